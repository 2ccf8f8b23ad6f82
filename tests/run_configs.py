"""Configurations of small runs that a workflow test runs and a unit test checks (the plan-once and the split
names' tests)."""

from __future__ import annotations

from pathlib import Path

from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT


def plan_once_config(root: Path) -> dict:
    """Two methods on 60 frames of the sample at ``root`` (the plan-once tests)."""
    return {"run": "r", "seq_lens": [3], "datasets": {"sample": {
        "loader": "nordland_sample", "root": str(root), "frames": [1000, 1060],
        "splits": {"train": [0, 30], "val": [30, 40], "test": [40, 60]}}},
        "methods": {"sad": {"backend": "sad"}, "hog": {"backend": "hog", "distance": "cosine"}},
        # the matchers experiment off: openseqslam's ratio window needs 14 references of a split, val has 10
        "experiments": {"matchers": False}}


# --- the splits named by the user ---

RENAMED = {"train": "fit", "val": "check", "test": "final"}
FRAMES = (1000, 1240)  # 240 frames of the sample: the three splits below
RANGES = {"train": [0, 100], "val": [100, 170], "test": [170, 240]}


def split_names_config(out: Path, names: dict[str, str]) -> dict:
    """Two methods, two sequence lengths and every experiment but matchers on 240 frames of the sample, its splits
    named ``names[role]`` (the split names' tests)."""
    return {
        "run": "names", "output": str(out), "seq_lens": [3, 4], "table_seq_len": 4, "seeds": 2,
        "trust_levels": [0.5],
        "train_split": names["train"], "eval_splits": [names["val"], names["test"]], "table_split": names["test"],
        "datasets": {"sample": {"loader": "nordland_sample", "root": str(DEFAULT_ROOT), "frames": list(FRAMES),
                                "splits": {names[role]: frames for role, frames in RANGES.items()}}},
        "methods": {"sad": {"backend": "sad"}, "hog": {"backend": "hog"}},
        "predictor": {"max_iter": 200},
        "speed": {"profiles": [2.0]},
        "experiments": {"matchers": False},  # tests/workflow/test_plugin_matcher_workflow.py runs it
    }
