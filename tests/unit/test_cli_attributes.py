"""`vpr-smr attributes` on a user's own distance matrix (.npy -> .csv)."""

import csv
import subprocess
import sys

import numpy as np
import pytest

from vpr_smr.core.constants import EPS
from vpr_smr.pipeline.cli import main

D = np.array([[1, 2, 4], [2, 1, 2], [4, 4, 1], [4, 2, 2]], dtype=float)


def test_csv_by_hand(tmp_path):
    np.save(tmp_path / "D.npy", D)
    # D has 4 references and 3 queries, frame i of both one place: positions are the frame indices, radius 2 frames
    np.save(tmp_path / "ref.npy", np.arange(4.0))
    np.save(tmp_path / "qry.npy", np.arange(3.0))
    assert main(["attributes", "--distances", str(tmp_path / "D.npy"), "--seq-len", "2", "--reference-positions",
                 str(tmp_path / "ref.npy"), "--query-positions", str(tmp_path / "qry.npy"), "--radius", "2",
                 "--out", str(tmp_path / "a.csv")]) == 0
    rows = list(csv.DictReader(open(tmp_path / "a.csv")))
    assert list(rows[0]) == ["query", "A1", "A2", "A3", "A4", "label"]
    assert [r["query"] for r in rows] == ["1", "2"]  # query 0 has no sequence match for L = 2
    # rank-0 attributes of query 1, worked by hand in test_attributes.py
    expected = [.25 / (.25 + EPS), .25 / (.25 + EPS), .25 / (1 + EPS), .25 / (3.5 / 3 + EPS)]
    np.testing.assert_allclose([float(rows[0][k]) for k in ("A1", "A2", "A3", "A4")], expected, rtol=1e-8)
    # query 1: single-frame 1, sequence 1 -> label 0; query 2: single 2, sequence 2 -> label 0 (tolerance 2)
    assert [r["label"] for r in rows] == ["0", "0"]


@pytest.mark.parametrize("array, message", [
    (np.zeros((4, 4, 2)), "2-D"),
    (np.full((4, 4), np.inf), "non-finite"),
    (np.zeros((3, 3)), "too small for sequence length 4"),
    (np.array(["a", "b"]), "numeric"),
])
def test_bad_matrices_give_clear_errors(tmp_path, capsys, array, message):
    np.save(tmp_path / "D.npy", array)
    out = tmp_path / "a.csv"
    assert main(["attributes", "--distances", str(tmp_path / "D.npy"), "--seq-len", "4", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err and "D.npy" in err
    assert not out.exists() and not list(tmp_path.glob("*.tmp"))


def test_missing_file(tmp_path, capsys):
    assert main(["attributes", "--distances", str(tmp_path / "nope.npy"), "--seq-len", "4",
                 "--out", str(tmp_path / "a.csv")]) == 2
    assert "distance matrix not found" in capsys.readouterr().err


def test_the_attributes_stage_leaves_unneeded_modules_out(tmp_path):
    """`vpr-smr attributes` takes no configuration file, asks np.unique nothing and compares no matchers: PyYAML,
    numpy.ma (which np.unique imports on first use) and the matchers experiment's module cost its fresh process
    10-40 ms of imports each (issue 34)."""
    matrix = tmp_path / "D.npy"
    np.save(matrix, np.random.default_rng(0).random((40, 40), dtype=np.float32))
    code = ("import sys\nfrom vpr_smr.pipeline import cli\n"
            f"cli.main(['attributes', '--distances', {str(matrix)!r}, '--seq-len', '4', '--out', "
            f"{str(tmp_path / 'a.h5')!r}])\n"
            "print(' '.join(m for m in ('yaml', 'numpy.ma', 'vpr_smr.eval.scoring.matcher_comparison', 'cv2') "
            "if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    assert out.stdout.strip() == ""
    assert (tmp_path / "a.h5").is_file()


@pytest.mark.parametrize("module", ["vpr_smr.pipeline", "vpr_smr.pipeline.cli"])
def test_the_program_exits_with_the_stages_status(tmp_path, module):
    """`python -m` runs the program's entry point (`cli.run`, which freezes the collector before the exit): a stage's
    error is status 2 with its message, and a stage that succeeds writes its file and exits 0."""
    missing = tmp_path / "missing.npy"
    failed = subprocess.run([sys.executable, "-m", module, "attributes", "--distances", str(missing), "--seq-len", "4",
                             "--out", str(tmp_path / "a.h5")], capture_output=True, text=True, timeout=120)
    assert failed.returncode == 2
    assert f"distance matrix not found: {missing}" in failed.stderr
    matrix = tmp_path / "D.npy"
    np.save(matrix, np.random.default_rng(0).random((30, 30), dtype=np.float32))
    done = subprocess.run([sys.executable, "-m", module, "attributes", "--distances", str(matrix), "--seq-len", "4",
                           "--out", str(tmp_path / "a.h5")], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "a.h5").is_file()
