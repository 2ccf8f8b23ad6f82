"""Evaluation of one method on one dataset: match removal by the predictor, PR curves, AOC, F1 (method §§7-9).

The seed-0 predictor (the authors' recipe) gives every curve and the headline numbers; every other seed's predictor
gives the reduction and AOC numbers under ``other_seeds``, and every seed's are summarised in ``seed_summary``, so a
table can show their spread.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from sklearn.metrics import confusion_matrix

from vpr_smr.core import environment
from vpr_smr.core.constants import DEFAULT_TRUST_LEVELS, LABELS, MODES
from vpr_smr.core.io import JSON_SUFFIXES, check_suffix, read_provenance
from vpr_smr.core.paths import timing_path
from vpr_smr.core.records import save
from vpr_smr.eval.matching.attributes import (
    QueryFeatures,
    check_matching,
    check_seq_len,
    common_matching,
    read_features,
    recorded_matching,
)
from vpr_smr.eval.predictor.estimator import SMRPredictor, macro_f1
from vpr_smr.eval.predictor.jobs import EvaluateJob as EvaluateJob  # the stage's job, named here too
from vpr_smr.eval.predictor.leakage import check_disjoint, check_scored, frame_ranges, trained_on
from vpr_smr.eval.scoring.curves import (
    WORSE_FROM_ZERO,
    Comparison,
    Curve,
    compare_curves,
    curve,
    from_zero,
    is_from_zero,
    keep_mask,
    outcome,
    recall_at_full_precision,
)
from vpr_smr.eval.scoring.intervals import WeightedComparison, aoc_difference, comparison_draws, percentile_interval
from vpr_smr.eval.scoring.records import (
    Evaluation,
    EvaluationSplit,
    ModeRemoval,
    PRCurve,
    Reduction,
    Removal,
    RemovalCurves,
    RestorationNumbers,
    SeedNumbers,
    SeedSummary,
    SplitTiming,
    Timing,
    TrustNumbers,
)
from vpr_smr.eval.scoring.restoration import evaluate_restoration


def rank_probabilities(predictor: Any, features: QueryFeatures, ranks: int | None = None) -> np.ndarray:
    """``(N, K, C)`` class probabilities of the attributes of ranks ``0..K-1`` (A1..A4 order, as the predictor
    takes them); ``ranks=1`` gives rank 0 only."""
    n_ranks = features.attributes.shape[1] if ranks is None else ranks
    return np.stack([predictor.predict_proba(features.attributes[:, k, :]) for k in range(n_ranks)], axis=1)


def recall_at_1(features: QueryFeatures, mode: str) -> tuple[float, float]:
    """Recall@1 before and after sequence matching (single-frame, sequence), by the mode's rule (method §8).

    Paper mode divides single-frame recall by every query of the split (the first ``L-1`` included, as the
    authors do); standard mode by the evaluated queries (those with a sequence match).
    """
    single = features.all_single_correct if mode == "paper" else features.single_correct
    return float(np.mean(single)), float(features.sequence_correct.mean())


def compare_removal(features: QueryFeatures, mode: str, keep: np.ndarray, intervals: bool = False
                    ) -> tuple[Curve, Curve, Reduction]:
    """One removal of matches (``keep``: the matches kept) against VPR+SM in ``mode`` (method §8): the baseline's
    curve, the curve with the removal, and Table I's numbers of the two (with ``intervals``, their bootstrap
    intervals over queries, method §8.7)."""
    n = len(features.queries)
    distances, correct = features.sequence_distance, features.sequence_correct
    s_range = (features.sequence_min, features.sequence_max)
    baseline = curve(mode, distances, correct, keep_mask(n=n), *s_range)
    kept = curve(mode, distances, correct, keep, *s_range)
    reduction = reduction_of(compare_curves(baseline, kept), n, int((~keep).sum()))
    if intervals:
        reduction = with_intervals(reduction, removal_draws(features, mode, [keep])[0])
    return baseline, kept, reduction


def reduction_of(comparison: Comparison, n_queries: int, removed: int, same_matches: bool = True) -> Reduction:
    """Table I's numbers of one comparison of curves (``curves.compare_curves``), with the removal's ``outcome``
    (``same_matches``: as ``curves.outcome`` takes it) as a record says it without intervals (``judged``);
    ``with_intervals`` judges it again by its intervals."""
    return Reduction(comparison.max_recall, comparison.auc_baseline, comparison.auc_predictor,
                     comparison.aoc_baseline, comparison.aoc_predictor, comparison.reduction_pct,
                     comparison.max_recall_baseline, comparison.aoc_baseline_own,
                     judged(outcome(n_queries, removed, comparison, same_matches), None))


def judged(found: str, draws: WeightedComparison | None) -> str:
    """``curves.outcome``'s ``found`` as a record keeps it: a ``WORSE_FROM_ZERO`` by the interval of its AOC
    difference over ``draws`` (``curves.from_zero``; None: no interval, ``NO_INTERVAL``), any other as it is (the
    records judge improved and worse by the reduction's interval, ``curves.earned``)."""
    return from_zero(None if draws is None else aoc_difference(draws)) if found == WORSE_FROM_ZERO else found


def removal_draws(features: QueryFeatures, mode: str, keeps: Sequence[np.ndarray]) -> list[WeightedComparison]:
    """Each removal of ``keeps`` against VPR+SM in ``mode`` on every bootstrap draw of the split's queries (method
    §8.7): the same draws for all, so that differences between them are paired."""
    return comparison_draws(mode, features.sequence_distance, features.sequence_correct, keeps,
                            features.sequence_min, features.sequence_max)


def with_intervals(reduction: Reduction, draws: WeightedComparison) -> Reduction:
    """``reduction`` with the percentile intervals of its reduction and AOCs over ``draws`` (of the same removal),
    and its outcome judged by them: improved or worse by the reduction's (the record's own rule), worse from a
    perfect baseline by the AOC difference's (``judged``), which the record keeps as ``aoc_difference_ci`` so that
    the word is shown beside the interval that earned it (None for any other outcome)."""
    found = WORSE_FROM_ZERO if is_from_zero(reduction.outcome, reduction.reduction_pct) else reduction.outcome
    difference = aoc_difference(draws) if found == WORSE_FROM_ZERO else None
    return replace(reduction, reduction_pct_ci=percentile_interval(draws.reduction_pct),
                   aoc_vpr_sm_ci=percentile_interval(draws.aoc_baseline),
                   aoc_vpr_sm_pred_ci=percentile_interval(draws.aoc_predictor),
                   outcome=from_zero(difference) if found == WORSE_FROM_ZERO else found, aoc_difference_ci=difference)


def _mode_removal(
    features: QueryFeatures,
    mode: str,
    predicted: np.ndarray,
    confidence: np.ndarray,
    trust_levels: tuple[float, ...],
    curves: bool,
    intervals: bool,
) -> ModeRemoval:
    """One mode of ``removal``: the baseline against the predictor, and per trust level the AUC (and curve); with
    ``intervals`` the reductions' bootstrap intervals (one pass over the draws for all of them)."""
    n = len(features.queries)
    distances, correct = features.sequence_distance, features.sequence_correct
    s_range = (features.sequence_min, features.sequence_max)
    keep = keep_mask(predicted, confidence)
    trust_keeps = [keep_mask(predicted, confidence, level) for level in trust_levels]
    draws = removal_draws(features, mode, [keep, *trust_keeps]) if intervals else None
    baseline, with_predictor, reduction = compare_removal(features, mode, keep)
    if draws is not None:
        reduction = with_intervals(reduction, draws[0])
    removal_curves = RemovalCurves(recall_at_full_precision(baseline), recall_at_full_precision(with_predictor),
                                   PRCurve.of(baseline), PRCurve.of(with_predictor)) if curves else None
    trust, trust_numbers = {}, {}
    for index, (level, level_keep) in enumerate(zip(trust_levels, trust_keeps, strict=True)):
        trust_curve = curve(mode, distances, correct, level_keep, *s_range)
        level_comparison = compare_curves(baseline, trust_curve)
        trust[str(level)] = PRCurve.of(trust_curve)
        removed = int((~level_keep).sum())
        trust_numbers[str(level)] = TrustNumbers(
            removed, level_comparison.max_recall, level_comparison.auc_predictor,
            level_comparison.aoc_predictor, level_comparison.auc_baseline, level_comparison.aoc_baseline,
            level_comparison.reduction_pct,
            judged(outcome(n, removed, level_comparison), None if draws is None else draws[1 + index]),
            percentile_interval(draws[1 + index].reduction_pct) if draws is not None else None)
    return ModeRemoval(*recall_at_1(features, mode), reduction, removal_curves,
                       trust_numbers if trust_levels else None, trust if trust_levels and curves else None)


def removal(
    features: QueryFeatures,
    probabilities: np.ndarray,
    classes: np.ndarray,
    modes: tuple[str, ...] = MODES,
    trust_levels: tuple[float, ...] = (),
    curves: bool = True,
    intervals: bool = False,
) -> Removal:
    """Match removal (the first filter) by one predictor's rank-0 probabilities ``(N, C)``: per mode the baseline
    against the predictor, and per trust level the AUC (and, with ``curves``, every curve; with ``intervals``, the
    reductions' bootstrap intervals over queries)."""
    predicted = np.asarray(classes)[np.argmax(probabilities, axis=1)]
    confidence = probabilities.max(axis=1)
    return Removal(
        predicted, macro_f1(features.labels, predicted), int((~keep_mask(predicted, confidence)).sum()),
        {mode: _mode_removal(features, mode, predicted, confidence, trust_levels, curves, intervals)
         for mode in modes})


def seed_summary(seeds: Sequence[SeedNumbers]) -> dict[str, SeedSummary]:
    """Per mode: mean, sample standard deviation (ddof 1; None under two seeds), min and max of ``reduction_pct`` over
    the ``n_seeds_defined`` of the ``n_seeds`` seeds where it is defined (all None when it is nowhere), and every
    seed's outcome, which says why a seed is left out."""
    return summarise_seeds({s.seed: s.modes for s in seeds})


def summarise_seeds(seeds: Mapping[int, Mapping[str, Reduction]]) -> dict[str, SeedSummary]:
    """``seed_summary`` of every seed's reductions per mode (seed -> mode -> its numbers), in the mapping's order."""
    out = {}
    for mode in next(iter(seeds.values())):
        reductions = [numbers[mode].reduction_pct for numbers in seeds.values()]
        values = np.array([v for v in reductions if v is not None], dtype=np.float64)
        defined = len(values) > 0
        out[mode] = SeedSummary(
            n_seeds=len(reductions),
            n_seeds_defined=len(values),
            reduction_pct_mean=float(values.mean()) if defined else None,
            reduction_pct_std=float(values.std(ddof=1)) if len(values) > 1 else None,
            reduction_pct_min=float(values.min()) if defined else None,
            reduction_pct_max=float(values.max()) if defined else None,
            outcomes={seed: numbers[mode].outcome for seed, numbers in seeds.items()},
        )
    return out


def _without_shared_curves(restoration: RestorationNumbers) -> RestorationNumbers:
    """Restoration as an evaluation keeps it: its baseline and removal curves are the mode's ``curve_vpr_sm`` and
    ``curve_vpr_sm_pred`` (seed 0, trust 0), kept once."""
    modes = {mode: replace(numbers, curve_vpr_sm=None, curve_removal=None)
             for mode, numbers in restoration.modes.items()}
    return replace(restoration, modes=modes)


def evaluate_split(
    features: QueryFeatures,
    predictors: SMRPredictor | Sequence[SMRPredictor],
    modes: tuple[str, ...] = MODES,
    trust_levels: tuple[float, ...] = DEFAULT_TRUST_LEVELS,
    restoration: bool = False,
    seeds: Sequence[int] | None = None,
) -> tuple[EvaluationSplit, float]:
    """Numbers and curves of one split: baseline (VPR+SM) against match removal (+Pred), per seed, and restoration;
    with the seconds the seed-0 predictor took to classify the split (a timing, kept out of the record).

    ``predictors`` are in seed order, seed 0 first: the first gives the curves, the predictor's own numbers
    (macro F1, confusion matrix), restoration and the bootstrap intervals over queries (method §8.7); each gives
    one entry of the split's ``seeds`` (the first's are its own numbers, written once; the others' spread is the
    seeds' spread, without intervals).
    """
    predictors = [predictors] if isinstance(predictors, SMRPredictor) else list(predictors)
    seeds = list(range(len(predictors))) if seeds is None else list(seeds)
    if len(seeds) != len(predictors):
        raise ValueError(f"{len(predictors)} predictors but {len(seeds)} seeds")
    first = predictors[0]
    start = time.perf_counter()
    probabilities = first.predict_proba(features.attributes[:, 0, :])
    predict_seconds = time.perf_counter() - start
    numbers = removal(features, probabilities, first.classes_, tuple(modes), tuple(trust_levels), intervals=True)
    seed_numbers = [SeedNumbers.of(seed, numbers if predictor is first else removal(
        features, predictor.predict_proba(features.attributes[:, 0, :]), predictor.classes_, tuple(modes),
        curves=False)) for seed, predictor in zip(seeds, predictors, strict=True)]
    restored = None
    if restoration:
        restored = _without_shared_curves(evaluate_restoration(
            features, rank_probabilities(first, features), first.classes_, tuple(modes), intervals=True))
    split = EvaluationSplit(
        n_queries=len(features.queries),
        n_queries_split=len(features.all_single_correct),
        # single-frame recall@1 by both rules: over the split's every query (paper) and the evaluated ones (standard)
        recall_at_1_single_all=float(np.mean(features.all_single_correct)),
        recall_at_1_single_evaluated=float(features.single_correct.mean()),
        recall_at_1_sequence=float(features.sequence_correct.mean()),
        f1_macro=numbers.f1_macro,
        confusion_matrix=tuple(map(tuple, confusion_matrix(features.labels, numbers.predicted,
                                                           labels=LABELS).tolist())),
        class_counts=tuple(np.bincount(features.labels, minlength=4).tolist()),
        predicted_counts=tuple(np.bincount(numbers.predicted, minlength=4).tolist()),
        removed=numbers.removed,
        modes=numbers.modes,
        seed=seed_numbers[0].seed,
        other_seeds=tuple(seed_numbers[1:]),
        seed_summary=seed_summary(seed_numbers),
        restoration=restored,
    )
    return split, predict_seconds


def main(job: EvaluateJob, seeds: Sequence[int] | None = None) -> tuple[Evaluation, Timing]:
    """Evaluate every split of ``job.attributes`` (e.g. val and test; files of ``job.seq_len``) with the predictors
    of ``job.predictors`` (seed order, seed 0 first; seeds numbered 0.. unless ``seeds`` is given) and write the
    evaluation to ``out`` and its timings per split (``attributes_seconds`` from the features file,
    ``predict_seconds``, their sum per query ``seconds_per_query``) to ``core.paths.timing_path(out)``; return
    both."""
    features_paths, predictor_paths, out = job.attributes, job.predictors, job.out
    modes, trust_levels, allow_split_overlap = job.modes, job.trust_levels, job.allow_split_overlap
    meta = {"dataset": job.dataset, "method": job.method, "seq_len": job.seq_len}
    check_suffix(out, JSON_SUFFIXES, "the evaluation (JSON; its timings go beside it)")
    check_seq_len(list(features_paths.values()), job.seq_len)
    if not predictor_paths:
        raise ValueError("evaluate needs at least one predictor file (seed 0 first)")
    predictors = []
    matching = common_matching(list(features_paths.values()))
    for path in predictor_paths:
        if not Path(path).is_file():
            raise FileNotFoundError(f"predictor file not found: {path} (train it first: vpr-smr train)")
        check_disjoint(trained_on(path), frame_ranges(features_paths.values()), allow_split_overlap,
                       f"predictor {path}")
        predictors.append(SMRPredictor.load(path))
        check_matching(predictors[-1], matching, "the attributes " + ", ".join(map(str, features_paths.values())))
    for split, path in features_paths.items():
        if not Path(path).is_file():
            raise FileNotFoundError(f"features of split {split!r} not found: {path} (run vpr-smr attributes)")
    read = {split: read_features(path) for split, path in features_paths.items()}
    for model in predictors:  # its length, and no matrix that shares entries with its training ones
        check_scored(model, {str(features_paths[split]): found for split, found in read.items()}, allow_split_overlap)
    splits: dict[str, EvaluationSplit] = {}
    timings: dict[str, SplitTiming] = {}
    for split, path in features_paths.items():
        features = read[split]
        splits[split], predict_seconds = evaluate_split(features, predictors, tuple(modes), tuple(trust_levels),
                                                        job.restoration, seeds)
        # Timings change from run to run: they go in their own file, so that two runs give identical results.
        attributes_seconds = float(read_provenance(path).get("attributes_seconds", 0.0))
        timings[split] = SplitTiming.of(attributes_seconds, predict_seconds, splits[split].n_queries)
    meta = {**recorded_matching(list(features_paths.values())), **meta, **environment.recorded()}
    evaluation = Evaluation(meta, tuple(str(p) for p in predictor_paths), splits)
    timing = Timing(dict(evaluation.meta), timings)
    save(timing_path(out), timing)
    save(out, evaluation)
    return evaluation, timing
