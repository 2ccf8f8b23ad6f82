"""SeqSLAM sequence matching with an identity kernel (SPEC section 4).

Matrices are references x queries. Column ``j`` of a sequence matrix belongs to query ``j + L - 1``: the
sequence ends at the current query and only uses past frames.
"""

from __future__ import annotations

import numpy as np

DEFAULT_TOLERANCE = 2  # SPEC 1: a match is correct within 2 frames, for every dataset (the one place it is set)

def check_shape(shape: tuple[int, ...], seq_len: int, name: str = "distance matrix") -> None:
    """Raise ValueError with a clear message when a matrix of ``shape`` cannot be sequence-matched."""
    if seq_len < 2:
        raise ValueError(f"sequence length must be at least 2, got {seq_len}")
    if len(shape) != 2:
        raise ValueError(f"{name} must be 2-D (references x queries), got shape {tuple(shape)}")
    n_ref, n_query = shape
    if n_ref < seq_len or n_query < seq_len:
        raise ValueError(
            f"{name} of shape {n_ref}x{n_query} is too small for sequence length {seq_len}: "
            f"it needs at least {seq_len} references and {seq_len} queries"
        )


def check_finite(values: np.ndarray, name: str = "distance matrix", where: str = "") -> None:
    """Raise ValueError when ``values`` (the whole matrix or one block of it, described by ``where``) has NaN/inf."""
    if np.issubdtype(values.dtype, np.inexact) and not np.all(np.isfinite(values)):
        bad = int(np.size(values) - np.count_nonzero(np.isfinite(values)))
        raise ValueError(f"{name} has {bad} non-finite values (NaN or inf){where}; distances must be finite")


def check_distance_matrix(distance_matrix: np.ndarray, seq_len: int, name: str = "distance matrix") -> None:
    """Raise ValueError with a clear message when ``distance_matrix`` cannot be sequence-matched."""
    check_shape(np.shape(distance_matrix), seq_len, name)
    check_finite(np.asarray(distance_matrix), name)


def diagonal_sums(matrix: np.ndarray, seq_len: int, n_terms: int | None = None) -> np.ndarray:
    """``out[i, j] = sum_{k < n_terms} matrix[i + k, j + k]`` for ``i <= R - L``, ``j <= Q - L``.

    ``n_terms`` defaults to ``seq_len``; ``seq_len - 1`` gives the sums over the past frames only.
    The loop runs over the ``L`` kernel taps, never over queries or diagonals.
    """
    n_terms = seq_len if n_terms is None else n_terms
    n_ref, n_query = matrix.shape
    rows, cols = n_ref - seq_len + 1, n_query - seq_len + 1
    out = np.zeros((rows, cols), dtype=np.float64)
    for k in range(n_terms):
        out += matrix[k : k + rows, k : k + cols]
    return out


def sequence_matrix(distance_matrix: np.ndarray, seq_len: int) -> np.ndarray:
    """``S = valid_conv2d(D, I_L)``, shape ``(R - L + 1) x (Q - L + 1)``, float64."""
    check_distance_matrix(distance_matrix, seq_len)
    return diagonal_sums(np.asarray(distance_matrix, dtype=np.float64), seq_len)


def single_frame_matches(distance_matrix: np.ndarray) -> np.ndarray:
    """Best reference per query: ``argmin_r D[r, q]`` (first index on ties)."""
    return np.argmin(distance_matrix, axis=0)


def sequence_matches(sequence: np.ndarray, seq_len: int) -> tuple[np.ndarray, np.ndarray]:
    """Reference index matched to each query ``a >= L - 1`` and its sequence distance ``min_i S[i, j]``."""
    best = np.argmin(sequence, axis=0)
    return best + seq_len - 1, sequence[best, np.arange(sequence.shape[1])]


def is_correct(reference: np.ndarray, query: np.ndarray, tolerance: int) -> np.ndarray:
    """Ground truth of a frame-aligned pair: a match is correct iff ``|r - q| <= tolerance``."""
    return np.abs(np.asarray(reference) - np.asarray(query)) <= tolerance
