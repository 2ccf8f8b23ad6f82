"""The experiment ``matchers`` (method §14): does SMR prediction help each sequence matcher, and does it beat the
matcher's own confidence?

For one dataset at Table I's ``L``, each compared matcher (``experiment_matchers``: the configuration's list,
default every built-in matcher at its defaults) has its own attributes files (its matches and labels) and its own
predictor (the authors' recipe, every seed). Every number is taken on the queries that every compared matcher
evaluates (``shared_queries``: the intersection, counted in the record), each matcher's features cut to them
(``restricted``):

- Table I's numbers as ``evaluate.evaluate_split`` computes them (recall@1 single and sequence, the AOCs at max
  recall of VPR+SM and VPR+SM+Pred, the reduction with its bootstrap interval, the spread over seeds);
- the training-free scorers at the seed-0 predictor's budget (``baselines.split_baselines``): the best of them, and
  the native confidence (the scorer ``native``) beside the predictor, paired over the same draws;
- the wrong-match average precision of the predictor and of the native confidence.

A matcher's recall@1 on the validation split far below the fixed matcher's (``far_below``) is logged and kept in
the record: a filter whose transition window does not fit the traverses' speed ratio matches almost nothing.

This module is imported by the workflow (``matcher_tag``, ``experiment_matchers``) each time Snakemake reads the
Snakefile: what needs scikit-learn is imported inside the functions that score.
"""

from __future__ import annotations

import hashlib
import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields, replace
from functools import reduce
from typing import TYPE_CHECKING, Any

import numpy as np

from vpr_smr.core.io import JSON_SUFFIXES, check_suffix
from vpr_smr.core.records import FileRecord, Record, save
from vpr_smr.eval.matching.attributes import QueryFeatures
from vpr_smr.eval.matching.matchers import MATCHERS, MatcherSpec, matcher_class
from vpr_smr.eval.scoring.records import Detection, Interval, Reduction, SeedSummary
from vpr_smr.eval.scoring.scorers import NATIVE, BaselineSettings  # NATIVE: each matcher's own confidence
from vpr_smr.eval.scoring.study_jobs import (  # the job records, re-exported: they live in a light module
    ComparedInputs,
    MatcherInputs,
    MatchersJob,
    read_inputs,
)

if TYPE_CHECKING:
    from vpr_smr.eval.predictor.estimator import SMRPredictor

__all__ = [
    "FAR_BELOW", "ComparedInputs", "MatcherComparison", "MatcherInputs", "MatcherMode", "MatcherScores", "MatchersJob",
    "compare", "experiment_matchers", "far_below", "fixed_matcher", "main", "matcher_tag", "read_inputs",
    "restricted", "shared_queries", "validation_warning",
]

log = logging.getLogger(__name__)

Json = dict[str, Any]

# A matcher whose validation recall@1 is below this share of the fixed matcher's gets a warning: its settings (a
# filter's transition window, a velocity range) likely do not fit the traverses' speed ratio.
FAR_BELOW = 0.5
# the one array of QueryFeatures that is not per evaluated query: the split's every query (paper mode's recall@1)
SPLIT_FIELDS = ("all_single_correct",)


def fixed_matcher() -> MatcherSpec:
    """The paper's fixed matcher (``seqslam`` with velocities [1.0]), the validation warning's reference."""
    return MatcherSpec.of()


def matcher_tag(spec: MatcherSpec) -> str:
    """A matcher's name in the experiment's files, tables and figures: its name at its defaults, else its name and
    the first 8 hex digits of the SHA-256 of its settings (two settings of one matcher are two tags)."""
    if spec == MatcherSpec.of(spec.name):
        return spec.name
    return f"{spec.name}-{hashlib.sha256(spec.settings.encode()).hexdigest()[:8]}"


def experiment_matchers(entries: Sequence[Mapping[str, Any]] | None, where: str = "matchers") -> list[MatcherSpec]:
    """The compared matchers: each entry ``{matcher: NAME, ...its settings}``, or (None) every built-in matcher at
    its defaults, in the registry's order; ValueError naming ``where`` for a bad entry, none, or one given twice."""
    if entries is None:
        return [MatcherSpec.of(name, {}, where) for name in MATCHERS]
    specs = []
    for i, entry in enumerate(entries):
        if not isinstance(entry, Mapping) or not isinstance(entry.get("matcher"), str):
            raise ValueError(f"{where}[{i}]: {entry!r} is not of the form {{matcher: NAME, ...its settings}}")
        try:
            matcher_class(entry["matcher"])
        except ValueError as error:
            raise ValueError(f"{where}[{i}].matcher: {error}") from None
        settings = {key: value for key, value in entry.items() if key != "matcher"}
        specs.append(MatcherSpec.of(entry["matcher"], settings, f"{where}[{i}]"))
    if not specs:
        raise ValueError(f"{where} lists no matcher: give at least one, or switch the experiment off "
                         "(experiments.matchers: false)")
    tags = [matcher_tag(spec) for spec in specs]
    twice = sorted({tag for tag in tags if tags.count(tag) > 1})
    if twice:
        raise ValueError(f"{where} lists the matcher {', '.join(twice)} twice with the same settings: give each once")
    return specs


# --- the shared queries -----------------------------------------------------------------------------------------


def shared_queries(features: Sequence[QueryFeatures]) -> np.ndarray:
    """The queries every one of ``features`` evaluates (ascending): the matchers' comparison is over them."""
    if not features:
        raise ValueError("no features to compare")
    return reduce(np.intersect1d, (np.asarray(f.queries, dtype=np.int64) for f in features))


def restricted(features: QueryFeatures, queries: np.ndarray) -> QueryFeatures:
    """``features`` cut to the evaluated ``queries`` (each one it evaluates; ValueError naming one it does not):
    every per-query array, the split's (``SPLIT_FIELDS``) and the numbers kept but ``sequence_min``, the smallest
    kept match's."""
    rows = np.searchsorted(features.queries, queries)
    inside = rows < len(features.queries)
    if not (inside.all() and np.array_equal(features.queries[rows], queries)):
        missing = queries[~inside] if not inside.all() else queries[features.queries[rows] != queries]
        raise ValueError(f"query {int(missing[0])} is not among the features' evaluated queries")
    cut = {item.name: getattr(features, item.name)[rows] for item in fields(features)
           if item.name not in SPLIT_FIELDS and isinstance(getattr(features, item.name), np.ndarray)}
    out = replace(features, **cut)
    return replace(out, sequence_min=float(out.sequence_distance.min()) if len(queries) else features.sequence_min)


def far_below(recall: float, fixed: float) -> bool:
    """Whether a matcher's validation recall@1 is far below the fixed matcher's: under ``FAR_BELOW`` of it."""
    return recall < FAR_BELOW * fixed


def validation_warning(tag: str, method: str, recall: float | None, fixed: float | None) -> str | None:
    """The warning of a matcher whose validation recall@1 is far below the fixed matcher's (None otherwise)."""
    if recall is None or fixed is None or not far_below(recall, fixed):
        return None
    return (f"{tag} on {method}: validation recall@1 {recall:.3f} is under {FAR_BELOW:g} of the fixed matcher's "
            f"({fixed:.3f}); its settings may not fit the traverses (a filter's transition window must fit their "
            "speed ratio, docs/method.md)")


# --- the records ------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class MatcherMode(Record):
    """One matcher and method in one mode, on the shared queries: recall@1, the seed-0 predictor's reduction (with
    its bootstrap interval over queries), the spread of the reduction over the seeds, the best training-free
    scorer at the seed-0 budget (None when none is defined) and its reduction, and the native confidence's
    reduction at that budget with the interval of its difference from the predictor's (paired draws)."""

    recall_at_1_single: float
    recall_at_1_sequence: float
    reduction: Reduction
    seeds: SeedSummary
    best_scorer: str | None
    best_scorer_reduction: Reduction | None
    native_reduction: Reduction
    native_minus_predictor_ci: Interval | None


@dataclass(frozen=True)
class MatcherScores(Record):
    """One matcher on one method's table split: ``n_evaluated``, the queries it evaluates itself (with a window);
    ``removed``, the seed-0 predictor's removals on the shared queries; per mode its numbers; the wrong-match
    detection of the predictor (seed 0) and of the native confidence, with the interval of the native's average
    precision minus the predictor's; ``validation_recall_at_1``, its sequence recall@1 on the shared queries of
    the validation split (None without one)."""

    n_evaluated: int
    n_wrong: int
    removed: int
    modes: dict[str, MatcherMode]
    detection_predictor: Detection
    detection_native: Detection
    native_minus_predictor_ap_ci: Interval | None
    validation_recall_at_1: float | None = None


@dataclass(frozen=True)
class MatcherComparison(FileRecord):
    """The experiment ``matchers`` of one dataset and method at one ``L`` (``main``). ``meta``: dataset, method,
    seq_len, the table
    and validation splits, modes, seeds, the compared matchers by tag (``MatcherSpec.provenance``) and the fixed
    matcher. ``n_queries``: the shared queries of the table split (every number is over them);
    ``n_queries_validation``: those of the validation split (None without one). ``matchers``: per tag, per method
    (the configuration's order) its scores. ``fixed_validation_recall_at_1``: per method, the fixed matcher's
    sequence recall@1 on the validation split's shared queries; ``warnings``: ``validation_warning``'s texts;
    ``tags``: the matchers in the configuration's order (the file's objects are written with sorted keys)."""

    meta: Json
    tags: tuple[str, ...]
    n_queries: int
    n_queries_validation: int | None
    matchers: dict[str, dict[str, MatcherScores]]
    fixed_validation_recall_at_1: dict[str, float] | None
    warnings: tuple[str, ...]


# --- the computation --------------------------------------------------------------------------------------------


def _detection(found: Detection) -> Detection:
    return replace(found, curve=None)


def score_matcher(features: QueryFeatures, predictors: Sequence[SMRPredictor], positions: np.ndarray,
                  settings: BaselineSettings, modes: Sequence[str], n_evaluated: int) -> MatcherScores:
    """One matcher's numbers on one method's features cut to the shared queries: Table I's (``evaluate_split``,
    every seed) and the training-free scorers' at the seed-0 budget (``split_baselines``)."""
    from vpr_smr.eval.scoring import scorers
    from vpr_smr.eval.scoring.baselines import Prediction, split_baselines
    from vpr_smr.eval.scoring.evaluate import evaluate_split

    split, _ = evaluate_split(features, predictors, tuple(modes), trust_levels=(), restoration=False)
    predictions = [Prediction(seed, np.asarray(p.predict_proba(features.attributes[:, 0, :])),
                              np.asarray(p.classes_)) for seed, p in enumerate(predictors)]
    found = split_baselines(features, settings, positions, predictions, modes)
    if NATIVE not in found.detection:
        raise ValueError(f"the training-free scorers hold no {NATIVE!r} confidence (the matcher's own): "
                         f"they hold {', '.join(found.detection)}")
    assert found.removal is not None and found.versus_predictor is not None  # predictions were given
    budget = found.removal[0].scorers
    out = {}
    for mode in modes:
        best = scorers.best_training_free({name: removal.modes[mode].reduction_pct for name, removal in budget.items()})
        numbers = split.modes[mode]
        out[mode] = MatcherMode(
            numbers.recall_at_1_single, numbers.recall_at_1_sequence, numbers.reduction, split.seed_summary[mode],
            best, None if best is None else budget[best].modes[mode], budget[NATIVE].modes[mode],
            found.versus_predictor[NATIVE].reduction_pct_difference_ci[mode])
    return MatcherScores(n_evaluated, found.n_wrong, split.removed, out,
                         _detection(found.detection[scorers.PREDICTOR]), _detection(found.detection[NATIVE]),
                         found.versus_predictor[NATIVE].average_precision_difference_ci)


def _sequence_recall(features: QueryFeatures) -> float:
    return float(np.mean(features.sequence_correct))


def compare(
    table: Mapping[str, Mapping[str, QueryFeatures]],
    predictors: Mapping[str, Sequence[SMRPredictor]],
    positions: Mapping[str, np.ndarray],
    settings: BaselineSettings,
    modes: Sequence[str],
    validation: Mapping[str, Mapping[str, QueryFeatures]] | None = None,
    fixed_validation: Mapping[str, QueryFeatures] | None = None,
) -> tuple[int, int | None, dict[str, dict[str, MatcherScores]], dict[str, float] | None, tuple[str, ...]]:
    """Every matcher (``table``: tag -> method -> its table split's features) scored on the shared queries with
    its own predictors (tag -> seed 0 first) and the reference ``positions`` of each method's split
    (``baselines.spread_positions``); with ``validation`` (the same matchers' validation features) and
    ``fixed_validation`` (the fixed matcher's), each matcher's validation recall@1 and the warnings.
    Returns the shared queries' counts (table, validation), the scores, the fixed matcher's recall and the
    warnings."""
    tags = list(table)
    methods = list(table[tags[0]])
    for tag in tags:
        if list(table[tag]) != methods:
            raise ValueError(f"the matcher {tag} has the methods {list(table[tag])}, {tags[0]} has {methods}")
    shared = {method: shared_queries([table[tag][method] for tag in tags]) for method in methods}
    counts = {len(queries) for queries in shared.values()}
    if len(counts) != 1:
        raise ValueError(f"the methods' table splits share different numbers of queries: {sorted(counts)}; give "
                         "every method's files of one split")
    n_queries = counts.pop()
    if n_queries == 0:
        raise ValueError(f"the matchers {', '.join(tags)} evaluate no query in common on the table split: no "
                         "comparison (shorten the sequence or give a longer split)")
    recalls: dict[str, dict[str, float]] = {tag: {} for tag in tags}
    fixed: dict[str, float] | None = None
    n_validation = None
    if validation is not None and fixed_validation is not None:
        fixed = {}
        for method in methods:
            val_shared = shared_queries([*(validation[tag][method] for tag in tags), fixed_validation[method]])
            n_validation = len(val_shared)
            if not n_validation:  # no recall to compare (not a recall of 0): no number, no warning
                continue
            fixed[method] = _sequence_recall(restricted(fixed_validation[method], val_shared))
            for tag in tags:
                recalls[tag][method] = _sequence_recall(restricted(validation[tag][method], val_shared))
    scores: dict[str, dict[str, MatcherScores]] = {}
    warnings = []
    for tag in tags:
        scores[tag] = {}
        for method in methods:
            found = table[tag][method]
            scored = score_matcher(restricted(found, shared[method]), predictors[tag], positions[method], settings,
                                   modes, len(found.queries))
            recall = recalls[tag].get(method)
            scores[tag][method] = replace(scored, validation_recall_at_1=recall)
            warning = validation_warning(tag, method, recall, None if fixed is None else fixed.get(method))
            if warning is not None:
                log.warning(warning)
                warnings.append(warning)
    return n_queries, n_validation, scores, fixed, tuple(warnings)


# --- the stage --------------------------------------------------------------------------------------------------




def main(job: MatchersJob) -> MatcherComparison:
    """The experiment ``matchers`` of one dataset and ``job.method`` at ``seq_len``, written to ``out`` (JSON,
    ``MatcherComparison``).

    ``inputs``: the compared matchers' files (``read_inputs``), each with the table split's (and the validation
    split's) attributes of ``method`` and its predictors; ``fixed``: the fixed matcher's validation attributes (the
    warning's reference; None leaves the warning out). ``distances``: ``{method: the table split's distance
    file}`` (the ground truth's reference positions, as ``vpr-smr baselines`` reads them: ``truth``). Every input
    is checked before any scoring."""
    from vpr_smr.eval.matching.attributes import Matching, check_matching, common_matching, read_features
    from vpr_smr.eval.matching.ground_truth_files import read_ground_truth
    from vpr_smr.eval.matching.io import open_distance_matrix, scored_shape, split_ground_truth
    from vpr_smr.eval.predictor.estimator import SMRPredictor
    from vpr_smr.eval.predictor.leakage import check_disjoint, check_scored, frame_ranges, trained_on
    from vpr_smr.eval.scoring.baselines import check_candidates, spread_positions

    dataset, method, seq_len, distances, table_split = job.dataset, job.method, job.seq_len, job.distances, job.split
    validation_split, settings, modes, truth = job.validation, job.baselines, job.modes, job.truth
    allow_split_overlap = job.allow_split_overlap
    out = check_suffix(job.out, JSON_SUFFIXES, "the matchers experiment's result (JSON)")
    compared, fixed = list(job.inputs.matchers), job.inputs.fixed
    tags = [matcher_tag(entry.spec) for entry in compared]
    methods = list(distances)
    if methods != [method]:
        raise ValueError(f"give the table split's distances of the method {method!r} alone (--distances "
                         f"{method}=PATH), not of {', '.join(methods) or 'none'}")
    splits = [table_split] + ([validation_split] if validation_split and fixed is not None else [])
    for entry, tag in zip(compared, tags, strict=True):
        for split in splits:
            given = list(entry.attributes.get(split, {}))
            if given != methods:
                raise ValueError(f"the matcher {tag}: its {split} attributes are of the methods {given}, the "
                                 f"distances of {methods}: give every method's, in the same order")
        if not entry.predictors:
            raise ValueError(f"the matcher {tag}: no predictor files (one per seed, seed 0 first)")
    predictors: dict[str, list[SMRPredictor]] = {}
    features: dict[str, dict[str, dict[str, QueryFeatures]]] = {split: {} for split in splits}
    for entry, tag in zip(compared, tags, strict=True):
        paths = [path for split in splits for path in entry.attributes[split].values()]
        matching = common_matching(paths)
        if matching.matcher != entry.spec:
            raise ValueError(f"{paths[0]} holds attributes of the matcher {matching.matcher}, but the experiment "
                             f"compares {entry.spec} under the tag {tag}: compute them again")
        predictors[tag] = []
        for path in entry.predictors:
            check_disjoint(trained_on(path), frame_ranges(paths), allow_split_overlap, f"predictor {path}")
            predictors[tag].append(SMRPredictor.load(path))
            check_matching(predictors[tag][-1], Matching.of(entry.spec, matching.ground_truth),
                           f"the {tag} attributes " + ", ".join(paths))
        for split in splits:
            features[split][tag] = {method: read_features(path) for method, path in entry.attributes[split].items()}
            for model in predictors[tag]:  # its length, and no matrix that shares entries with its training ones
                check_scored(model, {path: features[split][tag][method]
                                     for method, path in entry.attributes[split].items()}, allow_split_overlap)
            for method, path in entry.attributes[split].items():
                if split == table_split:
                    check_candidates(features[split][tag][method], settings, path)
    fixed_features = None
    if fixed is not None and validation_split:
        fixed_features = {method: read_features(path) for method, path in fixed.attributes[validation_split].items()}
    file_truth = None if truth.ground_truth is None else read_ground_truth(
        truth.ground_truth, truth.ground_truth_key, within=scored_shape(distances.values()))
    positions = {}
    for method, distance_path in distances.items():
        with open_distance_matrix(distance_path) as matrix:
            shape = tuple(int(n) for n in matrix.shape)
        positions[method] = spread_positions(split_ground_truth(
            distance_path, shape, truth.tolerance, truth.radius, truth.reference_positions, truth.query_positions,
            file_truth))
    n_queries, n_validation, scores, fixed_recall, warnings = compare(
        features[table_split], predictors, positions, settings, modes,
        features.get(validation_split or "") if fixed_features is not None else None, fixed_features)
    meta = {"dataset": dataset, "method": method, "seq_len": int(seq_len), "split": table_split,
            "validation_split": validation_split,
            "modes": list(modes), "seeds": len(compared[0].predictors), **settings.meta(),
            "matchers": {tag: entry.spec.provenance() for tag, entry in zip(tags, compared, strict=True)},
            "fixed": fixed_matcher().provenance(), "far_below": FAR_BELOW}
    result = MatcherComparison(meta, tuple(tags), n_queries, n_validation, scores, fixed_recall, warnings)
    save(out, result)
    log.info("%d matchers, %d methods, %d shared queries", len(tags), len(methods), n_queries)
    return result
