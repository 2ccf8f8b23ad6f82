"""Every table and figure of the report, named once.

The writer (``build``) looks each table and figure up here for its file names and title, and ``build.
expected_outputs`` lists the files from here, so that a table or figure cannot be written without being declared
to the workflow, nor declared without being written. The order is the report's: tables, then figures.
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from dataclasses import dataclass

TABLES_DIR = "tables"
FIGURES_DIR = "figures"
HTML = "report.html"


@dataclass(frozen=True)
class Table:
    name: str  # the file stem under tables/
    title: str  # the heading of its Markdown and LaTeX files and of the HTML page
    experiments: tuple[str, ...]  # written when every one of these is run (``expected_outputs``' names)
    suffixes: tuple[str, ...] = (".csv", ".md", ".tex")  # the CSV first: the HTML page shows it

    def enabled(self, experiments: Collection[str]) -> bool:
        return all(name in experiments for name in self.experiments)

    def files(self) -> list[str]:
        """The table's files, relative to the run folder."""
        return [f"{TABLES_DIR}/{self.name}{suffix}" for suffix in self.suffixes]


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


TABLES = (
    Table("table1", "Table I: area over the PR curve at max recall", ("table1",)),
    Table("predictor_methods", "Predictor alone: macro F1, class counts and predicted counts per method",
          ("table1",)),
    Table("predictor_confusion", "Predictor alone: confusion matrix (rows true class, columns predicted)",
          ("table1",)),
    Table("trust_levels", "Trust-level ablation: PR AUC per trust level", ("table1", "trust")),
    Table("restoration", "Match restoration (second filter): removal against restoration", ("table1", "restoration")),
    Table("timing", "Inference time per query: attributes + prediction", ("table1",)),
    Table("vpr_metrics", "Standard VPR metrics: recall@N, recall at 100 % precision, PR AUC and extended precision "
          "of single-frame matching, sequence matching and sequence matching with the predictor", ("metrics",)),
    Table("ablation_seq_len", "Sequence-length ablation: Table I columns per dataset, method and sequence length",
          ("table1", "seq_len")),
    Table("speed", "Speed profiles: recall@1 and the Table I AOC numbers of the fixed matcher and of velocity search "
          "on simulated queries driven at other speeds (SPEC 11), per dataset, method, profile and matcher",
          ("speed",)),
    Table("predictor", "Predictor alone: macro F1 (cross-validation with SMOTE inside the folds, validation, test)",
          ("predictor",)),
    Table("table2", "Table II: macro F1 by attribute", ("attributes",)),
    Table("leave_one_method_out", "Leave one method out: pooled predictor against one trained without the method",
          ("leave_one_method_out",)),
    Table("datasets", "Datasets: traverses, frames per split, tolerance, frame lists and where the images came from",
          ("datasets",)),
)

FIGURES = (
    Figure("pr", "PR curves", ("table1",), "pr_{dataset}_L{seq_len}_{mode}.png"),
    Figure("trust", "Trust levels", ("table1", "trust"), "trust_{dataset}_L{seq_len}_{mode}.png"),
    Figure("restoration", "Restoration", ("table1", "restoration"), "restoration_{dataset}_L{seq_len}_{mode}.png"),
    Figure("restoration_auc", "Restoration PR AUC difference", ("table1", "restoration"),
           "restoration_auc_{dataset}_L{seq_len}_{mode}.png"),
    Figure("confusion", "Confusion matrix", ("table1",), "confusion_{dataset}_L{seq_len}.png"),
    Figure("seq_len", "Sequence-length ablation", ("table1", "seq_len"), "seq_len_{dataset}_{mode}.png"),
    Figure("speed", "Speed profiles", ("speed",), "speed_{dataset}_L{seq_len}.png"),
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
) -> list[str]:
    """Paths (relative to the run folder) that ``main`` writes, from the configuration alone.

    ``experiments``: any of ``"table1"`` (evaluations given: Table I, predictor_methods, predictor_confusion,
    timing, PR and confusion figures), ``"predictor"`` (predictor reports given), ``"trust"`` (trust levels
    configured), ``"restoration"``, ``"seq_len"`` (the sequence-length ablation), ``"attributes"`` (Table II),
    ``"leave_one_method_out"``, ``"metrics"`` (the standard VPR metrics given), ``"datasets"`` (dataset cards
    given), ``"speed"`` (the speed experiment, at ``table_seq_lens``, for ``speed_datasets``: default every
    dataset; those with positions have none); each table and figure of ``registry`` is listed when all of its
    experiments are.
    """
    out = [path for spec in TABLES if spec.enabled(experiments) for path in spec.files()]
    figure_lens = [s for s in seq_lens if table_seq_lens is None or s in table_seq_lens]
    per_seq_len = [spec for spec in FIGURES if spec.per_seq_len and spec.enabled(experiments)]
    for dataset in sorted(datasets):
        for seq_len in sorted(figure_lens):
            for mode in modes:
                out += [spec.file(dataset=dataset, seq_len=seq_len, mode=mode) for spec in per_seq_len
                        if spec.per_mode]
            out += [spec.file(dataset=dataset, seq_len=seq_len) for spec in per_seq_len if not spec.per_mode
                    and (spec.name != "speed" or speed_datasets is None or dataset in speed_datasets)]
    # the figures over every sequence length (one per dataset and mode)
    out += [spec.file(dataset=dataset, mode=mode) for spec in FIGURES
            if not spec.per_seq_len and spec.enabled(experiments) for dataset in sorted(datasets)
            for mode in sorted(modes)]
    if html:
        out.append(HTML)
    return out
