"""Sequence matching of the attributes stage against hand-worked values and the naive references of tests/helpers."""

import numpy as np
import pytest
from oracles import sequence_matches, sequence_matrix, single_frame_matches

from vpr_smr.eval.matching.attributes import query_features
from vpr_smr.eval.matching.ground_truth import GroundTruth

# A 4 x 3 matrix (references x queries) worked through by hand.
D = np.array([[1, 2, 4], [2, 1, 2], [4, 4, 1], [4, 2, 2]], dtype=float)


def test_sequence_matrix_by_hand():
    # S[i, j] = D[i, j] + D[i+1, j+1] for L = 2
    expected = np.array([[1 + 1, 2 + 2], [2 + 4, 1 + 1], [4 + 2, 4 + 2]], dtype=float)
    np.testing.assert_array_equal(sequence_matrix(D, 2), expected)


def test_sequence_matrix_length_three():
    expected = np.array([[1 + 1 + 1], [2 + 4 + 2]], dtype=float)
    np.testing.assert_array_equal(sequence_matrix(D, 3), expected)


def test_matches_by_hand():
    match, distance = sequence_matches(sequence_matrix(D, 2), 2)
    # query 1: column 0, best diagonal 0 -> reference 1; query 2: column 1, best diagonal 1 -> reference 2
    np.testing.assert_array_equal(match, [1, 2])
    np.testing.assert_array_equal(distance, [2, 2])
    np.testing.assert_array_equal(single_frame_matches(D), [0, 1, 2])
    features = query_features(D, 2)
    np.testing.assert_array_equal(features.sequence_match, [1, 2])
    np.testing.assert_array_equal(features.sequence_distance, [2, 2])
    np.testing.assert_array_equal(features.single_match, [1, 2])


@pytest.mark.parametrize("seq_len", [2, 4, 7])
def test_query_features_match_the_naive_reference(seq_len):
    matrix = np.random.default_rng(seq_len).random((23, 17))
    features = query_features(matrix, seq_len)
    sequence = sequence_matrix(matrix, seq_len)
    match, distance = sequence_matches(sequence, seq_len)
    np.testing.assert_array_equal(features.sequence_match, match)
    np.testing.assert_allclose(features.sequence_distance, distance, rtol=1e-12)
    np.testing.assert_array_equal(features.single_match, single_frame_matches(matrix)[seq_len - 1 :])
    assert features.sequence_min == pytest.approx(sequence.min(), rel=1e-12)
    assert features.sequence_max == pytest.approx(sequence.max(), rel=1e-12)


def test_ground_truth_tolerance():
    truth = GroundTruth.aligned(10, 10, 2)
    np.testing.assert_array_equal(truth.correct([0, 3, 5, 9], [2, 5, 8, 9]), [True, True, False, True])


@pytest.mark.parametrize(
    "matrix, seq_len, message",
    [
        (np.zeros((3, 3, 1)), 2, "must be 2-D"),
        (np.zeros((3, 5)), 4, "too small for sequence length 4"),
        (np.array([[0, np.nan], [1, 2], [3, 4], [5, 6]]), 2, "non-finite"),
        (np.zeros((5, 5)), 1, "at least 2"),
    ],
)
def test_bad_matrices(matrix, seq_len, message):
    with pytest.raises(ValueError, match=message):
        query_features(matrix, seq_len)
