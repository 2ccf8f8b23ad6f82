"""The README's adaptive sequence length commands, run as written on a user's own matrices (SAD distances of real
frames of the shipped Nordland sample, one matrix per split), and the result checked against a naive loop over the
files they wrote."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
from helpers import doc_block
from sample_matrix import sample_distances

from vpr_smr.core.constants import KEPT_CLASSES
from vpr_smr.eval.matching.attributes import read_features
from vpr_smr.eval.predictor.estimator import SMRPredictor


def test_readme_commands_run_as_written_and_choose_as_a_naive_loop(tmp_path: Path):
    for split, (first, count) in {"train": (600, 120), "val": (720, 80), "test": (800, 80)}.items():
        np.save(tmp_path / f"{split}.npy", sample_distances(first, count))
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"}
    done = subprocess.run(["bash", "-e", "-c", doc_block("adaptive-commands")], cwd=tmp_path, env=env,
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    for name in ("L2+pred", "L4+pred", "adaptive", "adaptive_fallback", "adaptive_uniqueness"):
        assert name in done.stdout
    result = json.loads((tmp_path / "adaptive.json").read_text())
    timing = json.loads((tmp_path / "adaptive.timing.json").read_text())
    assert timing["n_queries"] == 77 and timing["seconds_adaptive"] > 0  # test queries 3..79 (L 4)
    # the naive loop: per test query a >= 3, L2's predictor first, then L4's; none keeps it: removed
    features = {n: read_features(tmp_path / f"L{n}" / "test.h5") for n in (2, 4)}
    predictors = {n: SMRPredictor.load(tmp_path / f"L{n}.h5") for n in (2, 4)}
    used, removed = [], 0
    for a in range(3, 80):
        for n in (2, 4):
            row = int(np.flatnonzero(features[n].queries == a)[0])
            if int(predictors[n].predict(features[n].attributes[row : row + 1, 0, :])[0]) in KEPT_CLASSES:
                used.append(n)
                break
        else:
            used.append(4)
            removed += 1
    adaptive = next(row for row in result["rows"] if row["name"] == "adaptive")
    assert adaptive["removed"] == removed
    assert adaptive["mean_length"] == np.mean(used)
    assert result["n_queries"] == 77 and result["lengths"] == [2, 4]
