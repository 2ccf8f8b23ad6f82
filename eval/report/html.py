"""``report.html``: one self-contained page that leads with the run's findings (SPEC 10).

The page, top to bottom: per dataset, Table I in the paper's layout with a few sentences saying what it shows;
then one section per experiment the run made, its figure next to a compact table and the whole table folded
(sortable by a click on a column header); then the dataset cards, the provenance and the configuration.

``build_page`` makes the page's view model (``view.Page``) from the tables and figures ``build`` wrote, and the
Jinja2 template ``templates/report.html.j2`` lays it out (autoescaped). Figures are embedded as base64 PNG data
URIs and the style sheet and the sorting script are inline, so the page needs no network and no file beside it:
it can be mailed or archived on its own.
"""

from __future__ import annotations

import base64
import json
import re
from collections.abc import Iterable, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from vpr_smr.core.citation import how_to_cite
from vpr_smr.core.io import atomic_path, package_version, read_provenance
from vpr_smr.core.paths import queries_path
from vpr_smr.eval.report import outcome_words as words
from vpr_smr.eval.report import registry
from vpr_smr.eval.report.findings import sentences, speed_sentences
from vpr_smr.eval.report.results import (
    Order,
    WrittenFigure,
    WrittenTable,
    ground_truth_text,
    split_text,
    unique,
)
from vpr_smr.eval.report.table1 import (
    ROW_NAMES,
    SEED_ROW_NAME,
    UNDEFINED,
    UNDEFINED_NOTE,
    Table1Block,
    cells,
    is_reduction,
    notes,
    table1_blocks,
)
from vpr_smr.eval.report.view import (
    Block,
    Card,
    Cell,
    Column,
    FigureView,
    Finding,
    Folded,
    Page,
    Section,
    TableView,
    cell,
    text_cell,
)

TEMPLATES = Path(__file__).resolve().parent / "templates"
TEMPLATE = "report.html.j2"
DESCRIPTOR_KEYS = ("dataset", "method", "checkpoint_sha256", "frames_sha256", "vpr_smr_version")
# Column headers of the compact tables (the folded whole tables keep the CSV's column names).
LABELS = {
    "seq_len": "L", "recall_at_1_single": "R@1 single", "recall_at_1_sequence": "R@1 sequence",
    "max_recall": "max recall", "aoc_vpr_sm": "AOC VPR+SM", "aoc_vpr_sm_pred": "AOC VPR+SM+Pred",
    "reduction_pct": "AOC reduction (%)", "n_queries": "queries", "f1_macro": "macro F1",
    **{f"class_{c}": f"true {c}" for c in range(4)}, **{f"predicted_{c}": f"predicted {c}" for c in range(4)},
    "n_train": "train samples", "f1_cv": "F1 cross-validation", "f1_val": "F1 validation", "f1_test": "F1 test",
    "f1_test_method_mean": "F1 test, mean over methods", "n_val": "val samples", "n_test": "test samples",
    "restored_correct": "restored correct", "wrong_to_right": "wrong to right", "right_to_wrong": "right to wrong",
    "auc_removal": "PR AUC removal", "auc_restoration": "PR AUC restoration", "auc_difference": "difference",
    "held_out": "held out", "f1_pooled": "F1 pooled", "f1_without": "F1 without", "removed_pooled": "removed pooled",
    "removed_without": "removed without", "aoc_pooled": "AOC pooled", "aoc_without": "AOC without",
    "reduction_pct_pooled": "reduction pooled (%)", "reduction_pct_without": "reduction without (%)",
    "ms_per_query": "ms per query", "ms_attributes_per_query": "attributes (ms)",
    "ms_predict_per_query": "prediction (ms)", "recall_at_1": "R@1", "recall_at_5": "R@5", "recall_at_10": "R@10",
    "recall_at_20": "R@20", "recall_at_100p": "R@100P", "pr_auc": "PR-AUC", "extended_precision": "EP",
}
MATCHER_TEXT = {"single": "single frame", "sequence": "sequence", "sequence_predictor": "sequence + predictor"}
ATTRIBUTES = ("A1", "A2", "A3", "A4")


def image_uri(path: Path | str) -> str:
    return "data:image/png;base64," + base64.b64encode(Path(path).read_bytes()).decode("ascii")


def anchor(*parts: Any) -> str:
    """An HTML id from ``parts``: lower case, letters, digits and dashes."""
    return re.sub(r"[^a-z0-9]+", "-", "-".join(str(p) for p in parts).lower()).strip("-")


def _relative(path: Path, run_dir: Path) -> str:
    try:
        return path.resolve().relative_to(run_dir.resolve()).as_posix()
    except ValueError:
        return str(path)


# --- tables -----------------------------------------------------------------------------------------------------


def _is_text(column: str, rows: Sequence[dict[str, Any]]) -> bool:
    value = next((row.get(column) for row in rows if row.get(column) is not None), None)
    return isinstance(value, str)


def data_table(table_id: str, columns: Sequence[str], rows: Sequence[dict[str, Any]], short: bool = True,
               caption: str = "", note: str = "", labels: dict[str, str] | None = None) -> TableView:
    """A sortable table of ``rows``' ``columns``: short labels (``LABELS``, ``labels``) or the CSV's names."""
    names = {**LABELS, **(labels or {})}
    head = tuple(Column(names.get(c, c.replace("_", " ")) if short else c, "text" if _is_text(c, rows) else "num",
                        title=c) for c in columns)
    body = tuple(tuple(row_cell(row, c) for c in columns) for row in rows)
    return TableView(table_id, head, body, caption=caption, note=note)


def row_cell(row: dict[str, Any], column: str) -> Cell:
    """``cell`` of a row's value; an undefined reduction says why, from the row's outcome of that reduction
    (``reduction_pct`` -> ``outcome``, ``reduction_pct_pooled`` -> ``outcome_pooled``)."""
    value = row.get(column)
    outcome = row.get(column.replace("reduction_pct", "outcome")) if is_reduction(column) else None
    if value is None and outcome in words.SHORT:
        return Cell(f"{UNDEFINED}: {words.SHORT[outcome]}", kind="na")
    return cell(value, column)


def pivot(table_id: str, rows: Sequence[dict[str, Any]], row_key: str, row_label: str, column_key: str,
          value_key: str, caption: str = "") -> TableView:
    """``value_key`` of ``rows`` with one row per ``row_key`` and one column per ``column_key`` (in first-seen
    order), e.g. the reduction per trust level (rows) and method (columns)."""
    row_values = sorted(set(r[row_key] for r in rows))
    column_values = unique(str(r[column_key]) for r in rows)
    by_key = {(r[row_key], str(r[column_key])): r for r in rows}
    head = (Column(row_label), *(Column(c) for c in column_values))
    body = tuple((cell(v, row_key), *(row_cell(by_key.get((v, c), {}), value_key) for c in column_values))
                 for v in row_values)
    return TableView(table_id, head, body, caption=caption)


def folded(table: WrittenTable, run_dir: Path) -> Folded:
    """The whole table as its CSV holds it (every column, unrounded for sorting), folded."""
    spec = registry.table(table.name)
    files = ", ".join(_relative(path, run_dir) for path in table.files)
    view = data_table(f"all-{table.name}", table.columns, table.rows, short=False)
    rows = f"{len(table.rows)} row" + ("" if len(table.rows) == 1 else "s")
    return Folded(f"{spec.title}: the whole table, {rows} ({files})", view)


def _where(rows: Iterable[dict[str, Any]], **match: Any) -> list[dict[str, Any]]:
    return [r for r in rows if all(str(r.get(k)) == str(v) for k, v in match.items())]


def speed_table(rows: Sequence[dict[str, Any]]) -> TableView:
    """Sequence recall@1, then the AOC reduction, per profile (rows) and method and matcher (columns)."""
    profiles = unique(str(r["profile"]) for r in rows)
    columns = list(dict.fromkeys((str(r["method"]), str(r["matcher"])) for r in rows))
    values = {(str(r["profile"]), str(r["method"]), str(r["matcher"])): r for r in rows}
    head = (Column("profile", "text"), *(Column(f"{method} · {matcher}") for method, matcher in columns))
    body = []
    for key, name in (("recall_at_1_sequence", "R@1 sequence"), ("reduction_pct", "AOC reduction (%)")):
        for profile in profiles:
            found = [values.get((profile, method, matcher)) for method, matcher in columns]
            body.append((text_cell(f"{profile}: {name}", header=True),
                         *(row_cell(r or {}, key) for r in found)))
    return TableView(anchor("speed", rows[0]["dataset"], rows[0]["seq_len"]), head, tuple(body),
                     caption="Sequence recall@1, then the predictor's AOC reduction (%), per profile (rows) and "
                             "method · matcher (columns); single-frame recall@1 and the AOCs: the whole table below")


# --- Table I and the findings -----------------------------------------------------------------------------------


def table1_view(block: Table1Block, table_id: str) -> TableView:
    """Table I of one dataset in the paper's layout: rows VPR+SM, VPR+SM+Pred, Reduction (%) and, with seeds,
    the reduction over seeds (mean ± std); a column per method, then Mean and Improved (Markdown's numbers)."""
    summary, note, improved = block.summary()
    head = (Column("", "text"), *(Column(m) for m in block.methods), Column("Mean"), Column("Improved", "text"))
    rows: list[tuple[Cell, ...]] = []
    for i, name in enumerate(ROW_NAMES):
        column = "reduction_pct" if i == 2 else "aoc"
        # the numbers' cells (sorting value, colour), with Table I's words where a number would mislead
        texts = cells(block.rows, summary, i, "{:.2f}" if i == 2 else "{:.4f}")
        numbers = [cell(v, column) for v in summary[i]]
        row = [Cell(t, c.sort, c.kind) for t, c in zip(texts, numbers, strict=True)]
        if i == 2 and note:
            row[-1] = Cell(row[-1].text + note, row[-1].sort, row[-1].kind)
        rows.append((text_cell(name, header=True), *row, text_cell(improved if i == 2 else "")))
    if block.has_seeds:
        texts, last = block.seed_cells()
        means = [r.get("reduction_pct_mean") for r in block.rows]
        kinds = ["na" if m is None else "up" if m > 0 else "down" if m < 0 else "num" for m in means] + ["num"]
        rows.append((text_cell(SEED_ROW_NAME, header=True),
                     *(Cell(t, kind=k) for t, k in zip(texts, kinds, strict=True)), text_cell(last)))
    undefined = any(c.text.startswith(UNDEFINED) for row in rows for c in row)
    below = [*notes(block.rows), *([UNDEFINED_NOTE] if undefined else [])]
    return TableView(table_id, head, tuple(rows), note=" ".join(below), sortable=False, css="paper table1")


def predictor_warnings(predictor: WrittenTable | None, dataset: str, seq_len: int) -> list[str]:
    """The warning of the predictor table's row of ``dataset`` at ``seq_len`` as a sentence (none without one)."""
    rows = _where(predictor.rows if predictor is not None else (), dataset=dataset, seq_len=seq_len)
    return [f"Warning: the predictor of {dataset} at L = {seq_len} cannot be trusted: {row['warning']}."
            for row in rows if row.get("warning")]


def findings(table1: WrittenTable | None, split: str, predictor: WrittenTable | None = None) -> tuple[Finding, ...]:
    """Per Table I block, its sentences, led by the warnings of a predictor that cannot be trusted."""
    if table1 is None:
        return ()
    out = []
    for block in table1_blocks(table1.rows):
        title = f"Table I: {block.dataset} · {split} split · L = {block.seq_len} · {block.mode} mode"
        warned = predictor_warnings(predictor, block.dataset, block.seq_len)
        out.append(Finding(title, (*warned, *sentences(block, split)),
                           table1_view(block, anchor("table1", block.dataset, block.mode, block.seq_len)),
                           block.query_note(split)))
    return tuple(out)


# --- the experiments' sections ----------------------------------------------------------------------------------


class _Builder:
    """Makes the sections from the written tables and figures (by registry name)."""

    def __init__(self, tables: Sequence[WrittenTable], figures: Sequence[WrittenFigure], order: Order, split: str,
                 run_dir: Path) -> None:
        self.tables = {t.name: t for t in tables}
        self.figures = list(figures)
        self.order, self.split, self.run_dir = order, split, run_dir

    def rows(self, name: str) -> tuple[dict[str, Any], ...]:
        table = self.tables.get(name)
        return table.rows if table else ()

    def folded(self, *names: str) -> tuple[Folded, ...]:
        return tuple(folded(self.tables[n], self.run_dir) for n in names if n in self.tables)

    def figure(self, written: WrittenFigure) -> FigureView:
        return FigureView(written.caption, image_uri(written.path), _relative(written.path, self.run_dir))

    def named(self, name: str) -> list[WrittenFigure]:
        return [f for f in self.figures if f.name == name]

    def table_lens(self) -> set[int]:
        """Table I's sequence lengths (the per-L figures'); every L when there is no Table I."""
        return {int(r["seq_len"]) for r in self.rows("table1")}

    def keys(self, rows: Iterable[dict[str, Any]]) -> list[tuple[str, int]]:
        """The (dataset, L) of ``rows``, in the configuration's order."""
        return sorted({(str(r["dataset"]), int(r["seq_len"])) for r in rows},
                      key=lambda key: (self.order.dataset(key[0]), key[1]))

    @staticmethod
    def _title(figure: WrittenFigure) -> str:
        parts = [figure.dataset] + ([f"L = {figure.seq_len}"] if figure.seq_len is not None else [])
        return ", ".join(parts) + (f", {figure.mode} mode" if figure.mode else "")

    def sections(self) -> list[Section]:
        makers = (self.pr, self.trust, self.restoration, self.seq_len, self.speed, self.predictor, self.table2,
                  self.lomo, self.timing, self.vpr_metrics, self.inspector)
        return [s for s in (make() for make in makers) if s is not None]

    def pr(self) -> Section | None:
        rows = self.rows("table1")
        blocks = []
        for f in self.named("pr"):
            shown = _where(rows, dataset=f.dataset, seq_len=f.seq_len, mode=f.mode)
            table = data_table(anchor("pr", f.dataset, f.seq_len, f.mode), (
                "method", "recall_at_1_single", "recall_at_1_sequence", "max_recall", "reduction_pct"), shown)
            blocks.append(Block(self._title(f), (self.figure(f),), (table,)))
        if not blocks and not rows:
            return None
        return Section("pr-curves", "Precision-recall curves", (
            "Sequence matching without (VPR+SM) and with the predictor's match removal (VPR+SM+Pred, the seed-0 "
            "predictor), one panel per method. The area over the curve (AOC) is measured up to VPR+SM+Pred's "
            "maximum recall (dotted line); VPR+SM's curve is cut there. Table I above reports it.",),
            tuple(blocks), self.folded("table1"))

    def trust(self) -> Section | None:
        rows = self.rows("trust_levels")
        if not rows:
            return None
        blocks = []
        for f in self.named("trust"):
            shown = _where(rows, dataset=f.dataset, seq_len=f.seq_len, mode=f.mode)
            table = pivot(anchor("trust", f.dataset, f.seq_len, f.mode), shown, "trust", "trust level", "method",
                          "reduction_pct", caption="AOC reduction (%) per trust level (columns: methods)")
            blocks.append(Block(self._title(f), (self.figure(f),), (table,)))
        return Section("trust-levels", "Trust levels", (
            "A match the predictor marks wrong is removed only when its confidence is at least the trust level; "
            "the curves and the reductions show each level against VPR+SM.",), tuple(blocks),
            self.folded("trust_levels"))

    def restoration(self) -> Section | None:
        rows = self.rows("restoration")
        if not rows:
            return None
        blocks = []
        for f in self.named("restoration"):
            shown = _where(rows, dataset=f.dataset, seq_len=f.seq_len, mode=f.mode)
            bars = [b for b in self.named("restoration_auc") if (b.dataset, b.seq_len, b.mode) ==
                    (f.dataset, f.seq_len, f.mode)]
            table = data_table(anchor("restoration", f.dataset, f.seq_len, f.mode), (
                "method", "removed", "restored", "wrong_to_right", "right_to_wrong", "auc_difference"), shown,
                labels={"auc_difference": "PR AUC difference"})
            blocks.append(Block(self._title(f), (self.figure(f),), (table,),
                                aside=tuple(self.figure(bar) for bar in bars)))
        return Section("restoration", "Match restoration", (
            "The second filter: a removed match is replaced by the next candidate the predictor trusts. PR AUC of "
            "restoration against removal alone, per method.",), tuple(blocks), self.folded("restoration"))

    def seq_len(self) -> Section | None:
        rows = self.rows("ablation_seq_len")
        if not rows:
            return None
        blocks = []
        for f in self.named("seq_len"):
            shown = _where(rows, dataset=f.dataset, mode=f.mode)
            table = pivot(anchor("seq-len", f.dataset, f.mode), shown, "seq_len", "L", "method", "reduction_pct",
                          caption="AOC reduction (%) per sequence length (columns: methods)")
            blocks.append(Block(self._title(f), (self.figure(f),), (table,)))
        return Section("sequence-length", "Sequence-length ablation", (
            "PR AUC of every method at every sequence length L, a bar from VPR+SM (bottom) to VPR+SM+Pred (top): "
            "green where the predictor helps, red where it hurts.",), tuple(blocks), self.folded("ablation_seq_len"))

    def speed(self) -> Section | None:
        rows = self.rows("speed")
        if not rows:
            return None
        blocks = []
        for f in self.named("speed"):
            shown = _where(rows, dataset=f.dataset, seq_len=f.seq_len)
            blocks.append(Block(self._title(f), (self.figure(f),), (speed_table(shown),),
                                tuple(speed_sentences(shown, self.split))))
        velocities = unique(str(r["velocities"]).replace(" ", ", ") for r in rows if r["matcher"] == "velocity")
        return Section("speed", "Speed profiles", (
            "The table split's query re-driven at other speeds (SPEC 11): a constant profile c advances c places per "
            "query frame (the query driven c times as fast; 1x is the aligned pair), the varying one "
            "1 + 0.5 sin(2 pi t / 200) places; the query's frames are the nearest to its positions, its distance "
            "matrix the aligned one's columns, and a match is correct within the tolerance of its position. The "
            "fixed matcher is the paper's (slope 1); velocity search tries the slopes "
            f"{'; '.join(velocities)} reference frames per query frame. Each matcher has its own seed-0 predictor, "
            "trained on its own features of the same profile's train split; the numbers are Table I's, paper mode.",),
            tuple(blocks), self.folded("speed"))

    def predictor(self) -> Section | None:
        methods, pooled = self.rows("predictor_methods"), self.rows("predictor")
        if not methods and not pooled:
            return None
        blocks = []
        confusion = self.named("confusion")
        datasets = unique([*(f.dataset for f in confusion), *(str(r["dataset"]) for r in pooled)])
        for dataset in sorted(datasets, key=self.order.dataset):
            tables = []
            for f in (c for c in confusion if c.dataset == dataset):
                shown = _where(methods, dataset=dataset, seq_len=f.seq_len)
                tables.append(data_table(anchor("predictor", dataset, f.seq_len), (
                    "method", "n_queries", "f1_macro", *(f"class_{c}" for c in range(4))), shown,
                    caption=f"Per method, {self.split} split, L = {f.seq_len}: macro F1 and the true classes' counts "
                            "(the predicted counts: the whole table below)"))
            shown = _where(pooled, dataset=dataset)
            if shown:
                columns = ("seq_len", "n_train", "f1_cv", "f1_val", "f1_test", "n_val", "n_test")
                warned = any(row.get("warning") for row in shown)
                tables.append(data_table(anchor("predictor-pooled", dataset), (*columns, *(
                    ("warning",) if warned else ())), shown,
                    caption="The pooled predictor (seed 0) per sequence length" + (
                        "; warning: the seeds whose predictor cannot be trusted on the validation split" if warned
                        else "")))
            figures = tuple(self.figure(c) for c in confusion if c.dataset == dataset)
            blocks.append(Block(dataset, figures, tuple(tables)))
        return Section("predictor", "The predictor alone", (
            "Classes (SPEC 6): 0 correct before and after sequence matching, 1 correct before only, 2 correct after "
            "only, 3 wrong both; the predictor keeps the matches of classes 0 and 2. Cross-validation uses SMOTE "
            "inside the folds. The confusion matrix sums every method.",), tuple(blocks),
            self.folded("predictor", "predictor_methods", "predictor_confusion"))

    def table2(self) -> Section | None:
        rows = self.rows("table2")
        if not rows:
            return None
        blocks = []
        for dataset, seq_len in self.keys(rows):
            shown = _where(rows, dataset=dataset, seq_len=seq_len)
            head = (*(Column(a, "text") for a in ATTRIBUTES), *(Column(LABELS[k]) for k in (
                "f1_cv", "f1_val", "f1_test", "f1_test_method_mean")))
            body = tuple((*(text_cell("✓" if r["attributes"] in (a, "all") else "×") for a in ATTRIBUTES),
                          *(cell(r.get(k), k) for k in ("f1_cv", "f1_val", "f1_test", "f1_test_method_mean")))
                         for r in shown)
            first = shown[0]
            counts = [f"{first[k]} {name}" for k, name in (("n_train", "training samples (cross-validation)"),
                                                           ("n_val", "validation"), ("n_test", "test samples"))
                      if first.get(k) is not None]
            note = "Macro F1 over " + ", ".join(counts) + ", every method pooled." if counts else ""
            table = TableView(anchor("table2", dataset, seq_len), head, body, note=note)
            blocks.append(Block(f"{dataset}, L = {seq_len}", (), (table,)))
        return Section("table-ii", "Table II: attribute ablation", (
            "Macro F1 of a predictor trained on each attribute alone and on all four: A1 minimum sum rate, A2 "
            "minimum value rate, A3 block sum rate, A4 group sum rate.",), tuple(blocks), self.folded("table2"))

    def lomo(self) -> Section | None:
        rows = self.rows("leave_one_method_out")
        if not rows:
            return None
        blocks = []
        for dataset in sorted(unique(str(r["dataset"]) for r in rows), key=self.order.dataset):
            shown = _where(rows, dataset=dataset)
            table = data_table(anchor("lomo", dataset), (
                "held_out", "seq_len", "mode", "f1_pooled", "f1_without", "removed_pooled", "removed_without",
                "aoc_vpr_sm", "aoc_pooled", "aoc_without", "reduction_pct_pooled", "reduction_pct_without"), shown)
            blocks.append(Block(dataset, (), (table,)))
        return Section("leave-one-method-out", "Leave one method out", (
            "Each method's test split under the pooled predictor and under one trained on every other method: how "
            "well the predictor carries over to a method it has not seen.",), tuple(blocks),
            self.folded("leave_one_method_out"))

    def timing(self) -> Section | None:
        rows = self.rows("timing")
        if not rows:
            return None
        lens = self.table_lens()
        blocks = []
        for dataset in sorted(unique(str(r["dataset"]) for r in rows), key=self.order.dataset):
            shown = [r for r in _where(rows, dataset=dataset, split=self.split)
                     if not lens or int(r["seq_len"]) in lens]
            if shown:
                table = data_table(anchor("timing", dataset), (
                    "method", "seq_len", "n_queries", "ms_per_query", "ms_attributes_per_query",
                    "ms_predict_per_query"), shown)
                blocks.append(Block(f"{dataset}, {self.split} split", (), (table,)))
        return Section("timing", "Inference time", (
            "Time per query of the attributes and of the prediction (this machine; every other number of the report "
            "repeats exactly, this one does not).",), tuple(blocks), self.folded("timing"))

    def vpr_metrics(self) -> Section | None:
        rows = self.rows("vpr_metrics")
        if not rows:
            return None
        modes = unique(str(r["mode"]) for r in rows)
        mode = "paper" if "paper" in modes else modes[0]
        blocks = []
        for dataset, seq_len in self.keys(rows):
            shown = [{**r, "matcher": MATCHER_TEXT.get(str(r["matcher"]), r["matcher"])}
                     for r in _where(rows, dataset=dataset, seq_len=seq_len, mode=mode)]
            columns = ("method", "matcher", "n_queries", *(c for c in rows[0] if c.startswith("recall_at_")),
                       "pr_auc", "extended_precision")
            table = data_table(anchor("metrics", dataset, seq_len, mode), columns, shown)
            blocks.append(Block(f"{dataset}, L = {seq_len}, {self.split} split, {mode} mode", (), (table,)))
        return Section("vpr-metrics", "Standard VPR metrics", (
            "Recall@N (a query counts when a correct reference is among its N best matches), recall at 100 % "
            "precision (R@100P), the area under the PR curve (PR-AUC) and extended precision (EP), for single-frame "
            "matching, sequence matching, and sequence matching with the predictor (a removed match counts as not "
            f"retrieved). The whole table has every mode ({', '.join(modes)}).",), tuple(blocks),
            self.folded("vpr_metrics"))

    def inspector(self) -> Section | None:
        figures = [f for f in self.figures if f.name in ("matches", "distance_matrix")]
        if not figures:
            return None
        blocks = []
        for key in unique(f"{f.dataset}\0{f.method}\0{f.seq_len}" for f in figures):
            dataset, method, seq_len = key.split("\0")
            shown = [f for f in figures if (f.dataset, f.method, str(f.seq_len)) == (dataset, method, seq_len)]
            queries = Path(queries_path(self.run_dir, dataset, method, seq_len))
            found = "" if queries.is_file() else " (not in the run folder when this page was written)"
            text = f"Every evaluated query, one row each: {_relative(queries, self.run_dir)}{found}."
            views = [self.figure(f) for f in shown]  # the match figure first: the larger one, the matrix beside it
            blocks.append(Block(f"{method} on {dataset}, L = {seq_len}", tuple(views[:1]), (), (text,),
                                aside=tuple(views[1:])))
        return Section("match-inspector", "Match inspector", (
            f"Query by query, where sequence matching and the predictor go right or wrong on the {self.split} "
            "split. The per-query CSV files (matches, distances, attributes, true class, prediction) are in the run "
            "folder, named under each method.",), tuple(blocks))


# --- datasets, provenance ---------------------------------------------------------------------------------------


def cards(datasets: dict[str, dict[str, Any]] | None, order: Order) -> tuple[Card, ...]:
    out = []
    for name in sorted(datasets or {}, key=order.dataset):
        info = (datasets or {})[name]
        splits = info.get("splits", {})
        reference_splits = info.get("reference_splits") or {}  # SPEC 11: reference ranges that differ
        items = [
            ("reference / query", f"{info.get('reference', '')} / {info.get('query', '')}", False),
            ("frames", str(info.get("n_frames", "")) if info.get("n_query_frames") is None  # frame-aligned
             else f"{info.get('n_frames', '')} reference, {info['n_query_frames']} query", False),
            *((f"split {split}", f"frames [{lo}, {hi}): {hi - lo}" if split not in reference_splits
               else split_text({split: (lo, hi)}, reference_splits).split(" ", 1)[1], False)
              for split, (lo, hi) in splits.items()),
            ("ground truth", ground_truth_text(info), False),
            ("paired", str(info.get("pairing", "")), False),
            ("splits overlap", "; ".join(info.get("overlaps", [])) or "no", False),
            ("frame lists SHA-256", str(info.get("frames_sha256", "")), True),
        ]
        if info.get("source"):
            items.append(("source", str(info["source"]), False))
        out.append(Card(name, tuple(items)))
    return tuple(out)


def overlap_warnings(datasets: dict[str, dict[str, Any]] | None, order: Order | None = None) -> tuple[str, ...]:
    """A warning per dataset whose splits share frames, in the configuration's ``order`` (default: as given)."""
    order = order or Order(tuple(datasets or {}))
    return tuple(f"Warning, {name}: splits share frames (allow_split_overlap: true): {'; '.join(info['overlaps'])}. "
                 "Its numbers are measured partly on frames the predictor was trained or validated on."
                 for name, info in sorted((datasets or {}).items(), key=lambda item: order.dataset(item[0]))
                 if info.get("overlaps"))


def provenance_rows(provenance: dict[str, Any] | None, descriptor_paths: Sequence[Path | str] = ()
                    ) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """The run's provenance (the package version added when missing) and, per descriptor file, its dataset,
    method, checkpoint and frame-list SHA-256 (read from the file's HDF5 attributes)."""
    general = {"vpr_smr_version": package_version(), **(provenance or {})}
    files = []
    for path in descriptor_paths:
        attrs = read_provenance(path)
        files.append({"file": str(path), **{k: attrs.get(k, "") for k in DESCRIPTOR_KEYS}})
    return general, files


def _provenance_table(general: dict[str, Any]) -> TableView:
    rows = tuple((text_cell(key, header=True),
                  Cell(value if isinstance(value, str) else json.dumps(value, sort_keys=True), kind="code"))
                 for key, value in general.items())
    return TableView("provenance-run", (Column("key", "text"), Column("value", "text")), rows, sortable=False)


def _config_text(config: str | dict[str, Any] | None) -> str:
    if isinstance(config, dict):
        import yaml

        return yaml.safe_dump(config, sort_keys=False, allow_unicode=True, default_flow_style=None, width=100)
    return config or "(not given)"


def build_page(
    tables: Sequence[WrittenTable],
    figures: Sequence[WrittenFigure],
    run_dir: Path,
    *,
    order: Order | None = None,
    split: str = "test",
    config: str | dict[str, Any] | None = None,
    provenance: dict[str, Any] | None = None,
    descriptor_paths: Sequence[Path | str] = (),
    title: str = "vpr-smr report",
    datasets: dict[str, dict[str, Any]] | None = None,
) -> Page:
    """The page's view model from the tables and figures of the run folder ``run_dir``."""
    order = order or Order(tuple(datasets or {}))
    by_name = {t.name: t for t in tables}
    general, files = provenance_rows(provenance, descriptor_paths)
    version = str(general["vpr_smr_version"])
    lens = sorted({int(r["seq_len"]) for r in by_name["table1"].rows}) if "table1" in by_name else []
    run = config.get("run") if isinstance(config, dict) else None
    subtitle = " · ".join([
        *([f"run {run}"] if run else []), f"vpr-smr {version}", f"{split} split",
        *([f"Table I at L = {', '.join(map(str, lens))}"] if lens else []),
        f"generated {datetime.now(UTC).strftime('%Y-%m-%d %H:%M UTC')}",
    ])
    found = findings(by_name.get("table1"), split, by_name.get("predictor"))
    table1_files = (", ".join(_relative(p, run_dir) for p in by_name["table1"].files[1:]) + " hold this layout; "
                    + _relative(by_name["table1"].files[0], run_dir) + " every column") if "table1" in by_name else ""
    sections = _Builder(tables, figures, order, split, run_dir).sections()
    dataset_table = by_name.get("datasets")
    descriptor_table = data_table("provenance-files", ("file", *DESCRIPTOR_KEYS), files, short=False) if files else None
    page_cards = cards(datasets, order)
    nav = [*([("findings", "Findings")] if found else []), *((s.id, s.title) for s in sections),
           *([("datasets", "Datasets")] if page_cards or dataset_table else []),
           ("provenance", "Provenance"), ("configuration", "Configuration")]
    return Page(
        title=title, subtitle=subtitle, warnings=overlap_warnings(datasets, order), findings=found,
        findings_files=table1_files, sections=tuple(sections), cards=page_cards,
        datasets_table=folded(dataset_table, run_dir) if dataset_table else None, cite=how_to_cite(version),
        provenance=_provenance_table(general), descriptor_files=descriptor_table, configuration=_config_text(config),
        nav=tuple(nav))


def render(page: Page) -> str:
    """The page as HTML text: the template, autoescaped."""
    import jinja2

    environment = jinja2.Environment(loader=jinja2.FileSystemLoader(TEMPLATES), autoescape=True,
                                     undefined=jinja2.StrictUndefined, trim_blocks=True, lstrip_blocks=True,
                                     keep_trailing_newline=True)
    return environment.get_template(TEMPLATE).render(page=page)


def main(
    out: Path | str,
    tables: Sequence[WrittenTable],
    figures: Sequence[WrittenFigure],
    *,
    order: Order | None = None,
    split: str = "test",
    config: str | dict[str, Any] | None = None,
    provenance: dict[str, Any] | None = None,
    descriptor_paths: Sequence[Path | str] = (),
    title: str = "vpr-smr report",
    datasets: dict[str, dict[str, Any]] | None = None,
) -> Path:
    """Write the page to ``out`` (temporary name, then rename; its folder is the run folder) and return its path."""
    out = Path(out)
    page = build_page(tables, figures, out.parent, order=order, split=split, config=config, provenance=provenance,
                      descriptor_paths=descriptor_paths, title=title, datasets=datasets)
    text = render(page)
    with atomic_path(out) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return out
