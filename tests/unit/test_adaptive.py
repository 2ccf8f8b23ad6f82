"""The adaptive sequence length (method §15): the rule, the threshold of adaptive_uniqueness and every row's numbers,
against a case worked out by hand and against a naive per-query loop on a real matrix."""

import numpy as np
import pytest

from vpr_smr.eval.matching.adaptive import NONE, first_accepted, used_lengths
from vpr_smr.eval.scoring.adaptive import Length, choose, compute, uniqueness_threshold
from vpr_smr.eval.scoring.adaptive_records import ADAPTIVE, ADAPTIVE_FALLBACK, ADAPTIVE_UNIQUENESS

# --- the rule ---------------------------------------------------------------------------------------------------


def test_the_shortest_accepting_length_is_chosen_and_none_is_named():
    accepted = np.array([[False, True, False, False],
                         [True, True, False, False],
                         [False, False, False, True]])
    assert first_accepted(accepted).tolist() == [1, 0, NONE, 2]
    assert used_lengths(first_accepted(accepted), (2, 4, 8)).tolist() == [4, 2, 8, 8]  # none: every length computed
    with pytest.raises(ValueError, match=r"one row per sequence length \(m, N\)"):
        first_accepted(np.array([True, False]))


def test_the_threshold_removes_as_many_as_adaptive_does_on_validation_fewer_on_ties():
    uniqueness = np.array([[1.0, 3.0, 1.2, 0.9],
                           [2.0, 1.1, 1.0, 0.8]])
    # largest per query: 2.0, 3.0, 1.2, 0.9; sorted 0.9, 1.2, 2.0, 3.0
    assert uniqueness_threshold(uniqueness, 2) == 2.0  # 0.9 and 1.2 are below it: two removed
    assert uniqueness_threshold(uniqueness, 0) == 0.9  # nothing below the smallest
    assert uniqueness_threshold(uniqueness, 4) == np.inf  # every query goes
    tied = np.array([[1.0, 1.0, 1.0, 2.0]])
    assert uniqueness_threshold(tied, 1) == 1.0  # nothing is below 1.0: none removed (equal values straddle the cut)


# --- a case worked out by hand ------------------------------------------------------------------------------------


def _length(seq_len, distances, correct, keeps, uniqueness):
    distances = np.asarray(distances, float)
    return Length(seq_len, distances, np.asarray(correct, bool), float(distances.min()), float(distances.max()),
                  (np.asarray(keeps, bool),), np.asarray(uniqueness, float))


# per-frame distances of the matches, their correctness, the seed-0 predictor's keep and the uniqueness, 4 queries
TABLE = [_length(2, [0.1, 0.2, 0.3, 0.4], [0, 0, 1, 1], [1, 0, 0, 1], [1.5, 1.0, 2.5, 2.0]),
         _length(4, [0.15, 0.25, 0.05, 0.02], [1, 1, 0, 1], [1, 1, 0, 0], [1.2, 2.2, 1.0, 1.0])]
VALIDATION = [_length(2, [0.1] * 4, [1] * 4, [0, 1, 0, 0], [1.0, 3.0, 1.2, 0.9]),
              _length(4, [0.1] * 4, [1] * 4, [1, 0, 0, 0], [2.0, 1.1, 1.0, 0.8])]


def test_each_rule_chooses_by_hand():
    # q0: L2 keeps; q1: L2 removes, L4 keeps; q2: neither; q3: L2 keeps
    chosen, keep = choose(TABLE, ADAPTIVE)
    assert chosen.tolist() == [0, 1, NONE, 0] and keep.tolist() == [True, True, False, True]
    chosen, keep = choose(TABLE, ADAPTIVE_FALLBACK)
    assert chosen.tolist() == [0, 1, NONE, 0] and keep.all()
    # validation: adaptive removes q2 and q3 there, so tau = 2.0 (above); uniqueness >= 2.0: L2 q2, q3; L4 q1
    chosen, keep = choose(TABLE, ADAPTIVE_UNIQUENESS, tau=2.0)
    assert chosen.tolist() == [NONE, 1, 0, 0] and keep.tolist() == [False, True, True, True]


def test_every_row_by_hand_in_standard_mode():
    rows, best = compute(TABLE, VALIDATION, ["standard"])
    by_name = {row.name: row for row in rows}
    assert list(by_name) == ["L2", "L4", "L2+pred", "L4+pred", ADAPTIVE, ADAPTIVE_FALLBACK, ADAPTIVE_UNIQUENESS]
    adaptive = by_name[ADAPTIVE]
    assert adaptive.removed == 1 and adaptive.mean_length == 3.0  # (2 + 4 + 4 + 2) / 4: none counts the longest
    assert adaptive.lengths == {NONE: 1, 2: 2, 4: 1}
    # kept, by distance: 0.1 wrong, 0.25 right, 0.4 right (recall over 4 queries): (0, 0), (.25, .5), (.5, 2/3);
    # AUC .25 * .5 / 2 + .25 * (.5 + 2/3) / 2 = 0.2083333; AOC = .5 - AUC
    numbers = adaptive.modes["standard"].reduction
    assert numbers.max_recall == 0.5
    assert numbers.aoc_vpr_sm_pred == pytest.approx(0.5 - 0.0625 - 0.1458333333, abs=1e-9)
    # against L4 without predictor: 0.02 right, 0.05 wrong, 0.15 right, 0.25 right -> (.25, 1), (.25, .5),
    # (.5, 2/3), (.75, .75); cut to recall .5: AUC .25 + .1458333 -> AOC .1041667
    assert numbers.aoc_vpr_sm == pytest.approx(0.5 - 0.25 - 0.1458333333, abs=1e-9)
    assert numbers.reduction_pct == pytest.approx(100 * (0.1041666667 - 0.2916666667) / 0.1041666667, rel=1e-8)
    # worse by its estimate, but 4 queries are too few draws to define an interval: no direction is named
    assert numbers.reduction_pct_ci is None and numbers.outcome == "no_interval"
    # fallback keeps q2 with L4's wrong match at 0.05: (0, 0), (0, 0), (.25, 1/3), (.5, 1/2): AUC .1458333
    fallback = by_name[ADAPTIVE_FALLBACK].modes["standard"].reduction
    assert fallback.aoc_vpr_sm_pred == pytest.approx(0.5 - 0.0416666667 - 0.1041666667, abs=1e-9)
    # nothing removed, yet other matches than the longest's: not kept_all (worse by its estimate, no interval)
    assert fallback.reduction_pct < 0 and fallback.outcome == "no_interval"
    uniq = by_name[ADAPTIVE_UNIQUENESS]
    assert uniq.threshold == 2.0 and uniq.removed == 1 and uniq.mean_length == 3.0
    # L4's own row is the baseline: kept_all, reduction 0
    assert by_name["L4"].modes["standard"].reduction.outcome == "kept_all"
    assert by_name["L4"].modes["standard"].seeds is None and by_name["L4+pred"].modes["standard"].seeds is not None
    # L4+pred keeps 0.15 and 0.25, both right: AOC 0, the smallest of the fixed rows
    assert by_name["L4+pred"].modes["standard"].reduction.aoc_vpr_sm_pred == pytest.approx(0.0, abs=1e-12)
    assert best == {"standard": "L4+pred"}
    # both at recall .5, the smaller of the two maximum recalls (here equal): .2916667 - 0
    assert adaptive.modes["standard"].minus_best_fixed == pytest.approx(0.2916666667, abs=1e-9)
    # uniqueness keeps q1 (L4, right), q2 and q3 (L2, right): precision 1 up to recall .75, AOC 0 at .5 too
    assert uniq.modes["standard"].minus_best_fixed == pytest.approx(0.0, abs=1e-12)
    assert by_name["L2"].modes["standard"].minus_best_fixed_ci is None  # fixed rows compare with nothing


def test_rows_are_compared_in_standard_mode_only():
    # paper mode's recall divides by each row's own correct matches: no best fixed row, no difference there
    rows, best = compute(TABLE, VALIDATION, ["paper", "standard"])
    assert best == {"standard": "L4+pred"}
    adaptive = next(row for row in rows if row.name == ADAPTIVE)
    assert adaptive.modes["paper"].minus_best_fixed is None and adaptive.modes["paper"].minus_best_fixed_ci is None
    assert compute(TABLE, VALIDATION, ["paper"])[1] == {}


def test_a_rule_equal_to_the_best_fixed_row_differs_by_exactly_zero_on_every_draw():
    # L2's predictor keeps nothing, L4's everything: adaptive takes L4's match everywhere, which is the row L4 (the
    # best fixed row: L4+pred ties with it, same AOC and recall, and comes later); paired draws give 0 on each
    table = [_length(2, [0.3, 0.1, 0.2, 0.4, 0.5, 0.6], [0, 0, 1, 0, 1, 0], [0] * 6, [1.0] * 6),
             _length(4, [0.1, 0.2, 0.3, 0.4, 0.5, 0.6], [1, 1, 0, 1, 0, 1], [1] * 6, [1.0] * 6)]
    rows, best = compute(table, None, ["standard"])
    assert best == {"standard": "L4"}
    adaptive = next(row for row in rows if row.name == ADAPTIVE).modes["standard"]
    assert adaptive.minus_best_fixed == 0.0
    assert (adaptive.minus_best_fixed_ci.low, adaptive.minus_best_fixed_ci.high) == (0.0, 0.0)


def test_the_best_fixed_row_breaks_ties_by_the_larger_recall():
    from vpr_smr.eval.scoring.adaptive import best_fixed
    from vpr_smr.eval.scoring.records import Reduction

    def numbers(aoc, recall, outcome="improved"):
        return Reduction(recall, 0.0, 0.0, 0.0, aoc, None, 1.0, 0.0, outcome)

    rows = [("L2", "fixed", 2, numbers(0.1, 0.9)), ("L2+pred", "fixed+predictor", 2, numbers(0.0, 0.3)),
            ("L4+pred", "fixed+predictor", 4, numbers(0.0, 0.6)), ("L8+pred", "fixed+predictor", 8,
                                                                   numbers(0.0, 0.0, "removed_all")),
            ("adaptive", "rule", None, numbers(0.0, 0.9))]
    assert best_fixed(rows) == "L4+pred"  # AOC 0 at recall .6 before AOC 0 at .3; removing all is no candidate
    assert best_fixed(rows[3:]) is None
    # the AOC alone would take a row that keeps almost nothing: AOC .02 at recall .02 is precision 0 throughout
    # (.02 / .02 = 1 of the precision lost), AOC .05 at recall .8 loses .0625 of it
    assert best_fixed([("L2+pred", "fixed+predictor", 2, numbers(0.02, 0.02)),
                       ("L8+pred", "fixed+predictor", 8, numbers(0.05, 0.8))]) == "L8+pred"


def test_without_validation_adaptive_uniqueness_is_left_out():
    rows, _ = compute(TABLE, None, ["standard"])
    assert ADAPTIVE_UNIQUENESS not in [row.name for row in rows]


# --- a naive per-query loop on a real matrix ----------------------------------------------------------------------


class ThresholdPredictor:
    """A predictor whose rank-0 A3 decides: class 0 (kept) below ``cut``, else 3."""

    classes_ = np.array([0, 1, 2, 3])

    def __init__(self, cut):
        self.cut = cut

    def predict_proba(self, x):
        keep = np.asarray(x)[:, 2] < self.cut
        out = np.zeros((len(x), 4))
        out[keep, 0], out[~keep, 3] = 1.0, 1.0
        return out


def test_the_rules_equal_a_naive_loop_on_a_real_matrix():
    from sample_matrix import sample_distances

    from vpr_smr.eval.matching.attributes import query_features
    from vpr_smr.eval.matching.confidence import uniqueness
    from vpr_smr.eval.scoring.curves import compare_curves, curve
    from vpr_smr.eval.scoring.scorers import DEFAULT_SETTINGS

    matrix = sample_distances(300, 90)
    lengths = (2, 4, 6)
    predictors = {2: ThresholdPredictor(0.45), 4: ThresholdPredictor(0.66), 6: ThresholdPredictor(0.75)}
    features = {n: query_features(matrix, n, n_candidates=DEFAULT_SETTINGS.candidates) for n in lengths}
    queries = np.arange(5, 90)  # a >= L_m - 1
    table = [Length.of(features[n], queries, n, n, [predictors[n]], DEFAULT_SETTINGS) for n in lengths]
    rows, _ = compute(table, None, ["standard", "paper"])
    found = {row.name: row for row in rows}
    # the naive loop: per query, the lengths shortest first, the first whose predictor keeps the match
    distances, correct, kept, used = [], [], [], []
    for a in queries:
        choice = None
        for n in lengths:
            row = int(np.flatnonzero(features[n].queries == a)[0])
            if predictors[n].predict_proba(features[n].attributes[row : row + 1, 0, :])[0, 0] == 1.0:
                choice = (n, row)
                break
        n, row = choice if choice is not None else (6, int(np.flatnonzero(features[6].queries == a)[0]))
        distances.append(features[n].sequence_distance[row] / n)  # per frame: SeqSLAM sums n frames
        correct.append(bool(features[n].sequence_correct[row]))
        kept.append(choice is not None)
        used.append(n)
    distances, correct, kept = np.array(distances), np.array(correct), np.array(kept)
    adaptive, fallback = found[ADAPTIVE], found[ADAPTIVE_FALLBACK]
    assert adaptive.removed == int((~kept).sum()) and adaptive.mean_length == pytest.approx(np.mean(used))
    assert fallback.removed == 0 and fallback.mean_length == adaptive.mean_length
    assert 0 < adaptive.removed < len(queries)  # the case exercises both: a kept and a removed query
    assert {n: used.count(n) for n in lengths} != {2: len(queries)}  # and more than one length
    longest = features[6]
    low = min(features[n].sequence_min / n for n in lengths)
    high = max(features[n].sequence_max / n for n in lengths)
    base_d, base_c = longest.sequence_distance / 6, longest.sequence_correct
    for mode in ("standard", "paper"):
        base = curve(mode, base_d, base_c, np.ones(len(queries), bool), longest.sequence_min / 6,
                     longest.sequence_max / 6)
        expected = compare_curves(base, curve(mode, distances, correct, kept, low, high))
        numbers = adaptive.modes[mode].reduction
        assert numbers.aoc_vpr_sm_pred == pytest.approx(expected.aoc_predictor, abs=1e-12)
        assert numbers.aoc_vpr_sm == pytest.approx(expected.aoc_baseline, abs=1e-12)
        assert numbers.max_recall == expected.max_recall
        every = compare_curves(base, curve(mode, distances, correct, np.ones(len(queries), bool), low, high))
        assert fallback.modes[mode].reduction.aoc_vpr_sm_pred == pytest.approx(every.aoc_predictor, abs=1e-12)
    # uniqueness: the §12 scorer on each length's candidates (L4 evaluates queries 3.., the shared ones are 5..)
    expected_u = uniqueness(features[4].sequence_candidates[2:], features[4].sequence_candidate_references[2:],
                            DEFAULT_SETTINGS.half_window)
    np.testing.assert_array_equal(table[1].uniqueness, expected_u)
