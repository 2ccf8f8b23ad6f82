"""The sequence matcher: every sequence sum ``S``, sequence match and best trajectory of the project comes from here.

``SequenceMatcher(seq_len, velocities)`` is SeqSLAM with an identity kernel along trajectories of the given
velocities (method §4 and §11): the trajectory of velocity ``v`` ending at reference ``r`` and query ``a`` visits
``(r - o_k(v), a - L + 1 + k)`` for ``k = 0 .. L-1``, ``o_k(v) = floor(v (L-1-k) + 0.5)``; ``S[r, a]`` is the
smallest sum of ``D`` along the valid trajectories ending there (velocities tried closest to 1 first, a later one
kept only when strictly smaller). The fixed matcher of the paper is ``velocities=(1.0,)``: the diagonal.

One matcher, one set of rules for all its callers (attributes, recall@N, the per-query CSV, the inspector, the
live matcher, the speed experiment and the plan's checks):

- ``check_references``: the one test that a split holds the slowest trajectory, with the one message;
- ``block_queries`` and ``map_blocks``: the one block-size rule and the one loop over blocks of query columns
  (``read_columns``), which counts NaN and inf over the whole matrix when a block holds one;
- ``sequences``: ``S`` of a block and the velocity of each end reference's best trajectory;
- ``block_features`` / ``features``: the four attributes of the ``K`` best trajectories (method §5), the single
  and the sequence match, per block or over a whole matrix; with ``n_candidates``, also the training-free scorers'
  candidates (method §12): the ``n`` smallest ``S[r, a]`` and the ``n`` smallest ``D[r, a]`` with their references.

Inside, the numbers come from one of four implementations that give the same float64 values bit for bit (each sum
``0 + x_0 + x_1 + ...`` in the definition's order): for any velocities the numpy twin (``velocity``) and its
compiled kernel (``velocity_kernels``); for ``(1.0,)`` a fast path that screens the diagonals by running sums in
O(1) per diagonal instead of O(L) (``fixed`` and its compiled kernel ``kernels``). The choice is made here only:
``KERNEL`` or the environment variable ``VPR_SMR_KERNEL`` (``numba``/``numpy``) force a path; otherwise the compiled
kernels run where they pay for numba's import (``KERNEL_MIN_VALUES``, ``KERNEL_MIN_WORK``).
"""

from __future__ import annotations

import math
import os
import sys
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from types import ModuleType
from typing import Any, TypeVar

import numpy as np

from vpr_smr.core.constants import DEFAULT_VELOCITIES
from vpr_smr.eval.matching import fixed, velocity
from vpr_smr.eval.matching.checks import NonFiniteError, check_finite, check_shape

__all__ = [
    "KERNEL", "THREADS_VARIABLE", "SequenceMatcher", "Sequences", "as_matrix", "block_dtype", "check_velocities",
    "first_reference", "offsets", "read_columns", "search_order", "thread_count",
]

BLOCK_VALUES = 1 << 20  # about 1 M values per block of query columns (4 MB of float32): measured fastest
# The fixed matcher's numpy path on one thread, whose direct sums keep several block-sized arrays: about 0.5 M values
# per block (2026-11-27, 9000 x 9000 at L 4, 12 candidates: 0.42 s against 0.48 s at 1 M and 0.45-0.48 s at 0.35 M).
# On several threads BLOCK_VALUES pays (0.32-0.37 s on 2 threads against 0.37-0.38 s at 0.5 M and 0.36-0.44 s at
# 2 M): half as many blocks, so half the small numpy calls and GIL hand-offs per value.
FIXED_BLOCK_VALUES = 1 << 19
# At most this many threads on the fixed matcher's numpy path: each keeps its own scratch arrays (about 25 MB), and
# two already share the caches' bandwidth (measured on 2 cores only; more cores are untested here).
FIXED_MAX_THREADS = 4
TRANSPOSE_ROWS = 256
KERNEL: str | None = None  # "numba" or "numpy" forces a path; None: VPR_SMR_KERNEL, else where the kernels pay
# The fixed matcher's compiled kernel costs about 0.65 s per process before its first result (numba's import and
# first dispatch, its on-disk cache warm). Whole `vpr-smr attributes` runs on 2 cores (2026-11-27, the numpy path
# reusing its scratch arrays): 9000 x 9000 at L 4 numpy 1.24-1.28 s, numba 1.71 s; at L 10 1.43-1.48 against
# 1.34-1.40 s; 12000 x 12000 at L 4 1.82-1.88 against 2.20-2.28 s, at L 10 2.04 against 1.61 s: it pays from about
# 100 M values.
KERNEL_MIN_VALUES = 100_000_000
# The velocity kernel costs about 0.5-0.7 s per process before its first result, then saves 1.5-4 ns per unit of
# work (|V| L R additions per query; benchmarks/velocity.py): it pays from about 300 M units. Once loaded, it is used
# from LOADED_MIN_WORK units per call on (below, threads do not pay).
KERNEL_MIN_WORK = 300_000_000
LOADED_MIN_WORK = 1_000_000
THREADS_VARIABLE = "VPR_SMR_THREADS"  # threads of the compiled kernels and of the numpy path's blocks

T = TypeVar("T")


# --- velocities and trajectories --------------------------------------------------------------------------------


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


def offsets(velocity_: float, seq_len: int) -> np.ndarray:
    """``o_k(v) = floor(v (L-1-k) + 0.5)`` for ``k = 0 .. L-1``: how far before the end reference the trajectory
    is at the ``k``-th query of the window (``o_{L-1} = 0``)."""
    k = np.arange(seq_len)
    out: np.ndarray = np.floor(velocity_ * (seq_len - 1 - k) + 0.5).astype(np.int64)
    return out


def first_reference(seq_len: int, velocities: Sequence[float]) -> int:
    """``r_min``: the lowest end reference with a valid trajectory (``r - o_0(v) >= 0`` for some ``v``); the
    attributes' index ``i`` counts from it (``L - 1`` for the fixed matcher)."""
    return min(int(offsets(v, seq_len)[0]) for v in velocities)


def search_order(velocities: Sequence[float]) -> tuple[float, ...]:
    """The velocities in the order of the tie rule: closest to 1 first, then the smaller. Scanning them in this
    order and keeping a trajectory only when it is strictly better implements that rule."""
    # rounded: 0.6 and 1.4 are equally close to 1 as written, though |0.6 - 1| and |1.4 - 1| differ in float64
    return tuple(sorted(velocities, key=lambda v: (round(abs(v - 1.0), 12), v)))


# --- reading blocks of query columns ----------------------------------------------------------------------------


def block_dtype(dtype: np.dtype) -> np.dtype:
    """float32 and float64 blocks are used as they are; anything else numeric is read as float64 (exactly)."""
    if dtype.kind not in "biuf":
        raise ValueError(f"expected a numeric matrix (references x queries), got dtype {dtype}")
    return dtype if dtype in (np.float32, np.float64) else np.dtype(np.float64)


def as_matrix(distance_matrix: Any) -> Any:
    """The matrix itself when it is a lazy 2-D array (memmap, h5py.Dataset), else as a numpy array."""
    if hasattr(distance_matrix, "shape") and hasattr(distance_matrix, "dtype") and hasattr(distance_matrix, "ndim"):
        return distance_matrix
    return np.asarray(distance_matrix)


def read_columns(matrix: Any, start: int, stop: int) -> np.ndarray:
    """Columns ``start .. stop - 1`` of a references x queries matrix, as rows: ``(stop - start, R)``, contiguous.

    The transpose is done in slabs of rows, which keeps it in the cache (twice as fast as one strided copy); an
    ``np.ndarray``/``np.memmap`` is read slab by slab, anything else (``h5py.Dataset``) in one read of the block.
    """
    n_ref = matrix.shape[0]
    dtype = block_dtype(np.dtype(matrix.dtype))
    in_memory = isinstance(matrix, np.ndarray)
    # a memmap as a plain view: slicing a memmap builds a memmap object per slab (about 13 µs each)
    source = np.asarray(matrix) if in_memory else np.asarray(matrix[:, start:stop])
    offset = start if in_memory else 0
    out = np.empty((stop - start, n_ref), dtype=dtype)
    for row in range(0, n_ref, TRANSPOSE_ROWS):
        out[:, row : row + TRANSPOSE_ROWS] = source[row : row + TRANSPOSE_ROWS, offset : offset + stop - start].T
    return out


def _float_block(columns: np.ndarray) -> np.ndarray:
    """A block as float32 or float64 (any other numeric dtype as float64, exactly), 2-D."""
    raw = np.asarray(columns)
    if raw.ndim != 2:
        raise ValueError(f"expected a block of query columns (columns x references), got shape {raw.shape}")
    return raw.astype(block_dtype(raw.dtype), copy=False)


# --- which implementation ---------------------------------------------------------------------------------------


def thread_count() -> int:
    """Threads for the compiled kernels and the fixed matcher's numpy blocks: ``VPR_SMR_THREADS`` when set, else
    the cores this process may use. The results are the same on any number (each block or query is computed
    alone and put in its place)."""
    value = os.environ.get(THREADS_VARIABLE, "").strip()
    if value:
        if not value.isdigit() or int(value) < 1:
            raise ValueError(f"{THREADS_VARIABLE}={value!r}: expected a whole number of threads, at least 1 (or "
                             "unset it: the cores this process may use)")
        return int(value)
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def _choice() -> str:
    choice = (KERNEL or os.environ.get("VPR_SMR_KERNEL", "") or "auto").lower()
    if choice not in ("numba", "numpy", "auto"):
        raise ValueError(f"VPR_SMR_KERNEL={choice!r}: expected numba, numpy or nothing (numba for large matrices)")
    return choice


def _import_kernels(name: str, choice: str) -> ModuleType | None:
    """``eval.matching.<name>`` (a numba module), or None when numba does not import and nobody asked for it by
    name: a missing numba only costs speed, the results are the same."""
    try:
        module = __import__(f"vpr_smr.eval.matching.{name}", fromlist=["_"])
    except ImportError as error:
        if choice == "numba":
            raise RuntimeError(f"the compiled attributes path was asked for but numba does not import ({error}); "
                               "pip install numba, or unset VPR_SMR_KERNEL") from None
        return None
    return module


def fixed_kernels(n_values: int, name: str = "kernels") -> ModuleType | None:
    """The compiled kernels ``eval.matching.<name>`` (the fixed matcher's ``kernels``, or a matcher's twin such as
    ``openseqslam_kernels``) for a matrix of ``n_values`` values, or None for the numpy path: compiled when forced,
    or from ``KERNEL_MIN_VALUES`` values on when numba imports."""
    choice = _choice()
    if choice == "numpy" or (choice == "auto" and n_values < KERNEL_MIN_VALUES):
        return None
    return _import_kernels(name, choice)


def velocity_kernels(work: int, total_work: int) -> ModuleType | None:
    """The velocity search's compiled kernel (``velocity_kernels``) for a block of ``work`` units (``|V| L R`` per
    query) of a run of ``total_work``, or None for its numpy twin: compiled when forced; else from
    ``KERNEL_MIN_WORK`` units of the run on, or from ``LOADED_MIN_WORK`` units of the block once this process has
    loaded it."""
    choice = _choice()
    if choice == "numpy":
        return None
    if choice == "auto":
        loaded = "vpr_smr.eval.matching.velocity_kernels" in sys.modules
        if total_work < KERNEL_MIN_WORK and not (loaded and work >= LOADED_MIN_WORK):
            return None
    return _import_kernels("velocity_kernels", choice)


# --- the matcher ------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Sequences:
    """``S`` of the queries of one block: ``sums[n, i]`` is ``S`` of block query ``n`` (query ``a = c + n + L - 1``
    of a block starting at column ``c``) at end reference ``first_reference + i``; ``velocity[n, i]`` the velocity
    of the trajectory that gives it."""

    sums: np.ndarray  # (w, R - r_min) float64
    velocity: np.ndarray  # (w, R - r_min) float64
    first_reference: int


@dataclass(frozen=True)
class SequenceMatcher:
    """Sequence matching of length ``seq_len`` along trajectories of ``velocities`` (``(1.0,)``: the diagonal)."""

    seq_len: int
    velocities: tuple[float, ...] = DEFAULT_VELOCITIES

    def __post_init__(self) -> None:
        if self.seq_len < 2:
            raise ValueError(f"sequence length must be at least 2, got {self.seq_len}")
        object.__setattr__(self, "velocities", check_velocities(self.velocities))

    @property
    def is_fixed(self) -> bool:
        """The paper's fixed matcher (velocity 1 only), which has a fast path."""
        return self.velocities == DEFAULT_VELOCITIES

    @property
    def first_reference(self) -> int:
        """``r_min``: the lowest end reference with a valid trajectory (``L - 1`` for the fixed matcher)."""
        return first_reference(self.seq_len, self.velocities)

    @property
    def references_needed(self) -> int:
        """References a split needs: ``L`` for the queries' windows, ``r_min + 1`` for the slowest trajectory."""
        return max(self.seq_len, self.first_reference + 1)

    def check_references(self, n_ref: int) -> None:
        """ValueError when ``n_ref`` references cannot hold a trajectory of every velocity's kind."""
        if self.first_reference > n_ref - 1:
            raise ValueError(f"{n_ref} references are too few for sequence length {self.seq_len} at velocities "
                             f"{list(self.velocities)}: the slowest trajectory spans {self.first_reference + 1} "
                             "references")

    def check(self, shape: tuple[int, ...], name: str = "distance matrix") -> None:
        """A references x queries matrix of ``shape`` can be matched: 2-D, ``L`` queries, enough references."""
        check_shape(tuple(shape), self.seq_len, name)
        self.check_references(int(shape[0]))

    @staticmethod
    def block_queries(n_ref: int, values: int = BLOCK_VALUES) -> int:
        """Query columns per block: about ``values`` values per block (``BLOCK_VALUES``; ``FIXED_BLOCK_VALUES`` on
        the fixed matcher's numpy path on one thread), at least 16 columns."""
        return max(16, values // max(n_ref, 1))

    def map_blocks(self, matrix: Any, function: Callable[[int, np.ndarray], T],
                   block_queries: int | None = None, threads: int = 1) -> list[T]:
        """``function(c, columns)`` for every block of query columns: ``columns`` (``read_columns``) holds columns
        ``c .. c + w + L - 2``, whose sequences end at queries ``c + L - 1 .. c + w + L - 2``; ``w`` is
        ``block_queries`` (default ``block_queries(R)``), less in the last block. The results in the blocks' order,
        computed on up to ``threads`` threads (``function`` must then be safe to run on several at once). A NaN or
        infinity a block reports is counted over the whole matrix (the first such block in order, as on one
        thread)."""
        n_ref, n_query = (int(n) for n in matrix.shape)
        n_out = n_query - self.seq_len + 1
        step = block_queries or self.block_queries(n_ref)
        starts = range(0, n_out, step)

        def run(start: int) -> T:
            stop = min(n_out, start + step)
            return function(start, read_columns(matrix, start, stop + self.seq_len - 1))

        try:
            if threads <= 1 or len(starts) < 2:
                return [run(start) for start in starts]
            pool = ThreadPoolExecutor(min(threads, len(starts)))
            try:
                return list(pool.map(run, starts))  # in order: the first failing block's error is raised
            finally:
                pool.shutdown(cancel_futures=True)
        except NonFiniteError as error:
            raise error.counted_in(matrix) from None

    def _table(self) -> tuple[tuple[float, ...], np.ndarray]:
        """The velocities in the tie rule's order and their offsets ``(|V|, L)``."""
        order = search_order(self.velocities)
        return order, np.stack([offsets(v, self.seq_len) for v in order])

    def sequences(self, columns: np.ndarray, first_column: int = 0) -> Sequences:
        """``S`` (and each best trajectory's velocity) of the queries of one block (``columns`` as ``map_blocks``
        gives it, ``first_column`` its first column: errors name the matrix's own column)."""
        raw = _float_block(columns)
        check_shape((raw.shape[1], raw.shape[0]), self.seq_len, "block")
        self.check_references(raw.shape[1])
        if not np.all(np.isfinite(raw)):
            check_finite(raw, first_column=first_column, queries_first=True)
        order, table = self._table()
        sums, best = velocity.sequence_sums(raw.astype(np.float64, copy=False), table, self.first_reference)
        return Sequences(sums, np.asarray(order, dtype=np.float64)[best], self.first_reference)

    def block_features(self, columns: np.ndarray, n_ranks: int, first_column: int = 0, *,
                       total_queries: int | None = None, screen_dtype: Any = np.float32,
                       workspace: fixed.Workspace | None = None, n_candidates: int = 0) -> dict[str, np.ndarray]:
        """The attributes, matches and ``S`` range of the queries of one block (``columns`` as ``map_blocks`` gives
        it): ``attributes (w, K, 4)``, ``rank_references (w, K)`` (where the rank-``k`` best trajectory ends),
        ``single_match``, ``sequence_match``, ``sequence_distance`` (``min_r S``), ``sequence_max`` (``max_r S``)
        and ``sequence_velocity`` (the velocity of the sequence match).

        With ``n_candidates`` ``n > 0``, also the training-free scorers' candidates (method §12), each ``(w, n)``
        in ascending order, equal values lowest reference first: ``sequence_candidates`` and
        ``sequence_candidate_references``, the ``n`` smallest ``S[r, a]`` and their end references (the first is
        the sequence match and its distance, bit for bit), and ``single_candidates`` and
        ``single_candidate_references``, the ``n`` smallest ``D[r, a]`` (the first is the single-frame match);
        where fewer end references or references exist, the rest is ``+inf`` and reference ``-1``.

        ``n_ranks`` must be 1 .. ``R - r_min``. ``total_queries``: the queries of the whole run the block belongs
        to, so that a compiled kernel is chosen where the whole run pays for its fixed cost (the results are the
        same on every path). ``screen_dtype`` only decides which candidates the fixed matcher's numpy path
        recomputes in float64; ``workspace``: its scratch arrays, reused over the blocks of one matrix."""
        raw = _float_block(columns)
        n_cols, n_ref = raw.shape
        if n_cols < self.seq_len:
            raise ValueError(f"a block of {n_cols} query columns holds no query of sequence length {self.seq_len} "
                             f"(query columns {first_column}..{first_column + n_cols - 1})")
        self.check_references(n_ref)
        r_min = self.first_reference
        if not 1 <= n_ranks <= n_ref - r_min:
            raise ValueError(f"n_ranks must be 1 .. {n_ref - r_min} (the end references with a trajectory), "
                             f"got {n_ranks}")
        n_queries = n_cols - self.seq_len + 1
        run_queries = max(n_queries, total_queries or 0)
        n_sequence, n_single = self.candidate_counts(n_ref, n_candidates)
        if self.is_fixed:
            out = fixed.block_features(raw, self.seq_len, n_ranks, screen_dtype, first_column,
                                       fixed_kernels(n_ref * (run_queries + self.seq_len - 1)), workspace,
                                       n_sequence, n_single)
        else:
            order, table = self._table()
            col_max = velocity.column_max(raw, first_column)
            per_query = len(order) * self.seq_len * n_ref
            kernels = velocity_kernels(per_query * n_queries, per_query * run_queries)
            if kernels is not None:
                out = kernels.block_features(raw, col_max, table, r_min, n_ranks, n_sequence, n_single)
            else:
                out = velocity.block_features(raw, col_max, table, r_min, n_ranks, n_sequence, n_single)
            out["sequence_velocity"] = np.asarray(order, dtype=np.float64)[out.pop("sequence_index")]
        return _as_references(out, r_min, n_candidates)

    def candidate_counts(self, n_ref: int, n_candidates: int) -> tuple[int, int]:
        """How many of the ``n_candidates`` smallest ``S`` and ``D`` values exist in a split of ``n_ref``
        references: at most the end references with a trajectory, and the references."""
        if n_candidates < 0:
            raise ValueError(f"n_candidates must be >= 0, got {n_candidates}")
        return min(n_candidates, n_ref - self.first_reference), min(n_candidates, n_ref)

    def features(self, matrix: Any, n_ranks: int, block_queries: int | None = None,
                 screen_dtype: Any = np.float32, n_candidates: int = 0) -> dict[str, np.ndarray]:
        """``block_features`` of every query ``a >= L - 1`` of a whole ``R x Q`` matrix (any 2-D array-like that
        slices by columns), read one block of query columns at a time; ``n_ranks`` is capped at ``R - r_min``;
        ``n_candidates``: the scorers' candidates, as ``block_features`` gives them."""
        matrix = as_matrix(matrix)
        self.check(tuple(matrix.shape))
        block_dtype(np.dtype(matrix.dtype))
        n_ref, n_query = (int(n) for n in matrix.shape)
        n_ranks = min(n_ranks, n_ref - self.first_reference)
        n_out = n_query - self.seq_len + 1
        kernels = fixed_kernels(n_ref * n_query) if self.is_fixed and not block_queries else None
        if kernels is not None:
            # The fixed matcher's compiled kernel reads the matrix in its own layout (no transpose); it gives None
            # where its float64 screening cannot bound the values' range, and the blocks below then run.
            out = fixed.compiled_matrix_features(kernels, matrix, self.seq_len, n_ranks,
                                                 *self.candidate_counts(n_ref, n_candidates))
            if out is not None:
                return _as_references(out, self.first_reference, n_candidates)
        workspace = fixed.Workspace()  # one set of scratch arrays per thread
        # The fixed matcher's numpy path runs its blocks on threads (numpy releases the GIL in its large
        # operations); the compiled kernels thread inside, the velocity search's numpy twin stays on one.
        fixed_numpy = self.is_fixed and fixed_kernels(n_ref * n_query) is None
        threads = min(thread_count(), FIXED_MAX_THREADS) if fixed_numpy else 1
        # BLOCK_VALUES where the threads get two blocks each or more, else the one-thread size
        large = threads > 1 and n_ref * n_out >= 2 * threads * BLOCK_VALUES
        step = block_queries or self.block_queries(n_ref, FIXED_BLOCK_VALUES if fixed_numpy and not large
                                                   else BLOCK_VALUES)
        parts = self.map_blocks(matrix, lambda start, columns: self.block_features(
            columns, n_ranks, start, total_queries=n_out, screen_dtype=screen_dtype, workspace=workspace,
            n_candidates=n_candidates), step, threads)
        return {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}


def _padded(values: np.ndarray, width: int, fill: float | int) -> np.ndarray:
    """``values`` (rows x k) widened to ``width`` columns of ``fill``."""
    out = np.full((len(values), width), fill, dtype=values.dtype)
    out[:, : values.shape[1]] = values
    return out


def _as_references(out: dict[str, np.ndarray], r_min: int, n_candidates: int = 0) -> dict[str, np.ndarray]:
    """The implementations' indices ``i`` of end references, as references ``r_min + i``; the fixed matcher's
    sequence matches are all of velocity 1. The candidates (with ``n_candidates``) padded to ``n_candidates``
    columns with ``+inf`` and reference ``-1`` where the split has fewer; without, none."""
    out["rank_references"] = out.pop("rank_diagonals") + r_min
    out["sequence_match"] = out.pop("sequence_diagonal") + r_min
    if "sequence_velocity" not in out:
        out["sequence_velocity"] = np.ones(len(out["sequence_match"]))
    sequence_references = out.pop("sequence_candidate_diagonals") + r_min
    if n_candidates > 0:
        out["sequence_candidates"] = _padded(out["sequence_candidates"], n_candidates, np.inf)
        out["sequence_candidate_references"] = _padded(sequence_references, n_candidates, -1)
        out["single_candidates"] = _padded(out["single_candidates"], n_candidates, np.inf)
        out["single_candidate_references"] = _padded(out["single_candidate_references"], n_candidates, -1)
    else:
        for key in ("sequence_candidates", "single_candidates", "single_candidate_references"):
            del out[key]
    return out
