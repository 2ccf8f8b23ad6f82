"""The base class of every descriptor backend.

A backend maps one RGB image (``H x W x 3`` uint8) to one global descriptor. It is a small class:
``preprocess(image)`` runs in DataLoader worker processes and returns a tensor or array, ``forward(batch)``
returns ``(B, dim)`` float32 descriptors, and learned backends ``load(checkpoint)`` from a local file.
Parameters come from ``default_conf`` updated with the configuration entry, as in hloc.

Checkpoint loading lives here, in ``TorchBackend.load``, for every learned backend: read the file with
``weights_only=True``, find the state dict inside it (``find_state_dict``), strip the wrapper prefixes of
training code once (``strip_wrappers``), let the backend adapt what really differs (``adapt_state_dict``: model
sizes read from the file, extra content such as a whitening), check every key and shape strictly, then load.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import torch

from ..eval.distances import METRICS

# Accepted by every backend, next to the backend's own ``default_conf``.
COMMON_SETTINGS = ("checkpoint", "device", "half", "distance", "preprocessing")

# Values of the ``preprocessing`` setting. "official": what each method's own evaluation code does with the
# published file; "vpr-methods-evaluation": the resizing of gmberton/VPR-methods-evaluation where it differs
# (backends where both agree ignore the setting).
PREPROCESSING = ("official", "vpr-methods-evaluation")


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
    # The file the weights came from, once loaded (its SHA-256 goes into the provenance).
    checkpoint_file: Path | None = None

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
        if self.conf.get("preprocessing") is None:
            self.conf["preprocessing"] = PREPROCESSING[0]
        preprocessing = self.conf["preprocessing"]
        if preprocessing not in PREPROCESSING:
            raise ValueError(f"backend {self.name!r}: preprocessing must be one of {', '.join(PREPROCESSING)}, "
                             f"got {preprocessing!r}")
        self.device = torch.device(self.conf.get("device") or ("cuda" if torch.cuda.is_available() else "cpu"))
        self.half = bool(self.conf.get("half", False)) and self.device.type == "cuda"

    @property
    def harness(self) -> bool:
        """Whether ``preprocessing`` asks for gmberton/VPR-methods-evaluation's resizing."""
        return self.conf["preprocessing"] == "vpr-methods-evaluation"

    def preprocess(self, image: np.ndarray) -> torch.Tensor:
        raise NotImplementedError

    def forward(self, batch: torch.Tensor) -> np.ndarray:
        raise NotImplementedError

    def load(self, checkpoint: Path | str | None) -> None:
        """Load weights from a local file. Weight-free backends accept ``None`` only."""
        if checkpoint is not None:
            raise CheckpointError(f"backend {self.name!r} takes no checkpoint, but one was given: {checkpoint}")

    def check(self, checkpoint: Path | str | None) -> None:
        """Raise what ``load(checkpoint)`` would raise, as cheaply as the backend can (here: by loading)."""
        self.load(checkpoint)

    def precomputed(self, pair: Any) -> tuple[np.ndarray, np.ndarray] | None:
        """Descriptors that need no images (e.g. files computed elsewhere); ``None``: compute from images."""
        return None

    def describe(self, image: np.ndarray) -> np.ndarray:
        """Descriptor of one image (a convenience; the pipeline batches)."""
        return self.forward(torch.as_tensor(self.preprocess(image))[None])[0]


class TorchBackend(Backend):
    """A backend whose descriptor is a ``torch.nn.Module`` applied to preprocessed batches.

    Subclasses implement ``build_model`` and ``preprocess``, name their file in ``expected_file`` and declare
    only what differs in their checkpoints (class attributes and ``adapt_state_dict``); ``load`` does the rest.
    """

    needs_checkpoint: ClassVar[bool] = True
    # Entries of a training checkpoint that hold the state dict (Lightning and most training scripts use
    # "state_dict"), tried in order; a file without any of them is taken as the state dict itself.
    state_dict_entries: ClassVar[tuple[str, ...]] = ("state_dict", "model_state_dict", "model")
    # Prefixes that wrappers put before every key (nn.DataParallel / DistributedDataParallel: "module."),
    # removed when every key has them.
    strip_prefixes: ClassVar[tuple[str, ...]] = ("module.",)
    # Key components removed wherever they occur (e.g. "module" when DataParallel wrapped submodules:
    # "encoder.module.0.weight"). Empty by default, since a plugin's model may name a submodule so.
    strip_components: ClassVar[tuple[str, ...]] = ()

    def __init__(self, conf: dict[str, Any] | None = None) -> None:
        super().__init__(conf)
        self.model = self.build_model().eval()

    def build_model(self) -> torch.nn.Module:
        raise NotImplementedError

    def expected_file(self) -> str:
        """The file this backend expects, for error messages (subclasses name their official release)."""
        return f"a file holding the state dict of backend {self.name!r}"

    def checkpoint_path(self, checkpoint: Path | str) -> Path:
        """The file that the ``checkpoint`` setting names (a backend may accept special values)."""
        return Path(checkpoint)

    def checkpoint_globals(self) -> list[Any]:
        """Globals that ``torch.load(weights_only=True)`` may build for this backend's files (none by default)."""
        return []

    def find_state_dict(self, data: Any, source: Path | str) -> dict[str, Any]:
        """The state dict inside a loaded file: one of ``state_dict_entries``, or the file itself."""
        if isinstance(data, dict):
            for entry in self.state_dict_entries:
                if isinstance(data.get(entry), dict):
                    data = data[entry]
                    break
        if not isinstance(data, dict) or not any(isinstance(v, torch.Tensor) for v in data.values()):
            found = f"a dict with keys {', '.join(map(str, list(data)[:8]))}" if isinstance(data, dict) and data \
                else type(data).__name__
            raise CheckpointError(f"checkpoint {source} holds no state dict (found {found}; looked for "
                                  f"tensors under {', '.join(map(repr, self.state_dict_entries))} or at the top)")
        return data

    def strip_wrappers(self, state_dict: dict[str, Any]) -> dict[str, Any]:
        """Remove ``strip_prefixes`` (when every key has one) and ``strip_components``, in one pass."""
        keys = [str(key) for key in state_dict]
        prefix = next((p for p in self.strip_prefixes if all(k.startswith(p) for k in keys)), "")
        drop = set(self.strip_components)
        renamed = {}
        for key, value in zip(keys, state_dict.values(), strict=True):
            key = key[len(prefix):]
            if drop:
                key = ".".join(part for part in key.split(".") if part not in drop)
            renamed[key] = value
        return renamed

    def adapt_state_dict(self, state_dict: dict[str, Any], data: Any, path: Path) -> dict[str, Any]:
        """Backend hook between unwrapping and the strict check: read sizes from the file (rebuilding the
        model), use its other content (``data`` is the whole loaded file), or refuse it with a clear error."""
        return state_dict

    def read_checkpoint(self, checkpoint: Path | str | None) -> dict[str, Any]:
        """The state dict of ``checkpoint``, adapted and checked against the model (strict keys and shapes),
        not yet loaded. Every error names the file and what the backend expects."""
        if checkpoint is None or checkpoint == "":
            raise CheckpointError(f"backend {self.name!r} needs a checkpoint: set `checkpoint` to "
                                  f"{self.expected_file()}")
        path = None
        try:
            path = self.checkpoint_path(checkpoint)
            with torch.serialization.safe_globals(self.checkpoint_globals()):
                data = load_tensor_file(path)
            state_dict = self.strip_wrappers(self.find_state_dict(data, path))
            state_dict = fill_batch_norm_counters(self.adapt_state_dict(state_dict, data, path), self.model)
            problems = state_dict_problems(self.model, state_dict)
            if problems:
                raise CheckpointError(f"checkpoint {path} does not fit backend {self.name!r}:\n{problems}"
                                      f"{self.key_hint(state_dict)}")
        except CheckpointError as error:
            expected = self.expected_file()
            if expected in str(error):
                raise
            raise CheckpointError(f"{error}\n  (backend {self.name!r} expected {expected})") from None
        self.checkpoint_file = path
        return state_dict

    def key_hint(self, state_dict: dict[str, Any]) -> str:
        """Extra explanation appended to a key mismatch (e.g. which setting sizes the mismatched layers)."""
        return ""

    def load(self, checkpoint: Path | str | None) -> None:
        """Load the weights of ``checkpoint`` strictly (see ``read_checkpoint``) and move the model to its device."""
        state_dict = self.read_checkpoint(checkpoint)
        # Copies into the model's dtypes (e.g. Patch-NetVLAD's float64 WPCA into float32), as load_state_dict does.
        self.model.load_state_dict(state_dict, strict=True)
        self.prepare()

    def check(self, checkpoint: Path | str | None) -> None:
        """Everything ``load`` checks, without copying weights or moving the model."""
        if type(self).load is TorchBackend.load:
            self.read_checkpoint(checkpoint)
        else:  # a backend with its own load(): only loading can tell
            self.load(checkpoint)

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


def fill_batch_norm_counters(state_dict: dict[str, Any], model: torch.nn.Module) -> dict[str, Any]:
    """Add BatchNorm's ``num_batches_tracked`` when a file has none at all (files saved before PyTorch 0.4.1,
    e.g. AP-GeM's); the counter is unused at evaluation. A file with some counters is left to the strict check."""
    expected = model.state_dict()
    counters = [k for k in expected if k.endswith("num_batches_tracked")]
    if counters and not any(k in state_dict for k in counters):
        state_dict = {**state_dict, **{k: torch.zeros_like(expected[k]) for k in counters}}
    return state_dict


def state_dict_problems(model: torch.nn.Module, state_dict: dict[str, Any], limit: int = 10) -> str:
    """Human-readable list of the keys that keep ``state_dict`` from loading into ``model`` (empty if none)."""
    expected = model.state_dict()
    missing = [k for k in expected if k not in state_dict]
    unexpected = [k for k in state_dict if k not in expected]
    misshaped = [
        f"{k}: file {tuple(getattr(state_dict[k], 'shape', ()))}, model {tuple(expected[k].shape)}"
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


def load_tensor_file(path: Path | str, setting: str = "checkpoint") -> Any:
    """``torch.load(path, weights_only=True)`` with errors that name the file and the setting to fix.

    The one place in the descriptors that tells a missing file apart (the configuration check does it
    before any job; this message is for Python callers).
    """
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

    Resizing follows torchvision's ``transforms.Resize`` on tensors (antialias on) and comes before the
    normalisation, as the official evaluation code of the learned methods does.
    """
    from torchvision.transforms.functional import normalize

    tensor = torch.from_numpy(np.ascontiguousarray(image)).permute(2, 0, 1).float().div_(255.0)
    if size is not None:
        tensor = resize_tensor(tensor, size, interpolation)
    return normalize(tensor, mean, std)


def resize_tensor(tensor: torch.Tensor, size: tuple[int, int] | list[int],
                  interpolation: str = "bilinear") -> torch.Tensor:
    """torchvision ``transforms.functional.resize(tensor, [H, W], antialias=True)`` (unchanged at that size)."""
    from torchvision.transforms import InterpolationMode
    from torchvision.transforms.functional import resize

    return resize(tensor, [int(size[0]), int(size[1])], interpolation=InterpolationMode(interpolation),
                  antialias=True)
