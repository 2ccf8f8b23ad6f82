"""Matrix files bounded before anything of their size is allocated (issue 44, item 5): ``.npz`` members, MATLAB v5
and v7.3 variables and ``.npy`` headers against ``MAX_MATRIX_VALUES``, the bytes the file holds and what compressed
bytes may inflate to; a ground truth against the scored matrix's header, else against MAX_TRUTH_CELLS whatever its
compression ratio; truncated or foreign ``.h5`` files named
with what they should be. Each refusal names the file, what it declares and the limit; legitimate files still read
with exactly their values."""

import io
import json
import struct
import subprocess
import sys
import tracemalloc
import zipfile

import h5py
import numpy as np
import pytest
import scipy.io
from field_files import band, save_rows, write_mat73
from helpers import write_distance_matrix

import vpr_smr.core.arrays as arrays
from vpr_smr.core.io import open_h5
from vpr_smr.core.pickles import PickleTooLarge, load_object_npy
from vpr_smr.eval.matching.attributes import read_features
from vpr_smr.eval.matching.ground_truth import MAX_TRUTH_CELLS
from vpr_smr.eval.matching.ground_truth_files import read_ground_truth
from vpr_smr.eval.matching.io import open_distance_matrix, scored_shape
from vpr_smr.eval.predictor.estimator import SMRPredictor
from vpr_smr.pipeline.cli import main as cli


def npy_bytes(shape, dtype="<f8", data=b""):
    """A .npy header declaring ``shape`` of ``dtype``, followed by ``data`` (what a hostile file may be)."""
    buffer = io.BytesIO()
    np.lib.format.write_array_header_2_0(buffer, {"descr": dtype, "fortran_order": False, "shape": shape})
    return buffer.getvalue() + data


def test_an_npz_member_declaring_40_billion_values_is_refused_by_the_cap(tmp_path):
    with zipfile.ZipFile(tmp_path / "bomb.npz", "w") as archive:
        archive.writestr("D.npy", npy_bytes((200000, 200000), data=b"\0" * 1000))
    with pytest.raises(ValueError, match=r"bomb.npz: its array 'D' declares 200000 x 200000 float64 \(40000000000 "
                                         r"values, 320000000000 bytes\), more than the 4294967296 values vpr-smr "
                                         "reads from a matrix file"):
        with open_distance_matrix(tmp_path / "bomb.npz"):
            pass


def test_an_npz_member_holding_less_than_its_header_declares_is_refused(tmp_path):
    # 10 x 10 float64 declared (800 bytes), 80 bytes stored: the zip directory says what the member holds
    with zipfile.ZipFile(tmp_path / "short.npz", "w") as archive:
        archive.writestr("D.npy", npy_bytes((10, 10), data=b"\0" * 80))
    with pytest.raises(ValueError, match=r"short.npz: its array 'D' declares 10 x 10 float64 \(100 values, 800 "
                                         r"bytes\), but the file holds 80 bytes of it: the file is truncated"):
        with open_distance_matrix(tmp_path / "short.npz"):
            pass


def test_a_compressed_npz_inflating_past_its_ratio_is_refused_in_little_memory(tmp_path, monkeypatch):
    np.savez_compressed(tmp_path / "zeros.npz", D=np.zeros((1000, 1000)))  # 8 MB of zeros in a few kB
    with zipfile.ZipFile(tmp_path / "zeros.npz") as archive:
        compressed = archive.getinfo("D.npy").compress_size
    monkeypatch.setattr(arrays, "INFLATE_FREE", 1 << 20)
    most = max(1 << 20, 32 * compressed)
    assert most < 8_000_000
    tracemalloc.start()
    with pytest.raises(ValueError, match=rf"zeros.npz: its array 'D' declares 1000 x 1000 float64 \(1000000 values, "
                                         rf"8000000 bytes\) from {compressed} compressed bytes, more than they may "
                                         rf"inflate to in memory \({most} bytes: 32 times as many, at least 1048576\)"):
        with open_distance_matrix(tmp_path / "zeros.npz"):
            pass
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 1_000_000, f"{peak} bytes traced while refusing"


def test_npz_members_read_with_their_values_stored_ones_memory_mapped(tmp_path):
    rng = np.random.default_rng(7)
    matrix = rng.random((6, 5)).astype(np.float32)
    fortran = np.asfortranarray(rng.random((4, 3)))
    np.savez(tmp_path / "stored.npz", D=matrix, F=fortran)
    np.savez_compressed(tmp_path / "packed.npz", D=matrix)
    with open_distance_matrix(tmp_path / "stored.npz", key="D") as read:
        assert isinstance(read, np.memmap) and read.dtype == np.float32
        assert np.array_equal(np.asarray(read), matrix)
    with open_distance_matrix(tmp_path / "stored.npz", key="F") as read:
        assert np.array_equal(np.asarray(read), fortran)
    with open_distance_matrix(tmp_path / "packed.npz", transpose=True) as read:
        assert np.array_equal(np.asarray(read), matrix.T)


def mat5_declaring(path, n, data_too):
    """A MATLAB v5 file of a 3 x 3 double ``D`` whose header is patched to declare ``n x n`` (and, with
    ``data_too``, as many bytes of data): the file stays 256 bytes."""
    scipy.io.savemat(path, {"D": np.zeros((3, 3))}, do_compression=False)
    raw = bytearray(path.read_bytes())
    dims = raw.find(struct.pack("<IIii", 5, 8, 3, 3))  # miINT32, 8 bytes, the dimensions
    raw[dims + 8 : dims + 16] = struct.pack("<ii", n, n)
    if data_too:
        data = raw.find(struct.pack("<II", 9, 72))  # miDOUBLE, 72 bytes
        raw[data + 4 : data + 8] = struct.pack("<I", n * n * 8 % 2**32)
    path.write_bytes(bytes(raw))
    return path


def test_mat_v5_variables_declaring_more_than_the_file_or_the_cap_are_refused_before_loadmat(tmp_path, monkeypatch):
    def never(*args, **kwargs):
        raise AssertionError("loadmat was called")

    monkeypatch.setattr(scipy.io, "loadmat", never)
    for data_too in (False, True):
        path = mat5_declaring(tmp_path / f"d{data_too}.mat", 20000, data_too)
        with pytest.raises(ValueError, match=r"\.mat: its array 'D' declares 20000 x 20000 double \(400000000 values, "
                                             r"3200000000 bytes\), but the file holds 256 bytes of it"):
            with open_distance_matrix(path):
                pass
    path = mat5_declaring(tmp_path / "huge.mat", 200000, True)
    with pytest.raises(ValueError, match=r"huge.mat: its array 'D' declares 200000 x 200000 double \(40000000000 "
                                         r"values, 320000000000 bytes\), more than the 4294967296 values"):
        with open_distance_matrix(path):
            pass


def test_a_garbled_mat_v5_variable_is_named_not_could_not_read_bytes(tmp_path):
    path = tmp_path / "cut.mat"
    scipy.io.savemat(path, {"D": np.arange(12.0).reshape(3, 4)}, do_compression=False)
    raw = bytearray(path.read_bytes())
    # its 12 doubles' element declares 960 bytes: fewer than the file's, so only SciPy finds it short
    data = raw.find(struct.pack("<II", 9, 96))
    raw[data + 4 : data + 8] = struct.pack("<I", 960)
    path.write_bytes(bytes(raw))
    with pytest.raises(ValueError, match=r"cut.mat: its array 'D' declares 3 x 4 double \(12 values, 96 bytes\), but "
                                         r"it cannot be read \(.*\): the file is truncated or damaged"):
        with open_distance_matrix(path):
            pass


def test_mat_files_of_either_version_read_with_their_values(tmp_path):
    matrix = np.arange(20.0).reshape(4, 5)
    scipy.io.savemat(tmp_path / "v5.mat", {"D": matrix}, do_compression=True)
    write_mat73(tmp_path / "v73.mat", {"D": matrix})
    for name in ("v5.mat", "v73.mat"):
        with open_distance_matrix(tmp_path / name) as read:
            assert np.array_equal(np.asarray(read[:, :]), matrix)


def test_a_v73_variable_and_a_npy_past_the_cap_are_refused_unread(tmp_path, monkeypatch):
    with h5py.File(tmp_path / "huge.mat", "w", userblock_size=512) as handle:  # chunked: nothing written
        handle.create_dataset("D", shape=(200000, 200000), dtype="f8", chunks=(1000, 1000))
        handle["D"].attrs["MATLAB_class"] = np.bytes_("double")
    with open(tmp_path / "huge.mat", "r+b") as handle:
        handle.write(b"MATLAB 7.3 MAT-file".ljust(116) + b"\x00" * 8 + b"\x00\x02IM")
    with pytest.raises(ValueError, match=r"huge.mat: its array 'D' declares 200000 x 200000 double \(40000000000 "
                                         r"values, 320000000000 bytes\), more than the 4294967296 values"):
        with open_distance_matrix(tmp_path / "huge.mat"):
            pass
    np.save(tmp_path / "D.npy", np.ones((4, 4)))
    monkeypatch.setattr(arrays, "MAX_MATRIX_VALUES", 15)
    with pytest.raises(ValueError, match=r"D.npy: its array declares 4 x 4 float64 \(16 values, 128 bytes\), more "
                                         "than the 15 values"):
        with open_distance_matrix(tmp_path / "D.npy"):
            pass


def test_vpr_bench_s_long_range_beside_a_known_matrix_is_refused_by_it_in_little_memory(tmp_path):
    np.save(tmp_path / "D.npy", np.random.default_rng(1).random((357, 357)).astype(np.float32))
    save_rows(tmp_path / "gt.npy", [[q, range(0, 3 * 10**7) if q == 0 else [q]] for q in range(100)])
    script = f"""
import resource
from vpr_smr.pipeline.cli import main
print(main(["metrics", "--distances", {str(tmp_path / "D.npy")!r}, "--seq-len", "4", "--ground-truth",
            {str(tmp_path / "gt.npy")!r}, "--out", {str(tmp_path / "m.json")!r}]))
print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024)
"""
    # through sh, so that the peak is this process's alone (getrusage's ru_maxrss survives exec)
    run = subprocess.run(["/bin/sh", "-c", '"$0" -c "$1"; exit $?', sys.executable, script], capture_output=True,
                         text=True, timeout=120, check=True)
    code, peak = run.stdout.split()
    assert code == "2"
    assert (f"{tmp_path / 'gt.npy'}: row 0 (query 0): the references (range(0, 30000000)) number 30000000, more than "
            "the matrix has 357 references (0..356)") in run.stderr
    assert "not known" not in run.stderr
    assert int(peak) < 400, f"peak resident memory {peak} MB"
    assert not (tmp_path / "m.json").exists()


def test_a_pickle_is_bounded_by_the_limit_its_caller_knows(tmp_path):
    path = save_rows(tmp_path / "gt.npy", [[0, np.arange(50, dtype=np.int64)]])
    with pytest.raises(PickleTooLarge, match=r"would build an array of shape \(50,\) of 400 bytes, beyond the 300 "
                                             "bytes lists of a 2 x 2 matrix take"):
        load_object_npy(path, "rows", limit=(300, "lists of a 2 x 2 matrix take"))
    rows = load_object_npy(path, "rows", limit=(500, "lists of a 2 x 2 matrix take"))
    assert rows[0][0] == 0 and np.array_equal(rows[0][1], np.arange(50))


def test_the_scored_shape_comes_from_headers_alone(tmp_path):
    np.save(tmp_path / "a.npy", np.zeros((3, 7)))
    np.savez(tmp_path / "b.npz", M=np.zeros((5, 2)))
    scipy.io.savemat(tmp_path / "c.mat", {"D": np.zeros((4, 4))})
    assert scored_shape([tmp_path / "a.npy"]) == (3, 7)
    assert scored_shape([tmp_path / "a.npy"], transpose=True) == (7, 3)
    assert scored_shape([tmp_path / "a.npy", tmp_path / "b.npz", tmp_path / "c.mat"]) == (5, 7)
    with h5py.File(tmp_path / "split.h5", "w") as handle:  # a dataset's split: its ground truth may be the dataset's
        handle.create_dataset("distance_matrix", data=np.zeros((2, 2)))
        handle.attrs["split_range"] = "[10, 12]"
    assert scored_shape([tmp_path / "a.npy", tmp_path / "split.h5"]) is None
    (tmp_path / "bad.npy").write_text("1,2\n")
    assert scored_shape([tmp_path / "bad.npy"]) is None


@pytest.mark.parametrize("damage", ["truncated", "text"])
def test_truncated_or_foreign_h5_files_are_named_with_what_they_should_be(tmp_path, damage):
    path = tmp_path / "x.h5"
    if damage == "truncated":
        with h5py.File(tmp_path / "full.h5", "w") as handle:
            handle.create_dataset("x", data=np.arange(10000.0))
        path.write_bytes((tmp_path / "full.h5").read_bytes()[:20000])
        said = r"x.h5 is a damaged or truncated HDF5 file \(.*truncated file.*\): expected {}; write or copy it again"
    else:
        path.write_text("query,reference\n0,1\n")
        said = r"x.h5 is text \(it starts with 'query,reference'\), not an HDF5 file: expected {}$"
    for read, what in ((SMRPredictor.load, "a predictor written by vpr-smr train"),
                       (read_features, r"attributes written by vpr-smr attributes \(.h5\)")):
        with pytest.raises(ValueError, match=said.format(what)):
            read(path)
    with pytest.raises(ValueError, match=said.format("a MATLAB file")):
        with open_h5(path, "a MATLAB file"):
            pass


def test_the_bad_input_page_states_the_readers_limits_as_the_code_has_them():
    from pathlib import Path

    page = (Path(__file__).parents[2] / "docs" / "interruptions.md").read_text()
    assert arrays.MAX_MATRIX_VALUES == 2**32 and f"more than 2^32 ({2**32}) values" in page
    assert f"more than {arrays.INFLATE_RATIO} times its compressed bytes" in page
    assert f"(and more than {arrays.INFLATE_FREE >> 20} MiB)" in page
    assert MAX_TRUTH_CELLS == 2**33 and f"by 2^33 ({2**33}) cells" in page


def test_a_compressed_mat_v5_variable_inflating_past_its_ratio_is_refused_before_loadmat(tmp_path, monkeypatch):
    scipy.io.savemat(tmp_path / "zeros.mat", {"D": np.zeros((500, 500))}, do_compression=True)
    size = (tmp_path / "zeros.mat").stat().st_size
    monkeypatch.setattr(arrays, "INFLATE_FREE", 1 << 16)
    assert 500 * 500 * 8 > max(1 << 16, 32 * size)

    def never(*args, **kwargs):
        raise AssertionError("loadmat was called")

    monkeypatch.setattr(scipy.io, "loadmat", never)
    with pytest.raises(ValueError, match=rf"zeros.mat: its array 'D' declares 500 x 500 double \(250000 values, "
                                         rf"2000000 bytes\) from {size} compressed bytes, more than they may inflate"):
        with open_distance_matrix(tmp_path / "zeros.mat"):
            pass


def test_a_compressed_ground_truth_may_inflate_to_the_matrix_it_scores(tmp_path, monkeypatch):
    truth = np.abs(np.subtract.outer(np.arange(300), np.arange(300))) <= 2  # a band: 90 kB from about 1 kB
    np.savez_compressed(tmp_path / "G.npz", G=truth)
    monkeypatch.setattr(arrays, "INFLATE_FREE", 1 << 10)
    assert 300 * 300 > max(1 << 10, 32 * (tmp_path / "G.npz").stat().st_size)
    for within in ((300, 300), None):  # None: bounded by MAX_TRUTH_CELLS, not by its compression ratio
        read = read_ground_truth(tmp_path / "G.npz", within=within)
        assert all(np.array_equal(read.correct_references(q), truth[:, q]) for q in (0, 1, 150, 299))


# A compressed ground-truth matrix of a whole dataset, beside a distance file of one of its splits (whose header does
# not say the dataset's extent), is read up to MAX_TRUTH_CELLS cells whatever its compression ratio, as MATLAB's
# default save and numpy.savez_compressed write it; bombs are still refused unread, and the refusal of a compressed
# array says how to save it uncompressed in its own program's words.

FRAMES, LO, HI, L = 240, 90, 170, 3  # the dataset's frames, the split's, the sequence length
SMALL_FREE = 1 << 10  # INFLATE_FREE in these tests: the ground truths inflate past it


def inflates_past_the_cap(path):
    """Whether the compressed file's ground truth (FRAMES x FRAMES bools) is more than it may inflate to when
    nothing else is known."""
    return FRAMES * FRAMES > max(SMALL_FREE, arrays.INFLATE_RATIO * path.stat().st_size)


@pytest.fixture
def split_and_truths(tmp_path, monkeypatch):
    """A split's distance file (frames LO..HI-1 of FRAMES) and the dataset's band |r - q| <= 2 as a compressed
    .npz, a compressed MATLAB v5 .mat (MATLAB's default save) and a plain .npy."""
    monkeypatch.setattr(arrays, "INFLATE_FREE", SMALL_FREE)
    d = np.random.default_rng(44).random((FRAMES, FRAMES)).astype(np.float32)
    write_distance_matrix(tmp_path / "test.h5", d[LO:HI, LO:HI],
                          {"dataset": "own", "split": "test", "split_range": [LO, HI], "method": "sad"})
    truth = band(FRAMES, FRAMES, 2)
    np.savez_compressed(tmp_path / "G.npz", GThard=truth)
    scipy.io.savemat(tmp_path / "G.mat", {"GThard": truth}, do_compression=True)
    for name in ("G.npz", "G.mat"):
        assert inflates_past_the_cap(tmp_path / name)
    return tmp_path, truth


def test_a_split_s_compressed_dataset_ground_truth_is_read_by_metrics_and_attributes(split_and_truths):
    folder, _ = split_and_truths
    assert scored_shape([folder / "test.h5"]) is None  # the split's header does not bound its dataset's frames
    distances = ["--distances", str(folder / "test.h5"), "--seq-len", str(L)]
    # the band |r - q| <= 2 is the frame-aligned ground truth of tolerance 2, an independent way to the same numbers
    assert cli(["metrics", *distances, "--tolerance", "2", "--out", str(folder / "tolerance.json")]) == 0
    assert cli(["attributes", *distances, "--tolerance", "2", "--out", str(folder / "tolerance.h5")]) == 0
    expected = json.loads((folder / "tolerance.json").read_text())["splits"]
    features = read_features(folder / "tolerance.h5")
    assert features.sequence_correct.any() and not features.sequence_correct.all()
    for name in ("G.npz", "G.mat"):
        given = ["--ground-truth", str(folder / name)]
        assert cli(["metrics", *distances, *given, "--out", str(folder / f"{name}.json")]) == 0
        assert json.loads((folder / f"{name}.json").read_text())["splits"] == expected
        assert cli(["attributes", *distances, *given, "--out", str(folder / f"{name}.h5")]) == 0
        read = read_features(folder / f"{name}.h5")
        for field in ("labels", "single_correct", "sequence_correct", "rank_correct"):
            np.testing.assert_array_equal(getattr(read, field), getattr(features, field), err_msg=field)


def test_the_api_reads_a_compressed_ground_truth_without_its_shape(split_and_truths):
    folder, truth = split_and_truths
    for name in ("G.npz", "G.mat"):
        read = read_ground_truth(folder / name)
        assert read.shape == (FRAMES, FRAMES)
        for q in (0, 1, 120, FRAMES - 1):
            assert np.flatnonzero(read.correct_references(q)).tolist() == [r for r in range(q - 2, q + 3)
                                                                           if 0 <= r < FRAMES]


def test_ground_truth_bombs_are_still_refused_unread_without_the_shape(tmp_path, monkeypatch):
    # 200000 x 200000 cells declared in a 1 kB member: past MAX_TRUTH_CELLS, refused from its header
    with zipfile.ZipFile(tmp_path / "bomb.npz", "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("G.npy", npy_bytes((200000, 200000), dtype="|b1", data=b"\0" * 1000))
    assert 200000 * 200000 > MAX_TRUTH_CELLS
    with pytest.raises(ValueError, match=r"bomb.npz: its matrix 'G' is 200000 x 200000 \(40000000000 cells, as the "
                                         rf"file declares it\), more than the {MAX_TRUTH_CELLS} cells"):
        read_ground_truth(tmp_path / "bomb.npz")

    def never(*args, **kwargs):
        raise AssertionError("loadmat was called")

    # a 256-byte MATLAB v5 file declaring 20000 x 20000 doubles: within the cells, but not in the file
    path = mat5_declaring(tmp_path / "short.mat", 20000, True)
    monkeypatch.setattr(scipy.io, "loadmat", never)
    with pytest.raises(ValueError, match=r"short.mat: its array 'D' declares 20000 x 20000 double \(400000000 values, "
                                         r"3200000000 bytes\), but the file holds 256 bytes of it"):
        read_ground_truth(path)


def test_a_compressed_refusal_says_how_its_own_program_saves_uncompressed(tmp_path, monkeypatch):
    monkeypatch.setattr(arrays, "INFLATE_FREE", SMALL_FREE)
    scipy.io.savemat(tmp_path / "D.mat", {"D": np.zeros((100, 100))}, do_compression=True)
    np.savez_compressed(tmp_path / "D.npz", D=np.zeros((100, 100)))
    with pytest.raises(ValueError, match=r"D.mat: .* more than they may inflate to .*: save it uncompressed from "
                                         r"MATLAB \(save\(path, name, '-v7.3'\), read from disk as needed, or "
                                         r"save\(path, name, '-v7', '-nocompression'\)\)") as refused:
        with open_distance_matrix(tmp_path / "D.mat"):
            pass
    assert "numpy" not in str(refused.value)
    with pytest.raises(ValueError, match=r"D.npz: .* more than they may inflate to .*: save it uncompressed "
                                         r"\(numpy.save, or numpy.savez rather than savez_compressed") as refused:
        with open_distance_matrix(tmp_path / "D.npz"):
            pass
    assert "MATLAB" not in str(refused.value)
