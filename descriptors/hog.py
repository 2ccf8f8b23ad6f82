"""HOG: OpenCV's histogram of oriented gradients, a classical weight-free global descriptor."""

from __future__ import annotations

from typing import Any, ClassVar

import cv2
import numpy as np
import torch

from vpr_smr.descriptors.base import Backend


class HOG(Backend):
    """Grey image resized to ``width x height``, OpenCV ``HOGDescriptor``, L2-normalised."""

    name: ClassVar[str] = "hog"
    default_conf: ClassVar[dict[str, Any]] = {"width": 128, "height": 64, "cell": 8, "block": 16, "bins": 9}
    input_summary: ClassVar[str] = f"any; grey, resized to {default_conf['width']}x{default_conf['height']} (W x H)"

    def __init__(self, conf: dict[str, Any] | None = None) -> None:
        super().__init__(conf)
        c = self.conf
        if c["width"] % c["cell"] or c["height"] % c["cell"] or c["block"] % c["cell"]:
            raise ValueError("hog: width, height and block must be multiples of cell")

    def _descriptor(self) -> cv2.HOGDescriptor:
        # Built per call: cv2 objects do not pickle into DataLoader workers.
        c = self.conf
        return cv2.HOGDescriptor(
            (c["width"], c["height"]), (c["block"], c["block"]), (c["cell"], c["cell"]), (c["cell"], c["cell"]),
            c["bins"],
        )

    def preprocess(self, image: np.ndarray) -> torch.Tensor:
        grey = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
        grey = cv2.resize(grey, (self.conf["width"], self.conf["height"]), interpolation=cv2.INTER_AREA)
        # OpenCV's stubs say Sequence[float]; compute returns an ndarray, which np.asarray passes through.
        values = np.asarray(self._descriptor().compute(grey)).ravel().astype(np.float32)
        norm = np.linalg.norm(values)
        return torch.from_numpy(values / norm if norm > 0 else values)

    def forward(self, batch: torch.Tensor) -> np.ndarray:
        return batch.numpy().astype(np.float32)
