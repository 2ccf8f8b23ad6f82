"""Is the predictor better than a simple rule? The training-free scorers of method §12 and their two protocols.
Each scorer is one entry of ``scorers.REGISTRY`` (its kind, colour, description, settings and confidence).

Every scorer gives each evaluated query ``a`` a confidence ``c_a`` (higher: its sequence match more likely correct).
They are pure functions of the candidates the sequence matcher keeps with the attributes (``QueryFeatures``' ``n``
smallest ``S[r, a]`` and ``D[r, a]`` of each query and their references), the sequence distance ``m_a``, the ground
truth's verdicts and the settings (``BaselineSettings``), so no distance matrix is read here:

- ``uniqueness``: SeqSLAM's windowed uniqueness, the smallest ``S`` outside ``|r - r*| <= w`` over ``m_a``
  (``w = floor(r_window / 2)``, ``core.constants.half_window``); 1 when no end reference lies outside the window or both
  numbers are 0, ``+inf`` when only ``m_a`` is;
- ``single_uniqueness``: the same on the query's own column ``D[:, a]`` around the single-frame match;
- ``spread``: minus the population standard deviation of the positions of the ``K`` best end references (frame
  indices, or with positions the root of the summed per-axis variances);
- ``native``: the matcher's own confidence (method §14), its numbers (``QueryFeatures.sequence_native``) or the scorer
  above it names (``uniqueness`` for seqslam);
- ``distance``: ``-m_a``; ``random``: ``numpy.random.default_rng(seed).permutation(N)``; ``oracle``: 1 for a correct
  sequence match, 0 for a wrong one; ``predictor``: ``1 - P(class 1) - P(class 3)``.

The protocols: ``removal_at_budget`` (each scorer removes as many matches as a predictor seed does, the ``k`` lowest
``c_a`` by a stable sort; the oracle the wrong matches of smallest ``m_a``, at most all of them), scored by Table I's
numbers (``evaluate.compare_removal``: one PR curve, AOC and reduction for everything); ``detection`` (average
precision and ROC AUC of ``-c_a`` against the wrong matches, threshold-free).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from functools import partial

import numpy as np

from vpr_smr.core.constants import MODES
from vpr_smr.eval.matching.attributes import QueryFeatures
from vpr_smr.eval.matching.ground_truth import POSITIONS, GroundTruth, PositionTruth
from vpr_smr.eval.scoring import scorers
from vpr_smr.eval.scoring.curves import keep_mask
from vpr_smr.eval.scoring.evaluate import compare_removal, removal_draws, with_intervals
from vpr_smr.eval.scoring.intervals import draws, percentile_interval, weighted_average_precision
from vpr_smr.eval.scoring.records import (
    BudgetRemoval,
    Detection,
    PRCurve,
    ScorerRemoval,
    SplitBaselines,
    Versus,
)
from vpr_smr.eval.scoring.scorers import (
    DEFAULT_SETTINGS,
    ORACLE,
    PREDICTOR,
    RANDOM,
    BaselineSettings,
    predictor_confidence,
    random_scores,
    spread,
    uniqueness,
)

__all__ = [
    "DEFAULT_SETTINGS", "ORACLE", "PREDICTOR", "RANDOM", "SCORERS", "TRAINING_FREE", "BaselineSettings", "Prediction",
    "check_candidates",
    "detection", "keep_lowest", "oracle_keep", "predictor_confidence", "query_scores", "random_scores",
    "removal_at_budget", "split_baselines", "spread", "spread_positions", "uniqueness",
]

# the registry's names as declared, for callers that read them once; the code here reads ``scorers.REGISTRY`` as it
# runs (``scorers.names``, ``scorers.training_free``)
SCORERS = scorers.names()
TRAINING_FREE = scorers.training_free()


@dataclass(frozen=True)
class Prediction:
    """One predictor seed on a split's rank-0 attributes: its class probabilities (columns in ``classes`` order)."""

    seed: int
    probabilities: np.ndarray  # (N, C)
    classes: np.ndarray  # (C,)

    @property
    def keep(self) -> np.ndarray:
        """The matches it keeps (method §8, trust level 0): its predicted class is 0 or 2."""
        return keep_mask(self.classes[np.argmax(self.probabilities, axis=1)], self.probabilities.max(axis=1))


# --- the one use of the ground truth beyond the matches' verdicts -----------------------------------------------


def spread_positions(truth: GroundTruth) -> np.ndarray:
    """The reference positions ``spread`` measures: those of a ground truth of positions (``(R,)`` or ``(R, d)``),
    else the frame indices ``0 .. R-1`` (frames within a tolerance, a matrix or per-query lists). The one place the
    scorers read a ground truth: every verdict they use is ``QueryFeatures.sequence_correct``
    (``GroundTruth.correct`` of the attributes stage)."""
    if isinstance(truth, PositionTruth) and truth.kind == POSITIONS:
        return truth.reference_positions
    return np.arange(truth.shape[0], dtype=np.float64)


def check_candidates(features: QueryFeatures, settings: BaselineSettings, where: str, other_fix: str = "") -> None:
    """ValueError naming ``where`` (the attributes file) when it keeps fewer candidates per query than the
    scorers' settings need, or no native confidence of its matcher (neither its numbers nor the scorer it names)
    (``other_fix``: another way out the stage offers, said after the first)."""
    if features.sequence_native is None and features.native_scorer is None:
        raise ValueError(f"{where}: {scorers.NO_NATIVE}: compute the attributes again with vpr-smr attributes"
                         + (f", {other_fix}" if other_fix else ""))
    held, needed = features.n_candidates, settings.candidates
    if held < needed:
        what = "no candidates" if held == 0 else f"{held} candidates per query"
        raise ValueError(f"{where} holds {what} for the training-free scorers, but r_window {settings.r_window} and "
                         f"spread_k {settings.spread_k} need {needed} (the smallest S and D values of each query): "
                         f"compute the attributes again with vpr-smr attributes --candidates {needed}"
                         + (f", {other_fix}" if other_fix else ""))


# --- the scorers ----------------------------------------------------------------------------------------------


def query_scores(features: QueryFeatures, settings: BaselineSettings, positions: np.ndarray, seed: int = 0,
                 prediction: Prediction | None = None) -> dict[str, np.ndarray]:
    """Every registered scorer's ``c_a`` of one split's evaluated queries, in ``scorers.REGISTRY``'s order (each
    by its ``confidence``): ``random`` of ``seed``, ``predictor`` only with ``prediction``. The features must hold
    the candidates (``check_candidates``)."""
    if features.sequence_candidates is None or features.single_candidates is None:
        raise ValueError("the features hold no candidates for the training-free scorers")
    scores = {}
    for one in scorers.REGISTRY:
        if one.confidence is not None:
            scores[one.name] = one.confidence(features, settings, positions, seed)
        elif prediction is not None:  # the predictor
            scores[one.name] = predictor_confidence(prediction.probabilities, prediction.classes)
    return scores


# --- removal at the predictor's budget (method §12.2) ---------------------------------------------------------


def keep_lowest(confidence: np.ndarray, budget: int) -> np.ndarray:
    """The keep-mask that removes the ``budget`` queries of lowest ``confidence`` (a stable sort: among equal values
    the lower query index goes first)."""
    keep = np.ones(len(confidence), dtype=bool)
    keep[np.argsort(confidence, kind="stable")[:budget]] = False
    return keep


def oracle_keep(distances: np.ndarray, correct: np.ndarray, budget: int) -> np.ndarray:
    """The oracle's keep-mask: it removes the wrong matches of smallest sequence distance first (equal distances:
    the lower query index), ``budget`` of them or all of them when there are fewer."""
    wrong = np.flatnonzero(~np.asarray(correct, dtype=bool))
    keep = np.ones(len(correct), dtype=bool)
    keep[wrong[np.argsort(np.asarray(distances)[wrong], kind="stable")][:budget]] = False
    return keep


def removal_at_budget(features: QueryFeatures, scores: Mapping[str, np.ndarray], prediction: Prediction,
                      modes: Sequence[str] = MODES, intervals: bool = False) -> BudgetRemoval:
    """Every scorer of ``scores`` (``predictor`` by the prediction's own removal, ``oracle`` by ``oracle_keep``, the
    others by ``keep_lowest``) removing as many matches as ``prediction`` does, each scored against VPR+SM by
    ``evaluate.compare_removal`` in ``modes`` (with ``intervals``, with its bootstrap intervals over queries)."""
    return _removal_at_budget(features, scores, prediction, modes, intervals)[0]


def _removal_at_budget(features: QueryFeatures, scores: Mapping[str, np.ndarray], prediction: Prediction,
                       modes: Sequence[str], intervals: bool) -> tuple[BudgetRemoval, dict[str, dict[str, np.ndarray]]]:
    """``removal_at_budget``; with ``intervals`` every reduction with its bootstrap intervals (method §8.7) and,
    per mode and scorer, its reduction on every draw (the same draws for all: VPR+SM's curve once per block)."""
    keep_predictor = prediction.keep
    budget = int((~keep_predictor).sum())
    keeps = {}
    for name in (n for n in scorers.names() if n in scores or n == PREDICTOR):
        if name == PREDICTOR:
            keeps[name] = keep_predictor
        elif name == ORACLE:
            keeps[name] = oracle_keep(features.sequence_distance, features.sequence_correct, budget)
        else:
            keeps[name] = keep_lowest(scores[name], budget)
    numbers = {name: {mode: compare_removal(features, mode, keep)[2] for mode in modes}
               for name, keep in keeps.items()}
    reductions: dict[str, dict[str, np.ndarray]] = {}
    if intervals:
        for mode in modes:
            found = removal_draws(features, mode, list(keeps.values()))
            reductions[mode] = {name: drawn.reduction_pct for name, drawn in zip(keeps, found, strict=True)}
            for name, drawn in zip(keeps, found, strict=True):
                numbers[name][mode] = with_intervals(numbers[name][mode], drawn)
    out = {name: ScorerRemoval(int((~keep).sum()), numbers[name]) for name, keep in keeps.items()}
    return BudgetRemoval(prediction.seed, budget, out), reductions


# --- detecting wrong matches (method §12.3) -------------------------------------------------------------------


def detection(wrong: np.ndarray, confidence: np.ndarray, curve: bool = True) -> Detection:
    """Average precision and ROC AUC of ranking the queries by ``-confidence`` against ``wrong`` (the positives),
    as scikit-learn's ``average_precision_score`` and ``roc_auc_score`` define them: one point per distinct
    threshold (equal scores enter together), ``AP = sum (R_i - R_{i-1}) P_i``, the ROC area by the trapezoid rule.
    Infinite confidences rank as any other value. ``curve``: also the PR curve's points where recall grows."""
    wrong = np.asarray(wrong, dtype=bool)
    score = -np.asarray(confidence, dtype=np.float64)
    positives = int(wrong.sum())
    negatives = len(wrong) - positives
    if positives == 0:
        return Detection(None, None, None)
    order = np.argsort(-score, kind="stable")  # the most suspect first
    ranked, hits = score[order], wrong[order]
    last = np.r_[ranked[1:] != ranked[:-1], True]  # the last query of each run of equal scores: one threshold
    tp, fp = np.cumsum(hits)[last], np.cumsum(~hits)[last]
    precision, recall = tp / (tp + fp), tp / positives
    average_precision = float(np.sum(np.diff(np.r_[0.0, recall]) * precision))
    roc_auc = None
    if negatives > 0:
        tpr, fpr = np.r_[0.0, recall], np.r_[0.0, fp / negatives]
        roc_auc = float(np.sum(np.diff(fpr) * (tpr[1:] + tpr[:-1]) / 2))
    points = None
    if curve:
        grows = np.diff(np.r_[0, tp]) > 0
        points = PRCurve(tuple(recall[grows].tolist()), tuple(precision[grows].tolist()))
    return Detection(average_precision, roc_auc, points)


# --- one split ------------------------------------------------------------------------------------------------


def split_baselines(features: QueryFeatures, settings: BaselineSettings, positions: np.ndarray,
                    predictions: Sequence[Prediction] = (), modes: Sequence[str] = MODES) -> SplitBaselines:
    """Both protocols of method §12 on one split: every scorer's wrong-match detection (``random`` and
    ``predictor`` by the first prediction's seed, 0 without one; ``random`` also per seed), and with
    ``predictions`` (one per predictor seed, the first first) every scorer's removal at each seed's budget.

    The first seed's numbers carry their bootstrap intervals over queries (method §8.7): every scorer's detection
    AP, its removal at the first budget, and (``versus_predictor``) each training-free scorer against the predictor,
    paired over the same draws."""
    seeds = tuple(p.seed for p in predictions) or (0,)
    first = predictions[0] if predictions else None
    scores = query_scores(features, settings, positions, seeds[0], first)
    wrong = ~np.asarray(features.sequence_correct, dtype=bool)
    n = len(features.queries)
    precisions = {name: draws(partial(weighted_average_precision, wrong, value), n) for name, value in scores.items()}
    found = {name: replace(detection(wrong, value), average_precision_ci=percentile_interval(precisions[name]))
             for name, value in scores.items()}
    random_found = tuple(detection(wrong, random_scores(n, seed), curve=False) for seed in seeds)
    removal, versus = None, None
    if predictions:
        assert first is not None
        first_removal, reductions = _removal_at_budget(features, scores, first, modes, intervals=True)
        removal = (first_removal, *(removal_at_budget(features, {**scores, RANDOM: random_scores(n, p.seed)}, p,
                                                      modes) for p in predictions[1:]))
        versus = {name: Versus(
            {mode: percentile_interval(reductions[mode][name] - reductions[mode][PREDICTOR]) for mode in modes},
            percentile_interval(precisions[name] - precisions[PREDICTOR]))
            for name in scorers.training_free() if name in scores}
    return SplitBaselines(n, int(wrong.sum()), seeds, found, random_found, removal, versus)
