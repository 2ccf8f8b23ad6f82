"""The fixed matcher's fast path (velocity 1 only): the same numbers as the velocity search's, in O(1) per diagonal.

Inside ``matcher.SequenceMatcher`` only: with ``velocities=(1.0,)`` every trajectory is a diagonal, so one block of
query columns is screened by whole-block additions along its diagonals, vectorised over every reference.

1. *Screening.* Every diagonal sum ``full_d``, ``past_d``, the row sums and ``S`` of the block, in float32: for
   ``L <= DIRECT_MAX_LEN`` term by term (``L - 1`` additions of shifted blocks), for longer windows as a difference
   of two running sums along the diagonals (a prefix sum over the block's columns, in diagonal coordinates), whose
   rounding error grows with the block's width. Partial selection finds a bound on each query's ``K``-th smallest
   screened value: the ``K``-th smallest of the minima of strided groups of 32 values (one reduction, then
   ``np.partition`` of a 32 times shorter row).
2. *Exact recomputation.* Every candidate within a rigorous bound of the float32 rounding error of that ``K``-th
   value is recomputed in float64 exactly as the definition does it (``0 + x_0 + x_1 + ...`` in this order), and the
   ``K`` best are taken by a stable sort on (value, diagonal): the tie rule of method §5, equal ``full_d`` lowest
   diagonal first. Only a handful of candidates per query pass the bound (all of them only when values tie
   massively), so this costs ``O(K L)`` per query; so do A3/A4, whose block and group means take ``L + 5`` exact
   ``full_m`` each.

Every reported number is therefore the float64 value of the definition, bit for bit, whatever the block size or the
screening precision (float32 only decides which few candidates are recomputed), and equals the velocity search's
with ``(1.0,)``. The compiled kernel (``kernels``) screens in float64 with the same error bounds, reading the matrix
in its own layout.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from types import ModuleType
from typing import Any

import numpy as np
from numpy.lib.stride_tricks import as_strided

from vpr_smr.eval.matching.checks import NonFiniteError, check_finite
from vpr_smr.eval.matching.formulas import attribute_rates, block_range, group_range, padded, select

# Sequence lengths up to this are screened by direct sums, longer ones by running sums. 9000 x 9000 float32, 12
# candidates (2026-11-27), seconds running sums / direct: on 2 threads (blocks of 1 M values) L 2 0.51 / 0.28, 4
# 0.43 / 0.30, 10 0.49 / 0.40, 12 0.50 / 0.42; on one thread (0.5 M values, whose running sums' bound is 4 times
# tighter) L 4 0.51 / 0.44, 8 0.56 / 0.54, 10 0.56 / 0.60, 12 0.59 / 0.66. Direct sums' error bounds are far
# tighter, so their selections recompute fewer candidates; past about 12 terms their L passes cost more.
DIRECT_MAX_LEN = 12
KERNEL_CHUNK_VALUES = 16 << 20  # values per read of a lazy (HDF5) matrix on the compiled path: 64 MB of float32


class Workspace:
    """The numpy path's large scratch arrays, reused from one block of queries to the next (``SequenceMatcher.features``
    keeps one per matrix). A fresh array of a few MB is mapped anew by the allocator and costs a page fault per 4 KB
    on its first write: up to a fifth of this path's time on a 3000 x 3000 matrix, varying with the process's heap.
    Scratch only: no result is a view of one of these arrays. Each thread gets its own arrays (blocks run on
    several threads at once)."""

    def __init__(self) -> None:
        self._local = threading.local()

    def empty(self, name: str, shape: tuple[int, int], dtype: np.dtype) -> np.ndarray:
        """An uninitialised ``shape`` array of ``dtype``: this thread's one named ``name`` again when it has that
        shape."""
        arrays: dict[str, np.ndarray] = self._local.__dict__.setdefault("arrays", {})
        array = arrays.get(name)
        if array is None or array.shape != shape or array.dtype != dtype:
            array = arrays[name] = np.empty(shape, dtype=dtype)
        return array

    def padded(self, name: str, n_rows: int, n_values: int, dtype: np.dtype) -> np.ndarray:
        """``formulas.padded`` in the array named ``name``."""
        return padded(n_rows, n_values, dtype, lambda shape, dtype: self.empty(name, shape, dtype))


# --- screening: running sums along diagonals --------------------------------------------------------------------


def _diagonal_view(array: np.ndarray, row: int, col: int, shape: tuple[int, int]) -> np.ndarray:
    """Read-only ``view[j, d] = array[row + j, col - j + d]`` (the caller keeps the indices in range)."""
    item = array.strides[1]
    return as_strided(array[row:, col:], shape=shape, strides=(array.strides[0] - item, item), writeable=False)


def _diagonal_prefix(x: np.ndarray, n_queries: int, workspace: Workspace) -> np.ndarray:
    """Prefix sums along the diagonals of the block ``x`` (columns of D as rows, shape ``(Wb, R)``).

    ``out[q + 1, s] = sum_{q' <= q} x[q', s + q' - (w - 1)]`` (terms outside ``x`` are 0) with ``w = n_queries``,
    so that the sum of the ``n`` entries of diagonal ``d`` starting at block column ``j`` is
    ``out[j + n, s] - out[j, s]`` with ``s = d - j + w - 1``. One pass over the block; the Python loop runs over
    its columns only.
    """
    n_cols, n_ref = x.shape
    width = n_ref + n_queries - 1
    out = workspace.empty("prefix", (n_cols + 1, width), x.dtype)
    out[0] = 0
    for q in range(n_cols):  # np.cumsum(axis=0) is 3 times slower than this loop of row additions
        lo = n_queries - 1 - q  # s at which column q's row 0 lies
        s0, s1 = max(lo, 0), min(lo + n_ref, width)
        np.add(out[q, s0:s1], x[q, s0 - lo : s1 - lo], out=out[q + 1, s0:s1])
        out[q + 1, :s0] = out[q, :s0]
        out[q + 1, s1:] = out[q, s1:]
    return out


def _window_sums(prefix: np.ndarray, n_terms: int, n_queries: int, n_diag: int, workspace: Workspace,
                 name: str = "window") -> np.ndarray:
    """``out[j, d]`` = screened sum of the first ``n_terms`` entries of diagonal ``d`` from block column ``j``,
    padded for ``formulas.select`` (the array ``name`` of ``workspace``: each use ends before the next begins)."""
    shape = (n_queries, n_diag)
    out = workspace.padded(name, n_queries, n_diag, prefix.dtype)
    np.subtract(_diagonal_view(prefix, n_terms, n_queries - 1, shape), _diagonal_view(prefix, 0, n_queries - 1, shape),
                out=out[:, :n_diag])
    return out


def _direct_sums(x: np.ndarray, n_terms: int, n_queries: int, n_values: int, step: int,
                 out: np.ndarray) -> np.ndarray:
    """``out[j, v] = x[j, v] + x[j + 1, v + step] + ...`` (``n_terms`` terms; ``step`` 1: along a diagonal, 0: along a
    row) for ``j < n_queries``, ``v < n_values``, in ``out``'s first columns: one whole-block addition per term."""
    window = out[:, :n_values]
    if n_terms == 1:
        window[...] = x[:n_queries, :n_values]
        return out
    dtype = out.dtype  # the additions in ``out``'s precision, whatever ``x``'s
    np.add(x[:n_queries, :n_values], x[1 : 1 + n_queries, step : step + n_values], out=window, dtype=dtype)
    for c in range(2, n_terms):
        np.add(window, x[c : c + n_queries, c * step : c * step + n_values], out=window, dtype=dtype)
    return out


def _error_bound(dtype: np.dtype, n_cols: int, seq_len: int, magnitude: float) -> float:
    """Bound on ``|screened - exact|`` of a window sum: float rounding of prefix sums over ``n_cols`` values of size
    at most ``magnitude`` (both ends, Higham's gamma_n), of the screened inputs, and of the float64 reference sum."""
    unit = float(np.finfo(dtype).eps) / 2
    return magnitude * (unit * (2.2 * n_cols * n_cols + 6 * seq_len + 4) + 1.2e-16 * seq_len * seq_len)


def _value_bound(dtype: np.dtype, magnitude: float) -> float:
    """Bound on ``|screened - exact|`` of one normalised value ``D[r, a] / max``: the screened quotient is rounded
    at most three times (the divisor, the quotient in float64, the result in ``dtype``; an underflow to a subnormal
    costs less than one more ``dtype`` unit at these magnitudes), the float64 reference once. No running sum is
    involved, so the prefix sums' ``n_cols**2`` term of ``_error_bound`` would only widen the scan."""
    unit = float(np.finfo(dtype).eps) / 2
    return magnitude * (4 * unit + 2.5e-16)



def numpy_block_features(
    columns: np.ndarray, seq_len: int, n_ranks: int, screen_dtype: Any = np.float32, first_column: int = 0,
    workspace: Workspace | None = None, n_sequence: int = 0, n_single: int = 0,
) -> dict[str, np.ndarray]:
    """``block_features`` in numpy: float32 (``screen_dtype``) screening by the prefix sums of the block; its scratch
    arrays from ``workspace`` (a new one when None). ``n_sequence``/``n_single``: how many of the smallest ``S`` and
    raw current values ``D[r, a]`` to report with their indices (``kernels.CANDIDATE_KEYS``; at most the diagonals
    and the references)."""
    raw = columns
    work = workspace or Workspace()
    n_cols, n_ref = raw.shape
    n_queries, n_diag, k = n_cols - seq_len + 1, n_ref - seq_len + 1, n_ranks

    raw_max, raw_min = raw.max(axis=1), raw.min(axis=1)  # NaN and inf show up here: no separate pass
    if not (np.all(np.isfinite(raw_max)) and np.all(np.isfinite(raw_min))):
        check_finite(raw, first_column=first_column, queries_first=True)
    col_max = raw_max.astype(np.float64)
    col_max[col_max == 0] = 1.0  # each column divided by its maximum; a zero maximum by 1
    magnitude_raw = float(max(np.abs(raw_max).max(), np.abs(raw_min).max()))
    magnitude = float((np.maximum(np.abs(raw_max), np.abs(raw_min)) / np.abs(col_max)).max()) * (1 + 1e-6)

    def value(j: np.ndarray, r: np.ndarray, normalised: bool) -> np.ndarray:
        """D[r, j] (block column j) in float64, divided by its column maximum."""
        v: np.ndarray = raw[j, r].astype(np.float64)
        return v / col_max[j] if normalised else v

    def diagonal_sum(j: np.ndarray, d: np.ndarray, n_terms: int, normalised: bool) -> np.ndarray:
        """``0 + x_0 + x_1 + ...`` along diagonal d from block column j, the definition's order."""
        acc = np.zeros(len(j))
        for c in range(n_terms):
            acc += value(j + c, d + c, normalised)
        return acc

    def row_sum(j: np.ndarray, r: np.ndarray, n_terms: int) -> np.ndarray:
        acc = np.zeros(len(j))
        for c in range(n_terms):
            acc += value(j + c, r, True)
        return acc

    screen = np.dtype(screen_dtype)
    if screen.itemsize < 8 and not (1e-30 < magnitude_raw < 1e30 and magnitude < 1e30):
        screen = np.dtype(np.float64)  # float32 would under- or overflow
    # Short windows are summed term by term (L - 1 whole-block additions per kind of sum, each sum over L values);
    # longer ones by running sums over the block's columns (two passes whatever L, each over n_cols values).
    direct = seq_len <= DIRECT_MAX_LEN
    span = seq_len if direct else n_cols  # values the screened sums run over: their rounding error grows with it
    margin = 2 * _error_bound(screen, span, seq_len, magnitude)
    margin_raw = 2 * _error_bound(screen, span, seq_len, magnitude_raw)
    x = work.padded("x", n_cols, n_ref, screen)  # the normalised block, padded for the current column's values
    np.divide(raw, col_max.astype(screen)[:, None], out=x[:, :n_ref])

    # Diagonal sums of the normalised window: full_d (L terms) ranks the diagonals, past_d (L-1 terms) gives A1.
    if direct:
        past = _direct_sums(x, seq_len - 1, n_queries, n_diag, 1, work.padded("past", n_queries, n_diag, screen))
        full = work.padded("window", n_queries, n_diag, screen)
        end = seq_len - 1  # the window's last term
        np.add(past[:, :n_diag], x[end : end + n_queries, end : end + n_diag], out=full[:, :n_diag])
    else:
        prefix = _diagonal_prefix(x[:, :n_ref], n_queries, work)
        full = _window_sums(prefix, seq_len, n_queries, n_diag, work)
        past = _window_sums(prefix, seq_len - 1, n_queries, n_diag, work, "past")
        del prefix
    _, rank_diagonals = select(full, n_diag, k, margin, lambda j, d: diagonal_sum(j, d, seq_len, True))
    past_sorted, _ = select(past, n_diag, k, margin, lambda j, d: diagonal_sum(j, d, seq_len - 1, True))
    del full, past

    # Row sums over the L-1 past columns of the window.
    row_past = work.padded("row_past", n_queries, n_ref, screen)
    if direct:
        _direct_sums(x, seq_len - 1, n_queries, n_ref, 0, row_past)
    else:  # a prefix sum over the block's columns
        row_prefix = work.empty("rows", (n_cols + 1, n_ref), screen)
        row_prefix[0] = 0
        for q in range(n_cols):
            np.add(row_prefix[q], x[q, :n_ref], out=row_prefix[q + 1])
        np.subtract(row_prefix[seq_len - 1 : seq_len - 1 + n_queries], row_prefix[:n_queries],
                    out=row_past[:, :n_ref])
        del row_prefix
    row_past_sorted, _ = select(row_past, n_ref, k, margin, lambda j, r: row_sum(j, r, seq_len - 1))
    del row_past

    # The current column's smallest raw values, exact (no margin, as velocity.smallest selects them): the single
    # candidates, the single match (the smallest, lowest index first: np.argmin's) and, where every maximum is
    # positive, the K smallest normalised values too (division by a positive number keeps the order, and each is
    # the same float64 expression as ``value``), so one selection serves all three; an underflow to 0, which could
    # swap the signs of equal zeros, and negative maxima select the normalised values themselves.
    current_max = col_max[seq_len - 1 :]
    positive = bool((current_max > 0).all())
    n_raw = max(n_single, k) if positive else n_single
    current_sorted: np.ndarray | None = None
    if n_raw > 0:
        current_raw = work.padded("current_raw", n_queries, n_ref, raw.dtype)
        current_raw[:, :n_ref] = raw[seq_len - 1 :]
        raw_values, raw_index = select(current_raw, n_ref, n_raw, 0.0, lambda j, r: value(j + seq_len - 1, r, False))
        single_match = raw_index[:, 0]
        if positive:
            current_sorted = raw_values[:, :k] / current_max[:, None]
            if np.any((current_sorted == 0) & (raw_values[:, :k] != 0)):
                current_sorted = None
    else:
        single_match = np.argmin(raw[seq_len - 1 :], axis=1)  # first index on ties, as np.argmin of the column
        raw_values, raw_index = np.empty((n_queries, 0)), np.empty((n_queries, 0), dtype=np.int64)
    if current_sorted is None:
        current_sorted, _ = select(x[seq_len - 1 :], n_ref, k, 2 * _value_bound(screen, magnitude),
                                   lambda j, r: value(j + seq_len - 1, r, True))
    del x
    single_values, single_index = raw_values[:, :n_single], raw_index[:, :n_single]

    # S on the raw distances: its argmin is the sequence match, its extremes the split's threshold range.
    if direct:
        s_approx = _direct_sums(raw, seq_len, n_queries, n_diag, 1, work.padded("window", n_queries, n_diag, screen))
    else:
        prefix = _diagonal_prefix(raw.astype(screen, copy=False), n_queries, work)
        s_approx = _window_sums(prefix, seq_len, n_queries, n_diag, work)
        del prefix
    # the smallest S: the sequence match and distance, then the scorers' candidates (the first of them is the match)
    s_min, s_arg = select(s_approx, n_diag, max(1, n_sequence), margin_raw,
                          lambda j, d: diagonal_sum(j, d, seq_len, False))
    s_approx[:, n_diag:] = -np.inf
    s_max, _ = select(s_approx, n_diag, 1, margin_raw, lambda j, d: diagonal_sum(j, d, seq_len, False), largest=True)
    del s_approx

    # A2..A4 of the ranked diagonals: a few values each, recomputed exactly.
    j = np.repeat(np.arange(n_queries), k)
    i = rank_diagonals.ravel()
    past_ranked = diagonal_sum(j, i, seq_len - 1, True).reshape(n_queries, k)
    last = value(j + seq_len - 1, i + seq_len - 1, True).reshape(n_queries, k)  # diag_i[L-1]
    block_mean = _mean_full(diagonal_sum, j, *block_range(i, seq_len, n_diag), seq_len)
    group_mean = _mean_full(diagonal_sum, j, *group_range(i, n_diag), seq_len)
    attributes = attribute_rates(past_sorted, row_past_sorted, current_sorted, last, past_ranked,
                                 block_mean.reshape(n_queries, k), group_mean.reshape(n_queries, k))
    return {
        "attributes": attributes,
        "rank_diagonals": rank_diagonals.astype(np.int64),
        "single_match": single_match.astype(np.int64),
        "sequence_diagonal": s_arg[:, 0].astype(np.int64),
        "sequence_distance": s_min[:, 0],
        "sequence_max": s_max[:, 0],
        "sequence_candidates": s_min[:, :n_sequence],
        "sequence_candidate_diagonals": s_arg[:, :n_sequence].astype(np.int64),
        "single_candidates": single_values,
        "single_candidate_references": single_index.astype(np.int64),
    }


def _compiled_features(kernels: ModuleType, raw: np.ndarray, seq_len: int, n_ranks: int, first_column: int,
                       block_queries: int | None = None, n_sequence: int = 0,
                       n_single: int = 0) -> dict[str, np.ndarray] | None:
    """``block_features`` of ``raw`` (references x query columns, float32/float64, any strides) by the compiled
    kernel, with ``n_sequence`` and ``n_single`` candidates; None when the values' range is too extreme for its
    float64 screening (the numpy path then runs)."""
    step = min(block_queries or kernels.BLOCK_QUERIES, kernels.BLOCK_QUERIES)
    # numpy's reductions along the rows read the matrix in its layout as fast as a kernel would, without a second
    # compiled entry point to load (each costs about 0.85 s per process); NaN and inf show up in the extremes
    col_max, col_min = raw.max(axis=0), raw.min(axis=0)
    if not (np.all(np.isfinite(col_max)) and np.all(np.isfinite(col_min))):
        check_finite(raw, first_column=first_column)
    col_max64 = col_max.astype(np.float64)
    col_max64[col_max64 == 0] = 1.0  # a zero maximum divides by 1
    size = np.maximum(np.abs(col_max), np.abs(col_min)).astype(np.float64)
    magnitude_raw = float(size.max())
    magnitude = float((size / np.abs(col_max64)).max()) * (1 + 1e-6)
    # Far from 1 the float64 running sums could overflow or lose the relative error bound (subnormals).
    if not (1e-200 < magnitude_raw < 1e200 and magnitude < 1e200):
        return None
    n_cols = step + seq_len - 1
    margin = 2 * _error_bound(np.dtype(np.float64), n_cols, seq_len, magnitude)
    margin_raw = 2 * _error_bound(np.dtype(np.float64), n_cols, seq_len, magnitude_raw)
    out: dict[str, np.ndarray] = kernels.column_blocks(raw, col_max64, seq_len, n_ranks, margin, margin_raw, step,
                                                       n_sequence, n_single)
    return out


def _mean_full(diagonal_sum: Callable[..., np.ndarray], j: np.ndarray, lo: np.ndarray, hi: np.ndarray,
               seq_len: int) -> np.ndarray:
    """Mean of ``full_m`` over the diagonals ``m = lo .. hi`` (inclusive) of block column ``j``: the block and
    group sums of method §5 (a sum over ``L`` entries of the entry-wise mean of those diagonals)."""
    width = int((hi - lo).max()) + 1
    offset = np.arange(width)
    inside = lo[:, None] + offset <= hi[:, None]
    # every full_m at once (one exact sum per (j, m), as one at a time), then added in the order m = lo .. hi
    full = diagonal_sum(np.repeat(j, width), np.minimum(lo[:, None] + offset, hi[:, None]).ravel(), seq_len,
                        True).reshape(len(j), width)
    total = np.zeros(len(j))
    for t in range(width):
        total += np.where(inside[:, t], full[:, t], 0.0)
    mean: np.ndarray = total / (hi - lo + 1)
    return mean



def block_features(raw: np.ndarray, seq_len: int, n_ranks: int, screen_dtype: Any, first_column: int,
                   kernels: ModuleType | None, workspace: Workspace | None = None, n_sequence: int = 0,
                   n_single: int = 0) -> dict[str, np.ndarray]:
    """The fixed matcher's numbers for one block ``raw`` (``(Wb, R)``, float32/float64), with ``n_sequence`` and
    ``n_single`` candidates: by the compiled ``kernels`` when given (and the values' range allows its float64
    screening), else in numpy (``workspace``: its scratch arrays, reused over a matrix's blocks)."""
    if kernels is not None:
        out = _compiled_features(kernels, raw.T, seq_len, n_ranks, first_column, None, n_sequence, n_single)
        if out is not None:
            return out
    return numpy_block_features(raw, seq_len, n_ranks, screen_dtype, first_column, workspace, n_sequence, n_single)


def compiled_matrix_features(kernels: ModuleType, matrix: Any, seq_len: int, n_ranks: int, n_sequence: int = 0,
                             n_single: int = 0) -> dict[str, np.ndarray] | None:
    """The fixed matcher's numbers for every query of a whole matrix by the compiled kernel, with ``n_sequence``
    and ``n_single`` candidates, reading the matrix in its own layout: a float32/float64 array or memmap as one view
    (no copy), anything else (HDF5, integers to convert) in chunks of whole rows of about ``KERNEL_CHUNK_VALUES``
    values. None when a chunk's range is too extreme for the kernel's float64 screening."""
    n_ref, n_query = (int(n) for n in matrix.shape)
    n_out = n_query - seq_len + 1
    in_place = isinstance(matrix, np.ndarray) and matrix.dtype in (np.float32, np.float64)
    chunk = n_out if in_place else max(kernels.BLOCK_QUERIES, KERNEL_CHUNK_VALUES // max(n_ref, 1))
    parts = []
    try:
        for first in range(0, n_out, chunk):
            last = min(n_out, first + chunk)
            raw = np.asarray(matrix[:, first : last + seq_len - 1])  # a view of an array or memmap; HDF5 reads
            if raw.dtype not in (np.float32, np.float64):
                raw = raw.astype(np.float64)
            out = _compiled_features(kernels, raw, seq_len, n_ranks, first, None, n_sequence, n_single)
            if out is None:
                return None
            parts.append(out)
    except NonFiniteError as error:  # a chunk names the first bad value; the count is the whole matrix's
        raise error.counted_in(matrix) from None
    return {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}
