"""AP-GeM (Revaud et al., ICCV 2019): ResNet-101 + GeM + FC + L2, with the optional learned whitening.

Our own implementation with the module tree of naver/deep-image-retrieval
(``dirtorch/nets/rmac_resnet.py`` ``ResNet_RMAC``, ``backbones/resnet.py``, ``layers/pooling.py``
``GeneralizedMeanPoolingP``), so that the state dict of ``Resnet-101-AP-GeM.pt`` loads with ``strict=True``:
``conv1``, ``bn1``, ``layer1..4``, ``adpool.p`` (the learned GeM power, shape ``(1,)``) and ``fc``
(2048 -> 2048).

The official file is a pickle that also holds scikit-learn PCA objects, so it is first converted by
``convert.convert_apgem`` into a plain tensor file ``{"state_dict", "whitening", "model_options",
"preprocess"}`` that loads with ``weights_only=True``.

Pipeline (``ResNet_RMAC.forward``): the ResNet trunk up to layer4, GeM ``(mean x^p)^(1/p)`` with ``x`` clamped
at 1e-6, the FC layer and L2. Whitening (``dirtorch/utils/common.py`` ``whiten_features`` with
``use_sklearn=True``), in float64 as the official numpy code: ``(x - mean_) @ components_[:v].T``, divided by
``whitenm * explained_variance_[:v] ** whitenp`` when the PCA was fitted with ``whiten=True``, then L2. The
official evaluation (``test_dir.py``) whitens with ``Landmarks_clean`` and ``whitenp = 0.25``, and so does the
default here (``whiten: auto``) when the converted file holds that whitening; a file without it gives the
unwhitened 2048-d descriptor. VPR-methods-evaluation does the same (full size, Landmarks_clean, 0.25), so
``preprocessing`` changes nothing here.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from vpr_smr.core.settings import setting
from vpr_smr.descriptors.base import IMAGENET_MEAN, IMAGENET_STD, CheckpointError, TorchBackend, to_tensor

EXPECTED_FILE = ("Resnet-101-AP-GeM.pt converted once with `vpr-smr convert-checkpoint apgem IN OUT` "
                 "(vpr_smr.descriptors.convert.convert_apgem)")
OFFICIAL_WHITENING = "Landmarks_clean"  # the whitening of the release that test_dir.py applies


class GeM(nn.Module):
    """Generalized-mean pooling with a learned power ``p`` of shape ``(1,)`` (dirtorch's ``adpool``)."""

    def __init__(self, p: float = 3.0, eps: float = 1e-6) -> None:
        super().__init__()
        self.p = nn.Parameter(torch.ones(1) * p)
        self.eps = eps

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """``(N, C, H, W)`` -> ``(N, C)``."""
        return F.adaptive_avg_pool2d(x.clamp(min=self.eps).pow(self.p), 1).pow(1.0 / self.p).flatten(1)


class Whitening(nn.Module):
    """Learned PCA whitening, applied in float64; its tensors are non-persistent (not in the state dict)."""

    # Buffers, registered in __init__ (torch types a module attribute as Tensor | Module).
    mean: torch.Tensor
    projection: torch.Tensor
    scale: torch.Tensor

    def __init__(self, mean: torch.Tensor, projection: torch.Tensor, scale: torch.Tensor) -> None:
        super().__init__()
        self.register_buffer("mean", mean.double(), persistent=False)
        self.register_buffer("projection", projection.double(), persistent=False)  # (v, D): components_[:v]
        self.register_buffer("scale", scale.double(), persistent=False)  # (v,)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        white = (x.double() - self.mean) @ self.projection.T / self.scale
        return F.normalize(white, p=2, dim=-1).to(x.dtype)


class APGeMNet(nn.Module):
    """ResNet-101 trunk (torchvision's Bottleneck has dirtorch's names and strides) + ``adpool`` + ``fc``."""

    def __init__(self, out_dim: int = 2048, norm_features: bool = False, without_fc: bool = False) -> None:
        super().__init__()
        from torchvision.models import resnet101

        trunk = resnet101(weights=None)
        self.conv1, self.bn1, self.relu, self.maxpool = trunk.conv1, trunk.bn1, trunk.relu, trunk.maxpool
        self.layer1, self.layer2 = trunk.layer1, trunk.layer2
        self.layer3, self.layer4 = trunk.layer3, trunk.layer4
        self.adpool = GeM(3.0)
        self.fc = nn.Linear(2048, out_dim)
        # Options of ResNet_RMAC stored in the file's model_options; the released model uses neither.
        self.norm_features = norm_features
        self.without_fc = without_fc
        self.whitening: Whitening | None = None

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x = self.maxpool(self.relu(self.bn1(self.conv1(x))))
        x = self.layer4(self.layer3(self.layer2(self.layer1(x))))
        x = self.adpool(x)
        if self.norm_features:
            x = F.normalize(x, p=2, dim=1)
        if not self.without_fc:
            x = self.fc(x)
        x = F.normalize(x, p=2, dim=-1)
        if self.whitening is not None:
            x = self.whitening(x)
        return x


@dataclass(frozen=True)
class APGeMSettings:
    """The settings of ``apgem``."""

    # null keeps the full image, as the official evaluation does
    max_size: int | None = setting(None, "integer or null: the longest image side in pixels; a larger image is shrunk "
                                         "to it, keeping its aspect ratio; null: full size, as the official evaluation")
    # "auto": the release's "Landmarks_clean", which the official test_dir.py (and VPR-methods-evaluation) applies,
    # when the converted file holds it
    whiten: str | None = setting("auto", "text, auto or null: the name of a whitening stored in the converted "
                                         f"checkpoint; auto: {OFFICIAL_WHITENING} (the official evaluation's) when the "
                                         "file holds it, else none; null: no whitening")
    # official test_dir.py default (the sklearn-style whitening would be 0.5)
    whitenp: float = setting(0.25, "the power of the explained variance that divides each whitened component "
                                   "(official test_dir.py: 0.25; 0.5 is scikit-learn's PCA whitening); used when the "
                                   "whitening was fitted with whiten=True")
    whitenv: int | None = setting(None, "integer or null: the number of whitening components kept, i.e. the whitened "
                                        "descriptor's size; null: all")
    whitenm: float = setting(1.0, "a factor of the divisor of each whitened component (whitenm x variance ^ "
                                  "whitenp); used when the whitening was fitted with whiten=True")


class APGeM(TorchBackend):
    """ResNet-101 AP-GeM, 2048-d descriptors (fewer with ``whitenv``)."""

    name: ClassVar[str] = "apgem"
    model: APGeMNet  # what build_model returns
    Settings: ClassVar[type | None] = APGeMSettings
    input_summary: ClassVar[str] = "full size (max_size caps the longest side)"

    def __init__(self, conf: dict[str, Any] | None = None) -> None:
        super().__init__(conf)
        # The file's `preprocess` may override these (dirtorch's load_model does the same).
        self.mean: tuple[float, ...] = IMAGENET_MEAN
        self.std: tuple[float, ...] = IMAGENET_STD
        self.whitening_name: str | None = None  # the whitening applied, once a file is loaded

    def build_model(self) -> APGeMNet:
        return APGeMNet()

    def preprocess(self, image: np.ndarray) -> torch.Tensor:
        """RGB uint8 ``H x W x 3`` -> normalised ``3 x H x W`` tensor at full size (or ``max_size``)."""
        image = np.ascontiguousarray(image)
        if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
            raise ValueError(f"apgem: expected an RGB uint8 H x W x 3 image, got {image.dtype} {image.shape}")
        size = None
        max_size = self.conf["max_size"]
        if max_size and max(image.shape[:2]) > int(max_size):
            scale = int(max_size) / max(image.shape[:2])
            size = (max(1, round(image.shape[0] * scale)), max(1, round(image.shape[1] * scale)))
        return to_tensor(image, size, mean=self.mean, std=self.std)

    def prepare(self) -> None:
        super().prepare()
        whitening = getattr(self.model, "whitening", None)
        if whitening is not None:
            whitening.double()  # ``half`` mode must not round the whitening, computed in float64 officially

    def expected_file(self) -> str:
        return f"{EXPECTED_FILE} (keys conv1.*, bn1.*, layer1-4.*, adpool.p, fc.weight, fc.bias)"

    def adapt_state_dict(self, state_dict: dict[str, Any], data: Any, path: Path) -> dict[str, Any]:
        """The converted file's model options, preprocessing and whitening (see ``convert.convert_apgem``)."""
        data = data if isinstance(data, dict) else {}
        options = data.get("model_options") or {}
        self._check_options(options, path)
        model = self.model
        fc = state_dict.get("fc.weight")
        if fc is not None and getattr(fc, "ndim", 0) == 2 and fc.shape[0] != model.fc.out_features:
            model.fc = nn.Linear(2048, int(fc.shape[0]))  # out_dim is a dirtorch option; 2048 in the release
        model.norm_features = bool(options.get("norm_features", False))
        model.without_fc = bool(options.get("without_fc", False))
        preprocess = data.get("preprocess") or {}
        if preprocess.get("mean") is not None and preprocess.get("std") is not None:
            self.mean = tuple(float(v) for v in preprocess["mean"])
            self.std = tuple(float(v) for v in preprocess["std"])
        # Non-persistent buffers: setting the whitening here does not touch the strict key check.
        stored = data.get("whitening") or {}
        self.whitening_name = self._whitening_name(stored, path)
        model.whitening = self._whitening(stored[self.whitening_name]) if self.whitening_name else None
        return state_dict

    def _check_options(self, options: dict[str, Any], path: Path) -> None:
        """Refuse files of another dirtorch architecture than the one implemented here."""
        arch = options.get("arch", "resnet101_rmac")
        pooling = str(options.get("pooling", "gem"))
        center_bias = float(options.get("center_bias") or 0)
        if arch != "resnet101_rmac" or not pooling.startswith("gem") or center_bias > 0:
            raise CheckpointError(
                f"checkpoint {path} is a dirtorch model with arch={arch!r}, pooling={pooling!r}, "
                f"center_bias={center_bias}; backend 'apgem' implements resnet101_rmac with GeM pooling "
                "only"
            )

    def _whitening_name(self, stored: dict[str, Any], path: Path) -> str | None:
        """``whiten: auto`` is the official Landmarks_clean when the file holds it; a name must be there."""
        name = self.conf["whiten"]
        if name == "auto":
            return OFFICIAL_WHITENING if OFFICIAL_WHITENING in stored else None
        if name and name not in stored:
            available = ", ".join(sorted(stored)) or "none"
            raise CheckpointError(f"checkpoint {path} has no whitening {name!r} (it has: {available}); "
                                  "set `whiten` to one of them, auto or null")
        return name or None

    def _whitening(self, pca: dict[str, Any]) -> Whitening:
        keep = int(self.conf["whitenv"]) if self.conf["whitenv"] else None
        projection = pca["components"][:keep]
        if pca.get("whiten", True):
            variance = pca["explained_variance"][:keep].double()
            scale = float(self.conf["whitenm"]) * variance ** float(self.conf["whitenp"])
        else:
            scale = torch.ones(projection.shape[0], dtype=torch.float64)
        return Whitening(pca["mean"], projection, scale)
