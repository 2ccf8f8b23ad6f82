"""The test-only plugin matcher ``toy`` (tests/plugins, see its README): where its site folder is, and how a test or
a process it starts sees it."""

from __future__ import annotations

import os
from pathlib import Path

# an installed package's site folder: the module and its dist-info (entry point group vpr_smr.matchers)
PLUGIN_SITE = Path(__file__).resolve().parent / "plugins" / "vpr_smr_toy_matcher"


def plugin_env() -> dict[str, str]:
    """This process's environment with the plugin's site folder first on ``PYTHONPATH``: a process started with it
    (the workflow, and Snakemake's jobs, which inherit it) finds ``toy`` through ``importlib.metadata``."""
    rest = os.environ.get("PYTHONPATH")
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(PLUGIN_SITE), *([rest] if rest else [])])}
