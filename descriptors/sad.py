"""SAD: patch-normalised thumbnails compared by mean absolute difference (method §2)."""

from __future__ import annotations

from typing import Any, ClassVar

import cv2
import numpy as np
import torch

from vpr_smr.descriptors.base import Backend


def patch_normalise(grey: np.ndarray, patch: int) -> np.ndarray:
    """Each ``patch x patch`` block to zero mean and unit (population) std; a constant block becomes 0."""
    h, w = grey.shape
    if h % patch or w % patch:
        raise ValueError(f"image size {w}x{h} is not a multiple of the patch size {patch}")
    blocks = grey.reshape(h // patch, patch, w // patch, patch).astype(np.float64)
    mean = blocks.mean(axis=(1, 3), keepdims=True)
    std = blocks.std(axis=(1, 3), keepdims=True)
    centred = blocks - mean
    normalised: np.ndarray = np.divide(centred, std, out=np.zeros_like(centred), where=std > 0)
    return normalised.reshape(h, w)


class SAD(Backend):
    """Grey, resized to 64x32 (W x H), 8x8 patch normalisation: 2048 values."""

    name: ClassVar[str] = "sad"
    default_conf: ClassVar[dict[str, Any]] = {"width": 64, "height": 32, "patch": 8}
    input_summary: ClassVar[str] = f"any; grey, resized to {default_conf['width']}x{default_conf['height']} (W x H)"
    distance = "mad"

    def preprocess(self, image: np.ndarray) -> torch.Tensor:
        grey = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
        size = (self.conf["width"], self.conf["height"])
        if grey.shape[::-1] != size:
            grey = cv2.resize(grey, size, interpolation=cv2.INTER_AREA)
        return torch.from_numpy(patch_normalise(grey, self.conf["patch"]).astype(np.float32).ravel())

    def forward(self, batch: torch.Tensor) -> np.ndarray:
        return batch.numpy().astype(np.float32)
