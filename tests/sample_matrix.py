"""A real distance matrix: SAD distances of frames of the shipped Nordland sample (summer references, winter
queries), computed here from the images."""

from __future__ import annotations

import numpy as np

from vpr_smr.datasets import read_image
from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT


def sad(path) -> np.ndarray:
    """The SAD descriptor written out: a 64x32 grey frame, each 8x8 patch normalised to mean 0 and std 1."""
    import cv2

    grey = cv2.resize(cv2.cvtColor(read_image(path), cv2.COLOR_RGB2GRAY), (64, 32)).astype(np.float64)
    patches = grey.reshape(4, 8, 8, 8).swapaxes(1, 2).reshape(32, 64)
    std = patches.std(axis=1, keepdims=True)
    return np.where(std > 0, (patches - patches.mean(axis=1, keepdims=True)) / np.where(std > 0, std, 1), 0).ravel()


def sample_distances(first: int, count: int) -> np.ndarray:
    """The ``count x count`` SAD distances (mean absolute difference of the descriptors, float64) of the sample's
    frames ``first .. first + count - 1`` (files ``images-{10 * i:05d}.png``), references x queries."""
    names = [f"images-{10 * i:05d}.png" for i in range(first, first + count)]
    reference = np.stack([sad(DEFAULT_ROOT / "summer" / n) for n in names])
    query = np.stack([sad(DEFAULT_ROOT / "winter" / n) for n in names])
    distances: np.ndarray = np.abs(reference[:, None, :] - query[None, :, :]).mean(axis=2)
    return distances
