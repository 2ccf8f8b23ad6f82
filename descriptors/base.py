"""The base class of every descriptor backend.

A backend maps one RGB image (``H x W x 3`` uint8) to one global descriptor. It is a small class:
``preprocess(image)`` runs in DataLoader worker processes and returns a tensor or array, ``forward(batch)``
returns ``(B, dim)`` float32 descriptors, and learned backends ``load(checkpoint)`` from a local file.
Parameters come from ``default_conf`` updated with the configuration entry, as in hloc.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import torch

from ..eval.distances import METRICS

COMMON_SETTINGS = ("checkpoint", "device", "half", "distance")  # accepted by every backend


class CheckpointError(ValueError):
    """A checkpoint is missing or does not fit the backend; the message names the file and the setting."""


class Backend:
    """Base class: subclasses set ``name`` and ``default_conf`` and implement ``preprocess`` and ``forward``."""

    name: ClassVar[str] = ""
    default_conf: ClassVar[dict[str, Any]] = {}
    # "l2": squared Euclidean on L2-normalised descriptors; "cosine": 1 - cos; "mad": mean absolute difference
    # (SAD). The class sets the method's own metric; the setting ``distance`` overrides it per method.
    distance: str = "l2"
    # Learned backends need a checkpoint path in the configuration (``checkpoint: ...``).
    needs_checkpoint: ClassVar[bool] = False

    def __init__(self, conf: dict[str, Any] | None = None) -> None:
        conf = dict(conf or {})
        unknown = sorted(set(conf) - set(self.default_conf) - set(COMMON_SETTINGS))
        if unknown:
            raise ValueError(
                f"backend {self.name!r} has no setting {', '.join(unknown)}; its settings are "
                f"{', '.join(sorted(self.default_conf)) or 'none'} (and {', '.join(COMMON_SETTINGS)})"
            )
        self.conf = {**self.default_conf, **conf}
        if self.conf.get("distance") is not None:
            if self.conf["distance"] not in METRICS:
                raise ValueError(f"backend {self.name!r}: distance must be one of {', '.join(METRICS)}, "
                                 f"got {self.conf['distance']!r}")
            self.distance = self.conf["distance"]
        self.device = torch.device(self.conf.get("device") or ("cuda" if torch.cuda.is_available() else "cpu"))
        self.half = bool(self.conf.get("half", False)) and self.device.type == "cuda"

    def preprocess(self, image: np.ndarray) -> torch.Tensor:
        raise NotImplementedError

    def forward(self, batch: torch.Tensor) -> np.ndarray:
        raise NotImplementedError

    def load(self, checkpoint: Path | str | None) -> None:
        """Load weights from a local file. Weight-free backends accept ``None`` only."""
        if checkpoint is not None:
            raise CheckpointError(f"backend {self.name!r} takes no checkpoint, but one was given: {checkpoint}")

    def precomputed(self, pair: Any) -> tuple[np.ndarray, np.ndarray] | None:
        """Descriptors that need no images (e.g. files computed elsewhere); ``None``: compute from images."""
        return None

    def describe(self, image: np.ndarray) -> np.ndarray:
        """Descriptor of one image (a convenience; the pipeline batches)."""
        return self.forward(torch.as_tensor(self.preprocess(image))[None])[0]


class TorchBackend(Backend):
    """A backend whose descriptor is a ``torch.nn.Module`` applied to preprocessed batches."""

    needs_checkpoint: ClassVar[bool] = True

    def __init__(self, conf: dict[str, Any] | None = None) -> None:
        super().__init__(conf)
        self.model = self.build_model().eval()

    def build_model(self) -> torch.nn.Module:
        raise NotImplementedError

    def load_state_dict(self, state_dict: dict[str, torch.Tensor], source: str) -> None:
        """``load_state_dict(strict=True)`` with an error that lists missing, unexpected and misshaped keys."""
        problems = state_dict_problems(self.model, state_dict)
        if problems:
            raise CheckpointError(f"checkpoint {source} does not fit backend {self.name!r}:\n{problems}")
        self.model.load_state_dict(state_dict, strict=True)

    def prepare(self) -> None:
        """Move the model to the device (after loading weights)."""
        self.model = self.model.to(self.device)
        if self.half:
            self.model = self.model.half()

    @torch.inference_mode()
    def forward(self, batch: torch.Tensor) -> np.ndarray:
        batch = batch.to(self.device, non_blocking=True)
        batch = batch.half() if self.half else batch.float()
        return self.model(batch).float().cpu().numpy()


def state_dict_problems(model: torch.nn.Module, state_dict: dict[str, Any], limit: int = 10) -> str:
    """Human-readable list of the keys that keep ``state_dict`` from loading into ``model`` (empty if none)."""
    expected = model.state_dict()
    missing = [k for k in expected if k not in state_dict]
    unexpected = [k for k in state_dict if k not in expected]
    misshaped = [
        f"{k}: file {tuple(state_dict[k].shape)}, model {tuple(expected[k].shape)}"
        for k in expected
        if k in state_dict and tuple(getattr(state_dict[k], "shape", ())) != tuple(expected[k].shape)
    ]
    lines = []
    for title, keys in (("missing keys", missing), ("unexpected keys", unexpected), ("wrong shapes", misshaped)):
        if keys:
            shown = "\n    ".join(keys[:limit])
            more = f"\n    ... and {len(keys) - limit} more" if len(keys) > limit else ""
            lines.append(f"  {len(keys)} {title}:\n    {shown}{more}")
    return "\n".join(lines)


def load_tensor_file(path: Path | str, setting: str = "checkpoint") -> dict[str, Any]:
    """``torch.load(path, weights_only=True)`` with errors that name the file and the setting to fix."""
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"checkpoint not found: {path} (set `{setting}` to the downloaded file)")
    try:
        return torch.load(path, map_location="cpu", weights_only=True)
    except Exception as error:  # torch raises UnpicklingError, RuntimeError, ... for unusable files
        raise CheckpointError(
            f"cannot load checkpoint {path} with weights_only=True: {error}. If it is an official file "
            "that stores Python objects, convert it first with `vpr-smr convert-checkpoint`."
        ) from None


def sha256_file(path: Path | str, chunk: int = 1 << 20) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        while block := handle.read(chunk):
            digest.update(block)
    return digest.hexdigest()


IMAGENET_MEAN = (0.485, 0.456, 0.406)
IMAGENET_STD = (0.229, 0.224, 0.225)


def to_tensor(image: np.ndarray, size: tuple[int, int] | None = None, mean=IMAGENET_MEAN, std=IMAGENET_STD,
              interpolation: str = "bilinear") -> torch.Tensor:
    """RGB uint8 ``H x W x 3`` -> normalised float tensor ``3 x H x W``, optionally resized to ``size = (H, W)``.

    Resizing follows torchvision's ``transforms.Resize`` on tensors (antialias on), as the official
    evaluation code of the learned methods does.
    """
    from torchvision.transforms import InterpolationMode
    from torchvision.transforms.functional import normalize, resize

    tensor = torch.from_numpy(np.ascontiguousarray(image)).permute(2, 0, 1).float().div_(255.0)
    if size is not None and tuple(tensor.shape[1:]) != tuple(size):
        tensor = resize(tensor, list(size), interpolation=InterpolationMode(interpolation), antialias=True)
    return normalize(tensor, mean, std)
