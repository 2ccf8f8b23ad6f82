"""Reading a distance matrix, ours (HDF5) or a user's (``.npy``), lazily and checked."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from vpr_smr.eval.matching.ground_truth import GroundTruth, read_positions

# A column block of a chunked distance matrix touches every chunk row; cache them so that the L-1 columns that
# consecutive blocks share are not read twice (64 MB holds one chunk column of a 27592-reference matrix).
CHUNK_CACHE_BYTES = 64 << 20
CHUNK_CACHE_SLOTS = 10007
NEGATIVE_ROUNDING = 1e-5  # negatives down to this fraction of the largest |distance| are float rounding
SCAN_VALUES = 1 << 24  # values per block of the scan for negative distances (64 MB of float32)

@contextmanager
def open_distance_matrix(path: Path | str) -> Iterator[Any]:
    """The references x queries matrix of ``path``, lazily: a read-only memory map of a ``.npy``, or the
    ``distance_matrix`` dataset of our HDF5 file (read by column blocks, see ``eval.matching.attributes.read_columns``).

    Raises ``FileNotFoundError``/``ValueError`` naming the file when it is missing, neither a ``.npy`` nor HDF5, has
    no ``distance_matrix`` dataset, or does not hold a 2-D numeric matrix.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"distance matrix not found: {path}")
    if path.suffix == ".npy":
        try:
            matrix = np.load(path, mmap_mode="r", allow_pickle=False)
        except ValueError as error:
            raise ValueError(f"cannot read {path} as a numeric .npy array: {error}") from None
        _check_matrix(path, matrix)
        check_non_negative(path, matrix)
        try:
            yield matrix
        finally:
            del matrix  # the memory map closes when its last reference goes
        return
    if not h5py.is_hdf5(path):
        raise ValueError(f"{path} is neither a .npy file nor HDF5; give a references x queries matrix as either")
    with h5py.File(path, "r", rdcc_nbytes=CHUNK_CACHE_BYTES, rdcc_nslots=CHUNK_CACHE_SLOTS) as f:
        if "distance_matrix" not in f:
            raise ValueError(f"{path} has no 'distance_matrix' dataset")
        matrix = f["distance_matrix"]
        _check_matrix(path, matrix)
        check_non_negative(path, matrix)
        yield matrix


def _check_matrix(path: Path, matrix: Any) -> None:
    if not np.issubdtype(matrix.dtype, np.number) or matrix.dtype.kind == "c":
        raise ValueError(f"{path}: expected a numeric matrix (references x queries), got {matrix.dtype}")
    if matrix.ndim != 2:
        raise ValueError(f"{path}: distance matrix must be 2-D (references x queries), got shape {matrix.shape}")


def _blocks(matrix: Any) -> Iterator[tuple[slice, slice]]:
    """Blocks of about ``SCAN_VALUES`` values in the matrix's storage order: whole chunk columns of a chunked HDF5
    dataset, column blocks of a Fortran-ordered array, row blocks otherwise."""
    n_rows, n_cols = matrix.shape
    chunks = getattr(matrix, "chunks", None)
    by_columns = chunks is not None or bool(getattr(getattr(matrix, "flags", None), "f_contiguous", False))
    if by_columns and n_rows:
        unit = chunks[1] if chunks is not None else 1
        step = max(unit, SCAN_VALUES // n_rows // unit * unit)
        for start in range(0, n_cols, step):
            yield slice(None), slice(start, start + step)
    else:
        step = max(1, SCAN_VALUES // max(n_cols, 1))
        for start in range(0, n_rows, step):
            yield slice(start, start + step), slice(None)


def check_non_negative(path: Path | str, matrix: Any) -> None:
    """Raise ValueError naming ``path``, the count and minimum of the negative values and the fix, when the matrix
    has any beyond float rounding: SPEC 5 divides each query column by its maximum, which presumes distances >= 0.
    Squared L2 and cosine distances of (nearly) identical descriptors come out about -1e-6 in float32 (faiss, as
    in the authors' code): values down to ``-NEGATIVE_ROUNDING`` times the largest magnitude pass unchanged.
    One pass in blocks; NaN passes here (the attributes stage names it)."""
    if matrix.dtype.kind == "u" or matrix.size == 0:
        return
    count, minimum, largest = 0, 0.0, 0.0
    for rows, cols in _blocks(matrix):
        block = np.asarray(matrix[rows, cols])
        finite = block[np.isfinite(block)]
        if finite.size:
            largest = max(largest, float(np.abs(finite).max()))
            negative = finite[finite < 0]
            if negative.size:
                count += int(negative.size)
                minimum = min(minimum, float(negative.min()))
    if count == 0 or minimum >= -NEGATIVE_ROUNDING * largest:
        return
    raise ValueError(
        f"{path}: {count} negative values in the distance matrix (minimum {minimum:.6g}); distances must be >= 0 "
        "(smaller = more similar; SPEC 5 divides each query column by its maximum). If these are similarities, "
        "turn them into distances first, e.g. D = 1 - S for the cosine similarity of L2-normalised descriptors, "
        "or D = S.max() - S")


def stored_positions(path: Path | str) -> tuple[np.ndarray, np.ndarray] | None:
    """The split's ``reference_positions`` and ``query_positions`` that a distance file of a dataset with positions
    holds (the distances stage copies them), or None (a frame-aligned split, or a ``.npy``)."""
    path = Path(path)
    if path.suffix == ".npy" or not h5py.is_hdf5(path):
        return None
    with h5py.File(path, "r") as f:
        if "reference_positions" not in f and "query_positions" not in f:
            return None
        if "reference_positions" not in f or "query_positions" not in f:
            raise ValueError(f"{path} holds the positions of one traverse only: compute it again (vpr-smr distances)")
        return np.asarray(f["reference_positions"][()]), np.asarray(f["query_positions"][()])


def split_ground_truth(path: Path | str, shape: tuple[int, ...], tolerance: int, radius: float | None = None,
                       reference_positions: Path | str | None = None,
                       query_positions: Path | str | None = None) -> GroundTruth:
    """The ground truth of the matrix in ``path`` (SPEC 1 and 11): the positions files given (``.npy`` or CSV, one
    position per frame), else the positions the distance file holds, each within ``radius``; else frame indices
    within ``tolerance``. Errors name the option or file and the fix."""
    if (reference_positions is None) != (query_positions is None):
        raise ValueError("give both --reference-positions and --query-positions (one position per frame of each "
                         "traverse), or neither")
    where = "the positions"
    if reference_positions is not None and query_positions is not None:
        positions: tuple[np.ndarray, np.ndarray] | None = (read_positions(reference_positions),
                                                            read_positions(query_positions))
        where = f"{reference_positions} and {query_positions}"
    else:
        positions = stored_positions(path)
        where = f"the positions stored in {path}"
    if positions is None:
        if radius is not None:
            raise ValueError(f"--radius {radius} needs positions (--reference-positions and --query-positions, or a "
                             f"distance file of a dataset with positions); {path} is frame-aligned: its ground "
                             "truth is --tolerance frames")
        return GroundTruth.aligned(shape[0], shape[1], tolerance)
    if radius is None:
        raise ValueError(f"{where}: a ground truth from positions needs --radius (in the positions' unit, e.g. "
                         "metres): a match is correct within that distance of the query's position")
    truth = GroundTruth(positions[0], positions[1], radius)
    try:
        truth.check_shape(shape)
    except ValueError as error:
        raise ValueError(f"{path} and {where}: {error}") from None
    return truth
