"""The test-only plugin matcher ``toy`` (tests/plugins, see its README): where its site folder is, and how a test or
a process it starts sees it."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

# an installed package's site folder: the module and its dist-info (entry point group vpr_smr.matchers)
PLUGIN_SITE = Path(__file__).resolve().parent / "plugins" / "vpr_smr_toy_matcher"


def plugin_env() -> dict[str, str]:
    """This process's environment with the plugin's site folder first on ``PYTHONPATH``: a process started with it
    (the workflow, and Snakemake's jobs, which inherit it) finds ``toy`` through ``importlib.metadata``."""
    rest = os.environ.get("PYTHONPATH")
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(PLUGIN_SITE), *([rest] if rest else [])])}


def toy_rule(d: np.ndarray, decay: float, step: int) -> tuple[list[list[float]], list[int], list[float]]:
    """The toy matcher's rule (its module's text) written out with loops: per query of ``d`` (references x
    queries; every query), its scores, match (lowest score, then lowest reference) and margin."""
    n_refs, n_queries = d.shape
    scores: list[list[float]] = []
    for a in range(n_queries):
        row = []
        for r in range(n_refs):
            value = float(d[r, a])
            if a > 0:
                value += decay * scores[a - 1][max(r - step, 0)]
            row.append(value)
        scores.append(row)
    matches = [min(range(n_refs), key=lambda r, row=row: (row[r], r)) for row in scores]
    margins = [sorted(row)[1] - sorted(row)[0] for row in scores]
    return scores, matches, margins
