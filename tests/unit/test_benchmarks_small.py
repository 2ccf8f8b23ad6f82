"""Every benchmark runs at a tiny size (``--small``) and prints its ratio line, so the benchmarks keep working."""

import subprocess
import sys

import pytest
from helpers import REPO

BENCHMARKS = REPO / "benchmarks"


@pytest.mark.parametrize("script, ratio_lines", [
    ("attributes.py", ("ratio (a) attributes / load+sum:", "ratio (b) peak / matrix:", "ratio (d) L=10 / L=2")),
    ("live.py", ("ratio live per frame / batch per query:",)),
    ("nordland_scale.py", ("ratio peak / 8 GB:",)),
    ("candidates.py", ("400 x 400, numpy in process, per query", "vpr-smr attributes (default path)")),
    ("matchers.py", ("seqslam ", "ratio time / seqslam:")),
])
def test_benchmark_runs_small(script, ratio_lines):
    done = subprocess.run([sys.executable, str(BENCHMARKS / script), "--small"], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    for line in ratio_lines:
        assert line in done.stdout, done.stdout


def test_attributes_benchmark_names_a_wrong_authors_code_folder(tmp_path):
    done = subprocess.run([sys.executable, str(BENCHMARKS / "attributes.py"), "--small", "--authors-code",
                           str(tmp_path)], capture_output=True, text=True, timeout=60)
    assert done.returncode != 0
    assert f"--authors-code {tmp_path}: no tools/mlp_classifier.py there" in done.stderr


def test_attributes_benchmark_ratio_only():
    done = subprocess.run([sys.executable, str(BENCHMARKS / "attributes.py"), "--small", "--ratio-only"],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "ratio (a) attributes / load+sum:" in done.stdout and "ratio (b)" not in done.stdout


# Three jobs of a 2-core run, as Snakemake 9 logs them: a (2 threads) 10:00:00-10:00:04; b 10:00:04-10:00:07 and
# c 10:00:04-10:00:05 side by side. By hand: wall 7 s; jobs a 4, b 3, c 1 s; busy cores 2+2+2+2 (a) + 2 (b and c at
# second 4) + 1 + 1 (b alone) = 12 of 14 core-seconds.
SNAKEMAKE_LOG = """Job stats:
[Fri Nov 27 10:00:00 2026]
localrule a:
    output: x
    jobid: 3
    threads: 2
Select jobs to execute...
[Fri Nov 27 10:00:04 2026]
Finished jobid: 3 (Rule: a)
[Fri Nov 27 10:00:04 2026]
localrule b:
    output: y
    jobid: 1
[Fri Nov 27 10:00:04 2026]
localrule c:
    output: z
    jobid: 2
[Fri Nov 27 10:00:05 2026]
Finished jobid: 2 (Rule: c)
[Fri Nov 27 10:00:07 2026]
Finished jobid: 1 (Rule: b)
"""


def test_demo_jobs_sums_a_log_by_hand(tmp_path):
    log = tmp_path / "snakemake-1.log"
    log.write_text(SNAKEMAKE_LOG)
    done = subprocess.run([sys.executable, str(BENCHMARKS / "demo_jobs.py"), str(log)], capture_output=True,
                          text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert [line.split()[:4] for line in lines[1:4]] == [["a", "1", "4", "/"], ["b", "1", "3", "/"],
                                                          ["c", "1", "1", "/"]]
    assert lines[-1].endswith("3 jobs, wall 7 s, job time 8 s, cores busy 12 of 14 core-seconds")
