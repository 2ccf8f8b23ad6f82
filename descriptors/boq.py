"""BoQ: Bag-of-Queries (Ali-bey et al., CVPR 2024), the released models of amaralibey/Bag-of-Queries.

Our own implementation of the model that ``hubconf.py`` ``get_trained_boq`` builds (``src/backbones.py``,
``src/boq.py`` at commit 1a4965e; the same module tree and maths as 593ba5b, the code of the release), with the
same module tree so that the two files of release v1.0 (plain state dicts) load with ``strict=True``:

- ``resnet50_16384.pth``: ``backbone.net.*`` is ``nn.Sequential(conv1, bn1, relu, maxpool, layer1, layer2,
  layer3)`` of a torchvision ResNet-50 (keys ``backbone.net.{0,1,4,5,6}.*``; ``layer4`` is cropped), giving
  1024 x 24 x 24 maps at 384 x 384; the aggregator projects to 512 channels.
- ``dinov2_12288.pth``: ``backbone.dino.*`` is the torch.hub DINOv2 ViT-B/14 (``descriptors/dinov2.py``). The
  official forward runs ``prepare_tokens_with_masks`` (no masks) and all 12 blocks, drops the class token and
  reshapes the 23 x 23 patch tokens to a ``(B, 768, 23, 23)`` map: the final ``norm`` is never applied and
  ``mask_token`` never used, yet both are in the file and load strictly (BoQ issue 20: a model that replaced
  ``norm`` by ``nn.Identity`` refused the file's ``backbone.dino.norm.*`` keys; fixed in cb0b503/1a4965e). The
  aggregator projects to 384 channels.

Aggregator (``aggregator.*``): ``proj_c`` (3 x 3 conv, padding 1) to ``P`` channels, tokens row-major,
``norm_input`` (LayerNorm), then 2 BoQ blocks, each: ``encoder`` = ``nn.TransformerEncoderLayer(P, P // 64
heads, feed-forward 4P, dropout 0, post-norm, ReLU)`` on the tokens; 64 learned ``queries`` refined by
``norm_q(q + self_attn(q, q, q))`` (independent of the image); ``out = norm_out(cross_attn(q, x, x))`` (no
residual). The blocks' outputs are concatenated (128 x P), ``fc`` maps the 128 rows to 32, the result is
flattened channel-major (index ``c * 32 + r``) and L2-normalised: 512 * 32 = 16384 and 384 * 32 = 12288 values.
All attention layers have ``P // 64`` heads (8 for ResNet-50, 6 for DINOv2) since 593ba5b; the official forward
also returns the head-averaged cross-attention maps, which we do not compute.

The official loader returns the model in training mode (``get_trained_boq`` never calls ``eval()``), so the
ResNet's BatchNorm would use the statistics of each batch; descriptors here always come from ``eval()`` mode.

Preprocessing (``preprocessing: official``): the README's transform for the released models ("when using our
models, use the following transform", unchanged from 5ecf256 to 1a4965e): ``ToTensor``, ``Resize(im_size,
BICUBIC, antialias=True)`` on the float tensor, ImageNet ``Normalize``, with ``im_size`` 384 x 384 for ResNet-50
and 322 x 322 for DINOv2. (The training code's validation, ``src/dataloaders/datamodule.py`` since 661e576,
resizes the decoded uint8 image with ``v2.Resize(.., interpolation=3)`` at the same sizes, i.e. rounds the
resized pixels to uint8 before normalising.)

``preprocessing: vpr-methods-evaluation``: gmberton/VPR-methods-evaluation (adbb6e2) ``parser.py`` forces
``--image_size`` to [384, 384] (ResNet50) or [322, 322] (Dinov2) for ``--method boq`` and ``test_dataset.py``
applies ``ToTensor``, ImageNet ``Normalize``, then ``transforms.Resize(image_size, antialias=True)`` (bilinear)
on the normalised tensor; BoQ is not wrapped in its ``ResizingWrapper``. Only this resizing is reproduced: that
harness's ``vpr_models/boq.py`` (bbf910b) copies the ResNet layout of BoQ before 87ff48c (``frozen_layers`` /
``unfrozen_layers``, ImageNet weights) and loads the file with ``strict=False``, so there the fine-tuned
``backbone.net.*`` weights are silently not loaded; its DINOv2 loads all weights used in the forward pass.
"""

from __future__ import annotations

import re
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
from vpr_smr.descriptors.dinov2 import DinoVisionTransformer

BACKBONES = ("resnet50", "dinov2")
# The files of release v1.0 and their descriptor sizes.
RELEASED: dict[str, tuple[str, int]] = {
    "resnet50": ("resnet50_16384.pth", 16384), "dinov2": ("dinov2_12288.pth", 12288),
}
SOURCE = "https://github.com/amaralibey/Bag-of-Queries/releases/tag/v1.0"
# The first key component under ``backbone.`` tells the variants apart.
BACKBONE_PREFIXES = {"resnet50": "backbone.net.", "dinov2": "backbone.dino."}
# (H, W) of the README's transform for each released model.
OFFICIAL_SIZE: dict[str, tuple[int, int]] = {"resnet50": (384, 384), "dinov2": (322, 322)}
# Aggregator sizes of the released models (``get_trained_boq``): the file's shapes override them on loading.
PROJ_CHANNELS = {"resnet50": 512, "dinov2": 384}
NUM_QUERIES = 64
NUM_LAYERS = 2
ROW_DIM = 32
HEAD_DIM = 64  # every attention layer has proj_channels // 64 heads
RESNET_CHANNELS = 1024  # ResNet-50 layer3
VIT_B = {"embed_dim": 768, "depth": 12}  # the torch.hub dinov2_vitb14 that BoQ fine-tunes
PATCH_SIZE = 14


class ResNet50Trunk(nn.Module):
    """torchvision ResNet-50 cut after layer3 in one ``nn.Sequential``: keys ``net.{0,1,4,5,6}.*``."""

    out_channels = RESNET_CHANNELS

    def __init__(self) -> None:
        super().__init__()
        resnet = torchvision.models.resnet50(weights=None)
        self.net = nn.Sequential(resnet.conv1, resnet.bn1, resnet.relu, resnet.maxpool,
                                 resnet.layer1, resnet.layer2, resnet.layer3)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        features: torch.Tensor = self.net(x)
        return features


class DinoV2Trunk(nn.Module):
    """DINOv2 in ``dino`` (keys ``dino.*``): patch tokens of the last block, without the final norm, as a map."""

    def __init__(self, embed_dim: int = VIT_B["embed_dim"], depth: int = VIT_B["depth"]) -> None:
        super().__init__()
        if embed_dim < HEAD_DIM:
            raise ValueError(f"boq: a DINOv2 of width {embed_dim} has no {HEAD_DIM}-wide attention head")
        self.dino = DinoVisionTransformer(embed_dim=embed_dim, depth=depth, num_heads=embed_dim // HEAD_DIM,
                                          patch_size=PATCH_SIZE)
        self.out_channels = embed_dim

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        batch, _, height, width = x.shape
        tokens: torch.Tensor = self.dino(x, norm=False)  # BoQ's forward runs the blocks only: `norm` stays unused
        patch = self.dino.patch_size
        # Patch tokens are row-major: (B, h*w, C) -> (B, C, h, w), as the official permute + view.
        return tokens[:, 1:].transpose(1, 2).reshape(batch, -1, height // patch, width // patch)


class EncoderLayer(nn.Module):
    """``nn.TransformerEncoderLayer(dim, heads, dim_feedforward=hidden, dropout=0, batch_first=True)`` at
    inference, written out: post-norm, ``x = norm1(x + SA(x)); x = norm2(x + linear2(relu(linear1(x))))``;
    LayerNorm eps 1e-5. Same parameter names."""

    def __init__(self, dim: int, num_heads: int, hidden: int) -> None:
        super().__init__()
        self.self_attn = nn.MultiheadAttention(dim, num_heads, batch_first=True)
        self.linear1 = nn.Linear(dim, hidden)
        self.linear2 = nn.Linear(hidden, dim)
        self.norm1 = nn.LayerNorm(dim)
        self.norm2 = nn.LayerNorm(dim)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x = self.norm1(x + self.self_attn(x, x, x, need_weights=False)[0])
        fed: torch.Tensor = self.linear2(F.relu(self.linear1(x)))
        out: torch.Tensor = self.norm2(x + fed)
        return out


class BoQBlock(nn.Module):
    """One BoQ block: refines the tokens (``encoder``) and aggregates them with learned queries."""

    def __init__(self, dim: int, num_queries: int, num_heads: int) -> None:
        super().__init__()
        self.encoder = EncoderLayer(dim, num_heads, 4 * dim)
        self.queries = nn.Parameter(torch.zeros(1, num_queries, dim))
        self.self_attn = nn.MultiheadAttention(dim, num_heads, batch_first=True)
        self.norm_q = nn.LayerNorm(dim)
        self.cross_attn = nn.MultiheadAttention(dim, num_heads, batch_first=True)
        self.norm_out = nn.LayerNorm(dim)

    def learned_queries(self) -> torch.Tensor:
        """``norm_q(Q + SA(Q))``, ``(1, num_queries, dim)``: the same for every image (BoQ's "can be cached")."""
        q = self.queries
        out: torch.Tensor = self.norm_q(q + self.self_attn(q, q, q, need_weights=False)[0])
        return out

    def forward(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Tokens ``(B, N, dim)`` -> (refined tokens ``(B, N, dim)``, block output ``(B, num_queries, dim)``)."""
        x = self.encoder(x)
        q = self.learned_queries().expand(x.shape[0], -1, -1)
        out: torch.Tensor = self.norm_out(self.cross_attn(q, x, x, need_weights=False)[0])
        return x, out


class BoQAggregator(nn.Module):
    """Projection, input norm, cascaded BoQ blocks, ``fc`` over the stacked queries, channel-major flatten, L2."""

    def __init__(self, in_channels: int, proj_channels: int, num_queries: int = NUM_QUERIES,
                 num_layers: int = NUM_LAYERS, row_dim: int = ROW_DIM, num_heads: int | None = None) -> None:
        super().__init__()
        heads = proj_channels // HEAD_DIM if num_heads is None else num_heads
        if heads < 1 or proj_channels % heads:
            raise ValueError(f"boq: {proj_channels} projected channels cannot be split into {heads} heads")
        self.proj_channels, self.num_queries, self.num_layers, self.row_dim = \
            proj_channels, num_queries, num_layers, row_dim
        self.proj_c = nn.Conv2d(in_channels, proj_channels, kernel_size=3, padding=1)
        self.norm_input = nn.LayerNorm(proj_channels)
        self.boqs = nn.ModuleList(BoQBlock(proj_channels, num_queries, heads) for _ in range(num_layers))
        self.fc = nn.Linear(num_layers * num_queries, row_dim)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """Feature map ``(B, C, h, w)`` -> descriptors ``(B, proj_channels * row_dim)``, unit L2 norm."""
        x = self.norm_input(self.proj_c(x).flatten(2).transpose(1, 2))  # (B, h*w, P), positions row-major
        outs = []
        for block in self.boqs:
            x, out = block(x)
            outs.append(out)
        stacked = torch.cat(outs, dim=1)  # (B, L*Q, P)
        rows: torch.Tensor = self.fc(stacked.transpose(1, 2))  # (B, P, row_dim)
        return F.normalize(rows.flatten(1), p=2, dim=-1)


class BoQNet(nn.Module):
    """``backbone`` + ``aggregator``, as the official ``VPRModel``; ``forward`` gives the descriptors only."""

    def __init__(self, backbone: str = "resnet50", proj_channels: int | None = None,
                 num_queries: int = NUM_QUERIES, num_layers: int = NUM_LAYERS, row_dim: int = ROW_DIM,
                 embed_dim: int = VIT_B["embed_dim"], depth: int = VIT_B["depth"]) -> None:
        super().__init__()
        if backbone not in BACKBONES:
            raise ValueError(f"boq: backbone must be one of {', '.join(BACKBONES)}, got {backbone!r}")
        self.kind = backbone
        trunk: ResNet50Trunk | DinoV2Trunk = ResNet50Trunk() if backbone == "resnet50" else \
            DinoV2Trunk(embed_dim, depth)
        self.backbone = trunk
        channels = PROJ_CHANNELS[backbone] if proj_channels is None else proj_channels
        self.aggregator = BoQAggregator(trunk.out_channels, channels, num_queries, num_layers, row_dim)

    @property
    def sizes(self) -> dict[str, int]:
        """The sizes that ``file_sizes`` reads from a state dict, of this model."""
        agg = self.aggregator
        sizes = {"proj_channels": agg.proj_channels, "num_queries": agg.num_queries, "num_layers": agg.num_layers,
                 "row_dim": agg.row_dim}
        if isinstance(self.backbone, DinoV2Trunk):
            sizes.update(embed_dim=self.backbone.dino.embed_dim, depth=len(self.backbone.dino.blocks))
        return sizes

    @property
    def dim(self) -> int:
        return self.aggregator.proj_channels * self.aggregator.row_dim

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        descriptors: torch.Tensor = self.aggregator(self.backbone(x))
        return descriptors


def detect_backbone(state_dict: dict[str, Any]) -> str | None:
    """``resnet50`` for ``backbone.net.*`` keys, ``dinov2`` for ``backbone.dino.*``; ``None`` for neither or both.
    BatchNorm counters do not count (the loader adds them to a file that has none)."""
    keys = [str(k) for k in state_dict if not str(k).endswith("num_batches_tracked")]
    found = [name for name, prefix in BACKBONE_PREFIXES.items() if any(k.startswith(prefix) for k in keys)]
    return found[0] if len(found) == 1 else None


def _count(state_dict: dict[str, Any], prefix: str) -> int:
    """Number of ``prefix.<i>.`` entries (consecutive from 0) among the keys."""
    pattern = re.compile(re.escape(prefix) + r"\.(\d+)\.")
    indices = {int(m.group(1)) for k in state_dict if (m := pattern.match(str(k)))}
    count = 0
    while count in indices:
        count += 1
    return count


def _shape(state_dict: dict[str, Any], key: str, ndim: int) -> tuple[int, ...] | None:
    value = state_dict.get(key)
    if isinstance(value, torch.Tensor) and value.ndim == ndim:
        return tuple(value.shape)
    return None


def file_sizes(state_dict: dict[str, Any]) -> dict[str, int]:
    """The model sizes a BoQ state dict holds (what is readable of them): ``proj_channels``, ``num_queries``,
    ``num_layers``, ``row_dim`` and, for DINOv2, ``embed_dim`` and ``depth``."""
    sizes: dict[str, int] = {}
    # (size, the key that holds it, that tensor's number of dimensions, the axis of the size)
    for name, key, ndim, axis in (("proj_channels", "aggregator.proj_c.weight", 4, 0),
                                  ("num_queries", "aggregator.boqs.0.queries", 3, 1),
                                  ("row_dim", "aggregator.fc.weight", 2, 0),
                                  ("embed_dim", "backbone.dino.cls_token", 3, 2)):
        shape = _shape(state_dict, key, ndim)
        if shape is not None:
            sizes[name] = shape[axis]
    for name, prefix in (("num_layers", "aggregator.boqs"), ("depth", "backbone.dino.blocks")):
        if count := _count(state_dict, prefix):
            sizes[name] = count
    return sizes


@dataclass(frozen=True)
class BoQSettings:
    """The settings of ``boq``."""

    backbone: str | None = setting(
        None, f"{', '.join(BACKBONES)} or null: the variant; null: read from the checkpoint's keys "
              f"({', '.join(f'{prefix}* for {kind}' for kind, prefix in BACKBONE_PREFIXES.items())}), which must "
              "match when set")
    # 16384 / 12288 for the releases
    output_dim: int | None = setting(
        None, "integer or null: the descriptor size ({}); null: read from the checkpoint, which must match when "
              "set".format(", ".join(f"{dim} for {kind}" for kind, (_, dim) in RELEASED.items())))
    image_size: str | tuple[int, ...] = setting(
        "auto", "auto or [H, W] in pixels: auto: {}, under either preset; [H, W] overrides it (multiples of {} for "
                "dinov2)".format(" or ".join("{} x {} for {}".format(*size, kind)
                                             for kind, size in OFFICIAL_SIZE.items()), PATCH_SIZE))


class BoQ(TorchBackend):
    """BoQ global descriptor (ResNet-50 16384-d or DINOv2 12288-d). Checkpoint: a file of release v1.0.

    ``backbone: null`` takes the variant from the file's keys (``backbone.net.*``: ResNet-50,
    ``backbone.dino.*``: DINOv2); the aggregator's sizes (and so the descriptor size) and the ViT's width and
    depth are always read from the file, and ``output_dim``, when set, must match. ``image_size: auto``: 384 x
    384 (ResNet-50) or 322 x 322 (DINOv2) under either preset (see the module docstring); ``[H, W]`` overrides it
    (multiples of 14 for DINOv2).
    """

    name: ClassVar[str] = "boq"
    model: BoQNet  # what build_model returns
    Settings: ClassVar[type | None] = BoQSettings
    input_summary: ClassVar[str] = ", ".join("{}x{} ({})".format(*size, backbone)
                                             for backbone, size in OFFICIAL_SIZE.items())

    def __init__(self, conf: dict[str, Any] | None = None) -> None:
        merged = {**self.default_conf, **(conf or {})}
        if merged["backbone"] is not None and merged["backbone"] not in BACKBONES:
            raise ValueError(f"backend 'boq': backbone must be one of {', '.join(BACKBONES)} or null (read from "
                             f"the checkpoint), got {merged['backbone']!r}")
        size = merged["image_size"]
        if size != "auto" and not (isinstance(size, list | tuple) and len(size) == 2
                                   and all(isinstance(s, int) and s > 0 for s in size)):
            raise ValueError(f"backend 'boq': image_size must be auto or [H, W], got {size!r}")
        output_dim = merged["output_dim"]
        if output_dim is not None and not (isinstance(output_dim, int) and output_dim > 0):
            raise ValueError(f"backend 'boq': output_dim must be a positive integer or null, got {output_dim!r}")
        super().__init__(conf)
        if self.model.kind == "dinov2":
            self.input_size()  # a DINOv2 image_size must be multiples of the patch size

    @property
    def backbone_kind(self) -> str:
        """The variant in use: the setting, else the loaded file's, else ResNet-50 (before loading)."""
        return self.model.kind

    @property
    def dim(self) -> int:
        return self.model.dim

    def input_size(self) -> tuple[int, int]:
        """The network's input ``(H, W)``: ``image_size``, or the official size of the variant in use."""
        size = self.conf["image_size"]
        kind = self.backbone_kind
        height, width = OFFICIAL_SIZE[kind] if size == "auto" else (int(size[0]), int(size[1]))
        if kind == "dinov2" and (height % PATCH_SIZE or width % PATCH_SIZE):
            raise ValueError(f"backend 'boq': image_size [{height}, {width}] must be multiples of {PATCH_SIZE} "
                             "for the DINOv2 backbone")
        return height, width

    def build_model(self, backbone: str | None = None, sizes: dict[str, int] | None = None) -> BoQNet:
        kind = backbone or self.conf["backbone"] or "resnet50"
        return BoQNet(kind, **(sizes or {}))

    def expected_file(self) -> str:
        kinds = [self.conf["backbone"]] if self.conf["backbone"] else list(BACKBONES)
        names = " or ".join(RELEASED[kind][0] for kind in kinds)
        keys = " or ".join(f"{BACKBONE_PREFIXES[kind]}*" for kind in kinds)
        return f"{names} from {SOURCE} (keys {keys} and aggregator.*)"

    def preprocess(self, image: np.ndarray) -> torch.Tensor:
        """RGB uint8 ``H x W x 3`` -> normalised ``3 x h x w`` tensor at ``image_size``."""
        image = np.ascontiguousarray(image)
        if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
            raise ValueError(f"boq: expected an RGB uint8 H x W x 3 image, got {image.dtype} {image.shape}")
        if self.harness:
            # VPR-methods-evaluation: ToTensor + Normalize, then Resize(image_size, antialias=True), bilinear.
            return resize_tensor(to_tensor(image), self.input_size(), "bilinear")
        # README: ToTensor, Resize(image_size, BICUBIC, antialias=True) on the [0, 1] tensor, then Normalize.
        return to_tensor(image, self.input_size(), interpolation="bicubic")

    def adapt_state_dict(self, state_dict: dict[str, Any], data: Any, path: Path) -> dict[str, Any]:
        """Take the variant from the keys (refusing one that contradicts ``backbone``) and the sizes from the
        shapes (refusing a descriptor size that contradicts ``output_dim``); rebuild the model to fit. A file
        that is not BoQ's is left to the strict key check, which lists what differs."""
        setting = self.conf["backbone"]
        found = detect_backbone(state_dict)
        if setting is not None and found is not None and found != setting:
            raise CheckpointError(
                f"checkpoint {path} holds a BoQ model with the {found} backbone ({BACKBONE_PREFIXES[found]}* keys) "
                f"but the setting is `backbone: {setting}`; set `backbone: {found}` or null "
                f"(expected {self.expected_file()})")
        kind = setting or found or self.model.kind
        sizes = file_sizes(state_dict)
        if kind != "dinov2":
            sizes = {k: v for k, v in sizes.items() if k not in ("embed_dim", "depth")}
        wanted = self.conf["output_dim"]
        if wanted is not None and "proj_channels" in sizes and "row_dim" in sizes:
            dim = sizes["proj_channels"] * sizes["row_dim"]
            if dim != int(wanted):
                raise CheckpointError(
                    f"checkpoint {path} gives {dim}-d descriptors ({sizes['proj_channels']} channels x "
                    f"{sizes['row_dim']} rows) but the setting is `output_dim: {wanted}`; set `output_dim: "
                    f"{dim}` or null (expected {self.expected_file()})")
        if kind != self.model.kind or any(self.model.sizes.get(k, v) != v for k, v in sizes.items()):
            try:
                self.model = self.build_model(kind, sizes).eval()
            except ValueError:  # sizes no BoQ model has (e.g. fewer than 64 channels): the strict check lists them
                pass
        if kind == "dinov2":
            self.input_size()  # a DINOv2 file with an image_size that is not a multiple of 14
        return state_dict

    def key_hint(self, state_dict: dict[str, Any]) -> str:
        keys = [str(k) for k in state_dict]
        if any(k.startswith(("backbone.frozen_layers.", "backbone.unfrozen_layers.")) for k in keys):
            return ("\nthe file's ResNet keys (backbone.frozen_layers.* / backbone.unfrozen_layers.*) are the "
                    "layout of BoQ's code from 661e576 to 87ff48c (and of VPR-methods-evaluation's copy), not that "
                    "of the released files (backbone.net.*)")
        if detect_backbone(state_dict) == "dinov2" and not any(k.startswith("backbone.dino.norm.") for k in keys):
            return ("\nthe file has no backbone.dino.norm.* keys: it was saved from a model whose final norm was "
                    "replaced by nn.Identity (BoQ's code from 706bdfb to cb0b503); the released file has them "
                    "(unused in the forward pass, but loaded strictly)")
        if detect_backbone(state_dict) is None:
            return ("\nthe file has neither backbone.net.* (ResNet-50) nor backbone.dino.* (DINOv2) keys: "
                    "not a BoQ checkpoint?")
        return ""
