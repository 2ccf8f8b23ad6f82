"""The Python API for notebooks: ``from vpr_smr import api as smr``.

A thin, typed facade over the functions the command-line stages call: every metric, matcher, attribute, predictor
and scorer here is the one the CLI runs (``vpr-smr metrics``, ``attributes``, ``train``, ``evaluate``,
``baselines``), on arrays in memory instead of files. Each function returns the tool's own records (frozen
dataclasses, all of them in ``vpr_smr.records``); :func:`plain` turns any of them into plain Python data (lists,
dicts, numbers), and the arrays of :class:`~vpr_smr.eval.matching.attributes.QueryFeatures` are NumPy arrays already.
:func:`run_stage` runs any stage of the workflow on files, as its command does.

``__all__`` is the stable surface: its names, their parameters and the fields of the records they return follow the
version policy at the top of the CHANGELOG (a name is renamed or removed only after a minor release in which the old
one still works and warns).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from vpr_smr.core.constants import DEFAULT_TOLERANCE, DEFAULT_TRUST_LEVELS, MODES
from vpr_smr.core.records import encode
from vpr_smr.core.settings import parse
from vpr_smr.eval.matching.attributes import (
    DEFAULT_CANDIDATES,
    Matching,
    QueryFeatures,
    check_length,
    check_matching,
    query_features,
)
from vpr_smr.eval.matching.features import match_blocks
from vpr_smr.eval.matching.ground_truth import FRAMES, MATRIX, GroundTruth
from vpr_smr.eval.matching.ground_truth_files import read_ground_truth as read_truth_file
from vpr_smr.eval.matching.io import open_distance_matrix
from vpr_smr.eval.matching.matcher import as_matrix
from vpr_smr.eval.matching.matchers import DEFAULT_MATCHER, MatcherSpec
from vpr_smr.eval.matching.matchers.base import MatchBlock
from vpr_smr.eval.predictor.defaults import PredictorSettings
from vpr_smr.eval.predictor.estimator import SMRPredictor
from vpr_smr.eval.predictor.leakage import Training, check_matrices, check_scored, matrix_overlaps
from vpr_smr.eval.predictor.train import check_trainable, predictor_params, rank0, train_seed
from vpr_smr.eval.scoring import baselines as scoring
from vpr_smr.eval.scoring.calibrate_stage import Deployed
from vpr_smr.eval.scoring.calibrate_stage import calibrate as calibrate_checked
from vpr_smr.eval.scoring.calibrate_stage import deploy as deploy_checked
from vpr_smr.eval.scoring.evaluate import evaluate_split
from vpr_smr.eval.scoring.queries import Prediction
from vpr_smr.eval.scoring.records import EvaluationSplit, SplitBaselines, SplitMetrics
from vpr_smr.eval.scoring.scorers import DEFAULT_SETTINGS, BaselineSettings
from vpr_smr.eval.scoring.thresholds import DEFAULT_RISK, DEFAULT_SEGMENT, GUARANTEED, Calibration
from vpr_smr.eval.scoring.vpr_metrics import score_split

# in the order of a session (and of the reference page)
__all__ = [
    "sample_distances", "read_distances", "read_ground_truth", "metrics", "match", "attributes", "train", "predict",
    "save_predictor", "load_predictor", "evaluate", "scores", "baselines", "calibrate", "deploy", "plain",
    "stage_commands", "run_stage",
]

Truth = GroundTruth | np.ndarray | None  # what a ``ground_truth`` argument takes


# --- reading matrices and ground truths -------------------------------------------------------------------------


def sample_distances(split: str = "val", backend: str = "sad", *, frames: int | None = None) -> np.ndarray:
    """The distance matrix of a split of the shipped Nordland sample, computed here from its images.

    Summer is the reference traverse, winter the query one, paired frame by frame (a frame-aligned ground truth).
    The descriptors and distances are those of ``vpr-smr descriptors`` and ``vpr-smr distances``.

    Args:
        split: the sample's split: ``train``, ``val`` or ``test``.
        backend: a descriptor backend without weights (``sad`` or ``hog``).
        frames: only the split's first ``frames`` frames (None: all of them).

    Returns:
        The ``references x queries`` distance matrix (float64; smaller is more similar).

    Raises:
        ValueError: an unknown split or backend, a backend that needs a checkpoint, or ``frames`` below 1.
    """
    from vpr_smr.datasets import Traverse
    from vpr_smr.datasets.nordland_sample import nordland_sample
    from vpr_smr.descriptors import backend_class
    from vpr_smr.descriptors.extract import build_backend, compute_descriptors
    from vpr_smr.eval.matching.distances import distance_matrix

    if backend_class(backend).needs_checkpoint:
        raise ValueError(f"backend: {backend!r} needs a checkpoint; sample_distances computes the backends without "
                         "weights (sad, hog); score another method's matrix with read_distances")
    pair = nordland_sample()
    lo, hi = pair.split_range(split)
    if frames is not None:
        if frames < 1:
            raise ValueError(f"frames: a number of frames >= 1, got {frames}")
        hi = min(hi, lo + frames)
    built, _ = build_backend(backend, {"backend": backend})
    reference, query = (compute_descriptors(Traverse(t.name, t.images[lo:hi]), built)
                        for t in (pair.reference, pair.query))
    return np.asarray(distance_matrix(reference, query, built.distance), dtype=np.float64)


def read_distances(path: Path | str, *, similarity: bool = False, key: str | None = None,
                   transpose: bool = False) -> np.ndarray:
    """A distance matrix from a file, read as ``vpr-smr metrics --distances`` reads it, into memory.

    Args:
        path: a ``.npy``, ``.npz``, MATLAB ``.mat`` (v5 or v7.3) or a distance file (``.h5``) of vpr-smr.
        similarity: the file holds similarities (larger is more similar): read as the distances ``max(M) - M``.
        key: the array of an ``.npz`` or the variable of a ``.mat`` holding the matrix (default: its only 2-D
            numeric one).
        transpose: the file is ``queries x references``.

    Returns:
        The ``references x queries`` distance matrix.

    Raises:
        FileNotFoundError: no such file.
        ValueError: the file is of another format, holds no such variable (or several and no ``key``), holds no 2-D
            numeric matrix or negative distances; the message names the file and the fix.
    """
    with open_distance_matrix(path, similarity, key, transpose, key_option="key") as matrix:
        return np.array(matrix[:, :])


def read_ground_truth(path: Path | str, *, key: str | None = None,
                      shape: tuple[int, int] | None = None) -> GroundTruth:
    """A ground truth from a file, read as ``--ground-truth`` reads it.

    Args:
        path: a boolean ``references x queries`` matrix (``.npy``, ``.npz``, ``.mat``, e.g. VPR_Tutorial's
            ``GThard`` or ``GTsoft``), or per-query lists of correct references (JSON, CSV ``query,reference``,
            VPR-Bench's ``ground_truth_new.npy``).
        key: the variable of an ``.npz`` or ``.mat`` holding several (e.g. ``GThard``).
        shape: ``(references, queries)`` of the matrix it scores: checked here, and per-query lists are sized to it.

    Returns:
        The ground truth, for the ``ground_truth`` argument of the other functions.

    Raises:
        FileNotFoundError: no such file.
        ValueError: a file of another format, without such a variable, or of another shape; the message names the
            file and the fix.
    """
    return read_truth_file(path, key, shape, key_option="key")


def _spec(matcher: str | MatcherSpec, settings: Mapping[str, Any] | None) -> MatcherSpec:
    """The matcher by name with its settings (the ``sequence_matching`` registry: built in, or a plugin's)."""
    if isinstance(matcher, MatcherSpec):
        if settings:
            raise ValueError("settings: give the settings in the MatcherSpec, or the matcher by name with settings")
        return matcher
    return MatcherSpec.of(matcher, settings, "settings")


def _truth(shape: tuple[int, int], ground_truth: Truth, tolerance: int) -> GroundTruth:
    """The ground truth of a ``shape`` matrix: the one given (a boolean matrix as it is), else frames within
    ``tolerance``; errors name the argument and the fix."""
    if ground_truth is None:
        if shape[0] != shape[1]:
            raise ValueError(f"ground_truth: the matrix is {shape[0]} x {shape[1]} (references x queries): a "
                             "frame-aligned ground truth (a match r of query q is correct when |r - q| <= tolerance) "
                             "needs as many references as queries; give ground_truth (read_ground_truth(path), or a "
                             "boolean references x queries array)")
        if tolerance < 0:
            raise ValueError(f"tolerance: a number of frames >= 0, got {tolerance}")
        return GroundTruth.aligned(shape[0], shape[1], tolerance)
    truth = ground_truth if isinstance(ground_truth, GroundTruth) else GroundTruth.matrix(ground_truth)
    try:
        truth.check_shape(shape)
    except ValueError as error:
        raise ValueError(f"ground_truth: {error}") from None
    return truth


def _matrix(distances: Any) -> Any:
    """A 2-D distance matrix as the stages read it (``as_matrix``), the error naming the argument."""
    try:
        return as_matrix(distances)
    except (ValueError, TypeError) as error:
        raise ValueError(f"distances: {error}") from None


# --- metrics, matching, attributes ------------------------------------------------------------------------------


def metrics(distances: Any, seq_len: int, *, tolerance: int = DEFAULT_TOLERANCE, ground_truth: Truth = None,
            matcher: str | MatcherSpec = DEFAULT_MATCHER, settings: Mapping[str, Any] | None = None,
            predictor: SMRPredictor | None = None, modes: Sequence[str] = MODES,
            allow_split_overlap: bool = False) -> SplitMetrics:
    """The standard VPR metrics of one matrix, as ``vpr-smr metrics`` computes them.

    Recall@N (N = 1, 5, 10, 20), recall at 100 % precision, the area under the PR curve and extended precision of
    single-frame matching (``single``), sequence matching (``sequence``) and, with a predictor, sequence matching
    with its matches removed (``sequence_predictor``), per metric mode.

    Args:
        distances: the ``references x queries`` distance matrix (an array, e.g. from :func:`read_distances`).
        seq_len: the sequence length L of sequence matching.
        tolerance: without ``ground_truth``, a match within this many frames is correct.
        ground_truth: a ground truth (:func:`read_ground_truth`) or a boolean ``references x queries`` array.
        matcher: the sequence matcher's name (``vpr-smr matchers`` lists them) or its spec.
        settings: the matcher's settings (missing ones at their defaults).
        predictor: a trained predictor (:func:`train`, :func:`load_predictor`): adds ``sequence_predictor``; one
            of another matcher or sequence length is refused, and so is one trained on this matrix or a block
            overlapping it.
        modes: the metric modes, ``paper`` and/or ``standard``.
        allow_split_overlap: score a predictor on a matrix that shares entries with its training matrices (a
            deliberate experiment; its scores are then measured on its own training data).

    Returns:
        The split's metrics, ``result.modes[mode][matcher]`` a record with ``recall_at`` (N to recall@N),
        ``recall_at_100p``, ``pr_auc`` and ``extended_precision``; :func:`plain` gives them as plain data.

    Raises:
        ValueError: a matrix too short for ``seq_len``, a ground truth of another shape, an unknown matcher,
            setting or mode, a predictor of another matcher or length; the message names it and the fix.
        vpr_smr.eval.predictor.leakage.SplitLeakError: (a ValueError) a predictor trained on this matrix or an
            overlapping block, unless ``allow_split_overlap``.
    """
    matrix = _matrix(distances)
    truth = _truth(tuple(matrix.shape), ground_truth, tolerance)
    spec = _spec(matcher, settings)
    if predictor is not None:  # one of another matcher, length or of this matrix is refused, as the CLI refuses it
        check_matching(predictor, Matching.of(spec, truth.kind), "metrics' matches")
        check_length(predictor, seq_len, f"seq_len={seq_len}", "seq_len=")
        training = getattr(predictor, "training_", None)
        if training is not None:
            check_matrices(matrix_overlaps(training, "distances", matrix=matrix), allow_split_overlap)
    return score_split(matrix, seq_len, tolerance, predictor, tuple(modes), matcher=spec, ground_truth=truth).metrics


def match(distances: Any, seq_len: int, *, matcher: str | MatcherSpec = DEFAULT_MATCHER,
          settings: Mapping[str, Any] | None = None) -> MatchBlock:
    """Sequence matching of every query the matcher evaluates.

    Args:
        distances: the ``references x queries`` distance matrix.
        seq_len: the sequence length L.
        matcher: the sequence matcher's name (built in or a plugin's; ``vpr-smr matchers`` lists them) or its spec.
        settings: the matcher's settings (missing ones at their defaults).

    Returns:
        The matcher's record of ``queries`` (the evaluated query indices), ``scores`` (one row per query, the score
        ``s_a[r]`` of every reference, lower is better), ``match`` (the matched reference) and ``native`` (the
        matcher's own confidence, None where it names a training-free scorer instead); NumPy arrays.

    Raises:
        ValueError: an unknown matcher or setting (the message lists the available ones), or a matrix too short
            for ``seq_len``.
    """
    matrix = _matrix(distances)
    built = _spec(matcher, settings).build(seq_len)
    built.check(tuple(matrix.shape))
    blocks = [found for found, _, _ in match_blocks(built, matrix)]
    natives = [found.native for found in blocks if found.native is not None]
    return MatchBlock(
        np.concatenate([found.queries for found in blocks]), np.concatenate([found.scores for found in blocks]),
        np.concatenate([found.match for found in blocks]),
        np.concatenate(natives) if len(natives) == len(blocks) else None)


def attributes(distances: Any, seq_len: int, *, tolerance: int = DEFAULT_TOLERANCE, ground_truth: Truth = None,
               matcher: str | MatcherSpec = DEFAULT_MATCHER, settings: Mapping[str, Any] | None = None,
               candidates: int = DEFAULT_CANDIDATES) -> QueryFeatures:
    """Sequence matching, the SMR attributes A1..A4 and the labels of one matrix, as ``vpr-smr attributes``.

    Args:
        distances: the ``references x queries`` distance matrix.
        seq_len: the sequence length L.
        tolerance: without ``ground_truth``, a match within this many frames is correct.
        ground_truth: a ground truth (:func:`read_ground_truth`) or a boolean ``references x queries`` array.
        matcher: the sequence matcher's name or its spec.
        settings: the matcher's settings (missing ones at their defaults).
        candidates: how many of the smallest sequence and single-frame distances of each query to keep for the
            training-free scorers (:func:`scores`, :func:`baselines`); 0 keeps none.

    Returns:
        The features of the evaluated queries, ``queries``, ``attributes`` (``N x K x 4``, A1..A4 of each rank;
        rank 0 is the match's), ``labels`` (0: correct before and after sequence matching, 1: before only, 2: after
        only, 3: neither), ``single_match``, ``sequence_match``, ``sequence_distance`` and their correctness; NumPy
        arrays (``dataclasses.asdict`` gives them by name). Also ``seq_len`` and ``matrix`` (the matrix's SHA-256
        and content fingerprint), which a predictor trained on them records.

    Raises:
        ValueError: a matrix too short for ``seq_len``, a ground truth of another shape, an unknown matcher or
            setting, ``candidates`` below 0.
    """
    matrix = _matrix(distances)
    truth = _truth(tuple(matrix.shape), ground_truth, tolerance)
    if candidates < 0:
        raise ValueError(f"candidates: a number of candidates per query >= 0, got {candidates}")
    return query_features(matrix, seq_len, tolerance, matcher=_spec(matcher, settings), ground_truth=truth,
                          n_candidates=candidates, fingerprint=True)


# --- the predictor ----------------------------------------------------------------------------------------------


def train(features: QueryFeatures | Sequence[QueryFeatures], *, seed: int = 0,
          settings: Mapping[str, Any] | None = None) -> SMRPredictor:
    """Train the SMR predictor on the rank-0 attributes and labels of one or more splits, as ``vpr-smr train``.

    Several features (e.g. one per method) are pooled in the given order. Seed 0 is the authors' recipe; seed
    ``s`` shifts the shuffle, SMOTE and network seeds by ``s``.

    Args:
        features: the training split's features (:func:`attributes`), or several to pool.
        seed: the training seed (>= 0).
        settings: the predictor's settings (``configuration.md``, ``predictor``; missing ones at their defaults).

    Returns:
        The trained predictor (scikit-learn style, with ``predict_proba`` and ``classes_``), recording the sequence
        length and the matrices of its features (``training_``), which :func:`save_predictor` writes.

    Raises:
        ValueError: an unknown or invalid setting, a negative seed, features of several sequence lengths, or labels
            it cannot be trained on (too few of a class); the message says why and the fix.
    """
    pooled = [features] if isinstance(features, QueryFeatures) else list(features)
    if not pooled:
        raise ValueError("features: give the training split's features (smr.attributes), or several to pool")
    if seed < 0:
        raise ValueError(f"seed: a training seed >= 0, got {seed}")
    values = dict(settings or {})
    parse(PredictorSettings, values, "settings")
    params = predictor_params(values)
    training = Training.of(pooled)
    x, y = rank0(pooled)
    check_trainable(y, params, [seed], "features")
    predictor, _ = train_seed(x, y, params, seed, cross_validate=False)
    predictor.training_, predictor.seq_len_ = training, training.seq_len
    return predictor


def predict(predictor: SMRPredictor, features: QueryFeatures, *, allow_split_overlap: bool = False) -> Prediction:
    """Apply a predictor to a split's features: which sequence matches it keeps.

    Args:
        predictor: a trained predictor (:func:`train`).
        features: the split's features (:func:`attributes`), of another split than its training one.
        allow_split_overlap: apply it to features of a matrix that shares entries with its training matrices (a
            deliberate experiment).

    Returns:
        Its decision per evaluated query, ``predicted`` (the class), ``probability`` (that class's), and the
        property ``kept`` (True where the match is kept: class 0 or 2); NumPy arrays.

    Raises:
        ValueError: features of another sequence length than the predictor's, or (``SplitLeakError``) of a matrix
            it was trained on or a block overlapping one, unless ``allow_split_overlap``.
    """
    check_scored(predictor, {"features": features}, allow_split_overlap, fix="features of seq_len=")
    return Prediction.of(predictor, features)


def save_predictor(predictor: SMRPredictor, path: Path | str, *, matcher: str | MatcherSpec = DEFAULT_MATCHER,
                   settings: Mapping[str, Any] | None = None, ground_truth: Truth = None,
                   seq_len: int | None = None, methods: Sequence[str] = ()) -> None:
    """Write a trained predictor to an HDF5 file that the command line and the live API read (``vpr-smr metrics
    --predictor``, ``LiveMatcher``), recording what its training attributes were made with.

    A predictor's classes describe one matcher's matches of one length, so the file records the matcher and the
    kind of ground truth of the attributes it was trained on (give the ``matcher``, ``settings`` and
    ``ground_truth`` that :func:`attributes` was given), their sequence length and the SHA-256 and fingerprint of
    their matrices (from :func:`train`); the stages that apply it refuse it with another matcher or length, and on
    a matrix it was trained on or a block overlapping one. The file is written under a temporary name and renamed,
    so an interrupted write leaves no file.

    Args:
        predictor: a trained predictor (:func:`train`).
        path: the file to write (``.h5``).
        matcher: the sequence matcher of its training attributes, by name or spec.
        settings: that matcher's settings (missing ones at their defaults).
        ground_truth: the ground truth its training attributes were labelled with (None: frames within a
            tolerance; a boolean array: a matrix; a :class:`~vpr_smr.eval.matching.ground_truth.GroundTruth`: its kind).
        seq_len: the sequence length of its training attributes: needed only for a predictor that does not know it
            (not trained by :func:`train`, or loaded from a file that records none); refused when it differs.
        methods: the names of the methods (descriptors) of its training attributes, recorded for the reader.

    Raises:
        ValueError: an unknown matcher or setting, a predictor that is not trained, or a length unknown or other
            than the predictor's.
    """
    kind = FRAMES if ground_truth is None else ground_truth.kind if isinstance(ground_truth, GroundTruth) else MATRIX
    training = getattr(predictor, "training_", None) or Training()
    if seq_len is not None and training.seq_len is not None and seq_len != training.seq_len:
        raise ValueError(f"seq_len: the predictor was trained on features of L = {training.seq_len}, not {seq_len}: "
                         "leave seq_len out, or give the length of its training attributes")
    length = training.seq_len if training.seq_len is not None else seq_len
    if length is None:
        raise ValueError("seq_len: the predictor does not record the sequence length of its training attributes "
                         "(it was not trained by smr.train): give save_predictor(..., seq_len=L), the seq_len its "
                         "attributes were computed with")
    training = replace(training, seq_len=int(length), methods=tuple(methods) or training.methods)
    predictor.save(path, Matching.of(_spec(matcher, settings), kind), training)


def load_predictor(path: Path | str) -> SMRPredictor:
    """A predictor from a file :func:`save_predictor` or ``vpr-smr train`` wrote.

    Args:
        path: the predictor file (``.h5``).

    Returns:
        The predictor, recording the matcher it was trained with (``matching_``) and what it was trained on
        (``training_``: its sequence length, also ``seq_len_``, methods, frames and matrices); the functions that
        apply it with another matcher or length, or to its training matrices, refuse it.

    Raises:
        FileNotFoundError: no such file.
    """
    return SMRPredictor.load(path)


def evaluate(features: QueryFeatures, predictors: SMRPredictor | Sequence[SMRPredictor], *,
             modes: Sequence[str] = MODES, trust_levels: Sequence[float] = DEFAULT_TRUST_LEVELS,
             restoration: bool = False, allow_split_overlap: bool = False) -> EvaluationSplit:
    """Match removal by the predictor against sequence matching alone, as ``vpr-smr evaluate`` scores a split.

    Args:
        features: the evaluated split's features (:func:`attributes`).
        predictors: one predictor per seed, in seed order, seed 0 first (:func:`train`).
        modes: the metric modes, ``paper`` and/or ``standard``.
        trust_levels: the trust levels of the trust-level ablation (empty: none).
        restoration: also restore removed matches from the next ranks (method §9).
        allow_split_overlap: score predictors on features of a matrix that shares entries with their training
            matrices (a deliberate experiment).

    Returns:
        The split's numbers, ``modes[mode].reduction`` holding the AOC of VPR+SM and of VPR+SM+Pred
        (``aoc_vpr_sm``, ``aoc_vpr_sm_pred``), their reduction in percent and its outcome; ``modes[mode].curves``
        the precision-recall curves; ``f1_macro``, ``removed``, ``seed_summary`` over the seeds.

    Raises:
        ValueError: an unknown mode, a predictor of another sequence length than the features', or
            (``SplitLeakError``) one trained on their matrix or a block overlapping it, unless ``allow_split_overlap``.
    """
    unknown = [mode for mode in modes if mode not in MODES]
    if unknown:
        raise ValueError(f"modes: unknown metric modes {unknown}; choose from {', '.join(MODES)}")
    for predictor in [predictors] if isinstance(predictors, SMRPredictor) else predictors:
        check_scored(predictor, {"features": features}, allow_split_overlap, fix="features of seq_len=")
    split, _ = evaluate_split(features, predictors, tuple(modes), tuple(trust_levels), restoration)
    return split


# --- the training-free scorers (method §12) ---------------------------------------------------------------------


def _scorer_inputs(features: QueryFeatures, settings: Mapping[str, Any] | None, ground_truth: GroundTruth | None
                   ) -> tuple[BaselineSettings, np.ndarray]:
    """The scorers' settings and the reference positions ``spread`` measures."""
    chosen = DEFAULT_SETTINGS if settings is None else parse(BaselineSettings, settings, "settings")
    scoring.check_candidates(features, chosen, "features", "or smr.attributes(..., candidates=N)")
    if ground_truth is not None:
        return chosen, scoring.spread_positions(ground_truth)
    # frame indices (scoring.spread_positions of a frame ground truth): position r of reference r, read only at the
    # candidates' references, so the range up to the largest of them gives every value arange(R) would
    assert features.sequence_candidate_references is not None  # check_candidates
    return chosen, np.arange(int(features.sequence_candidate_references.max()) + 1, dtype=np.float64)


def scores(features: QueryFeatures, *, settings: Mapping[str, Any] | None = None,
           ground_truth: GroundTruth | None = None, seed: int = 0) -> dict[str, np.ndarray]:
    """Every scorer's confidence that each sequence match is correct (higher: more likely), as ``vpr-smr queries``
    writes them (its ``c_<name>`` columns).

    Args:
        features: the split's features (:func:`attributes`, with its default ``candidates``).
        settings: the scorers' settings ``r_window`` and ``spread_k`` (missing ones at their defaults).
        ground_truth: the ground truth of a dataset with positions (``spread`` measures them); None: frame indices.
        seed: the seed of the ``random`` scorer.

    Returns:
        Scorer name (``uniqueness``, ``single_uniqueness``, ``spread``, ``distance``, ``native``, ``random``,
        ``oracle``) to its confidence per evaluated query (a NumPy array).

    Raises:
        ValueError: features without enough candidates for the settings, or an invalid setting.
    """
    chosen, positions = _scorer_inputs(features, settings, ground_truth)
    return scoring.query_scores(features, chosen, positions, seed)


def baselines(features: QueryFeatures, *, predictors: Sequence[SMRPredictor] = (),
              settings: Mapping[str, Any] | None = None, ground_truth: GroundTruth | None = None,
              modes: Sequence[str] = MODES, allow_split_overlap: bool = False) -> SplitBaselines:
    """The training-free scorers against the predictor, as ``vpr-smr baselines``: how well each detects the wrong
    matches, and with predictors each one's removal of as many matches as each predictor seed removes.

    Args:
        features: the evaluated split's features (:func:`attributes`, with its default ``candidates``).
        predictors: one predictor per seed, seed 0 first (:func:`train`); none: detection only.
        settings: the scorers' settings ``r_window`` and ``spread_k`` (missing ones at their defaults).
        ground_truth: the ground truth of a dataset with positions (``spread`` measures them); None: frame indices.
        modes: the metric modes of the removal.
        allow_split_overlap: score predictors on features of a matrix that shares entries with their training
            matrices (a deliberate experiment).

    Returns:
        The split's record, ``detection[name]`` (average precision and ROC AUC of finding the wrong matches), and
        with predictors ``removal`` (per seed: per scorer its AOC reduction at the seed's budget).

    Raises:
        ValueError: features without enough candidates for the settings, an invalid setting or an unknown mode, a
            predictor of another sequence length, or (``SplitLeakError``) one trained on their matrix or a block
            overlapping it, unless ``allow_split_overlap``.
    """
    unknown = [mode for mode in modes if mode not in MODES]
    if unknown:
        raise ValueError(f"modes: unknown metric modes {unknown}; choose from {', '.join(MODES)}")
    for predictor in predictors:
        check_scored(predictor, {"features": features}, allow_split_overlap, fix="features of seq_len=")
    chosen, positions = _scorer_inputs(features, settings, ground_truth)
    rank0_attributes = features.attributes[:, 0, :]
    found = [scoring.Prediction(seed, predictor.predict_proba(rank0_attributes), predictor.classes_)
             for seed, predictor in enumerate(predictors)]
    return scoring.split_baselines(features, chosen, positions, found, tuple(modes))


# --- thresholds for a robot (method §16) ------------------------------------------------------------------------


def calibrate(confidences: Any, correct: Any, precision: float = 0.9, risk: float = DEFAULT_RISK,
              rule: str = GUARANTEED) -> Calibration:
    """A threshold on a calibration split's confidences for a target precision, as ``vpr-smr calibrate`` sets it.

    Args:
        confidences: one source's confidence per evaluated query of the calibration split (higher: more likely
            correct), e.g. a column of :func:`scores` or ``vpr-smr queries``' ``c_<source>``.
        correct: whether each query's sequence match is correct (``QueryFeatures.sequence_correct``).
        precision: the target precision ``p``, in (0, 1].
        risk: ``guaranteed``'s ``delta``, in (0, 1): the probability that its threshold misses ``p`` on new
            exchangeable queries (a route's queries are not exchangeable: see the page on thresholds).
        rule: ``empirical`` (the smallest threshold reaching ``p`` on the split), ``guaranteed`` (Selection with
            Guaranteed Risk) or ``same_fraction`` (the fraction ``empirical`` accepts, applied to another split).

    Returns:
        The rule's record, with its ``threshold`` (None: it abstains, accepting nothing; else it accepts
        ``c >= threshold``) and its counts on the split.

    Raises:
        ValueError: a target outside (0, 1], a risk outside (0, 1), an unknown rule, a split without any correct
            match, and for ``guaranteed`` a target of 1 or fewer queries than it can use for the target (the message
            says how many it needs).
    """
    return calibrate_checked(np.asarray(confidences), np.asarray(correct), precision, risk, rule, "confidences")


def deploy(confidences: Any, calibration: Calibration, correct: Any = None,
           segment: int = DEFAULT_SEGMENT) -> Deployed:
    """A calibration applied to another split, as ``vpr-smr deploy`` applies a threshold file.

    Args:
        confidences: the same source's confidence per evaluated query of the split (``same_fraction`` needs these
            only).
        calibration: :func:`calibrate`'s record.
        correct: the split's labels, one per query; None: the accepted queries only.
        segment: queries per segment of the segments' count.

    Returns:
        The record of the split, with ``accepted`` (a boolean mask, in query order) and, with labels, ``realised``
        (precision, recall and accepted fraction with block-bootstrap intervals), ``outcome`` (``held``, ``violated`` or
        ``abstained``) and ``segments``.

    Raises:
        ValueError: an empty split, labels of another length, or a segment below 1.
    """
    return deploy_checked(np.asarray(confidences), calibration, None if correct is None else np.asarray(correct),
                          segment)


# --- plain data -------------------------------------------------------------------------------------------------


def plain(record: Any) -> Any:
    """Any record of this module as plain data, through the records' one codec (what their JSON files hold).

    Args:
        record: a record (e.g. :func:`metrics`' or :func:`evaluate`'s), or a mapping or sequence of them.

    Returns:
        The same data as dicts (one entry per field; fields that are None left out), lists and Python numbers;
        NumPy arrays become lists.
    """
    return encode(record)


# --- the workflow's stages, on files ----------------------------------------------------------------------------


def stage_commands() -> tuple[str, ...]:
    """The stages :func:`run_stage` runs.

    Returns:
        Each stage's command (``vpr-smr COMMAND``), in the order of the data flow.
    """
    from vpr_smr.pipeline.stages import STAGES

    return tuple(one.command for one in STAGES)


def run_stage(command: str, job: Any = None, /, **settings: Any) -> Any:
    """Run one stage of the workflow in this process, as ``vpr-smr COMMAND`` runs it: the same files, the same
    numbers.

    The settings are those of the command's options, by their Python names (``--seq-len`` is ``seq_len``); a group
    of them (``truth``: the ground truth, ``matrix``: how a matrix file is read) is given as its record
    (:class:`~vpr_smr.eval.matching.sources.TruthSource`) or a dict of its settings, the matcher as a
    :class:`~vpr_smr.eval.matching.matchers.MatcherSpec` or a dict ``{"matcher": NAME, SETTING: VALUE, ...}``.
    Paths are strings or :class:`~pathlib.Path`.

    Args:
        command: the stage's command (:func:`stage_commands`), e.g. ``"attributes"`` or ``"ablation held-out"``.
        job: the stage's whole job record instead of ``settings`` (``vpr_smr.pipeline.stages.stage(command).job``
            is its class).
        **settings: the job's settings; those left out are at their defaults.

    Returns:
        What the stage computed (``attributes``: the :class:`~vpr_smr.eval.matching.attributes.QueryFeatures` it
        wrote to ``out``).

    Raises:
        ValueError: an unknown stage (the message lists them), a missing or unknown setting or a value it refuses
            (the message names it); the stage's own errors as its command raises them.
        TypeError: both a job record and settings.
    """
    from vpr_smr.pipeline.stages import STAGES

    found = {one.command: one for one in STAGES}
    if command not in found:
        raise ValueError(f"command: no stage {command!r}; the stages: {', '.join(found)}")
    return found[command](job, **{name: _path_text(value) for name, value in settings.items()})


def _path_text(value: Any) -> Any:
    """A setting's value with its paths as text (the job records hold paths as the JSON text their rules give)."""
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, Mapping):
        return {key: _path_text(item) for key, item in value.items()}
    return value
