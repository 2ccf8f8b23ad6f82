"""Descriptor backends, selected by name.

Built-in backends are listed in ``BACKENDS``. Third-party backends register through the entry point group
``vpr_smr.descriptors`` (``name = "package.module:Class"``) or are named in the configuration by a dotted
path ``package.module:Class``.
"""

from __future__ import annotations

import importlib
from importlib.metadata import entry_points
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from vpr_smr.descriptors.base import Backend


ENTRY_POINT_GROUP = "vpr_smr.descriptors"

# name -> "module:Class" within this package; imported lazily so that a backend's imports cost nothing until used.
BACKENDS: dict[str, str] = {
    "sad": "sad:SAD",
    "hog": "hog:HOG",
    "efficientnet_lite0_gem": "efficientnet_lite:EfficientNetLite0GeM",
    "netvlad": "netvlad:NetVLAD",
    "apgem": "apgem:APGeM",
    "cosplace": "cosplace:CosPlace",
    "eigenplaces": "cosplace:EigenPlaces",
    "mixvpr": "mixvpr:MixVPR",
    "salad": "salad:SALAD",
    "boq": "boq:BoQ",
    "megaloc": "megaloc:MegaLoc",
    "precomputed": "precomputed:Precomputed",
}

# A method's settings that do not change its descriptors: the distance reaches only its distance matrices.
DISTANCE_SETTING = "distance"

# The revision of what a built-in backend computes, where it is not 1: a param of every descriptors job, so that a
# backend whose numbers change in a release computes its descriptors again (and everything below them), and only
# that backend's. 2: sad and hog by exact NumPy rules, the same bytes on every CPU (method §2.3; 0.10.0).
REVISIONS: dict[str, int] = {"sad": 2, "hog": 2}

__all__ = [
    "BACKENDS", "Backend", "CheckpointError", "TorchBackend", "available_backends", "backend_class",
    "descriptor_revision", "descriptor_settings",
]


def descriptor_settings(method: dict[str, Any]) -> dict[str, Any]:
    """A method's settings without those that do not change its descriptors (what the descriptors job gets)."""
    return {key: value for key, value in method.items() if key != DISTANCE_SETTING}


def descriptor_revision(backend: str) -> int:
    """The revision of what ``backend`` computes (``REVISIONS``; 1 for any other, a plugin's included)."""
    return REVISIONS.get(backend, 1)


def __getattr__(name: str) -> Any:
    # The base classes import PyTorch: loaded on first use, so that the workflow's parsing (which only needs
    # ``descriptor_settings``) does not pay for it.
    if name in ("Backend", "CheckpointError", "TorchBackend"):
        from vpr_smr.descriptors import base

        return getattr(base, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _import(target: str, package: str | None = None) -> type[Backend]:
    module_name, _, class_name = target.partition(":")
    module = importlib.import_module(module_name, package)
    cls: type[Backend] = getattr(module, class_name)  # backend_class checks what a dotted path names
    return cls


def available_backends() -> list[str]:
    names = set(BACKENDS) | {ep.name for ep in entry_points(group=ENTRY_POINT_GROUP)}
    return sorted(names)


def backend_class(name: str) -> type[Backend]:
    """Resolve a backend by built-in name, entry point name, or dotted path ``package.module:Class``."""
    if name in BACKENDS:
        return _import("." + BACKENDS[name], __name__)
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        if ep.name == name:
            loaded: type[Backend] = ep.load()
            return loaded
    if ":" in name:
        try:
            cls = _import(name)
        except (ImportError, AttributeError) as error:
            raise ValueError(f"cannot import descriptor backend {name!r}: {error}") from None
        from vpr_smr.descriptors.base import Backend

        if not (isinstance(cls, type) and issubclass(cls, Backend)):
            raise ValueError(f"{name!r} is not a subclass of vpr_smr.descriptors.Backend")
        return cls
    raise ValueError(
        f"unknown descriptor backend {name!r}; available: {', '.join(available_backends())}, "
        "or a dotted path package.module:Class (`vpr-smr backends` lists each with its settings)"
    )
