"""Faults: killed runs resume to the same tables, SIGTERM stops the whole workflow, a run folder has one writer.

Run A goes through uninterrupted; run B, from scratch in another folder, is killed with SIGKILL to its whole
process group in the descriptors, attributes and training stages and started again with the same command each
time. Both must give byte-identical tables, evaluations, predictor reports and ablations, timings aside (which
also shows that a run is deterministic).
"""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from helpers import session_alive

from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT

pytestmark = pytest.mark.slow

CONFIG = {
    "run": "f",
    "output": "results",
    "seq_lens": [3],
    "seeds": 2,
    "trust_levels": [0.0, 0.5],
    "datasets": {"sample": {"loader": "nordland_sample", "root": str(DEFAULT_ROOT), "frames": [1500, 1620],
                            "splits": {"train": [0, 50], "val": [50, 80], "test": [80, 120]}}},
    "methods": {"sad": {"backend": "sad"}, "hog": {"backend": "hog"}},
    "predictor": {"max_iter": 200},
    "experiments": {"matchers": False},  # test_plugin_matcher_workflow.py runs it
}
# Outputs that hold timings (measured anew by every run) are not compared byte for byte; the evaluations keep
# theirs in a separate `.timing.json`.
TIMED = {"timing.csv", "timing.md", "timing.tex"}


def start(folder, *extra):
    (folder / "c.yaml").write_text(yaml.safe_dump(CONFIG))
    return subprocess.Popen([sys.executable, "-m", "vpr_smr.pipeline", "run", "c.yaml", *extra], cwd=folder,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True)


def wait_for(path, process, timeout=300):
    deadline = time.monotonic() + timeout
    while not path.exists():
        assert process.poll() is None, f"the run ended before {path} appeared:\n{process.stdout.read()[-3000:]}"
        assert time.monotonic() < deadline, f"{path} did not appear"
        time.sleep(0.02)


def outputs(folder):
    run = folder / "results" / "f"
    files = sorted([*run.glob("tables/*"), *run.glob("evaluation/**/*.json"), *run.glob("predictors/**/*.json"),
                    *run.glob("ablation/**/*.json")])
    return {str(p.relative_to(run)): p.read_bytes() for p in files if p.name not in TIMED
            and not p.name.endswith(".timing.json")}


def finish(folder):
    process = start(folder)
    out, _ = process.communicate(timeout=900)
    assert process.returncode == 0, out[-4000:]
    return out


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    folder = tmp_path_factory.mktemp("a")
    finish(folder)
    return outputs(folder)


def test_killed_runs_resume_to_identical_tables(uninterrupted, tmp_path):
    logs = tmp_path / "results" / "f" / "logs"
    for stage_log in ("descriptors/sample/hog.log", "attributes/sample/sad/L3/test.log", "predictors/sample/L3.log"):
        process = start(tmp_path)
        wait_for(logs / stage_log, process)
        os.killpg(process.pid, signal.SIGKILL)
        process.wait()
        finals = [p for p in (tmp_path / "results").rglob("*") if p.is_file() and p.suffix in (".h5", ".json")]
        for path in finals:  # whatever exists under a final name is complete: it opens
            if path.suffix == ".h5":
                import h5py

                with h5py.File(path, "r"):
                    pass
    out = finish(tmp_path)  # no --unlock: the killed runs left no lock in the way
    assert "unlock" not in out.lower()
    resumed = outputs(tmp_path)
    assert set(resumed) == set(uninterrupted)
    for name, content in uninterrupted.items():
        assert resumed[name] == content, f"{name} differs after resuming"


def test_sigterm_stops_the_whole_workflow(tmp_path):
    process = start(tmp_path)
    wait_for(tmp_path / "results" / "f" / "logs" / "descriptors", process)
    time.sleep(0.5)
    process.send_signal(signal.SIGTERM)  # to `vpr-smr run` only, not to its group
    process.wait(timeout=60)
    assert process.returncode != 0
    alive = session_alive(process.pid)
    assert alive == [], f"processes of the stopped run still alive 15 s after it stopped: {alive}"
    assert not list((tmp_path / "results").rglob("*.tmp"))


def test_a_second_run_of_the_same_folder_is_refused(tmp_path):
    first = start(tmp_path)
    lock = tmp_path / "results" / "f" / ".vpr-smr.lock"
    deadline = time.monotonic() + 120
    while not (lock.exists() and lock.read_text()):
        assert time.monotonic() < deadline and first.poll() is None
        time.sleep(0.05)
    second = start(tmp_path)
    out, _ = second.communicate(timeout=120)
    assert second.returncode != 0
    assert f"results/f is in use by process {first.pid}" in out, out
    out, _ = first.communicate(timeout=900)
    assert first.returncode == 0, out[-3000:]
    assert (tmp_path / "results" / "f" / "tables" / "table1.csv").is_file()


def test_dry_run_does_not_claim_results(tmp_path):
    process = start(tmp_path, "-n")
    out, _ = process.communicate(timeout=300)
    assert process.returncode == 0, out[-3000:]
    assert "tables:" not in out and "figures:" not in out
    assert not Path(tmp_path / "results" / "f" / "tables").exists()
