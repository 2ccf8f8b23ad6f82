"""The four SMR attributes of every query and its label (SPEC sections 5 and 6, paper mode).

Everything is vectorised over queries: the work is split into blocks of query columns only to bound memory,
and the only Python loops run over the ``L`` kernel taps and those blocks.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .sequence import (
    check_distance_matrix,
    diagonal_sums,
    is_correct,
    sequence_matches,
    sequence_matrix,
    single_frame_matches,
)

EPS = 1e-6
GROUP_HALF_WIDTH = 2  # W in the paper: the group of diagonal i is i-W .. i+W
ATTRIBUTE_NAMES = ("A1", "A2", "A3", "A4")  # minimum sum, minimum value, block sum, group sum rates


@dataclass(frozen=True)
class QueryFeatures:
    """What the predictor and the evaluation need of one split, for queries ``a = L-1 .. Q-1``.

    ``attributes[n, k]`` holds ``[A1_k, A2_k, A3_k, A4_k]`` of query ``queries[n]``;
    ``rank_references[n, k]`` is the reference that the rank-``k`` diagonal matches to that query.
    """

    queries: np.ndarray  # (N,) query index within the split
    attributes: np.ndarray  # (N, K, 4)
    rank_references: np.ndarray  # (N, K)
    single_match: np.ndarray  # (N,) argmin_r D[r, a]
    sequence_match: np.ndarray  # (N,) argmin_i S[i, a-L+1] + L - 1
    sequence_distance: np.ndarray  # (N,) min_i S[i, a-L+1]
    labels: np.ndarray  # (N,) 0..3, SPEC section 6
    single_correct: np.ndarray  # (N,) bool
    sequence_correct: np.ndarray  # (N,) bool
    rank_correct: np.ndarray  # (N, K) bool
    sequence_min: float  # S.min() of the whole split
    sequence_max: float  # S.max() of the whole split


def normalise_columns(distance_matrix: np.ndarray) -> np.ndarray:
    """Divide each query column by its maximum over all references (a zero maximum divides by 1)."""
    col_max = distance_matrix.max(axis=0)
    col_max = np.where(col_max == 0, 1.0, col_max)
    return distance_matrix / col_max


def _window_means(values: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Mean of ``values[lo[i] .. hi[i]]`` (inclusive) along axis 0, for each row index ``i``."""
    cumsum = np.concatenate([np.zeros((1, values.shape[1])), np.cumsum(values, axis=0)])
    return (cumsum[hi + 1] - cumsum[lo]) / (hi - lo + 1)[:, None]


def _smallest_sorted(values: np.ndarray, count: int) -> np.ndarray:
    """The ``count`` smallest values of each column, ascending."""
    if count >= values.shape[0]:
        return np.sort(values, axis=0)[:count]
    return np.partition(values, np.arange(count), axis=0)[:count]


def attribute_block(normalised: np.ndarray, seq_len: int, n_ranks: int) -> tuple[np.ndarray, np.ndarray]:
    """Attributes for all queries of ``normalised`` (columns already divided by their maxima).

    Returns ``attributes`` of shape ``(Q - L + 1, K, 4)`` and the rank-``k`` diagonal indices ``(Q - L + 1, K)``.
    """
    n_ref = normalised.shape[0]
    n_diag = n_ref - seq_len + 1
    full = diagonal_sums(normalised, seq_len)  # full_d per query column
    past = diagonal_sums(normalised, seq_len, seq_len - 1)  # past_d
    cols = full.shape[1]
    row_past = np.zeros((n_ref, cols))
    for c in range(seq_len - 1):
        row_past += normalised[:, c : c + cols]
    current = normalised[:, seq_len - 1 :]  # W[:, L-1] of each query

    order = np.argsort(full, axis=0, kind="stable")[:n_ranks]  # (K, cols), ties -> lower diagonal
    col_index = np.arange(cols)
    a1 = _smallest_sorted(past, n_ranks) / (_smallest_sorted(row_past, n_ranks) + EPS)
    a2 = _smallest_sorted(current, n_ranks) / (current[order + seq_len - 1, col_index] + EPS)

    diag = np.arange(n_diag)
    block_lo = seq_len * (diag // seq_len)
    block_hi = np.minimum(n_diag - 1, block_lo + seq_len - 1)
    group_lo = np.maximum(0, diag - GROUP_HALF_WIDTH)
    group_hi = np.minimum(n_diag - 1, diag + GROUP_HALF_WIDTH)
    # block_i / group_i: the sum over L entries of the entry-wise mean of the diagonals, i.e. the mean of full_m.
    block = _window_means(full, block_lo, block_hi)
    group = _window_means(full, group_lo, group_hi)
    past_ranked = past[order, col_index]
    a3 = past_ranked / (block[order, col_index] + EPS)
    a4 = past_ranked / (group[order, col_index] + EPS)
    attributes = np.stack([a1, a2, a3, a4], axis=-1).transpose(1, 0, 2)  # (cols, K, 4)
    return attributes, order.T


def query_attributes(
    distance_matrix: np.ndarray, seq_len: int, n_ranks: int = 4, block_queries: int = 1024
) -> tuple[np.ndarray, np.ndarray]:
    """Paper-mode attributes of ranks ``0 .. K-1`` for every query ``a >= L - 1``.

    Returns ``(attributes (Q-L+1, K, 4), rank_references (Q-L+1, K))``; ``K`` is at most the number of
    diagonals ``R - L + 1``.
    """
    check_distance_matrix(distance_matrix, seq_len)
    normalised = normalise_columns(np.asarray(distance_matrix, dtype=np.float64))
    n_ranks = min(n_ranks, normalised.shape[0] - seq_len + 1)
    n_cols = normalised.shape[1] - seq_len + 1
    attributes = np.empty((n_cols, n_ranks, 4))
    diagonals = np.empty((n_cols, n_ranks), dtype=np.int64)
    for start in range(0, n_cols, block_queries):
        stop = min(n_cols, start + block_queries)
        block = normalised[:, start : stop + seq_len - 1]
        attributes[start:stop], diagonals[start:stop] = attribute_block(block, seq_len, n_ranks)
    return attributes, diagonals + seq_len - 1


def labels_from_correctness(single_correct: np.ndarray, sequence_correct: np.ndarray) -> np.ndarray:
    """0 correct before and after, 1 correct before only, 2 correct after only, 3 wrong both."""
    single_correct = np.asarray(single_correct, dtype=bool)
    sequence_correct = np.asarray(sequence_correct, dtype=bool)
    return np.where(single_correct, np.where(sequence_correct, 0, 1), np.where(sequence_correct, 2, 3))


def query_features(
    distance_matrix: np.ndarray, seq_len: int, tolerance: int = 2, n_ranks: int = 4
) -> QueryFeatures:
    """Sequence matching, attributes and labels of one split's ``R x Q`` distance matrix."""
    distance_matrix = np.asarray(distance_matrix, dtype=np.float64)
    sequence = sequence_matrix(distance_matrix, seq_len)
    queries = np.arange(seq_len - 1, distance_matrix.shape[1])
    single = single_frame_matches(distance_matrix)[queries]
    seq_match, seq_dist = sequence_matches(sequence, seq_len)
    attributes, rank_refs = query_attributes(distance_matrix, seq_len, n_ranks)
    single_correct = is_correct(single, queries, tolerance)
    sequence_correct = is_correct(seq_match, queries, tolerance)
    return QueryFeatures(
        queries=queries,
        attributes=attributes,
        rank_references=rank_refs,
        single_match=single,
        sequence_match=seq_match,
        sequence_distance=seq_dist,
        labels=labels_from_correctness(single_correct, sequence_correct),
        single_correct=single_correct,
        sequence_correct=sequence_correct,
        rank_correct=is_correct(rank_refs, queries[:, None], tolerance),
        sequence_min=float(sequence.min()),
        sequence_max=float(sequence.max()),
    )
