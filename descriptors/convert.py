"""One-off conversion of official checkpoints that ``torch.load(weights_only=True)`` cannot read.

The AP-GeM release (naver/deep-image-retrieval, ``Resnet-101-AP-GeM.pt``) is a ``torch.save`` pickle of
``{'model_options', 'state_dict', 'pca', ...}`` where ``pca`` maps a dataset name (``Landmarks_clean``) to a
scikit-learn 0.20 ``PCA`` object, pickled under the module name ``sklearn.decomposition.pca`` (gone since
scikit-learn 0.24). ``convert_apgem`` reads it with a restricted unpickler that resolves only an explicit
list of globals (tensor and numpy-array rebuilding, ``OrderedDict``, and the PCA class, replaced by an inert
stand-in that only keeps the pickled attributes), so nothing in the file can run code, and writes a plain
tensor file that the ``apgem`` backend loads with ``weights_only=True``.

Nanne's NetVLAD ``checkpoint.pth.tar`` needs no conversion: the ``netvlad`` backend allow-lists the two numpy
globals its scalars need.
"""

from __future__ import annotations

import collections
import pickle
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import torch

from vpr_smr.descriptors.base import CheckpointError, describe_file

APGEM_FILE = "Resnet-101-AP-GeM.pt"
CONVERTED_FORMAT = "vpr-smr apgem 1"


class PCAStandIn:
    """Inert replacement for a pickled scikit-learn PCA: unpickling only fills ``__dict__``."""

    def __repr__(self) -> str:
        return f"PCAStandIn({', '.join(sorted(self.__dict__))})"


def _latin1_encode(text: str, encoding: str = "latin1") -> bytes:
    """``_codecs.encode`` as protocol-2 pickles use it for raw bytes (numpy buffers), latin-1 only."""
    if encoding not in ("latin1", "latin-1") or not isinstance(text, str):
        raise pickle.UnpicklingError(f"refusing _codecs.encode with encoding {encoding!r}")
    return text.encode("latin1")


def _allowed_globals() -> dict[tuple[str, str], Any]:
    """Every global the official AP-GeM pickle may name, under old and new module paths, and nothing else.

    Storage classes (``torch.FloatStorage`` ...) are resolved by ``torch.load`` itself before it asks us.
    """
    core = getattr(np, "_core", None) or np.core  # numpy >= 2 moved numpy.core to numpy._core
    allowed: dict[tuple[str, str], Any] = {
        ("collections", "OrderedDict"): collections.OrderedDict,
        ("torch._utils", "_rebuild_tensor_v2"): torch._utils._rebuild_tensor_v2,
        ("torch._utils", "_rebuild_parameter"): torch._utils._rebuild_parameter,
        ("numpy", "ndarray"): np.ndarray,
        ("numpy", "dtype"): np.dtype,
        ("_codecs", "encode"): _latin1_encode,
        # scikit-learn 0.20 wrote sklearn.decomposition.pca; later versions sklearn.decomposition._pca.
        ("sklearn.decomposition.pca", "PCA"): PCAStandIn,
        ("sklearn.decomposition._pca", "PCA"): PCAStandIn,
    }
    for module in ("numpy.core.multiarray", "numpy._core.multiarray"):
        allowed[(module, "_reconstruct")] = core.multiarray._reconstruct
        allowed[(module, "scalar")] = core.multiarray.scalar
    return allowed


class RestrictedUnpickler(pickle.Unpickler):
    """An unpickler that resolves only the globals of ``_allowed_globals``."""

    _allowed = _allowed_globals()

    def find_class(self, module: str, name: str) -> Any:
        try:
            return self._allowed[(module, name)]
        except KeyError:
            raise pickle.UnpicklingError(
                f"refusing to unpickle global {module}.{name}: not one of the objects an official AP-GeM "
                "checkpoint holds"
            ) from None


class _RestrictedPickleModule:
    """What ``torch.load(pickle_module=...)`` needs: ``Unpickler`` and ``load``, both restricted."""

    Unpickler = RestrictedUnpickler

    @staticmethod
    def load(file: Any, **kwargs: Any) -> Any:
        return RestrictedUnpickler(file, **kwargs).load()


def read_restricted(path: Path | str) -> Any:
    """``torch.load`` of a legacy or zip ``torch.save`` file through the restricted unpickler."""
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"checkpoint not found: {path} (expected the official {APGEM_FILE})")
    if zipfile.is_zipfile(path):
        with zipfile.ZipFile(path) as archive:
            names = archive.namelist()
        # The release is downloaded as a zip around the .pt file; torch's own zip format has a data.pkl.
        if not any(n.endswith("data.pkl") for n in names):
            raise CheckpointError(f"{path} is a zip archive holding {', '.join(names[:5])}: unzip it and "
                                  f"convert the {APGEM_FILE} inside")
    try:
        return torch.load(path, map_location="cpu", pickle_module=_RestrictedPickleModule, weights_only=False)
    except Exception as error:  # torch raises RuntimeError, EOFError, ... for truncated or foreign files
        # What the file is (empty, an HTML page, truncated ...) tells more than the unpickler's complaint.
        finding = describe_file(path, setting="IN", inside=f"convert the {APGEM_FILE} inside")
        if finding is not None:
            raise CheckpointError(f"cannot convert {path}: it {finding} (expected the official {APGEM_FILE})"
                                  ) from None
        if isinstance(error, pickle.UnpicklingError):
            raise CheckpointError(f"cannot convert {path}: {error} (expected the official {APGEM_FILE})"
                                  ) from None
        raise CheckpointError(f"cannot read {path} as a torch.save file: {error} "
                              f"(expected the official {APGEM_FILE})") from None


def _plain(value: Any) -> Any:
    """``value`` as str/int/float/bool/None or a list of them (numpy scalars made Python), else None."""
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    return value if value is None or isinstance(value, (str, int, float, bool)) else None


def _float64(value: Any, what: str, source: Path) -> torch.Tensor:
    try:
        return torch.from_numpy(np.array(value, dtype=np.float64))
    except (TypeError, ValueError) as error:
        raise CheckpointError(f"{source}: whitening {what} is not numeric: {error}") from None


def apgem_tensors(checkpoint: Any, source: Path | str) -> dict[str, Any]:
    """The converted content of an unpickled official AP-GeM checkpoint (see ``convert_apgem``)."""
    source = Path(source)
    if not isinstance(checkpoint, dict) or not isinstance(checkpoint.get("state_dict"), dict):
        raise CheckpointError(f"{source} has no 'state_dict' entry (expected the official {APGEM_FILE})")
    state_dict = collections.OrderedDict()
    for key, value in checkpoint["state_dict"].items():
        if not isinstance(value, torch.Tensor):
            raise CheckpointError(f"{source}: state_dict[{key!r}] is a {type(value).__name__}, not a tensor")
        # The official loader strips a leading "module." (DataParallel); so do we.
        state_dict[str(key).removeprefix("module.")] = value
    whitening = {}
    for name, pca in (checkpoint.get("pca") or {}).items():
        attributes = getattr(pca, "__dict__", pca if isinstance(pca, dict) else {})
        missing = [a for a in ("components_", "explained_variance_") if attributes.get(a) is None]
        if missing:
            raise CheckpointError(f"{source}: whitening {name!r} has no {', '.join(missing)}")
        components = _float64(attributes["components_"], "components_", source)
        mean = attributes.get("mean_")
        whitening[str(name)] = {
            # dirtorch's transform skips the centring when mean_ is None: a zero mean does the same.
            "mean": torch.zeros(components.shape[1], dtype=torch.float64) if mean is None
            else _float64(mean, "mean_", source),
            "components": components,
            "explained_variance": _float64(attributes["explained_variance_"], "explained_variance_", source),
            "whiten": bool(attributes.get("whiten", False)),
        }
    options = {str(k): _plain(v) for k, v in (checkpoint.get("model_options") or {}).items()}
    preprocess = {}
    for key in ("mean", "std"):
        values = (checkpoint.get("preprocess") or {}).get(key)
        if values is not None:
            preprocess[key] = [float(v) for v in values]
    return {"format": CONVERTED_FORMAT, "source": source.name, "state_dict": state_dict,
            "whitening": whitening, "model_options": options, "preprocess": preprocess}


def _save_atomic(content: Any, out_path: Path) -> None:
    """``torch.save`` to a temporary file next to ``out_path``, check it reads back safely, then rename."""
    from vpr_smr.core.io import atomic_path

    with atomic_path(out_path) as temporary:
        torch.save(content, temporary)
        torch.load(temporary, map_location="cpu", weights_only=True)  # the promise of the conversion


def convert_apgem(in_path: Path | str, out_path: Path | str) -> Path:
    """Convert the official ``Resnet-101-AP-GeM.pt`` into a file the ``apgem`` backend loads.

    The output is ``{"format", "source", "state_dict", "whitening": {name: {"mean", "components",
    "explained_variance", "whiten"}}, "model_options", "preprocess"}`` of tensors and plain values only.
    """
    in_path, out_path = Path(in_path), Path(out_path)
    if in_path.resolve() == out_path.resolve():
        raise CheckpointError(f"convert_apgem: the output {out_path} must differ from the input")
    _save_atomic(apgem_tensors(read_restricted(in_path), in_path), out_path)
    return out_path


# Method name -> converter, for the command line (``vpr-smr convert-checkpoint``).
CONVERTERS: dict[str, Callable[[Path | str, Path | str], Path]] = {"apgem": convert_apgem}


def no_conversion(method: str) -> str:
    """Why ``vpr-smr convert-checkpoint METHOD`` has nothing to do for a method without a converter, and which
    file its backend loads as it is."""
    from vpr_smr.descriptors import backend_class

    available = f"conversions exist for {', '.join(CONVERTERS)} only"
    try:
        cls = backend_class(method)
    except ValueError as error:
        return f"no conversion for {method!r}: {error}; {available}"
    if not cls.needs_checkpoint:
        return f"no conversion for {method!r}: backend {method!r} takes no checkpoint file; {available}"
    expected = "its checkpoint file"  # for a backend that needs settings, or a plugin without expected_file
    try:
        with torch.device("meta"):  # shapes only: the model costs nothing to build
            backend = cls()
            if hasattr(backend, "expected_file"):  # TorchBackend's method; a plugin's Backend may lack it
                expected = backend.expected_file()
    except (ValueError, AttributeError):
        pass
    return (f"no conversion for {method!r}: backend {method!r} loads its file as it is, tensors only (torch.load "
            f"with weights_only=True, or safetensors) (expected: {expected}); check yours with "
            f"`vpr-smr checkpoint check {method} FILE`; {available}")
