"""SAD: patch-normalised thumbnails compared by mean absolute difference (method §2)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import torch

from vpr_smr.core.settings import setting
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


@dataclass(frozen=True)
class SADSettings:
    """The settings of ``sad``."""

    width: int = setting(64, "pixels: the width the grey image is resized to (OpenCV's area interpolation); a multiple "
                             "of patch")
    height: int = setting(32, "pixels: the height the grey image is resized to; a multiple of patch")
    patch: int = setting(8, "pixels: the side of the square blocks that patch normalisation brings each to zero mean "
                            "and unit standard deviation (a constant block becomes 0)")


class SAD(Backend):
    """Grey, resized to 64x32 (W x H), 8x8 patch normalisation: 2048 values."""

    name: ClassVar[str] = "sad"
    Settings: ClassVar[type | None] = SADSettings
    input_summary: ClassVar[str] = f"any; grey, resized to {SADSettings.width}x{SADSettings.height} (W x H)"
    distance = "mad"

    def preprocess(self, image: np.ndarray) -> torch.Tensor:
        # OpenCV's grey and INTER_AREA rules, computed exactly (the same bytes on every machine)
        grey = resize_area(to_grey(image), self.conf["width"], self.conf["height"])
        return torch.from_numpy(patch_normalise(grey, self.conf["patch"]).astype(np.float32).ravel())

    def forward(self, batch: torch.Tensor) -> np.ndarray:
        return batch.numpy().astype(np.float32)
