"""Ground-truth files read safely: VPR-Bench's pickled rows through an unpickler that builds arrays, lists, tuples and
numbers only (a pickle that would run a command runs nothing and is named), Python 2's pickles of it, and every
error naming the file, what was found and the fix."""

import pickle

import numpy as np
import pytest
from field_files import write_json_lists, write_vpr_bench

from vpr_smr.core.pickles import ALLOWED
from vpr_smr.eval.matching.ground_truth_files import read_ground_truth
from vpr_smr.pipeline.cli import main as cli

LISTS = {0: [0, 1], 1: [1], 2: [1, 2, 3], 3: []}


def cells(truth):
    return truth.correct(np.arange(truth.shape[0])[:, None], np.arange(truth.shape[1])[None, :])


def expected(shape=(4, 4)):
    out = np.zeros(shape, dtype=bool)
    for query, references in LISTS.items():
        out[references, query] = True
    return out


class RunsACommand:
    """What a malicious ground_truth_new.npy holds: unpickling it calls os.system."""

    def __init__(self, sentinel):
        self.sentinel = sentinel

    def __reduce__(self):
        import os

        return os.system, (f"touch {self.sentinel}",)


def test_a_pickle_that_would_run_a_command_runs_nothing(tmp_path, capsys):
    sentinel = tmp_path / "sentinel"
    rows = np.empty((2, 2), dtype=object)
    rows[0] = [0, [0]]
    rows[1] = [1, RunsACommand(sentinel)]
    np.save(tmp_path / "ground_truth_new.npy", rows, allow_pickle=True)
    with pytest.raises(ValueError) as error:
        read_ground_truth(tmp_path / "ground_truth_new.npy")
    message = str(error.value)
    assert "ground_truth_new.npy: its pickle names posix.system, which vpr-smr refuses to build" in message
    assert "nothing of this file was run" in message and "allow_pickle" not in message
    assert not sentinel.exists()
    # the same through the command
    np.save(tmp_path / "D.npy", np.ones((2, 2)))
    assert cli(["metrics", "--distances", str(tmp_path / "D.npy"), "--seq-len", "1", "--ground-truth",
                str(tmp_path / "ground_truth_new.npy"), "--out", str(tmp_path / "m.json")]) == 2
    err = capsys.readouterr().err
    assert "posix.system" in err and "allow_pickle" not in err and "Traceback" not in err
    assert not sentinel.exists() and not (tmp_path / "m.json").exists()


def test_other_classes_are_refused_by_name(tmp_path):
    rows = np.empty((1, 2), dtype=object)
    rows[0] = [0, {1, 2}]  # a set is built by opcodes: refused when its structure is checked
    np.save(tmp_path / "set.npy", rows, allow_pickle=True)
    with pytest.raises(ValueError, match=r"row 0 \(query 0\): the references is \{1, 2\}, not a frame index"):
        read_ground_truth(tmp_path / "set.npy")
    # a pickle naming a builtin function: the header of an object array, then GLOBAL builtins.eval
    header = np.lib.format.header_data_from_array_1_0(np.empty((1, 2), dtype=object))
    with open(tmp_path / "eval.npy", "wb") as handle:
        np.lib.format.write_array_header_1_0(handle, header)
        handle.write(b"cbuiltins\neval\n(S'1'\ntR.")
    with pytest.raises(ValueError, match="its pickle names builtins.eval, which vpr-smr refuses to build"):
        read_ground_truth(tmp_path / "eval.npy")
    # _codecs.encode makes the bytes of an array's data from latin-1 text, nothing else
    payload = b"c_codecs\nencode\n(S'x'\nS'rot13'\ntR."
    with open(tmp_path / "codec.npy", "wb") as handle:
        np.lib.format.write_array_header_1_0(handle, header)
        handle.write(payload)
    with pytest.raises(ValueError, match=r"its pickle names _codecs.encode of str as 'rot13'"):
        read_ground_truth(tmp_path / "codec.npy")
    assert {module for module, _ in ALLOWED} == {"numpy", "numpy.core.multiarray", "numpy._core.multiarray",
                                                 "numpy.core.numeric", "numpy._core.numeric", "_codecs", "builtins",
                                                 "__builtin__"}


def test_vpr_bench_files_of_python_3_and_python_2(tmp_path):
    path = write_vpr_bench(tmp_path / "ground_truth_new.npy", LISTS)
    assert np.array_equal(cells(read_ground_truth(path, shape=(4, 4))), expected())
    # rows of NumPy integers and arrays, floats that are integers, a range, and a single reference
    rows = np.empty((4, 2), dtype=object)
    rows[0] = [np.int64(0), np.array([0, 1])]
    rows[1] = [1.0, 1]
    rows[2] = [2, range(1, 4)]
    rows[3] = [3, ()]
    np.save(tmp_path / "mixed.npy", rows, allow_pickle=True)
    assert np.array_equal(cells(read_ground_truth(tmp_path / "mixed.npy", shape=(4, 4))), expected())
    # NumPy 1 names numpy.core.multiarray; pickle protocol 2 (VPR-Bench's helper downgrades its files to it) writes
    # the names as text and an array's data through _codecs.encode(..., "latin1")
    payload = pickle.dumps(rows[:2].copy(), protocol=2).replace(b"numpy._core.multiarray", b"numpy.core.multiarray")
    assert b"numpy.core.multiarray" in payload and b"_codecs\nencode" in payload
    header = np.lib.format.header_data_from_array_1_0(rows[:2])
    with open(tmp_path / "old.npy", "wb") as handle:
        np.lib.format.write_array_header_1_0(handle, header)
        handle.write(payload)
    assert np.array_equal(cells(read_ground_truth(tmp_path / "old.npy", shape=(4, 2))), expected()[:, :2])


@pytest.mark.parametrize(("name", "write", "message"), [
    ("empty.npy", lambda p: p.write_bytes(b""), r"empty.npy is empty \(0 bytes\)"),
    ("empty.json", lambda p: p.write_text(""), r"empty.json is empty \(0 bytes\)"),
    ("nothing.json", lambda p: p.write_text("{}"), "nothing.json names no correct pair"),
    ("list.json", lambda p: p.write_text("[[0, 1]]"), "holds a JSON list, not an object of per-query lists"),
    ("twice.json", lambda p: p.write_text('{"1": [1], "1": [2]}'), "query '1' is given twice"),
    ("word.json", lambda p: p.write_text('{"first": [1]}'), "its key 'first' is not a query index"),
    ("negative.json", lambda p: p.write_text('{"1": [-1]}'), r"query '1''s references, item 0 is -1, not a frame"),
    ("half.json", lambda p: p.write_text('{"1": [1.5]}'), "is 1.5, not a frame index"),
    ("noheader.csv", lambda p: p.write_text("0,1\n1,2\n"), "its first line is '0,1', not the header query,reference"),
    ("three.csv", lambda p: p.write_text("query,reference\n0,1,2\n"), "line 2: '0,1,2' is not a pair"),
    ("nan.npy", lambda p: np.save(p, np.array([[0.0, np.nan], [1.0, 0.0]])),
     r"holds booleans \(or 0 and 1\), but it holds nan at row 0 \(reference\), column 1 \(query\)"),
    ("two.npy", lambda p: np.save(p, np.array([[0, 2], [1, 0]])), "but it holds 2 at row 0"),
    ("flat.npy", lambda p: np.save(p, np.ones(4, dtype=bool)), r"is 2-D \(references x queries\), got shape \(4,\)"),
    ("none.npy", lambda p: np.save(p, np.ones((0, 3), dtype=bool)), "is 0 x 3: it holds no values"),
    ("text.npy", lambda p: p.write_text("1,0\n0,1\n"), "text.npy is text"),
    ("gt.txt", lambda p: p.write_text("1 0"), "gt.txt: a ground truth is a boolean R x Q matrix"),
])
def test_bad_files_are_named(tmp_path, name, write, message):
    path = tmp_path / name
    write(path)
    with pytest.raises(ValueError, match=message) as error:
        read_ground_truth(path)
    assert name in str(error.value) and "allow_pickle" not in str(error.value)


def test_shapes_and_indices_are_checked_against_the_matrix(tmp_path, capsys):
    np.save(tmp_path / "g.npy", expected())
    with pytest.raises(ValueError, match=r"g.npy: distance matrix of shape 4x5 but the ground truth g.npy \(a matrix\) "
                                         r"is 4x4 \(references x queries\): give the ground truth of the matrix"):
        read_ground_truth(tmp_path / "g.npy", shape=(4, 5))
    np.save(tmp_path / "wide.npy", np.zeros((3, 5), dtype=bool))
    with pytest.raises(ValueError, match="the two are transposed: give the matrix with --transpose"):
        read_ground_truth(tmp_path / "wide.npy", shape=(5, 3))
    path = write_json_lists(tmp_path / "gt.json", {0: [0], 1: [9]})
    with pytest.raises(ValueError, match=r"gt.json names reference 9 \(the pair query 1, reference 9\), but the "
                                         r"matrix has 4 references \(0..3\)"):
        read_ground_truth(path, shape=(4, 4))
    # through a command: a lists file that names frames past the matrix
    np.save(tmp_path / "D.npy", np.ones((4, 4)))
    assert cli(["metrics", "--distances", str(tmp_path / "D.npy"), "--seq-len", "2", "--ground-truth", str(path),
                "--out", str(tmp_path / "m.json")]) == 2
    err = capsys.readouterr().err
    # bounded by the matrix's header before the lists are built: the first index past it is named
    assert "gt.json names reference 9 (the pair query 1, reference 9), but the matrix has 4 references (0..3)" in err
    # and a matrix of another shape
    assert cli(["metrics", "--distances", str(tmp_path / "D.npy"), "--seq-len", "2", "--ground-truth",
                str(tmp_path / "wide.npy"), "--out", str(tmp_path / "m.json")]) == 2
    err = capsys.readouterr().err
    assert "D.npy: distance matrix of shape 4x4 but the ground truth wide.npy (a matrix) is 3x5" in err


def test_variables_are_chosen_by_name(tmp_path):
    np.savez(tmp_path / "GT.npz", GThard=expected(), GTsoft=np.ones((4, 4), dtype=bool))
    with pytest.raises(ValueError, match=r"GT.npz holds 2 2-D arrays of numbers \(GThard \(4 x 4 bool\), GTsoft "
                                         r"\(4 x 4 bool\)\): choose a boolean ground-truth matrix .* with "
                                         "--ground-truth-key NAME"):
        read_ground_truth(tmp_path / "GT.npz")
    with pytest.raises(ValueError, match="GT.npz has no variable 'GT'; it holds GThard"):
        read_ground_truth(tmp_path / "GT.npz", "GT")
    assert np.array_equal(cells(read_ground_truth(tmp_path / "GT.npz", "GThard")), expected())
    write_json_lists(tmp_path / "gt.json", LISTS)
    with pytest.raises(ValueError, match="--ground-truth-key GThard: .*gt.json holds per-query lists"):
        read_ground_truth(tmp_path / "gt.json", "GThard")
    with pytest.raises(FileNotFoundError, match="ground truth not found: .*nowhere.npy"):
        read_ground_truth(tmp_path / "nowhere.npy")
