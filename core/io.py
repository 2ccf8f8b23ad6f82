"""Files of the pipeline: written to a temporary name and renamed, with provenance attributes; suffix checks.

At the bottom of the data flow: every stage writes through these helpers and nothing here imports a stage.
"""

from __future__ import annotations

import json
import os
import secrets
from collections.abc import Iterator
from contextlib import contextmanager
from functools import cache
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from vpr_smr.core.files import read_head, what_it_is

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


@cache  # each lookup scans sys.path for the distribution; a stage asks for it twice (--version, the output file)
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


@contextmanager
def open_h5(path: Path | str, what: str, **options: Any) -> Iterator[h5py.File]:
    """The HDF5 file ``path`` open for reading (``options`` go to ``h5py.File``). A file that is missing, not HDF5
    or damaged raises FileNotFoundError or ValueError naming it, what it is and ``what`` it should be (e.g. "a
    predictor written by vpr-smr train"), instead of h5py's "file signature not found" or "truncated file: eof =".
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{what} not found: {path}")
    if not h5py.is_hdf5(path):  # its signature, at 0 or after a user block (MATLAB v7.3 puts one of 512 bytes)
        raise ValueError(f"{path} is {what_it_is(read_head(path))}, not an HDF5 file: expected {what}")
    try:
        handle = h5py.File(path, "r", **options)
    except OSError as error:  # h5py's reason, e.g. "truncated file: eof = 20000, sblock->base_addr = 0, ..."
        raise ValueError(f"{path} is a damaged or truncated HDF5 file ({error}; a copy or download that stopped?): "
                         f"expected {what}; write or copy it again") from None
    with handle:
        yield handle


def read_provenance(path: Path | str) -> dict[str, Any]:
    with open_h5(path, "an HDF5 file written by vpr-smr") as f:
        return {key: _maybe_json(value) for key, value in f.attrs.items()}


def _maybe_json(value: Any) -> Any:
    if isinstance(value, str) and value[:1] in "[{":
        try:
            return json.loads(value)
        except json.JSONDecodeError:
            return value
    return value.item() if isinstance(value, np.generic) else value
