"""Reference x query distance matrices (method §3), in memory or written block by block to chunked HDF5."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vpr_smr.core import environment
from vpr_smr.core.constants import METRICS
from vpr_smr.core.io import HDF5_SUFFIXES, atomic_h5, check_suffix, open_h5
from vpr_smr.core.settings import REQUIRED, setting

# Chunks of the stored matrix: whole chunk columns are what the attributes stage reads (blocks of about 2^20 / R
# query columns, all references). 4096 x 64 float32 is 1 MB, inside HDF5's advised range; a 27592-reference column
# block touches 7 chunks (7 MB), which the reader's 64 MB chunk cache keeps for the next block's overlap.
CHUNK_ROWS, CHUNK_COLUMNS = 4096, 64
BLOCK_VALUES = 1 << 24  # distances computed per block of query columns (64 MB of float32)


def l2_normalise(descriptors: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    norms = np.linalg.norm(descriptors, axis=1, keepdims=True)
    normalised: np.ndarray = np.divide(descriptors, np.where(norms == 0, 1.0, norms).astype(descriptors.dtype), out=out)
    return normalised


def _check_metric(metric: str) -> None:
    if metric not in METRICS:
        raise ValueError(f"unknown distance metric {metric!r}; choose one of {', '.join(METRICS)}")


def prepare_references(reference: np.ndarray, metric: str, in_place: bool = False) -> np.ndarray:
    """Reference descriptors as ``distance_columns`` takes them: float32, L2-normalised for ``l2`` and ``cosine``.

    ``in_place`` normalises an array the caller owns without a second copy (large traverses).
    """
    _check_metric(metric)
    reference = np.ascontiguousarray(reference, dtype=np.float32)
    if reference.ndim != 2:
        raise ValueError(f"reference descriptors must be 2-D (frames x dimension), got shape {reference.shape}")
    if metric in ("l2", "cosine"):
        return l2_normalise(reference, out=reference if in_place else None)
    return reference


def distance_columns(reference: np.ndarray, query: np.ndarray, metric: str, block: int = 512) -> np.ndarray:
    """``D[:, q]`` for a block of query descriptors, ``reference`` prepared by ``prepare_references``; float32."""
    query = np.ascontiguousarray(query, dtype=np.float32)
    if query.ndim != 2 or reference.shape[1] != query.shape[1]:
        raise ValueError(
            f"descriptors must be 2-D with the same dimension, got {reference.shape} and {query.shape}"
        )
    if metric in ("l2", "cosine"):
        query = l2_normalise(query)
        if metric == "cosine":
            out: np.ndarray = (1.0 - reference @ query.T).astype(np.float32)
        else:
            import faiss

            # pairwise_distances(xq, xb) is what IndexFlatL2 computes for every pair: squared L2.
            out = np.ascontiguousarray(faiss.pairwise_distances(query, reference).T, dtype=np.float32)
        # Both are |r|^2 + |q|^2 - 2 r.q in float32: about -1e-6 for (nearly) identical descriptors. Kept as they
        # are, as faiss (and the authors' code) gives them: clamping at 0 turns them into ties and moves Table I
        # (measured on the demo: HOG 78.16 % -> 76.71 %). The attributes stage accepts rounding-sized negatives.
        return out
    if metric == "mad":
        import torch

        ref_t, query_t = torch.from_numpy(reference), torch.from_numpy(query)
        out = np.empty((len(reference), len(query)), dtype=np.float32)
        for start in range(0, len(reference), block):  # bounded memory, cdist does the work
            out[start : start + block] = torch.cdist(ref_t[start : start + block], query_t, p=1).numpy()
        out /= reference.shape[1]
        return out
    _check_metric(metric)
    raise AssertionError  # unreachable


def distance_matrix(reference: np.ndarray, query: np.ndarray, metric: str = "l2", block: int = 512) -> np.ndarray:
    """``D[r, q]`` between reference and query descriptors, float32, references x queries.

    - ``l2``: squared Euclidean distance of the L2-normalised descriptors (faiss, as the authors' code);
    - ``cosine``: ``1 - cos``, of the same normalised descriptors;
    - ``mad``: mean absolute difference (SAD).
    """
    _check_metric(metric)
    reference = np.asarray(reference)
    query = np.asarray(query)
    if reference.ndim != 2 or query.ndim != 2 or reference.shape[1] != query.shape[1]:
        raise ValueError(
            f"descriptors must be 2-D with the same dimension, got {reference.shape} and {query.shape}"
        )
    return distance_columns(prepare_references(reference, metric), query, metric, block)


def distance_chunks(n_ref: int, n_query: int) -> tuple[int, int]:
    return min(n_ref, CHUNK_ROWS), min(n_query, CHUNK_COLUMNS)


def write_distance_blocks(out: Any, reference: np.ndarray, query: Any, metric: str, query_offset: int = 0,
                          block_queries: int | None = None) -> None:
    """Fill ``out`` (``R x Q``, an ``h5py.Dataset`` or array) with the distances of ``query[query_offset + q]``,
    computed ``block_queries`` chunk-aligned query columns at a time; ``reference`` from ``prepare_references``."""
    n_ref, n_query = out.shape
    step = block_queries or max(CHUNK_COLUMNS, BLOCK_VALUES // max(n_ref, 1) // CHUNK_COLUMNS * CHUNK_COLUMNS)
    for start in range(0, n_query, step):
        stop = min(n_query, start + step)
        out[:, start:stop] = distance_columns(reference, query[query_offset + start : query_offset + stop], metric)


POSITIONS = ("reference_positions", "query_positions")  # method §11: one position per frame, when the pair has them


def _check_descriptors(f: Any, descriptors: Path, split: str, ranges: dict[str, tuple[int, int]]) -> None:
    """Raise when the descriptor file lacks what the stage reads, or a range falls outside its traverse."""
    missing = [k for k in ("reference", "query") if k not in f]
    missing += [f"attribute {k!r}" for k in ("distance", "dataset", "method", "checkpoint_sha256",
                                              "frames_sha256") if k not in f.attrs]
    if sum(k in f for k in POSITIONS) == 1:
        missing.append(next(k for k in POSITIONS if k not in f))
    if missing:
        raise ValueError(f"{descriptors} lacks {', '.join(missing)}: run the descriptors stage again")
    for name, (lo, hi) in ranges.items():
        if not 0 <= lo < hi <= len(f[name]):
            raise ValueError(f"{descriptors}: split {split!r} covers frames {lo}..{hi - 1}, but {name!r} has "
                             f"{len(f[name])} frames; were these descriptors computed for this dataset?")


@dataclass(frozen=True)
class DistancesJob:
    """The ``distances`` stage's job: the distance matrix of one split of a descriptor file."""

    descriptors: str = setting(REQUIRED, "the descriptor file (.h5) of vpr-smr descriptors", metavar="PATH")
    split: str = setting(REQUIRED, "the split's name, e.g. test (written in the file)", metavar="NAME")
    frames: tuple[int, ...] = setting(REQUIRED, "the split's frames lo..hi-1 of both traverses (its queries, with "
                                                "--reference-frames): LO HI", min_items=2, max_items=2)
    reference_frames: tuple[int, ...] | None = setting(
        None, "the split's reference frames lo..hi-1, when they differ from --frames (traverses with positions): "
              "LO HI", min_items=2, max_items=2)
    metric: str | None = setting(None, "the distance (default: the descriptor file's, its backend's)",
                                 choices=METRICS)
    out: str = setting(REQUIRED, "the output file: the distance matrix (HDF5)", metavar="PATH")


def main(job: DistancesJob, block_queries: int | None = None) -> Path:
    """The ``distances`` stage: the R x Q matrix of one split of a descriptor file, to chunked HDF5.

    ``job.descriptors`` holds ``reference`` and ``query`` (frames x dimension) and the attributes ``distance``,
    ``dataset``, ``method``, ``checkpoint_sha256``, ``frames_sha256``; the split's queries are frames
    ``job.frames = (lo, hi)``, its references frames ``job.reference_frames`` (default: the same range). Only the
    split's references and one block of queries (``block_queries`` columns; default: about 64 MB) are in memory at
    a time. ``job.metric`` (one of ``METRICS``) overrides the file's ``distance`` (its backend's default): the
    workflow passes the method's ``distance`` setting here, so that changing it does not recompute the descriptors.

    When the descriptor file holds ``reference_positions`` and ``query_positions`` (method §11), the split's slices
    of them are written beside the matrix under the same names: the ground truth of the later stages. The
    provenance's ``split_range`` is the query range; ``reference_range`` is added only when it differs.
    """
    out = check_suffix(job.out, HDF5_SUFFIXES, "the distance matrix (HDF5)")
    descriptors, split, metric = Path(job.descriptors), job.split, job.metric
    lo, hi = (int(v) for v in job.frames)
    ref_lo, ref_hi = (int(v) for v in (job.reference_frames or (lo, hi)))
    with open_h5(descriptors, "a descriptor file written by vpr-smr descriptors") as f:
        _check_descriptors(f, descriptors, split, {"reference": (ref_lo, ref_hi), "query": (lo, hi)})
        if (ref_lo, ref_hi) != (lo, hi) and not all(k in f for k in POSITIONS):
            # without positions the later stages score frame indices within a tolerance, which presumes the same
            # frames of both traverses: other ranges would be scored against the wrong references
            raise ValueError(f"{descriptors} has no positions, so split {split!r} must cover the same frames of "
                             f"both traverses: --reference-frames {ref_lo} {ref_hi} differs from --frames {lo} "
                             f"{hi}; give a dataset positions (method §11) to use separate ranges")
        if metric is None:
            metric = f.attrs["distance"]
            metric = metric.decode() if isinstance(metric, bytes) else str(metric)
        _check_metric(metric)
        provenance = {k: f.attrs[k] for k in ("dataset", "method", "checkpoint_sha256", "frames_sha256")}
        provenance.update(split=split, split_range=[lo, hi])
        if (ref_lo, ref_hi) != (lo, hi):  # only then: files of frame-aligned splits stay as they were
            provenance["reference_range"] = [ref_lo, ref_hi]
        reference = prepare_references(f["reference"][ref_lo:ref_hi], metric, in_place=True)
        shape = (ref_hi - ref_lo, hi - lo)
        with atomic_h5(out, {**provenance, "metric": metric}) as g:
            dataset = g.create_dataset("distance_matrix", shape=shape, dtype=np.float32, chunks=distance_chunks(*shape))
            write_distance_blocks(dataset, reference, f["query"], metric, lo, block_queries)
            # information only: l2 and cosine go through the BLAS, whose kernel and threads round them
            environment.record_in(g.attrs)
            if all(k in f for k in POSITIONS):
                g.create_dataset("reference_positions", data=f["reference_positions"][ref_lo:ref_hi])
                g.create_dataset("query_positions", data=f["query_positions"][lo:hi])
    return out
