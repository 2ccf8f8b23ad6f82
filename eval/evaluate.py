"""Evaluation of one method on one dataset: match removal by the predictor, PR curves, AOC, F1 (SPEC 7-8)."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
from sklearn.metrics import confusion_matrix

from .attributes import QueryFeatures
from .io import read_features, read_provenance, write_json
from .metrics import MODES, Curve, compare_curves, curve, keep_mask, recall_at_full_precision
from .predictor import SMRPredictor, macro_f1

LABELS = (0, 1, 2, 3)
DEFAULT_TRUST_LEVELS = (0.0, 0.5, 0.7, 0.9, 1.0)


def evaluate_split(
    features: QueryFeatures,
    predictor: SMRPredictor,
    modes: tuple[str, ...] = MODES,
    trust_levels: tuple[float, ...] = DEFAULT_TRUST_LEVELS,
) -> dict[str, Any]:
    """Numbers and curves of one split: baseline (VPR+SM) against match removal by the predictor (+Pred)."""
    start = time.perf_counter()
    probabilities = predictor.predict_proba(features.attributes[:, 0, :])
    predict_seconds = time.perf_counter() - start
    predicted = predictor.classes_[np.argmax(probabilities, axis=1)]
    confidence = probabilities.max(axis=1)
    n = len(features.queries)
    distances, correct = features.sequence_distance, features.sequence_correct
    s_range = (features.sequence_min, features.sequence_max)
    baseline_keep = keep_mask(n=n)
    predictor_keep = keep_mask(predicted, confidence)
    result: dict[str, Any] = {
        "n_queries": n,
        "recall_at_1_single": float(features.single_correct.mean()),
        "recall_at_1_sequence": float(features.sequence_correct.mean()),
        "f1_macro": macro_f1(features.labels, predicted),
        "confusion_matrix": confusion_matrix(features.labels, predicted, labels=LABELS).tolist(),
        "class_counts": np.bincount(features.labels, minlength=4).tolist(),
        "predicted_counts": np.bincount(predicted, minlength=4).tolist(),
        "removed": int((~predictor_keep).sum()),
        "predict_seconds": predict_seconds,
        "modes": {},
    }
    for mode in modes:
        baseline = curve(mode, distances, correct, baseline_keep, *s_range)
        with_predictor = curve(mode, distances, correct, predictor_keep, *s_range)
        comparison = compare_curves(baseline, with_predictor)
        result["modes"][mode] = {
            "max_recall": comparison.max_recall,
            "auc_vpr_sm": comparison.auc_baseline,
            "auc_vpr_sm_pred": comparison.auc_predictor,
            "aoc_vpr_sm": comparison.aoc_baseline,
            "aoc_vpr_sm_pred": comparison.aoc_predictor,
            "reduction_pct": comparison.reduction_pct,
            "recall_at_100_precision_vpr_sm": recall_at_full_precision(baseline),
            "recall_at_100_precision_vpr_sm_pred": recall_at_full_precision(with_predictor),
            "curve_vpr_sm": _curve_dict(baseline),
            "curve_vpr_sm_pred": _curve_dict(with_predictor),
            "trust": {
                str(level): _curve_dict(curve(mode, distances, correct, keep_mask(predicted, confidence, level),
                                              *s_range))
                for level in trust_levels
            },
        }
    return result


def _curve_dict(curve_: Curve) -> dict[str, Any]:
    return {"recall": curve_.recall, "precision": curve_.precision}


def main(
    features_paths: dict[str, Path | str],
    predictor_path: Path | str,
    out: Path | str,
    modes: tuple[str, ...] = MODES,
    trust_levels: tuple[float, ...] = DEFAULT_TRUST_LEVELS,
    meta: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """Evaluate every split in ``features_paths`` (e.g. val and test) and write one JSON file."""
    predictor = SMRPredictor.load(predictor_path)
    result: dict[str, Any] = {"meta": dict(meta or {}), "splits": {}}
    for split, path in features_paths.items():
        features = read_features(path)
        split_result = evaluate_split(features, predictor, tuple(modes), tuple(trust_levels))
        attributes_seconds = float(read_provenance(path).get("attributes_seconds", 0.0))
        n = max(split_result["n_queries"], 1)
        split_result["seconds_per_query"] = (attributes_seconds + split_result["predict_seconds"]) / n
        result["splits"][split] = split_result
    write_json(out, result)
    return result
