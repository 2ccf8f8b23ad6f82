"""vpr-smr: sequence-matching receptiveness (SMR) for visual place recognition, an offline benchmark pipeline.

``vpr_smr.__version__`` is the installed version; ``vpr_smr.api`` is the Python API for notebooks
(``from vpr_smr import api as smr``) and ``vpr_smr.records`` the records its functions return. The stages live in
``vpr_smr.core``, ``datasets``, ``descriptors``, ``eval`` and ``pipeline`` (the ``vpr-smr`` command line).

``api`` and ``records`` are imported on first use (PEP 562), so that the command line and the workflow's jobs, which
import a stage, do not load the whole API.
"""

from __future__ import annotations

import importlib
from importlib.metadata import PackageNotFoundError, version
from types import ModuleType
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from vpr_smr import api as api
    from vpr_smr import records as records

__all__ = ["__version__", "api", "records"]

try:
    __version__ = version("vpr-smr")  # the package metadata's, as `vpr-smr --version` prints it
except PackageNotFoundError:  # the checkout on sys.path without an install (pip install -e . gives one)
    __version__ = "unknown"

_LAZY = ("api", "records")


def __getattr__(name: str) -> ModuleType:
    if name in _LAZY:
        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})
