"""The threshold rules of method §16 on hand-worked splits and against naive loops over every candidate threshold
(counts by Python loops, the Clopper-Pearson bound by SciPy per step)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from oracles import naive_empirical, naive_guaranteed
from scipy.stats import beta, binomtest

from vpr_smr.eval.scoring import intervals
from vpr_smr.eval.scoring import thresholds as th

# --- hand-worked cases -------------------------------------------------------------------------------------------

# ten queries: confidences and labels, worked by hand below
CONF = np.array([9, 8, 8, 8, 7, 6, 5, 5, 3, 1], dtype=float)
GOOD = np.array([1, 1, 1, 0, 1, 1, 0, 1, 0, 0], dtype=bool)


def test_empirical_by_hand_with_ties_at_the_threshold() -> None:
    # t=9: 1/1; t=8 (three tied, one wrong): 3/4 = 0.75; t=7: 4/5 = 0.8; t=6: 5/6; t=5: 6/8 = 0.75; t=3: 6/9; t=1: 6/10
    assert th.empirical(CONF, GOOD, 0.8) == 6.0  # 5/6 >= 0.8 and 0.75 at t=5 does not reach it
    assert th.empirical(CONF, GOOD, 0.75) == 5.0
    assert th.empirical(CONF, GOOD, 0.6) == 1.0
    assert th.empirical(CONF, GOOD, 1.0) == 9.0  # p = 1: the highest threshold whose accepted set is all correct
    # nothing reaches p: every query wrong
    assert th.empirical(CONF, np.zeros(10, dtype=bool), 0.1) is None


def test_empirical_all_wrong_and_constant_confidence() -> None:
    constant = np.full(6, 0.5)
    assert th.empirical(constant, np.array([1, 1, 1, 1, 1, 0], dtype=bool), 0.8) == 0.5  # 5/6
    assert th.empirical(constant, np.array([1, 1, 1, 1, 0, 0], dtype=bool), 0.8) is None  # 4/6 < 0.8
    # m = 6, steps 3; z = 3, t = 0.5 accepts all 6 (ties), k = 0: bound 1 - (0.1 / 3)^(1/6) = 0.433
    assert 1 - (0.1 / 3) ** (1 / 6) == pytest.approx(0.4327, abs=1e-4)
    assert th.guaranteed(constant, np.ones(6, dtype=bool), 0.55, 0.1) == 0.5  # 0.433 <= 0.45: kept
    assert th.guaranteed(constant, np.ones(6, dtype=bool), 0.6, 0.1) is None  # 0.433 > 0.4


def test_guaranteed_by_hand() -> None:
    # 100 queries, confidences 100..1, the 10 least confident wrong; p = 0.9, delta = 0.1, steps = 7
    conf = np.arange(100, 0, -1, dtype=float)
    good = np.arange(100) < 90
    q = 1 - 0.1 / 7
    # (z, t, n, k, kept): the bound beta.ppf(q, k + 1, n - k) against 1 - p = 0.1
    trace = [(50, 51, 50, 0, True), (75, 26, 75, 0, True), (88, 13, 88, 0, True), (94, 7, 94, 4, False),
             (91, 10, 91, 1, True), (93, 8, 93, 3, True), (94, 7, 94, 4, False)]
    lo, hi = 0, 100
    for z, t, n, k, kept in trace:
        assert z == math.ceil((lo + hi) / 2) and conf[z - 1] == t
        assert (beta.ppf(q, k + 1, n - k) <= 0.1) == kept  # 0.081, 0.055, 0.047, 0.114, 0.066, 0.099, 0.114
        lo, hi = (z, hi) if kept else (lo, z)
    assert th.guaranteed(conf, good, 0.9, 0.1) == 8.0  # the last kept


def test_p_one_and_too_small_splits() -> None:
    assert th.guaranteed(np.arange(1000, dtype=float), np.ones(1000, dtype=bool), 1.0, 0.1) is None
    with pytest.raises(ValueError, match="precision 1 cannot be guaranteed"):
        th.smallest_calibration(1.0, 0.1)
    # 180 all-correct queries cannot guarantee 0.99 at delta 0.1 (needs 917), but can guarantee 0.9
    conf, good = np.arange(180, dtype=float), np.ones(180, dtype=bool)
    assert th.guaranteed(conf, good, 0.99, 0.1) is None
    assert th.guaranteed(conf, good, 0.9, 0.1) == 0.0


def test_smallest_calibration_against_a_loop() -> None:
    for p, delta in ((0.9, 0.1), (0.95, 0.1), (0.8, 0.05), (0.99, 0.1)):
        found = th.smallest_calibration(p, delta)
        # the loop: the first m at which the rule on m distinct all-correct confidences sets a threshold
        m = 1
        while naive_guaranteed([float(i) for i in range(m)], [True] * m, p, delta) is None:
            m += 1
        assert found == m
    assert th.smallest_calibration(0.99, 0.1) == 917  # the first step takes 459: ln(0.1 / 10) / ln(0.99) = 458.2


def test_clopper_pearson_bound_against_the_exact_binomial_interval() -> None:
    # a one-sided bound at 1 - a equals the upper end of the two-sided exact interval at confidence 1 - 2a
    a = 0.05
    for n, k in ((20, 2), (100, 7), (37, 0)):
        upper = binomtest(k, n).proportion_ci(confidence_level=1 - 2 * a, method="exact").high
        assert th._bound(n, k, a, 1) == pytest.approx(upper, rel=1e-9)
    assert th._bound(40, 0, 0.1, 1) == pytest.approx(1 - 0.1 ** (1 / 40), rel=1e-12)  # closed form at k = 0


def test_infinite_confidences_are_candidates_and_abstention_is_none() -> None:
    conf = np.array([np.inf, np.inf, 3.0, 2.0, 1.0])
    good = np.array([1, 1, 0, 1, 0], dtype=bool)
    assert th.empirical(conf, good, 0.9) == np.inf  # accepts the two infinite ones: 2/2
    cal = th.calibrate(conf, good, 0.9, th.EMPIRICAL)
    assert (cal.threshold, cal.accepted, cal.wrong) == (np.inf, 2, 0)
    assert th.accept(conf, cal).tolist() == [True, True, False, False, False]
    none = th.calibrate(conf, np.zeros(5, dtype=bool), 0.9, th.EMPIRICAL)
    assert none.abstains and not th.accept(conf, none).any()
    with pytest.raises(ValueError, match="NaN"):
        th.calibrate(np.array([1.0, np.nan]), np.array([1, 0], dtype=bool), 0.9, th.EMPIRICAL)


def test_same_fraction_integer_ceil_and_ties_at_the_cut() -> None:
    cal = th.Calibration(th.SAME_FRACTION, 0.9, None, 0.5, 10, 3, 0)  # f = 3/10
    assert th.accept(np.arange(10, dtype=float), cal).tolist() == [False] * 7 + [True] * 3
    seven = th.Calibration(th.SAME_FRACTION, 0.9, None, 0.5, 100, 7, 0)  # f = 7/100 on 100 queries: exactly 7
    assert math.ceil(7 / 100 * 100) == 8  # what f as a float would give
    assert int(th.accept(np.arange(100, dtype=float), seven).sum()) == 7
    third = th.Calibration(th.SAME_FRACTION, 0.9, None, 0.5, 3, 1, 0)  # f = 1/3 on 9 queries: exactly 3
    assert int(th.accept(np.arange(9, dtype=float), third).sum()) == 3
    tied = np.array([5, 4, 4, 4, 1, 0], dtype=float)  # ceil(3 * 6 / 10) = 2 wanted; the cut 4 has three
    assert th.accept(tied, cal).tolist() == [True, True, True, True, False, False]
    assert th.accept(np.zeros(0), cal).tolist() == []
    assert not th.accept(tied, th.Calibration(th.SAME_FRACTION, 0.9, None, None, 10, 0, 0)).any()


def test_calibrate_checks_its_settings() -> None:
    conf, good = np.arange(5, dtype=float), np.ones(5, dtype=bool)
    for bad in (0.0, 1.5, -0.1, float("nan"), "high", None):
        with pytest.raises(ValueError, match="precision"):
            th.calibrate(conf, good, bad, th.EMPIRICAL)
    for bad in (0.0, 1.0, float("inf"), "low"):
        with pytest.raises(ValueError, match="risk"):
            th.calibrate(conf, good, 0.9, th.GUARANTEED, bad)
    with pytest.raises(ValueError, match="unknown rule"):
        th.calibrate(conf, good, 0.9, "median")
    with pytest.raises(ValueError, match="empty"):
        th.calibrate(np.zeros(0), np.zeros(0, dtype=bool), 0.9, th.EMPIRICAL)
    with pytest.raises(ValueError, match="labels"):
        th.calibrate(conf, good[:4], 0.9, th.EMPIRICAL)


@pytest.mark.parametrize("seed", range(6))
def test_rules_against_naive_loops(seed: int) -> None:
    rng = np.random.default_rng(seed)
    for _ in range(40):
        m = int(rng.integers(1, 300))
        conf = rng.integers(0, int(rng.integers(1, 30)), m).astype(float)  # many ties
        good = rng.random(m) < rng.uniform(0.3, 1.0)
        for p in (0.5, 0.8, 0.9, 0.95, 1.0):
            assert th.empirical(conf, good, p) == naive_empirical(conf.tolist(), good.tolist(), p)
            for delta in (0.05, 0.2):
                assert th.guaranteed(conf, good, p, delta) == naive_guaranteed(conf.tolist(), good.tolist(), p,
                                                                               delta)


def test_guaranteed_on_200000_queries() -> None:
    rng = np.random.default_rng(0)
    conf, good = rng.random(200_000), rng.random(200_000) < 0.95
    t = th.guaranteed(conf, good, 0.9, 0.1)
    assert t is not None and t == conf.min()  # 95 % correct everywhere: the whole split is accepted


def test_realise_by_hand_and_its_intervals() -> None:
    accepted = CONF >= 6  # 9, 8, 8, 8, 7, 6: six accepted, one wrong (a tied 8)
    found = th.realise(accepted, GOOD)
    assert (found.n_queries, found.accepted, found.wrong) == (10, 6, 1)
    assert found.precision == 5 / 6 and found.recall == 5 / 10 and found.accepted_fraction == 6 / 10
    # the intervals: the same draws every interval of a split takes, computed by a loop over the draws here
    precisions, recalls = [], []
    for weights in intervals.query_weights(10):
        for row in weights:
            n = float(row[accepted].sum())
            hit = float(row[accepted & GOOD].sum())
            precisions.append(hit / n if n else np.nan)
            recalls.append(hit / row.sum())
    assert found.precision_ci == intervals.percentile_interval(np.array(precisions))
    assert found.recall_ci == intervals.percentile_interval(np.array(recalls))
    assert th.realise(accepted, GOOD, weights=th.bootstrap_weights(10)) == found  # the draws computed once
    assert found.precision_ci is not None and found.precision_ci.low <= 5 / 6 <= found.precision_ci.high
    nothing = th.realise(np.zeros(10, dtype=bool), GOOD)
    assert nothing.precision is None and nothing.recall == 0.0 and th.outcome(nothing, 0.9) == th.ABSTAINED
    assert th.outcome(found, 0.8) == th.HELD and th.outcome(found, 0.9) == th.VIOLATED
    with pytest.raises(ValueError, match="empty"):
        th.realise(np.zeros(0, dtype=bool), np.zeros(0, dtype=bool))


def test_segments_by_hand() -> None:
    assert th.segment_bounds(250, 100) == [(0, 100), (100, 250)]
    assert th.segment_bounds(60, 100) == [(0, 60)]
    assert th.segment_bounds(300, 100) == [(0, 100), (100, 200), (200, 300)]
    accepted = np.zeros(250, dtype=bool)
    good = np.ones(250, dtype=bool)
    accepted[[5, 6, 150, 151, 152]] = True
    good[150] = False  # second segment: 2 of 3 correct
    assert th.segments(accepted, good, 0.9, 100) == th.Segments(100, 2, 2, 1)
    assert th.segments(accepted, good, 0.6, 100) == th.Segments(100, 2, 2, 0)
    accepted[[5, 6]] = False
    assert th.segments(accepted, good, 0.6, 100) == th.Segments(100, 2, 1, 0)
    with pytest.raises(ValueError, match="segment"):
        th.segments(accepted, good, 0.9, 0)


def test_risk_coverage_by_hand() -> None:
    coverage, risk, t = th.risk_coverage(CONF, GOOD)
    assert t.tolist() == [9, 8, 7, 6, 5, 3, 1]
    assert coverage.tolist() == [0.1, 0.4, 0.5, 0.6, 0.8, 0.9, 1.0]
    assert risk.tolist() == pytest.approx([0, 1 / 4, 1 / 5, 1 / 6, 2 / 8, 3 / 9, 4 / 10])


def test_precision_interval_without_enough_defined_draws() -> None:
    # one accepted query of 200: a draw that misses it has no precision; counted by a loop over the draws
    accepted = np.zeros(200, dtype=bool)
    accepted[0] = True
    good = np.ones(200, dtype=bool)
    defined = total = 0
    for weights in intervals.query_weights(200):
        for row in weights:
            total += 1
            defined += row[0] > 0
    assert defined < intervals.MIN_DEFINED * total  # the case this test is about
    found = th.realise(accepted, good)
    assert found.precision == 1.0 and found.precision_ci is None
    assert found.recall_ci is not None and found.recall_ci.low <= 1 / 200 <= found.recall_ci.high
