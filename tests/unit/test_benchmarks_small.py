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
