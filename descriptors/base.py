"""The base class of every descriptor backend.

A backend maps one RGB image (``H x W x 3`` uint8) to one global descriptor. It is a small class:
``preprocess(image)`` runs in DataLoader worker processes and returns a tensor or array, ``forward(batch)``
returns ``(B, dim)`` float32 descriptors, and learned backends ``load(checkpoint)`` from a local file.
A backend declares its own settings as its ``Settings`` record (``core.settings.setting`` fields: default and one
line of help each, as a matcher does); ``conf`` is their defaults (``default_conf``) updated with the configuration
entry, as in hloc.

Checkpoint loading lives here, in ``TorchBackend.load``, for every learned backend: read the file with
``weights_only=True`` (``read_file``; a backend released as a safetensors file reads it with ``safetensors``),
find the state dict inside it (``find_state_dict``), strip the wrapper prefixes of training code once
(``strip_wrappers``), let the backend adapt what really differs (``adapt_state_dict``: model sizes read from the
file, extra content such as a whitening), check every key and shape strictly, then load.
A file torch cannot read is described by what it is (``describe_file``: empty, a web page, a git-lfs pointer,
truncated, an archive ...) or by what torch refused (``describe_load_error``), never with torch's own advice.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import pickletools
import re
import shlex
import tarfile
import zipfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import torch

from vpr_smr.core.constants import METRICS
from vpr_smr.core.deprecation import deprecated
from vpr_smr.core.files import EMPTY, GZIP, HDF5, KINDS, MAT, NPY, PICKLE, TAR, ZIP, file_kind, read_head, text_start
from vpr_smr.core.settings import declared, json_default

# Accepted by every backend, next to the backend's own settings (its ``Settings``).
COMMON_SETTINGS = ("checkpoint", "device", "half", "distance", "preprocessing")

# Values of the ``preprocessing`` setting. "official": what each method's own evaluation code does with the
# published file; "vpr-methods-evaluation": the resizing of gmberton/VPR-methods-evaluation where it differs
# (backends where both agree ignore the setting).
PREPROCESSING = ("official", "vpr-methods-evaluation")

# What each of COMMON_SETTINGS means, with its type and default (what ``Backend.__init__`` and the extraction do),
# for the configuration reference: one line each, like ``Backend.settings_help``.
COMMON_SETTINGS_HELP: dict[str, str] = {
    "checkpoint": "text or null: the path of the backend's weights file (a relative path is read from the working "
                  "folder), needed by the learned backends; null (the default) for the weight-free ones; "
                  "efficientnet_lite0_gem also takes `package`",
    "device": "text or null: the torch device the network runs on (cpu, cuda, cuda:1); null (the default): cuda "
              "when PyTorch sees a GPU, else cpu",
    "half": "true/false: run the network in float16 (default false); only on a CUDA device, ignored on the CPU and "
            "by the weight-free backends",
    "distance": f"one of {', '.join(METRICS)} or null: how descriptors are compared (l2: squared Euclidean of the "
                "L2-normalised descriptors, cosine: 1 - cos, mad: mean absolute difference); null (the default): "
                "the backend's own metric, as `vpr-smr backends` lists it",
    "preprocessing": f"one of {', '.join(PREPROCESSING)} or null: the input transform; official (the default, also "
                     "for null): each method's own evaluation code; vpr-methods-evaluation: the resizing of "
                     "gmberton/VPR-methods-evaluation, where it differs",
}


class CheckpointError(ValueError):
    """A checkpoint is missing or does not fit the backend; the message names the file and the setting."""


class Backend:
    """Base class: subclasses set ``name`` and ``Settings`` and implement ``preprocess`` and ``forward``."""

    name: ClassVar[str] = ""
    # The backend's own settings: a frozen dataclass of ``core.settings.setting(default, help)`` fields, the help
    # saying what the setting means, its unit or choices, and what null or auto does (with the accepted types where
    # the default does not show them); the configuration reference and `vpr-smr backends` show them.
    Settings: ClassVar[type | None] = None
    # What ``Settings`` declares, as JSON (``__init_subclass__`` derives them): the defaults, and the help by name.
    default_conf: ClassVar[dict[str, Any]] = {}
    settings_help: ClassVar[dict[str, str]] = {}
    # "l2": squared Euclidean on L2-normalised descriptors; "cosine": 1 - cos; "mad": mean absolute difference
    # (SAD). The class sets the method's own metric; the setting ``distance`` overrides it per method.
    distance: str = "l2"
    # Learned backends need a checkpoint path in the configuration (``checkpoint: ...``).
    needs_checkpoint: ClassVar[bool] = False
    # The images the backend feeds its model under its default settings, in words (listed by `vpr-smr backends`):
    # the official evaluation's size, or "full size".
    input_summary: ClassVar[str] = "not stated"
    # The file the weights came from, once loaded (its SHA-256 goes into the provenance).
    checkpoint_file: Path | None = None

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "Settings" in vars(cls) and cls.Settings is not None:
            settings = declared(cls.Settings)
            cls.default_conf = {item.name: json_default(item) for item in settings}
            cls.settings_help = {item.name: item.help for item in settings}
        elif "default_conf" in vars(cls) or "settings_help" in vars(cls):
            # a plugin written for 0.15: its dicts still work
            deprecated(f"descriptor backend {cls.__module__}.{cls.__qualname__} declares its settings as "
                          "default_conf and settings_help dicts, which a later release will not read: declare them "
                          "as a Settings record of core.settings.setting(default, help) fields (docs/extending.md, "
                          "'A descriptor backend')")

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
        preprocessing: str = self.conf["preprocessing"]
        return preprocessing == "vpr-methods-evaluation"

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
        descriptors = self.forward(torch.as_tensor(self.preprocess(image))[None])
        descriptor: np.ndarray = descriptors[0]
        return descriptor


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

    def read_file(self, path: Path) -> Any:
        """The content of a checkpoint file: ``torch.load(weights_only=True)`` with described errors
        (``load_tensor_file``). A backend whose release is another format of tensors overrides it."""
        return load_tensor_file(path, backend=self.name)

    def find_state_dict(self, data: Any, source: Path | str) -> dict[str, Any]:
        """The state dict inside a loaded file: one of ``state_dict_entries``, or the file itself."""
        looked = f"looked for tensors under {', '.join(map(repr, self.state_dict_entries))} or at the top"
        if isinstance(data, dict):
            for entry in self.state_dict_entries:
                if isinstance(data.get(entry), dict):
                    if not _has_tensors(data[entry]):
                        raise CheckpointError(f"checkpoint {source} holds no state dict: its {entry!r} entry is "
                                              f"{describe_value(data[entry])}")
                    state_dict: dict[str, Any] = data[entry]
                    return state_dict
            if _has_tensors(data):
                return data
        raise CheckpointError(f"checkpoint {source} holds no state dict: it holds {describe_value(data)} ({looked})"
                              f"{_nested_state_dict_hint(data, source)}")

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
                data = self.read_file(path)
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

    def prepare(self) -> None:
        """Move the model to the device (after loading weights)."""
        self.model = self.model.to(self.device)
        if self.half:
            self.model = self.model.half()

    @torch.inference_mode()
    def forward(self, batch: torch.Tensor) -> np.ndarray:
        batch = batch.to(self.device, non_blocking=True)
        batch = batch.half() if self.half else batch.float()
        descriptors: torch.Tensor = self.model(batch)
        return descriptors.float().cpu().numpy()


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


# The fix for a file cut short, for the empty and truncated-file messages.
AGAIN = "the download did not finish; download it again"


def load_tensor_file(path: Path | str, setting: str = "checkpoint", backend: str | None = None) -> Any:
    """``torch.load(path, weights_only=True)`` with errors that name the file, what it holds and the fix.

    The one place in the descriptors that tells a missing file apart (the configuration check does it
    before any job; this message is for Python callers). ``backend`` (its name) decides whether a file that
    stores Python objects gets the hint to convert it (only backends in ``convert.CONVERTERS`` have one).
    """
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"checkpoint not found: {path} (set `{setting}` to the downloaded file)")
    try:
        return torch.load(path, map_location="cpu", weights_only=True)
    except Exception as error:  # torch raises UnpicklingError, RuntimeError, EOFError, IndexError ... for bad files
        finding = describe_file(path, setting) or describe_load_error(error, path, backend)
        raise CheckpointError(f"checkpoint {path} {finding}") from None


def is_safetensors_file(path: Path | str) -> bool:
    """Whether ``path`` starts as a safetensors file does (an 8-byte header length, then ``{``), complete or not."""
    with open(path, "rb") as handle:
        head = handle.read(9)
    return len(head) == 9 and head[8:9] == b"{" and 0 < int.from_bytes(head[:8], "little") < 1 << 32


def load_safetensors_file(path: Path | str, setting: str = "checkpoint") -> dict[str, torch.Tensor]:
    """The tensors of a safetensors file (on the CPU), with errors that name the file, what is wrong and the fix.

    safetensors reads tensors only (no code can run). The file's header gives each tensor's byte range, so a
    file cut short is told apart from a damaged one.
    """
    from safetensors import SafetensorError
    from safetensors.torch import load_file

    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"checkpoint not found: {path} (set `{setting}` to the downloaded file)")
    try:
        return load_file(path, device="cpu")
    except (SafetensorError, OSError, ValueError) as error:
        raise CheckpointError(f"checkpoint {path} {_describe_safetensors(path, error)}") from None


def _describe_safetensors(path: Path, error: Exception) -> str:
    """Why safetensors refused ``path``: empty, cut short (the header announces more bytes than the file has)
    or damaged."""
    size = path.stat().st_size
    if size == 0:
        return f"is empty (0 bytes): {AGAIN}"
    with open(path, "rb") as handle:
        length = int.from_bytes(handle.read(8), "little")
        header_bytes = handle.read(min(length, size))
    if 8 + length > size:
        return (f"is truncated ({size} bytes; its safetensors header alone announces {8 + length} bytes): "
                f"{AGAIN}")
    try:
        header = json.loads(header_bytes)
        end = max((int(entry["data_offsets"][1]) for key, entry in header.items() if key != "__metadata__"),
                  default=0)
    except (ValueError, TypeError, KeyError, IndexError, AttributeError):
        end = None
    if end is not None and 8 + length + end > size:
        return (f"is truncated ({size} bytes; its safetensors header announces {8 + length + end} bytes): "
                f"{AGAIN}")
    first = str(error).strip().splitlines()[0][:120] if str(error).strip() else ""
    return f"is damaged or not a safetensors file ({type(error).__name__}: {first}): download it again"


def describe_file(path: Path, setting: str = "checkpoint", inside: str | None = None) -> str | None:
    """What a file that ``torch.load`` could not read is, from its bytes alone (nothing is unpickled), with
    the fix: "is empty (0 bytes): ...". ``None`` when it looks like an intact torch.save file. ``inside``: what
    to do with the file inside an archive (default: point ``setting`` to it)."""
    size = path.stat().st_size
    head = read_head(path)
    kind = file_kind(head)
    inside = inside or f"set `{setting}` to the checkpoint inside"
    if kind == EMPTY:
        return f"is empty (0 bytes): {AGAIN}"
    if kind == TAR:  # torch's weights_only unpickler reads a tar header as "pop from empty list"
        return f"is a tar archive{_members(path, tarfile.open)}, not a checkpoint: unpack it (`tar -xf`) and {inside}"
    if kind == GZIP:
        return f"is gzip-compressed, not a checkpoint: unpack it (`gunzip`, or `tar -xzf` for a .tar.gz) and {inside}"
    if kind == HDF5:
        return "is an HDF5 file (Keras or TensorFlow weights?), not a PyTorch checkpoint: download the PyTorch release"
    if kind in (NPY, MAT):
        return f"is {KINDS[kind]}, not a torch.save checkpoint: download the checkpoint itself"
    if _is_safetensors(head, size):
        return ("is a safetensors file, not a torch.save checkpoint (.pth, .pt, .ckpt): this backend reads the "
                "torch.save release; download that file")
    if kind == ZIP:  # torch.save's zip format
        if not zipfile.is_zipfile(path):
            return f"is truncated ({size} bytes; a zip archive, torch.save's format, without its end): {AGAIN}"
        with zipfile.ZipFile(path) as archive:
            names = archive.namelist()
        if not any(name.endswith("/data.pkl") for name in names):
            return f"is a zip archive{_members(path, zipfile.ZipFile)}, not a torch.save file: unzip it and {inside}"
        return None
    text = text_start(head)
    if text is not None:
        return _describe_text(text)
    if kind == PICKLE:  # torch.save's legacy format, or a plain pickle
        return _describe_legacy(path, size)
    return (f"is not a torch.save file (it starts with bytes {head[:8].hex(' ')}): download the checkpoint "
            f"again, or check that `{setting}` names the right file")


def describe_load_error(error: Exception, path: Path, backend: str | None = None) -> str:
    """The finding and fix for a torch.save file that ``torch.load(weights_only=True)`` refused. Never quotes
    torch's advice to load unsafely; a conversion is suggested only for a backend that has a converter."""
    message = str(error)
    refused = re.findall(r"GLOBAL (\S+) (?:was not an allowed global|whose module)", message)
    refused += re.findall(r"but got <class '([^']+)'>", message)
    refused += re.findall(r"unrecognized function (\S+)", message)
    if refused:
        from vpr_smr.descriptors.convert import CONVERTERS  # here: convert imports this module

        if backend in CONVERTERS:
            fix = (f"convert it first with `vpr-smr convert-checkpoint {backend} {shlex.quote(str(path))} OUT` "
                   "and load OUT")
        else:
            fix = ("this backend reads files of tensors only: use the file it expects, or save the model's state "
                   "dict alone where it was trained (`torch.save(model.state_dict(), PATH)`)")
        names = ", ".join(dict.fromkeys(refused))
        return (f"stores Python objects, not only tensors: loading with weights_only=True refuses {names}; "
                f"{fix}")
    if isinstance(error, EOFError) or "unexpected EOF" in message:
        return f"is truncated ({path.stat().st_size} bytes; the torch.save data stops early): {AGAIN}"
    return f"is damaged or not a torch.save file ({_torch_reason(error)}): download it again"


def _torch_reason(error: Exception) -> str:
    """torch's own reason, short, without its advice (which includes loading with weights_only off)."""
    message = str(error).split("\n\nCheck the documentation", 1)[0]
    if "Weights only load failed" in message:
        message = message.rsplit("\n\n", 1)[-1]
    first = message.strip().splitlines()[0] if message.strip() else ""
    first = first.split(". This is an internal", 1)[0]
    if not first or "weights_only" in first:
        return type(error).__name__
    return f"{type(error).__name__}: {first[:120]}"


def _members(path: Path, opener: Any) -> str:
    """" holding a.pth, b.txt" for an archive (the first few members), or "" when it cannot be listed."""
    try:
        with opener(path) as archive:
            members = archive.namelist() if isinstance(archive, zipfile.ZipFile) else \
                [member.name for member in itertools.islice(archive, 4)]
    except (OSError, tarfile.TarError, zipfile.BadZipFile):
        return ""
    shown = ", ".join(members[:3]) + (", ..." if len(members) > 3 else "")
    return f" holding {shown}" if shown else ""


def _is_safetensors(head: bytes, size: int) -> bool:
    """safetensors: an 8-byte little-endian header length, then the JSON header."""
    length = int.from_bytes(head[:8], "little")
    return len(head) > 8 and head[8:9] == b"{" and 0 < length <= size - 8


def _describe_text(text: str) -> str:
    start = text.lstrip()
    shown = (start.splitlines() or [""])[0][:40]
    if start.startswith("version https://git-lfs"):
        return (f"is text, not a checkpoint: a git-lfs pointer (it starts with {shown!r}) that stands in for the "
                "real file; fetch the file with `git lfs pull` in the repository it came from, or download it "
                "from the release")
    if start.lower().startswith(("<!doctype html", "<html", "<head", "<?xml")):
        return (f"is text, not a checkpoint (it starts with {shown!r}...): a web page, e.g. an error or sign-in "
                "page, was saved instead of the file; download the checkpoint itself again")
    return f"is text, not a checkpoint (it starts with {shown!r}...): download the checkpoint itself again"


def _describe_legacy(path: Path, size: int) -> str | None:
    """Check the five pickles that open torch.save's legacy format (magic number, protocol, system info, the
    object, storage keys) by their opcodes only; the raw storages follow them. ``None`` when they are whole."""
    with open(path, "rb") as handle:
        for index in range(5):
            try:
                ops = [(op.name, arg) for op, arg, _ in pickletools.genops(handle)]
            except ValueError as error:
                if handle.tell() >= size:  # the stream ended inside a pickle: the file is cut off
                    return f"is truncated ({size} bytes; the torch.save data stops early): {AGAIN}"
                return f"is damaged or not a torch.save file (a pickle that cannot be read: {error}): download it again"
            if index == 0 and ("LONG1", torch.serialization.MAGIC_NUMBER) not in ops:
                return ("is a plain Python pickle, not a torch.save file: save the state dict with "
                        "`torch.save(state_dict, PATH)`")
    return None


def _has_tensors(data: dict[Any, Any]) -> bool:
    return any(isinstance(value, torch.Tensor) for value in data.values())


def describe_value(value: Any, limit: int = 8) -> str:
    """A short description of a loaded object for messages: "a dict with keys epoch, args (no tensors)"."""
    if isinstance(value, dict):
        if not value:
            return "an empty dict"
        keys = ", ".join(map(str, itertools.islice(value, limit)))
        more = f" and {len(value) - limit} more" if len(value) > limit else ""
        return f"a dict with keys {keys}{more} (no tensors)"
    if isinstance(value, torch.Tensor):
        return f"a single tensor of shape {tuple(value.shape)}"
    if isinstance(value, list | tuple):
        return f"a {type(value).__name__} of {len(value)} items"
    return f"a {type(value).__name__}"


def _nested_state_dict_hint(data: Any, source: Path | str) -> str:
    """When a state dict sits under another entry: how to save it alone (the loading stays weights_only)."""
    if not isinstance(data, dict):
        return ""
    entry = next((key for key, value in data.items() if isinstance(value, dict) and _has_tensors(value)), None)
    if entry is None:
        return ""
    return (f"; its {entry!r} entry holds tensors: save them alone with `torch.save(torch.load({str(source)!r}, "
            f"weights_only=True)[{entry!r}], OUT)` and set `checkpoint` to OUT")


def sha256_file(path: Path | str, chunk: int = 1 << 20) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        while block := handle.read(chunk):
            digest.update(block)
    return digest.hexdigest()


IMAGENET_MEAN = (0.485, 0.456, 0.406)
IMAGENET_STD = (0.229, 0.224, 0.225)


def to_tensor(image: np.ndarray, size: tuple[int, int] | None = None, mean: Sequence[float] = IMAGENET_MEAN,
              std: Sequence[float] = IMAGENET_STD, interpolation: str = "bilinear") -> torch.Tensor:
    """RGB uint8 ``H x W x 3`` -> normalised float tensor ``3 x H x W``, optionally resized to ``size = (H, W)``.

    Resizing follows torchvision's ``transforms.Resize`` on tensors (antialias on) and comes before the
    normalisation, as the official evaluation code of the learned methods does.
    """
    from torchvision.transforms.functional import normalize

    tensor = torch.from_numpy(np.ascontiguousarray(image)).permute(2, 0, 1).float().div_(255.0)
    if size is not None:
        tensor = resize_tensor(tensor, size, interpolation)
    normalised: torch.Tensor = normalize(tensor, mean, std)  # torchvision is untyped
    return normalised


def resize_tensor(tensor: torch.Tensor, size: tuple[int, int] | list[int],
                  interpolation: str = "bilinear") -> torch.Tensor:
    """torchvision ``transforms.functional.resize(tensor, [H, W], antialias=True)`` (unchanged at that size)."""
    from torchvision.transforms import InterpolationMode
    from torchvision.transforms.functional import resize

    resized: torch.Tensor = resize(tensor, [int(size[0]), int(size[1])],
                                   interpolation=InterpolationMode(interpolation), antialias=True)
    return resized
