"""Every table and figure of the report, named once.

The writer (``build``) looks each table and figure up here for its file names and title, and ``build.
expected_outputs`` lists the files from here, so that a table or figure cannot be written without being declared
to the workflow, nor declared without being written. The order is the report's: tables, then figures.

Each table names its row record (``rows``: its fields are the columns, in the files' order, each with its header
on the page and how the page writes its numbers), how its rows are made from the run's inputs (``make``), and what
of it the page's compact tables show (``page``, ``pivot``, ``caption``) and in which section (``section``, or one of
``html.SECTIONS``): ``build`` writes the CSV, Markdown and LaTeX files of the records' cells and ``html`` builds the
page's tables from them.

A table is one declaration: the tables of ``CORE_TABLES`` below (the tool's own experiments' among them, from their
modules), then each module of the package ``eval/report/tables/`` that declares a ``TABLE`` (a ``Table``), in the
modules' names' order, then the tables of the experiments installed packages register (``eval.report.experiments``).
The experiments ``matchers`` and ``adaptive_seq_len`` declare their tables in such a module and their sections on
them in their own modules (``html.declared_sections`` reads them there).

A figure is one declaration too (``Figure``): the core figures of ``FIGURES`` below, the tool's own experiments'
from their modules (each with the function that draws it, ``Figure.draw``), each at its place in the report's order,
then those of the experiments installed packages register.
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Collection, Sequence
from typing import TypeVar

from vpr_smr.core.constants import RECALL_AT
from vpr_smr.eval.report import names, rows
from vpr_smr.eval.report import tabulate as make
from vpr_smr.eval.report.results import split_word
from vpr_smr.eval.report.rows import Column
from vpr_smr.eval.report.table_spec import FIGURES_DIR as FIGURES_DIR
from vpr_smr.eval.report.table_spec import TABLES_DIR as TABLES_DIR
from vpr_smr.eval.report.table_spec import Figure as Figure
from vpr_smr.eval.report.table_spec import Pivot as Pivot
from vpr_smr.eval.report.table_spec import Table as Table
from vpr_smr.eval.report.table_spec import expand as expand
from vpr_smr.eval.report.tabulate import Inputs

HTML = "report.html"
_Named = TypeVar("_Named", Table, Figure)  # an entry of the report's files, by its name


# The predictor table's title names the run's evaluation splits (``results.split_word``); registered with the
# configuration's default ones (val, test)
PREDICTOR_TITLE = "Predictor alone: macro F1 (cross-validation with SMOTE inside the folds, {splits})"


def _predictor_title(inputs: Inputs) -> str:
    return PREDICTOR_TITLE.format(splits=", ".join(map(split_word, inputs.splits.evaluation)))

# the column the report adds to every table's CSV in a run whose splits share frames (allow_split_overlap)
SPLIT_OVERLAP = Column("split_overlap")
# the column the report adds to every table's CSV whose datasets' ground truth is known: each row's dataset's, as
# the Markdown and LaTeX files' "Correct matches:" line under the title says it ("within 2 frames", "gt.npy (a matrix)")
CORRECT_MATCHES = Column("correct_matches")

def own_tables(name: str) -> tuple[Table, ...]:
    """The tables of the tool's own experiment ``name`` (``eval.report.experiments``: its module is imported here,
    by its registered name; the report does not import the workflow's modules itself)."""
    from vpr_smr.eval.report.experiments import EXPERIMENTS

    return EXPERIMENTS.get(name).tables


def own_figures(name: str) -> tuple[Figure, ...]:
    """The figures of the tool's own experiment ``name``, as ``own_tables``."""
    from vpr_smr.eval.report.experiments import EXPERIMENTS

    return EXPERIMENTS.get(name).figures


CORE_TABLES = (
    Table("table1", "Table I: area over the PR curve at max recall", ("table1",),
          row=rows.Table1Row, make=make.make_table1, markdown=make.table1_md, latex=make.table1_tex,
          page=("method", names.RECALL_SINGLE, names.RECALL_SEQUENCE, "max_recall", names.REDUCTION)),
    Table("predictor_methods", "Predictor alone: macro F1, class counts and predicted counts per method",
          ("table1",),
          row=rows.PredictorMethodRow, make=make.make_predictor_methods,
          page=("method", "n_queries", "f1_macro", "class_0", "class_1", "class_2", "class_3"),
          caption="Per method, {split} split, L = {seq_len}: macro F1 and the true classes' counts (the predicted "
                  "counts: the whole table below)"),
    Table("predictor_confusion", "Predictor alone: confusion matrix (rows true class, columns predicted)",
          ("table1",), row=rows.ConfusionRow, make=make.make_confusion),
    # the tool's own experiments' tables (pipeline.experiments), each at its place in the report's order
    *own_tables("trust_levels"),
    *own_tables("restoration"),
    Table("timing", "Inference time per query: attributes + prediction", ("table1",),
          row=rows.TimingRow, make=make.make_timing,
          page=("method", "seq_len", "n_queries", "ms_per_query", "ms_attributes_per_query", "ms_predict_per_query")),
    Table("vpr_metrics", "Standard VPR metrics: recall@N, recall at 100 % precision, PR AUC and extended precision "
          "of single-frame matching, sequence matching and sequence matching with the predictor", ("metrics",),
          row=rows.VPRMetricsRow, make=make.make_vpr_metrics,
          page=("method", "matcher", "n_queries", *(f"recall_at_{n}" for n in RECALL_AT), "recall_at_100p",
                "pr_auc", "extended_precision")),
    Table("baselines", "Training-free baselines: AOC at max recall of each scorer removing as many matches as the "
          "predictor (method §12), per dataset, method, L and mode", ("baselines",),
          row=rows.BaselineRow, make=make.make_baselines,
          caption="AOC reduction (%) of each scorer (rows) per method (columns) at the seed-0 predictor's budget; "
                  "random: mean ± sample standard deviation over the seeds"),
    Table("wrong_match_detection", "Detecting wrong matches: average precision and ROC AUC of each scorer against "
          "the wrong sequence matches (method §12), per dataset, method and L", ("baselines",),
          row=rows.DetectionRow, make=make.make_detection,
          caption="Average precision of detecting the wrong sequence matches (rows: scorers, columns: methods); "
                  "random: mean over its seeds; the last row: the fraction of wrong matches, a random ranking's "
                  "expected average precision"),
    Table("ablation_seq_len", "Sequence-length ablation: Table I columns per dataset, method and sequence length",
          ("table1", "seq_len"),
          row=rows.SeqLenRow, make=make.make_seq_len,
          pivot=Pivot("seq_len", ("method",), (names.REDUCTION,)),
          caption="AOC reduction (%) per sequence length (columns: methods)"),
    *own_tables("speed"),
    Table("predictor", PREDICTOR_TITLE.format(splits="validation, test"), ("predictor",),
          row=rows.PredictorRow, make=make.make_predictor, run_title=_predictor_title,
          page=("seq_len", "n_train", "f1_cv", "f1_{evaluation}", "n_{evaluation}", "warning"),
          caption="The pooled predictor (seed 0) per sequence length"),
    Table("table2", "Table II: macro F1 by attribute", ("attributes",),
          row=rows.Table2Row, make=make.make_table2, markdown=make.table2_md, latex=make.table2_tex,
          page=make.TABLE2_PAGE),
    Table("leave_one_method_out", "Leave one method out: pooled predictor against one trained without the method",
          ("leave_one_method_out",),
          row=rows.HeldOutRow, make=make.make_lomo,
          page=("held_out", "seq_len", "mode", "f1_pooled", "f1_without", "removed_pooled", "removed_without",
                names.AOC_VPR_SM, "aoc_pooled", "aoc_without", "reduction_pct_pooled", "reduction_pct_without")),
    *own_tables("protocol_sweep"),
)

TABLES_PACKAGE = "vpr_smr.eval.report.tables"  # each of its modules declares one table (its ``TABLE``)


def declared(package: str = TABLES_PACKAGE) -> tuple[Table, ...]:
    """The tables the modules of ``package`` declare, each its ``TABLE``, in the modules' names' order."""
    found = importlib.import_module(package)
    out = []
    for info in sorted(pkgutil.iter_modules(found.__path__), key=lambda info: info.name):
        module = importlib.import_module(f"{package}.{info.name}")
        entry = getattr(module, "TABLE", None)
        if not isinstance(entry, Table):
            raise TypeError(f"{module.__file__} declares no TABLE (a registry.Table): each module of {package} is "
                            "one table of the report")
        out.append(entry)
    return tuple(out)


def _once(kind: str, entries: tuple[_Named, ...]) -> tuple[_Named, ...]:
    """``entries`` (tables or figures), each name once: a second of a name would overwrite the first one's files."""
    named = [entry.name for entry in entries]
    twice = sorted({name for name in named if named.count(name) > 1})
    if twice:
        raise ValueError(f"{kind}s declared twice: {', '.join(twice)} (the report's own {kind}s, the modules of "
                         f"eval/report/tables/ and the experiments name each {kind} once)")
    return entries


def collected(*tables: Table) -> tuple[Table, ...]:
    """``tables``, each name once."""
    return _once("table", tables)


def plugin_tables() -> tuple[Table, ...]:
    """The tables of the experiments installed packages register (``eval.report.experiments``), each experiment's in
    its declaration's order, the experiments by name."""
    from vpr_smr.eval.report.experiments import installed  # its plugins import this module (its ``Table``)

    return tuple(entry for experiment in installed() for entry in experiment.tables)


TABLES = collected(*CORE_TABLES, *declared(), *plugin_tables())


def plugin_figures() -> tuple[Figure, ...]:
    """The figures of the experiments installed packages register, as ``plugin_tables``."""
    from vpr_smr.eval.report.experiments import installed

    return tuple(entry for experiment in installed() for entry in experiment.figures)


def collected_figures(*figures: Figure) -> tuple[Figure, ...]:
    """``figures``, each name once."""
    return _once("figure", figures)


# the report's figures, in its order: the core ones here, the tool's own experiments' from their modules
# (pipeline.experiments), each at its place, then the installed experiments'
FIGURES = collected_figures(
    Figure("pr", "PR curves", ("table1",), "pr_{dataset}_L{seq_len}_{mode}.png"),
    *own_figures("trust_levels"),
    *own_figures("restoration"),
    Figure("confusion", "Confusion matrix", ("table1",), "confusion_{dataset}_L{seq_len}.png"),
    Figure("seq_len", "Sequence-length ablation", ("table1", "seq_len"), "seq_len_{dataset}_{mode}.png"),
    *own_figures("adaptive_seq_len"),
    Figure("baselines", "Training-free baselines", ("baselines",), "baselines_{dataset}_L{seq_len}_{mode}.png"),
    Figure("detection", "Detecting wrong matches", ("baselines",), "detection_{dataset}_L{seq_len}.png"),
    *own_figures("matchers"),
    *own_figures("deployment"),
    *own_figures("speed"),
    *own_figures("protocol_sweep"),
    *plugin_figures(),
)


def table(name: str) -> Table:
    """The registered table ``name``; a KeyError for a table the registry does not declare."""
    for entry in TABLES:
        if entry.name == name:
            return entry
    raise KeyError(f"table {name!r} is not in eval/report/registry.py CORE_TABLES nor declared by a module of "
                   "eval/report/tables/")


def figure(name: str) -> Figure:
    """The registered figure ``name``; a KeyError for a figure the registry does not declare."""
    for entry in FIGURES:
        if entry.name == name:
            return entry
    raise KeyError(f"figure {name!r} is not in eval/report/registry.py FIGURES nor declared by an experiment")


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
    timing, PR and confusion figures), ``"predictor"`` (predictor reports given), ``"trust_levels"`` (trust
    levels configured), ``"restoration"``, ``"seq_len"`` (the sequence-length ablation), ``"attributes"`` (Table II),
    ``"leave_one_method_out"``, ``"metrics"`` (the standard VPR metrics given), ``"datasets"`` (dataset cards
    given), ``"baselines"`` (the training-free baselines given), ``"speed"`` (the speed experiment, at
    ``table_seq_lens``, for ``speed_datasets``: default every dataset; those with positions have none),
    ``"protocol_sweep"`` (the protocol sweep, for ``sweep_datasets``: default every dataset; those whose ground truth
    is a file have none), ``"adaptive_seq_len"`` (the experiment's files given); each table and figure of
    ``registry`` is listed when all of its experiments are.
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
