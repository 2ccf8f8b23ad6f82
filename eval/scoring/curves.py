"""Match removal and precision-recall (method §8), in paper and standard mode.

A curve is two arrays, recall and precision, whose first point is ``(R=0, P=1)``. Both modes share
``keep_mask`` and ``compare_curves``; only the curve differs, selected by the ``mode`` parameter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from vpr_smr.core.constants import KEPT_CLASSES, MODES

if TYPE_CHECKING:
    from vpr_smr.eval.scoring.records import Interval

PAPER_THRESHOLDS = 1999
# An AOC this small is 0: the trapezoid sum of a curve whose precision is 1 everywhere leaves about 1e-16
AOC_ZERO = 1e-9
# A reduction (per cent) of smaller magnitude is no change (method §8.4): two removals that keep the same matches
# give curves equal up to the trapezoid sums' rounding, e.g. 2.1e-14 %
UNCHANGED_PCT = 1e-6


@dataclass(frozen=True)
class Curve:
    recall: np.ndarray
    precision: np.ndarray


def keep_mask(
    predicted: np.ndarray | None = None, confidence: np.ndarray | None = None, trust: float = 0.0, n: int = 0
) -> np.ndarray:
    """Which queries keep their sequence match, before any distance threshold.

    Without a predictor every query is kept. With one, a query is kept when its predicted class is 0 or 2;
    with a trust level ``p`` the predictor only acts where its highest class probability is ``>= p``.
    """
    if predicted is None:
        return np.ones(n, dtype=bool)
    keep = np.isin(predicted, KEPT_CLASSES)
    if trust > 0:
        if confidence is None:
            raise ValueError("a trust level needs the predictor's class probabilities")
        keep |= np.asarray(confidence) < trust
    return keep


def _precision_recall(tp: np.ndarray, fp: np.ndarray, positives: int) -> Curve:
    tp = tp.astype(np.float64)
    has_tp = tp > 0
    precision = np.where(has_tp, tp / np.maximum(tp + fp, 1), 0.0)
    recall = np.where(has_tp, tp / max(positives, 1), 0.0)
    return Curve(np.concatenate([[0.0], recall]), np.concatenate([[1.0], precision]))


def paper_curve(
    distances: np.ndarray,
    correct: np.ndarray,
    keep: np.ndarray,
    sequence_min: float,
    sequence_max: float,
    n_thresholds: int = PAPER_THRESHOLDS,
) -> Curve:
    """The authors' curve: a fixed grid of thresholds over ``[S.min(), S.max()]`` of the split.

    Recall's denominator is the number of queries whose sequence match is correct; ``(0, 0)`` where TP = 0.
    """
    thresholds = np.linspace(sequence_min, sequence_max, n_thresholds)
    correct = np.asarray(correct, dtype=bool)
    tp = np.searchsorted(np.sort(distances[keep & correct]), thresholds, side="right")
    fp = np.searchsorted(np.sort(distances[keep & ~correct]), thresholds, side="right")
    return _precision_recall(tp, fp, int(correct.sum()))


def standard_curve(distances: np.ndarray, correct: np.ndarray, keep: np.ndarray) -> Curve:
    """The exact curve: one point per distinct distance of a kept match, recall over all queries."""
    correct = np.asarray(correct, dtype=bool)
    kept_distances = distances[keep]
    order = np.argsort(kept_distances, kind="stable")
    sorted_distances = kept_distances[order]
    hits = correct[keep][order]
    tp = np.cumsum(hits)
    fp = np.cumsum(~hits)
    # One point per threshold: the last of each run of equal distances.
    last = np.r_[sorted_distances[1:] != sorted_distances[:-1], True] if len(order) else np.zeros(0, bool)
    return _precision_recall(tp[last], fp[last], len(distances))


def curve(
    mode: str,
    distances: np.ndarray,
    correct: np.ndarray,
    keep: np.ndarray,
    sequence_min: float,
    sequence_max: float,
) -> Curve:
    if mode == "paper":
        return paper_curve(distances, correct, keep, sequence_min, sequence_max)
    if mode == "standard":
        return standard_curve(distances, correct, keep)
    raise ValueError(f"unknown metric mode {mode!r}; choose one of {', '.join(MODES)}")


@dataclass(frozen=True)
class Comparison:
    max_recall: float
    auc_baseline: float
    auc_predictor: float
    aoc_baseline: float
    aoc_predictor: float
    reduction_pct: float | None  # None (JSON null) when the baseline's AOC is 0: nothing to reduce
    baseline_cut: Curve
    # The baseline's own maximum recall and its AOC there: what the baseline is worth when the predictor's maximum
    # recall leaves nothing of it to compare (a predictor that removed every match cuts it at recall 0).
    max_recall_baseline: float
    aoc_baseline_own: float


def reduction_pct(aoc_before: float, aoc_after: float) -> float | None:
    """``100 (AOC_before - AOC_after) / AOC_before``; None when ``AOC_before`` is 0 (up to ``AOC_ZERO``) or either
    is not finite: a perfect baseline leaves nothing to reduce, and 0 % would read as a predictor that did nothing."""
    if not (math.isfinite(aoc_before) and math.isfinite(aoc_after)) or aoc_before <= AOC_ZERO:
        return None
    return 100.0 * (aoc_before - aoc_after) / aoc_before


def cut_curve(curve_: Curve, max_recall: float) -> Curve:
    inside = curve_.recall <= max_recall
    return Curve(curve_.recall[inside], curve_.precision[inside])


def area(curve_: Curve) -> float:
    """Area under the curve by the trapezoid rule (``sklearn.metrics.auc``)."""
    if len(curve_.recall) < 2:
        return 0.0
    from sklearn.metrics import auc  # imported here: the workflow's parsing reads this module's constants (1 s)

    return float(auc(curve_.recall, curve_.precision))


def compare_curves(baseline: Curve, predictor: Curve) -> Comparison:
    """AOC at the predictor's maximum recall: the baseline is cut to ``R <= R_max``, ``AOC = R_max - AUC``."""
    max_recall = float(predictor.recall[-1])
    baseline_cut = cut_curve(baseline, max_recall)
    auc_base, auc_pred = area(baseline_cut), area(predictor)
    # Precision <= 1, so AUC <= R_max: a negative AOC is rounding error of the trapezoid sum.
    aoc_base, aoc_pred = max(0.0, max_recall - auc_base), max(0.0, max_recall - auc_pred)
    max_recall_own = float(baseline.recall[-1])
    aoc_own = max(0.0, max_recall_own - area(baseline))
    return Comparison(max_recall, auc_base, auc_pred, aoc_base, aoc_pred, reduction_pct(aoc_base, aoc_pred),
                      baseline_cut, max_recall_own, aoc_own)


# What removing matches did to one comparison (``outcome``). All but the last three are degenerate: the reduction
# says nothing there (it is undefined, or 0 because nothing changed), so every table and sentence names them in words.
NO_CORRECT_MATCH = "no_correct_match"  # no sequence match is correct: both curves are at recall 0
REMOVED_ALL = "removed_all"  # every match removed: recall 0, nothing left to score
KEPT_NONE_CORRECT = "kept_none_correct"  # some matches kept, none of them correct: recall 0
KEPT_ALL = "kept_all"  # nothing removed: both curves are the baseline's, the reduction 0
NOTHING_TO_REDUCE = "nothing_to_reduce"  # both AOCs 0 up to the predictor's maximum recall
# the baseline's AOC 0 there and the predictor's larger: worse by an undefined %, a direction said only where the
# interval of the AOC difference earns it (``from_zero``)
WORSE_FROM_ZERO = "worse_from_zero"
IMPROVED, WORSE, UNCHANGED = "improved", "worse", "unchanged"
# A removal that lost every correct match: the reduction cannot show it (both AOCs are 0 at recall 0)
LOST_ALL = (REMOVED_ALL, KEPT_NONE_CORRECT)
# reduction_pct None; so is it for a WORSE_FROM_ZERO whose interval did not earn it (``from_zero``: ``is_from_zero``)
UNDEFINED = (NO_CORRECT_MATCH, *LOST_ALL, NOTHING_TO_REDUCE, WORSE_FROM_ZERO)
# Both AOCs are taken at recall 0 (no correct match left, or none to begin with): an AOC of 0 there says nothing
AT_RECALL_ZERO = (*LOST_ALL, NO_CORRECT_MATCH)
# Outcomes that count against a predictor wherever methods or seeds are counted as improved: the reduction is
# undefined there, but the predictor did harm. WORSE_FROM_ZERO is one only as ``from_zero`` gives it, its interval
# above 0; one whose interval holds 0 (or that has none) is no harm earned, only a comparison without a %.
HARMFUL = (*LOST_ALL, WORSE_FROM_ZERO)


def outcome(n_queries: int, removed: int, comparison: Comparison, same_matches: bool = True) -> str:
    """What removing ``removed`` of ``n_queries`` matches did, by the first that applies: no match correct to
    begin with; every match removed; none correct kept (maximum recall 0); both AOCs 0 (nothing to reduce); the
    baseline's AOC 0 and the predictor's not (worse, the percentage undefined); nothing removed (a reduction of 0);
    else improved or worse by the sign of the reduction, unchanged when its magnitude is below ``UNCHANGED_PCT``.
    The reduction is undefined (None) exactly for the outcomes of ``UNDEFINED``. Improved, worse and
    ``WORSE_FROM_ZERO`` are a point estimate's direction: a record or table says them only as ``earned`` (the
    reduction's interval) or ``from_zero`` (the AOC difference's interval) judge them. ``same_matches`` False: the
    compared curve's matches are not the baseline's (another sequence length's, method §15), so keeping every one of
    them still changes the curve: never ``KEPT_ALL``."""
    if comparison.max_recall_baseline <= 0:
        return NO_CORRECT_MATCH
    if n_queries > 0 and removed >= n_queries:
        return REMOVED_ALL
    if comparison.max_recall <= 0:
        return KEPT_NONE_CORRECT
    if comparison.reduction_pct is None:
        return WORSE_FROM_ZERO if comparison.aoc_predictor > AOC_ZERO else NOTHING_TO_REDUCE
    if removed == 0 and same_matches:
        return KEPT_ALL
    if abs(comparison.reduction_pct) < UNCHANGED_PCT:
        return UNCHANGED
    return by_sign(comparison.reduction_pct)


def by_sign(reduction_pct: float) -> str:
    """The direction a reduction's estimate points: improved above 0, else worse (what ``earned`` then judges)."""
    return IMPROVED if reduction_pct > 0 else WORSE


# What a table or the console says in place of improved or worse where the interval does not earn it (``earned``)
HOLDS_ZERO = "interval_holds_0"  # the interval holds 0
NO_INTERVAL = "no_interval"  # none: too few draws define it, or none is computed (the speed experiment, other seeds)
AGAINST_SIGN = "interval_against_sign"  # it excludes 0, on the other side from the estimate
NOT_EARNED = (HOLDS_ZERO, NO_INTERVAL, AGAINST_SIGN)  # what earned or from_zero says in place of a direction
# The outcomes of an estimate with a direction: improved or worse by its sign, and what ``earned`` says of them
DIRECTED = (IMPROVED, WORSE, *NOT_EARNED)


def earned(outcome: str, interval: Interval | None) -> str:
    """The one rule for a direction word: ``outcome`` (``outcome``'s, by the sign of a point estimate) as a table,
    the console or a sentence may say it beside ``interval``, the estimate's interval over queries: improved or
    worse only where the interval excludes 0 on the estimate's side, else ``HOLDS_ZERO``, ``NO_INTERVAL`` or
    ``AGAINST_SIGN``; any other outcome (a degenerate one, unchanged, ``WORSE_FROM_ZERO`` as ``from_zero`` gave it,
    or one this function gave) as it is."""
    wanted = {IMPROVED: 1, WORSE: -1}.get(outcome)
    return outcome if wanted is None else _judged(outcome, wanted, interval)


def from_zero(difference: Interval | None) -> str:
    """The same rule for ``WORSE_FROM_ZERO`` (the baseline's AOC 0, the predictor's larger: no reduction in per cent
    to take an interval of): ``difference`` is the interval over queries of the predictor's AOC minus the baseline's
    (``intervals.aoc_difference``), and the word is said only where it lies wholly above 0, else ``HOLDS_ZERO``,
    ``NO_INTERVAL`` (None: e.g. a seed other than 0, whose intervals are not computed) or ``AGAINST_SIGN``."""
    return _judged(WORSE_FROM_ZERO, 1, difference)


def _judged(outcome: str, wanted: int, interval: Interval | None) -> str:
    """``outcome`` where ``interval`` lies wholly on the side ``wanted`` (+1 above 0, -1 below) of 0."""
    if interval is None:
        return NO_INTERVAL
    found = interval.sign()
    return HOLDS_ZERO if found == 0 else outcome if found == wanted else AGAINST_SIGN


def is_from_zero(outcome: str, reduction_pct: float | None) -> bool:
    """The comparison's baseline AOC is 0 and the predictor's larger, whether or not an interval earned the word:
    ``WORSE_FROM_ZERO``, or the word ``from_zero`` said in its place (the other directions have a reduction)."""
    return outcome == WORSE_FROM_ZERO or (outcome in NOT_EARNED and reduction_pct is None)


def reduction_undefined(outcome: str, reduction_pct: float | None) -> bool:
    """The reduction in per cent is undefined (None): a degenerate outcome of ``UNDEFINED``, or a ``WORSE_FROM_ZERO``
    whose interval did not earn it (``is_from_zero``): left out of every mean of reductions, and named where it is."""
    return outcome in UNDEFINED or is_from_zero(outcome, reduction_pct)


def recall_at_full_precision(curve_: Curve) -> float:
    """Highest recall of a point whose precision is exactly 1."""
    return float(curve_.recall[curve_.precision == 1.0].max())
