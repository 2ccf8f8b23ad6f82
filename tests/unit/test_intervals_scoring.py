"""The intervals the scoring stages record (method §8.7) against the naive bootstrap: draw the queries' indices as
the tool does (runs of consecutive queries, ``helpers.bootstrap_indices``), take the drawn queries (repeats and all),
score them with the functions that score a split (``compare_removal``, restoration, ``baselines.detection``,
recall@1) and take the 2.5th and 97.5th percentiles by hand. Also: ``unchanged`` for rounding noise, the seeds'
spread of one seed, and a results file of the previous format refused."""

from __future__ import annotations

import json
from dataclasses import fields, replace

import numpy as np
import pytest
from helpers import bootstrap_indices, make_features

from vpr_smr.core.records import FormatError, load
from vpr_smr.eval.matching.attributes import QueryFeatures, query_features
from vpr_smr.eval.matching.ground_truth import GroundTruth
from vpr_smr.eval.scoring import curves
from vpr_smr.eval.scoring import intervals as iv
from vpr_smr.eval.scoring.baselines import (
    ORACLE,
    PREDICTOR,
    TRAINING_FREE,
    BaselineSettings,
    Prediction,
    detection,
    keep_lowest,
    oracle_keep,
    query_scores,
    split_baselines,
)
from vpr_smr.eval.scoring.evaluate import compare_removal, evaluate_split, recall_at_1
from vpr_smr.eval.scoring.records import Evaluation, Interval
from vpr_smr.eval.scoring.restoration import evaluate_restoration
from vpr_smr.eval.scoring.sweep import protocol_sweep, rescored

N = 30
DRAWS = 200  # of the tool's 1000 (the first 200 of the same draws): the naive loop scores every draw 5-15 times
MODES = ("paper", "standard")
TRUST = (0.0, 0.6)


def test_the_tool_draws_1000_times() -> None:
    assert iv.RESAMPLES == 1000 and iv.BOOTSTRAP_SEED == 0 and iv.CONFIDENCE == 0.95


@pytest.fixture(autouse=True)
def fewer_draws(monkeypatch: pytest.MonkeyPatch, request: pytest.FixtureRequest) -> None:
    if request.node.name != "test_the_tool_draws_1000_times":
        monkeypatch.setattr(iv, "RESAMPLES", DRAWS)


def drawn(n: int = N) -> np.ndarray:
    """The draws the tool takes (runs of consecutive queries, ``helpers.bootstrap_indices``), the first ``DRAWS``."""
    return bootstrap_indices(n, DRAWS)


def naive_interval(values: list[float | None]) -> Interval | None:
    """The percentile interval by hand: the defined values' 2.5th and 97.5th percentiles (linear interpolation),
    none when fewer than 95 % of the draws define the number."""
    defined = np.array([v for v in values if v is not None and np.isfinite(v)], dtype=np.float64)
    if len(defined) < 0.95 * len(values):
        return None
    low, high = np.percentile(defined, [2.5, 97.5])
    return Interval(float(low), float(high))


def same(got: Interval | None, expected: Interval | None) -> bool:
    if got is None or expected is None:
        return got is expected
    return bool(np.isclose(got.low, expected.low, rtol=0, atol=1e-9)
                and np.isclose(got.high, expected.high, rtol=0, atol=1e-9))


PER_QUERY = ("queries", "attributes", "rank_references", "single_match", "sequence_match", "sequence_distance",
             "labels", "single_correct", "sequence_correct", "rank_correct", "sequence_candidates",
             "sequence_candidate_references", "single_candidates", "single_candidate_references")


def subset(features: QueryFeatures, idx: np.ndarray) -> QueryFeatures:
    """The drawn queries as a split of their own (the split's S range kept: a property of the split)."""
    names = {f.name for f in fields(QueryFeatures)}
    return replace(features, **{name: getattr(features, name)[idx] for name in PER_QUERY
                                if name in names and getattr(features, name) is not None})


def hand_split(seed: int = 3) -> QueryFeatures:
    """30 queries: distances with ties, ~35 % wrong, three ranks, the scorers' candidates (r_window 2, spread_k 2)."""
    rng = np.random.default_rng(seed)
    correct = rng.random(N) > 0.35
    distances = np.round(rng.uniform(1, 3, N), 1)
    rank_correct = np.c_[correct, rng.random((N, 2)) > 0.5]
    values = np.sort(np.round(rng.uniform(0, 4, (N, 4)), 1), axis=1)
    values[:, 0] = distances
    values = np.sort(values, axis=1)
    references = rng.integers(0, 60, (N, 4))
    features = make_features(correct, rank_correct, sequence_distance=distances, sequence_min=0.5, sequence_max=3.5,
                             single_correct=rng.random(N) > 0.5, queries=np.arange(N),
                             sequence_match=references[:, 0], labels=rng.integers(0, 4, N),
                             all_single_correct=rng.random(N + 3) > 0.5,
                             rank_references=rng.integers(60, 80, (N, 3)),
                             sequence_candidates=values, sequence_candidate_references=references,
                             single_candidates=np.sort(rng.uniform(0, 4, (N, 4)), axis=1),
                             single_candidate_references=rng.integers(0, 60, (N, 4)))
    # query n's rank-k attributes carry the key 10 n + k (TablePredictor reads it)
    features.attributes[:, :, 0] = 10 * np.arange(N)[:, None] + np.arange(3)[None, :]
    return features


class TablePredictor:
    """Class probabilities by the attributes' key: random, fixed by ``seed``."""

    classes_ = np.arange(4)

    def __init__(self, seed: int) -> None:
        self.table = np.random.default_rng(seed).dirichlet(np.ones(4) * 0.7, 10 * N)

    def predict_proba(self, attributes: np.ndarray) -> np.ndarray:
        return self.table[attributes[:, 0].astype(int)]


def test_the_first_seeds_reductions_trust_levels_and_restoration_are_the_naive_bootstrap() -> None:
    features = hand_split()
    predictors = [TablePredictor(2), TablePredictor(1)]
    split = evaluate_split(features, predictors, MODES, TRUST, restoration=True)[0]
    probabilities = predictors[0].predict_proba(features.attributes[:, 0, :])
    predicted, confidence = np.argmax(probabilities, axis=1), probabilities.max(axis=1)
    ranks = np.stack([predictors[0].predict_proba(features.attributes[:, k, :]) for k in range(3)], axis=1)
    for mode in MODES:
        keeps = [curves.keep_mask(predicted, confidence, level) for level in (0.0, *TRUST)]
        reductions, trusts = [], [[] for _ in TRUST]
        restorations = []
        for idx in drawn():
            sub = subset(features, idx)
            reductions.append(compare_removal(sub, mode, keeps[0][idx])[2])
            for found, keep in zip(trusts, keeps[1:], strict=True):
                found.append(compare_removal(sub, mode, keep[idx])[2].reduction_pct)
            restorations.append(evaluate_restoration(sub, ranks[idx], np.arange(4), (mode,)).modes[mode].reduction_pct)
        numbers = split.modes[mode]
        got = numbers.reduction
        assert got.reduction_pct_ci is not None  # defined here: a check of the numbers, not of two Nones
        assert same(got.reduction_pct_ci, naive_interval([r.reduction_pct for r in reductions]))
        assert same(got.aoc_vpr_sm_ci, naive_interval([r.aoc_vpr_sm for r in reductions]))
        assert same(got.aoc_vpr_sm_pred_ci, naive_interval([r.aoc_vpr_sm_pred for r in reductions]))
        assert numbers.trust_auc is not None
        for level, found in zip(TRUST, trusts, strict=True):
            assert same(numbers.trust_auc[str(level)].reduction_pct_ci, naive_interval(found)), (mode, level)
        assert split.restoration is not None
        restored = split.restoration.modes[mode].reduction_pct_ci
        assert restored is not None and same(restored, naive_interval(restorations))
        # the other seed's numbers carry none: their spread is the seeds'
        other = split.other_seeds[0].modes[mode]
        assert (other.reduction_pct_ci, other.aoc_vpr_sm_ci, other.aoc_vpr_sm_pred_ci) == (None, None, None)


def test_the_scorers_intervals_and_their_differences_to_the_predictor_are_the_naive_paired_bootstrap() -> None:
    features = hand_split()
    settings = BaselineSettings(r_window=2, spread_k=2)
    positions = np.arange(80, dtype=np.float64)
    probabilities = TablePredictor(2).predict_proba(features.attributes[:, 0, :])
    first = Prediction(0, probabilities, np.arange(4))
    found = split_baselines(features, settings, positions, [first, Prediction(1, probabilities[::-1], np.arange(4))],
                            MODES)
    scores = query_scores(features, settings, positions, 0, first)
    budget = int((~first.keep).sum())
    keeps = {name: first.keep if name == PREDICTOR else
             oracle_keep(features.sequence_distance, features.sequence_correct, budget) if name == ORACLE else
             keep_lowest(value, budget) for name, value in scores.items()}
    wrong = ~features.sequence_correct
    precisions: dict[str, list[float | None]] = {name: [] for name in scores}
    reductions: dict[str, dict[str, list[float | None]]] = {m: {name: [] for name in scores} for m in MODES}
    for idx in drawn():
        sub = subset(features, idx)
        for name, value in scores.items():
            precisions[name].append(detection(wrong[idx], value[idx], curve=False).average_precision)
            for mode in MODES:
                reductions[mode][name].append(compare_removal(sub, mode, keeps[name][idx])[2].reduction_pct)

    def minus(a: list[float | None], b: list[float | None]) -> list[float | None]:
        return [None if x is None or y is None else x - y for x, y in zip(a, b, strict=True)]

    assert found.removal is not None and found.versus_predictor is not None
    assert set(found.versus_predictor) == set(TRAINING_FREE)
    for name in scores:
        assert found.detection[name].average_precision_ci is not None
        assert same(found.detection[name].average_precision_ci, naive_interval(precisions[name])), name
        for mode in MODES:
            got = found.removal[0].scorers[name].modes[mode].reduction_pct_ci
            assert same(got, naive_interval(reductions[mode][name])), (name, mode)
            assert found.removal[1].scorers[name].modes[mode].reduction_pct_ci is None  # another seed's
    assert all(found.removal[0].scorers[name].modes[mode].reduction_pct_ci is not None
               for name in scores for mode in MODES if name != ORACLE)  # numbers, not only Nones
    for name in TRAINING_FREE:
        versus = found.versus_predictor[name]
        assert same(versus.average_precision_difference_ci, naive_interval(minus(precisions[name],
                                                                                 precisions[PREDICTOR])))
        for mode in MODES:
            assert same(versus.reduction_pct_difference_ci[mode],
                        naive_interval(minus(reductions[mode][name], reductions[mode][PREDICTOR]))), (name, mode)
    assert any(v.average_precision_difference_ci is not None for v in found.versus_predictor.values())
    # without a predictor there is nothing to set the scorers against
    assert split_baselines(features, settings, positions, (), MODES).versus_predictor is None


def test_the_sweeps_recall_change_is_over_the_same_queries_and_its_intervals_are_the_naive_bootstrap() -> None:
    rng = np.random.default_rng(3)
    n = N + 3  # L = 4: 30 evaluated queries
    offset = np.abs(np.arange(n)[:, None] - np.arange(n)[None, :])
    matrix = np.minimum(offset, 12) / 12 + 1.2 * rng.random((n, n))
    features = query_features(matrix, 4, 2)
    assert len(features.queries) == N
    kept = np.random.default_rng(2).random(N) > 0.3
    single_matches = np.argmin(matrix, axis=0)
    truth = GroundTruth.aligned(n, n, 2)
    swept = protocol_sweep(features, single_matches, truth, MODES, kept, thresholds=(0, 1))
    for position, threshold in enumerate((0, 1)):
        scored = rescored(features, single_matches, truth.within(float(threshold)))
        evaluated, _ = recall_at_1(scored, "standard")  # standard mode: both over the evaluated queries
        changes, reductions = [], {mode: [] for mode in MODES}
        for idx in drawn():
            sub = subset(scored, idx)
            single, sequence = recall_at_1(sub, "standard")
            changes.append(sequence - single)
            for mode in MODES:
                reductions[mode].append(compare_removal(sub, mode, kept[idx])[2].reduction_pct)
        for mode in MODES:
            point = swept.modes[mode][position]
            assert point.recall_at_1_single_evaluated == pytest.approx(evaluated, abs=1e-15)
            assert point.recall_change_ci is not None and same(point.recall_change_ci, naive_interval(changes))
            assert point.reduction is not None
            assert same(point.reduction.reduction_pct_ci, naive_interval(reductions[mode])), (mode, threshold)
    # a check of numbers, not of Nones: every interval is defined here
    assert all(p.reduction is not None and p.reduction.reduction_pct_ci is not None
               for points in swept.modes.values() for p in points)
    # paper mode's single-frame recall@1 is over every query of the split, the evaluated one over 30 of 33
    paper = swept.modes["paper"][0]
    assert paper.recall_at_1_single != paper.recall_at_1_single_evaluated


# --- unchanged, the seeds' spread, the results format ---------------------------------------------------------


def test_a_removal_that_keeps_what_a_threshold_keeps_is_unchanged_not_improved() -> None:
    # Paper mode, keeping the matches of distance <= 0.29 (the grid points fall so that the cut adds no trapezoid):
    # the removal's curve is VPR+SM's up to the cut, its last point repeated over the rest of the grid, and the
    # trapezoid sums of the two arrays round differently: a "reduction" of 2.0e-14 %.
    distances = np.array([0.81, 0.45, 0.88, 0.6, 0.79, 0.19, 0.32, 0.38, 0.49, 0.47, 0.82, 0.17, 0.85, 0.89, 0.08,
                          0.01, 0.29, 0.4, 0.97, 0.07, 0.78, 0.48, 0.13, 0.37, 0.38])
    correct = np.array([1, 1, 1, 0, 1, 0, 1, 1, 1, 0, 1, 1, 0, 1, 1, 0, 1, 1, 1, 0, 0, 0, 1, 1, 1], dtype=bool)
    features = make_features(correct, np.ones((25, 1), bool), sequence_distance=distances,
                             sequence_min=0.01, sequence_max=0.97, queries=np.arange(25))
    reduction = compare_removal(features, "paper", distances <= 0.29)[2]
    assert reduction.reduction_pct is not None and 1e-15 < reduction.reduction_pct < 1e-13  # rounding, not zero
    assert reduction.outcome == curves.UNCHANGED


@pytest.mark.parametrize(("value", "expected"), [(2.1e-14, curves.UNCHANGED), (-2.1e-14, curves.UNCHANGED),
                                                  (1e-3, curves.IMPROVED), (-1e-3, curves.WORSE)])
def test_the_outcome_tolerance(value: float, expected: str) -> None:
    comparison = curves.Comparison(0.5, 0.3, 0.3, 0.2, 0.2 * (1 - value / 100), value,
                                   curves.Curve(np.zeros(1), np.ones(1)), 0.5, 0.2)
    assert curves.outcome(10, 2, comparison) == expected


def test_the_spread_of_one_defined_seed_is_not_a_number() -> None:
    features = hand_split()
    # seed 1 removes every match: its reduction is undefined, leaving one defined seed
    everything_wrong = TablePredictor(1)
    everything_wrong.table = np.tile([0.0, 0.0, 0.0, 1.0], (10 * N, 1))
    split = evaluate_split(features, [TablePredictor(2), everything_wrong], ("standard",), ())[0]
    summary = split.seed_summary["standard"]
    assert summary.n_seeds == 2 and summary.n_seeds_defined == 1
    assert summary.reduction_pct_std is None  # not 0: one value has no spread to measure
    assert summary.reduction_pct_mean == split.modes["standard"].reduction.reduction_pct
    assert '"reduction_pct_std": null' in json.dumps(split.to_json()["seed_summary"])


def test_a_results_file_of_format_4_is_computed_again(tmp_path) -> None:
    path = tmp_path / "evaluation.json"
    path.write_text(json.dumps({"format": 4, "meta": {}, "predictors": [], "splits": {}}))
    with pytest.raises(FormatError, match="compute it again"):
        load(path, Evaluation)
