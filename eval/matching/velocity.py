"""SeqSLAM's velocity search (SPEC 11): sequence matching along trajectories of several slopes, and the four
attributes of the best trajectory ending at each reference.

A velocity ``v`` is reference frames per query frame. The trajectory of length ``L`` ending at reference ``r`` and
query ``a`` visits ``(r - o_k(v), a - L + 1 + k)`` for ``k = 0 .. L-1``, with ``o_k(v) = floor(v (L-1-k) + 0.5)``.
With the velocities ``(1.0,)`` this is SPEC 4's diagonal, and ``eval.matching.attributes`` computes it.

``velocity_block_features`` computes everything ``attributes.block_features`` reports, for any velocities, on one
block of query columns. Unlike the fixed matcher's running sums along diagonals, trajectories of different queries
are not segments of one line (the offsets are rounded), so every sum is computed as defined: per velocity and term
one shifted addition over the block (``|V| L R`` additions per query), each ``0 + x_0 + x_1 + ...`` in float64 in
this order. Every number is therefore exact, whatever the block split, and with ``(1.0,)`` equals the fixed
matcher's bit for bit. ``velocity_kernels`` (numba) computes the same numbers in one pass per query, chosen as
``attributes._kernels`` allows and where it pays (``KERNEL_MIN_WORK``).
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from types import ModuleType

import numpy as np

from vpr_smr.core.constants import EPS, GROUP_HALF_WIDTH
from vpr_smr.eval.matching.checks import check_finite

__all__ = ["check_velocities", "first_reference", "offsets", "search_order", "velocity_block_features"]


def check_velocities(velocities: Sequence[float], name: str = "velocities") -> tuple[float, ...]:
    """The velocities as a tuple of floats, or ValueError naming ``name``: at least one, each finite and > 0, no
    repeats."""
    values = tuple(float(v) for v in velocities)
    if not values:
        raise ValueError(f"{name}: give at least one velocity (reference frames per query frame), e.g. [1.0]")
    bad = [v for v in values if not (math.isfinite(v) and v > 0)]
    if bad:
        raise ValueError(f"{name}: velocities are reference frames per query frame, each > 0; got {bad[0]}")
    if len(set(values)) != len(values):
        raise ValueError(f"{name}: {list(values)} repeats a velocity")
    return values


def offsets(velocity: float, seq_len: int) -> np.ndarray:
    """``o_k(v) = floor(v (L-1-k) + 0.5)`` for ``k = 0 .. L-1``: how far before the end reference the trajectory
    is at the ``k``-th query of the window (``o_{L-1} = 0``)."""
    k = np.arange(seq_len)
    out: np.ndarray = np.floor(velocity * (seq_len - 1 - k) + 0.5).astype(np.int64)
    return out


def first_reference(seq_len: int, velocities: Sequence[float]) -> int:
    """``r_min``: the lowest end reference with a valid trajectory (``r - o_0(v) >= 0`` for some ``v``); the
    attributes' index ``i`` counts from it (``L - 1`` for the fixed matcher)."""
    return min(int(offsets(v, seq_len)[0]) for v in velocities)


def search_order(velocities: Sequence[float]) -> tuple[float, ...]:
    """The velocities in the order of SPEC 11's tie rule: closest to 1 first, then the smaller. Scanning them in
    this order and keeping a trajectory only when it is strictly better implements that rule."""
    # rounded: 0.6 and 1.4 are equally close to 1 as written, though |0.6 - 1| and |1.4 - 1| differ in float64
    return tuple(sorted(velocities, key=lambda v: (round(abs(v - 1.0), 12), v)))


# --- one block of query columns: the attributes along the best trajectories -------------------------------------

# Queries per numpy pass: about this many values per (queries x references) float64 array, so that the dozen arrays
# that one pass touches stay in the cache (measured at R = 3000, L = 10, |V| = 9: 8 times more values per pass is
# 1.4 times slower, 4 times fewer 1.3 times slower: numpy's cost per call).
CHUNK_VALUES = 1 << 15
SCREEN_GROUP = 32  # values per group of the K-smallest selection (strided groups, as attributes._select)
# The compiled kernel (velocity_kernels) costs about 0.5-0.7 s per process before its first result (numba's import
# and first dispatch, its on-disk cache warm), then saves 1.5-4 ns per unit of work (|V| L R additions per query;
# benchmarks/velocity.py): it pays from about 300 M units (a 3000 x 3000 matrix is 108 M at |V| = 3, L = 4, 810 M
# at |V| = 9, L = 10). Once loaded, it is used from LOADED_MIN_WORK units per call on (below, threads do not pay).
KERNEL_MIN_WORK = 300_000_000
LOADED_MIN_WORK = 1_000_000


def _float_block(columns: np.ndarray) -> np.ndarray:
    """The block as float32 or float64 (any other numeric dtype as float64, exactly), 2-D."""
    from vpr_smr.eval.matching.attributes import _block_dtype  # here: attributes imports this module

    raw = np.asarray(columns)
    if raw.ndim != 2:
        raise ValueError(f"expected a block of query columns (columns x references), got shape {raw.shape}")
    return raw.astype(_block_dtype(raw.dtype), copy=False)


def _check_block(raw: np.ndarray, seq_len: int, n_ranks: int, velocities: tuple[float, ...],
                 first_column: int) -> int:
    """``r_min``, after checking the block's shape against ``L``, ``K`` and the velocities."""
    n_cols, n_ref = raw.shape
    if seq_len < 2:
        raise ValueError(f"sequence length must be at least 2, got {seq_len}")
    if n_cols < seq_len:
        raise ValueError(f"a block of {n_cols} query columns holds no query of sequence length {seq_len} (query "
                         f"columns {first_column}..{first_column + n_cols - 1})")
    r_min = first_reference(seq_len, velocities)
    if n_ref - r_min < 1:
        raise ValueError(f"{n_ref} references are too few for sequence length {seq_len} at velocities "
                         f"{list(velocities)}: the slowest trajectory spans {r_min + 1} references")
    if not 1 <= n_ranks <= n_ref - r_min:
        raise ValueError(f"n_ranks must be 1 .. {n_ref - r_min} (the end references with a trajectory), got {n_ranks}")
    return r_min


def _column_max(raw: np.ndarray, first_column: int) -> np.ndarray:
    """Each column's maximum over all references, float64, a zero maximum replaced by 1 (as SPEC 5 divides), or
    ``NonFiniteError`` when the block (whose first column is ``first_column``) holds NaN or inf (they show up in
    the maxima and minima)."""
    raw_max = raw.max(axis=1)
    if not (np.all(np.isfinite(raw_max)) and np.all(np.isfinite(raw.min(axis=1)))):
        check_finite(raw, first_column=first_column, queries_first=True)
    col_max: np.ndarray = raw_max.astype(np.float64)
    col_max[col_max == 0] = 1.0
    return col_max


def velocity_block_features(columns: np.ndarray, seq_len: int, n_ranks: int, velocities: Sequence[float],
                            first_column: int = 0, *, total_queries: int | None = None) -> dict[str, np.ndarray]:
    """SPEC 11's sequence matching and attributes for the queries of one block of ``Wb`` consecutive query columns.

    ``columns`` is ``(Wb, R)``: row ``q`` is column ``c + q`` of the distance matrix (``attributes.read_columns``);
    its queries are the last ``w = Wb - L + 1`` columns. Returns ``attributes.block_features``' keys over them, on the
    index ``i = r - r_min`` of the end reference (``r_min = first_reference(L, velocities)``): ``attributes``
    ``(w, K, 4)``, ``rank_diagonals`` ``(w, K)``, ``single_match``, ``sequence_diagonal`` (``argmin_i S``, lowest ``i``
    on ties), ``sequence_distance``, ``sequence_max`` (``max_i S``), and ``sequence_velocity``: ``v*`` at the sequence
    match. Every value is the definition's float64 value, summed in its order, so any block split gives the same
    numbers, and ``velocities=(1.0,)`` gives ``attributes.block_features``' numbers bit for bit.

    ``n_ranks`` must be 1 .. ``R - r_min``. ``first_column`` is ``c``, so that an error on NaN or inf gives the
    matrix's own column.
    ``total_queries``: the queries of the whole matrix this block belongs to (default: the block's), so that the
    compiled kernel is chosen when the whole run pays for its fixed cost (``KERNEL_MIN_WORK``); the results are the
    same on either path.
    """
    values = check_velocities(velocities)
    raw = _float_block(columns)
    r_min = _check_block(raw, seq_len, n_ranks, values, first_column)
    order = search_order(values)
    table = np.stack([offsets(v, seq_len) for v in order])  # (|V|, L), in the tie rule's order
    col_max = _column_max(raw, first_column)
    n_queries = raw.shape[0] - seq_len + 1
    per_query = len(order) * seq_len * raw.shape[1]
    kernels = _velocity_kernels(per_query * n_queries, per_query * max(n_queries, total_queries or 0))
    if kernels is not None:
        out: dict[str, np.ndarray] = kernels.block_features(raw, col_max, table, r_min, n_ranks)
    else:
        step = max(1, CHUNK_VALUES // raw.shape[1])
        parts = [_numpy_chunk(raw[j : min(n_queries, j + step) + seq_len - 1], col_max[j : j + step + seq_len - 1],
                              table, r_min, n_ranks) for j in range(0, n_queries, step)]
        out = {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}
    out["sequence_velocity"] = np.asarray(order, dtype=np.float64)[out.pop("sequence_index")]
    return out


def _velocity_kernels(work: int, total_work: int) -> ModuleType | None:
    """The compiled kernel (``velocity_kernels``) for a block of ``work`` units (``|V| L R`` per query) of a run of
    ``total_work``, or None for the numpy path.

    ``attributes._kernels`` says what is allowed (``attributes.KERNEL``, ``VPR_SMR_KERNEL``, numba importable): the
    compiled path when forced, numpy when forced or numba is missing; else compiled from ``KERNEL_MIN_WORK`` units
    of the run on, or from ``LOADED_MIN_WORK`` units of the block once this process has loaded it."""
    from vpr_smr.eval.matching import attributes

    if attributes._kernels(0) is None:  # only a forced "numba" gives the compiled kernels at any size
        loaded = "vpr_smr.eval.matching.velocity_kernels" in sys.modules
        if total_work < KERNEL_MIN_WORK and not (loaded and work >= LOADED_MIN_WORK):
            return None
        if attributes._kernels(attributes.KERNEL_MIN_VALUES) is None:  # numpy forced, or numba missing
            return None
    from vpr_smr.eval.matching import velocity_kernels

    return velocity_kernels


def _numpy_chunk(raw: np.ndarray, col_max: np.ndarray, table: np.ndarray, r_min: int,
                 n_ranks: int) -> dict[str, np.ndarray]:
    """The features of the queries of ``raw`` (``(w + L - 1, R)``, a slice of the block) in numpy: per velocity and
    per term one shifted addition over the chunk, each sum accumulated ``0 + x_0 + x_1 + ...`` as defined."""
    seq_len = table.shape[1]
    n_cols, n_ref = raw.shape
    w = n_cols - seq_len + 1
    y = raw.astype(np.float64, copy=False)
    x = y / col_max[:, None]  # Dn, by division as SPEC 5 (not a multiplication by the inverse)
    s, full, past, best = _best_trajectories(y, x, table, r_min)
    rows = np.arange(w)

    sequence_index = np.argmin(s, axis=1)  # first index on ties
    _, rank_index = _smallest(full, n_ranks, with_index=True)
    past_sorted = _smallest(past, n_ranks)[0]
    row_past = np.zeros((w, n_ref))
    for k in range(seq_len - 1):
        row_past += x[k : k + w]
    row_past_sorted = _smallest(row_past, n_ranks)[0]
    current = x[seq_len - 1 :]
    current_sorted = _smallest(current, n_ranks)[0]

    past_ranked = np.take_along_axis(past, rank_index, axis=1)
    last = np.take_along_axis(current, rank_index + r_min, axis=1)  # traj[L-1] = Dn[r, a]: o_{L-1} = 0
    block_lo = seq_len * (rank_index // seq_len)
    n_index = full.shape[1]
    block_mean = _mean(full, block_lo, np.minimum(n_index - 1, block_lo + seq_len - 1))
    group_mean = _mean(full, np.maximum(0, rank_index - GROUP_HALF_WIDTH),
                       np.minimum(n_index - 1, rank_index + GROUP_HALF_WIDTH))
    attributes = np.stack([
        past_sorted / (row_past_sorted + EPS),
        current_sorted / (last + EPS),
        past_ranked / (block_mean + EPS),
        past_ranked / (group_mean + EPS),
    ], axis=-1)
    return {
        "attributes": attributes,
        "rank_diagonals": rank_index.astype(np.int64),
        "single_match": np.argmin(raw[seq_len - 1 :], axis=1).astype(np.int64),
        "sequence_diagonal": sequence_index.astype(np.int64),
        "sequence_distance": s[rows, sequence_index],
        "sequence_max": s.max(axis=1),
        "sequence_index": best[rows, sequence_index],
    }


def _best_trajectories(y: np.ndarray, x: np.ndarray, table: np.ndarray,
                       r_min: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``S``, ``full``, ``past`` and the index of ``v*`` (in ``table``'s order) for every query of the chunk and
    every end reference ``r = r_min + i``: arrays ``(w, N)``, ``N = R - r_min``.

    ``y`` holds the chunk's raw columns in float64 and ``x`` the normalised ones, both ``(w + L - 1, R)``. The
    velocities are scanned in ``table``'s order (the tie rule's) and a trajectory replaces the best one only when
    its ``S`` is strictly smaller; where no earlier velocity had a valid trajectory it is taken as it is.
    """
    n_cols, n_ref = y.shape
    seq_len = table.shape[1]
    w, n_index = n_cols - seq_len + 1, n_ref - r_min
    s, full, past = (np.empty((w, n_index)) for _ in range(3))
    best = np.empty((w, n_index), dtype=np.int64)
    covered = n_index  # indices covered..N-1 have a trajectory so far: validity r >= o_0(v) is a suffix
    for v, offs in enumerate(table):
        first = int(offs[0])  # the lowest valid end reference
        lo, n = first - r_min, n_ref - first
        if n <= 0:  # too slow or too fast for these references: no trajectory fits
            continue
        s_v, f_v = np.zeros((w, n)), np.zeros((w, n))
        for k in range(seq_len - 1):
            start = first - int(offs[k])  # reference of term k for the end reference `first`
            s_v += y[k : k + w, start : start + n]
            f_v += x[k : k + w, start : start + n]
        s_v += y[seq_len - 1 :, first:]  # o_{L-1} = 0: the current query's own reference
        full_v = f_v + x[seq_len - 1 :, first:]
        if lo < covered:  # no earlier velocity reaches these end references
            new = slice(0, covered - lo)
            s[:, lo:covered], full[:, lo:covered], past[:, lo:covered] = s_v[:, new], full_v[:, new], f_v[:, new]
            best[:, lo:covered] = v
        old = max(lo, covered)
        if old < n_index:
            take = s_v[:, old - lo :] < s[:, old:]
            np.copyto(s[:, old:], s_v[:, old - lo :], where=take)
            np.copyto(full[:, old:], full_v[:, old - lo :], where=take)
            np.copyto(past[:, old:], f_v[:, old - lo :], where=take)
            np.copyto(best[:, old:], v, where=take)
        covered = min(covered, lo)
    return s, full, past, best


def _smallest(values: np.ndarray, count: int, with_index: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """The ``count`` smallest values of each row (ascending) and, ``with_index``, their column indices, equal values
    lowest index first (a stable sort's order); without it the index array is empty.

    A bound first: the ``count``-th smallest of the minima of strided groups of ``SCREEN_GROUP`` values is at least
    the row's ``count``-th smallest value, so only the values at or below it are sorted (a few per row)."""
    n_rows, n = values.shape
    group = SCREEN_GROUP if n >= 16 * SCREEN_GROUP else 1
    n_groups = -(-n // group)
    if n_groups * group != n:
        padded = np.full((n_rows, n_groups * group), np.inf)
        padded[:, :n] = values
    else:
        padded = values
    heads = padded.reshape(n_rows, group, n_groups).min(axis=1)
    if count >= n_groups:
        bound = heads.max(axis=1)
    else:
        bound = np.partition(heads, count - 1, axis=1)[:, count - 1]
    rows, cols = np.nonzero(values <= bound[:, None])
    if not with_index:
        picked = values[rows, cols]
        order = np.lexsort((picked, rows))
        keep = np.arange(len(rows)) - np.searchsorted(rows[order], rows[order]) < count
        return picked[order][keep].reshape(n_rows, count), np.empty(0, dtype=np.int64)
    picked = values[rows, cols]
    order = np.lexsort((cols, picked, rows))  # by row, then value, then column: the stable sort's order
    rows, cols, picked = rows[order], cols[order], picked[order]
    keep = np.arange(len(rows)) - np.searchsorted(rows, rows) < count  # position within its row
    return picked[keep].reshape(n_rows, count), cols[keep].reshape(n_rows, count)


def _mean(full: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Mean of ``full[q, m]`` over ``m = lo .. hi`` (inclusive, per query ``q`` and rank): ``total = 0 + full_lo +
    full_{lo+1} + ...``, then ``total / count``, as ``attributes._mean_full`` (SPEC 5's block and group sums)."""
    width = int((hi - lo).max()) + 1
    total = np.zeros(lo.shape)
    for t in range(width):
        inside = lo + t <= hi
        total += np.where(inside, np.take_along_axis(full, np.minimum(lo + t, hi), axis=1), 0.0)
    mean: np.ndarray = total / (hi - lo + 1)
    return mean
