"""PR curves, AUC and AOC on examples worked out by hand (method §8)."""

import numpy as np
import pytest

from vpr_smr.eval.scoring.curves import (
    compare_curves,
    keep_mask,
    paper_curve,
    recall_at_full_precision,
    standard_curve,
)

DIST = np.array([1.0, 2.0, 3.0, 4.0])
CORRECT = np.array([True, False, True, False])
ALL = np.ones(4, dtype=bool)
PRED = np.array([True, False, True, True])  # the predictor removes the wrong match at distance 2


def test_paper_curve_by_hand():
    # thresholds 0, 1, 2, 3, 4: TP 0,1,1,2,2  FP 0,0,1,1,2  positives 2
    base = paper_curve(DIST, CORRECT, ALL, 0.0, 4.0, n_thresholds=5)
    np.testing.assert_allclose(base.recall, [0, 0, .5, .5, 1, 1])
    np.testing.assert_allclose(base.precision, [1, 0, 1, .5, 2 / 3, .5])
    pred = paper_curve(DIST, CORRECT, PRED, 0.0, 4.0, n_thresholds=5)
    np.testing.assert_allclose(pred.recall, [0, 0, .5, .5, 1, 1])
    np.testing.assert_allclose(pred.precision, [1, 0, 1, 1, 1, 2 / 3])
    result = compare_curves(base, pred)
    auc_base = .25 + (.5 + 2 / 3) / 2 * .5  # trapezoids (0,0)->(.5,1) and (.5,.5)->(1,2/3)
    assert result.max_recall == 1.0
    assert result.auc_baseline == pytest.approx(auc_base)
    assert result.auc_predictor == pytest.approx(.75)
    assert result.aoc_baseline == pytest.approx(1 - auc_base)
    assert result.aoc_predictor == pytest.approx(.25)
    assert result.reduction_pct == pytest.approx(100 * ((1 - auc_base) - .25) / (1 - auc_base))


def test_standard_curve_by_hand():
    # sorted kept matches 1T 2F 3T 4F, recall over all 4 queries
    base = standard_curve(DIST, CORRECT, ALL)
    np.testing.assert_allclose(base.recall, [0, .25, .25, .5, .5])
    np.testing.assert_allclose(base.precision, [1, 1, .5, 2 / 3, .5])
    pred = standard_curve(DIST, CORRECT, PRED)
    np.testing.assert_allclose(pred.recall, [0, .25, .5, .5])
    np.testing.assert_allclose(pred.precision, [1, 1, 1, 2 / 3])
    result = compare_curves(base, pred)
    assert result.max_recall == .5
    assert result.auc_baseline == pytest.approx(.25 + (.5 + 2 / 3) / 2 * .25)
    assert result.aoc_predictor == pytest.approx(0.0)
    assert result.reduction_pct == pytest.approx(100.0)
    assert recall_at_full_precision(base) == .25
    assert recall_at_full_precision(pred) == .5


def test_standard_curve_ties_make_one_point():
    curve = standard_curve(np.array([1.0, 1.0, 2.0]), np.array([True, False, True]), np.ones(3, bool))
    np.testing.assert_allclose(curve.recall, [0, 1 / 3, 2 / 3])
    np.testing.assert_allclose(curve.precision, [1, .5, 2 / 3])


def test_baseline_cut_at_predictor_max_recall():
    base = paper_curve(DIST, CORRECT, ALL, 0.0, 4.0, n_thresholds=5)
    pred = paper_curve(DIST, CORRECT, np.array([True, False, False, False]), 0.0, 4.0, n_thresholds=5)
    result = compare_curves(base, pred)
    assert result.max_recall == .5
    np.testing.assert_allclose(result.baseline_cut.recall, [0, 0, .5, .5])
    assert result.auc_baseline == pytest.approx(.25)  # (0,0)->(.5,1) then a vertical drop
    assert result.aoc_baseline == pytest.approx(.25)


def test_zero_baseline_aoc_gives_an_undefined_reduction():
    # Thresholds start at S.min(), which is always some query's match distance: no (0, 0) point here.
    # Every match correct: precision 1 everywhere, AOC 0, nothing to reduce (not a 0 % reduction).
    correct = np.ones(4, dtype=bool)
    base = paper_curve(DIST, correct, ALL, 1.0, 4.0, n_thresholds=5)
    result = compare_curves(base, base)
    assert result.aoc_baseline == pytest.approx(0.0) and result.reduction_pct is None


def test_keep_mask_trust():
    predicted = np.array([0, 1, 2, 3, 3])
    confidence = np.array([.9, .9, .4, .4, .95])
    np.testing.assert_array_equal(keep_mask(n=3), [True, True, True])
    np.testing.assert_array_equal(keep_mask(predicted, confidence), [True, False, True, False, False])
    # trust .5: the predictor only acts where its confidence >= .5; the others keep their match
    np.testing.assert_array_equal(keep_mask(predicted, confidence, .5), [True, False, True, True, False])
    # full trust (>= 1): no prediction is that sure, nothing is removed
    np.testing.assert_array_equal(keep_mask(predicted, confidence, 1.0), [True] * 5)
