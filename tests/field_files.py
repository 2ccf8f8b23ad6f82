"""Ground truths and matrices as the field writes them, for the tests of the ground-truth kinds and users' matrices:
MATLAB v7.3 the way MATLAB writes it (HDF5 behind a 512-byte text header, each matrix stored column-major, so that
h5py shows MATLAB's R x Q variable as Q x R), VPR-Bench's ``ground_truth_new.npy`` (a pickled array of
``[query, [references]]`` rows, written the way VPR-Bench's own helper writes it), per-query lists as JSON and as a
CSV of pairs."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import h5py
import numpy as np

MATLAB_CLASS = {"b": "logical", "f": "double", "u": "uint8", "i": "int64"}


def band(n_reference: int, n_query: int, tolerance: int) -> np.ndarray:
    """The boolean matrix of ``|r - q| <= tolerance``, written out."""
    return np.abs(np.arange(n_reference)[:, None] - np.arange(n_query)[None, :]) <= tolerance


def lists_of(truth: np.ndarray) -> dict[int, list[int]]:
    """Per-query lists of a boolean references x queries matrix (every query, an empty list where none)."""
    return {q: [int(r) for r in np.flatnonzero(truth[:, q])] for q in range(truth.shape[1])}


def write_mat73(path: Path, variables: dict[str, np.ndarray]) -> Path:
    """A MATLAB v7.3 file of 2-D ``variables`` as MATLAB writes them: stored transposed (column-major), with their
    MATLAB class (``logical`` as uint8), behind MATLAB's header."""
    with h5py.File(path, "w", userblock_size=512) as f:
        for name, value in variables.items():
            value = np.asarray(value)
            stored = f.create_dataset(name, data=np.ascontiguousarray(value.T.astype(np.uint8 if value.dtype == bool
                                                                                       else value.dtype)))
            stored.attrs["MATLAB_class"] = np.bytes_(MATLAB_CLASS[value.dtype.kind])
    header = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  1 00:00:00 2024 HDF5 schema 1.00 ."
    with open(path, "r+b") as handle:  # text, subsystem offset, version 0x0200, endian indicator
        handle.write(header.ljust(116, b" ") + b"\0" * 8 + (0x0200).to_bytes(2, "little") + b"IM")
    return path


def write_vpr_bench(path: Path, lists: dict[int, list[int]]) -> Path:
    """VPR-Bench's ground_truth_new.npy: an object array of rows [query, [references]] (``np.save`` pickles it)."""
    rows = np.empty((len(lists), 2), dtype=object)
    for i, (query, references) in enumerate(sorted(lists.items())):
        rows[i, 0], rows[i, 1] = query, list(references)
    np.save(path, rows, allow_pickle=True)  # writing the field's file; vpr-smr never loads one this way
    return path


def save_rows(path: Path, rows: list[Any]) -> Path:
    """VPR-Bench's form as rows of any content: a 1-D object array of ``[query, references]`` rows (``np.save``
    pickles it), e.g. a ``range`` of references, to test what the bounded reader refuses."""
    array = np.empty(len(rows), dtype=object)
    for i, row in enumerate(rows):
        array[i] = row
    np.save(path, array, allow_pickle=True)  # writing the field's file; vpr-smr never loads one this way
    return path


def write_json_lists(path: Path, lists: dict[int, list[int]]) -> Path:
    path.write_text(json.dumps({str(q): refs for q, refs in lists.items()}))
    return path


def write_csv_pairs(path: Path, lists: dict[int, list[int]]) -> Path:
    path.write_text("query,reference\n" + "".join(f"{q},{r}\n" for q, refs in lists.items() for r in refs))
    return path
