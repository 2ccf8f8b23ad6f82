"""Extended precision as VPR-Bench computes it (``performance_comparison.compute_extendedprecision``): ``P_R0`` is
``precision[-2]`` of scikit-learn's PR curve, the precision at the strictest threshold, so a wrong most-confident
match gives ``P_R0 = 0`` (and ``R_P100 = 0``), not the precision at the first non-zero recall. Worked by hand on a
4 x 4 matrix no other test uses, and checked against scikit-learn's curve read the way VPR-Bench reads it."""

import numpy as np
import pytest
from sklearn.metrics import precision_recall_curve

from vpr_smr.eval.scoring.vpr_metrics import precision_at_strictest, score_split

# references x queries; tolerance 0: a match is correct iff r == q. Single matches (column minimum):
# q0 -> r1 at 0.1 (wrong), q1 -> r1 at 0.3 (right), q2 -> r2 at 0.5 (right), q3 -> r0 at 0.7 (wrong).
D = np.array([
    [0.9, 0.8, 0.9, 0.7],
    [0.1, 0.3, 0.9, 0.9],
    [0.9, 0.9, 0.5, 0.9],
    [0.9, 0.9, 0.9, 0.8],
])


def vpr_bench_p_r0(distances, correct):
    """VPR-Bench's P_R0: scikit-learn's curve of the matches scored by similarity, its second-last precision."""
    precision, _, _ = precision_recall_curve(np.asarray(correct, dtype=int), -np.asarray(distances, dtype=float))
    return float(precision[-2])


def test_a_wrong_most_confident_match_gives_zero():
    metrics = score_split(D, 2, 0, modes=("paper", "standard")).metrics.modes
    # Paper mode scores every query: matches F T T F by ascending distance 0.1 0.3 0.5 0.7. The strictest threshold
    # (0.1) accepts q0's wrong match alone: P_R0 = 0/1 = 0, so R_P100 = 0 and EP = (0 + 0) / 2 = 0. (The precision at
    # the first non-zero recall, 1/2 at 0.3, gave the old 0.25.)
    assert metrics["paper"]["single"].extended_precision == 0.0
    assert vpr_bench_p_r0([0.1, 0.3, 0.5, 0.7], [False, True, True, False]) == 0.0
    # Standard mode scores q1..q3: T T F at 0.3 0.5 0.7. P_R0 = 1/1; R@100P over its 3 queries 2/3 (0.5: TP 2, FP 0);
    # EP = (1 + 2/3) / 2 = 5/6.
    assert metrics["standard"]["single"].extended_precision == pytest.approx(5 / 6)


@pytest.mark.parametrize(("keep", "expected"), [
    ([True, True, True, True], 0.5),  # 0.2 is tied by a right and a wrong match: 1/2
    ([False, True, True, True], 0.0),  # without the right one, the wrong match alone at 0.2
    ([True, False, True, True], 1.0),
    ([False, False, True, True], 0.0),  # 0.4 wrong
    ([False, False, False, False], 0.0),  # nothing kept: nothing accepted at any threshold
])
def test_ties_at_the_strictest_threshold_count_together(keep, expected):
    distances = np.array([0.2, 0.2, 0.4, 0.6])
    correct = np.array([True, False, False, True])
    keep = np.array(keep)
    assert precision_at_strictest(distances, correct, keep) == expected
    if keep.any():
        assert vpr_bench_p_r0(distances[keep], correct[keep]) == expected
