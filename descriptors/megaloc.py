"""MegaLoc: DINOv2 ViT-B/14 + SALAD aggregation + a linear projection (Berton & Masone, CVPRW 2025).

Our own implementation of gmberton/MegaLoc's ``megaloc_model.py`` (the layout with the ViT written out, since
e31e8e0 of 2026-01-21; read at 1af071c), with the same module tree so that the released ``model.safetensors``
(Hugging Face ``gberton/MegaLoc``; keys ``backbone.{cls_token, pos_embed, patch_embed.proj.*, blocks.N.*,
norm.*}`` and ``aggregator.*``) loads with ``strict=True``. The ViT is the shared one of ``dinov2.py``
without ``mask_token`` (MegaLoc's ViT has none), itself the ``backbone`` module; the aggregation is SALAD's
(``salad.SALADAggregator``: the same code in both repositories) under ``aggregator.agg``.

Network: the ViT runs all 12 blocks and its final LayerNorm; the class token gives a 256-d token and the
patch tokens are assigned to 64 clusters (plus a dustbin) by 3 log-space Sinkhorn iterations; each cluster's
256-d weighted sum is L2-normalised, the token is L2-normalised, and their concatenation (256 + 64 * 256 =
16640 values) is L2-normalised; ``aggregator.linear`` maps it to 8448 values, which are L2-normalised.
``MegaLocNet.forward`` first resizes a batch whose sides are not multiples of 14 to the nearest multiples
(``round(side / 14) * 14``, torchvision bilinear with antialias), as the official ``forward`` does. The
position embedding is resampled as DINOv2 does it (bicubic, factors ``(h + 0.1) / 37`` and ``(w + 0.1) / 37``
for an ``h x w`` patch grid); MegaLoc's own code passed height and width the other way round for non-square
inputs from e31e8e0 until 4a23a2b (2026-01-21), which we do not reproduce. The model is always in eval mode
(the official loader returns it in training mode, with active dropout in the aggregation).

Presets (``image_size: auto``; the image is made a float tensor in [0, 1] and normalised with ImageNet's
mean and std first, then resized with torchvision's tensor ``resize``, bilinear, antialias on):

- ``preprocessing: official``: 322 x 322 (23 x 23 patches). MegaLoc publishes no evaluation script; its
  authors state "We resize the images to 322 x 322 for evaluation and use standard normalization"
  (gmberton/MegaLoc issue 2) and point to VPR-methods-evaluation for evaluations, whose
  ``--image_size 322 322`` resizes exactly so (``test_dataset.py``: ``ToTensor``, ``Normalize``,
  ``Resize(size, antialias=True)``).
- ``preprocessing: vpr-methods-evaluation``: that harness's MegaLoc run (``parser.py`` sets no image size
  for ``megaloc``; ``vpr_models/__init__.py`` uses the torch.hub model without a ``ResizingWrapper``): the full
  image, each side resized to the nearest multiple of 14 (what MegaLoc's ``forward`` does; here in
  ``preprocess``, with the same call).

``image_size: [H, W]`` resizes to that size under either preset (sides that are not multiples of 14 are then
rounded by the network, as the official ``forward`` does).

Checkpoints: ``model.safetensors`` is read with the safetensors library (tensors only). The earlier release
``megaloc.torch`` (GitHub release v1.0, loaded by ``hubconf.py`` before e31e8e0) is a state dict of the model
whose ViT was DINOv2's torch.hub model under ``backbone.model.*`` (with ``mask_token``); it is read with
``torch.load(weights_only=True)`` and loaded directly: its ``backbone.model.*`` keys are renamed to
``backbone.*`` and the unused ``backbone.model.mask_token`` is left out (``from_megaloc_torch``), then every
key and shape is checked strictly. No conversion command is needed.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, TypeVar

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from vpr_smr.core.settings import setting
from vpr_smr.descriptors.base import (
    CheckpointError,
    TorchBackend,
    is_safetensors_file,
    load_safetensors_file,
    load_tensor_file,
    resize_tensor,
    to_tensor,
)
from vpr_smr.descriptors.dinov2 import VIT_SETTINGS_HELP, DinoVisionTransformer
from vpr_smr.descriptors.salad import SALADAggregator, harness_size

log = logging.getLogger(__name__)

EXPECTED_FILE = "model.safetensors"
EARLIER_FILE = "megaloc.torch"
OFFICIAL_SIZE = (322, 322)  # (H, W): gmberton/MegaLoc issue 2; 23 x 23 patches
# Key prefix of the ViT in megaloc.torch (torch.hub DINOv2 wrapped in MegaLoc's first DINOv2 module) ...
EARLIER_PREFIX = "backbone.model."
# ... and in model.safetensors (the ViT written out in megaloc_model.py).
PREFIX = "backbone."
# The only key of megaloc.torch without a counterpart: DINOv2's training-only masking token.
EARLIER_ONLY = EARLIER_PREFIX + "mask_token"

V = TypeVar("V")


def from_megaloc_torch(state_dict: dict[str, V]) -> dict[str, V]:
    """The keys of ``megaloc.torch`` (``backbone.model.*``) renamed to those of ``model.safetensors``
    (``backbone.*``), ``backbone.model.mask_token`` (unused at inference) left out, other keys unchanged.

    Raises ``CheckpointError`` for a state dict that mixes the two layouts (a renamed key would collide).
    """
    mixed = [k for k in state_dict if k.startswith(PREFIX) and not k.startswith(EARLIER_PREFIX)]
    if mixed:
        raise CheckpointError(f"the state dict mixes MegaLoc's two layouts: it has {EARLIER_PREFIX}* keys (as "
                              f"{EARLIER_FILE}) and {PREFIX}* keys (as {EXPECTED_FILE}), e.g. {mixed[0]}")
    return {(PREFIX + key[len(EARLIER_PREFIX):] if key.startswith(EARLIER_PREFIX) else key): value
            for key, value in state_dict.items() if key != EARLIER_ONLY}


class MegaLocAggregator(nn.Module):
    """MegaLoc's ``aggregator``: SALAD's aggregation (``agg``) then a linear map (``linear``) to ``feat_dim``."""

    def __init__(self, num_channels: int = 768, num_clusters: int = 64, cluster_dim: int = 256,
                 token_dim: int = 256, mlp_dim: int = 512, feat_dim: int = 8448) -> None:
        super().__init__()
        self.agg = SALADAggregator(num_channels, num_clusters, cluster_dim, token_dim, hidden=mlp_dim)
        self.linear = nn.Linear(token_dim + num_clusters * cluster_dim, feat_dim)

    def forward(self, features: torch.Tensor, token: torch.Tensor) -> torch.Tensor:
        """Patch tokens ``(B, C, h, w)`` and class token ``(B, C)`` -> ``(B, feat_dim)``, not normalised."""
        projected: torch.Tensor = self.linear(self.agg(features, token))
        return projected


class MegaLocNet(nn.Module):
    """``backbone`` (the ViT, keys ``backbone.*``) + ``aggregator`` + L2 normalisation."""

    def __init__(self, embed_dim: int = 768, depth: int = 12, num_heads: int = 12, patch_size: int = 14,
                 num_clusters: int = 64, cluster_dim: int = 256, token_dim: int = 256, mlp_dim: int = 512,
                 feat_dim: int = 8448) -> None:
        super().__init__()
        self.backbone = DinoVisionTransformer(embed_dim=embed_dim, depth=depth, num_heads=num_heads,
                                              patch_size=patch_size, with_mask_token=False)
        self.aggregator = MegaLocAggregator(embed_dim, num_clusters, cluster_dim, token_dim, mlp_dim, feat_dim)

    def forward(self, images: torch.Tensor) -> torch.Tensor:
        """Normalised images ``(B, 3, H, W)`` -> L2-normalised descriptors ``(B, feat_dim)``."""
        height, width = images.shape[-2:]
        patch = self.backbone.patch_size
        if height % patch or width % patch:  # the official forward's resizing, same rounding and call
            images = resize_tensor(images, harness_size(height, width, patch, "megaloc"))
        features, token = self.backbone.features_and_token(images)
        return F.normalize(self.aggregator(features, token), p=2, dim=-1)


@dataclass(frozen=True)
class MegaLocSettings:
    """The settings of ``megaloc``."""

    # "auto": 322 x 322 (official) or the harness's rounding to multiples of 14; or [H, W]
    image_size: str | tuple[int, ...] = setting(
        "auto", "auto or [H, W] in pixels: auto: {} x {} (official), or under preprocessing vpr-methods-evaluation "
                "the full image with each side resized to the nearest multiple of 14; [H, W]: that size under either "
                "preset (the network rounds sides that are not multiples of 14)".format(*OFFICIAL_SIZE))
    feat_dim: int = setting(8448, "the descriptor size, the output of the final linear map (aggregator.linear); must "
                                  "match the checkpoint")
    num_clusters: int = setting(64, "the number of clusters the patch tokens are assigned to (plus a dustbin); must "
                                    "match the checkpoint")
    cluster_dim: int = setting(256, "the size of each cluster's aggregated feature (token_dim + num_clusters x "
                                    "cluster_dim values enter the linear map); must match the checkpoint")
    token_dim: int = setting(256, "the size of the global token made from the class token; must match the checkpoint")
    mlp_dim: int = setting(512, "the hidden size of the aggregation's token, cluster-feature and score layers; must "
                                "match the checkpoint")
    # ViT-B/14; change only for checkpoints trained with another DINOv2 size (without registers)
    embed_dim: int = setting(768, VIT_SETTINGS_HELP["embed_dim"])
    depth: int = setting(12, VIT_SETTINGS_HELP["depth"])
    num_heads: int = setting(12, VIT_SETTINGS_HELP["num_heads"])


class MegaLoc(TorchBackend):
    """DINOv2 + SALAD + linear, 8448-d descriptors. Checkpoint: the official ``model.safetensors`` (or the
    earlier ``megaloc.torch``). Presets: see the module docstring."""

    name: ClassVar[str] = "megaloc"
    Settings: ClassVar[type | None] = MegaLocSettings
    input_summary: ClassVar[str] = "{}x{} (H x W)".format(*OFFICIAL_SIZE)
    patch_size: ClassVar[int] = 14
    # Set by ``adapt_state_dict``: whether the file read last had megaloc.torch's keys (for messages).
    earlier_layout: bool = False

    def build_model(self) -> nn.Module:
        size = self.conf["image_size"]
        if size != "auto" and not (isinstance(size, list | tuple) and len(size) == 2
                                   and all(isinstance(s, int) and s > 0 for s in size)):
            raise ValueError(f"megaloc: image_size must be auto or [H, W] (positive integers), got {size!r}")
        return MegaLocNet(
            embed_dim=int(self.conf["embed_dim"]), depth=int(self.conf["depth"]),
            num_heads=int(self.conf["num_heads"]), patch_size=self.patch_size,
            num_clusters=int(self.conf["num_clusters"]), cluster_dim=int(self.conf["cluster_dim"]),
            token_dim=int(self.conf["token_dim"]), mlp_dim=int(self.conf["mlp_dim"]),
            feat_dim=int(self.conf["feat_dim"]),
        )

    def expected_file(self) -> str:
        return (f"the official {EXPECTED_FILE} of MegaLoc (Hugging Face gberton/MegaLoc; keys {PREFIX}* and "
                f"aggregator.*), or its earlier release {EARLIER_FILE} (keys {EARLIER_PREFIX}*, loaded with "
                f"them renamed)")

    def read_file(self, path: Path) -> Any:
        """``model.safetensors`` through safetensors; anything else (``megaloc.torch``) as a torch.save file."""
        if path.is_file() and is_safetensors_file(path):
            return load_safetensors_file(path)
        return load_tensor_file(path, backend=self.name)

    def adapt_state_dict(self, state_dict: dict[str, Any], data: Any, path: Path) -> dict[str, Any]:
        self.earlier_layout = any(key.startswith(EARLIER_PREFIX) for key in state_dict)
        if not self.earlier_layout:
            return state_dict
        log.info("megaloc: %s has the layout of the earlier release %s (torch.hub DINOv2 keys %s*): loading it "
                 "directly, its keys renamed to %s* and the unused %s left out (no conversion needed)",
                 path, EARLIER_FILE, EARLIER_PREFIX, PREFIX, EARLIER_ONLY)
        return from_megaloc_torch(state_dict)

    def key_hint(self, state_dict: dict[str, Any]) -> str:
        hints = []
        if self.earlier_layout:
            hints.append(f"the file's {EARLIER_PREFIX}* keys were renamed to {PREFIX}* (the layout of "
                         f"{EARLIER_FILE}) before this check")
        if "aggregator.token_features.0.weight" in state_dict:
            hints.append("its aggregator.* keys have no agg./linear level: SALAD's dino_salad.ckpt? "
                         "(use backend salad for it)")
        return "".join(f"\n  ({hint})" for hint in hints)

    def preprocess(self, image: np.ndarray) -> torch.Tensor:
        """RGB uint8 ``H x W x 3`` -> normalised ``3 x h x w`` tensor (322 x 322 by default)."""
        image = np.ascontiguousarray(image)
        if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
            raise ValueError(f"megaloc: expected an RGB uint8 H x W x 3 image, got {image.dtype} {image.shape}")
        size = self.conf["image_size"]
        if size != "auto":
            target = (int(size[0]), int(size[1]))
        elif self.harness:
            target = harness_size(image.shape[0], image.shape[1], self.patch_size, self.name)
        else:
            target = OFFICIAL_SIZE
        return resize_tensor(to_tensor(image), target)
