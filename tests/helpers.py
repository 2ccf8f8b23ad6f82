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


# --- naive references of sequence matching (SPEC section 4), written from the definitions, one value at a time ---


def sequence_matrix(distance_matrix: np.ndarray, seq_len: int) -> np.ndarray:
    """``S[i, j] = sum_{k < L} D[i + k, j + k]``, shape ``(R - L + 1) x (Q - L + 1)``, float64."""
    d = np.asarray(distance_matrix, dtype=np.float64)
    rows, cols = d.shape[0] - seq_len + 1, d.shape[1] - seq_len + 1
    return np.array([[sum(d[i + k, j + k] for k in range(seq_len)) for j in range(cols)] for i in range(rows)])


def single_frame_matches(distance_matrix: np.ndarray) -> np.ndarray:
    """Best reference per query: ``argmin_r D[r, q]`` (first index on ties)."""
    return np.argmin(distance_matrix, axis=0)


def sequence_matches(sequence: np.ndarray, seq_len: int) -> tuple[np.ndarray, np.ndarray]:
    """Reference index matched to each query ``a >= L - 1`` and its sequence distance ``min_i S[i, j]``."""
    best = np.argmin(sequence, axis=0)
    return best + seq_len - 1, sequence[best, np.arange(sequence.shape[1])]


# --- a tiny learned backend, written as a plugin module (``module:TinyNet``) that tests and jobs import ---

TINY_NET = '''
import torch
from vpr_smr.descriptors.base import TorchBackend, to_tensor


class TinyNet(TorchBackend):
    """A convolution and global average pooling: a learned backend whose weights come from a file."""

    name = "tiny_net"
    default_conf = {"channels": 8, "kernel": 3}

    def build_model(self):
        conv = torch.nn.Conv2d(3, self.conf["channels"], self.conf["kernel"])
        return torch.nn.Sequential(conv, torch.nn.AdaptiveAvgPool2d(1), torch.nn.Flatten())

    def preprocess(self, image):
        return to_tensor(image)  # full size: frames of different sizes cannot share a batch
'''


def tiny_net_model(channels: int = 8, kernel: int = 3) -> Any:
    """The network of ``TINY_NET``'s backend with these settings (to write its checkpoints)."""
    import torch

    conv = torch.nn.Conv2d(3, channels, kernel)
    return torch.nn.Sequential(conv, torch.nn.AdaptiveAvgPool2d(1), torch.nn.Flatten())


# --- frames whose colour says which they are (the match inspector's tests) ---

COLOUR_FRAMES = 24  # frames per traverse of the ``colour_frames`` fixture


def reference_colour(i: int) -> tuple[int, int, int]:
    return (20 + 9 * i, 240 - 7 * i, 101)


def query_colour(i: int) -> tuple[int, int, int]:
    return (99, 15 + 8 * i, 230 - 5 * i)
