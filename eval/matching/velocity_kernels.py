"""Compiled (numba) kernel of the velocity search (``velocity.block_features``): the same numbers, bit for bit.

One query at a time, the end references are walked in tiles of ``TILE``: for each velocity (in the tie rule's
order) and each term ``k`` one contiguous pass adds the raw and the normalised values of the shifted column to the
tile's running sums (``0 + x_0 + x_1 + ...``, the definition's order), then ``S``, ``full``, ``past`` and ``v*`` of
the tile are replaced where that velocity's ``S`` is strictly smaller (or no earlier velocity reaches the
reference). The tile's sums stay in the L1 cache, and the normalised columns are divided once each (a ring of the
last ``L``). The ``K`` smallest values are kept by insertion in ascending index order with strict comparisons (equal
values lowest index first, method §5's tie rule), skipping every group of ``GROUP`` values whose minimum cannot enter.

The kernel releases the GIL: ``block_features`` runs parts of the block's queries on a few threads.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
from numba import njit

# the fixed matcher's kernel's sorted top-K insertion and attribute formulas: one copy of each
from vpr_smr.eval.matching.kernels import _bounds, _insert, _rates, empty_outputs
from vpr_smr.eval.matching.matcher import thread_count

TILE = 256  # end references per tile: the tile's sums (2 KB each) stay in the L1 cache
GROUP = 64  # values per group of the K-smallest scan
MIN_THREAD_QUERIES = 16  # queries per thread at least: fewer do not pay for a thread


@njit(cache=True, nogil=True)
def _smallest(values: np.ndarray, out: np.ndarray, index: np.ndarray) -> None:
    """The ``len(out)`` smallest of ``values`` into ``out`` (ascending) and their indices into ``index``; nothing for
    an empty ``out``."""
    capacity = len(out)
    if capacity == 0:
        return
    count = 0
    for g0 in range(0, len(values), GROUP):
        g1 = min(len(values), g0 + GROUP)
        if count == capacity:  # a group whose minimum is not below the current last cannot enter
            low = values[g0]
            for t in range(g0 + 1, g1):
                value = values[t]
                low = value if value < low else low
            if not low < out[capacity - 1]:
                continue
        for t in range(g0, g1):
            if count < capacity or values[t] < out[capacity - 1]:
                count = _insert(out, index, count, values[t], t)


@njit(cache=True, nogil=True)
def _divide(column: np.ndarray, maximum: float, out: np.ndarray) -> None:
    """``out = float64(column) / maximum``: one normalised column (1-D views, so that the loop vectorises)."""
    for r in range(len(column)):
        out[r] = np.float64(column[r]) / maximum


@njit(cache=True, nogil=True)
def _mean_full(full: np.ndarray, lo: int, hi: int) -> float:
    """``(0 + full_lo + ... + full_hi) / (hi - lo + 1)``, as the numpy path's ``_mean``."""
    total = 0.0
    for m in range(lo, hi + 1):
        total += full[m]
    return total / (hi - lo + 1)


@njit(cache=True, nogil=True)
def _take_all(acc_s: np.ndarray, acc_f: np.ndarray, y_last: np.ndarray, x_last: np.ndarray, v: int, s: np.ndarray,
              past: np.ndarray, full: np.ndarray, best: np.ndarray) -> None:
    """The trajectories of velocity ``v`` where no earlier velocity has one: ``S`` and ``full`` get their last term.

    All arguments are views starting at the first reference concerned, indexed by the loop counter: numba then knows
    that no index is negative, and the loops vectorise (any other index costs a wrap-around check that stops that).
    """
    for t in range(len(s)):
        s[t] = acc_s[t] + y_last[t]
        past[t] = acc_f[t]
        full[t] = acc_f[t] + x_last[t]
        best[t] = v


@njit(cache=True, nogil=True)
def _take_smaller(acc_s: np.ndarray, acc_f: np.ndarray, y_last: np.ndarray, x_last: np.ndarray, v: int,
                  s: np.ndarray, past: np.ndarray, full: np.ndarray, best: np.ndarray) -> None:
    """As ``_take_all``, only where velocity ``v``'s ``S`` is strictly smaller than the best so far.

    Selects, not branches: which velocity wins is data, and a mispredicted branch per reference costs more than
    the sums."""
    for t in range(len(s)):
        total = acc_s[t] + y_last[t]
        old = s[t]
        take = total < old
        s[t] = total if take else old
        past[t] = acc_f[t] if take else past[t]
        full[t] = acc_f[t] + x_last[t] if take else full[t]
        best[t] = v if take else best[t]


@njit(cache=True, nogil=True)
def _best_trajectories(raw: np.ndarray, x: np.ndarray, table: np.ndarray, r_min: int, j: int, s: np.ndarray,
                       full: np.ndarray, past: np.ndarray, best: np.ndarray, acc_s: np.ndarray,
                       acc_f: np.ndarray) -> None:
    """``S``, ``full``, ``past`` and ``v*``'s index of every end reference ``r_min + i`` of block query ``j``.

    ``x`` is the ring of normalised columns (column ``c`` in row ``c % L``). Per tile of end references, the
    velocities in ``table``'s order: a velocity replaces the tile's best where its ``S`` is strictly smaller, or
    where no earlier velocity has a trajectory (validity ``r >= o_0(v)`` is a suffix of the references)."""
    n_vel, seq_len = table.shape
    n_index = len(s)
    for t0 in range(0, n_index, TILE):
        t1 = min(n_index, t0 + TILE)
        covered = n_index
        for v in range(n_vel):
            lo = table[v, 0] - r_min
            a = max(t0, lo)
            if a < t1:
                n = t1 - a
                acc_s[:n] = 0.0
                acc_f[:n] = 0.0
                for k in range(seq_len - 1):
                    base = a + r_min - table[v, k]
                    y_row, x_row = raw[j + k, base : base + n], x[(j + k) % seq_len, base : base + n]
                    for t in range(n):
                        acc_s[t] += y_row[t]
                        acc_f[t] += x_row[t]
                base = a + r_min  # o_{L-1} = 0: the current query's own reference
                y_row, x_row = raw[j + seq_len - 1, base : base + n], x[(j + seq_len - 1) % seq_len, base : base + n]
                fresh = min(n, max(0, covered - a))  # no earlier velocity reaches a .. a + fresh - 1: taken
                _take_all(acc_s[:fresh], acc_f[:fresh], y_row[:fresh], x_row[:fresh], v,
                          s[a : a + fresh], past[a : a + fresh], full[a : a + fresh], best[a : a + fresh])
                _take_smaller(acc_s[fresh:n], acc_f[fresh:n], y_row[fresh:], x_row[fresh:], v,
                              s[a + fresh : t1], past[a + fresh : t1], full[a + fresh : t1], best[a + fresh : t1])
            covered = min(covered, lo)


@njit(cache=True, nogil=True)
def _queries(raw: np.ndarray, col_max: np.ndarray, table: np.ndarray, r_min: int, q0: int, q1: int,
             attributes: np.ndarray, rank_index: np.ndarray, single_match: np.ndarray, sequence_index: np.ndarray,
             sequence_distance: np.ndarray, sequence_max: np.ndarray, sequence_candidates: np.ndarray,
             sequence_candidate_index: np.ndarray, single_candidates: np.ndarray, single_candidate_index: np.ndarray,
             sequence_velocity: np.ndarray) -> None:
    """The features of block queries ``q0 .. q1 - 1`` of ``raw`` (``(Wb, R)``, rows contiguous) into the outputs'
    rows ``q0 .. q1 - 1``; ``sequence_velocity`` receives the index of ``v*`` in ``table``'s order, the candidates
    (widths 0: none) the smallest ``S`` by ``i`` and the smallest ``D[r, a]`` by ``r``."""
    n_ref = raw.shape[1]
    n_vel, seq_len = table.shape
    n_index = n_ref - r_min
    n_ranks = attributes.shape[1]
    x = np.empty((seq_len, n_ref))
    for c in range(q0, q0 + seq_len - 1):
        _divide(raw[c], col_max[c], x[c % seq_len])
    s, full, past = np.empty(n_index), np.empty(n_index), np.empty(n_index)
    best = np.empty(n_index, dtype=np.int64)
    acc_s, acc_f = np.empty(TILE), np.empty(TILE)
    row_past = np.empty(n_ref)
    ranked, past_sorted = np.empty(n_ranks), np.empty(n_ranks)
    row_sorted, current_sorted = np.empty(n_ranks), np.empty(n_ranks)
    index, unused = np.empty(n_ranks, dtype=np.int64), np.empty(n_ranks, dtype=np.int64)
    for j in range(q0, q1):
        c = j + seq_len - 1  # the current query's column
        current = x[c % seq_len]
        _divide(raw[c], col_max[c], current)
        _best_trajectories(raw, x, table, r_min, j, s, full, past, best, acc_s, acc_f)

        low, high, at = s[0], s[0], 0
        for i in range(1, n_index):
            if s[i] < low:
                low, at = s[i], i
            high = s[i] if s[i] > high else high
        sequence_index[j], sequence_distance[j], sequence_max[j] = at, low, high
        sequence_velocity[j] = best[at]
        column = raw[c]
        at = 0
        for r in range(1, n_ref):
            if column[r] < column[at]:
                at = r
        single_match[j] = at
        _smallest(s, sequence_candidates[j], sequence_candidate_index[j])
        _smallest(column, single_candidates[j], single_candidate_index[j])

        row_past[:] = 0.0
        for k in range(seq_len - 1):
            row = x[(j + k) % seq_len]
            for r in range(n_ref):
                row_past[r] += row[r]
        _smallest(full, ranked, index)
        _smallest(past, past_sorted, unused)
        _smallest(row_past, row_sorted, unused)
        _smallest(current, current_sorted, unused)
        for k in range(n_ranks):
            i = index[k]
            rank_index[j, k] = i
            block_lo, block_hi, group_lo, group_hi = _bounds(i, seq_len, n_index)
            _rates(attributes[j, k], past_sorted[k], row_sorted[k], current_sorted[k],
                   current[i + r_min],  # traj[L-1] = Dn[r, a]: o_{L-1} = 0
                   past[i], _mean_full(full, block_lo, block_hi), _mean_full(full, group_lo, group_hi))


def block_features(raw: np.ndarray, col_max: np.ndarray, table: np.ndarray, r_min: int, n_ranks: int,
                   n_sequence: int = 0, n_single: int = 0) -> dict[str, np.ndarray]:
    """The numpy path's ``_numpy_chunk`` over all queries of the block ``raw`` (``(Wb, R)``, float32 or float64),
    ``col_max`` its columns' maxima (float64, 0 replaced by 1), ``table`` the offsets ``(|V|, L)`` in the tie rule's
    order, with ``n_sequence`` and ``n_single`` candidates. ``sequence_index`` holds the index of ``v*`` in
    ``table``. The queries are split over threads."""
    raw = np.ascontiguousarray(raw)
    table = np.ascontiguousarray(table, dtype=np.int64)
    n_queries = raw.shape[0] - table.shape[1] + 1
    out = {**empty_outputs(n_queries, n_ranks, n_sequence, n_single),
           "sequence_index": np.empty(n_queries, dtype=np.int64)}
    outputs = tuple(out.values())

    def run(bounds: tuple[int, int]) -> None:
        _queries(raw, col_max, table, r_min, bounds[0], bounds[1], *outputs)

    threads = max(1, min(thread_count(), n_queries // MIN_THREAD_QUERIES))
    edges = np.linspace(0, n_queries, threads + 1).astype(int)
    parts = [(int(edges[t]), int(edges[t + 1])) for t in range(threads)]
    if threads == 1:
        run(parts[0])
    else:
        with ThreadPoolExecutor(threads) as pool:
            list(pool.map(run, parts))
    return out
