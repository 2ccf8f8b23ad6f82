"""Predictor ablations: each attribute alone (the paper's Table II) and leave-one-method-out generalisation.

Attribute ablation: a predictor trained on one attribute alone (``SMRPredictor(column_order=(k,))``, ``k = 0..3``
for A1..A4, the paper's names) and on all four (the default column order, the authors' recipe), each reported by
its macro F1 of cross-validation (SMOTE inside the folds) and on each evaluation split it is given, by the split's
name (the workflow gives the validation split and the last evaluation split: ``defaults.ablation_splits``).

Leave-one-method-out (not in the paper): per dataset, for each method, a predictor trained on the train splits of
the other methods only, named ``without_<method>``, evaluated on the held-out method's table split beside the
pooled predictor (which saw that method's train split). Each stage takes its job record (``AttributeAblationJob``,
``WithoutJob``) of explicit paths, which a Snakemake rule gives; nothing here knows the workflow.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from vpr_smr.core.io import HDF5_SUFFIXES, JSON_SUFFIXES, check_suffix
from vpr_smr.core.records import save
from vpr_smr.eval.matching.attributes import (
    ATTRIBUTE_NAMES,
    check_seq_len,
    common_matching,
    read_features,
    recorded_matching,
)
from vpr_smr.eval.predictor.estimator import SMRPredictor, check_training_labels, cross_validated_f1, macro_f1
from vpr_smr.eval.predictor.jobs import AttributeAblationJob, TrainJob, WithoutJob
from vpr_smr.eval.predictor.leakage import check_disjoint, frame_ranges
from vpr_smr.eval.predictor.records import AttributeAblation, AttributeScores, AttributeSplit, PredictorReport
from vpr_smr.eval.predictor.train import describe

log = logging.getLogger(__name__)

ALL_ATTRIBUTES = "all"
# name -> columns of the A1..A4 input the predictor uses (None: all four, in the predictor's default order)
ATTRIBUTE_SETS: dict[str, tuple[int, ...] | None] = {
    **{name: (k,) for k, name in enumerate(ATTRIBUTE_NAMES)}, ALL_ATTRIBUTES: None,
}


def _predictor(params: dict[str, Any] | None, columns: tuple[int, ...] | None) -> SMRPredictor:
    params = dict(params or {})
    if "hidden_layer_sizes" in params:
        params["hidden_layer_sizes"] = tuple(params["hidden_layer_sizes"])
    if columns is not None:
        params["column_order"] = tuple(columns)
    return SMRPredictor(**params)


def _features(paths: Sequence[Path | str]) -> list[tuple[np.ndarray, np.ndarray]]:
    """Rank-0 attributes (A1..A4) and labels of each file."""
    out = []
    for path in paths:
        if not Path(path).is_file():
            raise FileNotFoundError(f"features file not found: {path} (run vpr-smr attributes)")
        features = read_features(path)
        out.append((features.attributes[:, 0, :], features.labels))
    return out


def _stack(parts: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    return np.concatenate([x for x, _ in parts]), np.concatenate([y for _, y in parts])


def attribute_f1(
    train: tuple[np.ndarray, np.ndarray],
    evaluate: Mapping[str, Sequence[tuple[np.ndarray, np.ndarray]]] | None = None,
    params: dict[str, Any] | None = None,
) -> dict[str, AttributeScores]:
    """Macro F1 of a predictor per attribute set (A1, A2, A3, A4 alone, then all four).

    ``train`` is ``(X, y)`` with ``X`` in A1..A4 order; ``evaluate`` maps each evaluation split's name to a list of
    ``(X, y)``, one per method: per split the macro F1 on them pooled, and the mean of the per-method F1 (the
    paper's Table II averages over methods).
    """
    x_train, y_train = train
    given = {name: list(parts) for name, parts in (evaluate or {}).items() if parts}
    out = {}
    for name, columns in ATTRIBUTE_SETS.items():
        predictor = _predictor(params, columns)
        f1_cv = cross_validated_f1(predictor, x_train, y_train)
        predictor.fit(x_train, y_train)
        splits = {}
        for split, parts in given.items():
            x, y = _stack(parts)
            splits[split] = AttributeSplit(
                macro_f1(y, predictor.predict(x)), int(len(y)),
                float(np.mean([macro_f1(y_m, predictor.predict(x_m)) for x_m, y_m in parts])))
        scores = AttributeScores(tuple(columns) if columns else None, f1_cv, splits)
        log.info("attributes %s: %s", name, scores)
        out[name] = scores
    return out


def attributes_main(job: AttributeAblationJob) -> AttributeAblation:
    """Table II for one dataset and sequence length: write ``job.out`` (JSON) with the F1 of every attribute set.

    ``job.train``: features files (one per method, the configuration's order) of the train split;
    ``job.evaluate``: each evaluation split's files of every method, by the split's name (the configuration's; the
    workflow gives the validation split and the last: ``defaults.ablation_splits``). Layout: ``{"meta", "params",
    "n_train", "attributes": {"A1": {"columns", "f1_cv", "splits": {SPLIT: {"f1", "n", "f1_method_mean"}, ...}},
    ..., "all": {...}}}`` (``records.AttributeAblation``, returned). The attributes files must be of
    ``job.seq_len``.
    """
    check_suffix(job.out, JSON_SUFFIXES, "the attribute ablation (JSON)")
    train, evaluate = list(job.train), {name: list(paths) for name, paths in (job.evaluate or {}).items()}
    scored = [path for paths in evaluate.values() for path in paths]
    check_seq_len([*train, *scored], job.seq_len)
    check_disjoint(frame_ranges(train), frame_ranges(scored), job.allow_split_overlap, "the per-attribute predictors")
    common_matching([*train, *scored])  # one matcher's labels, as the pooled predictor's
    x_train, y_train = _stack(_features(train))
    meta = {"dataset": job.dataset, "seq_len": job.seq_len}
    params = job.predictor.values
    # attribute_f1 trains on the labels in this order (no shuffle): check them as they are, before any training
    check_training_labels(y_train, describe(meta, len(train)), bool(params.get("smote", True)))
    result = AttributeAblation({**recorded_matching(train), **meta}, params, int(len(y_train)),
                               attribute_f1((x_train, y_train), {name: _features(paths) for name, paths
                                                                 in evaluate.items()}, params))
    save(job.out, result)
    return result


def train_without(job: WithoutJob) -> PredictorReport:
    """Train the ``without_<method>`` predictor on the train splits of every method but ``job.method``.

    ``job.train`` maps method -> features file of the train split, in the configuration's order (the pooled order
    is part of the recipe); ``job.evaluate`` gives each evaluation split's name (the configuration's; the workflow
    gives the validation split) with such files. The held-out method's files, if given, are never opened (the
    workflow does not give them, so that they are not inputs of this predictor). Writes ``job.out`` (.h5) and its
    JSON report through ``train.fit`` (seed 0, ``training.validation`` its validation split, not cross-validated:
    the leave-one-out table compares the two predictors on the held-out method's split alone), with ``held_out`` and
    ``trained_on`` in its ``meta``.
    """
    from vpr_smr.eval.predictor import train as train_stage

    check_suffix(job.out, HDF5_SUFFIXES, "the predictor (HDF5; its report goes beside it as .json)")
    held_out = job.method
    others = [method for method in job.train if method != held_out]
    if not others:
        raise ValueError(f"leave-one-method-out needs at least two methods; only {held_out!r} is configured")
    scored = {split: tuple(files[m] for m in others if m in files) for split, files in job.splits.items()}
    check_seq_len([*(job.train[m] for m in others), *(path for paths in scored.values() for path in paths)],
                  job.seq_len)
    pooled = TrainJob(job.dataset, job.seq_len, tuple(job.train[m] for m in others), scored,
                                  job.training, seeds=1, out=job.out)
    return train_stage.fit(pooled, {"held_out": held_out, "trained_on": others}, cross_validate=False)
