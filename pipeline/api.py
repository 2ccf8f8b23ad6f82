"""Moved: the Python API is ``vpr_smr.api`` (``from vpr_smr import api as smr``) since 0.16.

This module re-exports it and warns once (``DeprecationWarning``), so that notebooks of 0.15 still run; by the version
policy at the top of the CHANGELOG it may go in the minor release after the one that moved it.
"""

from __future__ import annotations

import warnings

from vpr_smr.api import *  # noqa: F403  (the same names, the same functions)
from vpr_smr.api import __all__ as __all__

# stacklevel 2: the line that imported this module (warnings skips the import machinery's frames), so that Python's
# default filters show it in a notebook or script and name that line
warnings.warn("vpr_smr.pipeline.api moved to vpr_smr.api: write `from vpr_smr import api as smr` (the same "
              "functions); the old import goes in a later release", DeprecationWarning, stacklevel=2)
