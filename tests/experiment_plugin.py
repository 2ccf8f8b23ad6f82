"""The test-only plugin experiment ``recall_gain`` (tests/plugins/vpr_smr_recall_gain, see its README): where its site
folder is, and how a process started with it sees it."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

# an installed package's site folder: the module and its dist-info (entry point group vpr_smr.experiments)
PLUGIN_SITE = Path(__file__).resolve().parent / "plugins" / "vpr_smr_recall_gain"


def plugin_env() -> dict[str, str]:
    """This process's environment with the plugin's site folder first on ``PYTHONPATH``: a process started with it
    (the workflow, and Snakemake's jobs, which inherit it) finds ``recall_gain`` through ``importlib.metadata``."""
    rest = os.environ.get("PYTHONPATH")
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(PLUGIN_SITE), *([rest] if rest else [])])}


def recall_gain(single: np.ndarray, sequence: np.ndarray) -> tuple[float, float, float]:
    """The gain and its 95 % interval written out with a loop: the mean of the paired differences (sequence minus
    single, each 0 or 1) and 1.96 standard errors either side (the sample standard deviation)."""
    differences = [int(b) - int(a) for a, b in zip(single, sequence, strict=True)]
    n = len(differences)
    mean = sum(differences) / n
    variance = sum((d - mean) ** 2 for d in differences) / (n - 1)
    half = 1.959963984540054 * (variance / n) ** 0.5
    return mean, mean - half, mean + half
