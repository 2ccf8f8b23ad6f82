"""Every table and figure of the report, named once.

The writer (``build``) looks each table and figure up here for its file names and title, and ``build.
expected_outputs`` lists the files from here, so that a table or figure cannot be written without being declared
to the workflow, nor declared without being written. The order is the report's: tables, then figures.

Each table names its row record (``rows``: its fields are the columns, in the files' order, each with its header
on the page and how the page writes its numbers), and what of it the page's compact tables show (``page``,
``pivot``, ``caption``): ``build`` writes the CSV, Markdown and LaTeX files of the records' cells and ``html``
builds the page's tables from them.
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from dataclasses import dataclass
from typing import Any

from vpr_smr.core.constants import RECALL_AT
from vpr_smr.eval.report import rows
from vpr_smr.eval.report.results import Splits
from vpr_smr.eval.report.rows import Column

TABLES_DIR = "tables"
FIGURES_DIR = "figures"
HTML = "report.html"


@dataclass(frozen=True)
class Pivot:
    """A compact table with a row per value of the column ``rows`` and a column per value of ``columns`` (method,
    or method and matcher), showing ``values``."""

    rows: str
    columns: tuple[str, ...]
    values: tuple[str, ...]


@dataclass(frozen=True)
class Table:
    """A table of the report: its files (``name``, ``title``), when it is written (``experiments``), its ``row``
    record (``rows``: its fields are the columns, in the files' order), and what of it the page's compact tables
    show: ``page`` (the columns by name, in their order) or ``pivot``, under ``caption`` (``{split}``: the table
    split, ``{seq_len}``: the L)."""

    name: str  # the file stem under tables/
    title: str  # the heading of its Markdown and LaTeX files and of the HTML page
    experiments: tuple[str, ...]  # written when every one of these is run (``expected_outputs``' names)
    row: Any  # the row record (a dataclass declared with ``rows``)
    suffixes: tuple[str, ...] = (".csv", ".md", ".tex")  # the CSV first: the HTML page shows it
    page: tuple[str, ...] = ()
    pivot: Pivot | None = None
    caption: str = ""

    def __post_init__(self) -> None:
        shown = (*self.page, *((self.pivot.rows, *self.pivot.values) if self.pivot else ()))
        unknown = [name for name in shown if name not in {column.name for column in self.columns}]
        if unknown:
            raise ValueError(f"table {self.name!r} shows undeclared columns {unknown}")

    @property
    def columns(self) -> tuple[Column, ...]:
        """Its row record's columns (``rows.columns``), a split role's still one."""
        return rows.columns(self.row)

    def enabled(self, experiments: Collection[str]) -> bool:
        return all(name in experiments for name in self.experiments)

    def files(self) -> list[str]:
        """The table's files, relative to the run folder."""
        return [f"{TABLES_DIR}/{self.name}{suffix}" for suffix in self.suffixes]

    def column(self, name: str) -> Column:
        """The declared column ``name`` (a KeyError for another)."""
        for column in self.columns:
            if column.name == name:
                return column
        raise KeyError(f"table {self.name!r} declares no column {name!r}")

    def expanded(self, splits: Splits | None = None) -> tuple[Column, ...]:
        """The columns of a run with ``splits`` (one per split where a column is), in the files' order."""
        return expand(self.columns, splits)

    def names(self, splits: Splits | None = None) -> tuple[str, ...]:
        return tuple(column.name for column in self.expanded(splits))

    def shown(self, splits: Splits | None = None) -> tuple[Column, ...]:
        """The columns of ``page``, in its order, of a run with ``splits``."""
        return expand([self.column(name) for name in self.page], splits)


def expand(columns: Sequence[Column], splits: Splits | None = None) -> tuple[Column, ...]:
    return tuple(one for column in columns for one in column.expand(splits))


@dataclass(frozen=True)
class Figure:
    name: str
    title: str  # the start of its caption in the HTML page ("<title>: <dataset, L, mode>")
    experiments: tuple[str, ...]
    # the file name under figures/: {dataset} and {mode}, and {seq_len} for one figure per sequence length
    pattern: str

    def enabled(self, experiments: Collection[str]) -> bool:
        return all(name in experiments for name in self.experiments)

    @property
    def per_seq_len(self) -> bool:
        return "{seq_len}" in self.pattern

    @property
    def per_mode(self) -> bool:
        return "{mode}" in self.pattern

    def file(self, **names: object) -> str:
        """The figure's file, relative to the run folder, for the ``dataset``, ``seq_len`` and ``mode`` given."""
        return f"{FIGURES_DIR}/{self.pattern.format(**names)}"


# The predictor table's title names the run's evaluation splits (``results.split_word``); registered with the
# configuration's default ones (val, test)
PREDICTOR_TITLE = "Predictor alone: macro F1 (cross-validation with SMOTE inside the folds, {splits})"

# the column the report adds to every table's CSV in a run whose splits share frames (allow_split_overlap)
SPLIT_OVERLAP = Column("split_overlap")
# the column the report adds to every table's CSV whose datasets' ground truth is known: each row's dataset's, as
# the Markdown and LaTeX files' "Correct matches:" line under the title says it ("within 2 frames", "gt.npy (a matrix)")
CORRECT_MATCHES = Column("correct_matches")

TABLES = (
    Table("table1", "Table I: area over the PR curve at max recall", ("table1",),
          row=rows.Table1Row,
          page=("method", "recall_at_1_single", "recall_at_1_sequence", "max_recall", "reduction_pct")),
    Table("predictor_methods", "Predictor alone: macro F1, class counts and predicted counts per method",
          ("table1",),
          row=rows.PredictorMethodRow,
          page=("method", "n_queries", "f1_macro", "class_0", "class_1", "class_2", "class_3"),
          caption="Per method, {split} split, L = {seq_len}: macro F1 and the true classes' counts (the predicted "
                  "counts: the whole table below)"),
    Table("predictor_confusion", "Predictor alone: confusion matrix (rows true class, columns predicted)",
          ("table1",), row=rows.ConfusionRow),
    Table("trust_levels", "Trust-level ablation: PR AUC per trust level", ("table1", "trust"),
          row=rows.TrustRow,
          pivot=Pivot("trust", ("method",), ("reduction_pct",)),
          caption="AOC reduction (%) per trust level (columns: methods)"),
    Table("restoration", "Match restoration (second filter): removal against restoration", ("table1", "restoration"),
          row=rows.RestorationRow,
          page=("method", "removed", "restored", "wrong_to_right", "right_to_wrong", "auc_difference")),
    Table("timing", "Inference time per query: attributes + prediction", ("table1",),
          row=rows.TimingRow,
          page=("method", "seq_len", "n_queries", "ms_per_query", "ms_attributes_per_query", "ms_predict_per_query")),
    Table("vpr_metrics", "Standard VPR metrics: recall@N, recall at 100 % precision, PR AUC and extended precision "
          "of single-frame matching, sequence matching and sequence matching with the predictor", ("metrics",),
          row=rows.VPRMetricsRow,
          page=("method", "matcher", "n_queries", *(f"recall_at_{n}" for n in RECALL_AT), "recall_at_100p",
                "pr_auc", "extended_precision")),
    Table("baselines", "Training-free baselines: AOC at max recall of each scorer removing as many matches as the "
          "predictor (method §12), per dataset, method, L and mode", ("baselines",),
          row=rows.BaselineRow,
          caption="AOC reduction (%) of each scorer (rows) per method (columns) at the seed-0 predictor's budget; "
                  "random: mean ± sample standard deviation over the seeds"),
    Table("wrong_match_detection", "Detecting wrong matches: average precision and ROC AUC of each scorer against "
          "the wrong sequence matches (method §12), per dataset, method and L", ("baselines",),
          row=rows.DetectionRow,
          caption="Average precision of detecting the wrong sequence matches (rows: scorers, columns: methods); "
                  "random: mean over its seeds; the last row: the fraction of wrong matches, a random ranking's "
                  "expected average precision"),
    Table("ablation_seq_len", "Sequence-length ablation: Table I columns per dataset, method and sequence length",
          ("table1", "seq_len"),
          row=rows.SeqLenRow,
          pivot=Pivot("seq_len", ("method",), ("reduction_pct",)),
          caption="AOC reduction (%) per sequence length (columns: methods)"),
    Table("speed", "Speed profiles: recall@1 and the Table I AOC numbers of the fixed matcher and of velocity search "
          "on simulated queries driven at other speeds (method §11), per dataset, method, profile and matcher",
          ("speed",),
          row=rows.SpeedRow,
          pivot=Pivot("profile", ("method", "matcher"), ("recall_at_1_sequence", "reduction_pct")),
          caption="Sequence recall@1, then the predictor's AOC reduction (%), per profile (rows) and method · matcher "
                  "(columns); single-frame recall@1 and the AOCs: the whole table below"),
    Table("predictor", PREDICTOR_TITLE.format(splits="validation, test"), ("predictor",),
          row=rows.PredictorRow,
          page=("seq_len", "n_train", "f1_cv", "f1_{evaluation}", "n_{evaluation}", "warning"),
          caption="The pooled predictor (seed 0) per sequence length"),
    Table("table2", "Table II: macro F1 by attribute", ("attributes",),
          row=rows.Table2Row,
          # the F1 columns, then the samples they are over, which the page says in a note
          page=("f1_cv", "f1_{validation}", "f1_{last}", "f1_{last}_method_mean", "n_train", "n_{validation}",
                "n_{last}")),
    Table("leave_one_method_out", "Leave one method out: pooled predictor against one trained without the method",
          ("leave_one_method_out",),
          row=rows.HeldOutRow,
          page=("held_out", "seq_len", "mode", "f1_pooled", "f1_without", "removed_pooled", "removed_without",
                "aoc_vpr_sm", "aoc_pooled", "aoc_without", "reduction_pct_pooled", "reduction_pct_without")),
    Table("protocol_sweep", "Protocol sweep: recall@1 and the AOC reduction of the predictor under other ground-truth "
          "tolerances (frames) or radii (positions), from the same matches and the same seed-0 predictor (method §13)",
          ("protocol_sweep",),
          row=rows.SweepRow,
          pivot=Pivot("threshold", ("method",), ("reduction_pct",)),
          caption="AOC reduction (%) per tolerance or radius (rows) and method (columns); recall@1: the figure and "
                  "the whole table below"),
    Table("datasets", "Datasets: traverses, frames per split, tolerance, frame lists and where the images came from",
          ("datasets",),
          row=rows.DatasetRow),
)

FIGURES = (
    Figure("pr", "PR curves", ("table1",), "pr_{dataset}_L{seq_len}_{mode}.png"),
    Figure("trust", "Trust levels", ("table1", "trust"), "trust_{dataset}_L{seq_len}_{mode}.png"),
    Figure("restoration", "Restoration", ("table1", "restoration"), "restoration_{dataset}_L{seq_len}_{mode}.png"),
    Figure("restoration_auc", "Restoration PR AUC difference", ("table1", "restoration"),
           "restoration_auc_{dataset}_L{seq_len}_{mode}.png"),
    Figure("confusion", "Confusion matrix", ("table1",), "confusion_{dataset}_L{seq_len}.png"),
    Figure("seq_len", "Sequence-length ablation", ("table1", "seq_len"), "seq_len_{dataset}_{mode}.png"),
    Figure("baselines", "Training-free baselines", ("baselines",), "baselines_{dataset}_L{seq_len}_{mode}.png"),
    Figure("detection", "Detecting wrong matches", ("baselines",), "detection_{dataset}_L{seq_len}.png"),
    Figure("speed", "Speed profiles", ("speed",), "speed_{dataset}_L{seq_len}.png"),
    Figure("protocol_sweep", "Protocol sweep", ("protocol_sweep",), "protocol_sweep_{dataset}_L{seq_len}_{mode}.png"),
)


def table(name: str) -> Table:
    """The registered table ``name``; a KeyError for a table the registry does not declare."""
    for entry in TABLES:
        if entry.name == name:
            return entry
    raise KeyError(f"table {name!r} is not in eval/report/registry.py TABLES")


def figure(name: str) -> Figure:
    """The registered figure ``name``; a KeyError for a figure the registry does not declare."""
    for entry in FIGURES:
        if entry.name == name:
            return entry
    raise KeyError(f"figure {name!r} is not in eval/report/registry.py FIGURES")


def expected_outputs(
    datasets: Sequence[str],
    seq_lens: Sequence[int],
    modes: Sequence[str],
    experiments: Collection[str],
    table_seq_lens: Collection[int] | None = None,
    html: bool = True,
    speed_datasets: Collection[str] | None = None,
    sweep_datasets: Collection[str] | None = None,
) -> list[str]:
    """Paths (relative to the run folder) that ``main`` writes, from the configuration alone.

    ``experiments``: any of ``"table1"`` (evaluations given: Table I, predictor_methods, predictor_confusion,
    timing, PR and confusion figures), ``"predictor"`` (predictor reports given), ``"trust"`` (trust levels
    configured), ``"restoration"``, ``"seq_len"`` (the sequence-length ablation), ``"attributes"`` (Table II),
    ``"leave_one_method_out"``, ``"metrics"`` (the standard VPR metrics given), ``"datasets"`` (dataset cards
    given), ``"baselines"`` (the training-free baselines given), ``"speed"`` (the speed experiment, at
    ``table_seq_lens``, for ``speed_datasets``: default every dataset; those with positions have none),
    ``"protocol_sweep"`` (the protocol sweep, for ``sweep_datasets``: default every dataset; those whose ground truth
    is a file have none); each table and figure of ``registry`` is listed when all of its experiments are.
    """
    only = {"speed": speed_datasets, "protocol_sweep": sweep_datasets}  # figures of some datasets only
    out = [path for spec in TABLES if spec.enabled(experiments) for path in spec.files()]
    figure_lens = [s for s in seq_lens if table_seq_lens is None or s in table_seq_lens]
    per_seq_len = [spec for spec in FIGURES if spec.per_seq_len and spec.enabled(experiments)]
    for dataset in sorted(datasets):
        for seq_len in sorted(figure_lens):
            for mode in modes:
                out += [spec.file(dataset=dataset, seq_len=seq_len, mode=mode) for spec in per_seq_len
                        if spec.per_mode and _shown(only.get(spec.name), dataset)]
            out += [spec.file(dataset=dataset, seq_len=seq_len) for spec in per_seq_len if not spec.per_mode
                    and _shown(only.get(spec.name), dataset)]
    # the figures over every sequence length (one per dataset and mode)
    out += [spec.file(dataset=dataset, mode=mode) for spec in FIGURES
            if not spec.per_seq_len and spec.enabled(experiments) for dataset in sorted(datasets)
            for mode in sorted(modes)]
    if html:
        out.append(HTML)
    return out


def _shown(datasets: Collection[str] | None, dataset: str) -> bool:
    """Whether a figure of ``dataset`` is written, when only ``datasets`` have it (None: every dataset)."""
    return datasets is None or dataset in datasets
