"""HOG: OpenCV's histogram of oriented gradients (its rules, computed exactly), a weight-free global descriptor."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import torch

from vpr_smr.core.settings import setting
from vpr_smr.descriptors.base import Backend
from vpr_smr.descriptors.classic import grey as to_grey
from vpr_smr.descriptors.classic import hog, l2_normalised, resize_area


@dataclass(frozen=True)
class HOGSettings:
    """The settings of ``hog``."""

    width: int = setting(128, "pixels: the width the grey image is resized to (OpenCV's area interpolation); a "
                              "multiple of cell")
    height: int = setting(64, "pixels: the height the grey image is resized to; a multiple of cell")
    cell: int = setting(8, "pixels: the side of a cell, the area of one orientation histogram; also the block stride")
    block: int = setting(16, "pixels: the side of a block, whose cells' histograms are normalised together; a "
                             "multiple of cell, at most the smaller image side")
    bins: int = setting(9, "the number of orientation bins per cell histogram, over unsigned gradients (0 to 180 "
                           "degrees); at least 2")


class HOG(Backend):
    """Grey image resized to ``width x height``, OpenCV's ``HOGDescriptor`` (block stride = cell), L2-normalised."""

    name: ClassVar[str] = "hog"
    Settings: ClassVar[type | None] = HOGSettings
    input_summary: ClassVar[str] = f"any; grey, resized to {HOGSettings.width}x{HOGSettings.height} (W x H)"

    def __init__(self, conf: dict[str, Any] | None = None) -> None:
        super().__init__(conf)
        c = self.conf
        problems = [f"{key} {c[key]} is not a multiple of cell {c['cell']}" for key in ("width", "height", "block")
                    if c[key] % c["cell"]]
        if c["bins"] < 2:
            problems.append(f"bins is {c['bins']}, at least 2 are needed")
        if c["block"] > min(c["width"], c["height"]):
            problems.append(f"block {c['block']} is larger than the {c['width']}x{c['height']} image")
        if problems:
            defaults = ", ".join(f"{key} {value}" for key, value in self.default_conf.items())
            raise ValueError(f"hog: {'; '.join(problems)}: set the method's settings so (the defaults: {defaults})")

    def preprocess(self, image: np.ndarray) -> torch.Tensor:
        # OpenCV's grey, INTER_AREA and HOGDescriptor rules in exact float64 NumPy (descriptors.classic): OpenCV's
        # own SIMD paths differ by CPU, which reordered near-ties between machines
        c = self.conf
        grey = resize_area(to_grey(image), c["width"], c["height"])
        return torch.from_numpy(l2_normalised(hog(grey, c["cell"], c["block"], c["bins"])))

    def forward(self, batch: torch.Tensor) -> np.ndarray:
        return batch.numpy().astype(np.float32)
