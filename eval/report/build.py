"""Tables and figures of every experiment, from the stages' JSON files, and the HTML report (SPEC section 10).

Each experiment is optional: a table or figure is written only when its inputs are given. ``expected_outputs``
lists, from the configuration alone, the files ``main`` writes, so that a workflow can declare them.
"""

from __future__ import annotations

import csv
import json
from collections.abc import Callable, Collection, Iterable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from vpr_smr.core.io import atomic_path
from vpr_smr.eval.predictor.records import AttributeAblation, PredictorReport
from vpr_smr.eval.report import figures as fig
from vpr_smr.eval.report import registry
from vpr_smr.eval.report.html import UNDEFINED, is_reduction
from vpr_smr.eval.scoring.records import Evaluation, EvaluationSplit, HeldOut, Timing

SEED_COLUMNS = ("reduction_pct_mean", "reduction_pct_std", "reduction_pct_min", "reduction_pct_max", "n_seeds")
# n_queries: the queries with a sequence match (Q - L + 1), which every sequence number is over;
# n_queries_single: those recall_at_1_single is over (paper mode: every query of the split, SPEC 8)
QUERY_COLUMNS = ("n_queries", "n_queries_single")
# n_seeds_defined: the seeds whose reduction is defined (the baseline's AOC not 0), which the seed columns are over
TABLE1_COLUMNS = (
    "dataset", "method", "seq_len", "mode", "recall_at_1_single", "recall_at_1_sequence", "max_recall",
    "aoc_vpr_sm", "aoc_vpr_sm_pred", "reduction_pct", *SEED_COLUMNS, *QUERY_COLUMNS, "n_seeds_defined",
)
SEQ_LEN_COLUMNS = (*TABLE1_COLUMNS[:-len(QUERY_COLUMNS) - 1], "auc_vpr_sm", "auc_vpr_sm_pred", *QUERY_COLUMNS,
                   "n_seeds_defined")
PREDICTOR_COLUMNS = ("dataset", "seq_len", "n_train", "train_class_0", "train_class_1", "train_class_2",
                     "train_class_3", "f1_cv", "f1_val", "f1_test", "n_val", "n_test")
PREDICTOR_METHOD_COLUMNS = ("dataset", "seq_len", "method", "split", "n_queries", "f1_macro", "class_0", "class_1",
                            "class_2", "class_3", "predicted_0", "predicted_1", "predicted_2", "predicted_3")
CONFUSION_COLUMNS = ("dataset", "seq_len", "method", "true_class", "predicted_0", "predicted_1", "predicted_2",
                     "predicted_3", "total")
TRUST_COLUMNS = ("dataset", "method", "seq_len", "mode", "trust", "removed", "max_recall", "auc", "aoc",
                 "auc_vpr_sm", "aoc_vpr_sm", "reduction_pct", "n_queries")
TABLE2_F1 = ("f1_cv", "f1_val", "f1_test", "f1_test_method_mean")
TABLE2_COLUMNS = ("dataset", "seq_len", "attributes", *TABLE2_F1, "n_train", "n_val", "n_test")
RESTORATION_COLUMNS = (
    "dataset", "method", "seq_len", "mode", "removed", "restored", "restored_correct", "restored_wrong",
    "wrong_to_right", "right_to_wrong", "max_recall_removal", "max_recall_restoration", "auc_vpr_sm", "auc_removal",
    "auc_restoration", "auc_difference", "aoc_removal", "aoc_restoration", "aoc_difference", "reduction_pct",
    "n_queries",
)
LOMO_COLUMNS = ("dataset", "seq_len", "held_out", "mode", "n_queries", "f1_pooled", "f1_without", "removed_pooled",
                "removed_without", "aoc_vpr_sm", "aoc_pooled", "aoc_without", "reduction_pct_pooled",
                "reduction_pct_without")
TIMING_COLUMNS = ("dataset", "method", "seq_len", "split", "n_queries", "attributes_seconds", "predict_seconds",
                  "ms_per_query", "ms_attributes_per_query", "ms_predict_per_query")
ROW_NAMES = ("VPR+SM", "VPR+SM+Pred", "Reduction (%)")
SEED_ROW_NAME = "Reduction over seeds (%)"
ATTRIBUTE_ORDER = ("A1", "A2", "A3", "A4", "all")
UNDEFINED_NOTE = (f"{UNDEFINED}: the reduction is undefined, the baseline's AOC being 0 (nothing to reduce); Mean and "
                  "Improved leave it out.")


# --- Table I --------------------------------------------------------------------------------------------------


def _mode_numbers(split_result: EvaluationSplit, mode: str) -> dict[str, Any]:
    numbers = split_result.modes[mode]
    n_queries = split_result.n_queries
    # recall@1 single by the mode's rule: paper mode over every query of the split (n_queries_single)
    return {**numbers.reduction.to_json(), "recall_at_1_single": numbers.recall_at_1_single,
            "recall_at_1_sequence": numbers.recall_at_1_sequence, **split_result.seed_summary[mode].to_json(),
            "n_queries": n_queries, "n_queries_single": split_result.n_queries_split if mode == "paper" else n_queries}


def table1_rows(evaluations: Sequence[Evaluation], split: str = "test",
                seq_lens: Collection[int] | None = None) -> list[dict[str, Any]]:
    """One row per (dataset, method, L, mode) of the evaluations, optionally only the sequence lengths given."""
    rows = []
    for evaluation in evaluations:
        meta, result = evaluation.meta, evaluation.splits[split]
        if seq_lens is not None and int(meta["seq_len"]) not in seq_lens:
            continue
        for mode in result.modes:
            rows.append({"dataset": meta["dataset"], "method": meta["method"], "seq_len": meta["seq_len"],
                         "mode": mode, **_mode_numbers(result, mode)})
    return sorted(rows, key=lambda r: (r["mode"], r["seq_len"], r["dataset"], r["method"]))


def _groups(rows: list[dict[str, Any]]) -> dict[tuple[str, int], dict[str, list[dict[str, Any]]]]:
    """(mode, seq_len) -> dataset -> rows (one per method, sorted by method)."""
    groups: dict[tuple[str, int], dict[str, list[dict[str, Any]]]] = {}
    for row in rows:
        groups.setdefault((row["mode"], row["seq_len"]), {}).setdefault(row["dataset"], []).append(row)
    return groups


def _defined(values: Iterable[float | None]) -> list[float]:
    return [v for v in values if v is not None]


def _reduction_mean(values: Sequence[float | None]) -> tuple[float | None, str]:
    """The mean of the defined reductions and, when some are undefined, how many it is over."""
    defined = _defined(values)
    mean = float(np.mean(defined)) if defined else None
    note = "" if len(defined) == len(values) else f" (mean over {len(defined)} of {len(values)} methods)"
    return mean, note


def _improved(values: Sequence[float | None]) -> str:
    """How many methods improve, of those whose reduction is defined."""
    defined = _defined(values)
    return f"{sum(v > 0 for v in defined)} / {len(defined)}"


def _summary(rows: list[dict[str, Any]]) -> tuple[list[list[float | None]], str, str]:
    """Per-method values of the three table rows with their mean appended (the reduction's over the methods where
    it is defined), the note saying how many that is (empty when all), and the methods improved."""
    reductions = [r["reduction_pct"] for r in rows]
    mean, note = _reduction_mean(reductions)
    values = [[r["aoc_vpr_sm"] for r in rows], [r["aoc_vpr_sm_pred"] for r in rows]]
    return ([v + [float(np.mean(v))] for v in values] + [reductions + [mean]], note, _improved(reductions))


def _has_seeds(rows: list[dict[str, Any]]) -> bool:
    return all(r.get("n_seeds") is not None for r in rows)


def _seed_cells(rows: list[dict[str, Any]], separator: str) -> tuple[list[str], str]:
    """``mean ± std`` per method (``n/a`` where no seed's reduction is defined, the seeds counted where only some
    are), the mean of the defined means, and how many methods improve on average."""
    cells = []
    for r in rows:
        if r.get("reduction_pct_mean") is None:
            cells.append(UNDEFINED)
            continue
        defined = r.get("n_seeds_defined", r["n_seeds"])
        part = "" if defined == r["n_seeds"] else f" ({defined} of {r['n_seeds']} seeds)"
        cells.append(f"{r['reduction_pct_mean']:.2f}{separator}{r['reduction_pct_std']:.2f}{part}")
    means = [r.get("reduction_pct_mean") for r in rows]
    mean, note = _reduction_mean(means)
    n_seeds = rows[0].get("n_seeds", "")
    return cells + [_number(mean, "{:.2f}") + note], f"{_improved(means)} ({n_seeds} seeds)"


def _number(value: float | None, fmt: str) -> str:
    return UNDEFINED if value is None else fmt.format(value)


def _query_note(datasets: dict[str, list[dict[str, Any]]], split: str, mode: str) -> str:
    """Per dataset: the queries the table is over (those with a sequence match) and, in paper mode, the split's
    every query, which single-frame recall@1 is over."""
    parts = []
    for dataset, rows in datasets.items():
        n = _span(r.get("n_queries") for r in rows)
        single = _span(r.get("n_queries_single") for r in rows)
        if n:  # files written before the counts were recorded have none
            text = f"{dataset}: {n} queries with a sequence match"
            if single and single != n:
                text += f" (single-frame recall@1 over all {single} of the split)"
            parts.append(text)
    return f"{split} split, {mode} mode: " + "; ".join(parts) if parts else ""


def _span(values: Iterable[Any]) -> str:
    """One value, ``lo-hi`` when the methods differ, or empty for files without the count."""
    known = sorted({int(v) for v in values if v is not None})
    if not known:
        return ""
    return str(known[0]) if len(known) == 1 else f"{known[0]}-{known[-1]}"


def table1_markdown(rows: list[dict[str, Any]], split: str = "test") -> str:
    out = [f"# Table I: area over the precision-recall curve at max recall ({split} split)", "",
           "Rows VPR+SM, VPR+SM+Pred, Reduction: the seed-0 predictor (the authors' recipe); "
           "Reduction over seeds: mean ± sample standard deviation over the predictor seeds.", ""]
    undefined = False
    for (mode, seq_len), datasets in sorted(_groups(rows).items()):
        methods = [r["method"] for r in next(iter(datasets.values()))]
        note = _query_note(datasets, split, mode)
        out += [f"## {mode} mode, sequence length {seq_len}", ""] + ([note, ""] if note else [])
        out.append("| dataset | | " + " | ".join(methods) + " | Mean | Improved |")
        out.append("|---|---|" + "---|" * (len(methods) + 2))
        for dataset, dataset_rows in datasets.items():
            summary, note, improved = _summary(dataset_rows)
            for i, (name, values) in enumerate(zip(ROW_NAMES, summary, strict=True)):
                cells = [_number(v, "{:.2f}" if i == 2 else "{:.4f}") for v in values]
                if i == 2:
                    cells[-1] += note
                last = improved if i == 2 else ""
                label = dataset if i == 0 else ""
                out.append(f"| {label} | {name} | " + " | ".join(cells) + f" | {last} |")
            if _has_seeds(dataset_rows):
                cells, last = _seed_cells(dataset_rows, " ± ")
                out.append(f"|  | {SEED_ROW_NAME} | " + " | ".join(cells) + f" | {last} |")
                undefined |= UNDEFINED in cells
            undefined |= None in summary[2]
        out.append("")
    if undefined:
        out += [UNDEFINED_NOTE, ""]
    return "\n".join(out)


def _tex_escape(text: Any) -> str:
    return str(text).replace("\\", r"\textbackslash{}").replace("_", r"\_").replace("%", r"\%").replace(
        "&", r"\&").replace("#", r"\#")


def _tex_reduction(value: float | None) -> str:
    if value is None:
        return UNDEFINED
    return rf"\textcolor{{{'green' if value > 0 else 'red' if value < 0 else 'black'}}}{{{value:.2f}}}"


def table1_latex(rows: list[dict[str, Any]], split: str = "test") -> str:
    out = [f"% Table I ({_tex_escape(split)} split)"]
    undefined = False
    for (mode, seq_len), datasets in sorted(_groups(rows).items()):
        methods = [r["method"] for r in next(iter(datasets.values()))]
        n_columns = len(methods) + 4
        out += [
            f"% {mode} mode, sequence length {seq_len}",
            r"\begin{tabular}{l|c|" + "c|" * (len(methods) + 1) + "c}",
            r"\multicolumn{2}{c|}{} & " + " & ".join(_tex_escape(m) for m in methods) + r" & Mean & Improved\\",
            r"\hline",
        ]
        for dataset, dataset_rows in datasets.items():
            summary, note, improved = _summary(dataset_rows)
            for i, (name, values) in enumerate(zip(ROW_NAMES, summary, strict=True)):
                if i == 2:
                    cells = [_tex_reduction(v) for v in values]
                    cells[-1] += _tex_escape(note)
                    last = improved
                else:
                    cells, last = [_number(v, "{:.4f}") for v in values], ""
                label = _tex_escape(dataset) if i == 0 else ""
                out.append(f"{label} & {_tex_escape(name)} & " + " & ".join(cells) + f" & {last}" + r"\\")
            if _has_seeds(dataset_rows):
                cells, last = _seed_cells(dataset_rows, r" $\pm$ ")
                out.append(f" & {_tex_escape(SEED_ROW_NAME)} & " + " & ".join(cells) + f" & {last}" + r"\\")
                undefined |= UNDEFINED in cells
            undefined |= None in summary[2]
            out.append(r"\hline")
        note = _query_note(datasets, split, mode)
        if note:
            out.append(rf"\multicolumn{{{n_columns}}}{{l}}{{\footnotesize {_tex_escape(note)}}}\\")
        if undefined:
            out.append(rf"\multicolumn{{{n_columns}}}{{l}}{{\footnotesize {_tex_escape(UNDEFINED_NOTE)}}}\\")
        out += [r"\end{tabular}", ""]
    return "\n".join(out)


# --- Table II ---------------------------------------------------------------------------------------------------


def table2_rows(ablations: Sequence[AttributeAblation]) -> list[dict[str, Any]]:
    rows = []
    for ablation in ablations:
        meta = ablation.meta
        for name in ATTRIBUTE_ORDER:
            if name in ablation.attributes:
                numbers = ablation.attributes[name]
                rows.append({"dataset": meta["dataset"], "seq_len": meta["seq_len"], "attributes": name,
                             **{k: getattr(numbers, k) for k in TABLE2_F1}, "n_train": ablation.n_train,
                             "n_val": numbers.n_val, "n_test": numbers.n_test})
    return sorted(rows, key=lambda r: (r["dataset"], r["seq_len"], ATTRIBUTE_ORDER.index(r["attributes"])))


def _marks(name: str, yes: str, no: str) -> list[str]:
    return [yes if name in (attribute, "all") else no for attribute in ATTRIBUTE_ORDER[:4]]


def _f1(value: Any) -> str:
    return "" if value is None else f"{value:.2f}"


def _sample_note(group: list[dict[str, Any]]) -> str:
    """The samples Table II's F1 is over: the pooled train split (cross-validation) and the val and test splits."""
    first = group[0]
    parts = [f"{name} {first[key]} samples" for name, key in (("train", "n_train"), ("validation", "n_val"),
                                                              ("test", "n_test")) if first.get(key) is not None]
    return "F1 over " + ", ".join(parts) + " (every method pooled)" if parts else ""


def table2_markdown(rows: list[dict[str, Any]]) -> str:
    out = ["# Table II: macro F1 of the predictor by attribute (A1 minimum sum rate, A2 minimum value rate, "
           "A3 block sum rate, A4 group sum rate)", ""]
    groups: dict[tuple[str, int], list[dict[str, Any]]] = {}
    for row in rows:
        groups.setdefault((row["dataset"], row["seq_len"]), []).append(row)
    for (dataset, seq_len), group in groups.items():
        note = _sample_note(group)
        out += [f"## {dataset}, sequence length {seq_len}", ""] + ([note, ""] if note else []) + [
                "| A1 | A2 | A3 | A4 | F1 cross-validation | F1 validation | F1 test | F1 test, mean over methods |",
                "|---|---|---|---|---|---|---|---|"]
        for row in group:
            cells = _marks(row["attributes"], "✓", "×") + [_f1(row[k]) for k in TABLE2_F1]
            out.append("| " + " | ".join(cells) + " |")
        out.append("")
    return "\n".join(out)


def table2_latex(rows: list[dict[str, Any]]) -> str:
    out = []
    groups: dict[tuple[str, int], list[dict[str, Any]]] = {}
    for row in rows:
        groups.setdefault((row["dataset"], row["seq_len"]), []).append(row)
    for (dataset, seq_len), group in groups.items():
        out += [f"% {dataset}, sequence length {seq_len}", r"\begin{tabular}{c|c|c|c|c|c|c|c}",
                r"A1 & A2 & A3 & A4 & F1 (CV) & F1 (val) & F1 (test) & F1 (test, method mean)\\", r"\hline"]
        for row in group:
            cells = _marks(row["attributes"], r"$\checkmark$", r"$\times$") + [_f1(row[k]) for k in TABLE2_F1]
            out.append(" & ".join(cells) + r"\\")
        note = _sample_note(group)
        if note:
            out.append(rf"\multicolumn{{8}}{{l}}{{\footnotesize {_tex_escape(note)}}}\\")
        out += [r"\end{tabular}", ""]
    return "\n".join(out)


# --- the other tables -----------------------------------------------------------------------------------------


def predictor_rows(predictors: Sequence[PredictorReport]) -> list[dict[str, Any]]:
    rows = []
    for report in predictors:
        numbers = {"n_train": report.n_train, **report.first_seed()}  # the predictor file's seed
        counts = numbers["train_class_counts"]
        rows.append({**{k: numbers.get(k) for k in PREDICTOR_COLUMNS}, **report.meta,
                     **{f"train_class_{c}": counts[c] for c in range(4)}})
    return sorted(rows, key=lambda r: (r["dataset"], r["seq_len"]))


def _by_key(evaluations: Sequence[Evaluation]) -> dict[tuple[str, int], list[Evaluation]]:
    """(dataset, L) -> evaluations sorted by method."""
    out: dict[tuple[str, int], list[Evaluation]] = {}
    for evaluation in evaluations:
        out.setdefault((evaluation.meta["dataset"], int(evaluation.meta["seq_len"])), []).append(evaluation)
    return {key: sorted(items, key=lambda e: e.meta["method"]) for key, items in sorted(out.items())}


def predictor_method_rows(evaluations: Sequence[Evaluation], split: str) -> list[dict[str, Any]]:
    rows = []
    for (dataset, seq_len), items in _by_key(evaluations).items():
        for evaluation in items:
            result = evaluation.splits[split]
            rows.append({"dataset": dataset, "seq_len": seq_len, "method": evaluation.meta["method"],
                         "split": split, "n_queries": result.n_queries, "f1_macro": result.f1_macro,
                         **{f"class_{c}": result.class_counts[c] for c in range(4)},
                         **{f"predicted_{c}": result.predicted_counts[c] for c in range(4)}})
    return rows


def confusion_rows(evaluations: Sequence[Evaluation], split: str) -> list[dict[str, Any]]:
    """The seed-0 confusion matrix per dataset, L and method, and summed over the methods (method ``all``)."""
    rows = []
    for (dataset, seq_len), items in _by_key(evaluations).items():
        matrices = [(e.meta["method"], np.array(e.splits[split].confusion_matrix)) for e in items]
        matrices.append(("all", np.sum([m for _, m in matrices], axis=0)))
        for method, matrix in matrices:
            for true_class, counts in enumerate(matrix):
                rows.append({"dataset": dataset, "seq_len": seq_len, "method": method, "true_class": true_class,
                             **{f"predicted_{c}": int(counts[c]) for c in range(4)}, "total": int(counts.sum())})
    return rows


def trust_rows(evaluations: Sequence[Evaluation], split: str) -> list[dict[str, Any]]:
    rows = []
    for (dataset, seq_len), items in _by_key(evaluations).items():
        for evaluation in items:
            result = evaluation.splits[split]
            for mode, numbers in result.modes.items():
                for level, values in (numbers.trust_auc or {}).items():
                    rows.append({"dataset": dataset, "method": evaluation.meta["method"], "seq_len": seq_len,
                                 "mode": mode, "trust": float(level), **values.to_json(),
                                 "n_queries": result.n_queries})
    return rows


def restoration_rows(evaluations: Sequence[Evaluation], split: str) -> list[dict[str, Any]]:
    rows = []
    for (dataset, seq_len), items in _by_key(evaluations).items():
        for evaluation in items:
            result = evaluation.splits[split]
            if result.restoration is None:
                continue
            for mode, numbers in result.restoration.modes.items():
                rows.append({"dataset": dataset, "method": evaluation.meta["method"], "seq_len": seq_len,
                             "mode": mode, **result.restoration.counts(), **numbers.to_json(),
                             "n_queries": result.n_queries})
    return rows


def lomo_rows(results: Sequence[HeldOut]) -> list[dict[str, Any]]:
    rows = []
    for result in results:
        meta, pooled, without = result.meta, result.pooled, result.without
        for mode in pooled.modes:
            rows.append({
                "dataset": meta["dataset"], "seq_len": meta["seq_len"], "held_out": meta["method"], "mode": mode,
                "n_queries": result.n_queries, "f1_pooled": pooled.f1_macro, "f1_without": without.f1_macro,
                "removed_pooled": pooled.removed, "removed_without": without.removed,
                "aoc_vpr_sm": pooled.modes[mode].reduction.aoc_vpr_sm,
                "aoc_pooled": pooled.modes[mode].reduction.aoc_vpr_sm_pred,
                "aoc_without": without.modes[mode].reduction.aoc_vpr_sm_pred,
                "reduction_pct_pooled": pooled.modes[mode].reduction.reduction_pct,
                "reduction_pct_without": without.modes[mode].reduction.reduction_pct,
            })
    return sorted(rows, key=lambda r: (r["mode"], r["dataset"], r["seq_len"], r["held_out"]))


def match_timings(evaluations: Sequence[Evaluation], timings: Sequence[Timing]) -> dict[tuple[str, str, int], Timing]:
    """Each timing by the (dataset, method, L) of its meta, which must be one of the evaluations'."""
    known = {evaluation.key for evaluation in evaluations}
    out: dict[tuple[str, str, int], Timing] = {}
    for timing in timings:
        dataset, method, seq_len = timing.key
        if timing.key not in known:
            raise ValueError(f"timings of {dataset}, {method}, L{seq_len} match no evaluation given")
        if timing.key in out:
            raise ValueError(f"two timing files of {dataset}, {method}, L{seq_len}")
        out[timing.key] = timing
    return out


def timing_rows(evaluations: Sequence[Evaluation], timings: Sequence[Timing]) -> list[dict[str, Any]]:
    """Per evaluation and split, its timing (matched by meta); evaluations whose timings are not given are left
    out."""
    matched = match_timings(evaluations, timings)
    rows = []
    for (dataset, seq_len), items in _by_key(evaluations).items():
        for evaluation in items:
            timing = matched.get(evaluation.key)
            if timing is None:
                continue
            for split in evaluation.splits:
                numbers = timing.splits[split]
                n = max(numbers.n_queries, 1)
                attributes, predict = numbers.attributes_seconds, numbers.predict_seconds
                rows.append({"dataset": dataset, "method": evaluation.meta["method"], "seq_len": seq_len,
                             "split": split, "n_queries": numbers.n_queries, "attributes_seconds": attributes,
                             "predict_seconds": predict, "ms_per_query": 1e3 * (attributes + predict) / n,
                             "ms_attributes_per_query": 1e3 * attributes / n,
                             "ms_predict_per_query": 1e3 * predict / n})
    return rows


# --- writing ----------------------------------------------------------------------------------------------------


def _cell(value: Any, column: str = "") -> str:
    if value is None:
        return UNDEFINED if is_reduction(column) else ""
    if isinstance(value, float):
        return f"{value:.4f}"
    return str(value)


def markdown_table(columns: Sequence[str], rows: Iterable[dict[str, Any]], title: str = "") -> str:
    out = [f"# {title}", ""] if title else []
    out += ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    out += ["| " + " | ".join(_cell(row.get(c), c) for c in columns) + " |" for row in rows]
    return "\n".join(out) + "\n"


def latex_table(columns: Sequence[str], rows: Iterable[dict[str, Any]], title: str = "") -> str:
    out = [f"% {title}"] if title else []
    out += [r"\begin{tabular}{" + "l" * len(columns) + "}", " & ".join(_tex_escape(c) for c in columns) + r"\\",
            r"\hline"]
    out += [" & ".join(_tex_escape(_cell(row.get(c), c)) for c in columns) + r"\\" for row in rows]
    return "\n".join(out + [r"\end{tabular}", ""])


def _write_text(path: Path, text: str) -> Path:
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return path


def _write_csv(path: Path, columns: Sequence[str], rows: list[dict[str, Any]]) -> Path:
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(columns), extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    return path


def overlap_notes(datasets: dict[str, dict[str, Any]] | None) -> dict[str, str]:
    """Per dataset whose splits share frames (``allow_split_overlap``), the sentence every table carries."""
    return {name: "splits share frames (allow_split_overlap: true): " + "; ".join(info["overlaps"])
            for name, info in (datasets or {}).items() if info.get("overlaps")}


def _flagged(text: str, notes: dict[str, str], latex: bool = False) -> str:
    """The table's text with a warning under its title line for every dataset whose splits overlap."""
    if not notes:
        return text
    if latex:
        lines = [f"\\noindent\\textbf{{Warning, {_tex_escape(d)}:}} {_tex_escape(n)}\\par" for d, n in notes.items()]
        return "\n".join(lines) + "\n" + text
    title, _, rest = text.partition("\n")
    lines = [f"**Warning, {d}: {n}**" for d, n in notes.items()]
    return f"{title}\n\n" + "\n".join(lines) + "\n" + rest


def _write_table(stem: Path, columns: Sequence[str], rows: list[dict[str, Any]], title: str,
                 suffixes: Sequence[str] = (".csv", ".md", ".tex"), markdown: str | None = None,
                 latex: str | None = None, notes: dict[str, str] | None = None) -> list[Path]:
    """``<stem>.csv`` (full precision), ``.md`` and ``.tex`` (4 decimals, or the given special layouts): those of
    ``suffixes``, in that order.

    ``notes``: per dataset whose splits overlap, a warning under the title and a ``split_overlap`` CSV column.
    """
    notes = notes or {}
    markdown = _flagged(markdown if markdown is not None else markdown_table(columns, rows, title), notes)
    latex = _flagged(latex if latex is not None else latex_table(columns, rows, title), notes, latex=True)
    if notes:
        columns = [*columns, "split_overlap"]
        rows = [{**row, "split_overlap": notes.get(row.get("dataset", ""), "")} for row in rows]
    texts = {".md": markdown, ".tex": latex}
    return [_write_csv(stem.with_suffix(suffix), columns, rows) if suffix == ".csv"
            else _write_text(stem.with_suffix(suffix), texts[suffix]) for suffix in suffixes]


def _figure_panels(items: list[Evaluation], split: str, mode: str, restoration: bool = False
                   ) -> list[tuple[str, dict[str, Any]]]:
    """(method, the numbers of one mode as written) per evaluation; with ``restoration``, restoration's numbers
    with the baseline and removal curves, which an evaluation keeps once, under the mode's removal curves."""
    panels = []
    for evaluation in items:
        result = evaluation.splits[split]
        numbers = result.modes[mode]
        if not restoration:
            panels.append((evaluation.meta["method"], numbers.to_json()))
            continue
        if result.restoration is None or numbers.curves is None:
            raise ValueError(f"{evaluation.key}: no restoration or no removal curves in split {split!r}")
        restored = replace(result.restoration.modes[mode], curve_vpr_sm=numbers.curves.curve_vpr_sm,
                           curve_removal=numbers.curves.curve_vpr_sm_pred)
        panels.append((evaluation.meta["method"], restored.to_json()))
    return panels


def _tables_and_figures(
    out_dir: Path, evaluations: list[Evaluation], timings: list[Timing], predictors: list[PredictorReport],
    ablations: list[AttributeAblation], lomo: list[HeldOut], split: str, table_seq_lens: Collection[int] | None,
    seq_len_ablation: bool, notes: dict[str, str],
) -> tuple[list[tuple[str, list[Path]]], list[tuple[str, Path]]]:
    contents: dict[str, tuple[Sequence[str], list[dict[str, Any]], dict[str, str]]] = {}
    figures: list[tuple[str, Path]] = []

    def table(name: str, columns: Sequence[str], rows: list[dict[str, Any]], **special: str) -> None:
        registry.table(name)  # only a declared table is written
        contents[name] = (columns, rows, special)

    def figure(name: str, caption: str, **names: Any) -> tuple[str, Path]:
        """The caption and file of a registered figure."""
        spec = registry.figure(name)
        return f"{spec.title}: {caption}", out_dir / spec.file(**names)

    if evaluations:
        rows = table1_rows(evaluations, split, table_seq_lens)
        table("table1", TABLE1_COLUMNS, rows, markdown=table1_markdown(rows, split), latex=table1_latex(rows, split))
        table("predictor_methods", PREDICTOR_METHOD_COLUMNS, predictor_method_rows(evaluations, split))
        table("predictor_confusion", CONFUSION_COLUMNS, confusion_rows(evaluations, split))
        trust = trust_rows(evaluations, split)
        if trust:
            table("trust_levels", TRUST_COLUMNS, trust)
        restoration = restoration_rows(evaluations, split)
        if restoration:
            table("restoration", RESTORATION_COLUMNS, restoration)
        table("timing", TIMING_COLUMNS, timing_rows(evaluations, timings))
        if seq_len_ablation:
            table("ablation_seq_len", SEQ_LEN_COLUMNS, table1_rows(evaluations, split))
    if predictors:
        table("predictor", PREDICTOR_COLUMNS, predictor_rows(predictors))
    if ablations:
        rows = table2_rows(ablations)
        table("table2", TABLE2_COLUMNS, rows, markdown=table2_markdown(rows), latex=table2_latex(rows))
    if lomo:
        table("leave_one_method_out", LOMO_COLUMNS, lomo_rows(lomo))

    tables: list[tuple[str, list[Path]]] = []
    for spec in registry.TABLES:  # in the registry's order, with its titles and files
        if spec.name in contents:
            columns, rows, special = contents[spec.name]
            tables.append((spec.name, _write_table(out_dir / registry.TABLES_DIR / spec.name, columns, rows,
                                                   spec.title, spec.suffixes, notes=notes, **special)))

    by_key = _by_key(evaluations)
    for (dataset, seq_len), items in by_key.items():
        if table_seq_lens is not None and seq_len not in table_seq_lens:
            continue
        result0 = items[0].splits[split]
        for mode in result0.modes:
            title = f"{dataset}, L={seq_len}, {mode} mode ({split})"
            names = {"dataset": dataset, "seq_len": seq_len, "mode": mode}
            caption, path = figure("pr", title, **names)
            figures.append((caption, fig.pr_figure(path, _figure_panels(items, split, mode), title)))
            if result0.modes[mode].trust is not None:
                caption, path = figure("trust", title, **names)
                figures.append((caption, fig.trust_figure(path, _figure_panels(items, split, mode),
                                                          f"{title}: predictor trust levels")))
            if result0.restoration is not None:
                panels = _figure_panels(items, split, mode, restoration=True)
                caption, path = figure("restoration", title, **names)
                figures.append((caption, fig.restoration_figure(path, panels,
                                                                f"{title}: match removal and restoration")))
                caption, path = figure("restoration_auc", title, **names)
                figures.append((caption, fig.difference_bars(
                    path, [m for m, _ in panels], [n["auc_difference"] for _, n in panels],
                    f"{title}: restoration - removal", "PR AUC, restoration - removal")))
        matrix = np.sum([np.array(e.splits[split].confusion_matrix) for e in items], axis=0)
        caption, path = figure("confusion", f"{dataset}, L={seq_len}", dataset=dataset, seq_len=seq_len)
        figures.append((caption, fig.confusion_figure(path, matrix, f"{dataset}, L={seq_len}: all methods ({split})")))
    if seq_len_ablation and evaluations:
        figures += _seq_len_figures(out_dir, table1_rows(evaluations, split))
    return tables, figures


def _seq_len_figures(out_dir: Path, rows: list[dict[str, Any]]) -> list[tuple[str, Path]]:
    out = []
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for row in rows:
        groups.setdefault((row["dataset"], row["mode"]), []).append(row)
    for (dataset, mode), group in sorted(groups.items()):
        methods = sorted({r["method"] for r in group})
        seq_lens = sorted({int(r["seq_len"]) for r in group})
        bottoms = np.full((len(methods), len(seq_lens)), np.nan)
        tops = np.full_like(bottoms, np.nan)
        for r in group:
            i, j = methods.index(r["method"]), seq_lens.index(int(r["seq_len"]))
            bottoms[i, j], tops[i, j] = r["auc_vpr_sm"], r["auc_vpr_sm_pred"]
        title = f"{dataset}, {mode} mode\nPR AUC, VPR+SM (bar bottom) -> VPR+SM+Pred (top)"
        spec = registry.figure("seq_len")
        out.append((f"{spec.title}: {dataset}, {mode} mode", fig.change_bars(
            out_dir / spec.file(dataset=dataset, mode=mode), methods, [f"L{s}" for s in seq_lens],
            np.nan_to_num(bottoms), np.nan_to_num(tops), title)))
    return out


def _load(paths: Sequence[Path | str], what: str) -> list[dict[str, Any]]:
    out = []
    for path in paths:
        if not Path(path).is_file():
            raise FileNotFoundError(f"{what} file not found: {path}")
        out.append(json.loads(Path(path).read_text()))
    return out


Record = TypeVar("Record")


def _read(paths: Sequence[Path | str], what: str, from_json: Callable[[dict[str, Any]], Record]) -> list[Record]:
    """The records of the files ``paths`` (``what``: the kind of file, for the error)."""
    return [from_json(data) for data in _load(paths, what)]


def main(
    out_dir: Path | str,
    evaluations: Sequence[Path | str] = (),
    predictors: Sequence[Path | str] = (),
    attribute_ablations: Sequence[Path | str] = (),
    leave_one_out: Sequence[Path | str] = (),
    *,
    timings: Sequence[Path | str] = (),
    split: str = "test",
    table_seq_lens: Collection[int] | None = None,
    seq_len_ablation: bool = False,
    config: str | dict[str, Any] | None = None,
    provenance: dict[str, Any] | None = None,
    descriptor_paths: Sequence[Path | str] = (),
    html: bool = True,
    datasets: dict[str, dict[str, Any]] | None = None,
) -> list[Path]:
    """Write ``tables/``, ``figures/`` and ``report.html`` under the run folder ``out_dir``; return the files.

    Inputs are JSON files of the stages, each list optional: ``evaluations`` (``evaluate.main``, one per dataset,
    method and L), ``predictors`` (``train.main`` reports), ``attribute_ablations`` (``ablation.attributes_main``),
    ``leave_one_out`` (``scoring.held_out.main``), ``timings`` (the ``.timing.json`` files ``evaluate.main`` writes,
    each matched to its evaluation by dataset, method and L; the timing table leaves out evaluations without one).
    ``table_seq_lens``: the sequence lengths of Table I and
    of the per-L figures (None: all); ``seq_len_ablation``: also the sequence-length table and figure over every L.
    ``config`` (YAML text or a dict) and ``provenance`` (e.g. package version, checkpoint and frame-list hashes)
    go into the HTML page, with the provenance attributes of ``descriptor_paths``. ``datasets``: per dataset its
    traverses, frames, tolerance, splits, pairing and ``overlaps`` (splits that share frames, allowed by the
    configuration), shown in the page; overlaps flag every table.
    """
    from vpr_smr.eval.report import html as html_report

    out_dir = Path(out_dir)
    table_seq_lens = None if table_seq_lens is None else {int(s) for s in table_seq_lens}
    tables, figures = _tables_and_figures(
        out_dir, _read(evaluations, "evaluation", Evaluation.from_json), _read(timings, "timing", Timing.from_json),
        _read(predictors, "predictor report", PredictorReport.from_json),
        _read(attribute_ablations, "attribute ablation", AttributeAblation.from_json),
        _read(leave_one_out, "leave-one-method-out", HeldOut.from_json), split,
        table_seq_lens, seq_len_ablation, overlap_notes(datasets))
    written = [path for _, paths in tables for path in paths] + [path for _, path in figures]
    if html:
        written.append(html_report.main(
            out_dir / registry.HTML, [(registry.table(name).title, paths[0]) for name, paths in tables], figures,
            config=config, provenance=provenance, descriptor_paths=descriptor_paths, datasets=datasets))
    return written
