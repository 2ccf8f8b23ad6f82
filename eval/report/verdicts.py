"""The report's first screen: per dataset and method, the answer to each question the run asked, in a word earned
by its 95 % interval over queries, with the number beside it and the interval under it.

The questions are those of the run's tables: does the predictor reduce the AOC (Table I), does it beat the best
training-free rule (``baselines``), does it detect wrong matches better (``wrong_match_detection``); per sequence
matcher, does its own predictor reduce the AOC and beat the matcher's own confidence (``matchers``); per length rule,
is its AOC below the best fixed length's (``adaptive_seq_len``). A question whose table the run did not write has no
column, a table without a column no place on the page.

A word names a direction only where the interval excludes 0 (``outcome_words.direction`` for a reduction, the
paired interval's sign for a comparison, ``bounds``); elsewhere the cell says that the interval holds 0. The
sentences below the table say the same in full.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TypeVar

from vpr_smr.eval.report import bounds
from vpr_smr.eval.report import outcome_words as words
from vpr_smr.eval.report.baselines import Comparison, DetectionComparison, comparisons, detection_comparisons
from vpr_smr.eval.report.results import Order, WrittenTable, unique
from vpr_smr.eval.report.rows import BaselineRow, DetectionRow, Table1Row
from vpr_smr.eval.report.tables.adaptive import AdaptiveSeqLenRow
from vpr_smr.eval.report.tables.matchers import MatchersRow
from vpr_smr.eval.report.view import Cell, Column, TableView, VerdictBlock, VerdictMode, anchor, text_cell
from vpr_smr.eval.scoring.adaptive_records import COMPARED_MODE, RULE, RULES
from vpr_smr.eval.scoring.curves import AGAINST_SIGN, HOLDS_ZERO, NO_INTERVAL, UNCHANGED
from vpr_smr.eval.scoring.records import Interval

Answer = Table1Row | BaselineRow | DetectionRow | MatchersRow | AdaptiveSeqLenRow  # a row of an answering table
R = TypeVar("R")
A = TypeVar("A", Table1Row, BaselineRow, DetectionRow, MatchersRow, AdaptiveSeqLenRow)
# The mode shown first: every row's recall over the same denominator (the split's queries), so rows compare; the
# other modes are folded below it
SHOWN_MODE = COMPARED_MODE


@dataclass(frozen=True)
class Words:
    """What a question's cell says: ``up`` where the interval lies above 0 (in the predictor's favour, or the
    rule's), ``down`` below 0."""

    up: str
    down: str


REDUCES = Words("reduces", "raises")
BEATS = Words("beats", "behind")
DETECTS = Words("better", "worse")
RULE_AOC = Words("lower", "higher")
MATCHER_GROUP = "the matcher with its own predictor"
RULES_GROUP = "each length rule's AOC minus the best fixed length's"


# --- cells ------------------------------------------------------------------------------------------------------


def _cell(word: str, number: str, interval: Interval | None, kind: str, fmt: str) -> Cell:
    """``reduces 40.0 %`` over ``[20.0, 55.0]``, ``holds 0: 3.2 %`` over ``[-40.0, 35.0]``."""
    joint = ": " if word in words.UNEARNED.values() else " "
    return Cell(f"{word}{joint}{number}", kind=kind, detail="" if interval is None else bounds.bracket(interval, fmt))


def _na(why: str) -> Cell:
    return Cell(f"n/a: {why}", kind="na")


def _by_sign(sign: int | None, said: Words, number: str, interval: Interval | None, fmt: str, against: str = ""
             ) -> Cell:
    """The cell of a number whose direction is ``sign`` (+1, -1, 0: the interval holds 0, None: no interval);
    ``against`` names what a direction word compares with (``beats uniqueness``)."""
    if sign is None:
        return _cell(words.UNEARNED[NO_INTERVAL], number, None, "hold", fmt)
    if sign == 0:
        return _cell(words.UNEARNED[HOLDS_ZERO], number, interval, "hold", fmt)
    word = (said.up if sign > 0 else said.down) + (f" {against}" if against else "")
    return _cell(word, number, interval, "up" if sign > 0 else "down", fmt)


def reduction_cell(row: Table1Row | MatchersRow) -> Cell:
    """Does the predictor reduce the AOC: a Table I (or matchers) row's seed-0 reduction in per cent, its word from
    ``outcome_words.direction``; a degenerate removal named."""
    value = row.reduction_pct
    if words.is_degenerate(row.outcome, value) or value is None:
        # a from-zero outcome names the interval of the AOC difference that judged it
        why = words.undefined_words(row.outcome, value, row.aoc_difference_ci)
        return _na(why or words.SHORT.get(row.outcome, "no reduction"))
    if row.outcome == UNCHANGED:
        return Cell(f"unchanged: {value:.1f} %", kind="hold")
    sign, interval = words.direction(row.outcome, row.reduction_pct_ci), row.reduction_pct_ci
    number = f"{value:.1f} %"
    if sign == 0 and interval is not None and interval.sign():  # the interval and the outcome disagree
        return _cell(words.UNEARNED[AGAINST_SIGN], number, interval, "hold", ".1f")
    return _by_sign(sign, REDUCES, number, interval, ".1f")


def flipped(interval: Interval | None) -> Interval | None:
    """The interval of ``-x`` from that of ``x``: the files hold (other - predictor), the cell says (predictor -
    other), positive in the predictor's favour."""
    return None if interval is None else Interval(-interval.high, -interval.low)


def paired_cell(ours: float | None, theirs: float | None, other_minus_ours: Interval | None, said: Words,
                fmt: str, against: str = "") -> Cell:
    """A comparison of two numbers over the same queries (higher better for both): their difference ``ours -
    theirs`` and its paired interval (the files' ``other_minus_ours``, flipped), worded by its sign; ``against``
    names the other."""
    if ours is None or theirs is None:
        return _na("a number is undefined")
    interval = flipped(other_minus_ours)
    if interval is not None and interval.low == 0 == interval.high:  # the same on every draw: equal, no direction
        return Cell("equal on every draw", kind="hold")
    return _by_sign(None if interval is None else interval.sign(), said, f"{ours - theirs:+{fmt}}", interval,
                    fmt, against)


def baseline_cell(comparison: Comparison, method: str) -> Cell:
    """Does the seed-0 predictor's reduction beat the best training-free scorer's at its budget (points)."""
    if comparison.best is None:
        return _na("no training-free reduction")
    i = comparison.methods.index(method)
    differences = comparison.differences or tuple(None for _ in comparison.methods)
    return paired_cell(comparison.predictor[i], comparison.best_values[i], differences[i], BEATS, ".1f",
                       against=comparison.best)


def detection_cell(found: DetectionComparison) -> Cell:
    """Does the predictor detect wrong matches better than the training-free scorer of highest average precision
    (the difference of average precisions)."""
    if found.best is None or found.average_precision is None:
        return _na("no wrong match")
    return paired_cell(found.predictor, found.average_precision, found.difference, DETECTS, ".3f",
                       against=f"than {found.best}")


def native_cell(row: MatchersRow) -> Cell:
    """Does a matcher's predictor beat the matcher's own confidence removing as many matches (points)."""
    return paired_cell(row.reduction_pct, row.native_reduction_pct, row.native_minus_predictor_ci, BEATS, ".1f")


def native_detection_cell(row: MatchersRow) -> Cell:
    """Does a matcher's predictor detect its wrong matches better than the matcher's own confidence."""
    if row.ap_predictor is None:
        return _na("no wrong match")
    return paired_cell(row.ap_predictor, row.ap_native, row.ap_native_minus_predictor_ci, DETECTS, ".3f")


def rule_cell(row: AdaptiveSeqLenRow) -> Cell:
    """Is a length rule's AOC below the best fixed row's, both at the recall both reach (the paired interval of the
    difference); a rule that keeps no correct match named."""
    if words.at_recall_zero(row.outcome):
        return _na(words.SHORT.get(row.outcome, "no correct match kept"))
    value, interval = row.minus_best_fixed, row.minus_best_fixed_ci
    if value is None:
        return _na("no difference")
    # a lower AOC is the rule's gain: the word follows the opposite of the difference's sign
    return _by_sign(None if interval is None else -interval.sign(), RULE_AOC, f"{value:+.3f}", interval, ".3f")


# --- tables -----------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Question:
    """A column: its header, its full wording (on hover) and the cell of a row key, None where the run has no
    answer for that row."""

    header: str
    title: str
    cell: Callable[[tuple[str, ...]], Cell | None]
    group: str = ""  # the header above a run of questions that share it


def _table(table_id: str, keys: Sequence[tuple[str, ...]], labels: Sequence[str],
           label: Callable[[tuple[str, ...]], tuple[str, ...]], questions: Sequence[Question]) -> TableView | None:
    """A row per key, headed by its ``labels`` (a label the row above has already said left blank), a column per
    question that some row answers (a question no row answers is absent); a cell a row lacks is empty."""
    found = [(q, [q.cell(key) for key in keys]) for q in questions]
    found = [(q, column) for q, column in found if any(c is not None for c in column)]
    if not found or not keys:
        return None
    head = (*(Column(name, "text") for name in labels),
            *(Column(q.header, "question", title=q.title) for q, _ in found))
    body = []
    above: tuple[str, ...] = ()
    for i, key in enumerate(keys):
        said = label(key)
        shown = [text if above[:j + 1] != said[:j + 1] else "" for j, text in enumerate(said)]
        body.append((*(text_cell(text, header=True) for text in shown),
                     *(column[i] or Cell("", kind="na") for _, column in found)))
        above = said
    groups: list[tuple[str, int]] = [("", len(labels))]
    for q, _ in found:
        if q.group == groups[-1][0]:
            groups[-1] = (q.group, groups[-1][1] + 1)
        else:
            groups.append((q.group, 1))
    return TableView(table_id, head, tuple(body), sortable=False, css="verdicts",
                     groups=tuple(groups) if any(label for label, _ in groups) else ())


def _methods(order: Order, rows: Sequence[Answer]) -> list[str]:
    """The rows' methods in the configuration's order, those it does not know as the rows first name them."""
    return sorted(unique(r.method for r in rows), key=lambda m: order.method(m)[0])


def _span(rows: Sequence[Answer]) -> str:
    """The rows' queries: ``2573``, or ``2562-2567`` where they differ."""
    known = sorted({r.n_queries for r in rows})
    return "" if not known else str(known[0]) if len(known) == 1 else f"{known[0]}-{known[-1]}"


def predictor_table(table_id: str, mode: str, table1: Sequence[Table1Row], baselines: Sequence[BaselineRow],
                    detection: Sequence[DetectionRow], order: Order) -> TableView | None:
    """One dataset's pooled predictor per method (and L, where Table I has several): reduces the AOC, beats the
    best training-free rule, detects wrong matches better."""
    # Table I's lengths (the baselines and the detection may span the sequence-length ablation's too)
    lens = sorted({r.seq_len for r in table1} or {r.seq_len for r in baselines})
    methods = _methods(order, [*table1, *baselines, *detection])
    keys = [(m, str(n)) for n in lens for m in methods]
    by_table1 = {(r.method, str(r.seq_len)): r for r in table1 if r.mode == mode}
    by_baseline = {(m, str(c.seq_len)): c for c in comparisons([r for r in baselines if r.mode == mode])
                   for m in c.methods}
    by_detection = {(d.method, str(d.seq_len)): d for d in detection_comparisons(detection)}
    several = len(lens) > 1
    return _table(table_id, keys, ("method", *(["L"] if several else [])), lambda k: k if several else k[:1], (
        Question("reduces the AOC?", "the seed-0 predictor's AOC reduction (%) with its 95 % interval (Table I)",
                 lambda k: reduction_cell(by_table1[k]) if k in by_table1 else None),
        Question("beats the best training-free rule?", "the predictor's reduction minus the best training-free "
                 "scorer's at the same budget (points), its paired 95 % interval",
                 lambda k: baseline_cell(by_baseline[k], k[0]) if k in by_baseline else None),
        Question("detects wrong matches better?", "the predictor's average precision of detecting the wrong "
                 "matches minus the best training-free scorer's, its paired 95 % interval",
                 lambda k: detection_cell(by_detection[k]) if k in by_detection else None),
    ))


def matcher_table(table_id: str, mode: str, matchers: Sequence[MatchersRow], adaptive: Sequence[AdaptiveSeqLenRow],
                  order: Order) -> TableView | None:
    """One dataset per method and sequence matcher: its own predictor's answers (``matchers``) and each length
    rule's (``adaptive_seq_len``, where the mode compares them)."""
    # a rule is compared with the best fixed row only in a mode that has one (``best_fixed``; standard mode)
    mine = [r for r in matchers if r.mode == mode]
    ruled = [r for r in adaptive if r.mode == mode and r.kind == RULE and r.best_fixed]
    tags = unique([*(r.matcher for r in mine), *(r.matcher for r in ruled)])
    methods = _methods(order, [*mine, *ruled])
    keys = [(m, t) for m in methods for t in tags]
    by_matcher = {(r.method, r.matcher): r for r in mine}
    by_rule: dict[tuple[str, ...], AdaptiveSeqLenRow] = {(r.method, r.matcher, r.name): r for r in ruled}
    rules = [name for name in unique([*RULES, *(r.name for r in ruled)])
             if any(key[2] == name for key in by_rule)]

    def rule(name: str) -> Question:
        return Question(name, f"{name}'s AOC minus the best fixed row's, both at the recall both reach, its paired "
                        "95 % interval (lower: the rule is better)",
                        lambda k: rule_cell(by_rule[(*k, name)]) if (*k, name) in by_rule else None, RULES_GROUP)

    keys = [k for k in keys if k in by_matcher or any((*k, name) in by_rule for name in rules)]
    return _table(table_id, keys, ("method", "matcher"), lambda k: k, (
        Question("reduces the AOC?", "the matcher's own seed-0 predictor's AOC reduction (%), its 95 % interval",
                 lambda k: reduction_cell(by_matcher[k]) if k in by_matcher else None, MATCHER_GROUP),
        Question("beats its own confidence?", "the predictor's reduction minus that of the matcher's "
                 "native confidence removing as many matches (points), its paired 95 % interval",
                 lambda k: native_cell(by_matcher[k]) if k in by_matcher else None, MATCHER_GROUP),
        Question("detects wrong matches better?", "the predictor's average precision of detecting the "
                 "wrong matches minus the native confidence's, its paired 95 % interval",
                 lambda k: native_detection_cell(by_matcher[k]) if k in by_matcher else None, MATCHER_GROUP),
        *(rule(name) for name in rules),
    ))


@dataclass(frozen=True)
class Answers:
    """The rows of the tables that answer the first screen's questions (each none where the run did not write it):
    Table I, the baselines, the wrong-match detection, the matchers and the length rules."""

    table1: tuple[Table1Row, ...] = ()
    baselines: tuple[BaselineRow, ...] = ()
    detection: tuple[DetectionRow, ...] = ()
    matchers: tuple[MatchersRow, ...] = ()
    adaptive: tuple[AdaptiveSeqLenRow, ...] = ()

    @classmethod
    def of(cls, tables: Sequence[WrittenTable]) -> Answers:
        """The answering tables among a run's written ``tables``, by their registered names."""
        by = {table.name: table for table in tables}

        def rows(name: str, row_type: type[R]) -> tuple[R, ...]:
            return by[name].of(row_type) if name in by else ()

        return cls(rows("table1", Table1Row), rows("baselines", BaselineRow),
                   rows("wrong_match_detection", DetectionRow), rows("matchers", MatchersRow),
                   rows("adaptive_seq_len", AdaptiveSeqLenRow))

    def of_dataset(self, dataset: str) -> Answers:
        return Answers(_of(dataset, self.table1), _of(dataset, self.baselines), _of(dataset, self.detection),
                       _of(dataset, self.matchers), _of(dataset, self.adaptive))


def _of(dataset: str, rows: tuple[A, ...]) -> tuple[A, ...]:
    return tuple(r for r in rows if r.dataset == dataset)


def _queries(mode: str, split: str, mine: Answers) -> str:
    """The queries the block's numbers are over (``mine``: its dataset's rows), said once: the table split's, and
    the shared ones of the matchers and of the length rules where they differ."""
    parts = []
    n = _span([r for r in mine.table1 if r.mode == mode] or [r for r in mine.baselines if r.mode == mode])
    if n:
        parts.append(f"{n} {split} queries")
    shared = _span([r for r in mine.matchers if r.mode == mode])
    if shared and shared != n:
        parts.append(f"{shared} that every matcher evaluates")
    lengths = _span([r for r in mine.adaptive if r.mode == mode])
    if lengths and lengths not in (n, shared):
        parts.append(f"{lengths} that every length evaluates")
    return "; ".join(parts)


def verdicts(answers: Answers, order: Order, split: str, protocols: Mapping[str, str] | None = None
             ) -> tuple[VerdictMode, ...]:
    """The first screen's verdict tables of the run's answering tables, per mode (``SHOWN_MODE`` first, where the
    run has it) and dataset (in ``order``); none where no table answers a question."""
    moded: list[Table1Row | BaselineRow | MatchersRow | AdaptiveSeqLenRow] = [
        *answers.table1, *answers.baselines, *answers.matchers, *answers.adaptive]
    modes = sorted(unique(r.mode for r in moded), key=lambda m: (m != SHOWN_MODE, order.mode(m)))
    datasets = sorted(unique([*(r.dataset for r in moded), *(r.dataset for r in answers.detection)]),
                      key=order.dataset)
    out = []
    for mode in modes:
        blocks = []
        for dataset in datasets:
            mine = answers.of_dataset(dataset)
            found = [t for t in (
                predictor_table(anchor("verdicts", dataset, mode), mode, mine.table1, mine.baselines, mine.detection,
                                order),
                matcher_table(anchor("verdicts-matchers", dataset, mode), mode, mine.matchers, mine.adaptive,
                              order)) if t is not None]
            if found:
                correct = (protocols or {}).get(dataset)
                blocks.append(VerdictBlock(dataset, "; ".join(filter(None, [
                    _queries(mode, split, mine), f"correct {correct}" if correct else ""])), tuple(found)))
        if blocks:
            out.append(VerdictMode(mode, tuple(blocks)))
    return tuple(out)
