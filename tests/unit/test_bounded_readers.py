"""Readers with bounds (method §13.2): a ground-truth file that declares or implies more than the matrix it scores can
hold (or, where that is not known, more than MAX_TRUTH_CELLS cells) is refused before anything of that size is built,
naming the file and the limit; a pickle cannot build more than a few bytes per byte of its file."""

import io
import pickle
import subprocess
import sys
import zipfile

import h5py
import numpy as np
import pytest
import scipy.io
from field_files import save_rows, write_json_lists

import vpr_smr.eval.matching.ground_truth_files as ground_truth_files
from vpr_smr.core.pickles import ArraysOnlyUnpickler, PickleTooLarge
from vpr_smr.eval.matching.ground_truth import MatrixTruth
from vpr_smr.eval.matching.ground_truth_files import read_ground_truth

_reconstruct = np.empty(0).__reduce__()[0]


def test_a_range_of_a_trillion_references_is_refused_at_once_in_little_memory(tmp_path):
    path = save_rows(tmp_path / "ground_truth_new.npy", [[0, range(0, 10**12)], [1, [1, 2]]])
    assert path.stat().st_size < 2048
    save_rows(tmp_path / "long.npy", [[0, range(0, 3 * 10**7)], [1, [1, 2]]])
    script = f"""
import resource
from vpr_smr.eval.matching.ground_truth_files import read_ground_truth
for shape in (None, (100, 50)):
    try:
        read_ground_truth({str(path)!r}, shape=shape)
    except ValueError as error:
        print(error)
truth = read_ground_truth({str(tmp_path / "long.npy")!r})  # 3e7 references of one query: a range, never expanded
print(truth.shape, int(truth.correct_references(0).sum()), int(truth.correct_references(1).sum()))
try:
    read_ground_truth({str(tmp_path / "long.npy")!r}, shape=(100, 50))
except ValueError as error:
    print(error)
print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024)
"""
    # through sh, which forks the interpreter: a process forked from pytest itself would count pytest's own pages in
    # its peak (getrusage's ru_maxrss survives exec)
    run = subprocess.run(["/bin/sh", "-c", '"$0" -c "$1"; exit $?', sys.executable, script], capture_output=True,
                         text=True, timeout=120, check=True)
    lines = run.stdout.splitlines()
    assert lines[0] == (f"{path}: row 0 (query 0): the references (range(0, 1000000000000)) number 1000000000000, "
                        "more than the 8589934592 cells (references x queries) vpr-smr reads from a ground truth "
                        "when the matrix it scores is not known: a query's list names each correct reference once; "
                        "give the ground truth of the distance matrices' frames (indices from 0)")
    assert "the references (range(0, 1000000000000)) number 1000000000000, more than the matrix has 100 " \
           "references (0..99)" in lines[1]
    assert lines[2] == "(30000000, 2) 30000000 2"
    assert "long.npy: row 0 (query 0): the references (range(0, 30000000)) number 30000000, more than the matrix " \
           "has 100 references (0..99)" in lines[3]
    assert int(lines[4]) < 400, f"peak resident memory {lines[4]} MB"


def test_pickled_lists_that_cannot_be_the_matrix_s_are_refused_before_unpickling(tmp_path, monkeypatch):
    def never(*args, **kwargs):
        raise AssertionError("the pickle was read")

    monkeypatch.setattr(ground_truth_files, "load_object_npy", never)
    rows = save_rows(tmp_path / "rows.npy", [[q, [0]] for q in range(10)])
    with pytest.raises(ValueError, match=r"rows.npy: its header says 10 rows, but the matrix has 4 queries \(0..3\): "
                                         "one row per query"):
        read_ground_truth(rows, shape=(8, 4))
    # 2 rows whose pickle is larger than lists of a 4 x 4 matrix can be: 65536 + 4 * 1024 + 4 * 4 * 256 bytes
    big = save_rows(tmp_path / "big.npy", [[0, np.arange(20000)], [1, [1]]])
    size = big.stat().st_size
    assert size > 73728
    with pytest.raises(ValueError, match=rf"big.npy: it is {size} bytes, more than per-query lists of the 4 x 4 "
                                         r"matrix it scores can take \(73728 bytes"):
        read_ground_truth(big, shape=(4, 4))


def test_a_list_longer_than_the_matrix_s_references_is_refused(tmp_path):
    path = save_rows(tmp_path / "gt.npy", [[0, [0, 0, 1, 1, 2]], [1, [1]]])
    with pytest.raises(ValueError, match=r"gt.npy: row 0 \(query 0\): the references number 5, more than the matrix "
                                         r"has 4 references \(0..3\)"):
        read_ground_truth(path, shape=(4, 4))


class Reduces:
    """An object that pickles as ``function(*args)``, with ``state`` set by BUILD when given."""

    def __init__(self, function, args, state=None):
        self.reduced = (function, args) if state is None else (function, args, state)

    def __reduce__(self):
        return self.reduced


@pytest.mark.parametrize(("built", "what"), [
    (Reduces(list, (range(10**12),)), "a list of 1000000000000 items of 8000000000000 bytes"),
    (Reduces(tuple, (range(10**9),)), "a tuple of 1000000000 items of 8000000000 bytes"),
    (Reduces(np.ndarray, ((10**6, 10**6), "f8")), r"an array of shape \(1000000, 1000000\) of 8000000000000 bytes"),
    (Reduces(_reconstruct, (np.ndarray, (10**10,), "O")), r"an array of shape \(10000000000,\) of 80000000000 bytes"),
    (Reduces(_reconstruct, (np.ndarray, (0,), "b"), (1, (10**9,), np.dtype("O"), False, [])),
     r"an array of shape \(1000000000,\) of 8000000000 bytes"),
    # NumPy takes an array as a shape: it is counted as one, not let through
    (Reduces(np.ndarray, (np.array([3000, 3000]), np.dtype("O"))),
     r"an array of shape \(3000, 3000\) of 72000000 bytes"),
])
def test_a_pickle_asking_for_more_than_its_file_holds_is_refused_before_building(tmp_path, built, what):
    path = save_rows(tmp_path / "gt.npy", [[0, built]])
    limit = 8 * path.stat().st_size + 2**20  # BUILT_PER_BYTE bytes per byte, plus BUILT_SLACK
    with pytest.raises(ValueError, match=rf"gt.npy: its pickle would build {what}, beyond the {limit} bytes its file "
                                         r"can hold \(8 bytes per byte of the file, plus 1048576\): it is not a "
                                         "ground truth, and it was refused before being built"):
        read_ground_truth(path)


def test_an_array_whose_shape_is_not_whole_numbers_is_refused_not_built(tmp_path):
    path = save_rows(tmp_path / "gt.npy", [[0, Reduces(np.ndarray, ([3.5, "x"], np.dtype("O")))]])
    with pytest.raises(ValueError, match=r"gt.npy: its pickle names an array of shape list \[3.5, 'x'\] and dtype "
                                         r"object .*, which vpr-smr refuses to build"):
        read_ground_truth(path)


def test_the_unpickler_s_limit_counts_every_array_list_and_tuple(tmp_path):
    payload = pickle.dumps([np.arange(100, dtype=np.int64), Reduces(list, ((1, 2, 3),))], protocol=2)
    # 100 int64 (800 bytes, built by _reconstruct and __setstate__) and a list of 3 references (24 bytes): 824 bytes
    loaded = ArraysOnlyUnpickler(io.BytesIO(payload), limit=824).load()
    assert np.array_equal(loaded[0], np.arange(100)) and loaded[1] == [1, 2, 3]
    with pytest.raises(PickleTooLarge, match="would build a list of 3 items of 24 bytes, beyond the 823 bytes"):
        ArraysOnlyUnpickler(io.BytesIO(payload), limit=823).load()


def test_lists_beyond_the_matrix_or_the_cap_are_refused_before_the_matrix_is_built(tmp_path, monkeypatch):
    def never(*args, **kwargs):
        raise AssertionError("a matrix was built")

    monkeypatch.setattr(MatrixTruth, "of_rows", never)
    (tmp_path / "pairs.csv").write_text("query,reference\n0,1\n7,2\n0,3\n")
    with pytest.raises(ValueError, match=r"pairs.csv names query 7 \(the pair query 7, reference \[2\]\), but the "
                                         r"matrix has 5 queries \(0..4\): give the ground truth of the matrix's "
                                         "frames"):
        read_ground_truth(tmp_path / "pairs.csv", shape=(5, 5))
    # without the matrix's shape: 100001 x 100001 cells implied by two pairs is past MAX_TRUTH_CELLS (2**33)
    path = write_json_lists(tmp_path / "far.json", {0: [100000], 100000: [0]})
    with pytest.raises(ValueError, match=r"far.json names references up to 100000 and queries up to 100000 \(2 pairs "
                                         r"so far\), more than the 8589934592 cells \(references x queries\) vpr-smr "
                                         r"reads from a ground truth when the matrix it scores is not known \(1024 "
                                         "MiB as bits\\)"):
        read_ground_truth(path)
    (tmp_path / "far.csv").write_text("query,reference\n0,100000\n100000,0\n")
    with pytest.raises(ValueError, match="far.csv names references up to 100000 and queries up to 100000"):
        read_ground_truth(tmp_path / "far.csv")


def write_npy_header(path, shape, dtype=bool):
    """A .npy whose header declares ``shape`` and which holds no data (what a damaged or hostile file may be)."""
    with open(path, "wb") as handle:
        np.lib.format.write_array_header_1_0(handle, {"descr": np.dtype(dtype).str, "fortran_order": False,
                                                      "shape": shape})
    return path


def test_matrices_declaring_more_than_the_matrix_or_the_cap_are_refused_unread(tmp_path, monkeypatch):
    npy = write_npy_header(tmp_path / "huge.npy", (100000, 100000))
    with pytest.raises(ValueError, match=r"huge.npy: its matrix is 100000 x 100000 \(10000000000 cells, as the file "
                                         r"declares it\), more than the 8589934592 cells"):
        read_ground_truth(npy)
    with zipfile.ZipFile(tmp_path / "huge.npz", "w") as archive:
        archive.write(npy, "G.npy")
    with pytest.raises(ValueError, match=r"huge.npz: its matrix 'G' is 100000 x 100000 \(10000000000 cells"):
        read_ground_truth(tmp_path / "huge.npz")
    with h5py.File(tmp_path / "huge.mat", "w", userblock_size=512) as handle:  # chunked: nothing written
        handle.create_dataset("G", shape=(100000, 100000), dtype="u1", chunks=(1000, 1000))
        handle["G"].attrs["MATLAB_class"] = np.bytes_("logical")
    with open(tmp_path / "huge.mat", "r+b") as handle:
        handle.write(b"MATLAB 7.3 MAT-file".ljust(116) + b"\x00" * 8 + b"\x00\x02IM")
    with pytest.raises(ValueError, match=r"huge.mat: its matrix 'G' is 100000 x 100000 \(10000000000 cells"):
        read_ground_truth(tmp_path / "huge.mat")
    # with the matrix's shape known, a 6 x 6 matrix cannot be the ground truth of a 4 x 4 one: nothing is loaded
    matrix = np.eye(6, dtype=bool)
    np.save(tmp_path / "six.npy", matrix)
    np.savez(tmp_path / "six.npz", G=matrix)
    scipy.io.savemat(tmp_path / "six.mat", {"G": matrix})

    def never(*args, **kwargs):
        raise AssertionError("the matrix was loaded")

    monkeypatch.setattr(ground_truth_files, "open_array", never)
    for name, shown in (("six.npy", "matrix"), ("six.npz", "matrix 'G'"), ("six.mat", "matrix 'G'")):
        with pytest.raises(ValueError, match=rf"{name}: its {shown} is 6 x 6 \(36 cells, as the file declares it\), "
                                             r"more than the 4 x 4 matrix it scores: give the ground truth of the "
                                             r"matrix's frames \(references x queries\); nothing of it was read"):
            read_ground_truth(tmp_path / name, shape=(4, 4))


def test_a_pickle_repeating_one_list_for_many_queries_is_refused_by_its_size(tmp_path):
    shared = list(range(1000))  # one list object: the pickle's memo writes it once, then 2 bytes per repetition
    path = save_rows(tmp_path / "memo.npy", [[q, shared] for q in range(2000)])
    size = path.stat().st_size
    most = 8 * size + 2**20  # LISTED_PER_BYTE references per byte, plus LISTED_SLACK
    assert 2000 * 1000 > most
    for shape in (None, (1000, 2000)):
        with pytest.raises(ValueError, match=rf"memo.npy lists more than {most} references one by one, more than its "
                                             rf"{size} bytes hold \(8 per byte, plus 1048576\)"):
            read_ground_truth(path, shape=shape)
    # the same lists, each written out: read, every cell correct
    own = save_rows(tmp_path / "own.npy", [[q, list(range(1000))] for q in range(20)])
    assert int(read_ground_truth(own, shape=(1000, 20)).bits.sum()) == 20 * 1000 // 8 * 255


def test_ranges_and_lists_set_the_cells_they_name_in_chunks(tmp_path, monkeypatch):
    import vpr_smr.eval.matching.ground_truth as ground_truth

    monkeypatch.setattr(ground_truth, "PAIRS_CHUNK", 2)
    monkeypatch.setattr(ground_truth, "RANGE_CHUNK", 2)
    path = save_rows(tmp_path / "gt.npy", [[0, range(1, 8, 3)], [1, range(7, 0, -2)], [2, [0, 9, 9, 3]],
                                           [3, range(2, 19)], [4, np.array([5, 6], dtype=np.int32)]])
    truth = read_ground_truth(path, shape=(20, 6))
    correct = {0: [1, 4, 7], 1: [1, 3, 5, 7], 2: [0, 3, 9], 3: list(range(2, 19)), 4: [5, 6], 5: []}
    for query, references in correct.items():
        assert np.flatnonzero(truth.correct_references(query)).tolist() == references


def test_a_query_given_by_two_rows_is_named_by_its_first_two_rows(tmp_path):
    path = save_rows(tmp_path / "twice.npy", [[3, [0]], [1, [0]], [3, [1]], [1, [1]], [1, [2]]])
    with pytest.raises(ValueError, match="twice.npy: rows 0 and 2 both give query 3: give each query once"):
        read_ground_truth(path)
