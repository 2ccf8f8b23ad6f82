"""`vpr-smr run`'s console: Snakemake's output parsed into jobs (on a fixed excerpt of it), a log read as a terminal
leaves it, and the running jobs' progress read from their logs (the real workflow: test_run_console_workflow.py)."""

import pytest

from vpr_smr.pipeline.console import SnakemakeOutput, readable_lines, stage_error

# Snakemake's own text (9.x): a job's description, two jobs finishing, a job failing with its log shown
# (show-failed-logs), in which a line looks like a job of Snakemake's.
SNAKEMAKE_TEXT = """\
Job stats:
job            count
-----------  -------
descriptors        1
distances          1
all                1
total              3

Select jobs to execute...
Execute 1 jobs...

[Mon Nov 23 13:32:34 2026]
localrule descriptors:
    output: out put ü/s/descriptors/d/sad.h5
    log: out put ü/s/logs/descriptors/d/sad.log
    jobid: 5
    reason: Missing output files: out put ü/s/descriptors/d/sad.h5
    wildcards: dataset=d, method=sad
    threads: 2
    resources: tmpdir=/tmp, gpu=1, extraction=
Select jobs to execute...
[Mon Nov 23 13:32:38 2026]
Finished jobid: 5 (Rule: descriptors)
1 of 3 steps (33%) done
Execute 1 jobs...

[Mon Nov 23 13:32:38 2026]
rule distances:
    input: out put ü/s/descriptors/d/sad.h5
    output: out put ü/s/distances/d/sad/test.h5
    log: out put ü/s/logs/distances/d/sad/test.log
    jobid: 7
    wildcards: dataset=d, method=sad, split=test
    resources: tmpdir=/tmp
[Mon Nov 23 13:32:44 2026]
Error in rule distances:
    message: None
    jobid: 7
    output: out put ü/s/distances/d/sad/test.h5
    log: out put ü/s/logs/distances/d/sad/test.log (check log file(s) for error details)
    shell:
        vpr-smr distances ...
        (command exited with non-zero exit code)
Logfile out put ü/s/logs/distances/d/sad/test.log:
======================
rule fake:
    jobid: 99
2 of 9 steps (22%) done
======================
Shutting down, this might take some time.
Exiting because a job execution failed. Look below for error messages
"""


def test_snakemake_output_is_parsed_into_jobs():
    parsed = SnakemakeOutput()
    events = [event for line in SNAKEMAKE_TEXT.splitlines(keepends=True) for event in parsed.feed(line)]
    events += parsed.flush()
    assert [(kind, job.rule, job.jobid) for kind, job in events] == [
        ("started", "descriptors", "5"), ("done", "descriptors", "5"), ("started", "distances", "7"),
        ("failed", "distances", "7")]
    assert (parsed.done, parsed.total) == (1, 3)  # the fake progress line inside the shown log is not read
    assert parsed.running == {} and set(parsed.jobs) == {"5", "7"}
    failed = parsed.failed[0]
    assert failed.label() == "distances d/sad/test"
    assert failed.fields["log"] == "out put ü/s/logs/distances/d/sad/test.log"  # the description's, whole
    assert events[0][1].wildcards() == [("dataset", "d"), ("method", "sad")]


def test_job_label_shows_the_sequence_length_as_in_file_names():
    parsed = SnakemakeOutput()
    text = "rule attributes:\n    jobid: 3\n    wildcards: dataset=d, method=sad, seq_len=4, split=val\n"
    for line in text.splitlines(keepends=True):
        parsed.feed(line)
    assert parsed.flush()[0][1].label() == "attributes d/sad/L4/val"


def test_a_log_reads_as_a_terminal_leaves_it():
    # tqdm redraws its bar with carriage returns and clears it at the end (leave=False)
    text = "\rsad d reference:   0%| | 0/2\rsad d reference:  50%|# | 1/2\r            \r\n\nloaded 12 frames\n"
    assert readable_lines(text) == ["sad d reference:  50%|# | 1/2", "loaded 12 frames"]
    lines = ["vpr-smr descriptors: error: first", "context", "vpr-smr ablation: error: cannot read x.h5", "end"]
    assert stage_error(lines) == "vpr-smr ablation: error: cannot read x.h5"
    assert stage_error(["error: no stage named"]) is None


# --- the running jobs' progress, read from their logs ------------------------------------------------------------

def running_jobs_text(efficientnet_log, hog_log):
    """Snakemake starting two descriptors jobs of a three-step run."""
    return f"""\
Job stats:
job            count
-----------  -------
descriptors        2
all                1
total              3

[Mon Nov 23 13:32:34 2026]
rule descriptors:
    output: out/descriptors/d/efficientnet.h5
    log: {efficientnet_log}
    jobid: 1
    wildcards: dataset=d, method=efficientnet
[Mon Nov 23 13:32:34 2026]
rule descriptors:
    output: out/descriptors/d/hog.h5
    log: {hog_log}
    jobid: 2
    wildcards: dataset=d, method=hog
"""


class FakeClock:
    def __init__(self, t=1000.0):
        self.t = t

    def __call__(self):
        return self.t


@pytest.fixture
def job_logs(tmp_path):
    efficientnet, hog = tmp_path / "logs" / "efficientnet.log", tmp_path / "logs" / "hog.log"
    efficientnet.parent.mkdir()
    # as tqdm writes into a file: each redraw after a carriage return, padded over a longer previous state
    efficientnet.write_text("2026-11-23 13:32:35 vpr_smr INFO: loading weights\n"
                            "\rreference: 0/3576 images (0 %) in 0.0 s"
                            "\rreference: 1200/3576 images (34 %) in 27.3 s"
                            "\rreference: 1450/3576 images (41 %) in 32.8 s", encoding="utf-8")
    hog.write_text("2026-11-23 13:32:35 vpr_smr INFO: starting\n", encoding="utf-8")  # no progress yet
    return efficientnet, hog


def counting_reads(monkeypatch):
    from vpr_smr.pipeline import console

    reads = []

    def read(path, *args):
        reads.append(path)
        return console_read(path, *args)

    console_read = console.read_progress
    monkeypatch.setattr(console, "read_progress", read)
    return reads


def test_not_a_terminal_gets_each_running_jobs_progress_every_interval(tmp_path, job_logs, monkeypatch):
    from io import StringIO

    from vpr_smr.pipeline.console import REPORT_EVERY_S, ProgressView

    assert REPORT_EVERY_S == 30
    efficientnet, hog = job_logs
    reads = counting_reads(monkeypatch)
    clock, out, err = FakeClock(), StringIO(), StringIO()
    view = ProgressView(tmp_path / "snakemake.log", out, err, tty=False, now=clock)
    for line in running_jobs_text(efficientnet, hog).splitlines(keepends=True):
        view.feed(line)
    view.idle()  # the jobs' descriptions end: they run from t = 1000
    start = len(out.getvalue().splitlines())
    for _ in range(149):  # idle every 0.2 s until just before the interval: nothing printed, no log read
        clock.t += 0.2
        view.idle()
    assert len(out.getvalue().splitlines()) == start and reads == []
    clock.t = 1030.0
    view.idle()
    # 1450 of 3576 images is 40.5 %; 1450 images in 32.8 s are 44.2 per second
    assert out.getvalue().splitlines()[start:] == [
        "[0/3] 0:00:30 running descriptors d/efficientnet: reference 1450/3576 images (41 %), 44.2 images/s",
        "[0/3] 0:00:30 running descriptors d/hog for 0:00:30"]
    assert len(reads) == 2
    # the query traverse starts; hog finishes
    with open(efficientnet, "a", encoding="utf-8") as f:
        f.write("\rreference: 3576/3576 images (100 %) in 80.9 s\r" + " " * 46 + "\r"
                "\rquery: 0/3576 images (0 %) in 0.0 s\rquery: 100/3576 images (3 %) in 2.5 s     ")
    for line in ["Finished jobid: 2 (Rule: descriptors)\n", "1 of 3 steps (33%) done\n"]:
        view.feed(line)
    clock.t = 1059.9
    view.idle()
    clock.t = 1060.0
    view.idle()
    assert out.getvalue().splitlines()[start + 2:] == [
        "[1/3] 0:00:30 done descriptors d/hog; running descriptors d/efficientnet",
        "[1/3] 0:01:00 running descriptors d/efficientnet: query 100/3576 images (3 %), 40.0 images/s"]


def test_a_slow_step_shows_seconds_each_and_a_job_without_log_its_time(tmp_path, monkeypatch):
    from io import StringIO

    from vpr_smr.pipeline.console import ProgressView

    log = tmp_path / "train.log"
    log.write_text("2026-11-23 13:32:35 vpr_smr INFO: training on 120 samples\n2/5 seeds (40 %) in 122.4 s\n")
    text = f"Job stats:\ntotal 2\nrule train:\n    log: {log}\n    jobid: 4\n    wildcards: dataset=d, seq_len=3\n" \
        "rule report:\n    jobid: 5\n"
    clock, out = FakeClock(), StringIO()
    view = ProgressView(tmp_path / "snakemake.log", out, StringIO(), tty=False, now=clock, report_s=5)
    for line in text.splitlines(keepends=True):
        view.feed(line)
    view.idle()
    clock.t += 5
    view.idle()
    # 2 seeds in 122.4 s: 61.2 s each
    assert out.getvalue().splitlines()[-2:] == ["[0/2] 0:00:05 running train d/L3: 2/5 seeds (40 %), 61.2 s each",
                                                "[0/2] 0:00:05 running report for 0:00:05"]


def test_a_terminal_shows_each_running_jobs_fraction_read_at_most_once_a_second(tmp_path, job_logs, monkeypatch):
    from io import StringIO

    from vpr_smr.pipeline.console import ProgressView

    monkeypatch.setenv("COLUMNS", "200")
    efficientnet, hog = job_logs
    reads = counting_reads(monkeypatch)
    clock, out = FakeClock(), StringIO()
    view = ProgressView(tmp_path / "snakemake.log", out, StringIO(), tty=True, now=clock)
    for line in running_jobs_text(efficientnet, hog).splitlines(keepends=True):
        view.feed(line)

    def drawn():
        return out.getvalue().rsplit("\r\x1b[K", 1)[-1]

    view.idle()
    assert drawn() == "[0/3] 0:00:00 running descriptors d/efficientnet reference 41 %, descriptors d/hog"
    with open(efficientnet, "a", encoding="utf-8") as f:
        f.write("\rreference: 2000/3576 images (56 %) in 45.0 s")
    hog.write_text("\rreference: 3/4 images (75 %) in 0.1 s")
    for _ in range(4):  # 0.8 s: the logs are not read again
        clock.t += 0.2
        view.idle()
    assert drawn().endswith("reference 41 %, descriptors d/hog") and len(reads) == 2
    clock.t = 1001.0
    view.idle()
    # 2000 of 3576 is 55.9 %
    assert drawn() == ("[0/3] 0:00:01 running descriptors d/efficientnet reference 56 %, "
                       "descriptors d/hog reference 75 %")
    assert len(reads) == 4


@pytest.mark.parametrize("tty", [False, True])
def test_the_warnings_a_finished_job_logged_stay_on_the_console(tmp_path, job_logs, tty):
    from io import StringIO

    from vpr_smr.pipeline.console import ProgressView

    efficientnet, hog = job_logs
    # as pipeline/cli.py's logging writes them; a Python warning of a library is not ours and is left out
    with open(hog, "a", encoding="utf-8") as f:
        f.write("2026-11-23 13:33:01,122 vpr_smr WARNING: D.npy looks like a similarity matrix\n"
                "/x/sklearn/_mlp.py:785: ConvergenceWarning: Maximum iterations reached\n"
                "2026-11-23 13:33:02,004 vpr_smr.eval INFO: wrote h.h5\n")
    out = StringIO()
    view = ProgressView(tmp_path / "snakemake.log", out, StringIO(), tty=tty, now=FakeClock())
    for line in [*running_jobs_text(efficientnet, hog).splitlines(keepends=True),
                 "Finished jobid: 2 (Rule: descriptors)\n", "1 of 3 steps (33%) done\n"]:
        view.feed(line)
    lines = [line.rsplit("\r\x1b[K", 1)[-1] for line in out.getvalue().split("\n")]  # a terminal: the last state
    assert "[1/3] 0:00:00 WARNING descriptors d/hog: D.npy looks like a similarity matrix" in lines
    assert sum("WARNING" in line for line in lines) == 1
