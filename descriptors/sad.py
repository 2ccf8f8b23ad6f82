"""SAD: patch-normalised thumbnails compared by mean absolute difference (method §2)."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
import torch

from vpr_smr.descriptors.base import Backend
from vpr_smr.descriptors.classic import grey as to_grey
from vpr_smr.descriptors.classic import resize_area, row_sums


def patch_normalise(grey: np.ndarray, patch: int) -> np.ndarray:
    """Each ``patch x patch`` block to zero mean and unit (population) std; a constant block becomes 0.

    The sums run left to right (``classic.row_sums``, float64), so the result does not depend on a library's
    summation order or SIMD path."""
    h, w = grey.shape
    if h % patch or w % patch:
        raise ValueError(f"image size {w}x{h} is not a multiple of the patch size {patch}")
    blocks = grey.reshape(h // patch, patch, w // patch, patch).astype(np.float64).transpose(0, 2, 1, 3)
    flat = blocks.reshape(-1, patch * patch)
    mean = row_sums(flat) / flat.shape[1]
    centred = flat - mean[:, None]
    std = np.sqrt(row_sums(centred * centred) / flat.shape[1])
    normalised = np.divide(centred, std[:, None], out=np.zeros_like(centred), where=std[:, None] > 0)
    result: np.ndarray = normalised.reshape(blocks.shape).transpose(0, 2, 1, 3).reshape(h, w)
    return result


class SAD(Backend):
    """Grey, resized to 64x32 (W x H), 8x8 patch normalisation: 2048 values."""

    name: ClassVar[str] = "sad"
    default_conf: ClassVar[dict[str, Any]] = {"width": 64, "height": 32, "patch": 8}
    settings_help: ClassVar[dict[str, str]] = {
        "width": "pixels: the width the grey image is resized to (OpenCV's area interpolation); a multiple of patch",
        "height": "pixels: the height the grey image is resized to; a multiple of patch",
        "patch": "pixels: the side of the square blocks that patch normalisation brings each to zero mean and unit "
                 "standard deviation (a constant block becomes 0)",
    }
    input_summary: ClassVar[str] = f"any; grey, resized to {default_conf['width']}x{default_conf['height']} (W x H)"
    distance = "mad"

    def preprocess(self, image: np.ndarray) -> torch.Tensor:
        # OpenCV's grey and INTER_AREA rules, computed exactly (the same bytes on every machine)
        grey = resize_area(to_grey(image), self.conf["width"], self.conf["height"])
        return torch.from_numpy(patch_normalise(grey, self.conf["patch"]).astype(np.float32).ravel())

    def forward(self, batch: torch.Tensor) -> np.ndarray:
        return batch.numpy().astype(np.float32)
