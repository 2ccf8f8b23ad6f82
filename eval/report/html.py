"""``report.html``: one self-contained page that leads with the run's findings (method §10).

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
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, TypeVar

from vpr_smr.core.citation import how_to_cite
from vpr_smr.core.io import atomic_path, package_version, read_provenance
from vpr_smr.core.paths import queries_path
from vpr_smr.eval.report import bounds, names, registry
from vpr_smr.eval.report import outcome_words as words
from vpr_smr.eval.report.baselines import comparisons, detection_comparisons, headline
from vpr_smr.eval.report.findings import (
    baseline_headline,
    baseline_sentence,
    detection_headline,
    detection_sentence,
    sentences,
)
from vpr_smr.eval.report.findings import headline as finding_headline
from vpr_smr.eval.report.results import (
    Order,
    Splits,
    WrittenFigure,
    WrittenTable,
    ground_truth_text,
    split_text,
    unique,
)
from vpr_smr.eval.report.rows import (
    BaselineRow,
    DetectionRow,
    HeldOutRow,
    PredictorMethodRow,
    PredictorRow,
    SeqLenRow,
    SpeedRow,
    Table1Row,
    Table2Row,
    TimingRow,
    VPRMetricsRow,
)
from vpr_smr.eval.report.rows import Column as TableColumn
from vpr_smr.eval.report.rows import cells as row_cells
from vpr_smr.eval.report.sections import INSPECTOR_FIGURES, Declared, Rows, placed, prose
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
from vpr_smr.eval.report.verdicts import Answers, verdicts
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
    anchor,
    cell,
    text_cell,
)
from vpr_smr.eval.scoring import scorers as scorer_registry
from vpr_smr.eval.scoring.scorers import RANDOM

TEMPLATES = Path(__file__).resolve().parent / "templates"
TEMPLATE = "report.html.j2"
R = TypeVar("R")  # a table's row record (``_Builder.records``)
DESCRIPTOR_KEYS = ("dataset", "method", "checkpoint_sha256", "frames_sha256", "vpr_smr_version")
# What another machine may change, measured on the demo (docs/method.md §7.5); shown in the provenance section
ACROSS_MACHINES = ("SAD's and HOG's descriptors are the same bytes on every CPU, and the predictor's training "
                   "through the BLAS changed no number of the demo; the l2 and cosine distances go through the "
                   "BLAS, whose kernel and threads moved the demo's seed-0 Table I reductions by up to 7 points "
                   "(HOG), so compare runs on different machines by their spread over seeds. Each file records "
                   "its machine's numeric environment under `environment` (method §7.5).")
# The tables' columns, their headers and formats, and what the compact tables show: registry.TABLES
MATCHER_TEXT = {"single": "single frame", "sequence": "sequence", "sequence_predictor": "sequence + predictor"}
ATTRIBUTES = ("A1", "A2", "A3", "A4")


def image_uri(path: Path | str) -> str:
    return "data:image/png;base64," + base64.b64encode(Path(path).read_bytes()).decode("ascii")


def _relative(path: Path, run_dir: Path) -> str:
    try:
        return path.resolve().relative_to(run_dir.resolve()).as_posix()
    except ValueError:
        return str(path)


# --- tables -----------------------------------------------------------------------------------------------------


def _is_text(column: str, rows: Sequence[dict[str, Any]]) -> bool:
    value = next((row.get(column) for row in rows if row.get(column) is not None), None)
    return isinstance(value, str)


def data_table(table_id: str, columns: Sequence[TableColumn], rows: Sequence[dict[str, Any]], short: bool = True,
               caption: str = "", note: str = "") -> TableView:
    """A sortable table of ``rows``' ``columns``: headed by their labels (``short``) or by their names (the CSV's
    headers)."""
    head = tuple(Column(c.header if short else c.name, "text" if _is_text(c.name, rows) else "num", title=c.name)
                 for c in columns)
    body = tuple(tuple(row_cell(row, c) for c in columns) for row in rows)
    return TableView(table_id, head, body, caption=caption, note=note)


def row_cell(row: dict[str, Any], column: TableColumn) -> Cell:
    """``cell`` of a row's value; an undefined reduction says why, from the row's outcome of that reduction
    (``names.REDUCTION`` -> ``outcome``, its ``_pooled`` column -> ``outcome_pooled``)."""
    value = row.get(column.name)
    outcome = row.get(column.name.replace(names.REDUCTION, "outcome")) if is_reduction(column.name) else None
    difference = bounds.of(row, column.name.replace(names.REDUCTION, "aoc_difference")) if outcome else None
    why = words.undefined_words(outcome, value, difference)
    if why is not None:
        return Cell(f"{UNDEFINED}: {why}", kind="na")
    found = cell(value, column.name, fmt=column.fmt)
    if is_reduction(column.name) and found.kind in ("up", "down"):  # coloured only where its interval says so
        sign = words.direction(outcome, bounds.of(row, column.name))
        return Cell(found.text, found.sort, {1: "up", -1: "down"}.get(sign or 0, "num"))
    return found


def _pivot(spec: registry.Table) -> registry.Pivot:
    if spec.pivot is None:
        raise ValueError(f"table {spec.name!r} declares no pivot")
    return spec.pivot


def pivot(table_id: str, records: Rows, spec: registry.Table) -> TableView:
    """The registered table ``spec``'s pivot of ``records`` (its rows): its value with one row per value of its
    rows' column (sorted) and one column per value of its columns' (in first-seen order), e.g. the reduction per
    trust level (rows) and method (columns)."""
    layout, rows = _pivot(spec), [row_cells(r) for r in records]
    row, value, key = spec.column(layout.rows), spec.column(layout.values[0]), layout.columns[0]
    row_values = sorted(set(r[row.name] for r in rows))
    column_values = unique(str(r[key]) for r in rows)
    by_key = {(r[row.name], str(r[key])): r for r in rows}
    head = (Column(row.header), *(Column(c) for c in column_values))
    body = tuple((cell(v, row.name, fmt=row.fmt), *(row_cell(by_key.get((v, c), {}), value) for c in column_values))
                 for v in row_values)
    return TableView(table_id, head, body, caption=spec.caption)


def folded(table: WrittenTable, run_dir: Path) -> Folded:
    """The whole table as its CSV holds it (every column, unrounded for sorting), folded."""
    spec = registry.table(table.name)
    files = ", ".join(_relative(path, run_dir) for path in table.files)
    view = data_table(f"all-{table.name}", table.columns, table.rows, short=False)
    rows = f"{len(table.rows)} row" + ("" if len(table.rows) == 1 else "s")
    return Folded(f"{table.title or spec.title}: the whole table, {rows} ({files})", view)


def speed_table(table_id: str, records: Sequence[SpeedRow]) -> TableView:
    """The speed table's pivot: sequence recall@1, then the AOC reduction, per profile (rows, in the order given)
    and method and matcher (columns)."""
    spec = registry.table("speed")
    layout, rows = _pivot(spec), [row_cells(r) for r in records]
    profile = spec.column(layout.rows)
    profiles = unique(str(r[profile.name]) for r in rows)
    columns = list(dict.fromkeys(tuple(str(r[key]) for key in layout.columns) for r in rows))
    values = {(str(r[profile.name]), *(str(r[key]) for key in layout.columns)): r for r in rows}
    head = (Column(profile.header, "text"), *(Column(" · ".join(names)) for names in columns))
    body = []
    for value in (spec.column(name) for name in layout.values):
        for name in profiles:
            found = [values.get((name, *names)) for names in columns]
            body.append((text_cell(f"{name}: {value.header}", header=True),
                         *(row_cell(r or {}, value) for r in found)))
    return TableView(table_id, head, tuple(body), caption=spec.caption)


def scorer_table(table_id: str, rows: Sequence[BaselineRow] | Sequence[DetectionRow], caption: str) -> TableView:
    """A compact table of the baselines (``baselines`` or ``wrong_match_detection`` rows of one dataset, L and
    mode): a row per scorer, a column per method, the reduction (the average precision) in each cell; ``random``'s
    reduction as its mean ± sample standard deviation over the seeds (``baselines.headline``), its average precision
    as the mean over its seeds; the detection table ends with the fraction of wrong matches."""
    methods = unique(r.method for r in rows)
    scorers = unique(r.scorer for r in rows)
    by: dict[tuple[str, str], BaselineRow | DetectionRow] = {(r.method, r.scorer): r for r in rows}
    number = names.REDUCTION if any(isinstance(r, BaselineRow) for r in rows) else "average_precision"
    head = (Column("scorer", "text"), *(Column(m) for m in methods))
    body = []
    for scorer in scorers:
        cells = []
        for method in methods:
            row = by.get((method, scorer))
            if row is None:
                cells.append(cell(None, number))
            elif isinstance(row, BaselineRow) and row.scorer == RANDOM:
                mean, std = headline(row), row.reduction_pct_std
                text = UNDEFINED if mean is None else f"{mean:.2f}" + ("" if std is None else f" ± {std:.2f}")
                # the seeds' spread, not an interval over queries: not coloured
                cells.append(Cell(text, "" if mean is None else repr(mean), "na" if mean is None else "num"))
            elif isinstance(row, DetectionRow) and row.scorer == RANDOM and row.average_precision_mean is not None:
                cells.append(cell(row.average_precision_mean, number))
            elif isinstance(row, BaselineRow):
                cells.append(row_cell(row_cells(row), TableColumn(number, fmt=".2f")))
            else:
                cells.append(cell(row.average_precision, number))
        body.append((text_cell(scorer, header=True), *cells))
    detection = [r for r in rows if isinstance(r, DetectionRow) and r.scorer == scorers[0]]
    if detection:
        body.append((text_cell("wrong fraction", header=True), *(cell(r.wrong_fraction, fmt=".4f") for r in detection)))
    return TableView(table_id, head, tuple(body), caption=caption)


def best_scorer_table(table_id: str, rows: Sequence[SeqLenRow]) -> TableView:
    """The sequence-length ablation's best training-free scorer beside the predictor: a row per L, a column per
    method, each cell the scorer and its reduction (%), then the predictor's."""
    methods = unique(r.method for r in rows)
    lens = sorted({r.seq_len for r in rows})
    by = {(r.seq_len, r.method): r for r in rows}
    head = (Column("L"), *(Column(m, "text") for m in methods))
    body = []
    for seq_len in lens:
        cells = []
        for method in methods:
            row = by.get((seq_len, method))
            value = None if row is None else row.best_scorer_reduction_pct
            outcome = None if row is None else row.best_scorer_outcome
            best = (f"{row.best_scorer} {value:.2f}" if row is not None and value is not None and row.best_scorer
                    else f"{UNDEFINED}: {words.SHORT[outcome]}" if outcome in words.SHORT else UNDEFINED)
            predictor = None if row is None else row.reduction_pct
            cells.append(text_cell(f"{best} · predictor {UNDEFINED if predictor is None else f'{predictor:.2f}'}"))
        body.append((cell(seq_len, "seq_len"), *cells))
    return TableView(table_id, head, tuple(body), caption="The best training-free scorer's AOC reduction (%) beside "
                     "the predictor's, per sequence length (rows) and method (columns)")


# --- Table I and the findings -----------------------------------------------------------------------------------


def table1_view(block: Table1Block, table_id: str) -> TableView:
    """Table I of one dataset in the paper's layout: rows VPR+SM, VPR+SM+Pred, Reduction (%) and, with seeds,
    the reduction over seeds (mean ± std); a column per method, then Mean and Improved (Markdown's numbers)."""
    summary, note, improved = block.summary()
    head = (Column("", "text"), *(Column(m) for m in block.methods), Column("Mean"), Column("Improved", "text"))
    rows: list[tuple[Cell, ...]] = []
    for i, name in enumerate(ROW_NAMES):
        column = names.REDUCTION if i == 2 else "aoc"
        # the numbers' cells (sorting value, colour), with Table I's words where a number would mislead
        texts = cells(block.rows, summary, i, ".2f" if i == 2 else ".4f")
        numbers = [cell(v, column) for v in summary[i]]
        # colour: a method's reduction only where its interval says a direction (``outcome_words.direction``)
        kinds = [_reduction_kind(r, c.kind) for r, c in zip(block.rows, numbers, strict=False)] + [
            "num" if i == 2 and summary[i][-1] is not None else numbers[-1].kind]
        row = [Cell(t, c.sort, k) for t, c, k in zip(texts, numbers, kinds, strict=True)]
        if i == 2 and note:
            row[-1] = Cell(row[-1].text + note, row[-1].sort, row[-1].kind)
        rows.append((text_cell(name, header=True), *row, text_cell(improved if i == 2 else "")))
    texts, last = block.seed_cells()
    # the seeds' spread is no interval over queries: the means are not coloured
    kinds = ["na" if r.reduction_pct_mean is None else "num" for r in block.rows] + ["num"]
    rows.append((text_cell(SEED_ROW_NAME, header=True),
                 *(Cell(t, kind=k) for t, k in zip(texts, kinds, strict=True)), text_cell(last)))
    undefined = any(c.text.startswith(UNDEFINED) for row in rows for c in row)
    below = [*notes(block.rows), *([UNDEFINED_NOTE] if undefined else [])]
    return TableView(table_id, head, tuple(rows), note=" ".join(below), sortable=False, css="paper table1")


def _reduction_kind(row: Table1Row, kind: str) -> str:
    """A reduction cell's class: ``up``/``down`` only where ``outcome_words.direction`` says so, else neutral."""
    if kind not in ("up", "down"):
        return kind
    return {1: "up", -1: "down"}.get(words.direction(row.outcome, row.reduction_pct_ci) or 0, "num")


def predictor_warnings(predictor: WrittenTable | None, dataset: str, seq_len: int) -> list[str]:
    """The warning of the predictor table's row of ``dataset`` at ``seq_len`` as a sentence (none without one)."""
    rows = predictor.of(PredictorRow) if predictor is not None else ()
    return [f"Warning: the predictor of {dataset} at L = {seq_len} cannot be trusted: {row.warning}."
            for row in rows if (row.dataset, row.seq_len) == (dataset, seq_len) and row.warning]


def findings(table1: WrittenTable | None, split: str, predictor: WrittenTable | None = None) -> tuple[Finding, ...]:
    """Per Table I block, its sentences, led by the warnings of a predictor that cannot be trusted."""
    if table1 is None:
        return ()
    out = []
    for block in table1_blocks(table1.of(Table1Row)):
        title = f"Table I: {block.dataset} · {split} split · L = {block.seq_len} · {block.mode} mode"
        warned = predictor_warnings(predictor, block.dataset, block.seq_len)
        out.append(Finding(title, (*warned, *sentences(block, split)),
                           table1_view(block, anchor("table1", block.dataset, block.mode, block.seq_len)),
                           block.query_note(split), finding_headline(block, split)
                           + (" The predictor cannot be trusted here (details below)." if warned else "")))
    return tuple(out)


# --- the experiments' sections ----------------------------------------------------------------------------------


class _Builder:
    """Makes the sections from the written tables and figures (by registry name)."""

    def __init__(self, tables: Sequence[WrittenTable], figures: Sequence[WrittenFigure], order: Order, split: str,
                 run_dir: Path, splits: Splits | None = None, protocols: Mapping[str, str] | None = None) -> None:
        self.tables = {t.name: t for t in tables}
        self.figures = list(figures)
        self.order, self.split, self.run_dir = order, split, run_dir
        self.splits = splits or Splits(split, (split,))
        self.protocols = dict(protocols or {})  # per dataset its ground truth ("within 2 frames"), as the tables say

    def correct(self, dataset: str) -> str:
        """`` · correct: within 2 frames``: what a block's title says of its dataset's ground truth."""
        text = self.protocols.get(dataset)
        return f" · correct: {text}" if text else ""

    def rows(self, name: str) -> Rows:
        """The row records of the registered table ``name`` (``records``: typed); none when the run did not write
        it."""
        table = self.tables.get(name)
        return table.records if table else ()

    def records(self, name: str, row_type: type[R]) -> tuple[R, ...]:
        """The rows of the registered table ``name`` as its records (``row_type``: its row record); none when the
        run did not write it."""
        table = self.tables.get(name)
        return table.of(row_type) if table else ()

    def folded(self, *names: str) -> tuple[Folded, ...]:
        return tuple(folded(self.tables[n], self.run_dir) for n in names if n in self.tables)

    def figure(self, written: WrittenFigure) -> FigureView:
        return FigureView(written.caption, image_uri(written.path), _relative(written.path, self.run_dir))

    def named(self, name: str) -> list[WrittenFigure]:
        return [f for f in self.figures if f.name == name]

    @staticmethod
    def of(figure: WrittenFigure, rows: Iterable[R]) -> list[R]:
        """The row records of ``figure``'s dataset, L and mode (those it is of)."""
        keys = {"dataset": figure.dataset, "seq_len": figure.seq_len, "mode": figure.mode}
        match = {key: str(value) for key, value in keys.items() if value is not None}
        return [r for r in rows if all(str(getattr(r, key, None)) == value for key, value in match.items())]

    def columns(self, name: str, rows: Rows) -> list[TableColumn]:
        """What the compact tables of the registered table ``name`` show of ``rows`` (its records): its ``page``
        columns, an ``if_any`` one only where a row has a value in it."""
        found = [row_cells(r) for r in rows]
        return [c for c in registry.table(name).shown(self.splits) if not c.if_any or any(r.get(c.name) for r in found)]

    def pivot(self, name: str, table_id: str, rows: Rows) -> TableView:
        """The registered table ``name``'s pivot of ``rows`` (``pivot``)."""
        return pivot(table_id, rows, registry.table(name))

    def compact(self, name: str, table_id: str, rows: Rows, caption: str = "") -> TableView:
        """The compact table of the registered table ``name``: its page columns of ``rows`` (its records), headed
        by labels."""
        return data_table(table_id, self.columns(name, rows), [row_cells(r) for r in rows], caption=caption)

    def table_lens(self) -> set[int]:
        """Table I's sequence lengths (the per-L figures'); every L when there is no Table I."""
        return {r.seq_len for r in self.records("table1", Table1Row)}

    def keys(self, rows: Iterable[Table2Row | VPRMetricsRow]) -> list[tuple[str, int]]:
        """The (dataset, L) of ``rows``, in the configuration's order."""
        return sorted({(r.dataset, r.seq_len) for r in rows}, key=lambda key: (self.order.dataset(key[0]), key[1]))

    def block_title(self, figure: WrittenFigure) -> str:
        parts = [figure.dataset] + ([f"L = {figure.seq_len}"] if figure.seq_len is not None else [])
        return ", ".join(parts) + (f", {figure.mode} mode" if figure.mode else "") + self.correct(figure.dataset)

    def anchor(self, prefix: str, figure: WrittenFigure) -> str:
        """The HTML id of a figure's table: ``prefix`` and what the figure is of (dataset, L, mode)."""
        return anchor(prefix, *(part for part in (figure.dataset, figure.seq_len, figure.mode) if part is not None))

    def section(self, spec: Declared) -> Section | None:
        """The one builder of the experiments' sections: ``spec``'s blocks (its own, or one per written figure of
        ``spec.figure``: the figure, its rows' tables, sentences and the figures aside), under its title and intro,
        with its tables whole, folded; none when no table of it has a row and it has no block."""
        rows = self.rows(spec.tables[0]) if spec.tables else ()
        headlines = list(spec.headlines(self) if spec.headlines is not None else ())
        if spec.blocks is not None:
            blocks = list(spec.blocks(self))
        else:
            blocks = []
            for f in self.named(spec.figure):
                shown = self.of(f, rows)
                aside = tuple(self.figure(a) for a in self.named(spec.aside)
                              if (a.dataset, a.seq_len, a.mode) == (f.dataset, f.seq_len, f.mode))
                text = tuple(spec.sentences(self, shown)) if spec.sentences is not None else ()
                tables = spec.view(self, f, shown) if spec.view is not None else ()
                blocks.append(Block(self.block_title(f), (self.figure(f),), tables, text, aside=aside))
                said = spec.headline(shown) if spec.headline is not None and shown else ""
                if said:  # a question the rows do not answer has no line on the first screen
                    headlines.append(said)
        if not blocks and not any(self.rows(name) for name in spec.tables):
            return None
        intro = spec.intro(self) if callable(spec.intro) else (spec.intro,)
        return Section(spec.id, spec.title, intro, tuple(blocks), self.folded(*spec.tables), tuple(headlines))

    def sections(self) -> list[Section]:
        """The page's sections (``SECTIONS``), then those of the tables that declare their own, in the registry's
        order."""
        return [s for s in (self.section(spec) for spec in declared_sections()) if s is not None]


# --- the experiments' sections, declared (``sections.Declared``) ---------------------------------------------


def _baseline_blocks(b: _Builder) -> list[Block]:
    """Per dataset, L and mode each scorer's reduction at the predictor's budget, and per dataset and L the
    detection of wrong matches."""
    rows, detection = b.records("baselines", BaselineRow), b.records("wrong_match_detection", DetectionRow)
    blocks = []
    for f in b.named("baselines"):
        shown = [r for r in rows if (r.dataset, r.seq_len, r.mode) == (f.dataset, f.seq_len, f.mode)]
        table = scorer_table(anchor("baselines", f.dataset, f.seq_len, f.mode), shown,
                             registry.table("baselines").caption)
        blocks.append(Block(b.block_title(f), (b.figure(f),), (table,)))
    for f in b.named("detection"):
        found = [r for r in detection if (r.dataset, r.seq_len) == (f.dataset, f.seq_len)]
        table = scorer_table(anchor("detection", f.dataset, f.seq_len), found,
                             registry.table("wrong_match_detection").caption)
        blocks.append(Block(f"{b.block_title(f)}: detecting wrong matches", (b.figure(f),), (table,)))
    return blocks


def _detection_groups(b: _Builder) -> list[list[Any]]:
    by_key: dict[tuple[str, int], list[Any]] = {}
    for one in detection_comparisons(b.records("wrong_match_detection", DetectionRow)):
        by_key.setdefault((one.dataset, one.seq_len), []).append(one)
    return list(by_key.values())


BUDGET = ("Each scorer gives every query a confidence that its sequence match is correct and removes as many matches "
          "as the predictor does (its budget: the seed-0 predictor's, and every seed's for the spread over seeds), "
          "those of lowest confidence; the oracle removes only wrong matches, those of smallest sequence distance "
          "first, at most all of them. Each removal is scored as Table I scores the predictor's: the AOC at its own "
          "maximum recall against VPR+SM's curve cut there.")


def _baseline_intro(b: _Builder) -> tuple[str, ...]:
    """The sentence of every dataset, mode and L first, then how the scorers remove and what each is."""
    # each scorer as its registry entry describes it; the predictor is the page's subject, described above
    described = "; ".join(f"{s.name}: {s.description}" for s in scorer_registry.REGISTRY if s.kind != "predictor")
    scorers_text = (described + ". Detecting wrong matches is threshold-free: the average precision and ROC AUC "
                    "of each confidence against the wrong matches (a random ranking's average precision is the "
                    "fraction of wrong matches).")
    detected = tuple(detection_sentence(group, b.split) for group in _detection_groups(b))
    return (*(baseline_sentence(c, b.split) for c in comparisons(b.records("baselines", BaselineRow))), *detected,
            BUDGET,
            scorers_text)


def _baseline_headlines(b: _Builder) -> tuple[str, ...]:
    return (*(baseline_headline(c) for c in comparisons(b.records("baselines", BaselineRow))),
            *(detection_headline(g) for g in _detection_groups(b)))


def _seq_len_view(b: _Builder, f: WrittenFigure, shown: Rows) -> tuple[TableView, ...]:
    tables = [pivot(b.anchor("seq-len", f), shown, registry.table("ablation_seq_len"))]
    if any(r.best_scorer for r in shown):
        tables.append(best_scorer_table(b.anchor("seq-len-best", f), shown))
    return tuple(tables)


def _predictor_blocks(b: _Builder) -> list[Block]:
    """Per dataset: per L its methods' compact table, the pooled predictor's table, and the confusion figures."""
    methods, pooled = b.records("predictor_methods", PredictorMethodRow), b.records("predictor", PredictorRow)
    blocks = []
    confusion = b.named("confusion")
    datasets = unique([*(f.dataset for f in confusion), *(r.dataset for r in pooled)])
    for dataset in sorted(datasets, key=b.order.dataset):
        tables = []
        for f in (c for c in confusion if c.dataset == dataset):
            caption = registry.table("predictor_methods").caption.format(split=b.split, seq_len=f.seq_len)
            tables.append(b.compact("predictor_methods", anchor("predictor", dataset, f.seq_len), b.of(f, methods),
                                    caption))
        shown = [r for r in pooled if r.dataset == dataset]
        if shown:
            columns = b.columns("predictor", shown)
            caption = registry.table("predictor").caption
            if any(column.if_any for column in columns):  # the warning column: a row has a warning
                validation = b.splits.validation
                caption += ("; warning: the seeds whose predictor cannot be trusted on the "
                            f"{'validation' if validation in (None, 'val') else validation} split")
            tables.append(data_table(anchor("predictor-pooled", dataset), columns, [row_cells(r) for r in shown],
                                     caption=caption))
        figures = tuple(b.figure(c) for c in confusion if c.dataset == dataset)
        blocks.append(Block(dataset, figures, tuple(tables)))
    return blocks


def _table2_blocks(b: _Builder) -> list[Block]:
    """Per dataset and L: a row per attribute set, its attributes marked, the F1 columns; the samples in a note."""
    rows = b.records("table2", Table2Row)
    blocks = []
    shown_columns = b.columns("table2", rows)
    f1 = [column for column in shown_columns if not column.note]  # the rest: the samples, said in the note
    for dataset, seq_len in b.keys(rows):
        shown = [r for r in rows if (r.dataset, r.seq_len) == (dataset, seq_len)]
        head = (*(Column(a, "text") for a in ATTRIBUTES), *(Column(c.header) for c in f1))
        body = tuple((*(text_cell("✓" if r.attributes in (a, "all") else "×") for a in ATTRIBUTES),
                      *(row_cell(row_cells(r), c) for c in f1))
                     for r in shown)
        first = row_cells(shown[0])
        counts = [f"{first[c.name]} {c.header}" for c in shown_columns if c.note and first.get(c.name) is not None]
        note = "Macro F1 over " + ", ".join(counts) + ", every method pooled." if counts else ""
        table = TableView(anchor("table2", dataset, seq_len), head, body, note=note)
        blocks.append(Block(f"{dataset}, L = {seq_len}", (), (table,)))
    return blocks


def _lomo_blocks(b: _Builder) -> list[Block]:
    rows = b.records("leave_one_method_out", HeldOutRow)
    return [Block(dataset, (), (b.compact("leave_one_method_out", anchor("lomo", dataset),
                                          [r for r in rows if r.dataset == dataset]),))
            for dataset in sorted(unique(r.dataset for r in rows), key=b.order.dataset)]


def _timing_blocks(b: _Builder) -> list[Block]:
    """Per dataset, the table split's timings at Table I's sequence lengths."""
    rows, lens = b.records("timing", TimingRow), b.table_lens()
    blocks = []
    for dataset in sorted(unique(r.dataset for r in rows), key=b.order.dataset):
        shown = [r for r in rows if (r.dataset, r.split) == (dataset, b.split) and (not lens or r.seq_len in lens)]
        if shown:
            table = b.compact("timing", anchor("timing", dataset), shown)
            blocks.append(Block(f"{dataset}, {b.split} split", (), (table,)))
    return blocks


def _metrics_mode(b: _Builder) -> tuple[str, tuple[str, ...]]:
    """The mode the compact tables show (paper, if the run has it) and every mode of the table."""
    modes = unique(r.mode for r in b.records("vpr_metrics", VPRMetricsRow))
    return ("paper" if "paper" in modes else modes[0]) if modes else "", modes


def _metrics_blocks(b: _Builder) -> list[Block]:
    rows, (mode, _) = b.records("vpr_metrics", VPRMetricsRow), _metrics_mode(b)
    blocks = []
    for dataset, seq_len in b.keys(rows):
        shown = [replace(r, matcher=MATCHER_TEXT.get(r.matcher, r.matcher)) for r in rows
                 if (r.dataset, r.seq_len, r.mode) == (dataset, seq_len, mode)]
        table = b.compact("vpr_metrics", anchor("metrics", dataset, seq_len, mode), shown)
        blocks.append(Block(f"{dataset}, L = {seq_len}, {b.split} split, {mode} mode{b.correct(dataset)}", (),
                            (table,)))
    return blocks


def _inspector_blocks(b: _Builder) -> list[Block]:
    """Per dataset, method and L: the match figure, the distance matrix beside it, and where the per-query CSV is."""
    figures = [f for f in b.figures if f.name in INSPECTOR_FIGURES]
    blocks = []
    for key in unique(f"{f.dataset}\0{f.method}\0{f.seq_len}" for f in figures):
        dataset, method, seq_len = key.split("\0")
        shown = [f for f in figures if (f.dataset, f.method, str(f.seq_len)) == (dataset, method, seq_len)]
        queries = Path(queries_path(b.run_dir, dataset, method, seq_len))
        found = "" if queries.is_file() else " (not in the run folder when this page was written)"
        text = f"Every evaluated query, one row each: {_relative(queries, b.run_dir)}{found}."
        views = [b.figure(f) for f in shown]  # the match figure first: the larger one, the matrix beside it
        blocks.append(Block(f"{method} on {dataset}, L = {seq_len}", tuple(views[:1]), (), (text,),
                            aside=tuple(views[1:])))
    return blocks


SECTIONS = (
    # right after Table I: is the predictor better than a simple rule?
    Declared("baselines", "Is the predictor better than a simple rule?", ("baselines", "wrong_match_detection"),
             _baseline_intro, blocks=_baseline_blocks, headlines=_baseline_headlines),
    Declared("pr-curves", "Precision-recall curves", ("table1",), prose("pr-curves"), "pr",
        view=lambda b, f, shown: (b.compact("table1", b.anchor("pr", f), shown),)),
    Declared("sequence-length", "Sequence-length ablation", ("ablation_seq_len",), prose("sequence-length"), "seq_len",
             view=_seq_len_view),
    Declared("predictor", "The predictor alone", ("predictor", "predictor_methods", "predictor_confusion"),
             prose("predictor"), blocks=_predictor_blocks),
    Declared("table-ii", "Table II: attribute ablation", ("table2",), prose("table-ii"), blocks=_table2_blocks),
    Declared("leave-one-method-out", "Leave one method out", ("leave_one_method_out",), lambda b: (
        f"Each method's {b.split} split under the pooled predictor and under one trained on every other "
        "method: how well the predictor carries over to a method it has not seen.",), blocks=_lomo_blocks),
    Declared("timing", "Inference time", ("timing",), prose("timing"), blocks=_timing_blocks),
    Declared("vpr-metrics", "Standard VPR metrics", ("vpr_metrics",), lambda b: (
        "Recall@N (a query counts when a correct reference is among its N best matches), recall at 100 % "
        "precision (R@100P), the area under the PR curve (PR-AUC) and extended precision (EP), for single-frame "
        "matching, sequence matching, and sequence matching with the predictor (a removed match counts as not "
        f"retrieved). The whole table has every mode ({', '.join(_metrics_mode(b)[1])}).",), blocks=_metrics_blocks),
    Declared("match-inspector", "Match inspector", (), lambda b: (
        f"Query by query, where sequence matching and the predictor go right or wrong on the {b.split} "
        "split. The per-query CSV files (matches, distances, attributes, true class, prediction) are in the run "
        "folder, named under each method.",), blocks=_inspector_blocks),
)




def declared_sections() -> tuple[Declared, ...]:
    """``SECTIONS``, and the ``section`` of each registered table that declares one (an experiment's: the tool's own
    and installed ones), in the page's order (``sections.placed``); each checked (its tables and figures
    registered) and its id once."""
    from vpr_smr.eval.report.experiments import builtin

    # the tables' sections: the tool's own experiments' (in their modules: those of ``matchers`` and
    # ``adaptive_seq_len`` on their tables of eval/report/tables/) and installed ones', each once
    tables = (*registry.TABLES, *(entry for experiment in builtin() for entry in experiment.tables))
    found = placed(SECTIONS, list(dict.fromkeys(entry.section for entry in tables if entry.section is not None)))
    for spec in found:
        spec.check()
    ids = [spec.id for spec in found]
    twice = sorted({name for name in ids if ids.count(name) > 1})
    if twice:
        raise ValueError(f"sections declared twice: {', '.join(twice)}")
    return found


# --- datasets, provenance ---------------------------------------------------------------------------------------


def cards(datasets: dict[str, dict[str, Any]] | None, order: Order) -> tuple[Card, ...]:
    out = []
    for name in sorted(datasets or {}, key=order.dataset):
        info = (datasets or {})[name]
        splits = info.get("splits", {})
        reference_splits = info.get("reference_splits") or {}  # method §11: reference ranges that differ
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
    split: str,
    config: str | dict[str, Any] | None = None,
    provenance: dict[str, Any] | None = None,
    descriptor_paths: Sequence[Path | str] = (),
    title: str = "vpr-smr report",
    datasets: dict[str, dict[str, Any]] | None = None,
    splits: Splits | None = None,
    protocols: Mapping[str, str] | None = None,
    matchers: Sequence[str] = (),
) -> Page:
    """The page's view model from the tables and figures of the run folder ``run_dir``: ``split`` is the table
    split, ``splits`` every split's name by role (default: ``split`` alone), ``protocols`` per dataset its ground
    truth as the tables say it (``build.protocols``; default: from the dataset cards), ``matchers`` the sequence
    matchers (name and settings) the evaluations record, which the subtitle names."""
    order = order or Order(tuple(datasets or {}))
    by_name = {t.name: t for t in tables}
    general, files = provenance_rows(provenance, descriptor_paths)
    version = str(general["vpr_smr_version"])
    lens = sorted({r.seq_len for r in by_name["table1"].of(Table1Row)}) if "table1" in by_name else []
    run = config.get("run") if isinstance(config, dict) else None
    subtitle = " · ".join([
        *([f"run {run}"] if run else []), f"vpr-smr {version}", *([f"{split} split"] if split else []),
        *([f"Table I at L = {', '.join(map(str, lens))}"] if lens else []),
        *([f"sequence matcher {'; '.join(matchers)}"] if matchers else []),
        f"generated {datetime.now(UTC).strftime('%Y-%m-%d %H:%M UTC')}",
    ])
    found = findings(by_name.get("table1"), split, by_name.get("predictor"))
    table1_files = (", ".join(_relative(p, run_dir) for p in by_name["table1"].files[1:]) + " hold this layout; "
                    + _relative(by_name["table1"].files[0], run_dir) + " every column") if "table1" in by_name else ""
    if protocols is None:
        protocols = {name: ground_truth_text(info) for name, info in (datasets or {}).items()}
    named = [f"{name} {text}" for name, text in protocols.items() if text]
    sections = _Builder(tables, figures, order, split, run_dir, splits, protocols).sections()
    dataset_table = by_name.get("datasets")
    descriptor_table = data_table("provenance-files", [TableColumn(key) for key in ("file", *DESCRIPTOR_KEYS)],
                                  files, short=False) if files else None
    page_cards = cards(datasets, order)
    answers = verdicts(Answers.of(tables), order, split, protocols)
    nav = [*([("findings", "Findings")] if found or answers else []), *((s.id, s.title) for s in sections),
           *([("datasets", "Datasets")] if page_cards or dataset_table else []),
           ("provenance", "Provenance"), ("configuration", "Configuration")]
    return Page(
        title=title, subtitle=subtitle, warnings=overlap_warnings(datasets, order), findings=found, verdicts=answers,
        findings_files=table1_files, sections=tuple(sections), cards=page_cards,
        datasets_table=folded(dataset_table, run_dir) if dataset_table else None, cite=how_to_cite(version),
        provenance=_provenance_table(general), descriptor_files=descriptor_table, configuration=_config_text(config),
        nav=tuple(nav), ground_truth="Correct matches: " + "; ".join(named) if named else "",
        across_machines=ACROSS_MACHINES)


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
    split: str,
    config: str | dict[str, Any] | None = None,
    provenance: dict[str, Any] | None = None,
    descriptor_paths: Sequence[Path | str] = (),
    title: str = "vpr-smr report",
    datasets: dict[str, dict[str, Any]] | None = None,
    splits: Splits | None = None,
    protocols: Mapping[str, str] | None = None,
    matchers: Sequence[str] = (),
) -> Path:
    """Write the page to ``out`` (temporary name, then rename; its folder is the run folder) and return its path."""
    out = Path(out)
    page = build_page(tables, figures, out.parent, order=order, split=split, config=config, provenance=provenance,
                      descriptor_paths=descriptor_paths, title=title, datasets=datasets, splits=splits,
                      protocols=protocols, matchers=matchers)
    text = render(page)
    with atomic_path(out) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return out
