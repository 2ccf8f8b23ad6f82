"""Sequence matching, the four SMR attributes of every query and its label (SPEC sections 4, 5 and 6, paper mode).

The matrix is read in blocks of query columns (any 2-D array-like that slices by columns: ``np.ndarray``,
``np.memmap``, ``h5py.Dataset``), so no full-size float64 copy of it ever exists. Within a block, the cost per query
does not depend on the sequence length ``L`` or on a sort of the whole column:

1. *Screening.* Running sums along the diagonals (a prefix sum over the block's columns, in diagonal coordinates)
   give every diagonal sum ``full_d``, ``past_d``, the row sums and ``S`` as a difference of two prefix sums, in
   float32. Partial selection finds a bound on each query's ``K``-th smallest screened value: the ``K``-th smallest
   of the minima of strided groups of 32 values (one reduction, then ``np.partition`` of a 32 times shorter row).
2. *Exact recomputation.* Every candidate within a rigorous bound of the float32 rounding error of that ``K``-th
   value is recomputed in float64 exactly as the definition does it (``0 + x_0 + x_1 + ...`` in this order), and the
   ``K`` best are taken by a stable sort on (value, diagonal): SPEC 5's tie rule, equal ``full_d`` lowest diagonal
   first. Only a handful of candidates per query pass the bound (all of them only when values tie massively), so
   this costs ``O(K L)`` per query; so do A3/A4, whose block and group means take ``L + 5`` exact ``full_m`` each.

Every reported number is therefore the float64 value of the definition, bit for bit, whatever the block size or the
screening precision (float32 only decides which few candidates are recomputed): block-wise equals whole-matrix
exactly, and the live matcher (``eval.matching.live``), which runs the same code on one window, equals the batch.

When numba is importable, the same selection runs compiled (``eval.matching.kernels``): the matrix is read in its own
layout, screened in float64 with the same error bounds, and every reported number is again the definition's float64
value, so the compiled and the numpy paths give identical results. ``_kernels`` picks the path, in this one
place: compiled for large matrices (``KERNEL_MIN_VALUES``) when numba imports, numpy otherwise, or as ``KERNEL``
(``"numba"``/``"numpy"``) or the environment variable ``VPR_SMR_KERNEL`` say.
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, fields
from pathlib import Path
from types import ModuleType
from typing import Any

import h5py
import numpy as np
from numpy.lib.stride_tricks import as_strided

from vpr_smr.core.constants import DEFAULT_TOLERANCE, DEFAULT_VELOCITIES, EPS, GROUP_HALF_WIDTH
from vpr_smr.core.io import CSV_SUFFIXES, HDF5_SUFFIXES, atomic_h5, atomic_path, check_suffix, read_provenance
from vpr_smr.eval.matching.checks import NonFiniteError, check_finite, check_shape
from vpr_smr.eval.matching.ground_truth import GroundTruth
from vpr_smr.eval.matching.io import (
    is_npy,
    open_distance_matrix,
    similarity_provenance,
    split_ground_truth,
    warn_if_similar,
)
from vpr_smr.eval.matching.velocity import check_velocities, first_reference, velocity_block_features

__all__ = [
    "ATTRIBUTE_NAMES", "QueryFeatures", "block_features", "is_correct", "labels_from_correctness",
    "query_attributes", "query_features", "read_columns",
]

ATTRIBUTE_NAMES = ("A1", "A2", "A3", "A4")  # minimum sum, minimum value, block sum, group sum rates
BLOCK_VALUES = 1 << 20  # about 1 M values (4 MB of float32) per block of query columns: measured fastest
SCREEN_GROUP = 32
TRANSPOSE_ROWS = 256
KERNEL_CHUNK_VALUES = 16 << 20  # values per read of a lazy (HDF5) matrix on the compiled path: 64 MB of float32
# The compiled path costs about 0.65-0.8 s per process before its first result (numba's import and first dispatch,
# its on-disk cache warm) and then saves about 15 ns per matrix value on 2 cores: it pays from about 50 M values.
KERNEL_MIN_VALUES = 50_000_000
KERNEL: str | None = None  # "numba" or "numpy" forces a path; None: VPR_SMR_KERNEL, else numba from KERNEL_MIN_VALUES


def _kernels(n_values: int) -> ModuleType | None:
    """The compiled kernels (``eval.matching.kernels``) for a matrix of ``n_values`` values, or None for the numpy path.

    The one place that chooses: ``KERNEL``, else the environment variable ``VPR_SMR_KERNEL`` (``numba`` or
    ``numpy``), else numba when it imports and the matrix has at least ``KERNEL_MIN_VALUES`` values. A missing
    numba only costs speed (the results are the same), unless the compiled path was asked for by name."""
    choice = (KERNEL or os.environ.get("VPR_SMR_KERNEL", "") or "auto").lower()
    if choice not in ("numba", "numpy", "auto"):
        raise ValueError(f"VPR_SMR_KERNEL={choice!r}: expected numba, numpy or nothing (numba for large matrices)")
    if choice == "numpy" or (choice == "auto" and n_values < KERNEL_MIN_VALUES):
        return None
    try:
        from vpr_smr.eval.matching import kernels
    except ImportError as error:
        if choice == "numba":
            raise RuntimeError(f"the compiled attributes path was asked for but numba does not import ({error}); "
                               "pip install numba, or unset VPR_SMR_KERNEL") from None
        return None
    return kernels


@dataclass(frozen=True)
class QueryFeatures:
    """What the predictor and the evaluation need of one split, for queries ``a = L-1 .. Q-1``.

    ``attributes[n, k]`` holds ``[A1_k, A2_k, A3_k, A4_k]`` of query ``queries[n]``;
    ``rank_references[n, k]`` is the reference that the rank-``k`` diagonal (with velocity search, SPEC 11: the
    rank-``k`` best trajectory) matches to that query, i.e. where it ends.
    """

    queries: np.ndarray  # (N,) query index within the split
    attributes: np.ndarray  # (N, K, 4)
    rank_references: np.ndarray  # (N, K)
    single_match: np.ndarray  # (N,) argmin_r D[r, a]
    sequence_match: np.ndarray  # (N,) the reference where the best sequence ends: argmin_i S[i, a-L+1] + L - 1
    sequence_distance: np.ndarray  # (N,) min_i S[i, a-L+1] (SPEC 11: min_r S[r, a])
    labels: np.ndarray  # (N,) 0..3, SPEC section 6
    single_correct: np.ndarray  # (N,) bool
    sequence_correct: np.ndarray  # (N,) bool
    rank_correct: np.ndarray  # (N, K) bool
    sequence_min: float  # S.min() of the whole split
    sequence_max: float  # S.max() of the whole split
    all_single_correct: np.ndarray  # (Q,) bool: single-frame correctness of every query, the first L-1 included


def is_correct(reference: np.ndarray, query: np.ndarray, tolerance: int) -> np.ndarray:
    """Ground truth of a frame-aligned pair: a match is correct iff ``|r - q| <= tolerance`` (``GroundTruth``
    generalises it to positions)."""
    correct: np.ndarray = np.abs(np.asarray(reference) - np.asarray(query)) <= tolerance
    return correct


def labels_from_correctness(single_correct: np.ndarray, sequence_correct: np.ndarray) -> np.ndarray:
    """0 correct before and after, 1 correct before only, 2 correct after only, 3 wrong both."""
    single_correct = np.asarray(single_correct, dtype=bool)
    sequence_correct = np.asarray(sequence_correct, dtype=bool)
    return np.where(single_correct, np.where(sequence_correct, 0, 1), np.where(sequence_correct, 2, 3))


# --- screening: running sums along diagonals --------------------------------------------------------------------


def _diagonal_view(array: np.ndarray, row: int, col: int, shape: tuple[int, int]) -> np.ndarray:
    """Read-only ``view[j, d] = array[row + j, col - j + d]`` (the caller keeps the indices in range)."""
    item = array.strides[1]
    return as_strided(array[row:, col:], shape=shape, strides=(array.strides[0] - item, item), writeable=False)


def _diagonal_prefix(x: np.ndarray, n_queries: int) -> np.ndarray:
    """Prefix sums along the diagonals of the block ``x`` (columns of D as rows, shape ``(Wb, R)``).

    ``out[q + 1, s] = sum_{q' <= q} x[q', s + q' - (w - 1)]`` (terms outside ``x`` are 0) with ``w = n_queries``,
    so that the sum of the ``n`` entries of diagonal ``d`` starting at block column ``j`` is
    ``out[j + n, s] - out[j, s]`` with ``s = d - j + w - 1``. One pass over the block; the Python loop runs over
    its columns only.
    """
    n_cols, n_ref = x.shape
    width = n_ref + n_queries - 1
    out = np.empty((n_cols + 1, width), dtype=x.dtype)
    out[0] = 0
    for q in range(n_cols):  # np.cumsum(axis=0) is 3 times slower than this loop of row additions
        lo = n_queries - 1 - q  # s at which column q's row 0 lies
        s0, s1 = max(lo, 0), min(lo + n_ref, width)
        np.add(out[q, s0:s1], x[q, s0 - lo : s1 - lo], out=out[q + 1, s0:s1])
        out[q + 1, :s0] = out[q, :s0]
        out[q + 1, s1:] = out[q, s1:]
    return out


def _window_sums(prefix: np.ndarray, n_terms: int, n_queries: int, n_diag: int) -> np.ndarray:
    """``out[j, d]`` = screened sum of the first ``n_terms`` entries of diagonal ``d`` from block column ``j``,
    padded for ``_select``."""
    shape = (n_queries, n_diag)
    out = _padded(n_queries, n_diag, prefix.dtype)
    np.subtract(_diagonal_view(prefix, n_terms, n_queries - 1, shape), _diagonal_view(prefix, 0, n_queries - 1, shape),
                out=out[:, :n_diag])
    return out


def _group_size(n_values: int) -> int:
    """Values per screening group: 32, strided (group g holds values g, g + G, g + 2G, ...), on long rows."""
    return SCREEN_GROUP if n_values >= 16 * SCREEN_GROUP else 1


def _padded(n_rows: int, n_values: int, dtype: np.dtype) -> np.ndarray:
    """An ``(n_rows, n_values + pad)`` array whose pad columns hold +inf, as ``_select`` expects."""
    group = _group_size(n_values)
    out = np.empty((n_rows, -(-n_values // group) * group), dtype=dtype)
    out[:, n_values:] = np.inf
    return out


def _select(
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
    group = _group_size(n_values)
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


def _error_bound(dtype: np.dtype, n_cols: int, seq_len: int, magnitude: float) -> float:
    """Bound on ``|screened - exact|`` of a window sum: float rounding of prefix sums over ``n_cols`` values of size
    at most ``magnitude`` (both ends, Higham's gamma_n), of the screened inputs, and of the float64 reference sum."""
    unit = float(np.finfo(dtype).eps) / 2
    return magnitude * (unit * (2.2 * n_cols * n_cols + 6 * seq_len + 4) + 1.2e-16 * seq_len * seq_len)


# --- one block of query columns ---------------------------------------------------------------------------------


def _block_dtype(dtype: np.dtype) -> np.dtype:
    """float32 and float64 blocks are used as they are; anything else numeric is read as float64 (exactly)."""
    if dtype.kind not in "biuf":
        raise ValueError(f"expected a numeric matrix (references x queries), got dtype {dtype}")
    return dtype if dtype in (np.float32, np.float64) else np.dtype(np.float64)


def read_columns(matrix: Any, start: int, stop: int) -> np.ndarray:
    """Columns ``start .. stop - 1`` of a references x queries matrix, as rows: ``(stop - start, R)``, contiguous.

    The transpose is done in slabs of rows, which keeps it in the cache (twice as fast as one strided copy); an
    ``np.ndarray``/``np.memmap`` is read slab by slab, anything else (``h5py.Dataset``) in one read of the block.
    """
    n_ref = matrix.shape[0]
    dtype = _block_dtype(np.dtype(matrix.dtype))
    source = matrix if isinstance(matrix, np.ndarray) else np.asarray(matrix[:, start:stop])
    offset = start if source is matrix else 0
    out = np.empty((stop - start, n_ref), dtype=dtype)
    for row in range(0, n_ref, TRANSPOSE_ROWS):
        out[:, row : row + TRANSPOSE_ROWS] = source[row : row + TRANSPOSE_ROWS, offset : offset + stop - start].T
    return out


def block_features(
    columns: np.ndarray, seq_len: int, n_ranks: int, screen_dtype: Any = np.float32, first_column: int = 0
) -> dict[str, np.ndarray]:
    """Everything ``query_features`` reports for the queries of one block of ``Wb`` consecutive query columns.

    ``columns`` is ``(Wb, R)``: row ``q`` is column ``c + q`` of the distance matrix (all references), as
    ``read_columns`` returns it. The block's queries are ``c + L - 1 .. c + Wb - 1`` (``w = Wb - L + 1`` of them).
    Returns arrays over those queries: ``attributes (w, K, 4)``, ``rank_diagonals (w, K)``, ``single_match``,
    ``sequence_diagonal``, ``sequence_distance`` and ``sequence_max`` (``max_i S[i, j]``). ``n_ranks`` must not
    exceed ``R - L + 1``. ``first_column`` is ``c``, so that an error on NaN or inf gives the matrix's own column.
    """
    raw = np.asarray(columns)
    raw = raw.astype(_block_dtype(raw.dtype), copy=False)
    kernels = _kernels(raw.size)
    if kernels is not None:
        out = _compiled_features(kernels, raw.T, seq_len, n_ranks, first_column)
        if out is not None:
            return out
    return _numpy_block_features(raw, seq_len, n_ranks, screen_dtype, first_column)


def _numpy_block_features(
    columns: np.ndarray, seq_len: int, n_ranks: int, screen_dtype: Any = np.float32, first_column: int = 0
) -> dict[str, np.ndarray]:
    """``block_features`` in numpy: float32 (``screen_dtype``) screening by the prefix sums of the block."""
    raw = np.asarray(columns)
    raw = raw.astype(_block_dtype(raw.dtype), copy=False)
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
    margin = 2 * _error_bound(screen, n_cols, seq_len, magnitude)
    margin_raw = 2 * _error_bound(screen, n_cols, seq_len, magnitude_raw)
    x = _padded(n_cols, n_ref, screen)  # the normalised block, padded for the current column's values
    np.divide(raw, col_max.astype(screen)[:, None], out=x[:, :n_ref])

    # Diagonal sums of the normalised window: full_d (L terms) ranks the diagonals, past_d (L-1 terms) gives A1.
    prefix = _diagonal_prefix(x[:, :n_ref], n_queries)
    full = _window_sums(prefix, seq_len, n_queries, n_diag)
    _, rank_diagonals = _select(full, n_diag, k, margin, lambda j, d: diagonal_sum(j, d, seq_len, True))
    del full
    past = _window_sums(prefix, seq_len - 1, n_queries, n_diag)
    del prefix
    past_sorted, _ = _select(past, n_diag, k, margin, lambda j, d: diagonal_sum(j, d, seq_len - 1, True))
    del past

    # Row sums over the L-1 past columns of the window: a prefix sum over the block's columns.
    row_prefix = np.empty((n_cols + 1, n_ref), dtype=screen)
    row_prefix[0] = 0
    for q in range(n_cols):
        np.add(row_prefix[q], x[q, :n_ref], out=row_prefix[q + 1])
    row_past = _padded(n_queries, n_ref, screen)
    np.subtract(row_prefix[seq_len - 1 : seq_len - 1 + n_queries], row_prefix[:n_queries], out=row_past[:, :n_ref])
    del row_prefix
    row_past_sorted, _ = _select(row_past, n_ref, k, margin, lambda j, r: row_sum(j, r, seq_len - 1))
    del row_past

    current_sorted, _ = _select(x[seq_len - 1 :], n_ref, k, margin, lambda j, r: value(j + seq_len - 1, r, True))
    del x
    single_match = np.argmin(raw[seq_len - 1 :], axis=1)  # first index on ties, as np.argmin of the column

    # S on the raw distances: its argmin is the sequence match, its extremes the split's threshold range.
    prefix = _diagonal_prefix(raw.astype(screen, copy=False), n_queries)
    s_approx = _window_sums(prefix, seq_len, n_queries, n_diag)
    del prefix
    s_min, s_arg = _select(s_approx, n_diag, 1, margin_raw, lambda j, d: diagonal_sum(j, d, seq_len, False))
    s_approx[:, n_diag:] = -np.inf
    s_max, _ = _select(s_approx, n_diag, 1, margin_raw, lambda j, d: diagonal_sum(j, d, seq_len, False), largest=True)
    del s_approx

    # A2..A4 of the ranked diagonals: a few values each, recomputed exactly.
    j = np.repeat(np.arange(n_queries), k)
    i = rank_diagonals.ravel()
    past_ranked = diagonal_sum(j, i, seq_len - 1, True).reshape(n_queries, k)
    last = value(j + seq_len - 1, i + seq_len - 1, True).reshape(n_queries, k)  # diag_i[L-1]
    block_lo = seq_len * (i // seq_len)
    block_mean = _mean_full(diagonal_sum, j, block_lo, np.minimum(n_diag - 1, block_lo + seq_len - 1), seq_len)
    group_mean = _mean_full(diagonal_sum, j, np.maximum(0, i - GROUP_HALF_WIDTH),
                            np.minimum(n_diag - 1, i + GROUP_HALF_WIDTH), seq_len)
    attributes = np.stack([
        past_sorted / (row_past_sorted + EPS),
        current_sorted / (last + EPS),
        past_ranked / (block_mean.reshape(n_queries, k) + EPS),
        past_ranked / (group_mean.reshape(n_queries, k) + EPS),
    ], axis=-1)
    return {
        "attributes": attributes,
        "rank_diagonals": rank_diagonals.astype(np.int64),
        "single_match": single_match.astype(np.int64),
        "sequence_diagonal": s_arg[:, 0].astype(np.int64),
        "sequence_distance": s_min[:, 0],
        "sequence_max": s_max[:, 0],
    }


def _compiled_features(kernels: ModuleType, raw: np.ndarray, seq_len: int, n_ranks: int, first_column: int,
                       block_queries: int | None = None) -> dict[str, np.ndarray] | None:
    """``block_features`` of ``raw`` (references x query columns, float32/float64, any strides) by the compiled
    kernel; None when the values' range is too extreme for its float64 screening (the numpy path then runs)."""
    step = min(block_queries or kernels.BLOCK_QUERIES, kernels.BLOCK_QUERIES)
    width = raw.shape[1]
    col_max, col_min, col_bad = np.empty(width, raw.dtype), np.empty(width, raw.dtype), np.empty(width)
    kernels.column_range(raw, col_max, col_min, col_bad)
    if np.any(col_bad != 0):
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
    out: dict[str, np.ndarray] = kernels.column_blocks(raw, col_max64, seq_len, n_ranks, margin, margin_raw, step)
    return out


def _mean_full(diagonal_sum: Callable[..., np.ndarray], j: np.ndarray, lo: np.ndarray, hi: np.ndarray,
               seq_len: int) -> np.ndarray:
    """Mean of ``full_m`` over the diagonals ``m = lo .. hi`` (inclusive) of block column ``j``: the block and
    group sums of SPEC 5 (a sum over ``L`` entries of the entry-wise mean of those diagonals)."""
    width = int((hi - lo).max()) + 1
    total = np.zeros(len(j))
    for t in range(width):
        inside = lo + t <= hi
        total += np.where(inside, diagonal_sum(j, np.minimum(lo + t, hi), seq_len, True), 0.0)
    mean: np.ndarray = total / (hi - lo + 1)
    return mean


# --- whole split ------------------------------------------------------------------------------------------------


def _as_matrix(distance_matrix: Any) -> Any:
    """The matrix itself when it is a lazy 2-D array (memmap, h5py.Dataset), else as a numpy array."""
    if hasattr(distance_matrix, "shape") and hasattr(distance_matrix, "dtype") and hasattr(distance_matrix, "ndim"):
        return distance_matrix
    return np.asarray(distance_matrix)


def default_block_queries(n_ref: int) -> int:
    """Query columns per block: about ``BLOCK_VALUES`` values per block, at least 16 columns."""
    return max(16, BLOCK_VALUES // max(n_ref, 1))


def _run_blocks(distance_matrix: Any, seq_len: int, n_ranks: int, block_queries: int | None,
                screen_dtype: Any, velocities: tuple[float, ...] = DEFAULT_VELOCITIES,
                ) -> tuple[dict[str, np.ndarray], int]:
    """Every block's results concatenated, and ``r_min`` (the end reference of index 0: ``L - 1`` for the fixed
    matcher, SPEC 11's lowest valid end reference with velocity search)."""
    matrix = _as_matrix(distance_matrix)
    check_shape(tuple(matrix.shape), seq_len)
    _block_dtype(np.dtype(matrix.dtype))
    if velocities != DEFAULT_VELOCITIES:
        return _run_velocity_blocks(matrix, seq_len, n_ranks, block_queries, velocities)
    n_ref, n_query = matrix.shape
    n_ranks = min(n_ranks, n_ref - seq_len + 1)
    n_out = n_query - seq_len + 1
    step = block_queries or default_block_queries(n_ref)
    parts: list[dict[str, np.ndarray]] = []
    kernels = _kernels(n_ref * n_query)
    chunk = step
    if kernels is not None and not block_queries:
        # The compiled path reads the matrix in its own layout: a float32/float64 array or memmap as one view (no
        # copy), anything else (HDF5, integers to convert) in chunks of whole rows of about KERNEL_CHUNK_VALUES values.
        in_place = isinstance(matrix, np.ndarray) and matrix.dtype in (np.float32, np.float64)
        chunk = n_out if in_place else max(kernels.BLOCK_QUERIES, KERNEL_CHUNK_VALUES // max(n_ref, 1))
    try:
        for first in range(0, n_out, chunk):
            last = min(n_out, first + chunk)
            if kernels is not None:
                raw = np.asarray(matrix[:, first : last + seq_len - 1])  # a view of an array or memmap; HDF5 reads
                raw = raw.astype(_block_dtype(raw.dtype), copy=False)
                out = _compiled_features(kernels, raw, seq_len, n_ranks, first, block_queries)
                if out is not None:
                    parts.append(out)
                    continue
            for start in range(first, last, step):  # the numpy path, in its own blocks
                stop = min(last, start + step)
                columns = read_columns(matrix, start, stop + seq_len - 1)
                parts.append(_numpy_block_features(columns, seq_len, n_ranks, screen_dtype, first_column=start))
    except NonFiniteError as error:  # a block names the first bad value; the count is the whole matrix's
        raise error.counted_in(matrix) from None
    return {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}, seq_len - 1


def _run_velocity_blocks(matrix: Any, seq_len: int, n_ranks: int, block_queries: int | None,
                         velocities: tuple[float, ...]) -> tuple[dict[str, np.ndarray], int]:
    """``_run_blocks`` with velocity search (SPEC 11): the same blocks of query columns, each block's numbers
    exact (``velocity.velocity_block_features``), so block-wise equals whole-matrix."""
    n_ref, n_query = matrix.shape
    r_min = first_reference(seq_len, velocities)
    if r_min > n_ref - 1:
        raise ValueError(f"{n_ref} references are too few for sequence length {seq_len} at velocities "
                         f"{list(velocities)}: the slowest trajectory spans {r_min + 1} references")
    n_ranks = min(n_ranks, n_ref - r_min)
    n_out = n_query - seq_len + 1
    step = block_queries or default_block_queries(n_ref)
    parts: list[dict[str, np.ndarray]] = []
    try:
        for start in range(0, n_out, step):
            stop = min(n_out, start + step)
            columns = read_columns(matrix, start, stop + seq_len - 1)
            # total_queries: the whole run's size decides whether the compiled kernel pays, not one block's
            parts.append(velocity_block_features(columns, seq_len, n_ranks, velocities, first_column=start,
                                                 total_queries=n_out))
    except NonFiniteError as error:
        raise error.counted_in(matrix) from None
    return {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}, r_min


def query_attributes(
    distance_matrix: Any, seq_len: int, n_ranks: int = 4, block_queries: int | None = None,
    velocities: Sequence[float] = DEFAULT_VELOCITIES,
) -> tuple[np.ndarray, np.ndarray]:
    """Paper-mode attributes of ranks ``0 .. K-1`` for every query ``a >= L - 1``.

    Returns ``(attributes (Q-L+1, K, 4), rank_references (Q-L+1, K))``; ``K`` is at most the number of
    diagonals ``R - L + 1`` (with velocity search: of end references ``R - r_min``).
    """
    result, r_min = _run_blocks(distance_matrix, seq_len, n_ranks, block_queries, np.float32,
                                check_velocities(velocities))
    return result["attributes"], result["rank_diagonals"] + r_min


def query_features(
    distance_matrix: Any, seq_len: int, tolerance: int = DEFAULT_TOLERANCE, n_ranks: int = 4,
    block_queries: int | None = None,
    screen_dtype: Any = np.float32,
    *,
    velocities: Sequence[float] = DEFAULT_VELOCITIES,
    ground_truth: GroundTruth | None = None,
) -> QueryFeatures:
    """Sequence matching, attributes and labels of one split's ``R x Q`` distance matrix.

    ``distance_matrix`` is any 2-D numeric array-like that supports column slicing (``np.ndarray``, a memory-mapped
    ``.npy``, an ``h5py.Dataset``); it is read ``block_queries`` columns at a time. ``screen_dtype`` only decides
    which candidates are recomputed in float64: the results are the same for float32 and float64.
    ``velocities``: SeqSLAM's velocity search (SPEC 11; ``(1.0,)``, the default, is SPEC 4's fixed matcher).
    ``ground_truth``: which matches are correct (default: frame-aligned within ``tolerance``, SPEC 1).
    """
    velocities = check_velocities(velocities)
    matrix = _as_matrix(distance_matrix)
    check_shape(tuple(matrix.shape), seq_len)  # before the ground truth's check: the matrix's own errors first
    if ground_truth is None:
        ground_truth = GroundTruth.aligned(matrix.shape[0], matrix.shape[1], tolerance)
    ground_truth.check_shape(tuple(matrix.shape))
    result, r_min = _run_blocks(matrix, seq_len, n_ranks, block_queries, screen_dtype, velocities)
    n_query = matrix.shape[1]
    queries = np.arange(seq_len - 1, n_query)
    rank_refs = result["rank_diagonals"] + r_min
    single = result["single_match"]
    seq_match = result["sequence_diagonal"] + r_min
    single_correct = ground_truth.correct(single, queries)
    sequence_correct = ground_truth.correct(seq_match, queries)
    return QueryFeatures(
        queries=queries,
        attributes=result["attributes"],
        rank_references=rank_refs,
        single_match=single,
        sequence_match=seq_match,
        sequence_distance=result["sequence_distance"],
        labels=labels_from_correctness(single_correct, sequence_correct),
        single_correct=single_correct,
        sequence_correct=sequence_correct,
        rank_correct=ground_truth.correct(rank_refs, queries[:, None]),
        sequence_min=float(result["sequence_distance"].min()),
        sequence_max=float(result["sequence_max"].max()),
        # Paper mode's single-frame recall@1 counts every query of the split (SPEC 8): the first L-1 too.
        all_single_correct=np.concatenate([
            ground_truth.correct(np.argmin(read_columns(matrix, 0, seq_len - 1), axis=1), np.arange(seq_len - 1)),
            single_correct,
        ]),
    )


def write_features(path: Path | str, features: QueryFeatures, provenance: dict[str, Any]) -> None:
    with atomic_h5(path, provenance) as f:
        for field in fields(QueryFeatures):
            f[field.name] = getattr(features, field.name)


def read_features(path: Path | str) -> QueryFeatures:
    with h5py.File(path, "r") as f:
        values = {field.name: f[field.name][()] for field in fields(QueryFeatures)}
    values["sequence_min"] = float(values["sequence_min"])
    values["sequence_max"] = float(values["sequence_max"])
    return QueryFeatures(**values)


# --- the `attributes` stage: sequence matching, attributes and labels of one distance matrix, to .csv or .h5

OUT_SUFFIXES = CSV_SUFFIXES + HDF5_SUFFIXES

log = logging.getLogger("vpr_smr")


def write_csv(path: Path | str, features: QueryFeatures) -> None:
    """One row per query: its index, the rank-0 attributes A1..A4 (the paper's names) and its label."""
    table = np.column_stack([features.queries, features.attributes[:, 0, :], features.labels])
    header = ",".join(("query", *ATTRIBUTE_NAMES, "label"))
    with atomic_path(path) as tmp:
        np.savetxt(tmp, table, delimiter=",", header=header, comments="", fmt=["%d", *["%.9g"] * 4, "%d"])


def main(distances: Path | str, out: Path | str, seq_len: int, tolerance: int,
         velocities: Sequence[float] = DEFAULT_VELOCITIES, radius: float | None = None,
         reference_positions: Path | str | None = None, query_positions: Path | str | None = None,
         similarity: bool = False) -> QueryFeatures:
    """Features of the matrix in ``distances`` (``.npy`` or our ``.h5``) written to ``out``.

    ``out`` ending in ``.csv`` gets the rank-0 table (``write_csv``); ``.h5``/``.hdf5`` every field of
    ``QueryFeatures`` as HDF5, with the distance file's provenance, ``seq_len``, ``tolerance`` and
    ``attributes_seconds`` (the time of the computation, reading included), and ``velocities`` and ``radius`` when
    they are not the frame-aligned defaults; another suffix is an error, before anything is read. The ground truth:
    ``io.split_ground_truth`` (positions within ``radius``, or frame indices within ``tolerance``). Errors name the
    distance file (negative distances included: ``io.check_non_negative``).
    """
    out = check_suffix(out, OUT_SUFFIXES, "the attributes (.csv table or HDF5)")
    velocities = check_velocities(velocities, "--velocities")
    distances = Path(distances)
    start = time.perf_counter()
    with open_distance_matrix(distances, similarity) as matrix:
        ground_truth = split_ground_truth(distances, tuple(matrix.shape), tolerance, radius, reference_positions,
                                          query_positions)
        warn_if_similar(distances, matrix, ground_truth, similarity)
        try:
            features = query_features(matrix, seq_len, tolerance, velocities=velocities, ground_truth=ground_truth)
        except ValueError as error:
            raise ValueError(f"{distances}: {error}") from None
    seconds = time.perf_counter() - start
    if out.suffix.lower() in CSV_SUFFIXES:
        write_csv(out, features)
    else:
        provenance = read_provenance(distances) if not is_npy(distances) else {}
        provenance = {k: v for k, v in provenance.items() if k != "vpr_smr_version"}
        provenance.update({**matcher_provenance(velocities, radius), **similarity_provenance(similarity)})
        write_features(out, features, {**provenance, "seq_len": seq_len, "tolerance": tolerance,
                                       "attributes_seconds": seconds})
    log.info("%d queries, %.1f µs per query", len(features.queries), 1e6 * seconds / max(len(features.queries), 1))
    return features


def matcher_provenance(velocities: Sequence[float], radius: float | None) -> dict[str, Any]:
    """What an attributes file records of its matcher and ground truth beyond ``seq_len`` and ``tolerance``: only
    what differs from the frame-aligned fixed matcher, so that the paper's files stay as they were."""
    out: dict[str, Any] = {}
    if tuple(velocities) != DEFAULT_VELOCITIES:
        out["velocities"] = [float(v) for v in velocities]
    if radius is not None:
        out["radius"] = float(radius)
    return out


FRAMES, POSITIONS = "frames", "positions"  # the kinds of ground truth: a frame tolerance, positions within a radius


@dataclass(frozen=True)
class Matching:
    """What made the matches and labels of an attributes file, beyond ``L``: the velocities searched (sorted: the
    same set in another order is the same matcher) and the kind of ground truth (``FRAMES`` or ``POSITIONS``). A
    predictor learns from such labels, so its file records the ``Matching`` it was trained with and every stage
    that applies it compares."""

    velocities: tuple[float, ...] = DEFAULT_VELOCITIES
    ground_truth: str = FRAMES

    @classmethod
    def of(cls, velocities: Sequence[float], radius: float | None) -> Matching:
        """A stage's matcher: positions within ``radius`` when it has one, else frame indices."""
        return cls(tuple(sorted(float(v) for v in velocities)), FRAMES if radius is None else POSITIONS)

    @classmethod
    def stored(cls, path: Path | str) -> Matching:
        """The matching an attributes file was computed with (``matcher_provenance``)."""
        stored = read_provenance(path)
        return cls.of(stored.get("velocities", DEFAULT_VELOCITIES), stored.get("radius"))

    def __str__(self) -> str:
        velocities = ("the fixed matcher (velocities [1.0])" if self.velocities == DEFAULT_VELOCITIES else
                      f"velocity search over {list(self.velocities)}")
        truth = "frame indices within a tolerance" if self.ground_truth == FRAMES else "positions within a radius"
        return f"{velocities}, ground truth from {truth}"

    def to_json(self) -> dict[str, Any]:
        return {"velocities": list(self.velocities), "ground_truth": self.ground_truth}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Matching:
        return cls(tuple(float(v) for v in data["velocities"]), str(data["ground_truth"]))


def common_matching(paths: Sequence[Path | str]) -> Matching:
    """The one ``Matching`` of several attributes files (a predictor's training files); ValueError naming two files
    that differ."""
    if not paths:
        return Matching()
    first = Matching.stored(paths[0])
    for path in paths[1:]:
        other = Matching.stored(path)
        if other != first:
            raise ValueError(f"{paths[0]} holds attributes of {first}, but {path} of {other}: give attributes files "
                             "computed with one matcher and one kind of ground truth")
    return first


def check_matching(predictor: Any, matching: Matching, where: str, ground_truth: bool = True) -> None:
    """Raise ValueError naming both when ``predictor`` was trained on attributes of another matcher (or, with
    ``ground_truth``, another kind of ground truth) than ``matching``, what ``where`` scores with: its classes would
    describe other matches and other labels. The record is the ``matching_`` that ``SMRPredictor.load`` reads from
    the file (``path_``); a predictor fitted in this process (never loaded) has none and passes; one loaded from a
    file without the record is refused, with the fix."""
    if not hasattr(predictor, "path_"):
        return
    trained: Matching | None = predictor.matching_
    if trained is None:
        raise ValueError(f"{predictor.path_} does not record the sequence matcher and ground truth it was trained "
                         f"with (it was written before vpr-smr 0.5.0), so it cannot be checked against {where}, of "
                         f"{matching}: train it again (vpr-smr train)")
    if ground_truth and trained != matching:
        raise ValueError(f"{predictor.path_} was trained on attributes of {trained}, but it is applied to {where}, "
                         f"of {matching}: give the predictor trained with this matcher (the same velocities, and "
                         "positions with a radius or not), or train one for it")
    if trained.velocities != matching.velocities:
        raise ValueError(f"{predictor.path_} was trained on attributes of {trained}, but it is applied to {where}, "
                         f"searching velocities {list(matching.velocities)}: give it the velocities the predictor "
                         f"was trained with ({list(trained.velocities)}), or train one for these")


def check_matcher(paths: Sequence[Path | str], velocities: Sequence[float], radius: float | None) -> None:
    """Raise ValueError when an attributes file was computed with other velocities, another kind of ground truth
    or another radius than a stage is given (its labels and matches would not be this matcher's)."""
    expected = Matching.of(velocities, radius)
    for path in paths:
        found, stored = Matching.stored(path), read_provenance(path).get("radius")
        if found != expected or (radius is not None and (stored is None or float(stored) != float(radius))):
            given = "" if radius is None else f" within {float(radius):g}"
            held = "" if stored is None else f" within {float(stored):g}"
            raise ValueError(f"{path} holds attributes of {found}{held}, but this stage was given {expected}{given}: "
                             "give the same --velocities and --radius, or recompute them")


def check_seq_len(paths: Sequence[Path | str], seq_len: int, option: str = "--seq-len") -> None:
    """Raise ValueError when an attributes file was computed at another sequence length than ``seq_len`` (a stage
    given ``--seq-len 4`` and files of L = 3 would label its outputs wrongly); files without the attribute (made
    elsewhere) pass."""
    for path in paths:
        stored = read_provenance(path).get("seq_len")
        if stored is not None and int(stored) != int(seq_len):
            raise ValueError(f"{path} holds attributes of sequence length {int(stored)}, but {option} is {seq_len}: "
                             f"give the attributes files of L = {seq_len}, or {option} {int(stored)}")
