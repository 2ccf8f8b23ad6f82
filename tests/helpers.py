"""Helpers shared by the tests (not part of the package): small files in the pipeline's formats."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import h5py
import numpy as np

from vpr_smr.core.io import atomic_h5
from vpr_smr.eval.matching.io import open_distance_matrix


def write_distance_matrix(path: Path | str, distance_matrix: np.ndarray, provenance: dict[str, Any]) -> None:
    """A references x queries matrix in the distances stage's HDF5 layout."""
    with atomic_h5(path, provenance) as f:
        f.create_dataset("distance_matrix", data=distance_matrix.astype(np.float32))


def read_distance_matrix(path: Path | str) -> np.ndarray:
    """A references x queries matrix from our HDF5 file (``distance_matrix``) or a user's ``.npy``, in memory."""
    with open_distance_matrix(path) as matrix:
        return np.asarray(matrix[()] if isinstance(matrix, h5py.Dataset) else np.array(matrix))
