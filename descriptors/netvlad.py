"""NetVLAD (Arandjelovic et al., CVPR 2016) on VGG16, with the optional whitening PCA of Patch-NetVLAD.

Our own implementation with the module tree of the two public PyTorch releases, so that their files load with
``strict=True``:

- QVPR/Patch-NetVLAD (``patchnetvlad/models/models_generic.py``, ``netvlad.py``; files such as
  ``pitts_WPCA4096.pth.tar``, written by ``add_pca.py`` as ``{'num_pcs', 'state_dict'}``): keys
  ``encoder.N.*``, ``pool.conv.weight``, ``pool.centroids``, ``WPCA.0.weight`` and ``WPCA.0.bias`` (the last
  two float64);
- Nanne/pytorch-NetVlad (``main.py``; ``checkpoint.pth.tar``): the same keys without ``WPCA``, possibly with
  ``module.`` components (``nn.DataParallel``), next to numpy scalars (``best_score``, ``recalls``).

Pipeline: VGG16 ``features[:-2]`` (up to conv5_3, without its ReLU and the last max-pool), 512-d local
features L2-normalised, soft-assigned to ``K`` clusters by a 1x1 convolution without bias and a softmax over
clusters, residuals to the centroids summed per cluster, intra-normalised (L2 per cluster), flattened
cluster-major and L2-normalised (``512 K`` values). With WPCA: a 1x1 convolution with bias ``512 K -> P``
and a final L2.
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
from vpr_smr.descriptors.base import TorchBackend, to_tensor
from vpr_smr.descriptors.layers import L2Norm, pil_resize, vgg16_conv5_3

EXPECTED_FILES = (
    "Patch-NetVLAD's pitts_WPCA4096.pth.tar (or another *_WPCA*.pth.tar) or Nanne's checkpoint.pth.tar"
)
PATCH_NETVLAD_SIZE = (480, 640)  # (H, W) of Patch-NetVLAD's configurations (imageresizeh, imageresizew)

class NetVLADPool(nn.Module):
    """NetVLAD aggregation (``vladv2=False``): ``conv.weight (K, D, 1, 1)`` and ``centroids (K, D)``."""

    def __init__(self, num_clusters: int = 64, dim: int = 512) -> None:
        super().__init__()
        self.num_clusters = num_clusters
        self.dim = dim
        self.conv = nn.Conv2d(dim, num_clusters, kernel_size=1, bias=False)
        self.centroids = nn.Parameter(torch.rand(num_clusters, dim))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """``(N, D, H, W)`` local features -> ``(N, K * D)`` descriptors."""
        x = F.normalize(x, p=2, dim=1)
        assignment = F.softmax(self.conv(x).flatten(2), dim=1)  # (N, K, HW), softmax over clusters
        features = x.flatten(2)  # (N, D, HW)
        # sum_i a_k(i) (x_i - c_k) = sum_i a_k(i) x_i - (sum_i a_k(i)) c_k: one batched product instead of the
        # official per-cluster loop (same value, without the (N, K, D, HW) residual tensor).
        weighted = torch.bmm(assignment, features.transpose(1, 2))  # (N, K, D)
        vlad = weighted - assignment.sum(-1, keepdim=True) * self.centroids
        vlad = F.normalize(vlad, p=2, dim=2)  # intra-normalisation
        return F.normalize(vlad.flatten(1), p=2, dim=1)


class NetVLADNet(nn.Module):
    """``encoder`` + ``pool`` (+ ``WPCA``), named as in both releases."""

    def __init__(self, num_clusters: int = 64, num_pcs: int = 4096) -> None:
        super().__init__()
        self.encoder = nn.Sequential(*vgg16_conv5_3())  # keys encoder.N.*, N = 0..28
        self.pool = NetVLADPool(num_clusters, 512)
        self.WPCA: nn.Sequential | None = None
        if num_pcs:
            # Patch-NetVLAD's WPCA: Conv2d 1x1 (index 0, keys WPCA.0.*), Flatten, L2Norm over the last dim.
            self.WPCA = nn.Sequential(
                nn.Conv2d(512 * num_clusters, num_pcs, kernel_size=1), nn.Flatten(1), L2Norm(-1)
            )

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        vlad: torch.Tensor = self.pool(self.encoder(x))
        if self.WPCA is not None:
            vlad = self.WPCA(vlad[:, :, None, None])  # as Patch-NetVLAD's get_pca_encoding
        return vlad


def _numpy_scalar_globals() -> list[Any]:
    """The numpy globals a pickled ``np.float64`` needs, under the names old and new numpy write.

    Nanne's ``checkpoint.pth.tar`` stores ``best_score`` and ``recalls`` as numpy float64 scalars; nothing
    broader than the scalar constructor and the float64 dtype is allowed.
    """
    core = getattr(np, "_core", None) or np.core  # numpy >= 2 moved numpy.core to numpy._core
    scalar = core.multiarray.scalar
    return [
        scalar,
        (scalar, "numpy.core.multiarray.scalar"),  # the name in files written with numpy 1.x
        (scalar, "numpy._core.multiarray.scalar"),
        np.dtype,
        type(np.dtype(np.float64)),  # numpy.dtypes.Float64DType, which the dtype's BUILD step needs
    ]


@dataclass(frozen=True)
class NetVLADSettings:
    """The settings of ``netvlad``."""

    # "auto": 480 x 640 with a Patch-NetVLAD (WPCA) file, full size with Nanne's; [H, W]; null: full size.
    image_size: str | tuple[int, ...] | None = setting(
        "auto", "auto, null or [H, W] in pixels: the size images are resized to (PIL bilinear); auto: {} x {} for a "
                "Patch-NetVLAD file (with WPCA), full size for Nanne's and under preprocessing vpr-methods-evaluation; "
                "null: full size".format(*PATCH_NETVLAD_SIZE))
    # Model sizes before a checkpoint is loaded; load() reads both from the file's shapes and rebuilds.
    num_clusters: int = setting(64, "the number of NetVLAD clusters K (512 K values before WPCA); sizes the model "
                                    "before loading only: the checkpoint's pool.centroids sets it")
    num_pcs: int = setting(4096, "the WPCA output size, 0 for no WPCA; sizes the model before loading only: the "
                                 "checkpoint's WPCA.0.bias sets it (0 for a file without WPCA)")


class NetVLAD(TorchBackend):
    """VGG16 + NetVLAD (+ WPCA); 32768-d (64 clusters) or ``num_pcs``-d descriptors.

    Default input size (``image_size: auto``), as the official evaluation of each file: a file with a WPCA
    layer is Patch-NetVLAD's, whose configurations resize every image to 480 x 640 (``imageresizeh``,
    ``imageresizew``); a file without it is Nanne's, whose evaluation (``pittsburgh.py`` ``input_transform``)
    feeds the full-size image. ``preprocessing: vpr-methods-evaluation`` feeds the full-size image too (that
    harness's own NetVLAD is a different file, hloc's MATLAB conversion). ``image_size: [H, W]`` or ``null``
    (full size) overrides both.
    """

    name: ClassVar[str] = "netvlad"
    Settings: ClassVar[type | None] = NetVLADSettings
    input_summary: ClassVar[str] = ("{}x{} (H x W) with a Patch-NetVLAD file, full size with Nanne's"
                                 .format(*PATCH_NETVLAD_SIZE))
    # Nanne's main.py wraps encoder and pool separately in nn.DataParallel: "encoder.module.0.weight".
    strip_components: ClassVar[tuple[str, ...]] = ("module",)

    def __init__(self, conf: dict[str, Any] | None = None) -> None:
        size = {**self.default_conf, **(conf or {})}["image_size"]
        if size not in ("auto", None) and not (isinstance(size, list | tuple) and len(size) == 2):
            raise ValueError(f"backend 'netvlad': image_size must be auto, null (full size) or [H, W], got {size!r}")
        super().__init__(conf)

    def build_model(self) -> nn.Module:
        return NetVLADNet(int(self.conf["num_clusters"]), int(self.conf["num_pcs"] or 0))

    def expected_file(self) -> str:
        return (f"{EXPECTED_FILES} (keys encoder.N.*, pool.conv.weight, pool.centroids, optionally "
                "WPCA.0.weight/bias)")

    @property
    def image_size(self) -> tuple[int, int] | None:
        """The ``(H, W)`` images are resized to, ``None`` for full size (see the class docstring)."""
        size = self.conf["image_size"]
        if size == "auto":
            patch_netvlad = self.model.WPCA is not None
            return PATCH_NETVLAD_SIZE if patch_netvlad and not self.harness else None
        return None if size is None else (int(size[0]), int(size[1]))

    def preprocess(self, image: np.ndarray) -> torch.Tensor:
        """RGB uint8 ``H x W x 3`` -> normalised ``3 x h x w`` tensor.

        Patch-NetVLAD's ``input_transform`` applies ``transforms.Resize((480, 640))`` to PIL images, i.e.
        PIL's bilinear resize on uint8 (filtering when shrinking), then ``ToTensor`` and ImageNet
        ``Normalize``; we call PIL directly so the resized pixels are identical. Nanne's applies only
        ``ToTensor`` and ``Normalize``.
        """
        image = np.ascontiguousarray(image)
        if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
            raise ValueError(f"netvlad: expected an RGB uint8 H x W x 3 image, got {image.dtype} "
                             f"{image.shape}")
        size = self.image_size
        if size is not None:
            image = pil_resize(image, size, "bilinear")
        return to_tensor(image)

    def checkpoint_globals(self) -> list[Any]:
        return _numpy_scalar_globals()

    def adapt_state_dict(self, state_dict: dict[str, Any], data: Any, path: Path) -> dict[str, Any]:
        """The cluster count and PCA size come from the file's shapes; the model is rebuilt to fit."""
        centroids = state_dict.get("pool.centroids")
        num_clusters = self.conf["num_clusters"]
        if centroids is not None and getattr(centroids, "ndim", 0) == 2:
            num_clusters = int(centroids.shape[0])
        bias = state_dict.get("WPCA.0.bias")
        num_pcs = int(bias.shape[0]) if bias is not None and getattr(bias, "ndim", 0) == 1 else 0
        if (num_clusters, num_pcs) != (self.conf["num_clusters"], self.conf["num_pcs"] or 0):
            self.conf.update(num_clusters=num_clusters, num_pcs=num_pcs)
            self.model = self.build_model().eval()
        return state_dict
