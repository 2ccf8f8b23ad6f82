"""The attribute formulas of method §5 and the selection of the ``K`` smallest values, in numpy, once for both numpy
paths (``fixed`` and ``velocity``).

The compiled kernels state the same expressions in numba (``kernels._rates`` and ``kernels._bounds``, which
``velocity_kernels`` imports): each value is the same float64 expression in the same order, so every path gives the
same bits.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from vpr_smr.core.constants import EPS, GROUP_HALF_WIDTH

SCREEN_GROUP = 32  # values per group of the K-smallest selection


def block_range(index: np.ndarray, seq_len: int, n_index: int) -> tuple[np.ndarray, np.ndarray]:
    """First and last trajectory (inclusive) of the block of ``L`` consecutive end references that holds
    ``index`` (A3): ``L * (i // L) .. min(N - 1, L * (i // L) + L - 1)``."""
    lo = seq_len * (index // seq_len)
    return lo, np.minimum(n_index - 1, lo + seq_len - 1)


def group_range(index: np.ndarray, n_index: int) -> tuple[np.ndarray, np.ndarray]:
    """First and last trajectory (inclusive) of the group ``i - W .. i + W`` around ``index`` (A4), clipped."""
    return np.maximum(0, index - GROUP_HALF_WIDTH), np.minimum(n_index - 1, index + GROUP_HALF_WIDTH)


def attribute_rates(past_sorted: np.ndarray, row_sorted: np.ndarray, current_sorted: np.ndarray,
                    last: np.ndarray, past_ranked: np.ndarray, block_mean: np.ndarray,
                    group_mean: np.ndarray) -> np.ndarray:
    """A1..A4 of every rank ``k`` (last axis): the rank-``k`` smallest past sum over the rank-``k`` smallest row
    sum of the past, the rank-``k`` smallest current value over the current value of the rank-``k`` trajectory, and
    that trajectory's past sum over its block's and its group's mean full sum; ``EPS`` in every denominator."""
    return np.stack([
        past_sorted / (row_sorted + EPS),
        current_sorted / (last + EPS),
        past_ranked / (block_mean + EPS),
        past_ranked / (group_mean + EPS),
    ], axis=-1)


def group_size(n_values: int) -> int:
    """Values per screening group: 32, strided (group g holds values g, g + G, g + 2G, ...), on long rows."""
    return SCREEN_GROUP if n_values >= 16 * SCREEN_GROUP else 1


def padded(n_rows: int, n_values: int, dtype: np.dtype,
           empty: Callable[[tuple[int, int], np.dtype], np.ndarray] = np.empty) -> np.ndarray:
    """An ``(n_rows, n_values + pad)`` array whose pad columns hold +inf, as ``select`` expects (from ``empty``,
    e.g. a reused scratch array)."""
    group = group_size(n_values)
    out = empty((n_rows, -(-n_values // group) * group), dtype)
    out[:, n_values:] = np.inf
    return out


def select(
    approx: np.ndarray, n_values: int, count: int, margin: float,
    exact: Callable[[np.ndarray, np.ndarray], np.ndarray], largest: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """The ``count`` smallest (``largest``: the largest, ``count`` 1 only) exact values of each row of a screened
    ``approx`` and their column indices, ties to the lowest index (a stable sort).

    ``approx`` holds ``n_values`` screened values per row, then padding (+inf; -inf when ``largest``). Every
    value whose exact value can be among the ``count`` best lies within ``margin`` (twice the bound on
    ``|approx - exact|``) of the ``count``-th best screened value; the ``count``-th best of the groups' best values
    bounds that from above. One reduction over the groups finds it; only the groups within ``margin`` of it are
    scanned, and only their candidates are recomputed by ``exact(rows, cols)`` in float64.
    """
    n_rows, width = approx.shape
    group = group_size(n_values)
    n_groups = width // group
    grouped = approx.reshape(n_rows, group, n_groups)
    heads = -grouped.max(axis=1) if largest else grouped.min(axis=1)
    if count == 1:
        bound = heads.min(axis=1)
    elif count >= n_groups:
        bound = heads.max(axis=1)
    else:
        bound = np.partition(heads, count - 1, axis=1)[:, count - 1]
    limit = bound + bound.dtype.type(margin)
    g_rows, g_cols = np.nonzero(heads <= limit[:, None])
    cols = g_cols[:, None] + n_groups * np.arange(group)
    values = approx[g_rows[:, None], cols]
    hit = (-values if largest else values) <= limit[g_rows, None]
    rows, cols = np.broadcast_to(g_rows[:, None], cols.shape)[hit], cols[hit]
    values = -exact(rows, cols) if largest else exact(rows, cols)
    order = np.lexsort((cols, values, rows))  # by row, then value, then column
    rows, cols, values = rows[order], cols[order], values[order]
    keep = np.arange(len(rows)) - np.searchsorted(rows, rows) < count  # position within its row
    values, cols = values[keep].reshape(n_rows, count), cols[keep].reshape(n_rows, count)
    return (-values if largest else values), cols
