"""Compute the descriptors of both traverses of a pair, in batches, into one HDF5 file.

The file holds ``reference`` and ``query`` arrays (N x dim, float32) and ``reference_names`` /
``query_names``; its attributes record the backend, its settings, the checkpoint's SHA-256 and the frame
list's fingerprint. A finished file with the same provenance is not computed again.
"""

from __future__ import annotations

import json
import logging
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import torch
from torch.utils.data import DataLoader, Dataset
from tqdm import tqdm

from ..datasets import Traverse, TraversePair
from . import backend_class
from .base import Backend, CheckpointError, sha256_file

log = logging.getLogger(__name__)


class TraverseImages(Dataset):
    """Decodes and preprocesses images lazily, in DataLoader worker processes."""

    def __init__(self, traverse: Traverse, backend: Backend) -> None:
        self.traverse, self.backend = traverse, backend

    def __len__(self) -> int:
        return len(self.traverse)

    def __getitem__(self, index: int) -> torch.Tensor:
        return torch.as_tensor(self.backend.preprocess(self.traverse.read(index)))


def build_backend(method: str, conf: dict[str, Any]) -> tuple[Backend, str | None]:
    """The backend of a method's configuration entry, with its weights loaded; also the checkpoint SHA-256."""
    conf = dict(conf)
    name = conf.pop("backend", method)
    checkpoint = conf.pop("checkpoint", None)
    cls = backend_class(name)
    if cls.needs_checkpoint and checkpoint in (None, ""):
        raise CheckpointError(
            f"method {method!r} (backend {name!r}) needs a checkpoint: set methods.{method}.checkpoint "
            "to the path of the downloaded file"
        )
    backend = cls(conf)
    backend.load(checkpoint)
    digest = None
    if checkpoint not in (None, "", "package") and Path(checkpoint).is_file():
        digest = sha256_file(checkpoint)
    return backend, digest


CPU_BATCH_ELEMENTS = 8 * 3 * 112 * 224  # a CPU batch holds about this many input values (see below)


def default_loading(
    backend: Backend, batch_size: int | None, num_workers: int | None, sample: torch.Tensor | None = None
) -> tuple[int, int]:
    """Batch size and decoding workers when the configuration leaves them unset (``null``).

    Measured on a 2-core CPU (benchmarks/extraction.py): CPU networks run fastest on batches of about
    600k input values (8 images of 112x224; a single 480x640 frame), and decoding workers only pay off when
    there are cores to spare beyond the network's threads. A GPU gets batches of 32 and up to 4 workers.
    ``sample`` is one preprocessed image, which sets the CPU batch size.
    """
    import os

    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    on_gpu = backend.device.type == "cuda"
    if batch_size is None:
        if on_gpu:
            batch_size = 32
        else:
            elements = sample.numel() if sample is not None else CPU_BATCH_ELEMENTS // 8
            batch_size = int(min(64, max(1, round(CPU_BATCH_ELEMENTS / elements))))
    if num_workers is None:
        num_workers = min(4, cores - 1) if on_gpu else min(4, cores // 4)
    return batch_size, num_workers


def compute_descriptors(
    traverse: Traverse, backend: Backend, batch_size: int | None = None, num_workers: int | None = None,
    desc: str = "",
) -> np.ndarray:
    images = TraverseImages(traverse, backend)
    sample = images[0] if batch_size is None and len(images) else None
    batch_size, num_workers = default_loading(backend, batch_size, num_workers, sample)
    loader = DataLoader(
        images,
        batch_size=batch_size,
        num_workers=num_workers,
        pin_memory=backend.device.type == "cuda",
        persistent_workers=False,
    )
    chunks = [backend.forward(batch) for batch in tqdm(loader, desc=desc, unit="batch", leave=False)]
    return np.concatenate(chunks).astype(np.float32)


def provenance_of(pair: TraversePair, method: str, conf: dict[str, Any], checkpoint_sha256: str | None) -> dict:
    return {
        "dataset": pair.name,
        "method": method,
        "method_conf": json.dumps(conf, sort_keys=True),
        "checkpoint_sha256": checkpoint_sha256 or "",
        "frames_sha256": pair.fingerprint(),
    }


def is_done(path: Path, provenance: dict[str, Any]) -> bool:
    if not path.is_file():
        return False
    try:
        with h5py.File(path, "r") as f:
            return all(f.attrs.get(k) == v for k, v in provenance.items())
    except OSError:  # an unreadable file is recomputed
        return False


def main(
    pair: TraversePair,
    method: str,
    conf: dict[str, Any],
    out: Path | str,
    batch_size: int | None = None,
    num_workers: int | None = None,
) -> Path:
    """Write ``out`` (HDF5) with the descriptors of both traverses; skip if already done with this provenance."""
    from ..eval.io import atomic_h5

    out = Path(out)
    backend, digest = build_backend(method, conf)
    provenance = provenance_of(pair, method, conf, digest)
    if is_done(out, provenance):
        log.info("descriptors already computed: %s", out)
        return out
    arrays = backend.precomputed(pair)
    if arrays is None:
        arrays = tuple(
            compute_descriptors(t, backend, batch_size, num_workers, desc=f"{method} {pair.name} {role}")
            for role, t in (("reference", pair.reference), ("query", pair.query))
        )
    with atomic_h5(out, provenance) as f:
        f.attrs["distance"] = backend.distance
        for role, traverse, values in zip(("reference", "query"), (pair.reference, pair.query), arrays, strict=True):
            f.create_dataset(role, data=values)
            f.create_dataset(f"{role}_names", data=np.array([p.name for p in traverse.images], dtype="S"))
    return out
