"""Which references show the place of a query (method §§1 and 11): frame indices within a tolerance, or positions
within a radius.

A frame-aligned pair is the special case ``p = frame index``, ``radius = tolerance``: ``GroundTruth.aligned``
builds it, and every stage scores through ``GroundTruth.correct``, so both cases are one code path.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vpr_smr.core.files import load_npy
from vpr_smr.core.io import CSV_SUFFIXES

__all__ = ["GroundTruth", "read_positions"]


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


@dataclass(frozen=True, eq=False)
class GroundTruth:
    """A match ``r`` of query ``q`` is correct iff ``|reference_positions[r] - query_positions[q]| <= radius``
    (Euclidean for 2-D positions). Indices count from the first frame of the split's references and queries."""

    reference_positions: np.ndarray  # (R,) or (R, d), float64
    query_positions: np.ndarray  # (Q,) or (Q, d), float64
    radius: float

    def __post_init__(self) -> None:
        reference = _as_positions(self.reference_positions, "reference positions")
        query = _as_positions(self.query_positions, "query positions")
        if reference.ndim != query.ndim or (reference.ndim == 2 and reference.shape[1] != query.shape[1]):
            raise ValueError(f"reference positions {reference.shape} and query positions {query.shape} have "
                             "different dimensions: give both traverses positions in the same coordinates")
        if not (np.isfinite(self.radius) and self.radius >= 0):
            raise ValueError(f"the ground-truth radius must be a number >= 0, got {self.radius}")
        object.__setattr__(self, "reference_positions", reference)
        object.__setattr__(self, "query_positions", query)
        object.__setattr__(self, "radius", float(self.radius))

    @classmethod
    def aligned(cls, n_reference: int, n_query: int, tolerance: int) -> GroundTruth:
        """A frame-aligned pair (method §1): positions are frame indices, the radius is the tolerance in frames."""
        if tolerance < 0:
            raise ValueError(f"the tolerance is a number of frames >= 0, got {tolerance}")
        return cls(np.arange(n_reference, dtype=np.float64), np.arange(n_query, dtype=np.float64), float(tolerance))

    @property
    def shape(self) -> tuple[int, int]:
        """(references, queries): the distance matrix this ground truth scores."""
        return len(self.reference_positions), len(self.query_positions)

    def check_shape(self, shape: tuple[int, ...], name: str = "distance matrix") -> None:
        """Raise ValueError naming both shapes when the positions do not have one entry per frame of the matrix."""
        if tuple(shape) != self.shape:
            raise ValueError(f"{name} of shape {shape[0]}x{shape[1]} but {self.shape[0]} reference and "
                             f"{self.shape[1]} query positions: give one position per frame of the matrix")

    def distance(self, reference: np.ndarray, query: np.ndarray) -> np.ndarray:
        """``|p_ref[reference] - p_qry[query]|`` for broadcastable index arrays."""
        delta = self.reference_positions[np.asarray(reference)] - self.query_positions[np.asarray(query)]
        out: np.ndarray
        if delta.ndim == np.broadcast(np.asarray(reference), np.asarray(query)).ndim:  # 1-D positions
            out = np.abs(delta)
        else:
            out = np.sqrt(np.sum(delta * delta, axis=-1))
        return out

    def correct(self, reference: np.ndarray, query: np.ndarray) -> np.ndarray:
        """Whether reference ``reference`` is a correct match of query ``query`` (broadcastable index arrays)."""
        correct: np.ndarray = self.distance(reference, query) <= self.radius
        return correct

    def correct_references(self, query: int) -> np.ndarray:
        """Boolean mask over every reference: the correct matches of query ``query``."""
        return self.correct(np.arange(self.shape[0]), np.full(self.shape[0], query))

    def is_aligned_band(self) -> bool:
        """Whether this is ``aligned(R, Q, tolerance)`` (frame indices, an integer radius): method §1's band."""
        n_ref, n_query = self.shape
        return (self.reference_positions.ndim == 1 and float(self.radius).is_integer()
                and np.array_equal(self.reference_positions, np.arange(n_ref))
                and np.array_equal(self.query_positions, np.arange(n_query)))


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
