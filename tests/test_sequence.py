import numpy as np
import pytest

from vpr_smr.eval.matching.sequence import is_correct, sequence_matches, sequence_matrix, single_frame_matches

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


def test_naive_convolution_agrees():
    rng = np.random.default_rng(0)
    matrix = rng.random((23, 17))
    for seq_len in (2, 4, 7):
        naive = np.array([[sum(matrix[i + k, j + k] for k in range(seq_len)) for j in range(17 - seq_len + 1)]
                          for i in range(23 - seq_len + 1)])
        np.testing.assert_allclose(sequence_matrix(matrix, seq_len), naive, rtol=1e-12)


def test_ground_truth_tolerance():
    np.testing.assert_array_equal(is_correct([0, 3, 5, 9], [2, 5, 8, 9], 2), [True, True, False, True])


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
        sequence_matrix(matrix, seq_len)
