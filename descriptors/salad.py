"""SALAD: DINOv2 ViT-B/14 features aggregated by optimal transport (Izquierdo & Civera, CVPR 2024).

Our own implementation of the model in serizba/salad (``models/backbones/dinov2.py``,
``models/aggregators/salad.py``, loaded as in ``eval.py``/``hubconf.py``), with the same module tree so that
the released ``dino_salad.ckpt`` (a plain state dict: ``backbone.model.*``, ``aggregator.*``) loads with
``strict=True``.

Pipeline: the image is resized to 322 x 322 (PIL bilinear, as the official evaluation) and normalised with
ImageNet mean/std; DINOv2 runs all 12 blocks and its final LayerNorm; the class token gives the 256-d global
token and the 23 x 23 patch tokens are softly assigned to 64 clusters (plus a dustbin) by 3 log-space Sinkhorn
iterations; each cluster's 128-d weighted sum is L2-normalised, the token is L2-normalised, and the
concatenation (256 + 128 * 64 = 8448 values) is L2-normalised. ``preprocessing: vpr-methods-evaluation``
gives that harness's full-size input instead (see ``SALAD``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from vpr_smr.core.settings import setting
from vpr_smr.descriptors.base import TorchBackend, resize_tensor, to_tensor
from vpr_smr.descriptors.dinov2 import VIT_SETTINGS_HELP, DinoVisionTransformer
from vpr_smr.descriptors.layers import pil_resize

EXPECTED_FILE = "dino_salad.ckpt"
OFFICIAL_SIZE = (322, 322)  # (H, W) of the official eval.py: 23 x 23 patches


def log_sinkhorn_with_dustbin(scores: torch.Tensor, dustbin: torch.Tensor,
                              num_iters: int = 3) -> torch.Tensor:
    """Log transport plan between ``m`` clusters plus a dustbin row and ``n`` features, times ``n + m``.

    ``scores``: ``(B, m, n)``; ``dustbin``: scalar score of the extra row. The target marginals are
    ``1 / (n + m)`` per feature, the source marginals ``1 / (n + m)`` per cluster and ``(n - m) / (n + m)``
    for the dustbin (both sum to ``n / (n + m)``). Sinkhorn starts from zero log-potentials and updates the
    row potentials, then the column potentials, ``num_iters`` times (regularisation 1). The result is
    ``log P + log(n + m)``: each feature's column then sums to 1 (a soft assignment), as in the official code.
    """
    batch, m, n = scores.shape
    if n <= m:
        raise ValueError(f"SALAD needs more local features ({n}) than clusters ({m}); use a larger image")
    log_scale = math.log(n + m)
    couplings = torch.cat((scores, dustbin.to(scores.dtype).reshape(1, 1, 1).expand(batch, 1, n)), dim=1)
    log_mu = torch.full((m + 1,), -log_scale, dtype=scores.dtype, device=scores.device)
    log_mu[-1] += math.log(n - m)
    log_nu = torch.full((n,), -log_scale, dtype=scores.dtype, device=scores.device)
    u = torch.zeros(batch, m + 1, dtype=scores.dtype, device=scores.device)
    v = torch.zeros(batch, n, dtype=scores.dtype, device=scores.device)
    for _ in range(num_iters):
        u = log_mu - torch.logsumexp(couplings + v[:, None, :], dim=2)
        v = log_nu - torch.logsumexp(couplings + u[:, :, None], dim=1)
    return couplings + u[:, :, None] + v[:, None, :] + log_scale


class SALADAggregator(nn.Module):
    """Optimal-transport aggregation; submodule indices match the official ``nn.Sequential`` layouts."""

    def __init__(self, num_channels: int = 768, num_clusters: int = 64, cluster_dim: int = 128,
                 token_dim: int = 256, hidden: int = 512, sinkhorn_iters: int = 3) -> None:
        super().__init__()
        self.num_clusters = num_clusters
        self.cluster_dim = cluster_dim
        self.sinkhorn_iters = sinkhorn_iters
        # Dropout (index 1, training only) is kept so that the Conv2d indices are 0 and 3, as in the file.
        self.token_features = nn.Sequential(
            nn.Linear(num_channels, hidden), nn.ReLU(), nn.Linear(hidden, token_dim)
        )
        self.cluster_features = nn.Sequential(
            nn.Conv2d(num_channels, hidden, 1), nn.Dropout(0.3), nn.ReLU(), nn.Conv2d(hidden, cluster_dim, 1)
        )
        self.score = nn.Sequential(
            nn.Conv2d(num_channels, hidden, 1), nn.Dropout(0.3), nn.ReLU(), nn.Conv2d(hidden, num_clusters, 1)
        )
        self.dust_bin = nn.Parameter(torch.tensor(1.0))

    def forward(self, features: torch.Tensor, token: torch.Tensor) -> torch.Tensor:
        """Patch tokens ``(B, C, h, w)`` and class token ``(B, C)`` -> descriptors ``(B, g + m * l)``."""
        local = self.cluster_features(features).flatten(2)  # (B, l, n)
        scores = self.score(features).flatten(2)  # (B, m, n)
        token = self.token_features(token)  # (B, g)
        # Soft assignment of each feature to the clusters; dropping the dustbin row discards its mass.
        assignment = log_sinkhorn_with_dustbin(scores, self.dust_bin, self.sinkhorn_iters).exp()[:, :-1, :]
        clusters = torch.einsum("bln,bmn->blm", local, assignment)  # (B, l, m)
        # Per-cluster L2 over the l channels; flattened channel-major (index l * m + cluster) as officially.
        clusters = F.normalize(clusters, p=2, dim=1).flatten(1)
        return F.normalize(torch.cat((F.normalize(token, p=2, dim=-1), clusters), dim=-1), p=2, dim=-1)


class DINOv2Backbone(nn.Module):
    """SALAD's backbone wrapper: the ViT lives in ``model`` (keys ``backbone.model.*``)."""

    def __init__(self, **vit_kwargs: Any) -> None:
        super().__init__()
        self.model = DinoVisionTransformer(**vit_kwargs)

    def forward(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        # SALAD uses norm_layer=True: the final LayerNorm is applied to the patch tokens and the class token.
        return self.model.features_and_token(x)


class SALADNet(nn.Module):
    def __init__(self, embed_dim: int = 768, depth: int = 12, num_heads: int = 12, patch_size: int = 14,
                 num_clusters: int = 64, cluster_dim: int = 128, token_dim: int = 256) -> None:
        super().__init__()
        self.backbone = DINOv2Backbone(embed_dim=embed_dim, depth=depth, num_heads=num_heads,
                                       patch_size=patch_size)
        self.aggregator = SALADAggregator(embed_dim, num_clusters, cluster_dim, token_dim)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        descriptors: torch.Tensor = self.aggregator(*self.backbone(x))
        return descriptors


def harness_size(height: int, width: int, patch: int = 14, method: str = "salad") -> tuple[int, int]:
    """VPR-methods-evaluation's ``ResizingWrapper`` (``dino_v2_resize``), also MegaLoc's own ``forward``: each
    side to the nearest multiple of the patch size, ``round(side / patch) * patch`` with Python's ``round``
    (halves go to the even multiple). ``method`` names the backend in the error."""
    size = (round(height / patch) * patch, round(width / patch) * patch)
    if min(size) == 0:
        raise ValueError(f"{method}: a {height} x {width} image rounds to {size[0]} x {size[1]}: too small")
    return size


@dataclass(frozen=True)
class SALADSettings:
    """The settings of ``salad``."""

    # "auto": 322 x 322 (official; 23 x 23 patches), or the harness's rounding (see SALAD's docstring)
    image_size: str | tuple[int, ...] = setting(
        "auto", "auto or [H, W] in pixels, multiples of 14: auto: {} x {} (PIL bilinear) as the official eval.py, or "
                "under preprocessing vpr-methods-evaluation the full image with each side resized to the nearest "
                "multiple of 14; [H, W]: that size (PIL bilinear) under either preset".format(*OFFICIAL_SIZE))
    num_clusters: int = setting(64, "the number of clusters the patch tokens are assigned to (plus a dustbin); must "
                                    "match the checkpoint")
    cluster_dim: int = setting(128, "the size of each cluster's aggregated feature (descriptor: token_dim + "
                                    "num_clusters x cluster_dim values); must match the checkpoint")
    token_dim: int = setting(256, "the size of the global token made from the class token; must match the checkpoint")
    # ViT-B/14; change only for checkpoints trained with another DINOv2 size (without registers)
    embed_dim: int = setting(768, VIT_SETTINGS_HELP["embed_dim"])
    depth: int = setting(12, VIT_SETTINGS_HELP["depth"])
    num_heads: int = setting(12, VIT_SETTINGS_HELP["num_heads"])


class SALAD(TorchBackend):
    """DINOv2 + SALAD, 8448-d descriptors. Checkpoint: the official ``dino_salad.ckpt``.

    Input size (``image_size: auto``): 322 x 322 (PIL bilinear) as the official ``eval.py``; with
    ``preprocessing: vpr-methods-evaluation``, that harness's: the full image normalised, then each side
    resized (tensor, bilinear, antialias) to the nearest multiple of 14 (``harness_size``). ``[H, W]``
    (multiples of 14) resizes to that size with PIL under either preset.
    """

    name: ClassVar[str] = "salad"
    Settings: ClassVar[type | None] = SALADSettings
    input_summary: ClassVar[str] = "{}x{} (H x W)".format(*OFFICIAL_SIZE)
    patch_size: ClassVar[int] = 14

    def build_model(self) -> nn.Module:
        size = self.conf["image_size"]
        if size != "auto":
            if not (isinstance(size, list | tuple) and len(size) == 2):
                raise ValueError(f"salad: image_size must be auto or [H, W], got {size!r}")
            if int(size[0]) % self.patch_size or int(size[1]) % self.patch_size:
                raise ValueError(f"salad: image_size {list(size)} must be multiples of {self.patch_size}")
        return SALADNet(
            embed_dim=int(self.conf["embed_dim"]), depth=int(self.conf["depth"]),
            num_heads=int(self.conf["num_heads"]), patch_size=self.patch_size,
            num_clusters=int(self.conf["num_clusters"]), cluster_dim=int(self.conf["cluster_dim"]),
            token_dim=int(self.conf["token_dim"]),
        )

    def expected_file(self) -> str:
        return f"the official {EXPECTED_FILE} from serizba/salad (keys backbone.model.* and aggregator.*)"

    def preprocess(self, image: np.ndarray) -> torch.Tensor:
        """RGB uint8 ``H x W x 3`` -> normalised ``3 x h x w`` tensor (322 x 322 by default).

        The official ``eval.py`` applies ``T.Resize(size, BILINEAR)`` to PIL images, i.e. PIL's bilinear
        resize on uint8 (which filters when shrinking), then ``ToTensor`` and ImageNet ``Normalize``; we call
        PIL directly so the resized pixels are identical.
        """
        image = np.ascontiguousarray(image)
        if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
            raise ValueError(f"salad: expected an RGB uint8 H x W x 3 image, got {image.dtype} {image.shape}")
        size = self.conf["image_size"]
        if size == "auto" and self.harness:
            image_height, image_width = image.shape[:2]
            return resize_tensor(to_tensor(image), harness_size(image_height, image_width, self.patch_size))
        height, width = OFFICIAL_SIZE if size == "auto" else (int(s) for s in size)
        return to_tensor(pil_resize(image, (height, width), "bilinear"))
