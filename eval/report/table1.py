"""Table I (method §10): the area over the PR curve at max recall per dataset and method, with and without the
predictor, in the paper's layout (methods as columns, then Mean and Improved) for Markdown, LaTeX and the HTML page.

The rows are the CSV's records (``table1_rows``: ``rows.Table1Row``, one per dataset, method, L and mode, in the
configuration's order); ``table1_blocks`` groups them into the paper's tables, one per dataset, mode and L.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from vpr_smr.eval.report import bounds, names
from vpr_smr.eval.report import outcome_words as words
from vpr_smr.eval.report.results import Order, Splits
from vpr_smr.eval.report.rows import Table1Row
from vpr_smr.eval.scoring.curves import NO_INTERVAL
from vpr_smr.eval.scoring.intervals import Interval
from vpr_smr.eval.scoring.records import Evaluation

UNDEFINED = "n/a"  # a reduction whose baseline AOC is 0: JSON null, an empty CSV cell
# The CSV's columns: registry.table("table1")
ROW_NAMES = ("VPR+SM", "VPR+SM+Pred", "Reduction (%)")
SEED_ROW_NAME = "Reduction over seeds (%)"
PLUS_MINUS = " ± "  # mean ± std over the seeds ($\pm$ in LaTeX)
UNDEFINED_NOTE = (f"{UNDEFINED}: the reduction is undefined (why: beside it, and below); Mean leaves it out, "
                  "Improved counts it as not improved.")
# Improved is a direction: a count of the intervals that earn it; the seeds' spread has no interval to earn one
IMPROVED_NOTE = f"Improved: the methods whose seed-0 reduction has its {bounds.LEVEL} interval above 0."


def is_reduction(column: str) -> bool:
    """A column of AOC reductions, undefined where the AOC reduced is 0."""
    return names.REDUCTION in column


def table1_rows(evaluations: Sequence[Evaluation], split: str | None = None,
                seq_lens: Collection[int] | None = None, order: Order | None = None) -> list[Table1Row]:
    """One row per (dataset, method, L, mode) of the evaluations' ``split`` (the configuration's table_split;
    default: the one split every evaluation holds), optionally only the sequence lengths given; by mode, L, dataset
    and method, each in the configuration's ``order`` (default: the evaluations')."""
    order = order or evaluation_order(evaluations)
    if split is None:
        split = str(Splits.resolve(None, None, None, [list(e.splits) for e in evaluations]).table)
    rows = [Table1Row.of(evaluation.key, mode, evaluation.splits[split]) for evaluation in evaluations
            if seq_lens is None or evaluation.seq_len in seq_lens for mode in evaluation.splits[split].modes]
    return sorted(rows, key=lambda r: (order.mode(r.mode), r.seq_len, order.dataset(r.dataset),
                                       order.method(r.method)))


def evaluation_order(evaluations: Sequence[Evaluation], methods: Sequence[str] = ()) -> Order:
    """The configuration's order as the evaluations give it (``methods``: an explicit method order, first)."""
    modes = [mode for e in evaluations for result in e.splits.values() for mode in result.modes]
    return Order.of((e.meta for e in evaluations), modes, methods)


def _groups(rows: Sequence[Table1Row]) -> dict[tuple[str, int], dict[str, list[Table1Row]]]:
    """(mode, seq_len) -> dataset -> rows (one per method), each in the order of ``rows``."""
    groups: dict[tuple[str, int], dict[str, list[Table1Row]]] = {}
    for row in rows:
        groups.setdefault((row.mode, row.seq_len), {}).setdefault(row.dataset, []).append(row)
    return groups


def _defined(values: Iterable[float | None]) -> list[float]:
    return [v for v in values if v is not None]


def _reduction_mean(rows: Sequence[Table1Row]) -> tuple[float | None, str]:
    """The mean of the rows' defined seed-0 reductions and, when some are undefined, the methods it is over,
    named."""
    over = [r for r in rows if r.reduction_pct is not None]
    mean = float(np.mean([r.reduction_pct for r in over])) if over else None
    # over some of the methods: name them; over none there is no mean, and n/a says so
    note = "" if len(over) in (0, len(rows)) else f" (mean over {len(over)} of {len(rows)} methods: {_names(over)})"
    return mean, note


def _names(rows: Iterable[Table1Row]) -> str:
    return ", ".join(r.method for r in rows)


def _improved(rows: Sequence[Table1Row]) -> str:
    """How many of all the methods improve: a method whose seed-0 reduction's interval lies above 0
    (``outcome_words.direction``); one whose reduction is undefined, or whose interval holds 0, counts as not
    improved, and those with an estimate but no interval are counted beside (``k / n (m without an interval)``): a
    perfect baseline made worse without an interval has no estimate, so it is not one of them."""
    directions = [words.direction(r.outcome, r.reduction_pct_ci) for r in rows]
    missing = sum(d is None and r.reduction_pct is not None for d, r in zip(directions, rows, strict=True))
    return f"{directions.count(1)} / {len(rows)}" + (f" ({missing} without an interval)" if missing else "")


def _summary(rows: Sequence[Table1Row]) -> tuple[list[list[float | None]], str, str]:
    """Per-method values of the three table rows with their mean appended, the note saying how many methods the
    means are over (empty when all), and the methods improved. The reduction's mean is over the methods where it is
    defined; the AOCs' over those whose AOCs are taken at a recall above 0 (``outcome_words.at_recall_zero``: both
    are 0 there, which is no AOC to average)."""
    reductions = [r.reduction_pct for r in rows]
    mean, note = _reduction_mean(rows)
    counted = [not words.at_recall_zero(r.outcome) for r in rows]
    values: list[list[float | None]] = [[r.aoc_vpr_sm for r in rows], [r.aoc_vpr_sm_pred for r in rows]]
    means = [float(np.mean([v for v, c in zip(row, counted, strict=True) if c])) if any(counted) else None
             for row in values]
    return ([row + [m] for row, m in zip(values, means, strict=True)] + [reductions + [mean]], note,
            _improved(rows))


def cells(rows: Sequence[Table1Row], summary: list[list[float | None]], row: int, fmt: str) -> list[str]:
    """The texts of one of Table I's three rows (``row`` 0, 1, 2: VPR+SM, VPR+SM+Pred, Reduction) per method and
    Mean, numbers formatted with ``fmt`` (a format spec), each method's number with its interval (``bounds``) and
    its cell saying in words where a number would mislead (``outcome_words``)."""
    method_cell = (words.baseline_cell, words.predictor_cell, words.reduction_cell)[row]
    intervals = [(r.aoc_vpr_sm_ci, r.aoc_vpr_sm_pred_ci, r.reduction_pct_ci)[row] for r in rows]
    texts = [method_cell(r, _with_interval(v, interval, fmt))
             for r, v, interval in zip(rows, summary[row][:-1], intervals, strict=True)]
    return texts + [_number(summary[row][-1], fmt) + (_aoc_mean_note(rows) if row < 2 else "")]


def _with_interval(value: float | None, interval: Interval | None, fmt: str) -> str:
    """A method's number and its interval (``[n/a]`` without one); ``n/a`` alone where the number is undefined."""
    return UNDEFINED if value is None else f"{_number(value, fmt)} {bounds.bracket(interval, fmt)}"


def _aoc_mean_note(rows: Sequence[Table1Row]) -> str:
    """`` (mean over k of n methods: a, b)`` when some methods' AOCs are left out of the AOC rows' Mean."""
    counted = [r for r in rows if not words.at_recall_zero(r.outcome)]
    return "" if len(counted) in (0, len(rows)) else (
        f" (mean over {len(counted)} of {len(rows)} methods: {_names(counted)})")


def notes(rows: Sequence[Table1Row]) -> list[str]:
    """One sentence per method whose seed-0 predictor was degenerate (``outcome_words.note``)."""
    return [f"{r.method}: {words.note(r)}." for r in rows if words.is_degenerate(r.outcome, r.reduction_pct)]


def _every_seed(row: Table1Row) -> bool:
    """Every seed's reduction is defined: the row's mean is a mean of all ``n_seeds`` seeds."""
    return row.reduction_pct_mean is not None and row.n_seeds_defined == row.n_seeds


def _seed_cells(rows: Sequence[Table1Row]) -> tuple[list[str], str]:
    """``mean ± std`` per method (``n/a`` where no seed's reduction is defined, the std ``n/a`` over fewer than two
    seeds, the seeds counted, and those left out named with the reason, where only some are), their Mean, and in
    the Improved column ``no interval (n seeds)``: the spread over seeds has no interval, so it names no direction.

    The Mean averages like with like: the means of all the seeds, over the methods whose every seed is defined
    (named where some are left out); where it and the seed-0 Mean above differ in sign, it says why."""
    texts = []
    for r in rows:
        left_out = r.seeds_left_out
        if r.reduction_pct_mean is None:
            texts.append(f"{UNDEFINED}: {left_out}" if left_out else UNDEFINED)
            continue
        why = f"; {left_out}" if left_out else ""
        part = "" if r.n_seeds_defined == r.n_seeds else f" ({r.n_seeds_defined} of {r.n_seeds} seeds{why})"
        std = r.reduction_pct_std  # None under two defined seeds (evaluate.seed_summary), shown n/a
        texts.append(f"{r.reduction_pct_mean:.2f}{PLUS_MINUS}{UNDEFINED if std is None else f'{std:.2f}'}{part}")
    n_seeds = rows[0].n_seeds
    full = [r for r in rows if _every_seed(r)]
    mean = float(np.mean([r.reduction_pct_mean for r in full])) if full else None
    if mean is None:
        note = f" (no method has all {n_seeds} seeds' reductions defined)" if any(
            r.reduction_pct_mean is not None for r in rows) else ""
    else:
        parts = [] if len(full) == len(rows) else [
            f"mean over {len(full)} of {len(rows)} methods, those with all {n_seeds} seeds: {_names(full)}"]
        seed0, _ = _reduction_mean(rows)
        if seed0 is not None and seed0 * mean < 0:
            over = [r for r in rows if r.reduction_pct is not None]
            parts.append(f"opposite in sign to the seed-0 Mean {seed0:.2f}, which is seed 0's predictor alone over "
                         f"{_names(over)}, this one every seed's over {_names(full)}")
        note = f" ({'; '.join(parts)})" if parts else ""
    return texts + [_number(mean, ".2f") + note], f"{words.UNEARNED[NO_INTERVAL]} ({n_seeds} seeds)"


def _number(value: float | None, fmt: str) -> str:
    return UNDEFINED if value is None else f"{value:{fmt}}"


def _query_note(datasets: dict[str, list[Table1Row]], split: str | None, mode: str) -> str:
    """Per dataset: the queries the table is over (those with a sequence match) and, in paper mode, the split's
    every query, which single-frame recall@1 is over."""
    parts = []
    for dataset, rows in datasets.items():
        n = _span(r.n_queries for r in rows)
        single = _span(r.n_queries_single for r in rows)
        if n:
            text = f"{dataset}: {n} queries with a sequence match"
            if single and single != n:
                text += f" (single-frame recall@1 over all {single} of the split)"
            parts.append(text)
    named = f"{split} split, " if split else ""
    return f"{named}{mode} mode: " + "; ".join(parts) if parts else ""


def _span(values: Iterable[int]) -> str:
    """One value, ``lo-hi`` when the methods differ; empty for no row."""
    known = sorted(set(values))
    if not known:
        return ""
    return str(known[0]) if len(known) == 1 else f"{known[0]}-{known[-1]}"


def table1_markdown(rows: Sequence[Table1Row], split: str | None = None) -> str:
    """Table I as markdown; ``split``: the table split the rows are of, named in the title and notes."""
    named = f" ({split} split)" if split else ""
    out = [f"# Table I: area over the precision-recall curve at max recall{named}", "",
           "Rows VPR+SM, VPR+SM+Pred, Reduction: the seed-0 predictor (the authors' recipe); "
           "Reduction over seeds: mean ± sample standard deviation over the predictor seeds. " + IMPROVED_NOTE, ""]
    undefined = False
    for (mode, seq_len), datasets in _groups(rows).items():
        methods = [r.method for r in next(iter(datasets.values()))]
        note = _query_note(datasets, split, mode)
        out += [f"## {mode} mode, sequence length {seq_len}", ""] + ([note, ""] if note else [])
        out.append("| dataset | | " + " | ".join(methods) + " | Mean | Improved |")
        out.append("|---|---|" + "---|" * (len(methods) + 2))
        degenerate = []
        for dataset, dataset_rows in datasets.items():
            summary, note, improved = _summary(dataset_rows)
            for i, name in enumerate(ROW_NAMES):
                texts = cells(dataset_rows, summary, i, ".2f" if i == 2 else ".4f")
                if i == 2:
                    texts[-1] += note
                last = improved if i == 2 else ""
                label = dataset if i == 0 else ""
                out.append(f"| {label} | {name} | " + " | ".join(texts) + f" | {last} |")
            texts, last = _seed_cells(dataset_rows)
            out.append(f"|  | {SEED_ROW_NAME} | " + " | ".join(texts) + f" | {last} |")
            undefined |= any(t.startswith(UNDEFINED) for t in texts)
            undefined |= None in summary[2]
            degenerate += [f"{dataset}, {n}" if len(datasets) > 1 else n for n in notes(dataset_rows)]
        out.append("")
        out += [*degenerate, ""] if degenerate else []
    if undefined:
        out += [UNDEFINED_NOTE, ""]
    return "\n".join(out)


def tex_escape(text: Any) -> str:
    return str(text).replace("\\", r"\textbackslash{}").replace("_", r"\_").replace("%", r"\%").replace(
        "&", r"\&").replace("#", r"\#")


def _tex_reduction(row: Table1Row | None, value: float | None) -> str:
    """A method's reduction and its interval, in colour only where the interval says a direction (green better, red
    worse; black where it contains 0, where there is none, and for the Mean); a method's ``row`` says in words
    where it is undefined."""
    if value is None:
        return tex_escape(words.reduction_cell(row, UNDEFINED)) if row is not None else UNDEFINED
    if row is None:
        return f"{value:.2f}"
    colour = {1: "green", -1: "red"}.get(words.direction(row.outcome, row.reduction_pct_ci) or 0, "black")
    text = rf"\textcolor{{{colour}}}{{{value:.2f}}} {bounds.bracket(row.reduction_pct_ci, '.2f')}"
    return tex_escape(words.reduction_cell(row, "@@")).replace("@@", text)


def table1_latex(rows: Sequence[Table1Row], split: str | None = None) -> str:
    """Table I as LaTeX tabulars; ``split``: the table split the rows are of, named in the first comment."""
    out = [f"% Table I ({tex_escape(split)} split)" if split else "% Table I"]
    for (mode, seq_len), datasets in _groups(rows).items():
        undefined = False  # each tabular has its own footnote: only where one of its cells is n/a
        methods = [r.method for r in next(iter(datasets.values()))]
        n_columns = len(methods) + 4
        out += [
            f"% {mode} mode, sequence length {seq_len}",
            r"\begin{tabular}{l|c|" + "c|" * (len(methods) + 1) + "c}",
            r"\multicolumn{2}{c|}{} & " + " & ".join(tex_escape(m) for m in methods) + r" & Mean & Improved\\",
            r"\hline",
        ]
        degenerate = []
        for dataset, dataset_rows in datasets.items():
            summary, note, improved = _summary(dataset_rows)
            for i, name in enumerate(ROW_NAMES):
                if i == 2:
                    texts = [_tex_reduction(r, v) for r, v in zip(dataset_rows, summary[2][:-1], strict=True)]
                    texts.append(_tex_reduction(None, summary[2][-1]) + tex_escape(note))
                    last = improved
                else:
                    texts, last = [tex_escape(t) for t in cells(dataset_rows, summary, i, ".4f")], ""
                label = tex_escape(dataset) if i == 0 else ""
                out.append(f"{label} & {tex_escape(name)} & " + " & ".join(texts) + f" & {last}" + r"\\")
            texts, last = _seed_cells(dataset_rows)
            texts = [tex_escape(t).replace(PLUS_MINUS, r" $\pm$ ") for t in texts]
            out.append(f" & {tex_escape(SEED_ROW_NAME)} & " + " & ".join(texts) + f" & {last}" + r"\\")
            undefined |= any(t.startswith(UNDEFINED) for t in texts)
            undefined |= None in summary[2]
            degenerate += [f"{dataset}, {n}" if len(datasets) > 1 else n for n in notes(dataset_rows)]
            out.append(r"\hline")
        note = _query_note(datasets, split, mode)
        if note:
            out.append(rf"\multicolumn{{{n_columns}}}{{l}}{{\footnotesize {tex_escape(note)}}}\\")
        for line in degenerate:
            out.append(rf"\multicolumn{{{n_columns}}}{{l}}{{\footnotesize {tex_escape(line)}}}\\")
        if undefined:
            out.append(rf"\multicolumn{{{n_columns}}}{{l}}{{\footnotesize {tex_escape(UNDEFINED_NOTE)}}}\\")
        out.append(rf"\multicolumn{{{n_columns}}}{{l}}{{\footnotesize {tex_escape(IMPROVED_NOTE)}}}\\")
        out += [r"\end{tabular}", ""]
    return "\n".join(out)




@dataclass(frozen=True)
class Table1Block:
    """One dataset's Table I in one mode at one L: its rows, one per method in the configuration's order."""

    dataset: str
    mode: str
    seq_len: int
    rows: tuple[Table1Row, ...]

    @property
    def methods(self) -> tuple[str, ...]:
        return tuple(r.method for r in self.rows)

    def summary(self) -> tuple[list[list[float | None]], str, str]:
        """The three rows' values per method and their Mean, the note on the reduction's Mean (empty when every
        reduction is defined) and Improved, as the Markdown and LaTeX tables show them."""
        return _summary(self.rows)

    def seed_cells(self) -> tuple[list[str], str]:
        """The row "Reduction over seeds": mean ± std per method, their mean, and how many improve on average."""
        return _seed_cells(self.rows)

    def query_note(self, split: str) -> str:
        """The queries the numbers are over."""
        return _query_note({self.dataset: list(self.rows)}, split, self.mode)


def table1_blocks(rows: Sequence[Table1Row]) -> list[Table1Block]:
    """Table I's rows as the paper's tables: per mode and L (in the order of ``rows``), one per dataset."""
    return [Table1Block(dataset, mode, seq_len, tuple(dataset_rows))
            for (mode, seq_len), datasets in _groups(rows).items() for dataset, dataset_rows in datasets.items()]
