"""Match restoration, the second filter (method §9).

After match removal, each query whose sequence match was removed looks at its next best sequence matches (ranks
1..K-1 of ``QueryFeatures``), whose attributes the predictor classifies like the rank-0 ones. The removed match is
replaced by the alternative with the highest predicted probability of its class, among the alternatives predicted
as class 0 or 2 (correct after sequence matching); ties go to the lower rank. A restored query is scored by the
correctness of the restored match itself (``rank_correct``), not of the match it replaced.

Threshold value of a restored query: it keeps its own rank-0 sequence distance ``m_a`` (``sequence_distance``).
The distance threshold is the confidence of the query's localisation, swept once per query; the authors' code does
the same (its restored matches are tested against ``min_i S``), and the alternative's own sum is not a comparable
score (the ranks are ordered by the column-normalised sums of method §5, not by ``S``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from vpr_smr.core.constants import KEPT_CLASSES
from vpr_smr.eval.matching.attributes import QueryFeatures
from vpr_smr.eval.scoring.curves import Curve, area, curve, keep_mask, reduction_pct
from vpr_smr.eval.scoring.intervals import draws, percentile_interval, weighted_restoration_reduction
from vpr_smr.eval.scoring.records import PRCurve, RestorationMode, RestorationNumbers


@dataclass(frozen=True)
class Restoration:
    """Per query: removed by the first filter, the rank restored (-1: none), and the final decision."""

    removed: np.ndarray  # (N,) bool: the predictor removed the rank-0 match
    restored_rank: np.ndarray  # (N,) int: 1..K-1 for a restored query, -1 otherwise
    keep: np.ndarray  # (N,) bool: a match is proposed (kept by the first filter, or restored)
    correct: np.ndarray  # (N,) bool: correctness of the proposed match (the restored one where restored)

    @property
    def restored(self) -> np.ndarray:
        return self.restored_rank > 0


def restore(
    features: QueryFeatures,
    probabilities: np.ndarray,
    classes: np.ndarray,
    trust: float = 0.0,
    min_score: float = 0.0,
) -> Restoration:
    """The second filter on one split.

    ``probabilities[n, k]`` are the predictor's class probabilities (columns in ``classes`` order) for the rank-``k``
    attributes of query ``n``; rank 0 decides removal (with the trust level ``trust``, as in match removal), ranks
    1.. are the alternatives. An alternative is eligible when its predicted class is 0 or 2, its probability of that
    class is at least ``min_score`` (the paper's restoration threshold; the authors use 0) and it is not the removed
    match itself (the normalised ranking of method §5 can differ from ``argmin S``).
    """
    probabilities = np.asarray(probabilities, dtype=np.float64)
    classes = np.asarray(classes)
    n, n_ranks = features.rank_references.shape
    if probabilities.shape[:2] != (n, n_ranks) or probabilities.shape[2] != len(classes):
        raise ValueError(f"probabilities of shape {probabilities.shape} do not match {n} queries, {n_ranks} ranks "
                         f"and {len(classes)} classes")
    predicted = classes[np.argmax(probabilities, axis=2)]  # (N, K)
    confidence = probabilities.max(axis=2)
    removed = ~keep_mask(predicted[:, 0], confidence[:, 0], trust)
    eligible = np.isin(predicted, KEPT_CLASSES) & (confidence >= min_score)
    eligible &= features.rank_references != features.sequence_match[:, None]
    eligible[:, 0] = False
    score = np.where(eligible, confidence, -np.inf)
    best = np.argmax(score, axis=1)  # the first maximum: ties to the lower rank
    restored = removed & eligible[np.arange(n), best]
    restored_rank = np.where(restored, best, -1)
    correct = np.where(restored, features.rank_correct[np.arange(n), best], features.sequence_correct)
    return Restoration(removed, restored_rank, ~removed | restored, correct.astype(bool))


def compare(baseline: Curve, removal: Curve, restoration: Curve) -> RestorationMode:
    """PR AUC of each curve over its own extent (the paper's numbers) and AOC at the common maximum recall.

    ``auc_difference = auc_restoration - auc_removal`` is the paper's bar (positive: restoration helps). The AOCs
    are taken at ``R = max(R_max_removal, R_max_restoration)``, ``AOC = R - AUC``, so a curve that stops at a lower
    recall counts the recall it misses as area lost; ``reduction_pct`` is the AOC reduction of restoration against
    removal, as in Table I.
    """
    max_removal, max_restoration = float(removal.recall[-1]), float(restoration.recall[-1])
    max_recall = max(max_removal, max_restoration)
    auc_removal, auc_restoration = area(removal), area(restoration)
    aoc_removal, aoc_restoration = max(0.0, max_recall - auc_removal), max(0.0, max_recall - auc_restoration)
    return RestorationMode(
        max_recall=max_recall,
        max_recall_removal=max_removal,
        max_recall_restoration=max_restoration,
        auc_vpr_sm=area(baseline),
        auc_removal=auc_removal,
        auc_restoration=auc_restoration,
        auc_difference=auc_restoration - auc_removal,
        aoc_removal=aoc_removal,
        aoc_restoration=aoc_restoration,
        aoc_difference=aoc_restoration - aoc_removal,
        reduction_pct=reduction_pct(aoc_removal, aoc_restoration),  # None when removal's AOC is 0
        curve_restoration=PRCurve.of(restoration),
        curve_vpr_sm=PRCurve.of(baseline),
        curve_removal=PRCurve.of(removal),
    )


def evaluate_restoration(
    features: QueryFeatures,
    probabilities: np.ndarray,
    classes: np.ndarray,
    modes: tuple[str, ...],
    trust: float = 0.0,
    min_score: float = 0.0,
    intervals: bool = False,
) -> RestorationNumbers:
    """Counts of the second filter and, per mode, the three curves (baseline, removal, restoration) compared; with
    ``intervals``, the bootstrap interval over queries (method §8.7) of each mode's ``reduction_pct``."""
    result = restore(features, probabilities, classes, trust, min_score)
    restored = result.restored
    n_ranks = features.rank_references.shape[1]
    distances, s_range = features.sequence_distance, (features.sequence_min, features.sequence_max)
    n = len(distances)
    modes_ = {}
    for mode in modes:
        baseline = curve(mode, distances, features.sequence_correct, keep_mask(n=n), *s_range)
        removal = curve(mode, distances, features.sequence_correct, ~result.removed, *s_range)
        restoration = curve(mode, distances, result.correct, result.keep, *s_range)
        modes_[mode] = compare(baseline, removal, restoration)
        if intervals:
            def statistic(weights: np.ndarray, mode: str = mode) -> np.ndarray:
                return weighted_restoration_reduction(mode, distances, (features.sequence_correct, ~result.removed),
                                                      (result.correct, result.keep), weights, *s_range)
            modes_[mode] = replace(modes_[mode], reduction_pct_ci=percentile_interval(draws(statistic, n)))
    return RestorationNumbers(
        trust=trust,
        min_score=min_score,
        removed=int(result.removed.sum()),
        restored=int(restored.sum()),
        restored_correct=int((restored & result.correct).sum()),
        restored_wrong=int((restored & ~result.correct).sum()),
        wrong_to_right=int((restored & result.correct & ~features.sequence_correct).sum()),
        right_to_wrong=int((restored & ~result.correct & features.sequence_correct).sum()),
        restored_by_rank=tuple(int((result.restored_rank == k).sum()) for k in range(1, n_ranks)),
        modes=modes_,
    )
