"""Compiled (numba) twin of ``openseqslam``'s local contrast enhancement (``OpenSeqSLAM._enhanced``): the same
numbers, bit for bit, in one pass over each query column instead of ``2 (E + 1)`` passes over a block.

Each column is taken ``TILE`` reference rows at a time; for each row of the window (top to bottom, as the numpy path
adds its shifted copies and as a window's mean reads it) the tile's running sums grow by one vectorised loop held in
the cache. Rows of the window outside the split are left out, which is what the numpy path's added zeros do
(``x + 0.0 == x``). The mean, the ``ddof = 1`` standard deviation and the quotient are the numpy path's operations in
its order; a window of equal distances (no change between neighbouring rows within it) is ``+inf``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

TILE = 512  # reference rows summed together (their running sums and means stay in the L1 cache)


@njit(cache=True, nogil=True, error_model="numpy")  # numpy's division (x / 0 is inf, no check in the loop)
def enhance(values: np.ndarray, half: int, out: np.ndarray) -> None:  # pragma: no cover - compiled
    """``out[c, r]``: the enhancement of ``values[c, r]`` (``values``: float64, query columns as rows)."""
    n_cols, n_ref = values.shape
    total = np.empty(TILE)
    squares = np.empty(TILE)
    count = np.empty(TILE)
    changes = np.empty(n_ref, dtype=np.int64)
    for c in range(n_cols):
        column = values[c]
        changes[0] = 0
        for r in range(1, n_ref):
            changes[r] = changes[r - 1] + (1 if column[r] != column[r - 1] else 0)
        for start in range(0, n_ref, TILE):
            size = min(TILE, n_ref - start)
            # loops without branches, so that the compiler vectorises them (the quotients and roots most of all)
            for t in range(size):
                total[t] = 0.0
                squares[t] = 0.0
                count[t] = min(n_ref, start + t + half + 1) - max(0, start + t - half)
            for j in range(-half, half + 1):  # the window's row r + j, for the rows r where it is in the split
                first, stop = max(0, -j - start), min(size, n_ref - j - start)
                rows, sums = column[start + first + j : start + stop + j], total[first:stop]
                for t in range(stop - first):  # views indexed from 0: no negative-index check, so it vectorises
                    sums[t] += rows[t]
            for t in range(size):
                total[t] = total[t] / count[t]  # the mean, in place
            for j in range(-half, half + 1):
                first, stop = max(0, -j - start), min(size, n_ref - j - start)
                rows, means, sums = column[start + first + j : start + stop + j], total[first:stop], squares[first:stop]
                for t in range(stop - first):
                    deviation = rows[t] - means[t]
                    sums[t] += deviation * deviation
            for t in range(size):
                squares[t] = math.sqrt(squares[t] / (count[t] - 1))  # the standard deviation, in place
            values_out, own = out[c, start : start + size], column[start : start + size]
            for t in range(size):
                values_out[t] = (own[t] - total[t]) / squares[t]
            for t in range(size):  # a window of equal distances: no change between neighbouring rows within it
                r = start + t
                if changes[min(n_ref, r + half + 1) - 1] == changes[max(0, r - half)]:
                    out[c, r] = np.inf
