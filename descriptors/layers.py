"""Building blocks shared by the descriptor backends: layers and PIL resizing (checkpoints: see ``base``).

Module indices matter here: the backends load the official releases with ``strict=True``, so a layer list is
returned as built (``nn.Sequential(*layers)`` gives the torchvision indices) and each caller names its own
container.
"""

from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

# VGG16 configuration "D": conv widths, "M" for 2x2 max pooling.
VGG16_LAYOUT: tuple[int | str, ...] = (
    64, 64, "M", 128, 128, "M", 256, 256, 256, "M", 512, 512, 512, "M", 512, 512, 512, "M",
)

# PIL resampling filters by name (the values of ``PIL.Image.Resampling``).
PIL_FILTERS = {"nearest": 0, "lanczos": 1, "bilinear": 2, "bicubic": 3, "box": 4, "hamming": 5}


class L2Norm(nn.Module):
    """L2 normalisation along ``dim``."""

    def __init__(self, dim: int) -> None:
        super().__init__()
        self.dim = dim

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return F.normalize(x, p=2.0, dim=self.dim)


def vgg16_conv5_3() -> list[nn.Module]:
    """torchvision ``vgg16().features[:-2]``: indices 0..28, up to conv5_3 without its ReLU and the last max
    pooling, as CosPlace, EigenPlaces and both NetVLAD releases cut it. ``nn.Sequential(*layers)`` has the keys
    ``N.weight``/``N.bias`` of torchvision.

    Built directly (not through ``torchvision.models.vgg16``) to skip the 120M-parameter classifier.
    """
    layers: list[nn.Module] = []
    channels = 3
    for item in VGG16_LAYOUT:
        if item == "M":
            layers.append(nn.MaxPool2d(kernel_size=2, stride=2))
        else:
            layers += [nn.Conv2d(channels, int(item), kernel_size=3, padding=1), nn.ReLU(inplace=True)]
            channels = int(item)
    return layers[:-2]


def resized_size(height: int, width: int, size: int | list[int] | tuple[int, int]) -> tuple[int, int]:
    """Output ``(H, W)`` of torchvision ``Resize(size)``: an int sets the shorter side and keeps the aspect
    ratio (the longer side is truncated, as torchvision does); a pair is ``(H, W)``."""
    if isinstance(size, int):
        short, long = (width, height) if width <= height else (height, width)
        new_short, new_long = size, int(size * long / short)
        return (new_long, new_short) if width <= height else (new_short, new_long)
    if len(size) == 1:
        return resized_size(height, width, int(size[0]))
    return int(size[0]), int(size[1])


def pil_resize(image: np.ndarray, size: tuple[int, int], interpolation: str = "bilinear") -> np.ndarray:
    """Resize an RGB uint8 image to ``size = (H, W)`` with PIL: exactly what torchvision ``Resize`` does to
    the PIL images of the official evaluation code (it resizes before ``ToTensor``, in uint8)."""
    from PIL import Image

    if tuple(image.shape[:2]) == tuple(size):
        return image  # torchvision returns the image unchanged when it already has the size
    resample = PIL_FILTERS[interpolation]
    resized = Image.fromarray(np.ascontiguousarray(image)).resize((size[1], size[0]), resample=resample)
    return np.array(resized)  # a writable copy: torch.from_numpy warns on read-only arrays
