"""`vpr-smr run`: any output or data path, a compact progress view, Snakemake's own output in a log file.

The real workflow runs on a copy of 200 frames of the shipped sample in folders whose names hold spaces and a
non-ASCII letter: a run that succeeds, one whose descriptors job meets a corrupt image, one stopped by Ctrl-C.
"""

import os
import re
import signal
import subprocess
import sys
import time

import pytest
import yaml
from helpers import session_alive

from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT

FRAMES = sorted(p.name for p in (DEFAULT_ROOT / "summer").iterdir())[:200]
METHODS = ("sad", "hog")
SPLITS = ("train", "val", "test")


def config(output, root, methods=METHODS):
    return {
        "run": "r",
        "output": str(output),
        "seq_lens": [3],
        "seeds": 1,
        "experiments": {"trust_levels": False, "restoration": False, "attribute_ablation": False,
                        "leave_one_method_out": False, "speed": False, "matchers": False, "deployment": False},
        "datasets": {"d": {"loader": "folders", "reference": str(root / "ref"), "query": str(root / "qry"),
                           "frames": [20, 140], "splits": {"train": [0, 50], "val": [50, 80], "test": [80, 120]}}},
        "methods": {name: {"backend": name} for name in methods},
        "predictor": {"max_iter": 100},
    }


def copy_sample(root):
    for name, season in (("ref", "summer"), ("qry", "winter")):
        (root / name).mkdir(parents=True)
        for frame in FRAMES:
            (root / name / frame).write_bytes((DEFAULT_ROOT / season / frame).read_bytes())
    return root


def start(folder, conf, *extra):
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "c.yaml").write_text(yaml.safe_dump(conf, allow_unicode=True), encoding="utf-8")
    return subprocess.Popen([sys.executable, "-m", "vpr_smr.pipeline", "run", "c.yaml", *extra], cwd=folder,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, encoding="utf-8",
                            start_new_session=True)


def finish(process, timeout=600):
    out, err = process.communicate(timeout=timeout)
    return process.returncode, out, err


def files(folder):
    return {str(p.relative_to(folder)): p.stat().st_mtime_ns for p in folder.rglob("*")}


@pytest.fixture(scope="module")
def sample(tmp_path_factory):
    return copy_sample(tmp_path_factory.mktemp("data") / "data set ü")


@pytest.fixture(scope="module")
def good_run(tmp_path_factory, sample):
    folder = tmp_path_factory.mktemp("work") / "work folder"
    data_before = files(sample)
    status, out, err = finish(start(folder, config("out put ü", sample)))
    assert status == 0, out[-3000:] + err[-3000:]
    return folder, out, err, data_before


@pytest.mark.slow
def test_paths_with_spaces_and_non_ascii_letters(good_run, sample):
    folder, _, _, data_before = good_run
    run = folder / "out put ü" / "r"
    assert (run / "report.html").is_file() and (run / "tables" / "table1.csv").is_file()
    # nothing outside the run folder and Snakemake's own folder: no stray file cut from a path at its space
    assert sorted(p.name for p in folder.iterdir()) == [".snakemake", "c.yaml", "out put ü"]
    assert [p.name for p in (folder / "out put ü").iterdir()] == ["r"]
    assert files(sample) == data_before  # the dataset is only read


@pytest.mark.slow
def test_a_run_prints_a_compact_progress_view(good_run):
    folder, out, err, _ = good_run
    lines = out.splitlines()
    assert len(lines) < 40 and err == "", out + err
    # one line per finished job (stdout is not a terminal): 2 descriptors, 3 distances and 3 attributes per method,
    # one predictor, one evaluation, training-free baselines, VPR metrics, per-query CSV and match inspector per
    # method, the report; Snakemake's `all` counts as the 27th step
    expected = {f"descriptors d/{m}" for m in METHODS} | {f"distances d/{m}/{s}" for m in METHODS for s in SPLITS} \
        | {f"attributes d/{m}/L3/{s}" for m in METHODS for s in SPLITS} | {"train d/L3", "report"} \
        | {f"{rule} d/{m}/L3" for m in METHODS for rule in ("evaluate", "baselines", "vpr_metrics", "queries",
                                                                       "inspect")}
    done = [re.fullmatch(r"\[ ?(\d+)/27\] \d+:\d\d:\d\d done (\S+(?: \S+)?)(?:; running .*)?", line) for line in lines]
    done = [match for match in done if match]
    assert sorted(int(match[1]) for match in done) == list(range(1, 27))
    assert {match[2] for match in done} == expected
    assert "27 jobs to run" in lines and any(re.fullmatch(r"27 of 27 jobs done in \S+", line) for line in lines)
    run = os.path.join("out put ü", "r")
    assert f"tables:  {run}/tables" in lines and f"report:  {run}/report.html" in lines
    # Snakemake's whole output is in the log named at the start
    log = re.fullmatch(r"Snakemake's output: (.*)", lines[0])[1]
    assert log.startswith(f"{run}/logs/snakemake-") and log.endswith(".log")
    text = (folder / log).read_text(encoding="utf-8")
    assert "Building DAG of jobs..." in text and "27 of 27 steps (100%) done" in text
    assert len(re.findall(r"^Finished jobid: \d+ \(Rule: \w+\)$", text, flags=re.MULTILINE)) == 27


@pytest.mark.slow
def test_dry_run_counts_jobs_per_rule_and_verbose_lists_them(tmp_path, sample):
    conf = config(tmp_path / "results", sample, methods=("sad",))
    status, out, err = finish(start(tmp_path, conf, "-n"))
    assert status == 0, out + err
    rows = dict(re.findall(r"^(\w+) +(\d+)$", out, flags=re.MULTILINE))
    assert rows == {"descriptors": "1", "distances": "3", "attributes": "3", "train": "1", "evaluate": "1",
                    "vpr_metrics": "1", "queries": "1", "inspect": "1", "report": "1", "all": "1", "baselines": "1",
                    "total": "15"}
    assert len(out.splitlines()) < 20 and "rule descriptors:" not in out
    status, out, err = finish(start(tmp_path, conf, "-n", "--verbose"))
    assert status == 0 and len(re.findall(r"^rule distances:$", out, flags=re.MULTILINE)) == 3, out + err
    assert not (tmp_path / "results").exists()  # a dry run writes nothing, not even a log


@pytest.mark.slow
def test_a_failed_job_shows_its_log_and_error(tmp_path, sample):
    data = tmp_path / "bad data"
    copy_sample(data)
    broken = data / "qry" / FRAMES[49]  # frame 29 of the run's slice: only the descriptors job reads it
    broken.write_bytes(b"\x89PNG not really")
    output = tmp_path / "res ults ü"  # absolute this time
    status, out, err = finish(start(tmp_path / "work", config(output, data, methods=("sad",))))
    assert status != 0 and "Traceback" not in out + err
    assert re.search(r"^\[ ?0/15\] \S+ FAILED descriptors d/sad$", out, flags=re.MULTILINE), out
    log = output / "r" / "logs" / "descriptors" / "d" / "sad.log"
    lines = err.splitlines()
    assert lines[0] == "vpr-smr run: job failed: rule descriptors (dataset=d, method=sad)"
    assert lines[1] == f"  last lines of its log {log}:"
    assert f"  vpr-smr descriptors: error: cannot decode image {broken}" in err
    snakemake_log = re.fullmatch(r"vpr-smr run: Snakemake's full output: (.*)", lines[-1])[1]
    assert snakemake_log.startswith(str(output / "r" / "logs" / "snakemake-"))
    assert "Error in rule descriptors:" in open(snakemake_log, encoding="utf-8").read()
    assert "tables:" not in out


@pytest.mark.slow
def test_ctrl_c_stops_the_run_in_one_line(tmp_path, sample):
    output = tmp_path / "results"
    process = start(tmp_path, config(output, sample, methods=("sad",)))
    job_log = output / "r" / "logs" / "descriptors" / "d" / "sad.log"
    deadline = time.monotonic() + 120
    while not job_log.exists():  # a job runs
        assert process.poll() is None and time.monotonic() < deadline, process.communicate()
        time.sleep(0.02)
    time.sleep(0.5)
    os.killpg(process.pid, signal.SIGINT)  # what Ctrl-C in a terminal does
    status, out, err = finish(process, timeout=60)
    assert status != 0
    assert len(err.splitlines()) <= 2 and "Traceback" not in out + err, err
    assert err.startswith("vpr-smr run: interrupted"), err
    alive = session_alive(process.pid)
    assert alive == [], f"processes of the stopped run still alive 15 s after it stopped: {alive}"
    assert not list(output.rglob("*.tmp"))
