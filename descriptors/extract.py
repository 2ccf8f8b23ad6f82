"""Compute the descriptors of both traverses of a pair, in batches, into one HDF5 file.

The file holds ``reference`` and ``query`` arrays (N x dim, float32; the two traverses may differ in length when
they have positions) and ``reference_names`` / ``query_names``; a pair with positions (method §11) adds
``reference_positions`` / ``query_positions`` (N x 2, float64). Its attributes record the backend, its settings,
the checkpoint's SHA-256 and the frame list's fingerprint (positions included). A finished file with the same
provenance is not computed again.
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

from vpr_smr.core.progress import progress_bar
from vpr_smr.datasets import Traverse, TraversePair
from vpr_smr.descriptors import backend_class
from vpr_smr.descriptors.base import Backend, CheckpointError, TorchBackend, sha256_file

log = logging.getLogger(__name__)


class TraverseImages(Dataset[tuple[int, torch.Tensor]]):
    """Decodes and preprocesses images lazily, in DataLoader worker processes."""

    def __init__(self, traverse: Traverse, backend: Backend) -> None:
        self.traverse, self.backend = traverse, backend

    def __len__(self) -> int:
        return len(self.traverse)

    def __getitem__(self, index: int) -> tuple[int, torch.Tensor]:
        return index, torch.as_tensor(self.backend.preprocess(self.traverse.read(index)))

    def collate(self, items: list[tuple[int, torch.Tensor]]) -> torch.Tensor:
        """Stack a batch; frames whose preprocessed sizes differ get an error naming two of them."""
        shapes = {tuple(tensor.shape): index for index, tensor in items}
        if len(shapes) > 1:
            (shape_a, a), (shape_b, b) = list(shapes.items())[:2]
            files = self.traverse.images
            raise ValueError(
                f"images of different sizes in one batch: {files[a]} gives {list(shape_a)}, {files[b]} gives "
                f"{list(shape_b)} after the backend's preprocessing; resize the images to one size, or use a "
                "backend that resizes (most do), or --batch-size 1")
        return torch.stack([tensor for _, tensor in items])


def _backend_and_checkpoint(conf: dict[str, Any], method: str | None) -> tuple[type[Backend], dict[str, Any], Any]:
    """The backend class of a method's configuration entry, its own settings and the checkpoint setting."""
    conf = dict(conf)
    name = conf.pop("backend", method)
    if name is None:
        raise ValueError("the method's settings name no `backend`")
    checkpoint = conf.pop("checkpoint", None)
    cls = backend_class(name)
    if cls.needs_checkpoint and checkpoint in (None, ""):
        who, where = (f"method {method!r} (backend {name!r})", f"methods.{method}.checkpoint") if method \
            else (f"backend {name!r}", "`checkpoint`")
        raise CheckpointError(f"{who} needs a checkpoint: set {where} to the path of the downloaded file")
    return cls, conf, checkpoint


def build_backend(method: str, conf: dict[str, Any]) -> tuple[Backend, str | None]:
    """The backend of a method's configuration entry, with its weights loaded; also the checkpoint SHA-256."""
    cls, settings, checkpoint = _backend_and_checkpoint(conf, method)
    backend = cls(settings)
    backend.load(checkpoint)
    return backend, checkpoint_digest(backend)


def check_checkpoint(method_conf: dict[str, Any], method: str | None = None) -> str | None:
    """Check a method's configuration entry without computing anything: build its backend and check its
    checkpoint (every key and shape, strictly) as ``build_backend`` would load it. Returns the checkpoint's
    SHA-256, ``None`` for a backend without a file. ``method`` (the entry's name) only improves messages.

    Raises ``ValueError`` for an unknown backend or backend setting (the message names it) and
    ``CheckpointError`` (a ``ValueError`` too) for a checkpoint that is not set, missing, unreadable or does
    not fit. Cheap: a backend using ``TorchBackend.load`` builds its model on PyTorch's meta device (shapes
    only: no memory, no random initialisation), copies no weights and runs no image; reading the file and its
    SHA-256 are the costs (about 0.8 s for SALAD's 350 MB file on one CPU thread, against 1.3-1.5 s to load).
    """
    cls, settings, checkpoint = _backend_and_checkpoint(method_conf, method)
    backend: Backend
    if issubclass(cls, TorchBackend) and cls.load is TorchBackend.load:
        with torch.device("meta"):
            backend = cls(settings)
            backend.check(checkpoint)
    else:  # weight-free backends, or a plugin with its own load(): check as it loads
        backend = cls(settings)
        backend.check(checkpoint)
    return checkpoint_digest(backend)


def checkpoint_digest(backend: Backend) -> str | None:
    """SHA-256 of the file the backend loaded (``None`` without one)."""
    return sha256_file(backend.checkpoint_file) if backend.checkpoint_file is not None else None


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
    sample = images[0][1] if batch_size is None and len(images) else None
    batch_size, num_workers = default_loading(backend, batch_size, num_workers, sample)
    loader = DataLoader(
        images,
        batch_size=batch_size,
        num_workers=num_workers,
        pin_memory=backend.device.type == "cuda",
        persistent_workers=False,
        collate_fn=images.collate,
    )
    chunks: list[np.ndarray] = []
    # counted in images, not batches, in the format `vpr-smr run` reads from the job's log
    with progress_bar(total=len(images), unit="images", desc=desc) as bar:
        for batch in loader:
            chunks.append(backend.forward(batch))
            bar.update(len(batch))
    return np.concatenate(chunks).astype(np.float32)


def provenance_of(pair: TraversePair, method: str, conf: dict[str, Any], checkpoint_sha256: str | None,
                  backend: Backend | None = None) -> dict[str, str]:
    """What a descriptor file was computed from. ``backend_conf`` holds every backend setting in effect,
    defaults included (e.g. ``preprocessing``), so a changed default is not mistaken for a finished file."""
    provenance = {
        "dataset": pair.name,
        "method": method,
        "method_conf": json.dumps(conf, sort_keys=True),
        "checkpoint_sha256": checkpoint_sha256 or "",
        "frames_sha256": pair.fingerprint(),
    }
    if backend is not None:
        provenance["backend_conf"] = json.dumps(backend.conf, sort_keys=True, default=str)
    return provenance


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
    from vpr_smr.core import environment
    from vpr_smr.core.io import atomic_h5

    out = Path(out)
    backend, digest = build_backend(method, conf)
    provenance = provenance_of(pair, method, conf, digest, backend)
    if is_done(out, provenance):
        log.info("descriptors already computed: %s", out)
        return out
    arrays: tuple[np.ndarray, ...] | None = backend.precomputed(pair)
    if arrays is None:
        arrays = tuple(
            compute_descriptors(t, backend, batch_size, num_workers, desc=role)
            for role, t in (("reference", pair.reference), ("query", pair.query))
        )
    with atomic_h5(out, provenance) as f:
        # the numeric environment is information, not provenance: ``is_done`` does not compare it
        environment.record_in(f.attrs)
        f.attrs["distance"] = backend.distance
        for role, traverse, values in zip(("reference", "query"), (pair.reference, pair.query), arrays, strict=True):
            f.create_dataset(role, data=values)
            f.create_dataset(f"{role}_names", data=np.array([p.name for p in traverse.images], dtype="S"))
            if pair.has_positions:  # the distances stage copies each split's slice for its ground truth
                f.create_dataset(f"{role}_positions", data=np.asarray(traverse.positions, dtype=np.float64))
    return out
