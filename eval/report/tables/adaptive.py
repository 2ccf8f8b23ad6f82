"""The experiment ``adaptive_seq_len`` (method §15): per dataset, matcher, mode and method, each fixed length with
and without its predictor and each rule choosing the length per query (``eval.scoring.adaptive_records``), on the
queries every length evaluates, with the live matcher's time per query where its timing file is beside the result.
Its section, declared on this table by the experiment's module (``pipeline/experiments/adaptive_seq_len.py``), follows
the sequence-length ablation's on the page."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from vpr_smr.eval.matching.adaptive import NONE
from vpr_smr.eval.report import bounds, names
from vpr_smr.eval.report import outcome_words as words
from vpr_smr.eval.report.registry import Table
from vpr_smr.eval.report.rows import column, interval
from vpr_smr.eval.report.tabulate import Inputs
from vpr_smr.eval.scoring.adaptive_records import (
    ADAPTIVE,
    ADAPTIVE_FALLBACK,
    COMPARED_MODE,
    RULE,
    RULES,
    AdaptiveResult,
    AdaptiveRow,
    AdaptiveTiming,
    best_key,
    fixed_name,
)
from vpr_smr.eval.scoring.curves import earned
from vpr_smr.eval.scoring.records import Interval

if TYPE_CHECKING:
    from vpr_smr.eval.report.results import Order

__all__ = ["TABLE", "AdaptiveSeqLenRow", "adaptive_rows", "adaptive_sentence", "histogram", "live_ms",
           "make_adaptive", "tag_of"]

# each number a word or a sentence reads is shown with its interval: the reduction's outcome names a direction only
# where that interval excludes 0 (``curves.earned``)
PAGE = ("matcher", "method", "name", "mean_length", "lengths", "removed", "max_recall", names.AOC, names.REDUCTION,
        "reduction_pct_ci_low", "reduction_pct_ci_high", "aoc_difference_ci_low", "aoc_difference_ci_high",
        "outcome", "minus_best_fixed", "minus_best_fixed_ci_low",
        "minus_best_fixed_ci_high", "ms_per_query", "live_note")


def tag_of(result: AdaptiveResult) -> str:
    """The matcher's tag of a result (its meta's ``tag``, as the experiment ``matchers`` names it)."""
    return str(result.meta["tag"])


def histogram(lengths: dict[int, int]) -> str:
    """A row's histogram as text, shortest length first, the queries no length accepted last:
    ``2: 812, 4: 301, none: 12``."""
    shown = [f"{length}: {count}" for length, count in sorted(lengths.items()) if length != NONE]
    return ", ".join([*shown, *([f"none: {lengths[NONE]}"] if NONE in lengths else [])])


def live_ms(result: AdaptiveResult, row: AdaptiveRow, timing: AdaptiveTiming | None) -> float | None:
    """The live time per query (ms) of a row, from the timing file beside the result, over its timed queries
    (``AdaptiveTiming.n_queries``, those with a match): ``adaptive`` and
    ``adaptive_fallback`` the adaptive live matcher's (lengths shortest first, up to the first kept), the longest
    length's ``L{m}+pred`` row a live matcher of that length alone; None for the other rows, without a timing, when
    the live matcher refused the matcher, or without a timed query."""
    if timing is None or not timing.n_queries:
        return None
    if row.name in (ADAPTIVE, ADAPTIVE_FALLBACK):
        seconds = timing.seconds_adaptive
    elif row.name == fixed_name(result.lengths[-1], True):
        seconds = timing.seconds_longest
    else:
        return None
    return None if seconds is None else 1000.0 * seconds / timing.n_queries


@dataclass(frozen=True)
class AdaptiveSeqLenRow:
    """``adaptive_seq_len``: one row of one dataset, matcher and method in one mode, on the ``n_queries`` queries
    every length evaluates (seed 0 but the spread over seeds)."""

    dataset: str = column()
    matcher: str = column()
    mode: str = column()
    method: str = column()
    name: str = column("row")  # ``L4``, ``L4+pred`` or a rule
    kind: str = column()
    seq_len: int | None = column()  # a fixed row's length; None for a rule
    n_queries: int = column()
    mean_length: float = column("mean length", ".2f")  # a query no length accepted counts the longest
    lengths: str = column("lengths used")  # the histogram: ``2: 812, 4: 301, none: 12``
    removed: int = column()
    max_recall: float = column("max recall")
    aoc: float = column("AOC")  # at the row's own maximum recall
    aoc_ci: Interval | None = interval()
    reduction_pct: float | None = column("AOC reduction vs longest (%)")  # None where the longest's AOC is 0
    reduction_pct_ci: Interval | None = interval()
    # the interval that judged a from-zero outcome (the longest's AOC 0: no reduction), shown beside its word
    aoc_difference_ci: Interval | None = interval("AOC difference vs longest", ".4f")
    outcome: str = column()  # ``curves.outcome`` by ``curves.earned``: a degenerate one named
    reduction_pct_mean: float | None = column("mean over seeds (%)", ".2f")
    reduction_pct_std: float | None = column("std over seeds", ".2f")
    best_fixed: str = column("best fixed row")  # of this mode (``AdaptiveResult.best_fixed``); empty without one
    # a rule's AOC minus the best fixed row's, both at the smaller of their maximum recalls, and its interval paired
    # over the same draws (standard mode only; None for a fixed row, or too few draws)
    minus_best_fixed: float | None = column("AOC - best fixed AOC at the recall both reach", ".4f")
    minus_best_fixed_ci: Interval | None = interval("AOC - best fixed AOC at the recall both reach", ".4f")
    threshold: float | None = column("uniqueness threshold")  # ``adaptive_uniqueness``'s tau
    ms_per_query: float | None = column("live ms per query", ".3f")
    live_note: str = column("live", if_any=True)  # why there is no live time (the matcher refused)

    @classmethod
    def of(cls, result: AdaptiveResult, row: AdaptiveRow, mode: str, timing: AdaptiveTiming | None
           ) -> AdaptiveSeqLenRow:
        numbers = row.modes[mode]
        reduction, seeds = numbers.reduction, numbers.seeds
        refused = timing.refused if timing is not None and timing.refused else ""
        timed = row.name in (ADAPTIVE, ADAPTIVE_FALLBACK, fixed_name(result.lengths[-1], True))
        return cls(
            str(result.meta["dataset"]), tag_of(result), mode, str(result.meta["method"]), row.name, row.kind,
            row.seq_len, result.n_queries, row.mean_length, histogram(row.lengths), row.removed,
            reduction.max_recall, reduction.aoc_vpr_sm_pred, reduction.aoc_vpr_sm_pred_ci, reduction.reduction_pct,
            reduction.reduction_pct_ci, reduction.aoc_difference_ci,
            earned(reduction.outcome, reduction.reduction_pct_ci),
            None if seeds is None else seeds.reduction_pct_mean,
            None if seeds is None else seeds.reduction_pct_std, result.best_fixed.get(mode, ""),
            numbers.minus_best_fixed, numbers.minus_best_fixed_ci, row.threshold, live_ms(result, row, timing),
            f"refused: {refused}" if refused and timed else "")


Found = tuple[AdaptiveResult, AdaptiveTiming | None]


def adaptive_rows(found: Sequence[Found], order: Order | None = None) -> list[AdaptiveSeqLenRow]:
    """One row per dataset, matcher, mode, method and result row: datasets and methods in the configuration's
    order (``order``; else as the files come), the matchers as the files first name them, the modes as ``order``
    (else the first file) lists them, the result's rows in its order."""
    items = list(found)
    if order is not None:
        items.sort(key=lambda item: (order.dataset(str(item[0].meta["dataset"])),
                                     order.method(str(item[0].meta["method"]))))
    datasets = list(dict.fromkeys(str(result.meta["dataset"]) for result, _ in items))
    tags = list(dict.fromkeys(tag_of(result) for result, _ in items))
    out = []
    for dataset in datasets:
        here = [item for item in items if item[0].meta["dataset"] == dataset]
        modes = list(dict.fromkeys(mode for result, _ in here for row in result.rows for mode in row.modes))
        if order is not None:
            modes.sort(key=order.mode)
        for tag in tags:
            for mode in modes:
                for result, timing in (item for item in here if tag_of(item[0]) == tag):
                    out += [AdaptiveSeqLenRow.of(result, row, mode, timing) for row in result.rows if mode in row.modes]
    return out


def make_adaptive(inputs: Inputs) -> list[AdaptiveSeqLenRow] | None:
    return adaptive_rows(inputs.adaptive, inputs.order) if inputs.adaptive else None


def _best_rule(rows: Sequence[AdaptiveSeqLenRow]) -> AdaptiveSeqLenRow | None:
    """The best rule among those that keep a correct match, by the best fixed row's measure (``best_key``: the least
    precision lost over its recall; a tie: the larger recall, then ``RULES``' order); None if none keeps one."""
    kept = [r for r in rows if r.kind == RULE and not words.at_recall_zero(r.outcome)]
    return min(kept, default=None,
               key=lambda r: best_key(r.aoc, r.max_recall, RULES.index(r.name) if r.name in RULES else len(RULES)))


def _count(n: int, what: str = "pair") -> str:
    return f"{n} {what}" + ("" if n == 1 else "s")


def query_counts(rows: Sequence[AdaptiveSeqLenRow]) -> str:
    """The queries every length evaluates, as a sentence names them: ``the 2567 queries``, or per matcher when they
    differ (a centred window evaluates fewer): ``the 2567 (seqslam) to 2563 (openseqslam) queries``."""
    counts = {r.matcher: r.n_queries for r in rows}
    if len(set(counts.values())) == 1:
        return f"the {next(iter(counts.values()))} queries"
    high, low = max(counts, key=counts.__getitem__), min(counts, key=counts.__getitem__)
    return f"the {counts[high]} ({high}) to {counts[low]} ({low}) queries"


def adaptive_sentence(rows: Sequence[AdaptiveSeqLenRow]) -> str:
    """The experiment's one sentence of one dataset and mode (its rows): over the method-matcher pairs, for
    how many the best rule (``_best_rule``: by the best fixed row's measure) has an AOC below the best
    fixed row's (the paired 95 % interval of the difference below 0), for how many the interval holds 0 (and for how
    many of those its mean length is shorter than the best fixed row's length), for how many it lies above 0; the
    pairs without an interval named (no interval), and those without a rule or a fixed row that keeps a
    correct match. Nothing beyond the intervals. The rows are compared in standard mode only (``best_fixed``): in
    paper mode each row's recall divides by its own correct matches, and the sentence says so."""
    if not rows:
        return ""
    first = rows[0]
    if not any(r.best_fixed for r in rows) and first.mode != COMPARED_MODE:
        return (f"On {first.dataset} ({first.mode} mode), the rows are not compared: a row's recall divides by "
                f"its own correct matches, which differ from row to row; the {COMPARED_MODE} mode's sentence "
                "compares them.")
    pairs: dict[tuple[str, str], list[AdaptiveSeqLenRow]] = {}
    for row in rows:
        pairs.setdefault((row.method, row.matcher), []).append(row)
    better, same, shorter, shorter_better, worse = 0, 0, 0, 0, 0
    untold, unscored = [], []
    for (method, matcher), found in pairs.items():
        best = _best_rule(found)
        fixed = next((r for r in found if r.name == found[0].best_fixed), None)
        if best is None or fixed is None:
            unscored.append(f"{method} · {matcher}")
            continue
        sign = bounds.sign(best.minus_best_fixed_ci)
        is_shorter = fixed.seq_len is not None and best.mean_length < fixed.seq_len
        if sign is None:
            untold.append(f"{method} · {matcher}")
        elif sign < 0:
            better += 1
            shorter_better += is_shorter
        elif sign > 0:
            worse += 1
        else:
            same += 1
            shorter += is_shorter
    text = (f"On {first.dataset} ({first.mode} mode, {query_counts(rows)} every length evaluates, "
            f"{_count(len(pairs), 'method-matcher pair')}), the best rule's AOC, at the recall both reach, is below "
            f"the best fixed row's for {better} (the paired {bounds.LEVEL} interval of the difference below 0; "
            f"{shorter_better} of them with a shorter mean length used than the best fixed row's length), cannot be "
            f"told apart from it for {same} (the interval holds 0; {shorter} of them with a shorter mean length) and "
            f"is above it for {worse}")
    if untold:
        text += f"; no interval of the difference for {', '.join(untold)}"
    if unscored:
        text += f"; no rule or no fixed row keeps a correct match for {', '.join(unscored)}"
    return text + "."


TABLE = Table("adaptive_seq_len", "Adaptive sequence length: each fixed length with and without its predictor and "
              "each rule choosing the length per query, on the queries every length evaluates (method §15)",
              ("adaptive_seq_len",), row=AdaptiveSeqLenRow, make=make_adaptive, page=PAGE,
              caption="Per method and row: the mean length used and its histogram, the matches removed, the "
                      "seed-0 maximum recall and AOC, the AOC reduction against the longest length without "
                      "predictor, a rule's AOC minus the best fixed row's (its paired 95 % interval) and the live "
                      "time per query")


def adaptive_sentences(rows: Sequence[AdaptiveSeqLenRow]) -> list[str]:
    """What the section says under a figure: the sentence of its dataset and mode."""
    return [adaptive_sentence(rows)] if rows else []

