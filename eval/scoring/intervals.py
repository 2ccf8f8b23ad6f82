"""Bootstrap intervals over queries (method §8.7): how far a number of a split could move with other queries.

One resampling serves every number of a split: ``RESAMPLES`` draws of the split's evaluated queries with
replacement, in runs of ``block_length`` consecutive queries (a circular block bootstrap: neighbouring queries share
frames of their sequences and of the route, so they are not drawn as if independent), each turned into per-query
multiplicities (``query_weights``). A number's interval is the 2.5th and 97.5th percentile of its value over the
draws (the percentile bootstrap). Because every scorer, seed and mode of a split sees the same draws, the interval of a
difference between two of them (``difference``) is paired: it is the percentile interval of the per-draw difference.

A draw repeats some queries and leaves others out; a number on a draw is the number computed on those queries, with
every repeated query counted as often as drawn. The curves and areas below are the rules of ``curves`` and
``baselines.detection`` with per-query weights in place of counting each query once, and equal, draw by draw, to
those functions applied to the drawn queries (the tests check it). Where a number is undefined on a draw (a
reduction whose baseline leaves nothing to reduce, an average precision without a wrong match), the draw is left
out; fewer than ``MIN_DEFINED`` of the draws defined and there is no interval (None), which every table and
sentence names in words.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from vpr_smr.eval.scoring.curves import AOC_ZERO, PAPER_THRESHOLDS
from vpr_smr.eval.scoring.records import Interval as Interval  # the record, written in the results' files

CONFIDENCE = 0.95
RESAMPLES = 1000
BOOTSTRAP_SEED = 0
# An interval needs this share of the draws defined: below it, the defined draws are a biased sample of the split
MIN_DEFINED = CONFIDENCE
# Draws computed at once: a (CHUNK x queries) block of weights and of cumulative sums stays a few tens of MB
CHUNK = 100


Statistic = Callable[[np.ndarray], np.ndarray]  # (draws x queries) weights -> one value per draw (NaN: undefined)


def block_length(n_queries: int) -> int:
    """The runs a draw takes: ``n^(1/3)`` queries rounded up (the smallest ``b`` with ``b^3 >= n``), the usual order
    of a block bootstrap's block for a variance or an interval; 14 for 2573 queries, 4 for 28, 1 for one query."""
    block = 1
    while block**3 < n_queries:
        block += 1
    return block


def query_weights(n_queries: int, resamples: int | None = None, seed: int = BOOTSTRAP_SEED
                  ) -> Iterator[np.ndarray]:
    """The draws as chunks of per-query multiplicities, ``CHUNK`` draws a chunk: row ``d`` counts how often each
    query is in draw ``d``. A draw takes ``k = ceil(n / b)`` runs of ``b = block_length(n)`` consecutive queries,
    each from a start drawn uniformly, wrapping past the last query to the first, and keeps the first ``n`` queries
    of the ``k b``. The starts of draw ``d`` are row ``d`` of ``default_rng(seed).integers(0, n, (resamples, k))``,
    whatever the chunk size (``resamples``: ``RESAMPLES`` unless given). With ``b = 1`` it is the plain bootstrap."""
    resamples = RESAMPLES if resamples is None else resamples
    rng = np.random.default_rng(seed)
    block = block_length(n_queries)
    runs = -(-n_queries // block)
    for start in range(0, resamples, CHUNK):
        rows = min(CHUNK, resamples - start)
        starts = rng.integers(0, n_queries, size=(rows, runs))
        drawn = ((starts[:, :, None] + np.arange(block)) % n_queries).reshape(rows, runs * block)[:, :n_queries]
        offsets = (np.arange(rows) * n_queries)[:, None]
        yield np.bincount((drawn + offsets).ravel(), minlength=rows * n_queries).reshape(rows, n_queries)


def draws(statistic: Statistic, n_queries: int, resamples: int | None = None, seed: int = BOOTSTRAP_SEED
          ) -> np.ndarray:
    """``statistic`` on every draw: one float per draw, NaN where undefined."""
    resamples = RESAMPLES if resamples is None else resamples
    if n_queries == 0:
        return np.full(resamples, np.nan)
    return np.concatenate([np.asarray(statistic(block), dtype=np.float64)
                           for block in query_weights(n_queries, resamples, seed)])


def percentile_interval(values: np.ndarray) -> Interval | None:
    """The ``CONFIDENCE`` percentile interval of the defined (finite) values; None when fewer than ``MIN_DEFINED``
    of them are defined."""
    values = np.asarray(values, dtype=np.float64)
    defined = values[np.isfinite(values)]
    if len(values) == 0 or len(defined) < MIN_DEFINED * len(values):
        return None
    tail = 100 * (1 - CONFIDENCE) / 2
    low, high = np.percentile(defined, [tail, 100 - tail])
    return Interval(float(low), float(high))


def interval(statistic: Statistic, n_queries: int) -> Interval | None:
    """The bootstrap interval of one number of a split of ``n_queries`` evaluated queries."""
    return percentile_interval(draws(statistic, n_queries))


def difference(first: Statistic, second: Statistic, n_queries: int) -> Interval | None:
    """The paired interval of ``first - second`` on the same draws (undefined where either is)."""
    return interval(lambda weights: first(weights) - second(weights), n_queries)


# --- the rules of curves.py with weights ---------------------------------------------------------------------


def _precision_recall(tp: np.ndarray, fp: np.ndarray, positives: np.ndarray, start_at_nothing_kept: bool
                      ) -> tuple[np.ndarray, np.ndarray]:
    """``curves._precision_recall`` per draw: (0, 0) where TP is 0, the point (R=0, P=1) first. A point where no
    query of the draw is kept yet (TP + FP = 0) is the first point again when ``start_at_nothing_kept`` (the standard
    curve has a point per kept distance, and a distance of queries the draw left out is no point of its curve)."""
    tp, fp = tp.astype(np.float64), fp.astype(np.float64)
    has_tp = tp > 0
    precision = np.where(has_tp, tp / np.maximum(tp + fp, 1), 0.0)
    recall = np.where(has_tp, tp / np.maximum(positives, 1)[:, None], 0.0)
    if start_at_nothing_kept:
        precision = np.where(tp + fp == 0, 1.0, precision)
    rows = len(tp)
    return (np.concatenate([np.zeros((rows, 1)), recall], axis=1),
            np.concatenate([np.ones((rows, 1)), precision], axis=1))


def weighted_curve(mode: str, distances: np.ndarray, correct: np.ndarray, keep: np.ndarray, weights: np.ndarray,
                   sequence_min: float, sequence_max: float) -> tuple[np.ndarray, np.ndarray]:
    """``curves.curve`` of every draw of ``weights`` (draws x queries): (recall, precision), each draws x points.

    Paper mode keeps its grid of thresholds over the whole split's ``S`` (a property of the split, not of its
    queries); the standard curve has a point per distinct kept distance of the split, where a draw that left out
    every query of that distance repeats its previous point (which adds no area). Integer ``weights`` (the draws'
    multiplicities) are summed as 32-bit integers: exact, and half the memory traffic of floats."""
    correct = np.asarray(correct, dtype=bool)
    keep = np.asarray(keep, dtype=bool)
    weights = _multiplicities(weights)
    if mode not in ("paper", "standard"):
        raise ValueError(f"unknown metric mode {mode!r}")
    # only the kept queries, by distance: the removed ones add nothing to either count
    inside = np.flatnonzero(keep)
    order = inside[np.argsort(distances[inside], kind="stable")]
    kept, hits = weights[:, order], correct[order]
    tp = np.cumsum(kept * hits, axis=1, dtype=weights.dtype)  # numpy would widen int32 sums to int64
    fp = np.cumsum(kept * ~hits, axis=1, dtype=weights.dtype)
    if mode == "paper":
        cut = np.searchsorted(distances[order], np.linspace(sequence_min, sequence_max, PAPER_THRESHOLDS),
                              side="right")
        return _precision_recall(_counts_at(tp, cut), _counts_at(fp, cut), weights @ correct,
                                 start_at_nothing_kept=False)
    sorted_distances = distances[order]
    last = np.r_[sorted_distances[1:] != sorted_distances[:-1], True] if len(order) else np.zeros(0, bool)
    return _precision_recall(tp[:, last], fp[:, last], weights.sum(axis=1), start_at_nothing_kept=True)


def _multiplicities(weights: np.ndarray) -> np.ndarray:
    """The draws' weights to sum: integer multiplicities as 32-bit integers (exact, half the memory traffic of
    floats), any other weights as floats."""
    weights = np.asarray(weights)
    return weights.astype(np.int32 if np.issubdtype(weights.dtype, np.integer) else np.float64, copy=False)


def _counts_at(cumulative: np.ndarray, cut: np.ndarray) -> np.ndarray:
    """The cumulative count of the first ``cut`` sorted queries, per draw (0 for none)."""
    padded = np.concatenate([np.zeros((len(cumulative), 1), cumulative.dtype), cumulative], axis=1)
    return padded[:, cut]


def _areas_up_to(recall: np.ndarray, precision: np.ndarray, max_recall: np.ndarray) -> np.ndarray:
    """The trapezoid area of each draw's curve cut to ``recall <= max_recall`` (``curves.cut_curve`` then
    ``curves.area``): recall never falls along a curve, so the kept points are a prefix."""
    segments = np.diff(recall, axis=1) * (precision[:, 1:] + precision[:, :-1]) / 2
    cumulative = np.concatenate([np.zeros((len(recall), 1)), np.cumsum(segments, axis=1)], axis=1)
    points = (recall <= max_recall[:, None]).sum(axis=1)
    areas: np.ndarray = cumulative[np.arange(len(recall)), np.maximum(points - 1, 0)]
    return areas


@dataclass(frozen=True)
class WeightedComparison:
    """``curves.compare_curves`` per draw: the AOCs at the predictor's maximum recall and the reduction in per
    cent (NaN where ``curves.reduction_pct`` is None)."""

    aoc_baseline: np.ndarray
    aoc_predictor: np.ndarray
    reduction_pct: np.ndarray


def aoc_difference(draws: WeightedComparison) -> Interval | None:
    """The paired interval of the predictor's AOC minus the baseline's over ``draws`` (in recall units): what
    earns ``curves.WORSE_FROM_ZERO`` (``curves.from_zero``), where the reduction in per cent is undefined."""
    return percentile_interval(draws.aoc_predictor - draws.aoc_baseline)


def _compared(base: tuple[np.ndarray, np.ndarray], kept: tuple[np.ndarray, np.ndarray]) -> WeightedComparison:
    """``curves.compare_curves`` of two weighted curves of the same draws."""
    max_recall = kept[0][:, -1]
    aoc_base, aoc_pred = _aoc(base, max_recall), _aoc(kept, max_recall)
    return WeightedComparison(aoc_base, aoc_pred, _reduction(aoc_base, aoc_pred))


def _aoc(curve: tuple[np.ndarray, np.ndarray], max_recall: np.ndarray) -> np.ndarray:
    """Each draw's AOC of ``curve`` (recall, precision) at ``max_recall``, floored at 0 (``curves.compare_curves``)."""
    aoc: np.ndarray = np.maximum(0.0, max_recall - _areas_up_to(*curve, max_recall))
    return aoc


def _reduction(before: np.ndarray, after: np.ndarray) -> np.ndarray:
    """``curves.reduction_pct`` per draw: NaN where ``before`` is 0 (up to ``AOC_ZERO``)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        reduction: np.ndarray = np.where(before > AOC_ZERO, 100.0 * (before - after) / before, np.nan)
    return reduction


def weighted_comparison(mode: str, distances: np.ndarray, correct: np.ndarray, keep: np.ndarray,
                        weights: np.ndarray, sequence_min: float, sequence_max: float) -> WeightedComparison:
    """Every match kept (VPR+SM) against the matches of ``keep`` (VPR+SM+Pred, or a scorer's removal), per draw."""
    everything = np.ones(len(distances), dtype=bool)
    base = weighted_curve(mode, distances, correct, everything, weights, sequence_min, sequence_max)
    return _compared(base, weighted_curve(mode, distances, correct, keep, weights, sequence_min, sequence_max))


def comparison_draws(mode: str, distances: np.ndarray, correct: np.ndarray, keeps: Sequence[np.ndarray],
                     sequence_min: float, sequence_max: float) -> list[WeightedComparison]:
    """``weighted_comparison`` of each of ``keeps`` on every draw of the split's queries (all NaN for a split
    without queries), VPR+SM's curve computed once per block of draws for all of them, and each distinct keep-mask
    once (a trust level that changes nothing, a scorer that removes what the predictor does)."""
    n = len(distances)
    if n == 0:
        nothing = np.full(RESAMPLES, np.nan)
        return [WeightedComparison(nothing, nothing, nothing) for _ in keeps]
    everything = np.ones(n, dtype=bool)
    masks = [np.asarray(keep, dtype=bool) for keep in keeps]
    distinct: dict[bytes, int] = {}
    for mask in masks:
        distinct.setdefault(np.packbits(mask).tobytes(), len(distinct))
    which = [distinct[np.packbits(mask).tobytes()] for mask in masks]
    firsts = [masks[which.index(index)] for index in range(len(distinct))]
    blocks: list[list[WeightedComparison]] = [[] for _ in firsts]
    for weights in query_weights(n):
        base = weighted_curve(mode, distances, correct, everything, weights, sequence_min, sequence_max)
        for found, keep in zip(blocks, firsts, strict=True):
            kept = base if keep.all() else weighted_curve(mode, distances, correct, keep, weights,
                                                          sequence_min, sequence_max)
            found.append(_compared(base, kept))
    joined = [WeightedComparison(*(np.concatenate([getattr(block, name) for block in found])
                                   for name in ("aoc_baseline", "aoc_predictor", "reduction_pct")))
              for found in blocks]
    return [joined[index] for index in which]


@dataclass(frozen=True)
class Scored:
    """One removal's matches, as a curve takes them (``curves.curve``): per query its distance, correctness and
    whether it is kept, and the paper grid's range."""

    distances: np.ndarray
    correct: np.ndarray
    keep: np.ndarray
    sequence_min: float
    sequence_max: float


def paired_draws(mode: str, baseline: Scored, rows: Sequence[Scored]) -> list[WeightedComparison]:
    """``curves.compare_curves(baseline, row)`` of each of ``rows`` on every draw of the queries (all NaN without
    queries): unlike ``comparison_draws``, each row has its own matches (e.g. the matches of another sequence length
    per query), the queries the same, so that the differences between rows are paired."""
    n = len(baseline.distances)
    if n == 0:
        nothing = np.full(RESAMPLES, np.nan)
        return [WeightedComparison(nothing, nothing, nothing) for _ in rows]

    def weighted(scored: Scored, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return weighted_curve(mode, scored.distances, scored.correct, scored.keep, weights, scored.sequence_min,
                              scored.sequence_max)

    blocks: list[list[WeightedComparison]] = [[] for _ in rows]
    for weights in query_weights(n):
        base = weighted(baseline, weights)
        for found, row in zip(blocks, rows, strict=True):
            found.append(_compared(base, weighted(row, weights)))
    return [WeightedComparison(*(np.concatenate([getattr(block, name) for block in found])
                                 for name in ("aoc_baseline", "aoc_predictor", "reduction_pct")))
            for found in blocks]


def common_recall_difference(mode: str, first: Scored, second: Scored) -> np.ndarray:
    """Per draw, ``first``'s AOC minus ``second``'s, both taken at the smaller of their two maximum recalls (each
    curve cut there, ``curves.cut_curve``): a row that removes more matches reaches a smaller recall, where an AOC is
    smaller whatever the ranking, so two rows are compared on the recall both reach. NaN without queries."""
    n = len(first.distances)
    if n == 0:
        return np.full(RESAMPLES, np.nan)
    out = []
    for weights in query_weights(n):
        curves = [weighted_curve(mode, s.distances, s.correct, s.keep, weights, s.sequence_min, s.sequence_max)
                  for s in (first, second)]
        common = np.minimum(curves[0][0][:, -1], curves[1][0][:, -1])
        out.append(_aoc(curves[0], common) - _aoc(curves[1], common))
    return np.concatenate(out)


def weighted_restoration_reduction(mode: str, distances: np.ndarray, removal: tuple[np.ndarray, np.ndarray],
                                   restoration: tuple[np.ndarray, np.ndarray], weights: np.ndarray,
                                   sequence_min: float, sequence_max: float) -> np.ndarray:
    """``restoration.compare``'s ``reduction_pct`` per draw (NaN where undefined): ``removal`` and ``restoration``
    are each (correctness, keep-mask) of the queries; both AOCs are taken over each curve's whole extent at the
    larger of the two maximum recalls."""
    removed = weighted_curve(mode, distances, removal[0], removal[1], weights, sequence_min, sequence_max)
    restored = weighted_curve(mode, distances, restoration[0], restoration[1], weights, sequence_min, sequence_max)
    max_recall = np.maximum(removed[0][:, -1], restored[0][:, -1])
    return _reduction(_aoc(removed, max_recall), _aoc(restored, max_recall))


def weighted_average_precision(wrong: np.ndarray, confidence: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """``baselines.detection``'s average precision per draw (NaN for a draw without a wrong match): the queries
    ranked by ``-confidence``, equal scores entering together, ``AP = sum (R_i - R_{i-1}) P_i``."""
    wrong = np.asarray(wrong, dtype=bool)
    score = -np.asarray(confidence, dtype=np.float64)
    weights = _multiplicities(weights)
    order = np.argsort(-score, kind="stable")
    ranked = score[order]
    last = np.r_[ranked[1:] != ranked[:-1], True] if len(order) else np.zeros(0, bool)
    ranked_weights, hits = weights[:, order], wrong[order]
    tp = np.cumsum(ranked_weights * hits, axis=1, dtype=weights.dtype)[:, last].astype(np.float64)
    fp = np.cumsum(ranked_weights * ~hits, axis=1, dtype=weights.dtype)[:, last].astype(np.float64)
    positives = weights @ wrong
    # a threshold that no drawn query reached adds no recall, whatever its precision
    precision = np.divide(tp, tp + fp, out=np.ones_like(tp), where=tp + fp > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        recall = tp / positives[:, None]
        gained = np.diff(np.concatenate([np.zeros((len(tp), 1)), recall], axis=1), axis=1)
        return np.where(positives > 0, np.sum(gained * precision, axis=1), np.nan)


def weighted_mean(values: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """The mean of per-query ``values`` (e.g. 1 for a correct match) in every draw."""
    weights = np.asarray(weights, dtype=np.float64)
    means: np.ndarray = (weights @ np.asarray(values, dtype=np.float64)) / weights.sum(axis=1)
    return means
