"""The compiled attributes path (eval.kernels, numba) against the numpy path and the naive per-query definition.

Every output must be bit-identical between the two paths (compared as raw bytes, so even the sign of a zero
counts), on random matrices, heavy ties (repeated rows and columns, constant and integer matrices), L = 2 and 10.
The first test compiles the kernels when numba's on-disk cache is cold (about 20 s once per checkout).
"""

import sys
from dataclasses import fields

import h5py
import numpy as np
import pytest

from vpr_smr.eval.matching import matcher
from vpr_smr.eval.matching.attributes import query_features
from vpr_smr.eval.matching.matcher import SequenceMatcher

pytest.importorskip("numba")

from oracles import naive_attributes, naive_sequence, tied_matrix  # noqa: E402


def features(matrix, seq_len, kernel, **kwargs):
    previous, matcher.KERNEL = matcher.KERNEL, kernel
    try:
        return query_features(matrix, seq_len, **kwargs)
    finally:
        matcher.KERNEL = previous


def assert_bit_identical(a, b):
    for field in fields(a):
        x, y = np.atleast_1d(getattr(a, field.name)), np.atleast_1d(getattr(b, field.name))
        assert x.dtype == y.dtype and x.shape == y.shape, field.name
        assert x.tobytes() == y.tobytes(), field.name


def matrices():
    rng = np.random.default_rng(11)
    yield "random float32", rng.random((700, 300), dtype=np.float32)
    yield "random float64, negative", rng.random((300, 80)) - 0.6
    yield "tied rows and columns", tied_matrix(n_ref=500, n_query=100)
    yield "integers 0..3", rng.integers(0, 4, (300, 120))
    yield "integer-valued float32", rng.integers(0, 3, (400, 90)).astype(np.float32)
    yield "constant", np.full((64, 40), 2.0, dtype=np.float32)
    yield "zero column", np.where(np.arange(60) == 7, 0.0, rng.random((50, 60)))


@pytest.mark.parametrize("seq_len", [2, 10])
@pytest.mark.parametrize("name, matrix", list(matrices()), ids=[name for name, _ in matrices()])
def test_compiled_equals_numpy_exactly(name, matrix, seq_len):
    assert_bit_identical(features(matrix, seq_len, "numba"), features(matrix, seq_len, "numpy"))


@pytest.mark.parametrize("seq_len", [2, 5])
def test_compiled_blocks_and_lazy_inputs(tmp_path, seq_len):
    matrix = tied_matrix(n_ref=300, n_query=200)
    expected = features(matrix, seq_len, "numpy")
    for block in (1, 7, 300):
        assert_bit_identical(features(matrix, seq_len, "numba", block_queries=block), expected)
    np.save(tmp_path / "D.npy", matrix)
    assert_bit_identical(features(np.load(tmp_path / "D.npy", mmap_mode="r"), seq_len, "numba"), expected)
    with h5py.File(tmp_path / "D.h5", "w") as f:
        f.create_dataset("distance_matrix", data=matrix, chunks=(64, 16))
    with h5py.File(tmp_path / "D.h5", "r") as f:
        assert_bit_identical(features(f["distance_matrix"], seq_len, "numba", block_queries=16), expected)


def test_compiled_equals_naive():
    matrix = (np.random.default_rng(4).random((600, 45)) * 2).astype(np.float32)
    got = features(matrix, 10, "numba", tolerance=1)
    expected, expected_refs = naive_attributes(matrix.astype(float), 10, 4)
    s, match, distance, single = naive_sequence(matrix.astype(float), 10)
    np.testing.assert_allclose(got.attributes, expected, rtol=1e-10)
    np.testing.assert_array_equal(got.rank_references, expected_refs)
    np.testing.assert_array_equal(got.sequence_match, match)
    np.testing.assert_array_equal(got.single_match, single)
    assert got.sequence_max == pytest.approx(s.max(), rel=1e-12)


def test_compiled_block_features_equal_numpy():
    # the live matcher's entry point (one window of L columns, as rows), forced onto the compiled path
    columns = np.random.default_rng(8).random((4, 900), dtype=np.float32)
    previous = matcher.KERNEL
    try:
        matcher.KERNEL = "numba"
        compiled = SequenceMatcher(4).block_features(columns, 4)
        matcher.KERNEL = "numpy"
        reference = SequenceMatcher(4).block_features(columns, 4)
    finally:
        matcher.KERNEL = previous
    for key, value in reference.items():
        assert compiled[key].tobytes() == value.tobytes(), key


def test_compiled_non_finite_names_the_block():
    matrix = np.random.default_rng(0).random((50, 40))
    matrix[30, 35] = np.inf
    with pytest.raises(ValueError, match=r"1 non-finite value \(1 inf\); the first is inf at row 30 \(reference\), "
                                         r"column 35 \(query\)"):
        features(matrix, 3, "numba", block_queries=8)


def test_extreme_magnitudes_fall_back_to_numpy():
    matrix = np.random.default_rng(1).random((40, 30)) * 1e250
    assert_bit_identical(features(matrix, 3, "numba"), features(matrix, 3, "numpy"))


def test_choice_of_path(monkeypatch):
    monkeypatch.setattr(matcher, "KERNEL", None)
    monkeypatch.delenv("VPR_SMR_KERNEL", raising=False)
    assert matcher.fixed_kernels(matcher.KERNEL_MIN_VALUES - 1) is None  # small: numpy, numba not even imported
    assert matcher.fixed_kernels(matcher.KERNEL_MIN_VALUES) is not None
    monkeypatch.setenv("VPR_SMR_KERNEL", "numpy")
    assert matcher.fixed_kernels(10**12) is None
    monkeypatch.setenv("VPR_SMR_KERNEL", "numba")
    assert matcher.fixed_kernels(10) is not None
    monkeypatch.setenv("VPR_SMR_KERNEL", "fast")
    with pytest.raises(ValueError, match="VPR_SMR_KERNEL='fast'"):
        matcher.fixed_kernels(10)
    # numba missing: the numpy path silently when chosen automatically, an error when asked for by name
    monkeypatch.delenv("VPR_SMR_KERNEL")
    monkeypatch.setitem(sys.modules, "numba", None)
    monkeypatch.delitem(sys.modules, "vpr_smr.eval.matching.kernels", raising=False)
    monkeypatch.delattr("vpr_smr.eval.matching.kernels", raising=False)
    assert matcher.fixed_kernels(10**12) is None
    monkeypatch.setattr(matcher, "KERNEL", "numba")
    with pytest.raises(RuntimeError, match="pip install numba"):
        matcher.fixed_kernels(10)
