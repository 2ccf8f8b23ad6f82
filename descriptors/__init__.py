"""Descriptor backends, selected by name.

Built-in backends are registered in ``BACKENDS`` (a ``core.registry.Registry``). Third-party backends register
through the entry point group ``vpr_smr.descriptors`` (``name = "package.module:Class"``) or are named in the
configuration by a dotted path ``package.module:Class``.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from vpr_smr.core.registry import Registry

if TYPE_CHECKING:
    from vpr_smr.descriptors.base import Backend


ENTRY_POINT_GROUP = "vpr_smr.descriptors"


def _backend(name: str, cls: Any) -> type[Backend]:
    """``cls`` if it is a ``Backend`` subclass; ValueError otherwise."""
    from vpr_smr.descriptors.base import Backend

    if not (isinstance(cls, type) and issubclass(cls, Backend)):
        raise ValueError(f"{name!r} is not a subclass of vpr_smr.descriptors.Backend")
    return cls


# Imported on first use, so that a backend's imports cost nothing until used.
BACKENDS: Registry[type[Backend]] = Registry("descriptor backend", ENTRY_POINT_GROUP, _backend, package=__name__)
BACKENDS.add_lazy("sad", ".sad:SAD")
BACKENDS.add_lazy("hog", ".hog:HOG")
BACKENDS.add_lazy("efficientnet_lite0_gem", ".efficientnet_lite:EfficientNetLite0GeM")
BACKENDS.add_lazy("netvlad", ".netvlad:NetVLAD")
BACKENDS.add_lazy("apgem", ".apgem:APGeM")
BACKENDS.add_lazy("cosplace", ".cosplace:CosPlace")
BACKENDS.add_lazy("eigenplaces", ".cosplace:EigenPlaces")
BACKENDS.add_lazy("mixvpr", ".mixvpr:MixVPR")
BACKENDS.add_lazy("salad", ".salad:SALAD")
BACKENDS.add_lazy("boq", ".boq:BoQ")
BACKENDS.add_lazy("megaloc", ".megaloc:MegaLoc")
BACKENDS.add_lazy("precomputed", ".precomputed:Precomputed")

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


def available_backends() -> list[str]:
    """The built-in backends and those installed packages register, sorted."""
    return sorted(BACKENDS.names())


def backend_class(name: str) -> type[Backend]:
    """Resolve a backend by built-in name, entry point name, or dotted path ``package.module:Class``."""
    if name in BACKENDS or ":" not in name:
        try:
            return BACKENDS.get(name)
        except ValueError as error:
            if name in BACKENDS:
                raise  # a plugin that is no backend
            raise ValueError(f"{error}, or a dotted path package.module:Class (`vpr-smr backends` lists each with "
                             "its settings)") from None
    module_name, _, class_name = name.partition(":")
    try:
        cls = getattr(importlib.import_module(module_name), class_name)
    except (ImportError, AttributeError) as error:
        raise ValueError(f"cannot import descriptor backend {name!r}: {error}") from None
    return _backend(name, cls)
