"""The ``attributes`` stage: sequence matching, attributes and labels of one distance matrix, to .csv or .h5.

The matrix is opened lazily (a memory-mapped ``.npy`` or our HDF5 file) and read in blocks of query columns by
``query_features``, so the stage never holds more than the matrix's pages and one block's working arrays.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path

import numpy as np

from .attributes import ATTRIBUTE_NAMES, QueryFeatures, query_features
from .io import (
    CSV_SUFFIXES,
    HDF5_SUFFIXES,
    atomic_path,
    check_suffix,
    open_distance_matrix,
    read_provenance,
    write_features,
)

OUT_SUFFIXES = CSV_SUFFIXES + HDF5_SUFFIXES

log = logging.getLogger("vpr_smr")


def write_csv(path: Path | str, features: QueryFeatures) -> None:
    """One row per query: its index, the rank-0 attributes A1..A4 (the paper's names) and its label."""
    table = np.column_stack([features.queries, features.attributes[:, 0, :], features.labels])
    header = ",".join(("query", *ATTRIBUTE_NAMES, "label"))
    with atomic_path(path) as tmp:
        np.savetxt(tmp, table, delimiter=",", header=header, comments="", fmt=["%d", *["%.9g"] * 4, "%d"])


def main(distances: Path | str, out: Path | str, seq_len: int, tolerance: int) -> QueryFeatures:
    """Features of the matrix in ``distances`` (``.npy`` or our ``.h5``) written to ``out``.

    ``out`` ending in ``.csv`` gets the rank-0 table (``write_csv``); ``.h5``/``.hdf5`` every field of
    ``QueryFeatures`` as HDF5, with the distance file's provenance, ``seq_len``, ``tolerance`` and
    ``attributes_seconds`` (the time of the computation, reading included); another suffix is an error, before
    anything is read. Errors name the distance file (negative distances included: ``io.check_non_negative``).
    """
    out = check_suffix(out, OUT_SUFFIXES, "the attributes (.csv table or HDF5)")
    distances = Path(distances)
    start = time.perf_counter()
    with open_distance_matrix(distances) as matrix:
        try:
            features = query_features(matrix, seq_len, tolerance)
        except ValueError as error:
            raise ValueError(f"{distances}: {error}") from None
    seconds = time.perf_counter() - start
    if out.suffix.lower() in CSV_SUFFIXES:
        write_csv(out, features)
    else:
        provenance = read_provenance(distances) if distances.suffix != ".npy" else {}
        provenance = {k: v for k, v in provenance.items() if k != "vpr_smr_version"}
        write_features(out, features, {**provenance, "seq_len": seq_len, "tolerance": tolerance,
                                       "attributes_seconds": seconds})
    log.info("%d queries, %.1f µs per query", len(features.queries), 1e6 * seconds / max(len(features.queries), 1))
    return features
