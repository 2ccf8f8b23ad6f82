"""MixVPR (Ali-bey et al., WACV 2023), the released ResNet-50 models of amaralibey/MixVPR.

Module tree as in the official ``main.py`` ``VPRModel`` so that the released files load with
``strict=True``: ``backbone.model.*`` is a torchvision ResNet-50 whose ``avgpool``, ``fc`` and
(``layers_to_crop=[4]``) ``layer4`` are set to ``None`` (``models/backbones/resnet.py``), so the file has no
``layer4`` keys and the trunk gives 1024 x 20 x 20 maps at 320 x 320; ``aggregator.*`` is
``models/aggregators/mixvpr.py``: 4 ``FeatureMixerLayer`` (``mix.<i>.mix = Sequential(LayerNorm, Linear, ReLU,
Linear)`` with a residual) over the flattened 400 positions, ``channel_proj`` (1024 -> out_channels),
``row_proj`` (400 -> out_rows), flatten, L2.

The released ``resnet50_MixVPR_4096_channels(1024)_rows(4).ckpt`` (and the 512 / 128 variants) are plain state
dicts despite the ``.ckpt`` name: the README loads them with ``model.load_state_dict(torch.load(path))``. A
checkpoint saved by the Lightning trainer of ``main.py`` wraps the state dict under ``state_dict`` next to
primitives (epoch, loops, hyper_parameters, and for full checkpoints optimizer and scheduler states with a
``collections.Counter``); torch's weights-only unpickler accepts all of these, so nothing is allow-listed.

Preprocessing as the official validation (``dataloaders/GSVCitiesDataloader.py`` ``valid_transform``):
``Resize((320, 320), BILINEAR)`` on the PIL image, ``ToTensor``, ImageNet ``Normalize``. (The README's
``demo.py`` uses bicubic instead: ``interpolation: bicubic``.) ``preprocessing: vpr-methods-evaluation`` gives
that harness's order instead (``vpr_models/mixvpr.py``): ``ToTensor`` and ``Normalize`` on the full-size image,
then ``transforms.Resize([320, 320], antialias=True)`` on the normalised float tensor.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import torch
import torch.nn.functional as F
import torchvision
from torch import nn

from vpr_smr.core.settings import setting
from vpr_smr.descriptors.base import CheckpointError, TorchBackend, resize_tensor, to_tensor
from vpr_smr.descriptors.layers import PIL_FILTERS, pil_resize

# The released aggregators: descriptor size -> (out_channels, out_rows); all use mix_depth 4, mlp_ratio 1.
RELEASED: dict[int, tuple[int, int]] = {4096: (1024, 4), 512: (256, 2), 128: (64, 2)}
TRUNK_CHANNELS = 1024  # ResNet-50 layer3 output
MIX_DEPTH = 4
MLP_RATIO = 1


def _stride2(size: int) -> int:
    """Output size of a stride-2 conv / pooling of the ResNet stem (k=7,p=3 / k=3,p=1 / k=3,p=1 agree)."""
    return (size - 1) // 2 + 1


def trunk_size(height: int, width: int) -> tuple[int, int]:
    """Feature map size after ResNet-50 layer3: conv1, maxpool, layer2 and layer3 each halve (rounding up)."""
    for _ in range(4):
        height, width = _stride2(height), _stride2(width)
    return height, width


class ResNetTrunk(nn.Module):
    """ResNet-50 up to layer3, kept inside ``.model`` to match the official ``backbone.model.*`` keys."""

    def __init__(self) -> None:
        super().__init__()
        self.model = torchvision.models.resnet50(weights=None)
        # Official cut: these become None, so they hold no parameters and have no keys.
        self.model.avgpool = None
        self.model.fc = None
        self.model.layer4 = None

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        m = self.model
        x = m.maxpool(m.relu(m.bn1(m.conv1(x))))
        features: torch.Tensor = m.layer3(m.layer2(m.layer1(x)))
        return features


class FeatureMixerLayer(nn.Module):
    """``x + MLP(LayerNorm(x))`` along the flattened spatial axis (each channel's H*W values are one row)."""

    def __init__(self, in_dim: int, mlp_ratio: float = 1) -> None:
        super().__init__()
        hidden = int(in_dim * mlp_ratio)
        self.mix = nn.Sequential(
            nn.LayerNorm(in_dim), nn.Linear(in_dim, hidden), nn.ReLU(), nn.Linear(hidden, in_dim)
        )

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        mixed: torch.Tensor = self.mix(x)
        return x + mixed


class MixVPRAggregator(nn.Module):
    """Feature mixers, then channel and row projections, flattened channel-major and L2-normalised."""

    def __init__(self, in_channels: int = TRUNK_CHANNELS, in_h: int = 20, in_w: int = 20,
                 out_channels: int = 1024, mix_depth: int = MIX_DEPTH, mlp_ratio: float = MLP_RATIO,
                 out_rows: int = 4) -> None:
        super().__init__()
        positions = in_h * in_w
        self.mix = nn.Sequential(*[FeatureMixerLayer(positions, mlp_ratio) for _ in range(mix_depth)])
        self.channel_proj = nn.Linear(in_channels, out_channels)
        self.row_proj = nn.Linear(positions, out_rows)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x = self.mix(x.flatten(2))  # B x C x HW
        x = self.channel_proj(x.permute(0, 2, 1))  # B x HW x out_channels
        x = self.row_proj(x.permute(0, 2, 1))  # B x out_channels x out_rows
        return F.normalize(x.flatten(1), p=2, dim=-1)


class MixVPRNet(nn.Module):
    def __init__(self, image_size: tuple[int, int] = (320, 320), out_channels: int = 1024,
                 out_rows: int = 4) -> None:
        super().__init__()
        in_h, in_w = trunk_size(*image_size)
        self.backbone = ResNetTrunk()
        self.aggregator = MixVPRAggregator(
            TRUNK_CHANNELS, in_h, in_w, out_channels, MIX_DEPTH, MLP_RATIO, out_rows
        )

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        descriptors: torch.Tensor = self.aggregator(self.backbone(x))
        return descriptors


def released_file(dim: int | None = None) -> str:
    dims = [dim] if dim in RELEASED else list(RELEASED)
    names = [f"resnet50_MixVPR_{d}_channels({RELEASED[d][0]})_rows({RELEASED[d][1]}).ckpt" for d in dims]
    return " or ".join(names)


@dataclass(frozen=True)
class MixVPRSettings:
    """The settings of ``mixvpr``."""

    # (H, W); the released models were trained and evaluated at 320 x 320
    image_size: tuple[int, ...] = setting((320, 320), "[H, W] in pixels: the input size; it sizes the aggregator, so "
                                                      "it must be the checkpoint's training size (320 x 320 for the "
                                                      "released models)")
    # official validation transform; demo.py uses "bicubic"
    interpolation: str = setting("bilinear", f"the resize filter, one of {', '.join(PIL_FILTERS)}: bilinear as the "
                                             "official validation, bicubic as the README's demo.py")
    out_channels: int | None = setting(
        None, "integer or null: the channel projection's output size ({}); null: read from the checkpoint's "
              "aggregator.channel_proj.weight, which must match when set".format(
                  ", ".join(f"{c} for {d}-d" for d, (c, _) in RELEASED.items())))
    out_rows: int | None = setting(
        None, "integer or null: the row projection's output size ({}); null: read from the checkpoint's "
              "aggregator.row_proj.weight, which must match when set".format(
                  ", ".join(f"{r} for {d}-d" for d, (_, r) in RELEASED.items())))


class MixVPR(TorchBackend):
    """MixVPR global descriptor; ``out_channels``/``out_rows`` of ``null`` are read from the checkpoint."""

    name: ClassVar[str] = "mixvpr"
    model: MixVPRNet  # what build_model returns
    Settings: ClassVar[type | None] = MixVPRSettings
    input_summary: ClassVar[str] = "{}x{} (H x W, image_size)".format(*MixVPRSettings.image_size)
    source: ClassVar[str] = "https://github.com/amaralibey/MixVPR (README, Google Drive links)"

    def __init__(self, conf: dict[str, Any] | None = None) -> None:
        merged = {**self.default_conf, **(conf or {})}
        if merged["interpolation"] not in PIL_FILTERS:
            raise ValueError(f"backend {self.name!r}: interpolation must be one of {', '.join(PIL_FILTERS)}")
        if len(merged["image_size"]) != 2:
            raise ValueError(
                f"backend {self.name!r}: image_size must be [H, W], got {merged['image_size']!r}"
            )
        super().__init__(conf)

    @property
    def image_size(self) -> tuple[int, int]:
        return int(self.conf["image_size"][0]), int(self.conf["image_size"][1])

    @property
    def dim(self) -> int:
        agg = self.model.aggregator
        return int(agg.channel_proj.out_features * agg.row_proj.out_features)

    def build_model(self, out_channels: int | None = None, out_rows: int | None = None) -> MixVPRNet:
        channels = out_channels or self.conf["out_channels"] or RELEASED[4096][0]
        rows = out_rows or self.conf["out_rows"] or RELEASED[4096][1]
        return MixVPRNet(self.image_size, int(channels), int(rows))

    def expected_file(self) -> str:
        channels, rows = self.conf["out_channels"], self.conf["out_rows"]
        dim = channels * rows if channels and rows else None
        return f"{released_file(dim)} from {self.source}"

    def preprocess(self, image: np.ndarray) -> torch.Tensor:
        if self.harness:
            # VPR-methods-evaluation: ToTensor + Normalize at full size, then the model's
            # transforms.Resize([320, 320], antialias=True) on the normalised tensor.
            return resize_tensor(to_tensor(image), self.image_size, self.conf["interpolation"])
        return to_tensor(pil_resize(image, self.image_size, self.conf["interpolation"]))

    def adapt_state_dict(self, state_dict: dict[str, Any], data: Any, path: Path) -> dict[str, Any]:
        """``out_channels`` and ``out_rows`` come from the file's projections; the model is rebuilt to fit."""
        shapes = {}
        for key in ("aggregator.channel_proj.weight", "aggregator.row_proj.weight"):
            weight = state_dict.get(key)
            if not isinstance(weight, torch.Tensor) or weight.ndim != 2:
                raise CheckpointError(
                    f"checkpoint {path} is not a MixVPR checkpoint: it has no 2-D `{key}`; "
                    f"expected {self.expected_file()}"
                )
            shapes[key] = tuple(weight.shape)
        found = {
            "out_channels": shapes["aggregator.channel_proj.weight"][0],
            "out_rows": shapes["aggregator.row_proj.weight"][0],
        }
        for name, value in found.items():
            wanted = self.conf[name]
            if wanted is not None and int(wanted) != value:
                raise CheckpointError(
                    f"checkpoint {path} has {name} = {value} but the setting is {wanted}; "
                    f"set `{name}: {value}` or null (expected {self.expected_file()})"
                )
        agg = self.model.aggregator
        if (agg.channel_proj.out_features, agg.row_proj.out_features) != (found["out_channels"], found["out_rows"]):
            self.model = self.build_model(found["out_channels"], found["out_rows"]).eval()
        return state_dict

    def key_hint(self, state_dict: dict[str, Any]) -> str:
        # The mixers and row projection are sized by H*W of the trunk output, fixed by the training input.
        positions = state_dict["aggregator.row_proj.weight"].shape[1]
        ours = self.model.aggregator.row_proj.in_features
        if positions == ours:
            return ""
        return (f"\nthe file expects {positions} feature positions (20 x 20 <=> image_size [320, 320]) "
                f"but image_size {list(self.image_size)} gives {ours}")
