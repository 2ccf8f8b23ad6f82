"""Train one predictor per dataset and sequence length on the train split of every method, pooled (SPEC 7)."""

from __future__ import annotations

import logging
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .io import read_features, write_json
from .predictor import SMRPredictor, cross_validated_f1, macro_f1

log = logging.getLogger(__name__)


def pooled(paths: Sequence[Path | str]) -> tuple[np.ndarray, np.ndarray]:
    """Rank-0 attributes and labels of several feature files, stacked."""
    features = [read_features(p) for p in paths]
    return (np.concatenate([f.attributes[:, 0, :] for f in features]),
            np.concatenate([f.labels for f in features]))


def main(
    train: Sequence[Path | str],
    out: Path | str,
    params: dict[str, Any] | None = None,
    val: Sequence[Path | str] = (),
    test: Sequence[Path | str] = (),
    meta: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """Fit on ``train``, report cross-validated, validation and test macro F1; write ``out`` (.h5) and .json."""
    params = dict(params or {})
    if "hidden_layer_sizes" in params:
        params["hidden_layer_sizes"] = tuple(params["hidden_layer_sizes"])
    x_train, y_train = pooled(train)
    predictor = SMRPredictor(**params)
    log.info("training on %d samples, class counts %s", len(y_train), np.bincount(y_train, minlength=4))
    report: dict[str, Any] = {
        "meta": dict(meta or {}),
        "params": predictor.get_params(),
        "n_train": int(len(y_train)),
        "train_class_counts": np.bincount(y_train, minlength=4).tolist(),
        "f1_cv": cross_validated_f1(predictor, x_train, y_train),
    }
    predictor.fit(x_train, y_train)
    for name, paths in (("val", val), ("test", test)):
        if paths:
            x, y = pooled(paths)
            report[f"f1_{name}"] = macro_f1(y, predictor.predict(x))
            report[f"n_{name}"] = int(len(y))
    report["n_iter"] = predictor.n_iter_
    out = Path(out)
    predictor.save(out, report=report)
    write_json(out.with_suffix(".json"), report)
    return report
