"""Which references show the place of a query (method §§1 and 11): frame indices within a tolerance, positions
within a radius, or a boolean matrix the field wrote (``R x Q``, or per-query lists of correct references, read by
``eval.matching.ground_truth_files``).

Every stage takes one ``GroundTruth`` and scores through ``correct``; the three kinds are its two rules:

- ``PositionTruth``: ``|p_ref[r] - p_qry[q]| <= radius``. A frame-aligned pair is the special case
  ``p = frame index``, ``radius = tolerance`` (``GroundTruth.aligned``, kind ``frames``), so frames and positions are
  one code path;
- ``MatrixTruth``: ``G[r, q]`` of a boolean ``R x Q`` matrix, held as bits (``np.packbits`` over the references:
  ``R x Q / 8`` bytes, 95 MB for Nordland's 27592 x 27592, where a bool matrix takes 761 MB; as fast to look up).

A query without any correct reference is never correct and still counts in every denominator that counts
queries; ``without_correct`` says which queries those are.
"""

from __future__ import annotations

import array
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vpr_smr.core.files import load_npy
from vpr_smr.core.io import CSV_SUFFIXES

__all__ = [
    "FRAMES", "GROUND_TRUTH_KINDS", "MATRIX", "MAX_TRUTH_CELLS", "POSITIONS", "GroundTruth", "MatrixTruth",
    "PositionTruth", "TruthSource", "read_positions",
]

FRAMES, POSITIONS, MATRIX = "frames", "positions", "matrix"  # the kinds of ground truth
GROUND_TRUTH_KINDS = (FRAMES, POSITIONS, MATRIX)
BLOCK_VALUES = 1 << 22  # reference x query cells looked at a time by the whole-matrix passes (4 MB of booleans)
# 2-D positions: from this many cells on, ``without_correct`` looks the references up in a k-d tree (SciPy's import
# costs about what judging 1 << 25 cells does); the tree's distances count as within the radius up to these margins
# (relative, and absolute for a radius 0), far above their rounding, and are then judged by ``correct`` itself
ND_TREE_CELLS = 1 << 25
ND_MARGIN, ND_MARGIN_ABSOLUTE = 1e-9, 1e-150
NO_REFERENCE = -1  # ``true_references`` of a query without any correct reference
# The most cells (references x queries) a ground-truth file may declare or imply when the matrix it scores is not known
# where it is read (the commands' --ground-truth, read before any distance matrix): 2**33, 1 GiB as bits. Pittsburgh
# 250k's test split is 2.1e9 cells, Nordland's 27592 x 27592 frames 0.76e9 (method §13.2).
MAX_TRUTH_CELLS = 1 << 33


def _as_positions(values: np.ndarray, what: str) -> np.ndarray:
    """``values`` as float64 positions: ``(n,)`` for 1-D, ``(n, d)`` for d-D (a single column becomes 1-D)."""
    positions = np.asarray(values, dtype=np.float64)
    if positions.ndim == 2 and positions.shape[1] == 1:
        positions = positions[:, 0]
    if positions.ndim not in (1, 2) or len(positions) == 0:
        raise ValueError(f"{what}: expected one position per frame (n values, or n rows of coordinates), got shape "
                         f"{positions.shape}")
    if not np.all(np.isfinite(positions)):
        bad = np.flatnonzero(~np.isfinite(positions.reshape(len(positions), -1)).all(axis=1))
        raise ValueError(f"{what}: the positions of frames {', '.join(map(str, bad[:5]))} are not finite numbers")
    return positions


def _query_blocks(n_reference: int, n_query: int) -> Iterator[slice]:
    """Query ranges of about ``BLOCK_VALUES`` cells of an ``n_reference x n_query`` matrix."""
    step = max(1, BLOCK_VALUES // max(n_reference, 1))
    for start in range(0, n_query, step):
        yield slice(start, min(start + step, n_query))


def _check_range(name: str, given: tuple[int, int], size: int | None) -> tuple[int, int]:
    lo, hi = (int(v) for v in given)
    if not 0 <= lo <= hi or (size is not None and hi > size):
        within = "" if size is None else f" of 0..{size}"
        raise ValueError(f"the {name} range [{lo}, {hi}) is not a range{within}")
    return lo, hi


class GroundTruth(ABC):
    """Which matches are correct: ``correct(r, q)`` for reference ``r`` and query ``q``, indices counting from the
    first frame of the split's references and queries. Built by ``aligned`` (frames), ``positions``, ``matrix`` or
    ``pairs`` (and read from the field's files by ``ground_truth_files.read_ground_truth``)."""

    kind: str  # FRAMES, POSITIONS or MATRIX

    @property
    @abstractmethod
    def shape(self) -> tuple[int, int]:
        """(references, queries): the distance matrix this ground truth scores."""

    @abstractmethod
    def correct(self, reference: Any, query: Any) -> np.ndarray:
        """Whether reference ``reference`` is a correct match of query ``query`` (broadcastable index arrays)."""

    @abstractmethod
    def describe(self) -> str:
        """A short text for tables and messages: ``within 2 frames``, ``positions within 25``, ``gt.npy (a matrix)``."""

    @abstractmethod
    def provenance(self) -> dict[str, Any]:
        """What an output records of this ground truth, as JSON data: its kind, the tolerance or radius, and for a
        file its name, SHA-256 and variable (and the ranges taken of it)."""

    @abstractmethod
    def sliced(self, references: tuple[int, int], queries: tuple[int, int]) -> GroundTruth:
        """The ground truth of the references ``[lo, hi)`` and queries ``[lo, hi)`` of this one (a split of a
        dataset), indices counting from each range's first frame again."""

    @abstractmethod
    def true_references(self, queries: np.ndarray) -> np.ndarray:
        """The true reference of each query for the per-query table (method §11: the nearest reference, the lowest
        on ties), ``NO_REFERENCE`` where none can be named."""

    @abstractmethod
    def check_shape(self, shape: tuple[int, ...], name: str = "distance matrix") -> None:
        """Raise ValueError naming both shapes and the fix when this ground truth does not score a ``shape``
        matrix."""

    def correct_references(self, query: int) -> np.ndarray:
        """Boolean mask over every reference: the correct matches of query ``query``."""
        return self.correct(np.arange(self.shape[0]), np.full(self.shape[0], query))

    def columns(self, queries: Any) -> np.ndarray:
        """``(R, n)`` bool: ``correct`` of every reference (rows) and each of ``queries`` (a slice or an index
        array; columns)."""
        picked = np.arange(self.shape[1])[queries]
        correct: np.ndarray = self.correct(np.arange(self.shape[0])[:, None], picked[None, :])
        return correct

    def without_correct(self) -> np.ndarray:
        """``(Q,)`` bool: the queries no reference is correct for (never correct, still counted). Every cell in
        blocks: ``O(R Q)``; the kinds compute it from their own form faster, with the same result."""
        n_reference, n_query = self.shape
        out = np.empty(n_query, dtype=bool)
        for block in _query_blocks(n_reference, n_query):
            out[block] = ~self.columns(block).any(axis=0)
        return out

    def is_aligned_band(self) -> bool:
        """Whether this is method §1's band ``|r - q| <= tolerance`` in the split's own indices."""
        return False

    @staticmethod
    def aligned(n_reference: int, n_query: int, tolerance: int) -> PositionTruth:
        """A frame-aligned pair (method §1): positions are frame indices, the radius is the tolerance in frames."""
        if tolerance < 0:
            raise ValueError(f"the tolerance is a number of frames >= 0, got {tolerance}")
        return PositionTruth(np.arange(n_reference, dtype=np.float64), np.arange(n_query, dtype=np.float64),
                             float(tolerance), FRAMES)

    @staticmethod
    def positions(reference_positions: np.ndarray, query_positions: np.ndarray, radius: float) -> PositionTruth:
        """Positions within ``radius`` (method §11.3)."""
        return PositionTruth(reference_positions, query_positions, radius)

    @staticmethod
    def matrix(correct: Any, source: TruthSource | None = None) -> MatrixTruth:
        """``correct[r, q]`` of a boolean (or 0/1) ``R x Q`` array-like, read by blocks of query columns."""
        return MatrixTruth.of_matrix(correct, source)

    @staticmethod
    def pairs(queries: np.ndarray, references: np.ndarray, shape: tuple[int, int],
              source: TruthSource | None = None, open_ended: bool = False) -> MatrixTruth:
        """The matrix whose correct cells are ``(references[i], queries[i])``: per-query lists, one pair each."""
        return MatrixTruth.of_pairs(queries, references, shape, source, open_ended)


@dataclass(frozen=True, eq=False)
class PositionTruth(GroundTruth):
    """A match ``r`` of query ``q`` is correct iff ``|reference_positions[r] - query_positions[q]| <= radius``
    (Euclidean for 2-D positions); kind ``frames`` when the positions are frame indices and the radius the
    tolerance (``GroundTruth.aligned``)."""

    reference_positions: np.ndarray  # (R,) or (R, d), float64
    query_positions: np.ndarray  # (Q,) or (Q, d), float64
    radius: float
    kind: str = POSITIONS

    def __post_init__(self) -> None:
        reference = _as_positions(self.reference_positions, "reference positions")
        query = _as_positions(self.query_positions, "query positions")
        if reference.ndim != query.ndim or (reference.ndim == 2 and reference.shape[1] != query.shape[1]):
            raise ValueError(f"reference positions {reference.shape} and query positions {query.shape} have "
                             "different dimensions: give both traverses positions in the same coordinates")
        if not (np.isfinite(self.radius) and self.radius >= 0):
            raise ValueError(f"the ground-truth radius must be a number >= 0, got {self.radius}")
        if self.kind not in (FRAMES, POSITIONS):
            raise ValueError(f"a ground truth of positions is of kind {FRAMES!r} or {POSITIONS!r}, not {self.kind!r}")
        object.__setattr__(self, "reference_positions", reference)
        object.__setattr__(self, "query_positions", query)
        object.__setattr__(self, "radius", float(self.radius))

    @property
    def shape(self) -> tuple[int, int]:
        return len(self.reference_positions), len(self.query_positions)

    def check_shape(self, shape: tuple[int, ...], name: str = "distance matrix") -> None:
        if tuple(shape) != self.shape:
            raise ValueError(f"{name} of shape {shape[0]}x{shape[1]} but {self.shape[0]} reference and "
                             f"{self.shape[1]} query positions: give one position per frame of the matrix")

    def distance(self, reference: Any, query: Any) -> np.ndarray:
        """``|p_ref[reference] - p_qry[query]|`` for broadcastable index arrays."""
        delta = self.reference_positions[np.asarray(reference)] - self.query_positions[np.asarray(query)]
        out: np.ndarray
        if delta.ndim == np.broadcast(np.asarray(reference), np.asarray(query)).ndim:  # 1-D positions
            out = np.abs(delta)
        else:
            out = np.sqrt(np.sum(delta * delta, axis=-1))
        return out

    def correct(self, reference: Any, query: Any) -> np.ndarray:
        correct: np.ndarray = self.distance(reference, query) <= self.radius
        return correct

    def bounds(self, queries: np.ndarray, references: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """1-D positions: for each of ``queries``, the range ``[lo, hi)`` of ``references`` (sorted positions; default
        this ground truth's, which must then be sorted) that ``correct`` holds for, as ``correct`` computes it.
        ``p_ref - p_qry`` rounds monotonically in ``p_ref``, so the correct references of a query are a run of sorted
        ones; its ends are found by bisection on the same difference, ``O(Q log R)`` where ``correct`` takes
        ``O(R Q)``."""
        sorted_positions = self.reference_positions if references is None else references
        query = self.query_positions[np.asarray(queries)]
        lo = _first_true(len(sorted_positions), len(query), lambda i: sorted_positions[i] - query >= -self.radius)
        hi = _first_true(len(sorted_positions), len(query), lambda i: sorted_positions[i] - query > self.radius)
        return lo, hi

    def has_sorted_references(self) -> bool:
        """1-D reference positions in non-decreasing order (frames, a route's chainage): ``bounds`` applies."""
        positions = self.reference_positions
        return positions.ndim == 1 and bool(np.all(positions[1:] >= positions[:-1]))

    def columns(self, queries: Any) -> np.ndarray:
        if not self.has_sorted_references():
            return super().columns(queries)
        lo, hi = self.bounds(np.arange(self.shape[1])[queries])
        references = np.arange(self.shape[0])[:, None]
        columns: np.ndarray = (references >= lo) & (references < hi)
        return columns

    def without_correct(self) -> np.ndarray:
        """1-D positions: a query has a correct reference iff its run of sorted references (``bounds``) is not
        empty; 2-D: ``_without_correct_nd``."""
        if self.reference_positions.ndim == 2:
            return _without_correct_nd(self)
        references = np.sort(self.reference_positions, kind="stable")
        lo, hi = self.bounds(np.arange(self.shape[1]), references)
        without: np.ndarray = lo == hi
        return without

    def is_aligned_band(self) -> bool:
        """Whether this is ``aligned(R, Q, tolerance)`` (frame indices, an integer radius): method §1's band."""
        n_ref, n_query = self.shape
        return (self.reference_positions.ndim == 1 and float(self.radius).is_integer()
                and np.array_equal(self.reference_positions, np.arange(n_ref))
                and np.array_equal(self.query_positions, np.arange(n_query)))

    def within(self, radius: float) -> PositionTruth:
        """The same positions with another radius (a ``frames`` ground truth: another tolerance)."""
        return PositionTruth(self.reference_positions, self.query_positions, radius, self.kind)

    @property
    def tolerance(self) -> int:
        """The tolerance in frames of a ``frames`` ground truth."""
        if self.kind != FRAMES:
            raise ValueError("a ground truth of positions has a radius, not a tolerance in frames")
        return int(self.radius)

    def describe(self) -> str:
        if self.kind == FRAMES:
            return f"within {self.tolerance} frame{'' if self.tolerance == 1 else 's'}"
        return f"positions within {self.radius:g}"

    def provenance(self) -> dict[str, Any]:
        if self.kind == FRAMES:
            return {"kind": FRAMES, "tolerance": self.tolerance}
        return {"kind": POSITIONS, "radius": self.radius}

    def sliced(self, references: tuple[int, int], queries: tuple[int, int]) -> PositionTruth:
        r_lo, r_hi = _check_range("reference", references, self.shape[0])
        q_lo, q_hi = _check_range("query", queries, self.shape[1])
        reference, query = self.reference_positions[r_lo:r_hi], self.query_positions[q_lo:q_hi]
        if self.kind == FRAMES:  # frame indices counted from the split's first query: the same distances
            reference, query = reference - q_lo, query - q_lo
        return PositionTruth(reference, query, self.radius, self.kind)

    def true_references(self, queries: np.ndarray) -> np.ndarray:
        """The reference nearest to each query's position (the lowest on ties), within the radius or not."""
        references = np.arange(self.shape[0])
        return np.array([int(np.argmin(self.distance(references, np.full(len(references), a)))) for a in queries],
                        dtype=np.int64)


def _first_true(n: int, count: int, true_at: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """For ``count`` predicates over ``0..n-1``, each false and then true along its index, the first index where each
    holds (``n`` where none does): a vectorised bisection. ``true_at(i)`` tells predicate ``k`` at index ``i[k]``."""
    lo, hi = np.zeros(count, dtype=np.int64), np.full(count, n, dtype=np.int64)
    while True:
        open_ = lo < hi
        if not open_.any():
            return lo
        middle = (lo + hi) // 2
        holds = true_at(np.minimum(middle, n - 1))  # a closed one's middle may be n; its answer is not used
        hi = np.where(open_ & holds, middle, hi)
        lo = np.where(open_ & ~holds, middle + 1, lo)


def _without_correct_nd(truth: PositionTruth) -> np.ndarray:
    """``without_correct`` of 2-D (or more) positions through a k-d tree (SciPy's): a query's nearest reference
    is looked up in the tree and judged by ``correct``; where it is not correct but the tree's distance comes within
    ``ND_MARGIN`` of the radius (the tree rounds its distances its own way), every reference the tree finds within the
    radius and the margin is judged by ``correct``, so the result is ``correct``'s. Below ``ND_TREE_CELLS`` cells
    every cell is judged."""
    n_reference, n_query = truth.shape
    if n_reference * n_query < ND_TREE_CELLS:
        return GroundTruth.without_correct(truth)
    from scipy.spatial import cKDTree  # 0.2-0.4 s of import, paid only here

    tree = cKDTree(truth.reference_positions)
    distance, nearest = tree.query(truth.query_positions, k=1)
    queries = np.arange(n_query)
    found = truth.correct(nearest, queries)
    reach = truth.radius * (1 + ND_MARGIN) + ND_MARGIN_ABSOLUTE
    for query in np.flatnonzero(~found & (distance <= reach)):
        candidates = np.asarray(tree.query_ball_point(truth.query_positions[query], reach), dtype=np.int64)
        found[query] = bool(truth.correct(candidates, np.full(len(candidates), query)).any())
    without: np.ndarray = ~found
    return without


@dataclass(frozen=True)
class TruthSource:
    """The file a ground truth was read from: its name as given, its SHA-256, its form (``FORMS``: a matrix or
    per-query lists, and in which format) and the variable read (``key``) where the file holds several."""

    file: str
    sha256: str
    form: str
    key: str | None = None

    @property
    def name(self) -> str:
        """``gt.npy``, or ``GT.mat:GThard`` for a variable of a file."""
        return Path(self.file).name + ("" if self.key is None else f":{self.key}")

    @property
    def lists(self) -> bool:
        """Per-query lists (JSON, CSV, VPR-Bench), as opposed to a matrix."""
        return self.form in LIST_FORMS


# the forms a ground-truth file may take (ground_truth_files.read_ground_truth); a matrix's own shape is the
# matrix's, lists name only the correct pairs
MATRIX_FORMS = ("npy matrix", "npz matrix", "mat v5 matrix", "mat v7.3 matrix")
LIST_FORMS = ("json lists", "csv pairs", "vpr-bench lists")
FORMS = MATRIX_FORMS + LIST_FORMS


@dataclass(frozen=True, eq=False)
class MatrixTruth(GroundTruth):
    """A match ``r`` of query ``q`` is correct iff ``G[r, q]``, with ``G`` held as bits: ``bits[r // 8, q]`` has
    bit ``7 - r % 8`` set (``np.packbits`` over the references, unused bits 0).

    ``open_ended``: per-query lists, which name the correct pairs only: their shape is the smallest that holds
    them, and ``sliced`` may reach past it (no correct pairs there). ``ranges``: the reference and query ranges of
    the file's matrix this one was sliced to (None: the whole file)."""

    bits: np.ndarray  # (ceil(R / 8), Q) uint8
    n_reference: int
    source: TruthSource | None = None
    open_ended: bool = False
    ranges: tuple[tuple[int, int], tuple[int, int]] | None = None
    kind: str = MATRIX

    def __post_init__(self) -> None:
        expected = (-(-self.n_reference // 8), self.bits.shape[1] if self.bits.ndim == 2 else -1)
        if self.bits.dtype != np.uint8 or self.bits.shape != expected:
            raise ValueError(f"a matrix ground truth's bits must be uint8 of shape {expected}, got "
                             f"{self.bits.dtype} {self.bits.shape}")

    @classmethod
    def of_matrix(cls, correct: Any, source: TruthSource | None = None) -> MatrixTruth:
        """``correct`` (a 2-D boolean or 0/1 array-like: ndarray, memmap, lazily read file) packed by blocks of
        query columns, so that no full boolean copy of a large matrix exists. ValueError on another shape or value
        (the first one, in query-column order)."""
        shape = tuple(int(n) for n in correct.shape)
        if len(shape) != 2:
            raise ValueError(f"a ground-truth matrix is 2-D (references x queries), got shape {shape}")
        if 0 in shape:
            raise ValueError(f"the ground-truth matrix is {shape[0]} x {shape[1]}: it holds no values")
        dtype = np.dtype(correct.dtype)
        if dtype.kind not in "biuf":
            raise ValueError(f"a ground-truth matrix holds booleans (or 0 and 1), not {dtype}")
        n_reference, n_query = shape
        bits = np.empty((-(-n_reference // 8), n_query), dtype=np.uint8)
        for block in _query_blocks(n_reference, n_query):
            values = np.asarray(correct[:, block])
            if dtype.kind != "b":
                bad = ~((values == 0) | (values == 1))  # NaN is neither
                if bad.any():
                    column, row = np.argwhere(bad.T)[0]
                    raise ValueError(f"a ground-truth matrix holds booleans (or 0 and 1), but it holds "
                                     f"{values[row, column].item()!r} at row {row} (reference), column "
                                     f"{block.start + column} (query)")
            bits[:, block] = np.packbits(values.astype(bool), axis=0)
        return cls(bits, n_reference, source)

    @classmethod
    def of_pairs(cls, queries: np.ndarray, references: np.ndarray, shape: tuple[int, int],
                 source: TruthSource | None = None, open_ended: bool = False) -> MatrixTruth:
        """The matrix of ``shape`` whose correct cells are ``(references[i], queries[i])`` (repeats allowed)."""
        queries, references = np.asarray(queries, dtype=np.int64), np.asarray(references, dtype=np.int64)
        n_reference, n_query = (int(n) for n in shape)
        if queries.shape != references.shape or queries.ndim != 1:
            raise ValueError("the correct pairs need one query per reference")
        outside = (queries < 0) | (queries >= n_query) | (references < 0) | (references >= n_reference)
        if outside.any():
            i = int(np.flatnonzero(outside)[0])
            raise ValueError(f"the pair query {queries[i]}, reference {references[i]} is outside the "
                             f"{n_reference} x {n_query} matrix (references x queries)")
        bits = np.zeros((-(-n_reference // 8), n_query), dtype=np.uint8)
        np.bitwise_or.at(bits, (references >> 3, queries), (1 << (7 - (references & 7))).astype(np.uint8))
        return cls(bits, n_reference, source, open_ended)

    @classmethod
    def of_rows(cls, rows: Iterable[tuple[Any, range | Sequence[int] | np.ndarray]], shape: tuple[int, int],
                source: TruthSource | None = None, open_ended: bool = False) -> MatrixTruth:
        """The matrix of ``shape`` whose correct cells are each row's references of its query: a query and a range
        (set byte by byte, never expanded) or a list or array of references, or an array of queries and one of
        references (pairs). Lists are set ``PAIRS_CHUNK`` pairs at a time. Every index must lie in ``shape`` (the
        readers check them as they read)."""
        n_reference, n_query = (int(n) for n in shape)
        bits = np.zeros((-(-n_reference // 8), n_query), dtype=np.uint8)
        queries, references = array.array("q"), array.array("q")

        def flush() -> None:
            pairs = np.array(references, dtype=np.int64)  # copies: the buffers are emptied for the next chunk
            np.bitwise_or.at(bits, (pairs >> 3, np.array(queries, dtype=np.int64)),
                             (1 << (7 - (pairs & 7))).astype(np.uint8))
            del queries[:], references[:]

        for query, correct in rows:
            if isinstance(correct, range):
                _set_range(bits[:, query], correct)
                continue
            if isinstance(query, np.ndarray):
                queries.extend(query.astype(np.int64))
            else:
                queries.extend([query] * len(correct))
            references.extend(np.asarray(correct, dtype=np.int64) if isinstance(correct, np.ndarray) else correct)
            if len(references) >= PAIRS_CHUNK:
                flush()
        if len(references):
            flush()
        return cls(bits, n_reference, source, open_ended)

    @property
    def shape(self) -> tuple[int, int]:
        return self.n_reference, int(self.bits.shape[1])

    def check_shape(self, shape: tuple[int, ...], name: str = "distance matrix") -> None:
        if tuple(shape) == self.shape:
            return
        fix = "give the ground truth of the matrix's frames (references x queries)"
        if tuple(shape) == self.shape[::-1] and shape[0] != shape[1]:
            fix = ("the two are transposed: give the matrix with --transpose if it is queries x references, or save "
                   "the ground truth as references x queries")
        raise ValueError(f"{name} of shape {shape[0]}x{shape[1]} but the ground truth {self.describe()} is "
                         f"{self.shape[0]}x{self.shape[1]} (references x queries): {fix}")

    def correct(self, reference: Any, query: Any) -> np.ndarray:
        reference, query = np.asarray(reference), np.asarray(query)
        byte = self.bits[reference >> 3, query]
        shift = (7 - (reference & 7)).astype(np.uint8)  # in uint8: the byte is not widened to int64
        correct: np.ndarray = ((byte >> shift) & 1).astype(bool)
        return correct

    def correct_references(self, query: int) -> np.ndarray:
        out: np.ndarray = np.unpackbits(self.bits[:, query], count=self.n_reference).astype(bool)
        return out

    def without_correct(self) -> np.ndarray:
        return np.asarray(~self.bits.any(axis=0))

    def columns(self, queries: Any) -> np.ndarray:
        """``G[:, queries]`` as booleans (R x n)."""
        out: np.ndarray = np.unpackbits(self.bits[:, queries], axis=0, count=self.n_reference).astype(bool)
        return out

    def describe(self) -> str:
        if self.source is None:
            return "a boolean matrix"
        return f"{self.source.name} ({'per-query lists' if self.source.lists else 'a matrix'})"

    def provenance(self) -> dict[str, Any]:
        out: dict[str, Any] = {"kind": MATRIX}
        if self.source is not None:
            out.update(file=Path(self.source.file).name, sha256=self.source.sha256, form=self.source.form)
            if self.source.key is not None:
                out["key"] = self.source.key
        if self.ranges is not None:
            out.update(references=list(self.ranges[0]), queries=list(self.ranges[1]))
        return out

    def sliced(self, references: tuple[int, int], queries: tuple[int, int]) -> MatrixTruth:
        """Per-query lists (``open_ended``) may be sliced past their shape: they name no correct pair there."""
        limit = None if self.open_ended else self.shape
        r_lo, r_hi = _check_range("reference", references, None if limit is None else limit[0])
        q_lo, q_hi = _check_range("query", queries, None if limit is None else limit[1])
        n_reference, n_query = r_hi - r_lo, q_hi - q_lo
        bits = np.zeros((-(-n_reference // 8), n_query), dtype=np.uint8)
        rows = slice(r_lo, min(r_hi, self.n_reference))  # the part this matrix holds; the rest has no pair
        for block in _query_blocks(self.n_reference, min(q_hi, self.shape[1]) - q_lo):
            held = self.columns(slice(q_lo + block.start, q_lo + block.stop))[rows]
            padded = np.zeros((n_reference, held.shape[1]), dtype=bool)
            padded[: held.shape[0]] = held
            bits[:, block] = np.packbits(padded, axis=0)
        offset = (0, 0) if self.ranges is None else (self.ranges[0][0], self.ranges[1][0])
        ranges = ((offset[0] + r_lo, offset[0] + r_hi), (offset[1] + q_lo, offset[1] + q_hi))
        return MatrixTruth(bits, n_reference, self.source, False, ranges)

    def sized(self, shape: tuple[int, int]) -> MatrixTruth:
        """Per-query lists (``open_ended``) as the ``R x Q`` matrix of the frames their indices count (no correct
        pair past those they name); its provenance is the lists', not a slice of them."""
        part = self.sliced((0, shape[0]), (0, shape[1]))
        return MatrixTruth(part.bits, part.n_reference, self.source, False, self.ranges)

    def true_references(self, queries: np.ndarray) -> np.ndarray:
        """The correct reference nearest to the query's own frame (the lowest on ties: where positions = frame
        indices would place it); ``NO_REFERENCE`` for a query without one. Frames count in the file's indices, so a
        split whose reference and query ranges differ compares like frames."""
        queries = np.asarray(queries, dtype=np.int64)
        offset = 0 if self.ranges is None else self.ranges[1][0] - self.ranges[0][0]  # query frame -> reference
        references = np.arange(self.n_reference)[:, None]
        out = np.full(len(queries), NO_REFERENCE, dtype=np.int64)
        for block in _query_blocks(self.n_reference, len(queries)):
            chosen = queries[block]
            correct = self.correct(references, chosen[None, :])
            gap = np.where(correct, np.abs(references - (chosen[None, :] + offset)), np.iinfo(np.int64).max)
            out[block] = np.where(correct.any(axis=0), np.argmin(gap, axis=0), NO_REFERENCE)
        return out


RANGE_CHUNK = 1 << 20  # the indices of a range with a step other than 1 set a time
PAIRS_CHUNK = 1 << 20  # the listed pairs set a time (16 MiB of indices)


def _set_range(column: np.ndarray, references: range) -> None:
    """Set the bits of ``references`` in a packed column (bit ``7 - r % 8`` of byte ``r // 8``): a run of
    consecutive references byte by byte (a first and a last partial byte), another step ``RANGE_CHUNK`` at a time."""
    if not len(references):
        return
    if abs(references.step) == 1:
        lo, hi = min(references[0], references[-1]), max(references[0], references[-1]) + 1
        first, last = lo >> 3, (hi - 1) >> 3
        head, tail = 0xFF >> (lo & 7), (0xFF << (7 - ((hi - 1) & 7))) & 0xFF
        if first == last:
            column[first] |= head & tail
            return
        column[first] |= head
        column[first + 1 : last] = 0xFF
        column[last] |= tail
        return
    for start in range(0, len(references), RANGE_CHUNK):
        part = references[start : start + RANGE_CHUNK]
        indices = np.arange(part.start, part.stop, part.step, dtype=np.int64)
        np.bitwise_or.at(column, indices >> 3, (1 << (7 - (indices & 7))).astype(np.uint8))


def read_positions(path: Path | str) -> np.ndarray:
    """One position per frame from a ``.npy`` (``(n,)`` or ``(n, d)``) or a CSV of numbers (one row per frame, one
    column per coordinate; a first line that is not numbers is a header). Errors name the file and line."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"positions file not found: {path}")
    if path.suffix.lower() == ".npy":
        return _as_positions(load_npy(path, "one position per frame"), str(path))
    if path.suffix.lower() not in CSV_SUFFIXES:
        raise ValueError(f"{path}: positions must be a .npy array or a .csv table (one row per frame)")
    rows: list[list[float]] = []
    for number, line in enumerate(path.read_text().splitlines(), start=1):
        cells = [cell.strip() for cell in line.split(",")]
        if not line.strip():
            continue
        try:
            rows.append([float(cell) for cell in cells])
        except ValueError:
            if number == 1 and not rows:
                continue  # a header
            raise ValueError(f"{path}, line {number}: {line.strip()!r} is not a row of numbers (one position "
                             "per frame, one column per coordinate)") from None
    if len({len(row) for row in rows}) > 1:
        raise ValueError(f"{path}: rows have different numbers of columns; give every frame the same coordinates")
    return _as_positions(np.array(rows), str(path))
