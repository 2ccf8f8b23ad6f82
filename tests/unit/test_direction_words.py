"""One rule for words: a direction (improved, worse, helps, better) is named only where its interval excludes 0 on
the estimate's side, with the interval beside it. Every writer of such words is fed a removal whose interval holds
0 (no direction word may appear) and one whose interval excludes 0 (its word must appear)."""

from __future__ import annotations

import csv
import io
import re
from collections.abc import Callable

import pytest
from report_runs import matcher_reduction
from row_records import record

from vpr_smr.eval.report import rows as report_rows
from vpr_smr.eval.report.baselines import baseline_rows
from vpr_smr.eval.report.build import latex_table, markdown_table
from vpr_smr.eval.report.findings import headline, sentences
from vpr_smr.eval.report.rows import HeldOutRow, SpeedRow, SweepRow, Table1Row, TrustRow, cells
from vpr_smr.eval.report.table1 import Table1Block, table1_latex, table1_markdown
from vpr_smr.eval.report.tables.adaptive import AdaptiveSeqLenRow
from vpr_smr.eval.report.tables.matchers import MatchersRow, comparison_sentence
from vpr_smr.eval.scoring import curves
from vpr_smr.eval.scoring.adaptive_records import AdaptiveMode, AdaptiveResult, AdaptiveRow
from vpr_smr.eval.scoring.matcher_comparison import MatcherComparison, MatcherMode, MatcherScores
from vpr_smr.eval.scoring.records import (
    Baselines,
    BudgetRemoval,
    Detection,
    EvaluationSplit,
    HeldOut,
    HeldOutPredictors,
    HeldOutScores,
    Interval,
    ModeRemoval,
    Reduction,
    ScorerRemoval,
    SeedSummary,
    SplitBaselines,
    SplitMetrics,
    SweepPoint,
    TrustNumbers,
    VPRMetrics,
)
from vpr_smr.eval.scoring.speed import SpeedResult, SpeedScores
from vpr_smr.eval.scoring.vpr_metrics import format_baselines
from vpr_smr.pipeline.stages.studies import adaptive_text

# The words that name a direction; lower case, so that a column headed "Improved" (a count) is not one
DIRECTION = re.compile(r"\b(improved|worse|helps|hurts|better)\b")
KEY = ("d", "m", 4)


@pytest.mark.parametrize(("outcome", "interval", "expected"), [
    # worked out by hand from the rule: the word only where the interval lies wholly on the estimate's side of 0
    ("improved", (1.0, 5.0), "improved"),
    ("worse", (-9.0, -1.0), "worse"),
    ("improved", (-2.0, 8.0), "interval_holds_0"),
    ("worse", (-3.3, 0.3), "interval_holds_0"),
    ("improved", (0.0, 4.0), "interval_holds_0"),  # a bound at 0 holds it
    ("improved", None, "no_interval"),
    ("worse", None, "no_interval"),
    ("improved", (-5.0, -1.0), "interval_against_sign"),  # a bootstrap interval can lie across the estimate
    ("removed_all", (-5.0, 5.0), "removed_all"),  # the degenerate words stay
    ("kept_all", None, "kept_all"),
    ("unchanged", (-1.0, 1.0), "unchanged"),
    ("interval_holds_0", (-1.0, 1.0), "interval_holds_0"),  # a word the rule gave stays as it is
])
def test_the_rule(outcome, interval, expected):
    assert curves.earned(outcome, None if interval is None else Interval(*interval)) == expected


def reduction(pct: float, interval: tuple[float, float] | None) -> Reduction:
    """A seed-0 removal whose reduction is ``pct`` (its outcome by the sign, as ``curves.outcome`` names it)."""
    return Reduction(0.8, 0.6, 0.7, 0.2, 0.2 * (1 - pct / 100), pct, 0.8, 0.2, "improved" if pct > 0 else "worse",
                     None if interval is None else Interval(*interval), Interval(0.15, 0.25), Interval(0.1, 0.3))


def _written(row_type: type, found: list[dict]) -> list[str]:
    """The row's table as the report writes it: CSV, Markdown and LaTeX."""
    columns = [column.name for column in report_rows.columns(row_type)]
    text = io.StringIO()
    writer = csv.DictWriter(text, columns, extrasaction="ignore")
    writer.writeheader()
    writer.writerows(found)
    return [text.getvalue(), markdown_table(columns, found), latex_table(columns, found)]


def table1(r: Reduction) -> tuple[str, list[str]]:
    split = EvaluationSplit(40, 43, 0.5, 0.5, 0.6, 0.5, ((1, 0), (0, 1)), (20, 10, 5, 5), (20, 10, 5, 5), 6,
                            {"paper": ModeRemoval(0.5, 0.6, r)}, 0, (),
                            {"paper": SeedSummary(1, 1, r.reduction_pct, None, r.reduction_pct, r.reduction_pct,
                                                  {0: r.outcome})})
    found = Table1Row.of(KEY, "paper", split)
    row, block = cells(found), Table1Block("d", "paper", 4, (found,))
    return row["outcome"], [*_written(Table1Row, [row]), table1_markdown([found]), table1_latex([found]),
                            *sentences(block, "test"), headline(block, "test")]


def held_out(r: Reduction) -> tuple[str, list[str]]:
    scores = HeldOutScores("p.h5", 0.5, 6, {"paper": ModeRemoval(0.5, 0.6, r)})
    row = cells(HeldOutRow.of(KEY, "paper", HeldOut({"dataset": "d", "method": "m", "seq_len": 4}, 40,
                                                    HeldOutPredictors(scores, scores))))
    assert row["outcome_pooled"] == row["outcome_without"]
    return row["outcome_pooled"], _written(HeldOutRow, [row])


def trust(r: Reduction) -> tuple[str, list[str]]:
    numbers = TrustNumbers(6, r.max_recall, 0.6, r.aoc_vpr_sm_pred, 0.7, r.aoc_vpr_sm, r.reduction_pct, r.outcome,
                           r.reduction_pct_ci)
    row = cells(TrustRow.of(KEY, "paper", 0.9, numbers, 40))
    return row["outcome"], _written(TrustRow, [row])


def sweep(r: Reduction) -> tuple[str, list[str]]:
    row = cells(SweepRow.of(KEY, "test", "paper", "frames", SweepPoint(2.0, 0.5, 0.6, r), 40))
    return row["outcome"], _written(SweepRow, [row])


def speed_row(r: Reduction) -> tuple[str, list[str]]:
    result = SpeedResult({"dataset": "d", "seq_len": 4, "profile": "2x"}, 2.0, 2.0, 60, 60, {})
    row = cells(SpeedRow.of(result, "fixed", (1.0,), "m", SpeedScores(40, 43, 0.5, 0.6, r, 0.5, 6)))
    return row["outcome"], _written(SpeedRow, [row])


def baselines(r: Reduction) -> tuple[str, list[str]]:
    found = SplitBaselines(40, 8, (0,), {}, (), (BudgetRemoval(0, 6, {"uniqueness": ScorerRemoval(6, {"paper": r})}),))
    meta = {"dataset": "d", "method": "m", "seq_len": 4}
    (row,) = [cells(one) for one in baseline_rows([Baselines(meta, {"test": found})], "test")]
    console = format_baselines(VPRMetrics(meta, {"test": SplitMetrics({}, baselines=found)}))
    return row["outcome"], [*_written(report_rows.BaselineRow, [row]), console]


def matchers(r: Reduction) -> tuple[str, list[str]]:
    seeds = SeedSummary(5, 5, 1.0, 2.0, -1.0, 3.0, dict.fromkeys(range(5), "improved"))
    mode = MatcherMode(0.4, 0.7, r, seeds, None, None, matcher_reduction(1.0), None)
    scores = MatcherScores(40, 8, 6, {"paper": mode}, Detection(0.6, 0.8), Detection(0.4, 0.7), None, 0.6)
    result = MatcherComparison({"dataset": "d", "method": "m", "seq_len": 4, "modes": ["paper"]}, ("seqslam",), 40,
                               None, {"seqslam": {"m": scores}}, None, ())
    found = MatchersRow.of(result, "seqslam", "m", "paper", scores)
    row = cells(found)
    return row["outcome"], [*_written(MatchersRow, [row]), comparison_sentence([found])]


def adaptive(r: Reduction) -> tuple[str, list[str]]:
    found = AdaptiveRow("L4+pred", "fixed+predictor", 4, 6, 4.0, {4: 40}, (4.0, 4.0),
                        {"paper": AdaptiveMode(r, None)})
    result = AdaptiveResult({"dataset": "d", "method": "m", "tag": "seqslam", "modes": ["paper"], "seeds": 1},
                            (2, 4), 40, None, (found,), {}, ())
    row = cells(AdaptiveSeqLenRow.of(result, found, "paper", None))
    return row["outcome"], [*_written(AdaptiveSeqLenRow, [row]), adaptive_text(result, None)]


WRITERS: dict[str, Callable[[Reduction], tuple[str, list[str]]]] = {
    "table1": table1, "leave_one_method_out": held_out, "trust_levels": trust, "protocol_sweep": sweep,
    "speed": speed_row, "baselines": baselines, "matchers": matchers, "adaptive_seq_len": adaptive}


@pytest.mark.parametrize("writer", WRITERS)
def test_an_interval_that_holds_0_names_no_direction(writer):
    # 3.2 % [-40.0, 35.0]: above 0 by its estimate, but its interval holds 0
    outcome, texts = WRITERS[writer](reduction(3.2, (-40.0, 35.0)))
    assert outcome == "interval_holds_0"
    for text in texts:
        assert not DIRECTION.search(text), text
    # the interval is printed beside the number, in the tables' cells and on the console
    assert any("-40.00" in text and "35.00" in text for text in texts[1:])
    # and without an interval: no direction either
    outcome, texts = WRITERS[writer](reduction(3.2, None))
    assert outcome == "no_interval" and not any(DIRECTION.search(text) for text in texts)


@pytest.mark.parametrize("writer", WRITERS)
def test_an_interval_that_excludes_0_names_its_direction(writer):
    outcome, texts = WRITERS[writer](reduction(3.2, (1.0, 5.0)))
    assert outcome == "improved" and "improved" in texts[0]  # the CSV's outcome column
    outcome, texts = WRITERS[writer](reduction(-6.0, (-9.0, -1.0)))
    assert outcome == "worse" and "worse" in texts[0]


def test_table1_counts_improved_by_the_interval():
    # two methods above 0 by their estimates; only the first interval lies above 0
    rows = []
    for method, interval in (("a", (1.0, 5.0)), ("b", (-40.0, 35.0)), ("c", None)):
        split = EvaluationSplit(40, 43, 0.5, 0.5, 0.6, 0.5, ((1, 0), (0, 1)), (20, 10, 5, 5), (20, 10, 5, 5), 6,
                                {"paper": ModeRemoval(0.5, 0.6, reduction(3.2, interval))}, 0, (),
                                {"paper": SeedSummary(1, 1, 3.2, None, 3.2, 3.2, {0: "improved"})})
        rows.append(Table1Row.of(("d", method, 4), "paper", split))
    assert "| 1 / 3 (1 without an interval) |" in table1_markdown(rows)


def test_a_finding_states_the_fact_and_the_queries_never_a_cause():
    # the numbers: sad -0.9 % [-3.3, 0.3] on 2573 queries
    row = {"dataset": "nordland", "method": "sad", "seq_len": 4, "mode": "paper", "reduction_pct": -0.9,
           "reduction_pct_ci_low": -3.3, "reduction_pct_ci_high": 0.3, "outcome": "worse", "n_queries": 2573,
           "aoc_vpr_sm": 0.2, "aoc_vpr_sm_pred": 0.2018, "max_recall": 0.9, "max_recall_vpr_sm": 0.9}
    block = Table1Block("nordland", "paper", 4, (record(Table1Row, row),))
    said = sentences(block, "test")
    assert said[1] == ("On the test split, the 95 % interval of sad's reduction [-3.3, 0.3] holds 0 (2573 queries), "
                       "so it names no direction.")
    first = headline(block, "test")
    assert "sad -0.9 % [-3.3, 0.3], no direction (interval holds 0)" in first and "2573" in first
    for text in (*said, first):
        assert "too few" not in text and not DIRECTION.search(text)


def test_the_headline_names_a_perfect_baseline_made_worse_without_an_earned_word():
    # the baseline's AOC 0, the predictor's 0.002, the interval of their difference holding 0: no reduction in %, and
    # the first screen's sentence says why in words (it raised KeyError: no short word for interval_holds_0)
    row = {"dataset": "d", "method": "sad", "seq_len": 4, "mode": "paper", "reduction_pct": None,
           "outcome": "interval_holds_0", "n_queries": 100, "aoc_vpr_sm": 0.0, "aoc_vpr_sm_pred": 0.002,
           "max_recall": 0.9, "max_recall_vpr_sm": 0.9}
    block = Table1Block("d", "paper", 4, (record(Table1Row, row),))
    assert headline(block, "test") == ("d (100 test queries, L = 4, paper mode): the seed-0 predictor's AOC reduction "
                                       "with its 95 % interval is sad n/a, perfect baseline, holds 0.")


def test_a_perfect_baseline_made_worse_without_an_interval_is_no_estimate_without_an_interval():
    # Table I's Improved column counts "without an interval" the estimates that have none; a perfect baseline made
    # worse (no reduction in %) whose seed had no interval (no_interval) is not an estimate: 0 / 2, nothing beside
    rows = [record(Table1Row, {"dataset": "d", "method": method, "seq_len": 4, "mode": "paper", "reduction_pct": pct,
                               "outcome": outcome, "n_queries": 100, "aoc_vpr_sm": aoc, "aoc_vpr_sm_pred": 0.002,
                               "max_recall": 0.9, "max_recall_vpr_sm": 0.9, "reduction_pct_ci_low": low,
                               "reduction_pct_ci_high": high})
            for method, pct, outcome, aoc, low, high in (("a", None, "no_interval", 0.0, None, None),
                                                         ("b", -5.0, "worse", 0.1, -9.0, 2.0))]
    assert "| 0 / 2 |" in table1_markdown(rows)
