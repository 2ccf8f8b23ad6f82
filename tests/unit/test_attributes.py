"""Attributes against a hand-worked example and against a naive per-query implementation of method §5."""

from dataclasses import fields

import numpy as np
import pytest
from oracles import naive_attributes, naive_sequence, tied_matrix

from vpr_smr.core.constants import EPS
from vpr_smr.eval.matching.attributes import labels_from_correctness, query_features

D = np.array([[1, 2, 4], [2, 1, 2], [4, 4, 1], [4, 2, 2]], dtype=float)


def test_attributes_by_hand():
    # Every column max is 4, so Dn = D / 4. Worked by hand for L = 2 (see the notes in each line).
    found = query_features(D, 2, n_ranks=3)
    attributes, references = found.attributes, found.rank_references
    e = EPS
    # Query 1: W = Dn[:, 0:2]; diagonals [.25,.25], [.5,1], [1,.5]; full [.5,1.5,1.5]; past [.25,.5,1];
    # rowpast [.25,.5,1,1]; ranks 0,1,2 (stable); blocks of L=2 diagonals {0,1}, {2}; groups of width 2.
    expected_q1 = [
        [.25 / (.25 + e), .25 / (.25 + e), .25 / (1.0 + e), .25 / (3.5 / 3 + e)],
        [.5 / (.5 + e), .5 / (1.0 + e), .5 / (1.0 + e), .5 / (3.5 / 3 + e)],
        [1 / (1 + e), .5 / (.5 + e), 1 / (1.5 + e), 1 / (3.5 / 3 + e)],
    ]
    # Query 2: W = Dn[:, 1:3]; diagonals [.5,.5], [.25,.25], [1,.5]; full [1,.5,1.5]; past [.5,.25,1];
    # rowpast [.5,.25,1,.5]; rank 0 is diagonal 1, whose block {0,1} has mean full .75 and group {0,1,2} mean 1.
    expected_q2_rank0 = [.25 / (.25 + e), .25 / (.25 + e), .25 / (.75 + e), .25 / (1 + e)]
    np.testing.assert_allclose(attributes[0], expected_q1, rtol=1e-12)
    np.testing.assert_allclose(attributes[1, 0], expected_q2_rank0, rtol=1e-12)
    np.testing.assert_array_equal(references[0], [1, 2, 3])
    np.testing.assert_array_equal(references[1], [2, 1, 3])


@pytest.mark.parametrize("shape, seq_len, block", [((30, 25), 2, 1024), ((41, 33), 4, 7), ((12, 50), 5, 3),
                                                   ((8, 8), 8, 1024)])
def test_vectorised_equals_naive(shape, seq_len, block):
    rng = np.random.default_rng(seq_len)
    matrix = rng.random(shape) * 3
    n_ranks = min(4, shape[0] - seq_len + 1)
    found = query_features(matrix, seq_len, n_ranks=4, block_queries=block)
    attributes, references = found.attributes, found.rank_references
    expected, expected_refs = naive_attributes(matrix, seq_len, n_ranks)
    np.testing.assert_allclose(attributes, expected, rtol=1e-10)
    np.testing.assert_array_equal(references, expected_refs)


def test_zero_column_is_divided_by_one():
    matrix = np.random.default_rng(1).random((10, 6))
    matrix[:, 3] = 0
    attributes = query_features(matrix, 3).attributes
    expected, _ = naive_attributes(matrix, 3, 4)
    np.testing.assert_allclose(attributes, expected, rtol=1e-10)
    assert np.all(np.isfinite(attributes))


def test_labels_by_hand():
    np.testing.assert_array_equal(
        labels_from_correctness([True, True, False, False], [True, False, True, False]), [0, 1, 2, 3]
    )


def test_query_features_labels():
    # References x queries, L = 2, tolerance 0. Query 1: single-frame best is reference 1 (correct), but the
    # sequence diagonal ending at reference 3 sums lower -> label 1. Query 2: single best reference 0 (wrong),
    # sequence ends at reference 2 (correct) -> label 2. Query 3: both at reference 3 -> label 0.
    matrix = np.array([
        [5, 5, 0.5, 5],
        [5, 1.0, 5, 5],
        [0.1, 5, 0.6, 5],
        [5, 1.05, 5, 0.1],
    ])
    features = query_features(matrix, 2, tolerance=0)
    np.testing.assert_array_equal(features.queries, [1, 2, 3])
    np.testing.assert_array_equal(features.single_match, [1, 0, 3])
    np.testing.assert_array_equal(features.sequence_match, [3, 2, 3])
    np.testing.assert_array_equal(features.labels, [1, 2, 0])
    np.testing.assert_allclose(features.sequence_distance, [0.1 + 1.05, 1.0 + 0.6, 0.6 + 0.1])


def assert_same_features(a, b):
    for field in fields(a):
        np.testing.assert_array_equal(getattr(a, field.name), getattr(b, field.name), err_msg=field.name)


@pytest.mark.parametrize("shape, seq_len", [((700, 90), 3), ((40, 60), 5), ((600, 45), 10)])
def test_query_features_equal_naive(shape, seq_len):
    rng = np.random.default_rng(shape[0])
    matrix = (rng.random(shape) * 2).astype(np.float32)
    features = query_features(matrix, seq_len, tolerance=1)
    s, match, distance, single = naive_sequence(matrix.astype(float), seq_len)
    expected, expected_refs = naive_attributes(matrix.astype(float), seq_len, 4)
    np.testing.assert_array_equal(features.sequence_match, match)
    np.testing.assert_allclose(features.sequence_distance, distance, rtol=1e-12)
    np.testing.assert_array_equal(features.single_match, single)
    assert features.sequence_min == pytest.approx(s.min(), rel=1e-12)
    assert features.sequence_max == pytest.approx(s.max(), rel=1e-12)
    np.testing.assert_allclose(features.attributes, expected, rtol=1e-10)
    np.testing.assert_array_equal(features.rank_references, expected_refs)


@pytest.mark.parametrize("seq_len", [2, 4, 7])
def test_tie_rule_on_repeated_rows_and_columns(seq_len):
    matrix = tied_matrix()
    features = query_features(matrix, seq_len)
    expected, expected_refs = naive_attributes(matrix.astype(float), seq_len, 4)
    _, match, _, single = naive_sequence(matrix.astype(float), seq_len)
    # the tie is real: rank 0 and rank 1 have the same full_d (hence the same A3 numerator) for most queries
    tied = features.rank_references[:, 1] == features.rank_references[:, 0] + 1
    assert tied.sum() > 50
    np.testing.assert_array_equal(features.rank_references, expected_refs)  # lowest diagonal first
    np.testing.assert_array_equal(features.rank_references[:, 0], 200 + seq_len - 1)
    np.testing.assert_array_equal(features.sequence_match, match)
    np.testing.assert_array_equal(features.single_match, single)
    np.testing.assert_allclose(features.attributes, expected, rtol=1e-10)


@pytest.mark.parametrize("seq_len", [2, 5])
def test_blockwise_equals_whole_matrix_exactly(seq_len):
    matrix = tied_matrix(n_ref=300, n_query=200)
    whole = query_features(matrix, seq_len, block_queries=10_000)
    for block in (1, 7, 64):
        assert_same_features(query_features(matrix, seq_len, block_queries=block), whole)


def test_float32_screening_equals_float64():
    # float32 only picks the candidates that are recomputed in float64: every output is identical (tolerance 0).
    for matrix in (tied_matrix(), np.random.default_rng(5).random((900, 80))):
        for seq_len in (2, 6):
            assert_same_features(query_features(matrix, seq_len, screen_dtype=np.float32),
                                 query_features(matrix, seq_len, screen_dtype=np.float64))


def test_lazy_inputs_equal_in_memory(tmp_path):
    import h5py

    matrix = tied_matrix(n_ref=300, n_query=90)
    expected = query_features(matrix, 4)
    np.save(tmp_path / "D.npy", matrix)
    assert_same_features(query_features(np.load(tmp_path / "D.npy", mmap_mode="r"), 4, block_queries=16), expected)
    with h5py.File(tmp_path / "D.h5", "w") as f:
        f.create_dataset("distance_matrix", data=matrix, chunks=(64, 16))
    with h5py.File(tmp_path / "D.h5", "r") as f:
        assert_same_features(query_features(f["distance_matrix"], 4, block_queries=16), expected)


def test_non_finite_found_in_any_block():
    matrix = np.random.default_rng(0).random((50, 40))
    matrix[30, 35] = np.nan
    matrix[2, 39] = np.inf
    # the first bad value in the matrix's own indices (block 32..39 found it), counted over the whole matrix
    with pytest.raises(ValueError, match=r"has 2 non-finite values \(1 NaN, 1 inf\); the first is NaN at row 30 "
                                         r"\(reference\), column 35 \(query\)"):
        query_features(matrix, 3, block_queries=8)


def test_integer_and_negative_matrices():
    rng = np.random.default_rng(2)
    for matrix in (rng.integers(0, 5, (60, 30)), rng.random((60, 30)) - 0.7):
        features = query_features(matrix, 3)
        expected, expected_refs = naive_attributes(matrix.astype(float), 3, 4)
        np.testing.assert_allclose(features.attributes, expected, rtol=1e-10)
        np.testing.assert_array_equal(features.rank_references, expected_refs)
        np.testing.assert_array_equal(features.sequence_match, naive_sequence(matrix.astype(float), 3)[1])
