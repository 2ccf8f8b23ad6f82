"""Reference x query distance matrices (SPEC section 3)."""

from __future__ import annotations

import numpy as np
import torch

METRICS = ("l2", "cosine", "mad")


def l2_normalise(descriptors: np.ndarray) -> np.ndarray:
    norms = np.linalg.norm(descriptors, axis=1, keepdims=True)
    return descriptors / np.where(norms == 0, 1.0, norms)


def distance_matrix(reference: np.ndarray, query: np.ndarray, metric: str = "l2", block: int = 512) -> np.ndarray:
    """``D[r, q]`` between reference and query descriptors, float32, references x queries.

    - ``l2``: squared Euclidean distance of the L2-normalised descriptors (faiss, as the authors' code);
    - ``cosine``: ``1 - cos``, of the same normalised descriptors;
    - ``mad``: mean absolute difference (SAD).
    """
    reference = np.ascontiguousarray(reference, dtype=np.float32)
    query = np.ascontiguousarray(query, dtype=np.float32)
    if reference.ndim != 2 or query.ndim != 2 or reference.shape[1] != query.shape[1]:
        raise ValueError(
            f"descriptors must be 2-D with the same dimension, got {reference.shape} and {query.shape}"
        )
    if metric in ("l2", "cosine"):
        import faiss

        reference, query = l2_normalise(reference), l2_normalise(query)
        if metric == "cosine":
            return (1.0 - reference @ query.T).astype(np.float32)
        # pairwise_distances(xq, xb) is what IndexFlatL2 computes for every pair: squared L2.
        return np.ascontiguousarray(faiss.pairwise_distances(query, reference).T, dtype=np.float32)
    if metric == "mad":
        ref_t, query_t = torch.from_numpy(reference), torch.from_numpy(query)
        out = np.empty((len(reference), len(query)), dtype=np.float32)
        for start in range(0, len(reference), block):  # bounded memory, cdist does the work
            out[start : start + block] = torch.cdist(ref_t[start : start + block], query_t, p=1).numpy()
        return out / reference.shape[1]
    raise ValueError(f"unknown distance metric {metric!r}; choose one of {', '.join(METRICS)}")
