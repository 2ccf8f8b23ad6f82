"""``worse_from_zero`` (the baseline's AOC 0, the predictor's larger: worse by an undefined %) is said only where the
interval over queries of the AOC difference (predictor's minus baseline's) lies above 0, as improved and worse are
only where the reduction's interval earns them; otherwise the record, the tables and the words say
``interval_holds_0`` (or ``no_interval``, ``interval_against_sign``), and the comparison stays out of every mean of
reductions and out of the outcomes counted as harm.

Two removals from one split of 100 queries, worked out by hand (queries in distance order, recall over all 100 in
standard mode): one that keeps wrong matches early, its AOC clearly above the baseline's 0 on every draw of the
bootstrap; one whose AOC is 1.65e-4 from a single wrong match, which many draws leave out."""

from dataclasses import replace

import numpy as np
import pytest
from row_records import record

from vpr_smr.eval.report import html
from vpr_smr.eval.report import outcome_words as words
from vpr_smr.eval.report.rows import Column, Table1Row, cells
from vpr_smr.eval.report.tables.adaptive import AdaptiveSeqLenRow
from vpr_smr.eval.scoring import curves
from vpr_smr.eval.scoring.adaptive import Length, compute
from vpr_smr.eval.scoring.adaptive_records import AdaptiveResult
from vpr_smr.eval.scoring.evaluate import reduction_of, summarise_seeds, with_intervals
from vpr_smr.eval.scoring.intervals import comparison_draws, query_weights
from vpr_smr.eval.scoring.records import EvaluationSplit, Interval, ModeRemoval, Reduction, SeedNumbers

N = 100
DISTANCES = np.arange(1.0, N + 1)
# 60 correct, 20 wrong, 20 correct: the baseline's precision is 1 up to recall 0.6
CORRECT = np.r_[np.ones(60), np.zeros(20), np.ones(20)].astype(bool)
# A keeps every fifth of the first 60 (12) and all the rest: its maximum recall is 32/100, where the baseline's AOC is
# 0; its curve runs at precision 1 to recall 0.12, drops to 12/32 over the 20 wrong (no width), then climbs to 32/52
# over the last 20 correct.
KEEP_A = np.r_[np.arange(60) % 5 == 0, np.ones(40, bool)]
AOC_A = 0.32 - (0.12 + sum(0.01 * ((12 + j - 1) / (32 + j - 1) + (12 + j) / (32 + j)) / 2 for j in range(1, 21)))
# B keeps queries 1..60 and 80: 59 correct, the first wrong, one late correct. Its maximum recall is 60/100, where the
# baseline's first wrong match adds no width (AOC 0); its curve reaches 0.59 at precision 1, then 59/60 at the wrong
# match, 60/61 at recall 0.6.
KEEP_B = np.isin(np.arange(N), [*range(1, 61), 80])
AOC_B = 0.6 - (0.59 + 0.01 * (59 / 60 + 60 / 61) / 2)


def _compared(correct, keep):
    everything = np.ones(len(correct), bool)
    return curves.compare_curves(curves.standard_curve(DISTANCES[: len(correct)], correct, everything),
                                 curves.standard_curve(DISTANCES[: len(correct)], correct, keep))


def _difference_interval(correct, keep):
    """The percentile interval of the AOC difference over the bootstrap's draws, each draw's queries written out
    (every query repeated as often as drawn) and compared by ``curves`` alone, without weights."""
    found = []
    for block in query_weights(N):
        for weights in block:
            drawn = np.repeat(np.arange(N), weights)
            comparison = curves.compare_curves(
                curves.standard_curve(DISTANCES[drawn], correct[drawn], np.ones(len(drawn), bool)),
                curves.standard_curve(DISTANCES[drawn], correct[drawn], keep[drawn]))
            found.append(comparison.aoc_predictor - comparison.aoc_baseline)
    low, high = np.percentile(found, [2.5, 97.5])
    return Interval(float(low), float(high))


def _with_intervals(correct, keep):
    reduction = reduction_of(_compared(correct, keep), N, int((~keep).sum()))
    draws = comparison_draws("standard", DISTANCES, correct, [keep], DISTANCES.min(), DISTANCES.max())[0]
    return reduction, with_intervals(reduction, draws)


@pytest.mark.parametrize(("correct", "keep", "aoc", "expected"), [
    (CORRECT, KEEP_A, AOC_A, curves.WORSE_FROM_ZERO),
    (CORRECT, KEEP_B, AOC_B, curves.HOLDS_ZERO),
])
def test_worse_from_zero_is_said_only_where_the_aoc_difference_interval_lies_above_zero(correct, keep, aoc, expected):
    comparison = _compared(correct, keep)
    assert comparison.aoc_baseline == pytest.approx(0.0, abs=1e-12) and comparison.reduction_pct is None
    assert comparison.aoc_predictor == pytest.approx(aoc, rel=1e-9)
    assert curves.outcome(N, int((~keep).sum()), comparison) == curves.WORSE_FROM_ZERO  # the point estimate's word
    interval = _difference_interval(correct, keep)
    assert curves.from_zero(interval) == expected
    if expected == curves.HOLDS_ZERO:
        assert interval.low <= 0.0 < interval.high
    else:
        assert interval.low > 0.005  # the draws keep wrong matches early
    without, judged = _with_intervals(correct, keep)
    assert without.outcome == curves.NO_INTERVAL  # made without intervals: nothing earns the word yet
    assert judged.outcome == expected and judged.reduction_pct is None and judged.reduction_pct_ci is None
    # the interval that judged it is kept beside the word: the naive loop's, over the same draws
    assert without.aoc_difference_ci is None
    assert judged.aoc_difference_ci is not None
    assert (judged.aoc_difference_ci.low, judged.aoc_difference_ci.high) == pytest.approx((interval.low, interval.high),
                                                                                          abs=1e-12)
    # the record read back keeps the word it was given and its interval, and earned (what every table applies)
    # leaves it as it is
    assert Reduction.from_json(judged.to_json()).outcome == expected
    assert Reduction.from_json(judged.to_json()).aoc_difference_ci == judged.aoc_difference_ci
    assert curves.earned(judged.outcome, judged.reduction_pct_ci) == expected


@pytest.mark.parametrize(("interval", "expected"), [
    ((0.002, 0.03), curves.WORSE_FROM_ZERO),
    ((0.0, 0.03), curves.HOLDS_ZERO),  # a bound at 0 holds it
    ((-0.01, 0.03), curves.HOLDS_ZERO),
    ((-0.03, -0.01), curves.AGAINST_SIGN),
    (None, curves.NO_INTERVAL),
])
def test_the_rule_for_worse_from_zero(interval, expected):
    assert curves.from_zero(None if interval is None else Interval(*interval)) == expected


def test_an_unearned_worse_from_zero_is_no_harm_and_stays_out_of_the_means():
    assert curves.WORSE_FROM_ZERO in curves.HARMFUL  # earned: counted against the predictor
    assert not set(curves.NOT_EARNED) & set(curves.HARMFUL)
    for word in curves.NOT_EARNED:
        assert curves.is_from_zero(word, None) and curves.reduction_undefined(word, None)
        assert not curves.is_from_zero(word, -12.0) and not curves.reduction_undefined(word, -12.0)
    # seed 0 earned worse from 0; seed 1 improved by 10 %, seed 2 made worse from 0 without an interval, seed 3 by 30 %
    without, a = _with_intervals(CORRECT, KEEP_A)
    b = _with_intervals(CORRECT, KEEP_B)[1]
    improved = Reduction(0.8, 0.6, 0.7, 0.2, 0.18, 10.0, 0.8, 0.2, curves.IMPROVED)
    better = Reduction(0.8, 0.6, 0.7, 0.2, 0.14, 30.0, 0.8, 0.2, curves.IMPROVED)
    seeds = {0: {"standard": a}, 1: {"standard": improved}, 2: {"standard": without},
             3: {"standard": better}, 4: {"standard": b}}
    summary = summarise_seeds(seeds)["standard"]
    assert summary.n_seeds == 5 and summary.n_seeds_defined == 2
    assert summary.reduction_pct_mean == pytest.approx(20.0)  # (10 + 30) / 2: the three from 0 are left out
    assert summary.outcomes == {0: curves.WORSE_FROM_ZERO, 1: curves.NO_INTERVAL, 2: curves.NO_INTERVAL,
                                3: curves.NO_INTERVAL, 4: curves.HOLDS_ZERO}
    # the seeds left out and why: the ones whose reduction is undefined, in the words of the table
    assert words.seeds_left_out(summary.outcomes, [0, 2, 4]) == (
        "seed 0: worse than a perfect baseline; seed 2: perfect baseline, no interval; "
        "seed 4: perfect baseline, holds 0")
    assert words.seeds_left_out(summary.outcomes) == "seed 0: worse than a perfect baseline"


def test_table1_and_the_page_say_why_a_perfect_baseline_made_worse_is_left_out():
    # seed 0 (Table I's) made worse from 0 with an interval that holds 0 (B), seed 1 improved by 10 % without an
    # interval, seed 2 made worse from 0 without an interval, seed 3 earned worse from 0 (A)
    without, a = _with_intervals(CORRECT, KEEP_A)
    b = _with_intervals(CORRECT, KEEP_B)[1]
    improved = Reduction(0.8, 0.6, 0.7, 0.2, 0.18, 10.0, 0.8, 0.2, curves.IMPROVED)
    seeds = {0: b, 1: improved, 2: without, 3: a}
    summary = summarise_seeds({seed: {"standard": r} for seed, r in seeds.items()})["standard"]
    split = EvaluationSplit(N, N, 0.5, 0.5, 0.6, 0.5, ((1, 0), (0, 1)), (20, 10, 5, 5), (20, 10, 5, 5), 1,
                            {"standard": ModeRemoval(0.5, 0.6, b)}, 0,
                            tuple(SeedNumbers(seed, 0.5, 1, {"standard": r}) for seed, r in seeds.items() if seed),
                            {"standard": summary})
    row = Table1Row.of(("d", "sad", 4), "standard", split)
    # seed 1's reduction is defined (no interval, no direction): it is in the spread, not left out
    assert row.seeds_left_out == ("seed 0: perfect baseline, holds 0; seed 2: perfect baseline, no interval; "
                                  "seed 3: worse than a perfect baseline")
    found = html.row_cell(cells(row), Column("reduction_pct"))
    held = _difference_interval(CORRECT, KEEP_B)
    shown = f"[{held.low:+.4f}, {held.high:+.4f}]"
    assert (found.text, found.kind) == (f"n/a: perfect baseline, holds 0 (AOC difference {shown})", "na")
    assert (cells(row)["aoc_difference_ci_low"], cells(row)["aoc_difference_ci_high"]) == pytest.approx(
        (held.low, held.high), abs=1e-12)
    # Table I's own cell (Markdown, LaTeX, the page's paper layout) names it too
    assert words.reduction_cell(row, "n/a") == f"n/a: perfect baseline, holds 0 (AOC difference {shown})"
    assert html.row_cell(cells(row), Column("reduction_pct_mean")).text == "10.0000"  # defined: its number


def test_the_words_of_a_table_row_say_no_direction_for_an_unearned_one():
    row = record(Table1Row, {"aoc_vpr_sm": 0.0, "aoc_vpr_sm_pred": AOC_B, "reduction_pct": None,
                             "outcome": curves.HOLDS_ZERO, "max_recall": 0.6, "max_recall_vpr_sm": 0.62,
                             "aoc_vpr_sm_own": 0.0002, "n_queries": N, "removed": 1})
    assert words.reduction_cell(row, "n/a") == "n/a: perfect baseline, holds 0"
    assert words.is_degenerate(row.outcome, row.reduction_pct)
    assert words.baseline_cell(row, "0.0000") == "0.0000 (own: 0.0002)"  # lowered recall, an undefined reduction
    assert words.note(row) == (
        "the baseline's AOC is 0 up to the predictor's maximum recall 0.6000 and the predictor's 0.0002, but the "
        "interval over queries of the difference holds 0: no direction, and the reduction is undefined (the "
        "baseline's AOC being 0)")
    assert "worse" not in words.note(row) + words.reduction_cell(row, "n/a")
    earned = replace(row, outcome=curves.WORSE_FROM_ZERO)
    assert words.reduction_cell(earned, "n/a") == "n/a: worse than a perfect baseline"


def test_the_adaptive_tables_outcome_column_uses_the_rule():
    # the same matches at both lengths, L2's predictor removal A, L4's B, each against L4 without predictor
    table = [Length(seq_len, DISTANCES.copy(), CORRECT, 1.0, float(N), (keep,), np.zeros(N))
             for seq_len, keep in ((2, KEEP_A), (4, KEEP_B))]
    rows, best = compute(table, None, ["standard"])
    result = AdaptiveResult({"dataset": "d", "method": "sad", "tag": "seqslam"}, (2, 4), N, None, tuple(rows), best,
                            ())
    outcomes = {row.name: AdaptiveSeqLenRow.of(result, row, "standard", None).outcome for row in rows}
    assert outcomes["L2"] == outcomes["L4"] == curves.KEPT_ALL
    assert outcomes["L2+pred"] == curves.WORSE_FROM_ZERO
    assert outcomes["L4+pred"] == curves.HOLDS_ZERO
    said = {row.name: cells(AdaptiveSeqLenRow.of(result, row, "standard", None)) for row in rows}
    for name in ("L2", "L4"):  # not from zero: no interval of the AOC difference, empty columns
        assert said[name]["aoc_difference_ci_low"] is None and said[name]["aoc_difference_ci_high"] is None
    for name, keep, word in (("L2+pred", KEEP_A, "worse than a perfect baseline"),
                             ("L4+pred", KEEP_B, "perfect baseline, holds 0")):
        naive = _difference_interval(CORRECT, keep)
        assert (said[name]["aoc_difference_ci_low"], said[name]["aoc_difference_ci_high"]) == pytest.approx(
            (naive.low, naive.high), abs=1e-12)
        assert html.row_cell(said[name], Column("reduction_pct")).text == (
            f"n/a: {word} (AOC difference [{naive.low:+.4f}, {naive.high:+.4f}])")
    for name, keep in (("L2+pred", KEEP_A), ("L4+pred", KEEP_B)):
        numbers = rows[[r.name for r in rows].index(name)].modes["standard"].reduction
        assert numbers.outcome == curves.from_zero(_difference_interval(CORRECT, keep)) == outcomes[name]


def test_the_interval_is_kept_for_a_from_zero_outcome_only_and_an_older_file_reads_none():
    # a removal whose baseline AOC is above 0 (the first 20 queries wrong) has a reduction: no AOC difference kept
    correct = np.r_[np.zeros(5), np.ones(95)].astype(bool)
    keep = np.r_[np.zeros(5, bool), np.ones(95, bool)]
    _, judged = _with_intervals(correct, keep)
    assert judged.reduction_pct is not None and judged.aoc_difference_ci is None
    # a file written before the field existed has none: it reads back as None
    _, earned_a = _with_intervals(CORRECT, KEEP_A)
    older = {key: value for key, value in earned_a.to_json().items() if key != "aoc_difference_ci"}
    assert Reduction.from_json(older).aoc_difference_ci is None


def test_the_console_names_the_interval_of_a_from_zero_outcome():
    from vpr_smr.pipeline.stages.predictor import reduction_text

    _, a = _with_intervals(CORRECT, KEEP_A)
    naive = _difference_interval(CORRECT, KEEP_A)
    assert reduction_text(a) == (
        f"n/a (worse than a perfect baseline, AOC difference [{naive.low:+.4f}, {naive.high:+.4f}])")
