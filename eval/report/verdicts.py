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
from typing import Any

from vpr_smr.eval.report import bounds, names
from vpr_smr.eval.report import outcome_words as words
from vpr_smr.eval.report.baselines import Comparison, DetectionComparison, comparisons, detection_comparisons
from vpr_smr.eval.report.results import Order, unique
from vpr_smr.eval.report.view import Cell, Column, TableView, VerdictBlock, VerdictMode, anchor, text_cell
from vpr_smr.eval.scoring.adaptive_records import COMPARED_MODE, RULE, RULES
from vpr_smr.eval.scoring.curves import AGAINST_SIGN, HOLDS_ZERO, NO_INTERVAL, UNCHANGED
from vpr_smr.eval.scoring.records import Interval

Rows = Sequence[Mapping[str, Any]]
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


def reduction_cell(row: Mapping[str, Any]) -> Cell:
    """Does the predictor reduce the AOC: a Table I (or matchers) row's seed-0 reduction in per cent, its word from
    ``outcome_words.direction``; a degenerate removal named."""
    value = row.get(names.REDUCTION)
    if words.is_degenerate(row) or value is None:
        return _na(words.SHORT.get(str(row.get("outcome")), "no reduction"))
    if row.get("outcome") == UNCHANGED:
        return Cell(f"unchanged: {float(value):.1f} %", kind="hold")
    sign, interval = words.direction(row), bounds.of(row, names.REDUCTION)
    number = f"{float(value):.1f} %"
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


def native_cell(row: Mapping[str, Any]) -> Cell:
    """Does a matcher's predictor beat the matcher's own confidence removing as many matches (points)."""
    return paired_cell(row.get(names.REDUCTION), row.get("native_reduction_pct"),
                       bounds.of(row, "native_minus_predictor"), BEATS, ".1f")


def native_detection_cell(row: Mapping[str, Any]) -> Cell:
    """Does a matcher's predictor detect its wrong matches better than the matcher's own confidence."""
    if row.get("ap_predictor") is None:
        return _na("no wrong match")
    return paired_cell(row.get("ap_predictor"), row.get("ap_native"), bounds.of(row, "ap_native_minus_predictor"),
                       DETECTS, ".3f")


def rule_cell(row: Mapping[str, Any]) -> Cell:
    """Is a length rule's AOC below the best fixed row's, both at the recall both reach (the paired interval of the
    difference); a rule that keeps no correct match named."""
    if words.at_recall_zero(row):
        return _na(words.SHORT.get(str(row.get("outcome")), "no correct match kept"))
    value = row.get("minus_best_fixed")
    if value is None:
        return _na("no difference")
    sign = bounds.sign(row, "minus_best_fixed")
    # a lower AOC is the rule's gain: the word follows the opposite of the difference's sign
    return _by_sign(None if sign is None else -sign, RULE_AOC, f"{float(value):+.3f}",
                    bounds.of(row, "minus_best_fixed"), ".3f")


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


def _where(rows: Rows, **match: Any) -> list[Mapping[str, Any]]:
    return [r for r in rows if all(str(r.get(k)) == str(v) for k, v in match.items())]


def _methods(order: Order, rows: Rows) -> list[str]:
    """The rows' methods in the configuration's order, those it does not know as the rows first name them."""
    return sorted(unique(str(r["method"]) for r in rows), key=lambda m: order.method(m)[0])


def _span(values: Sequence[Any]) -> str:
    """``2573``, or ``2562-2567`` where they differ."""
    known = sorted({int(v) for v in values if v is not None})
    return "" if not known else str(known[0]) if len(known) == 1 else f"{known[0]}-{known[-1]}"


def predictor_table(table_id: str, mode: str, table1: Rows, baselines: Rows, detection: Rows, order: Order
                    ) -> TableView | None:
    """One dataset's pooled predictor per method (and L, where Table I has several): reduces the AOC, beats the
    best training-free rule, detects wrong matches better."""
    # Table I's lengths (the baselines and the detection may span the sequence-length ablation's too)
    lens = sorted({int(r["seq_len"]) for r in table1} or {int(r["seq_len"]) for r in baselines})
    methods = _methods(order, [*table1, *baselines, *detection])
    keys = [(m, str(n)) for n in lens for m in methods]
    by_table1 = {(str(r["method"]), str(r["seq_len"])): r for r in _where(table1, mode=mode)}
    by_baseline = {(m, str(c.seq_len)): c for c in comparisons([dict(r) for r in _where(baselines, mode=mode)])
                   for m in c.methods}
    by_detection = {(d.method, str(d.seq_len)): d for d in detection_comparisons([dict(r) for r in detection])}
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


def matcher_table(table_id: str, mode: str, matchers: Rows, adaptive: Rows, order: Order) -> TableView | None:
    """One dataset per method and sequence matcher: its own predictor's answers (``matchers``) and each length
    rule's (``adaptive_seq_len``, where the mode compares them)."""
    # a rule is compared with the best fixed row only in a mode that has one (``best_fixed``; standard mode)
    mine = _where(matchers, mode=mode)
    ruled = [r for r in _where(adaptive, mode=mode) if r.get("kind") == RULE and r.get("best_fixed")]
    tags = unique([*(str(r["matcher"]) for r in mine), *(str(r["matcher"]) for r in ruled)])
    methods = _methods(order, [*mine, *ruled])
    keys = [(m, t) for m in methods for t in tags]
    by_matcher = {(str(r["method"]), str(r["matcher"])): r for r in mine}
    by_rule: dict[tuple[str, ...], Mapping[str, Any]] = {
        (str(r["method"]), str(r["matcher"]), str(r["name"])): r for r in ruled}
    rules = [name for name in unique([*RULES, *(str(r["name"]) for r in ruled)])
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


def _queries(dataset: str, mode: str, split: str, tables: Mapping[str, Rows]) -> str:
    """The queries the block's numbers are over, said once: the table split's, and the shared ones of the matchers
    and of the length rules where they differ."""
    parts = []
    table1 = _where(tables.get("table1", ()), dataset=dataset, mode=mode) or _where(
        tables.get("baselines", ()), dataset=dataset, mode=mode)
    n = _span([r.get("n_queries") for r in table1])
    if n:
        parts.append(f"{n} {split} queries")
    shared = _span([r.get("n_queries") for r in _where(tables.get("matchers", ()), dataset=dataset, mode=mode)])
    if shared and shared != n:
        parts.append(f"{shared} that every matcher evaluates")
    lengths = _span([r.get("n_queries") for r in _where(tables.get("adaptive_seq_len", ()), dataset=dataset,
                                                          mode=mode)])
    if lengths and lengths not in (n, shared):
        parts.append(f"{lengths} that every length evaluates")
    return "; ".join(parts)


def verdicts(tables: Mapping[str, Rows], order: Order, split: str, protocols: Mapping[str, str] | None = None
             ) -> tuple[VerdictMode, ...]:
    """The first screen's verdict tables of the run's ``tables`` (rows by registered name), per mode (``SHOWN_MODE``
    first, where the run has it) and dataset (in ``order``); none where no table answers a question."""
    answering = ("table1", "baselines", "wrong_match_detection", "matchers", "adaptive_seq_len")
    rows = {name: tuple(tables.get(name, ())) for name in answering}
    modes = sorted(unique(str(r["mode"]) for name in answering for r in rows[name] if "mode" in r),
                   key=lambda m: (m != SHOWN_MODE, order.mode(m)))
    datasets = sorted(unique(str(r["dataset"]) for name in answering for r in rows[name]), key=order.dataset)
    out = []
    for mode in modes:
        blocks = []
        for dataset in datasets:
            mine = {name: _where(found, dataset=dataset) for name, found in rows.items()}
            found = [t for t in (
                predictor_table(anchor("verdicts", dataset, mode), mode, mine["table1"], mine["baselines"],
                                mine["wrong_match_detection"], order),
                matcher_table(anchor("verdicts-matchers", dataset, mode), mode, mine["matchers"],
                              mine["adaptive_seq_len"], order)) if t is not None]
            if found:
                correct = (protocols or {}).get(dataset)
                blocks.append(VerdictBlock(dataset, "; ".join(filter(None, [
                    _queries(dataset, mode, split, mine), f"correct {correct}" if correct else ""])), tuple(found)))
        if blocks:
            out.append(VerdictMode(mode, tuple(blocks)))
    return tuple(out)
