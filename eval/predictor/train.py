"""Train one predictor per dataset and sequence length on the train split of every method, pooled (method §7).

The recipe of the authors' code, for seed 0: the rank-0 attributes (A1..A4 columns) and labels of the methods'
train splits, concatenated in the configuration's order, shuffled with ``sklearn.utils.shuffle(X, y,
random_state=0)``, then fitted (column order, SMOTE with ``random_state=42``, scaler, MLP with ``random_state=0``:
``SMRPredictor``). Seed ``s`` shifts the shuffle, SMOTE and MLP seeds by ``s`` together (``seeded_params``).
"""

from __future__ import annotations

import json
import logging
import time
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from sklearn.metrics import confusion_matrix
from sklearn.utils import shuffle

from vpr_smr.core import environment
from vpr_smr.core.constants import LABELS
from vpr_smr.core.io import HDF5_SUFFIXES, check_suffix, read_provenance
from vpr_smr.core.paths import predictor_report_path, seed_predictor_path
from vpr_smr.core.progress import write_progress
from vpr_smr.core.records import save
from vpr_smr.eval.matching.attributes import (
    QueryFeatures,
    check_seq_len,
    common_matching,
    read_features,
    recorded_matching,
)
from vpr_smr.eval.predictor.estimator import (
    SMRPredictor,
    check_training_labels,
    cross_validated_f1,
    fit_warning,
    macro_f1,
)
from vpr_smr.eval.predictor.jobs import TrainJob as TrainJob  # the stage's job, named here too
from vpr_smr.eval.predictor.leakage import (
    FrameRange,
    Training,
    check_disjoint,
    check_matrices,
    frame_ranges,
    matrix_overlaps,
)
from vpr_smr.eval.predictor.records import PredictorReport, SeedReport, SplitScores

log = logging.getLogger(__name__)

SEEDED = ("random_state", "smote_random_state")  # the predictor's seeds that a training seed shifts


def read_all(paths: Sequence[Path | str]) -> list[QueryFeatures]:
    """The features of several files, in the given order; errors name a missing file."""
    if not paths:
        raise ValueError("no features files given to pool (the train split or an evaluation split)")
    for path in paths:
        if not Path(path).is_file():
            raise FileNotFoundError(f"features file not found: {path} (run vpr-smr attributes)")
    return [read_features(path) for path in paths]


def pooled(paths: Sequence[Path | str]) -> tuple[np.ndarray, np.ndarray]:
    """Rank-0 attributes (A1..A4 columns) and labels of several feature files, stacked in the given order."""
    return rank0(read_all(paths))


def training_record(paths: Sequence[Path | str], features: Sequence[QueryFeatures], meta: Mapping[str, Any],
                    frames: Sequence[FrameRange]) -> Training:
    """What a predictor trained on the features files ``paths`` records (``leakage.Training``): their length (or,
    for files that record none, ``meta``'s), each file's method (its provenance's, else its name), their frame
    ranges and matrices."""
    methods = [str(read_provenance(path).get("method", Path(path).name)) for path in paths]
    training = Training.of(features, list(dict.fromkeys(methods)), frames)
    given = meta.get("seq_len")
    if given is not None and training.seq_len is not None and int(given) != training.seq_len:
        raise ValueError(f"the training attributes {', '.join(map(str, paths))} are of L = {training.seq_len}, but "
                         f"the predictor is trained for L = {given}: give the attributes of L = {given}")
    return training if training.seq_len is not None or given is None else replace(training, seq_len=int(given))


def rank0(features: Sequence[QueryFeatures]) -> tuple[np.ndarray, np.ndarray]:
    """Rank-0 attributes (A1..A4 columns) and labels of several methods' features, stacked in the given order: the
    pooled training samples of the recipe (``pooled`` reads them from files, the speed experiment computes them)."""
    return (np.concatenate([f.attributes[:, 0, :] for f in features]),
            np.concatenate([f.labels for f in features]))


def seeded_params(params: dict[str, Any] | None, seed: int) -> dict[str, Any]:
    """``params`` with the MLP and SMOTE seeds (given, or the predictor's defaults 0 and 42) shifted by ``seed``.

    Seed 0 returns them unchanged: the authors' recipe.
    """
    params = dict(params or {})
    defaults = SMRPredictor().get_params()
    for key in SEEDED:
        params[key] = int(params.get(key, defaults[key])) + int(seed)
    return params


def predictor_params(params: dict[str, Any] | None) -> dict[str, Any]:
    """Settings from a configuration (JSON lists) as ``SMRPredictor`` arguments (tuples)."""
    params = dict(params or {})
    unknown = set(params) - set(SMRPredictor().get_params())
    if unknown:
        raise ValueError(f"unknown predictor settings {sorted(unknown)}; known: "
                         f"{sorted(SMRPredictor().get_params())} (fix the configuration's 'predictor' section)")
    for key in ("hidden_layer_sizes", "column_order"):
        if params.get(key) is not None:
            params[key] = tuple(params[key])
    return params


def _seeds(seeds: int | Sequence[int]) -> list[int]:
    seeds = list(range(seeds)) if isinstance(seeds, int) else [int(s) for s in seeds]
    if not seeds or min(seeds) < 0 or len(set(seeds)) != len(seeds):
        raise ValueError(f"seeds must be distinct non-negative integers (or a count >= 1), got {seeds}")
    return seeds


def describe(meta: dict[str, Any] | None, n_files: int) -> str:
    """Who is being trained, for messages: the dataset, sequence length and held-out method of ``meta``."""
    meta = meta or {}
    parts = [f"dataset {meta['dataset']!r}" if meta.get("dataset") is not None else "",
             f"sequence length {meta['seq_len']}" if meta.get("seq_len") is not None else "",
             f"without method {meta['held_out']!r}" if meta.get("held_out") is not None else ""]
    return ", ".join([p for p in parts if p] + [f"train split of {n_files} method(s) pooled"])


def check_trainable(y_train: np.ndarray, params: dict[str, Any], seeds: Sequence[int], where: str) -> None:
    """Fail before any training when a seed's shuffled labels cannot be cross-validated and fitted (the folds
    follow the shuffled order); the error names ``where``, the class counts and the fix."""
    smote = bool(params.get("smote", SMRPredictor().smote))
    for seed in seeds:
        check_training_labels(shuffle(y_train, random_state=seed), where, smote)


def seeded_training(
    x_train: np.ndarray, y_train: np.ndarray, params: dict[str, Any] | None, seed: int
) -> tuple[SMRPredictor, np.ndarray, np.ndarray]:
    """Seed ``seed`` of the recipe, its one implementation (``train_seed``, the speed experiment's ``fit_pooled``):
    the unfitted ``SMRPredictor(**seeded_params(params, seed))`` and the pooled samples shuffled with ``seed``,
    which it is fitted on (and cross-validated on: the folds fit clones, so the fit is the same either way)."""
    x, y = shuffle(x_train, y_train, random_state=seed)
    return SMRPredictor(**seeded_params(params, seed)), x, y


def train_seed(
    x_train: np.ndarray,
    y_train: np.ndarray,
    params: dict[str, Any] | None,
    seed: int,
    evaluation: dict[str, tuple[np.ndarray, np.ndarray]] | None = None,
    cross_validate: bool = True,
    where: str = "the pooled train split",
) -> tuple[SMRPredictor, SeedReport]:
    """Shuffle the pooled train set with ``seed``, fit a predictor with ``seeded_params`` (``seeded_training``),
    cross-validate it when ``cross_validate`` (``f1_cv`` None otherwise), and score it on each ``evaluation`` split
    (name -> (X, y)). Returns the fitted predictor and its numbers. ``where``: who is trained, for the line that
    puts scikit-learn's warnings of the cross-validation in words (``estimator.fold_warning``)."""
    predictor, x, y = seeded_training(x_train, y_train, params, seed)
    # the settings as JSON holds them (lists, not tuples), so that a report read back equals the one written
    settings = json.loads(json.dumps(predictor.get_params()))
    # the folds fit clones of the unfitted predictor: the fit below is the same with or without them
    f1_cv = cross_validated_f1(predictor, x, y, where=where) if cross_validate else None
    splits = {}
    with warnings.catch_warnings(record=True) as caught:  # scikit-learn's, put in our words below
        warnings.simplefilter("always")
        predictor.fit(x, y)
        for name, (x_eval, y_eval) in (evaluation or {}).items():
            predicted = predictor.predict(x_eval)
            splits[name] = SplitScores(
                macro_f1(y_eval, predicted), int(len(y_eval)),
                tuple(np.bincount(y_eval, minlength=len(LABELS)).tolist()),
                tuple(map(tuple, confusion_matrix(y_eval, predicted, labels=list(LABELS)).tolist())))
    note = fit_warning([w.message for w in caught], f"{where}, seed {seed}")
    if note:
        log.warning(note)
    numbers = SeedReport(seed, settings, f1_cv, predictor.n_iter_,
                         tuple(np.bincount(y, minlength=len(LABELS)).tolist()), splits)
    log.info("seed %d: %s%s, %d iterations", seed, cv_text(numbers), split_f1s(numbers), numbers.n_iter)
    return predictor, numbers


def cv_text(numbers: SeedReport) -> str:
    """``f1 cv 0.712``, or that the seed was not cross-validated."""
    return "not cross-validated" if numbers.f1_cv is None else f"f1 cv {numbers.f1_cv:.3f}"


def split_f1s(numbers: SeedReport) -> str:
    """``, check 0.712, final 0.698``: the macro F1 on each evaluation split, by the splits' own names."""
    return "".join(f", {name} {scores.f1:.3f}" for name, scores in numbers.splits.items())


def check_validation(evaluate: Mapping[str, Sequence[Path | str]], validation: str | None) -> str | None:
    """The validation split: ``validation`` when it is one of the evaluation splits, by default the first of them
    (None when there are none)."""
    if validation is None:
        return next(iter(evaluate), None)
    if validation not in evaluate:
        raise ValueError(f"the validation split {validation!r} is not among the evaluation splits given "
                         f"({', '.join(map(repr, evaluate)) or 'none'})")
    return validation


def main(job: TrainJob) -> PredictorReport:
    """The ``train`` stage: its output's suffix and its attributes files' sequence length checked first (files of
    another ``seq_len`` would label its outputs wrongly), then ``fit``."""
    check_suffix(job.out, HDF5_SUFFIXES, "the predictor (HDF5; its report goes beside it as .json)")
    check_seq_len([*job.train, *(path for paths in job.splits.values() for path in paths)], job.seq_len)
    return fit(job)


def fit(job: TrainJob, meta: Mapping[str, Any] | None = None, cross_validate: bool = True) -> PredictorReport:
    """Train one predictor per seed on the pooled ``job.train`` files (the configuration's method order) and report;
    ``meta``: what the report records besides the dataset and the sequence length (the leave-one-method-out
    predictor's held-out method).

    ``job.evaluate``: the evaluation splits by their names (the configuration's, e.g. ``{"val": [...], "test":
    [...]}`` or ``{"check": [...], "final": [...]}``), each split's files of every method, pooled in the given order:
    the predictors' macro F1 on each. ``job.training.validation``: the split whose F1 decides whether a predictor can
    be trusted (the warning; default: the first of ``evaluate``, none when it is empty).

    Seeds ``0..job.seeds-1`` (seed 0: the authors' recipe). Only the first seed is cross-validated (when
    ``cross_validate``; the others' ``f1_cv`` is None): its numbers are the ones every table shows, and the
    cross-validation was three quarters of a training job's time. The first seed's predictor is written to ``out``
    (.h5), the others to ``<out stem>.seed<s>.h5`` beside it, and the report to ``out`` with suffix ``.json``: meta,
    n_train, per seed (``seeds``: params, f1_cv, n_iter, train_class_counts and per evaluation split by its name f1,
    n, class_counts and the confusion matrix over labels 0..3) and ``seed_models`` (when several seeds):
    ``records.PredictorReport``, which is returned. The first predictor file holds it as its ``report``, the others
    a report of their own seed alone. Nothing is written until every seed has finished, so an interrupted training
    leaves no file. The evaluation splits may not share frames with ``train`` (``allow_split_overlap``: a deliberate
    experiment); each predictor file records its sequence length, methods, the frame ranges and the matrices it was
    trained on (``training_record``), which every later stage checks.
    """
    out_path = check_suffix(job.out, HDF5_SUFFIXES, "the predictor (HDF5; its report goes beside it as .json)")
    meta = {"dataset": job.dataset, "seq_len": job.seq_len, **(meta or {})}
    train, seeds = list(job.train), _seeds(job.seeds)
    params = predictor_params(job.training.predictor.values)
    allow_split_overlap = job.training.allow_split_overlap
    evaluate = {name: list(paths) for name, paths in job.splits.items() if paths}
    validation = check_validation(evaluate, job.training.validation)
    scored = [path for paths in evaluate.values() for path in paths]
    trained = frame_ranges(train)
    check_disjoint(trained, frame_ranges(scored), allow_split_overlap, "the predictor")
    # the labels it learns and is scored on must come from one matcher and one kind of ground truth, which its
    # files record for every stage that applies it
    matching = common_matching([*train, *scored])
    train_features = read_all(train)
    training = training_record(train, train_features, meta, trained)
    x_train, y_train = rank0(train_features)
    check_trainable(y_train, params, seeds, describe(meta, len(train)))
    scored_features = {name: read_all(paths) for name, paths in evaluate.items()}
    check_matrices([found for name, paths in evaluate.items()
                    for path, features in zip(paths, scored_features[name], strict=True)
                    for found in matrix_overlaps(training, str(path), features.matrix)], allow_split_overlap)
    evaluation = {name: rank0(features) for name, features in scored_features.items()}
    log.info("training on %d samples, class counts %s, seeds %s", len(y_train),
             np.bincount(y_train, minlength=len(LABELS)), seeds)
    # several seeds take about a minute each: a progress line per seed, which `vpr-smr run` shows for the job
    # (one seed, as the ablations train, has no fraction worth showing)
    several, started = len(seeds) > 1, time.monotonic()
    fitted: list[tuple[SMRPredictor, SeedReport]] = []
    if several:
        write_progress(0, len(seeds), "seeds", 0.0)
    for seed in seeds:
        fitted.append(train_seed(x_train, y_train, params, seed, evaluation,
                                 cross_validate=cross_validate and not fitted, where=describe(meta, len(train))))
        if several:
            write_progress(len(fitted), len(seeds), "seeds", time.monotonic() - started)

    paths = [out_path] + [Path(seed_predictor_path(out_path, seed)) for seed in seeds[1:]]
    # the numeric environment (BLAS kernel and threads) is information for the reader, never compared as a setting
    report = PredictorReport({**recorded_matching(list(train)), **meta, **environment.recorded()},
                             int(len(y_train)),
                             tuple(numbers for _, numbers in fitted),
                             tuple(str(p) for p in paths) if len(seeds) > 1 else None)
    warning = report.warning(validation) if validation is not None else ""
    if warning:  # `vpr-smr run` shows the warnings of its jobs' logs; the predictor table and the report say it too
        log.warning("%s: this predictor cannot be trusted: %s", describe(meta, len(train)), warning)
    for i, ((predictor, numbers), path) in enumerate(zip(fitted, paths, strict=True)):
        # the first predictor keeps the whole report, the others a report of their own seed alone
        own = report if i == 0 else PredictorReport(report.meta, report.n_train, (numbers,))
        predictor.save(path, matching, training, report=own.to_json())
    save(predictor_report_path(out_path), report)
    return report
