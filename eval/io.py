"""HDF5 and JSON files of the pipeline: written to a temporary name and renamed, with provenance attributes."""

from __future__ import annotations

import json
import os
import secrets
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import fields
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from .attributes import QueryFeatures

# A column block of a chunked distance matrix touches every chunk row; cache them so that the L-1 columns that
# consecutive blocks share are not read twice (64 MB holds one chunk column of a 27592-reference matrix).
CHUNK_CACHE_BYTES = 64 << 20
CHUNK_CACHE_SLOTS = 10007
SCAN_VALUES = 1 << 24  # values per block of the scan for negative distances (64 MB of float32)

# What each kind of output file may be called (``check_suffix``)
HDF5_SUFFIXES = (".h5", ".hdf5")
JSON_SUFFIXES = (".json",)
CSV_SUFFIXES = (".csv",)


def check_suffix(path: Path | str, allowed: tuple[str, ...], what: str, option: str = "--out") -> Path:
    """``path`` as a Path when its suffix is one of ``allowed`` (any case), else a ValueError naming the option,
    what was given and the suffixes allowed; ``what`` says what the file holds (e.g. "the features (HDF5)")."""
    path = Path(path)
    if path.suffix.lower() not in allowed:
        given = f"suffix {path.suffix!r}" if path.suffix else "no suffix"
        names = allowed[0] if len(allowed) == 1 else f"{', '.join(allowed[:-1])} or {allowed[-1]}"
        example = path.with_suffix(allowed[0]) if path.stem else Path("out" + allowed[0])
        raise ValueError(f"{option} {path}: {what} must end in {names}, got {given}; e.g. {option} {example}")
    return path


def package_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("vpr-smr")
    except PackageNotFoundError:
        return "unknown"


@contextmanager
def atomic_path(path: Path | str) -> Iterator[Path]:
    """A temporary name beside ``path`` to write to: renamed to ``path`` when the block finishes, removed if it fails.

    The name is unique to this process and call, so that two writers of one file never share a temporary file.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f"{path.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp")
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


@contextmanager
def atomic_h5(path: Path | str, provenance: dict[str, Any] | None = None) -> Iterator[h5py.File]:
    """An HDF5 file written through ``atomic_path``, with the package version and ``provenance`` as attributes."""
    with atomic_path(path) as tmp, h5py.File(tmp, "w") as f:
        f.attrs["vpr_smr_version"] = package_version()
        for key, value in (provenance or {}).items():
            f.attrs[key] = json.dumps(value, sort_keys=True) if isinstance(value, dict | list) else value
        yield f


def write_json(path: Path | str, data: dict[str, Any]) -> None:
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(data, indent=1, sort_keys=True, default=_jsonable))


def _jsonable(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON serialisable: {type(value)}")


def write_distance_matrix(path: Path | str, distance_matrix: np.ndarray, provenance: dict[str, Any]) -> None:
    with atomic_h5(path, provenance) as f:
        f.create_dataset("distance_matrix", data=distance_matrix.astype(np.float32))


def read_distance_matrix(path: Path | str) -> np.ndarray:
    """A references x queries matrix from our HDF5 file (``distance_matrix``) or a user's ``.npy``, in memory."""
    with open_distance_matrix(path) as matrix:
        return np.asarray(matrix[()] if isinstance(matrix, h5py.Dataset) else np.array(matrix))


@contextmanager
def open_distance_matrix(path: Path | str) -> Iterator[Any]:
    """The references x queries matrix of ``path``, lazily: a read-only memory map of a ``.npy``, or the
    ``distance_matrix`` dataset of our HDF5 file (read by column blocks, see ``eval.attributes.read_columns``).

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
    has any: SPEC 5 divides each query column by its maximum, which presumes distances >= 0. One pass in blocks;
    NaN passes here (the attributes stage names it)."""
    if matrix.dtype.kind == "u" or matrix.size == 0:
        return
    if not any(np.any(np.asarray(matrix[rows, cols]) < 0) for rows, cols in _blocks(matrix)):
        return
    count, minimum = 0, 0.0  # a second pass, on the way to the error only
    for rows, cols in _blocks(matrix):
        negative = np.asarray(matrix[rows, cols])
        negative = negative[negative < 0]
        if negative.size:
            count += negative.size
            minimum = min(minimum, float(negative.min()))
    raise ValueError(
        f"{path}: {count} negative values in the distance matrix (minimum {minimum:.6g}); distances must be >= 0 "
        "(smaller = more similar; SPEC 5 divides each query column by its maximum). If these are similarities, "
        "turn them into distances first, e.g. D = 1 - S for the cosine similarity of L2-normalised descriptors, "
        "or D = S.max() - S")


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


def read_provenance(path: Path | str) -> dict[str, Any]:
    with h5py.File(path, "r") as f:
        return {key: _maybe_json(value) for key, value in f.attrs.items()}


def _maybe_json(value: Any) -> Any:
    if isinstance(value, str) and value[:1] in "[{":
        try:
            return json.loads(value)
        except json.JSONDecodeError:
            return value
    return value.item() if isinstance(value, np.generic) else value
