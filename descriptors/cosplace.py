"""CosPlace (Berton et al., CVPR 2022) and EigenPlaces (Berton et al., ICCV 2023).

Both methods share one network (gmberton/CosPlace ``cosplace_model/cosplace_network.py``,
gmberton/EigenPlaces ``eigenplaces_model/eigenplaces_network.py``): a torchvision trunk cut before its
pooling, then ``aggregation = Sequential(L2Norm, GeM, Flatten, Linear, L2Norm)``. Module names follow the
official tree so that the released ``<backbone>_<dim>_{cosplace,eigenplaces}.pth`` files (plain state dicts)
load with ``strict=True``: ``backbone.<i>.*``, ``aggregation.1.p``, ``aggregation.3.weight``,
``aggregation.3.bias``.

Preprocessing follows the official ``datasets/test_dataset.py``: ``ToTensor`` + ImageNet ``Normalize`` on the
full-size image. CosPlace's evaluation can also resize the shorter side (``--resize_test_imgs --image_size``);
the ``resize`` setting does that (an int), or resizes to ``[H, W]``. VPR-methods-evaluation feeds the full-size
image as well, so ``preprocessing`` changes nothing here.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, cast

import numpy as np
import torch
import torch.nn.functional as F
import torchvision
from torch import nn

from vpr_smr.core.settings import setting
from vpr_smr.descriptors.base import CheckpointError, TorchBackend, to_tensor
from vpr_smr.descriptors.layers import PIL_FILTERS, L2Norm, pil_resize, resized_size, vgg16_conv5_3

# Channels of the last convolutional feature map, i.e. the input size of the Linear layer.
FEATURE_DIMS: dict[str, int] = {
    "VGG16": 512, "ResNet18": 512, "ResNet50": 2048, "ResNet101": 2048, "ResNet152": 2048,
}

# Blocks in ResNet ``layer3`` (``backbone.6``): tells the released ResNets apart from a state dict.
_LAYER3_BLOCKS = {2: "ResNet18", 6: "ResNet50", 23: "ResNet101", 36: "ResNet152"}


class GeM(nn.Module):
    """Generalised-mean pooling over the whole map: ``mean(clamp(x, eps)^p)^(1/p)``.

    ``p`` is a learned one-element parameter (``aggregation.1.p``, shape ``(1,)``), initialised to 3;
    ``eps`` is 1e-6 and the clamp comes before the power, as in the official ``cosplace_model/layers.py``.
    """

    def __init__(self, p: float = 3.0, eps: float = 1e-6) -> None:
        super().__init__()
        self.p = nn.Parameter(torch.ones(1) * p)
        self.eps = eps

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        # avg_pool2d over the full map (rather than mean) keeps the official reduction order.
        pooled = F.avg_pool2d(x.clamp(min=self.eps).pow(self.p), (x.size(-2), x.size(-1)))
        return pooled.pow(1.0 / self.p)


class Flatten(nn.Module):
    """``B x C x 1 x 1`` -> ``B x C``."""

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return x[:, :, 0, 0]


def build_backbone(backbone: str) -> nn.Sequential:
    """The official trunk as an ``nn.Sequential`` (keys ``backbone.<i>.*``), randomly initialised."""
    if backbone == "VGG16":
        return nn.Sequential(*vgg16_conv5_3())
    if backbone.startswith("ResNet") and backbone in FEATURE_DIMS:
        model = getattr(torchvision.models, backbone.lower())(weights=None)
        return nn.Sequential(*list(model.children())[:-2])  # drop avgpool and fc
    raise ValueError(f"unknown backbone {backbone!r}; choose one of {', '.join(FEATURE_DIMS)}")


class GeoLocalizationNet(nn.Module):
    """The CosPlace / EigenPlaces network: trunk, then L2 per location, GeM, Linear, L2."""

    def __init__(self, backbone: str, fc_output_dim: int) -> None:
        super().__init__()
        self.backbone = build_backbone(backbone)
        self.aggregation = nn.Sequential(
            L2Norm(1), GeM(), Flatten(), nn.Linear(FEATURE_DIMS[backbone], fc_output_dim), L2Norm(1)
        )

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        descriptors: torch.Tensor = self.aggregation(self.backbone(x))
        return descriptors


def detect_backbone(state_dict: dict[str, Any]) -> str | None:
    """Which released backbone a CosPlace-style state dict holds (``None`` if it is none of them)."""
    if "backbone.28.weight" in state_dict and "backbone.1.running_mean" not in state_dict:
        return "VGG16"
    blocks = {key.split(".")[2] for key in state_dict if key.startswith("backbone.6.")}
    name = _LAYER3_BLOCKS.get(len(blocks))
    bottleneck = "backbone.6.0.conv3.weight" in state_dict
    if name is None or bottleneck != (name != "ResNet18"):
        return None
    return name


# Released files per backbone (hubconf.py AVAILABLE_TRAINED_MODELS) and where to get them.
COSPLACE_RELEASED: dict[str, list[int]] = {
    "VGG16": [64, 128, 256, 512],
    "ResNet18": [32, 64, 128, 256, 512],
    "ResNet50": [32, 64, 128, 256, 512, 1024, 2048],
    "ResNet101": [32, 64, 128, 256, 512, 1024, 2048],
    "ResNet152": [32, 64, 128, 256, 512, 1024, 2048],
}
EIGENPLACES_RELEASED: dict[str, list[int]] = {
    "VGG16": [512],
    "ResNet18": [256, 512],
    "ResNet50": [128, 256, 512, 1024, 2048],
    "ResNet101": [128, 256, 512, 1024, 2048],
}


@dataclass(frozen=True)
class CosPlaceSettings:
    """The settings of ``cosplace``."""

    backbone: str = setting("ResNet50", f"the checkpoint's trunk, one of {', '.join(COSPLACE_RELEASED)}; a file with "
                                        "another one is refused")
    # null: read from the checkpoint's aggregation.3.weight
    fc_output_dim: int | None = setting(None, "integer or null: the descriptor size (the output of the Linear layer "
                                              "aggregation.3); null: read from the checkpoint, which must match when "
                                              "set")
    resize: int | tuple[int, ...] | None = setting(
        None, "null, integer or [H, W] in pixels: null: full size, as the official evaluation; integer: the shorter "
              "side, keeping the aspect ratio (CosPlace's --resize_test_imgs --image_size); [H, W]: that size")
    interpolation: str = setting("bilinear", f"the PIL filter of resize, one of {', '.join(PIL_FILTERS)}")


@dataclass(frozen=True)
class EigenPlacesSettings(CosPlaceSettings):
    """The settings of ``eigenplaces``: CosPlace's, its own trunks; EigenPlaces evaluates full-size images only (its
    test_dataset.py has no resize option): resize is kept for symmetry with CosPlace."""

    backbone: str = setting("ResNet50", f"the checkpoint's trunk, one of {', '.join(EIGENPLACES_RELEASED)}; a file "
                                        "with another one is refused")
    resize: int | tuple[int, ...] | None = setting(
        None, "null, integer or [H, W] in pixels: null: full size, as the official evaluation (which has no other); "
              "integer: the shorter side, keeping the aspect ratio; [H, W]: that size")


class CosPlace(TorchBackend):
    """CosPlace global descriptor; ``fc_output_dim: null`` takes the dimension from the checkpoint."""

    name: ClassVar[str] = "cosplace"
    model: GeoLocalizationNet  # what build_model returns
    Settings: ClassVar[type | None] = CosPlaceSettings
    input_summary: ClassVar[str] = "full size (resize: optional)"
    # Released files per backbone (hubconf.py AVAILABLE_TRAINED_MODELS) and where to get them.
    released: ClassVar[dict[str, list[int]]] = COSPLACE_RELEASED
    file_suffix: ClassVar[str] = "cosplace"
    release_url: ClassVar[str] = "https://github.com/gmberton/CosPlace/releases/download/v1.0/"

    def __init__(self, conf: dict[str, Any] | None = None) -> None:
        merged = {**self.default_conf, **(conf or {})}
        if merged["backbone"] not in self.released:
            raise ValueError(
                f"backend {self.name!r}: unknown backbone {merged['backbone']!r}; "
                f"choose one of {', '.join(self.released)}"
            )
        if merged["interpolation"] not in PIL_FILTERS:
            raise ValueError(f"backend {self.name!r}: interpolation must be one of {', '.join(PIL_FILTERS)}")
        super().__init__(conf)

    @property
    def dim(self) -> int:
        """Descriptor size of the current model."""
        linear = cast(nn.Linear, self.model.aggregation[3])  # Sequential(L2Norm, GeM, Flatten, Linear, L2Norm)
        return int(linear.out_features)

    def build_model(self, fc_output_dim: int | None = None) -> GeoLocalizationNet:
        backbone = self.conf["backbone"]
        # Before a checkpoint is read, use the largest released size of this backbone.
        dim = fc_output_dim or self.conf["fc_output_dim"] or max(self.released[backbone])
        return GeoLocalizationNet(backbone, int(dim))

    def expected_file(self) -> str:
        backbone = self.conf["backbone"]
        dim = self.conf["fc_output_dim"]
        name = f"{backbone}_{dim or '<dim>'}_{self.file_suffix}.pth"
        dims = "" if dim else f" with <dim> one of {', '.join(map(str, self.released[backbone]))}"
        return f"{name}{dims} from {self.release_url}"

    def preprocess(self, image: np.ndarray) -> torch.Tensor:
        if self.conf["resize"] is not None:
            size = resized_size(image.shape[0], image.shape[1], self.conf["resize"])
            image = pil_resize(image, size, self.conf["interpolation"])
        return to_tensor(image)

    def adapt_state_dict(self, state_dict: dict[str, Any], data: Any, path: Path) -> dict[str, Any]:
        """Check the file's backbone against the setting and read the descriptor size from it."""
        weight = state_dict.get("aggregation.3.weight")
        if not isinstance(weight, torch.Tensor) or weight.ndim != 2:
            raise CheckpointError(
                f"checkpoint {path} is not a {self.name} checkpoint: it has no 2-D `aggregation.3.weight`; "
                f"expected {self.expected_file()}"
            )
        backbone = self.conf["backbone"]
        found = detect_backbone(state_dict)
        if found is not None and found != backbone:
            raise CheckpointError(
                f"checkpoint {path} holds a {found} backbone but backend {self.name!r} is set to "
                f"`backbone: {backbone}`; set `backbone: {found}` (expected {self.expected_file()})"
            )
        dim = int(weight.shape[0])
        wanted = self.conf["fc_output_dim"]
        if wanted is not None and int(wanted) != dim:
            raise CheckpointError(
                f"checkpoint {path} gives {dim}-d descriptors but `fc_output_dim` is {wanted}; "
                f"set `fc_output_dim: {dim}` or null (expected {self.expected_file()})"
            )
        if dim != self.dim:
            self.model = self.build_model(dim).eval()
        return state_dict


class EigenPlaces(CosPlace):
    """EigenPlaces: the CosPlace network trained with a different objective; its own released files."""

    name: ClassVar[str] = "eigenplaces"
    Settings: ClassVar[type | None] = EigenPlacesSettings
    released: ClassVar[dict[str, list[int]]] = EIGENPLACES_RELEASED
    file_suffix: ClassVar[str] = "eigenplaces"
    release_url: ClassVar[str] = "https://github.com/gmberton/EigenPlaces/releases/download/v1.0/"
