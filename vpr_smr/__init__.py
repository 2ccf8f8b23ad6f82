"""vpr-smr: sequence-matching receptiveness (SMR) for visual place recognition, an offline benchmark pipeline.

``vpr_smr.__version__`` is the installed version; ``vpr_smr.api`` is the Python API for notebooks
(``from vpr_smr import api as smr``) and ``vpr_smr.records`` the records its functions return. The stages live in
``vpr_smr.core``, ``datasets``, ``descriptors``, ``eval`` and ``pipeline`` (the ``vpr-smr`` command line).

``__version__``, ``api`` and ``records`` are looked up on first use (PEP 562): every import of a stage's module runs
this file first, and the command line and the workflow's jobs should not pay for the API or the metadata lookup.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from vpr_smr import api as api
    from vpr_smr import records as records

__all__ = ["__version__", "api", "records"]

__version__: str  # set on first use, below


def __getattr__(name: str) -> Any:
    if name == "__version__":
        from importlib.metadata import PackageNotFoundError, version

        try:
            found = version("vpr-smr")  # the package metadata's, as `vpr-smr --version` prints it
        except PackageNotFoundError:  # the checkout on sys.path without an install (pip install -e . gives one)
            found = "unknown"
        globals()["__version__"] = found
        return found
    if name in ("api", "records"):
        return importlib.import_module(f"{__name__}.{name}")  # which binds it here too
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
