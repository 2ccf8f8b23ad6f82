"""Predictor ablations: each attribute alone (the paper's Table II) and leave-one-method-out generalisation.

Attribute ablation: a predictor trained on one attribute alone (``SMRPredictor(column_order=(k,))``, ``k = 0..3``
for A1..A4, the paper's names) and on all four (the default column order, the authors' recipe), each reported by
its macro F1 of cross-validation (SMOTE inside the folds), on the validation split and on the last evaluation
split (the configuration's names of them; ``records.AttributeScores`` keeps them as ``val`` and ``test``).

Leave-one-method-out (not in the paper): per dataset, for each method, a predictor trained on the train splits of
the other methods only, named ``without_<method>``, evaluated on the held-out method's table split beside the
pooled predictor (which saw that method's train split). Each function takes explicit paths so that a Snakemake rule
can call it; nothing here knows the workflow.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from vpr_smr.core.io import JSON_SUFFIXES, check_suffix
from vpr_smr.core.records import save
from vpr_smr.eval.matching.attributes import ATTRIBUTE_NAMES, common_matching, read_features
from vpr_smr.eval.predictor.estimator import SMRPredictor, check_training_labels, cross_validated_f1, macro_f1
from vpr_smr.eval.predictor.leakage import check_disjoint, frame_ranges
from vpr_smr.eval.predictor.records import AttributeAblation, AttributeScores, PredictorReport
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
    val: Sequence[tuple[np.ndarray, np.ndarray]] = (),
    test: Sequence[tuple[np.ndarray, np.ndarray]] = (),
    params: dict[str, Any] | None = None,
) -> dict[str, AttributeScores]:
    """Macro F1 of a predictor per attribute set (A1, A2, A3, A4 alone, then all four).

    ``train`` is ``(X, y)`` with ``X`` in A1..A4 order; ``val`` and ``test`` are lists of ``(X, y)``, one per
    method: ``f1_val``/``f1_test`` are the macro F1 on them pooled, ``f1_test_method_mean`` the mean of the
    per-method test F1 (the paper's Table II averages over methods).
    """
    x_train, y_train = train
    out = {}
    for name, columns in ATTRIBUTE_SETS.items():
        predictor = _predictor(params, columns)
        f1_cv = cross_validated_f1(predictor, x_train, y_train)
        predictor.fit(x_train, y_train)
        scored: dict[str, Any] = {}
        for split, parts in (("val", val), ("test", test)):
            if parts:
                x, y = _stack(list(parts))
                scored[f"f1_{split}"] = macro_f1(y, predictor.predict(x))
                scored[f"n_{split}"] = int(len(y))
        if test:
            scored["f1_test_method_mean"] = float(np.mean([macro_f1(y, predictor.predict(x)) for x, y in test]))
        scores = AttributeScores(tuple(columns) if columns else None, f1_cv, **scored)
        log.info("attributes %s: %s", name, scores)
        out[name] = scores
    return out


def table_roles(evaluate: Mapping[str, Sequence[Path | str]]
                ) -> tuple[Sequence[Path | str], Sequence[Path | str]]:
    """The files of Table II's two splits among ``evaluate`` (split name -> files, in the configuration's order):
    the validation split (the first) and the last, or the one split given as the last; more than two splits is an
    error (Table II shows two: ``predictor.defaults.ablation_splits``)."""
    given = [paths for paths in evaluate.values() if paths]
    if len(given) > 2:
        raise ValueError(f"the attribute ablation scores two splits (the validation split and the last); got "
                         f"{len(given)}: {', '.join(map(repr, evaluate))}")
    if not given:
        return (), ()
    return (given[0] if len(given) == 2 else ()), given[-1]


def attributes_main(
    train: Sequence[Path | str],
    out: Path | str,
    params: dict[str, Any] | None = None,
    evaluate: Mapping[str, Sequence[Path | str]] | None = None,
    meta: dict[str, Any] | None = None,
    allow_split_overlap: bool = False,
) -> AttributeAblation:
    """Table II for one dataset and sequence length: write ``out`` (JSON) with the F1 of every attribute set.

    ``train``: features files (one per method, the configuration's order) of the train split; ``evaluate``: the
    validation split and the last evaluation split by their names (the configuration's), in that order, each its
    files of every method (``table_roles``). Layout: ``{"meta", "params", "n_train", "attributes": {"A1":
    {"columns", "f1_cv", "f1_val", "f1_test", "f1_test_method_mean", "n_val", "n_test"}, ..., "all": {...}}}``
    (``records.AttributeAblation``, returned), where ``val`` is the first split given and ``test`` the last,
    whatever their names.
    """
    check_suffix(out, JSON_SUFFIXES, "the attribute ablation (JSON)")
    val, test = table_roles(evaluate or {})
    check_disjoint(frame_ranges(train), frame_ranges([*val, *test]), allow_split_overlap,
                   "the per-attribute predictors")
    common_matching([*train, *val, *test])  # one matcher's labels, as the pooled predictor's
    x_train, y_train = _stack(_features(train))
    # attribute_f1 trains on the labels in this order (no shuffle): check them as they are, before any training
    check_training_labels(y_train, describe(meta, len(train)), bool(dict(params or {}).get("smote", True)))
    result = AttributeAblation(dict(meta or {}), dict(params or {}), int(len(y_train)),
                               attribute_f1((x_train, y_train), _features(val), _features(test), params))
    save(out, result)
    return result


def train_without(
    train: Mapping[str, Path | str],
    held_out: str,
    out: Path | str,
    params: dict[str, Any] | None = None,
    evaluate: Mapping[str, Mapping[str, Path | str]] | None = None,
    meta: dict[str, Any] | None = None,
    allow_split_overlap: bool = False,
    validation: str | None = None,
) -> PredictorReport:
    """Train the ``without_<held_out>`` predictor on the train splits of every method but ``held_out``.

    ``train`` maps method -> features file of the train split, in the configuration's order (the pooled order is
    part of the recipe); ``evaluate`` maps each evaluation split's name (the configuration's; the workflow gives
    the validation split) to such a mapping. The held-out method's files, if given, are never opened (the workflow
    does not give them, so that they are not inputs of this predictor). Writes ``out`` (.h5) and its JSON report
    through ``train.main`` (seed 0, ``validation`` its validation split), with ``held_out`` and ``trained_on`` in
    its ``meta``.
    """
    from vpr_smr.eval.predictor import train as train_stage

    others = [method for method in train if method != held_out]
    if not others:
        raise ValueError(f"leave-one-method-out needs at least two methods; only {held_out!r} is configured")
    meta = {**(meta or {}), "held_out": held_out, "trained_on": others}
    scored = {split: [files[m] for m in others if m in files] for split, files in (evaluate or {}).items()}
    return train_stage.main([train[m] for m in others], out, params, evaluate=scored, meta=meta,
                            allow_split_overlap=allow_split_overlap, validation=validation)
