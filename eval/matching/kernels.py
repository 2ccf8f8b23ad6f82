"""Compiled (numba) kernel of the fixed matcher's fast path (``fixed.block_features``): the same numbers, in one pass.

The matrix is read in its own layout (references x queries, rows contiguous), row by row, so a memory-mapped
``.npy`` is never transposed or copied. For a block of query columns, running sums along the diagonals (``T``
normalised, ``V`` raw, a ring of the last ``L + 1`` rows) and along each row give every screened ``full_d``,
``past_d``, ``S``, row sum and current value as one subtraction, in float64; the minimum (for ``S`` also the
maximum) of each group of ``GROUP`` consecutive diagonals or rows is kept per query. Then per query, every group
whose minimum lies within ``margin`` (twice the bound on the screening error, ``fixed._error_bound``) of the
``K``-th smallest group minimum is recomputed exactly, as the definition does it (``0 + x_0 + x_1 + ...``, each
``x`` divided by its column maximum in float64), and the ``K`` best are kept in ascending index order with strict
comparisons: equal values lowest index first, method §5's tie rule. Every group that can hold one of the ``K`` best
exact values is scanned (the ``K``-th group minimum bounds the ``K``-th smallest screened value from above), so
the result equals the numpy path's exactly; only the amount of work differs. The training-free scorers' candidates
(method §12): the ``n`` smallest ``S`` come from the same scan (the sequence match is the first of them), bounded on
the group minima and recomputed by parts of ``FINE`` diagonals; the ``n`` smallest raw values of the current column
are exact already and are kept as the rows stream by (``_keep_smallest``), without a second read of the matrix.

The kernels release the GIL: ``column_blocks`` runs blocks of query columns on a few threads.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
from numba import njit, types
from numba.core.typing.templates import Signature

from vpr_smr.core.constants import EPS, GROUP_HALF_WIDTH  # plain globals: numba freezes them at compile time
from vpr_smr.eval.matching.matcher import thread_count

GROUP = 32  # diagonals (rows) per screening group
# The scorers' n smallest S keep a minimum per FINE diagonals besides the one per GROUP: the bound and the first test
# stay on the GROUP minima, and within a group that passes only the parts that pass are recomputed. For n ~ 12, most
# of the n groups a bound lets through hold one candidate: recomputing them whole cost +33 % of the kernel's time at
# 3000 x 3000 (one thread), by parts +15 %; bounding on the FINE minima themselves costs as much in bookkeeping over
# four times the groups.
FINE = 8
PARTS = GROUP // FINE
BLOCK_QUERIES = 256  # query columns per kernel call (measured: 128 and 64 are slower)


def _matrix(dtype: types.Type) -> types.Array:
    """A read-only float matrix of any strides (what a memory-mapped .npy gives)."""
    return types.Array(dtype, 2, "A", readonly=True)


def _block_signature(dtype: types.Type) -> Signature:
    f8, i8 = types.float64, types.int64
    return types.void(_matrix(dtype), f8[:], i8, f8, f8, f8[:, :, :], i8[:, :], i8[:], i8[:], f8[:], f8[:],
                      f8[:, :], i8[:, :], f8[:, :], i8[:, :])


@njit(cache=True, nogil=True)
def _insert(values: np.ndarray, index: np.ndarray, count: int, value: float, at: int) -> int:
    """Insert (value, at) into the ascending ``values[:count]`` (capacity ``len(values)``) after every equal value:
    called in ascending ``at``, this keeps the lowest index first among equal values. Returns the new count."""
    k = len(values)
    if count == k:
        if not value < values[k - 1]:
            return count
        count -= 1
    pos = count
    while pos > 0 and value < values[pos - 1]:
        values[pos] = values[pos - 1]
        index[pos] = index[pos - 1]
        pos -= 1
    values[pos] = value
    index[pos] = at
    return count + 1


@njit(cache=True, nogil=True)
def _diag(raw: np.ndarray, col_max: np.ndarray, d: int, j: int, n_terms: int, normalised: bool) -> float:
    """``0 + x_0 + x_1 + ...`` along diagonal ``d`` from block column ``j``: ``diagonal_sum`` of the numpy path."""
    acc = 0.0
    for c in range(n_terms):
        v = np.float64(raw[d + c, j + c])
        acc += v / col_max[j + c] if normalised else v
    return acc


@njit(cache=True, nogil=True)
def _exact(raw: np.ndarray, col_max: np.ndarray, kind: int, i: int, j: int, seq_len: int) -> float:
    """The definition's float64 value of item ``i`` of query ``j``: kind 0 full_d, 1 past_d, 2 row sum of the
    past, 3 current value, 4 S, 5 -S."""
    if kind == 0:
        return _diag(raw, col_max, i, j, seq_len, True)
    if kind == 1:
        return _diag(raw, col_max, i, j, seq_len - 1, True)
    if kind == 2:
        acc = 0.0
        for c in range(seq_len - 1):
            acc += np.float64(raw[i, j + c]) / col_max[j + c]
        return acc
    if kind == 3:
        current: float = np.float64(raw[i, j + seq_len - 1]) / col_max[j + seq_len - 1]
        return current
    if kind == 4:
        return _diag(raw, col_max, i, j, seq_len, False)
    return -_diag(raw, col_max, i, j, seq_len, False)


@njit(cache=True, nogil=True)
def _limits(heads: np.ndarray, count: int, margin: float) -> np.ndarray:
    """Per query ``j``: the ``count``-th smallest of ``heads[:, j]`` plus ``margin`` (+inf with fewer groups).

    ``heads[g, j]`` is the smallest screened value of group ``g`` of query ``j``, so at least ``count`` screened
    values lie at or below that ``count``-th smallest head: every item whose exact value can be among the
    ``count`` best has a screened value, hence a group head, within ``margin`` of it."""
    n_groups, n_queries = heads.shape
    bound = np.full((n_queries, count), np.inf)
    dummy = np.zeros(count, dtype=np.int64)
    filled = np.zeros(n_queries, dtype=np.int64)
    if n_groups >= count:
        for g in range(n_groups):
            row = heads[g]
            for j in range(n_queries):
                if row[j] < bound[j, count - 1]:
                    filled[j] = _insert(bound[j], dummy, filled[j], row[j], g)
    return bound[:, count - 1] + margin


@njit(cache=True, nogil=True)
def _scan(heads: np.ndarray, limit: np.ndarray, g: int, n_values: int, kind: int, raw: np.ndarray,
          col_max: np.ndarray, seq_len: int, values: np.ndarray, index: np.ndarray, filled: np.ndarray) -> None:
    """Recompute exactly the items of group ``g`` of every query whose group head is within its limit, keeping
    the ``K`` smallest (value, item) per query; called for ascending ``g``, so equal values keep the lowest item."""
    if g >= heads.shape[0]:
        return
    row = heads[g]
    count = values.shape[1]
    for j in range(len(row)):
        if row[j] <= limit[j]:
            for i in range(g * GROUP, min(n_values, (g + 1) * GROUP)):
                value = _exact(raw, col_max, kind, i, j, seq_len)
                if filled[j] < count or value < values[j, count - 1]:  # most fail here: no insertion
                    filled[j] = _insert(values[j], index[j], filled[j], value, i)


@njit(cache=True, nogil=True)
def _scan_parts(heads: np.ndarray, parts: np.ndarray, limit: np.ndarray, g: int, n_values: int, kind: int,
                raw: np.ndarray, col_max: np.ndarray, seq_len: int, values: np.ndarray, index: np.ndarray,
                filled: np.ndarray) -> None:
    """``_scan`` of group ``g`` recomputing only its parts (``FINE`` items each, minima ``parts``) within the limit."""
    if g >= heads.shape[0]:
        return
    row = heads[g]
    count = values.shape[1]
    for j in range(len(row)):
        if row[j] <= limit[j]:
            for f in range(g * PARTS, min(parts.shape[0], (g + 1) * PARTS)):
                if parts[f, j] <= limit[j]:
                    for i in range(f * FINE, min(n_values, (f + 1) * FINE)):
                        value = _exact(raw, col_max, kind, i, j, seq_len)
                        if filled[j] < count or value < values[j, count - 1]:
                            filled[j] = _insert(values[j], index[j], filled[j], value, i)


@njit(cache=True, nogil=True)
def _keep_smallest(current: np.ndarray, above: np.ndarray, r: int, values: np.ndarray, index: np.ndarray,
                   filled: np.ndarray) -> None:
    """Row ``r``'s value of each query (``current``) into its ``values.shape[1]`` smallest so far, kept ascending
    with their rows (``_insert``: called for ascending ``r``, equal values keep the lowest row); ``above``: each
    query's largest kept value once it keeps as many as it may (+inf before). Most rows enter no query's smallest:
    one vectorised count first, the insertions only where one does."""
    count = values.shape[1]
    entering = 0
    for j in range(len(current)):
        entering += current[j] < above[j]
    if entering == 0:
        return
    for j in range(len(current)):
        if current[j] < above[j]:
            filled[j] = _insert(values[j], index[j], filled[j], current[j], r)
            if filled[j] == count:
                above[j] = values[j, count - 1]


@njit(cache=True, nogil=True)
def _coarse(parts: np.ndarray, n_groups: int) -> np.ndarray:
    """The minimum of every ``PARTS`` consecutive rows of ``parts``: the ``GROUP`` minima of ``FINE`` ones."""
    out = np.full((n_groups, parts.shape[1]), np.inf)
    for f in range(parts.shape[0]):
        _minimum(out[f // PARTS], parts[f])
    return out


@njit(cache=True, nogil=True)
def _minimum(heads: np.ndarray, values: np.ndarray) -> None:
    """``heads = min(heads, values)`` element-wise (a select, so that it vectorises)."""
    for j in range(len(heads)):
        v = values[j]
        heads[j] = v if v < heads[j] else heads[j]


@njit(cache=True, nogil=True)
def _mean_full(raw: np.ndarray, col_max: np.ndarray, j: int, lo: int, hi: int, seq_len: int) -> float:
    total = 0.0
    for m in range(lo, hi + 1):
        total += _diag(raw, col_max, m, j, seq_len, True)
    return total / (hi - lo + 1)


@njit(cache=True, nogil=True)
def _bounds(i: int, seq_len: int, n_index: int) -> tuple[int, int, int, int]:
    """First and last trajectory (inclusive) of A3's block and of A4's group around trajectory ``i``, as
    ``formulas.block_range`` and ``formulas.group_range``."""
    lo = seq_len * (i // seq_len)
    return lo, min(n_index - 1, lo + seq_len - 1), max(0, i - GROUP_HALF_WIDTH), min(n_index - 1, i + GROUP_HALF_WIDTH)


@njit(cache=True, nogil=True)
def _rates(out: np.ndarray, past_sorted: float, row_sorted: float, current_sorted: float, last: float,
           past: float, block_mean: float, group_mean: float) -> None:
    """A1..A4 of one rank into ``out`` (4 values), the expressions of ``formulas.attribute_rates``."""
    out[0] = past_sorted / (row_sorted + EPS)
    out[1] = current_sorted / (last + EPS)
    out[2] = past / (block_mean + EPS)
    out[3] = past / (group_mean + EPS)


def _block(raw: np.ndarray, col_max: np.ndarray, seq_len: int, margin: float, margin_raw: float,
          attributes: np.ndarray, rank_diagonals: np.ndarray, single_match: np.ndarray,
          sequence_diagonal: np.ndarray, sequence_distance: np.ndarray, sequence_max: np.ndarray,
          sequence_values: np.ndarray, sequence_index: np.ndarray, single_values: np.ndarray,
          single_index: np.ndarray) -> None:
    """``block_features`` of the block ``raw`` (R x W: all references, W = w + L - 1 consecutive query columns,
    any strides) into the outputs over its ``w`` queries; ``col_max`` is the block's column maxima in float64
    (0 replaced by 1). ``margin`` bounds twice the screening error of the normalised sums, ``margin_raw`` of S.
    ``sequence_values``/``sequence_index`` (``w x n``, ``n`` at most the diagonals) receive the ``n`` smallest ``S``
    and their diagonals, ``single_values``/``single_index`` (``w x n'``) the ``n'`` smallest ``D[r, a]`` and their
    references, ascending, equal values lowest index first; a width of 0 computes none."""
    n_ref, width = raw.shape
    n_queries = width - seq_len + 1
    n_diag = n_ref - seq_len + 1
    n_ranks = attributes.shape[1]
    n_sequence, n_single = sequence_values.shape[1], single_values.shape[1]
    gd, gr = (n_diag + GROUP - 1) // GROUP, (n_ref + GROUP - 1) // GROUP
    # the smallest S by parts of FINE when candidates are asked for (the sequence match alone: by GROUP, as before)
    s_size = FINE if n_sequence > 0 else GROUP
    h_full = np.full((gd, n_queries), np.inf)
    h_past = np.full((gd, n_queries), np.inf)
    h_smin = np.full(((n_diag + s_size - 1) // s_size, n_queries), np.inf)
    h_smax = np.full((gd, n_queries), np.inf)  # holds -max, so that the same selection finds it
    h_row = np.full((gr, n_queries), np.inf)
    h_cur = np.full((gr, n_queries), np.inf)
    # the single-frame candidates: exact values, kept as the rows stream by (ascending r: ties lowest r first);
    # ``above`` is each query's n-th smallest so far once it has n (+inf before), which a new value must be below
    filled_single = np.zeros(n_queries, dtype=np.int64)
    above = np.full(n_queries, np.inf)
    ring = seq_len + 1
    t = np.zeros((ring, width + 1))  # t[r % ring, c + 1]: sum along the diagonal ending at (r, c); t[:, 0] = 0
    v = np.zeros((ring, width + 1))
    inverse = 1.0 / col_max  # screening only: x * (1 / m) is within 2 ulp of x / m, inside the error bound
    x = np.empty(width)
    y = np.empty(width)
    h = np.zeros(width + 1)  # h[c + 1]: sum of x[0 .. c] along the row (any order: screening only)
    chains = 4
    part = (width + chains - 1) // chains
    best = raw[0, seq_len - 1 :].copy()
    single_match[:] = 0
    for r in range(n_ref):
        row = raw[r]
        for c in range(width):
            yc = np.float64(row[c])
            y[c] = yc
            x[c] = yc * inverse[c]
        tc, tp, vc, vp = t[r % ring], t[(r - 1) % ring], v[r % ring], v[(r - 1) % ring]
        tc1, vc1 = tc[1:], vc[1:]
        for c in range(width):
            tc1[c] = tp[c] + x[c]
        for c in range(width):
            vc1[c] = vp[c] + y[c]
        # Row prefix in 4 independent chains (one chain is bound by the add latency), then the chains' offsets.
        a0 = a1 = a2 = a3 = 0.0
        for c in range(part):
            a0 += x[c]
            h[c + 1] = a0
            if part + c < width:
                a1 += x[part + c]
                h[part + c + 1] = a1
            if 2 * part + c < width:
                a2 += x[2 * part + c]
                h[2 * part + c + 1] = a2
            if 3 * part + c < width:
                a3 += x[3 * part + c]
                h[3 * part + c + 1] = a3
        for k in range(1, chains):
            offset = h[k * part]
            for c in range(k * part + 1, min(width, (k + 1) * part) + 1):
                h[c] += offset
        g = r // GROUP
        hl, head = h[seq_len - 1 :], h_row[g]
        for j in range(n_queries):  # one subtraction and minimum per loop: several in one loop do not vectorise
            a = hl[j] - h[j]
            head[j] = a if a < head[j] else head[j]
        _minimum(h_cur[g], x[seq_len - 1 :])
        if n_single > 0:
            _keep_smallest(y[seq_len - 1 :], above, r, single_values, single_index, filled_single)
        current = row[seq_len - 1 :]
        for j in range(n_queries):
            if current[j] < best[j]:
                best[j] = current[j]
                single_match[j] = r
        if r >= seq_len - 1:
            g = (r - seq_len + 1) // GROUP
            to, vo = t[(r - seq_len) % ring], v[(r - seq_len) % ring]
            tcl, tpl, vcl = tc[seq_len:], tp[seq_len - 1 :], vc[seq_len:]
            head = h_full[g]
            for j in range(n_queries):
                a = tcl[j] - to[j]
                head[j] = a if a < head[j] else head[j]
            head = h_past[g]
            for j in range(n_queries):
                a = tpl[j] - to[j]
                head[j] = a if a < head[j] else head[j]
            head = h_smin[(r - seq_len + 1) // s_size]
            for j in range(n_queries):
                a = vcl[j] - vo[j]
                head[j] = a if a < head[j] else head[j]
            head = h_smax[g]
            for j in range(n_queries):
                a = vo[j] - vcl[j]
                head[j] = a if a < head[j] else head[j]

    # Exact recomputation: every kind's candidates of group g together, so that g's rows are read once. The
    # smallest S are as many as the candidates asked for (the first is the sequence match); the raw current values
    # are exact already (their margin is 0) and scanned only when candidates are asked for.
    p_smin = h_smin  # the parts of S, with candidates; their group minima are the heads
    if n_sequence > 0:
        h_smin = _coarse(p_smin, gd)
    heads = (h_full, h_past, h_row, h_cur, h_smin, h_smax)
    counts = (n_ranks, n_ranks, n_ranks, n_ranks, max(1, n_sequence), 1)
    sizes = (n_diag, n_diag, n_ref, n_ref, n_diag, n_diag)
    kinds = (0, 1, 2, 3, 4, 5)
    margins = (margin, margin, margin, margin, margin_raw, margin_raw)
    values = [np.empty((n_queries, c)) for c in counts]
    index = [np.empty((n_queries, c), dtype=np.int64) for c in counts]
    filled = [np.zeros(n_queries, dtype=np.int64) for _ in counts]
    limits = [_limits(heads[q], counts[q], margins[q]) for q in range(6)]
    for g in range(gr):
        for q in range(6):
            if q == 4 and n_sequence > 0:
                _scan_parts(heads[q], p_smin, limits[q], g, sizes[q], kinds[q], raw, col_max, seq_len, values[q],
                            index[q], filled[q])
            else:
                _scan(heads[q], limits[q], g, sizes[q], kinds[q], raw, col_max, seq_len, values[q], index[q],
                      filled[q])
    full_index, past_sorted, row_sorted, current_sorted = index[0], values[1], values[2], values[3]
    for j in range(n_queries):
        for k in range(n_ranks):
            i = full_index[j, k]
            rank_diagonals[j, k] = i
            last = np.float64(raw[i + seq_len - 1, j + seq_len - 1]) / col_max[j + seq_len - 1]
            past = _diag(raw, col_max, i, j, seq_len - 1, True)
            block_lo, block_hi, group_lo, group_hi = _bounds(i, seq_len, n_diag)
            _rates(attributes[j, k], past_sorted[j, k], row_sorted[j, k], current_sorted[j, k], last, past,
                   _mean_full(raw, col_max, j, block_lo, block_hi, seq_len),
                   _mean_full(raw, col_max, j, group_lo, group_hi, seq_len))
        sequence_distance[j] = values[4][j, 0]
        sequence_diagonal[j] = index[4][j, 0]
        sequence_max[j] = -values[5][j, 0]  # the smallest -S, as the numpy path's ``largest`` selection
        for k in range(n_sequence):
            sequence_values[j, k] = values[4][j, k]
            sequence_index[j, k] = index[4][j, k]


_COMPILED: dict[tuple[str, np.dtype], Any] = {}


def compiled(name: str, dtype: np.dtype) -> Any:
    """The entry point ``name`` (``block``) for a float32 or float64 matrix, compiled for one
    signature only (any strides, read-only or not) and loaded from numba's on-disk cache on first use: a process
    loads only what it runs (each compiled version costs about 0.1 s to load, about 9 s to compile)."""
    key = (name, np.dtype(dtype))
    if key not in _COMPILED:
        nb_type = types.float32 if key[1] == np.float32 else types.float64
        function, signature = {"block": (_block, _block_signature)}[name]
        _COMPILED[key] = njit(signature(nb_type), cache=True, nogil=True)(function)
    return _COMPILED[key]


# the candidates of the training-free scorers (method §12): the n smallest S and D[r, a] and their indices
CANDIDATE_KEYS = ("sequence_candidates", "sequence_candidate_diagonals", "single_candidates",
                  "single_candidate_references")


def empty_outputs(n_queries: int, n_ranks: int, n_sequence: int = 0, n_single: int = 0) -> dict[str, np.ndarray]:
    """The arrays ``block_features`` returns, for ``n_queries`` queries, ``n_ranks`` ranks and the ``n_sequence``
    and ``n_single`` candidates (``CANDIDATE_KEYS``; widths of 0: none asked for), to be filled."""
    return {
        "attributes": np.empty((n_queries, n_ranks, 4)),
        "rank_diagonals": np.empty((n_queries, n_ranks), dtype=np.int64),
        "single_match": np.empty(n_queries, dtype=np.int64),
        "sequence_diagonal": np.empty(n_queries, dtype=np.int64),
        "sequence_distance": np.empty(n_queries),
        "sequence_max": np.empty(n_queries),
        "sequence_candidates": np.empty((n_queries, n_sequence)),
        "sequence_candidate_diagonals": np.empty((n_queries, n_sequence), dtype=np.int64),
        "single_candidates": np.empty((n_queries, n_single)),
        "single_candidate_references": np.empty((n_queries, n_single), dtype=np.int64),
    }


def column_blocks(raw: np.ndarray, col_max: np.ndarray, seq_len: int, n_ranks: int, margin: float,
                  margin_raw: float, block_queries: int = BLOCK_QUERIES, n_sequence: int = 0,
                  n_single: int = 0) -> dict[str, np.ndarray]:
    """``block`` over all queries of ``raw`` (R x W), in blocks of ``block_queries`` query columns on
    ``thread_count()`` threads, with ``n_sequence`` and ``n_single`` candidates (``empty_outputs``). The margins
    must hold for blocks of ``block_queries + L - 1`` columns."""
    n_out = raw.shape[1] - seq_len + 1
    out = empty_outputs(n_out, n_ranks, n_sequence, n_single)
    keys = ("attributes", "rank_diagonals", "single_match", "sequence_diagonal", "sequence_distance", "sequence_max",
            *CANDIDATE_KEYS)

    block = compiled("block", raw.dtype)

    def run(start: int) -> None:
        stop = min(n_out, start + block_queries)
        block(raw[:, start : stop + seq_len - 1], col_max[start : stop + seq_len - 1], seq_len, margin, margin_raw,
              *(out[key][start:stop] for key in keys))

    starts = range(0, n_out, block_queries)
    threads = min(thread_count(), len(starts))
    if threads == 1:
        for start in starts:
            run(start)
    else:
        with ThreadPoolExecutor(threads) as pool:
            list(pool.map(run, starts))
    return out
