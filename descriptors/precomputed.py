"""Descriptors computed elsewhere: the ``.npy`` files of VPR-methods-evaluation's ``--save_descriptors``.

That tool writes ``database_descriptors.npy`` (references) and ``queries_descriptors.npy`` (queries), one row
per image in the sorted order of each folder. Point ``folder`` at the directory holding both (or give
``database`` and ``queries`` paths); the dataset's frames must be the same images in the same order.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np

from vpr_smr.core.files import load_npy
from vpr_smr.core.settings import setting
from vpr_smr.datasets import TraversePair
from vpr_smr.descriptors.base import Backend, CheckpointError

DATABASE_FILE = "database_descriptors.npy"
QUERIES_FILE = "queries_descriptors.npy"


@dataclass(frozen=True)
class PrecomputedSettings:
    """The settings of ``precomputed``."""

    folder: str | None = setting(None, f"text or null: the folder holding {DATABASE_FILE} and {QUERIES_FILE} "
                                       "(VPR-methods-evaluation's --save_descriptors); null: database and queries name "
                                       "the files")
    database: str | None = setting(None, "text or null: the .npy file of the reference descriptors, one row per "
                                         f"frame in frame order; null: {DATABASE_FILE} in folder")
    queries: str | None = setting(None, "text or null: the .npy file of the query descriptors, one row per frame in "
                                        f"frame order; null: {QUERIES_FILE} in folder")


class Precomputed(Backend):
    name: ClassVar[str] = "precomputed"
    Settings: ClassVar[type | None] = PrecomputedSettings
    input_summary: ClassVar[str] = "no images: descriptors read from files"

    def paths(self) -> tuple[Path, Path]:
        folder = self.conf["folder"]
        database = self.conf["database"] or (Path(folder) / DATABASE_FILE if folder else None)
        queries = self.conf["queries"] or (Path(folder) / QUERIES_FILE if folder else None)
        if database is None or queries is None:
            raise CheckpointError(
                "backend 'precomputed' needs `folder` (holding database_descriptors.npy and queries_descriptors.npy) "
                "or both `database` and `queries` in the method's settings"
            )
        return Path(database), Path(queries)

    def precomputed(self, pair: TraversePair) -> tuple[np.ndarray, np.ndarray]:
        arrays = []
        for path, traverse in zip(self.paths(), (pair.reference, pair.query), strict=True):
            if not path.is_file():
                raise CheckpointError(f"precomputed descriptors not found: {path}")
            try:
                values = load_npy(path, f"the {traverse.name} descriptors (frames x dim)")
            except ValueError as error:
                raise CheckpointError(str(error)) from None
            if values.ndim != 2 or len(values) != len(traverse):
                raise CheckpointError(
                    f"{path} holds an array of shape {values.shape}, but dataset {pair.name!r} has {len(traverse)} "
                    f"{traverse.name} frames: expected ({len(traverse)}, dim), one row per frame in the same order"
                )
            arrays.append(values.astype(np.float32))
        if arrays[0].shape[1] != arrays[1].shape[1]:
            raise CheckpointError(f"database and query descriptors differ in size: {arrays[0].shape[1]} and "
                                  f"{arrays[1].shape[1]}")
        return arrays[0], arrays[1]
