"""Match restoration (method §9) on hand-made queries, against curves and areas worked out by hand.

Four queries, sequence distances 0.1, 0.2, 0.3, 0.4 (S.min 0.1, S.max 0.4), two alternatives each (ranks 1, 2).
Probabilities are given directly (columns = classes 0..3), so the test does not depend on a trained network.
"""

import numpy as np
import pytest
from helpers import make_features

from vpr_smr.eval.scoring.restoration import evaluate_restoration, restore


def proba(cls: int, p: float) -> list[float]:
    """Class ``cls`` with probability ``p``, the rest spread evenly over the other classes."""
    row = [(1 - p) / 3] * 4
    row[cls] = p
    return row


KEEP = proba(0, 0.9)
REMOVE = proba(3, 0.9)
NO = proba(3, 0.8)  # an alternative predicted wrong: never eligible
CLASSES = np.arange(4)


def test_restoration_gains_when_the_replacement_is_right_and_the_removed_match_was_wrong():
    # q1's sequence match is wrong and removed; its rank-1 alternative is predicted correct (class 0) and is right.
    # q3 is removed and nothing is eligible. rank_correct[:, 0] is the rank-0 match, unused by restoration.
    features = make_features([True, False, True, False], [[1, 0, 0], [0, 1, 0], [1, 0, 0], [0, 0, 0]])
    probabilities = np.array([[KEEP, NO, NO], [REMOVE, proba(0, 0.6), proba(1, 0.9)], [KEEP, NO, NO],
                              [REMOVE, NO, NO]])
    result = restore(features, probabilities, CLASSES)
    assert result.removed.tolist() == [False, True, False, True]
    assert result.restored_rank.tolist() == [-1, 1, -1, -1]
    assert result.correct.tolist() == [True, True, True, False]
    numbers = evaluate_restoration(features, probabilities, CLASSES, ("standard",)).to_json()
    assert (numbers["restored"], numbers["wrong_to_right"], numbers["right_to_wrong"]) == (1, 1, 0)
    assert numbers["restored_by_rank"] == [1, 0]
    standard = numbers["modes"]["standard"]
    # removal keeps q0 (right), q2 (right): points (.25, 1), (.5, 1) -> AUC 0.5.
    # restoration keeps q0, q1 (restored, right), q2: (.25, 1), (.5, 1), (.75, 1) -> AUC 0.75.
    assert standard["curve_restoration"]["recall"] == pytest.approx([0, 0.25, 0.5, 0.75])
    assert standard["auc_removal"] == pytest.approx(0.5)
    assert standard["auc_restoration"] == pytest.approx(0.75)
    assert standard["auc_difference"] == pytest.approx(0.25)
    # AOC at the common max recall 0.75: removal 0.75 - 0.5, restoration 0.
    assert (standard["max_recall_removal"], standard["max_recall_restoration"]) == pytest.approx((0.5, 0.75))
    assert standard["aoc_removal"] == pytest.approx(0.25) and standard["aoc_restoration"] == pytest.approx(0.0)
    assert standard["reduction_pct"] == pytest.approx(100.0)
    # the baseline (every match kept): (.25, 1), (.25, .5), (.5, 2/3), (.5, .5) -> .25 + (.5 + 2/3) / 2 * .25
    assert standard["auc_vpr_sm"] == pytest.approx(0.25 + (0.5 + 2 / 3) / 8)


def test_restoration_loses_when_the_replacement_is_wrong_and_the_removed_match_was_right():
    # q1's match is right but removed; rank 1 (class 2, p .55, right) loses to rank 2 (class 0, p .7, wrong):
    # the highest probability wins, so the restored match is wrong. Scoring by the replaced match would call it
    # right; scoring by its own correctness must not.
    features = make_features([True, True, True, False], [[1, 0, 0], [0, 1, 0], [1, 0, 0], [0, 0, 0]])
    probabilities = np.array([[KEEP, NO, NO], [REMOVE, proba(2, 0.55), proba(0, 0.7)], [KEEP, NO, NO],
                              [REMOVE, NO, NO]])
    numbers = evaluate_restoration(features, probabilities, CLASSES, ("standard",)).to_json()
    assert numbers["restored_by_rank"] == [0, 1]
    assert (numbers["restored_correct"], numbers["restored_wrong"], numbers["right_to_wrong"]) == (0, 1, 1)
    standard = numbers["modes"]["standard"]
    # removal: q0, q2 right -> (.25, 1), (.5, 1): AUC .5. restoration: q0 right, q1 wrong, q2 right ->
    # (.25, 1), (.25, .5), (.5, 2/3): AUC .25 + (.5 + 2/3) / 2 * .25 = 19/48.
    assert standard["curve_restoration"]["precision"] == pytest.approx([1, 1, 0.5, 2 / 3])
    assert standard["auc_removal"] == pytest.approx(0.5)
    assert standard["auc_restoration"] == pytest.approx(19 / 48)
    assert standard["auc_difference"] == pytest.approx(-5 / 48)
    assert standard["aoc_removal"] == pytest.approx(0.0) and standard["aoc_restoration"] == pytest.approx(5 / 48)


def test_paper_mode_counts_recall_over_the_correct_proposed_matches():
    # q0 kept but wrong, q1 removed (wrong) and restored right by rank 1, q2 and q3 kept and right.
    features = make_features([False, False, True, True], [[0, 0, 0], [0, 1, 0], [1, 0, 0], [1, 0, 0]])
    probabilities = np.array([[KEEP, NO, NO], [REMOVE, proba(0, 0.6), NO], [KEEP, NO, NO], [KEEP, NO, NO]])
    paper = evaluate_restoration(features, probabilities, CLASSES, ("paper",)).to_json()["modes"]["paper"]
    # removal, 2 correct matches: TP = 0 below .3 -> (0, 0); (.5, .5) from .3; (1, 2/3) at .4.
    # AUC = (0 + .5) / 2 * .5 + (.5 + 2/3) / 2 * .5 = 5/12.
    assert paper["auc_removal"] == pytest.approx(5 / 12)
    # restoration, 3 correct proposed matches: (0, 0) below .2, (1/3, 1/2), (2/3, 2/3), (1, 3/4).
    # AUC = 1/12 + 7/36 + 17/72 = 37/72.
    assert paper["auc_restoration"] == pytest.approx(37 / 72)
    assert paper["auc_difference"] == pytest.approx(7 / 72)
    assert paper["aoc_removal"] == pytest.approx(7 / 12) and paper["aoc_restoration"] == pytest.approx(35 / 72)


def test_ties_go_to_the_lower_rank_and_min_score_and_the_removed_match_are_not_eligible():
    features = make_features([False, False], [[0, 1, 0], [0, 0, 1]],
                             rank_references=np.array([[0, 100, 101], [1, 1, 102]]),
                             sequence_distance=np.array([0.1, 0.2]))
    probabilities = np.array([[REMOVE, proba(0, 0.7), proba(2, 0.7)], [REMOVE, proba(0, 0.9), proba(2, 0.6)]])
    result = restore(features, probabilities, CLASSES)
    # q0: equal scores -> rank 1. q1: rank 1 is the removed match itself (reference 1) -> rank 2.
    assert result.restored_rank.tolist() == [1, 2]
    assert result.correct.tolist() == [True, True]
    assert restore(features, probabilities, CLASSES, min_score=0.65).restored_rank.tolist() == [1, -1]
