"""The velocity search's numpy twin: sequence sums along trajectories of any velocities, and the four attributes of
the best trajectory ending at each reference (method §11). Inside ``matcher.SequenceMatcher`` only.

Trajectories of different queries are not segments of one line (the offsets are rounded), so every sum is computed
as defined: per velocity and term one shifted addition over the block (``|V| L R`` additions per query), each
``0 + x_0 + x_1 + ...`` in float64 in this order. Every number is therefore exact, whatever the block split, and
with ``(1.0,)`` equals the fixed matcher's fast path (``fixed``) bit for bit. ``velocity_kernels`` (numba) computes
the same numbers in one pass per query.

The velocities come as a table of offsets ``(|V|, L)`` in the tie rule's order (``matcher.search_order``) and
``r_min``, the lowest end reference with a trajectory; indices ``i`` count end references from it.
"""

from __future__ import annotations

import numpy as np

from vpr_smr.eval.matching.checks import check_finite
from vpr_smr.eval.matching.formulas import attribute_rates, block_range, group_range, padded, select

__all__ = ["block_features", "column_max", "sequence_sums", "smallest"]

# --- one block of query columns: the attributes along the best trajectories -------------------------------------

# Queries per numpy pass: about this many values per (queries x references) float64 array, so that the dozen arrays
# that one pass touches stay in the cache (measured at R = 3000, L = 10, |V| = 9: 8 times more values per pass is
# 1.4 times slower, 4 times fewer 1.3 times slower: numpy's cost per call).
CHUNK_VALUES = 1 << 15


def column_max(raw: np.ndarray, first_column: int) -> np.ndarray:
    """Each column's maximum over all references, float64, a zero maximum replaced by 1 (as method §5 divides), or
    ``NonFiniteError`` when the block (whose first column is ``first_column``) holds NaN or inf (they show up in
    the maxima and minima)."""
    raw_max = raw.max(axis=1)
    if not (np.all(np.isfinite(raw_max)) and np.all(np.isfinite(raw.min(axis=1)))):
        check_finite(raw, first_column=first_column, queries_first=True)
    col_max: np.ndarray = raw_max.astype(np.float64)
    col_max[col_max == 0] = 1.0
    return col_max


def block_features(raw: np.ndarray, col_max: np.ndarray, table: np.ndarray, r_min: int, n_ranks: int,
                   n_sequence: int = 0, n_single: int = 0) -> dict[str, np.ndarray]:
    """The features of every query of the block ``raw`` (``(Wb, R)``), in chunks of about ``CHUNK_VALUES`` values;
    ``velocity_kernels.block_features`` computes the same. ``sequence_index`` holds the index of ``v*`` in
    ``table``; ``n_sequence`` and ``n_single``: how many of the smallest ``S`` and ``D[r, a]`` to report
    (``kernels.CANDIDATE_KEYS``, the sequence candidates indexed by ``i``)."""
    seq_len = table.shape[1]
    n_queries = raw.shape[0] - seq_len + 1
    step = max(1, CHUNK_VALUES // raw.shape[1])
    parts = [_numpy_chunk(raw[j : min(n_queries, j + step) + seq_len - 1], col_max[j : j + step + seq_len - 1],
                          table, r_min, n_ranks, n_sequence, n_single) for j in range(0, n_queries, step)]
    return {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}


def sequence_sums(y: np.ndarray, table: np.ndarray, r_min: int) -> tuple[np.ndarray, np.ndarray]:
    """``S`` ``(w, R - r_min)`` of the queries of a block of raw float64 columns ``y`` (``(w + L - 1, R)``) and the
    index in ``table`` of each best trajectory's velocity."""
    s, _, _, best = _best_trajectories(y, None, table, r_min)
    return s, best


def _numpy_chunk(raw: np.ndarray, col_max: np.ndarray, table: np.ndarray, r_min: int, n_ranks: int,
                 n_sequence: int = 0, n_single: int = 0) -> dict[str, np.ndarray]:
    """The features of the queries of ``raw`` (``(w + L - 1, R)``, a slice of the block) in numpy: per velocity and
    per term one shifted addition over the chunk, each sum accumulated ``0 + x_0 + x_1 + ...`` as defined."""
    seq_len = table.shape[1]
    n_cols, n_ref = raw.shape
    w = n_cols - seq_len + 1
    y = raw.astype(np.float64, copy=False)
    x = y / col_max[:, None]  # Dn, by division as method §5 (not a multiplication by the inverse)
    s, full, past, best = _best_trajectories(y, x, table, r_min)
    rows = np.arange(w)

    sequence_index = np.argmin(s, axis=1)  # first index on ties
    _, rank_index = smallest(full, n_ranks)
    past_sorted = smallest(past, n_ranks)[0]
    row_past = np.zeros((w, n_ref))
    for k in range(seq_len - 1):
        row_past += x[k : k + w]
    row_past_sorted = smallest(row_past, n_ranks)[0]
    current = x[seq_len - 1 :]
    current_sorted = smallest(current, n_ranks)[0]

    past_ranked = np.take_along_axis(past, rank_index, axis=1)
    last = np.take_along_axis(current, rank_index + r_min, axis=1)  # traj[L-1] = Dn[r, a]: o_{L-1} = 0
    n_index = full.shape[1]
    block_mean = _mean(full, *block_range(rank_index, seq_len, n_index))
    group_mean = _mean(full, *group_range(rank_index, n_index))
    attributes = attribute_rates(past_sorted, row_past_sorted, current_sorted, last, past_ranked, block_mean,
                                 group_mean)
    sequence_values, sequence_candidates = smallest(s, n_sequence)
    single_values, single_index = smallest(y[seq_len - 1 :], n_single)
    return {
        "attributes": attributes,
        "rank_diagonals": rank_index.astype(np.int64),
        "single_match": np.argmin(raw[seq_len - 1 :], axis=1).astype(np.int64),
        "sequence_diagonal": sequence_index.astype(np.int64),
        "sequence_distance": s[rows, sequence_index],
        "sequence_max": s.max(axis=1),
        "sequence_index": best[rows, sequence_index],
        "sequence_candidates": sequence_values,
        "sequence_candidate_diagonals": sequence_candidates.astype(np.int64),
        "single_candidates": single_values,
        "single_candidate_references": single_index.astype(np.int64),
    }


def _best_trajectories(y: np.ndarray, x: np.ndarray | None, table: np.ndarray,
                       r_min: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``S``, ``full``, ``past`` and the index of ``v*`` (in ``table``'s order) for every query of the chunk and
    every end reference ``r = r_min + i``: arrays ``(w, N)``, ``N = R - r_min``.

    ``y`` holds the chunk's raw columns in float64 and ``x`` the normalised ones, both ``(w + L - 1, R)``. The
    velocities are scanned in ``table``'s order (the tie rule's) and a trajectory replaces the best one only when
    its ``S`` is strictly smaller; where no earlier velocity had a valid trajectory it is taken as it is. Without
    ``x`` (``S`` alone), ``full`` and ``past`` are not computed (their arrays are returned unfilled).
    """
    n_cols, n_ref = y.shape
    seq_len = table.shape[1]
    w, n_index = n_cols - seq_len + 1, n_ref - r_min
    s = np.empty((w, n_index))
    full, past = (np.empty((w, n_index) if x is not None else (0, 0)) for _ in range(2))
    best = np.empty((w, n_index), dtype=np.int64)
    covered = n_index  # indices covered..N-1 have a trajectory so far: validity r >= o_0(v) is a suffix
    for v, offs in enumerate(table):
        first = int(offs[0])  # the lowest valid end reference
        lo, n = first - r_min, n_ref - first
        if n <= 0:  # too slow or too fast for these references: no trajectory fits
            continue
        s_v = np.zeros((w, n))
        f_v = np.zeros((w, n)) if x is not None else None
        for k in range(seq_len - 1):
            start = first - int(offs[k])  # reference of term k for the end reference `first`
            s_v += y[k : k + w, start : start + n]
            if x is not None and f_v is not None:
                f_v += x[k : k + w, start : start + n]
        s_v += y[seq_len - 1 :, first:]  # o_{L-1} = 0: the current query's own reference
        if lo < covered:  # no earlier velocity reaches these end references
            new = slice(0, covered - lo)
            s[:, lo:covered] = s_v[:, new]
            best[:, lo:covered] = v
        old = max(lo, covered)
        take = s_v[:, old - lo :] < s[:, old:] if old < n_index else None
        if take is not None:
            np.copyto(s[:, old:], s_v[:, old - lo :], where=take)
            np.copyto(best[:, old:], v, where=take)
        if x is not None and f_v is not None:
            full_v = f_v + x[seq_len - 1 :, first:]
            if lo < covered:
                full[:, lo:covered], past[:, lo:covered] = full_v[:, new], f_v[:, new]
            if take is not None:
                np.copyto(full[:, old:], full_v[:, old - lo :], where=take)
                np.copyto(past[:, old:], f_v[:, old - lo :], where=take)
        covered = min(covered, lo)
    return s, full, past, best


def smallest(values: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``count`` smallest values of each row (ascending, float64) and their column indices, equal values lowest
    index first (a stable sort's order): ``formulas.select`` on exact values (no screening margin); none for a
    ``count`` of 0."""
    n_rows, n = values.shape
    if count == 0:
        return np.empty((n_rows, 0)), np.empty((n_rows, 0), dtype=np.int64)
    screened = padded(n_rows, n, values.dtype)
    screened[:, :n] = values
    return select(screened, n, count, 0.0, lambda rows, cols: values[rows, cols])


def _mean(full: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Mean of ``full[q, m]`` over ``m = lo .. hi`` (inclusive, per query ``q`` and rank): ``total = 0 + full_lo +
    full_{lo+1} + ...``, then ``total / count``, as ``fixed._mean_full`` (the block and group sums of method §5)."""
    width = int((hi - lo).max()) + 1
    total = np.zeros(lo.shape)
    for t in range(width):
        inside = lo + t <= hi
        total += np.where(inside, np.take_along_axis(full, np.minimum(lo + t, hi), axis=1), 0.0)
    mean: np.ndarray = total / (hi - lo + 1)
    return mean
