"""Tables and figures of every experiment, from the stages' JSON files, and the HTML report (method §10).

Each experiment is optional: a table or figure is written only when its inputs are given. ``expected_outputs``
lists, from the configuration alone, the files ``main`` writes, so that a workflow can declare them.
"""

from __future__ import annotations

import csv
import json
import re
from collections.abc import Callable, Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Protocol, TypeVar

import numpy as np

from vpr_smr.core.io import atomic_path, package_version
from vpr_smr.core.paths import match_figure_path, matrix_figure_path, timing_path
from vpr_smr.core.records import FormatError
from vpr_smr.eval.predictor.records import AttributeAblation, PredictorReport
from vpr_smr.eval.report import bounds, experiments, registry
from vpr_smr.eval.report import figures as fig
from vpr_smr.eval.report.baselines import baseline_rows, comparisons
from vpr_smr.eval.report.job import ReportJob, RunFiles
from vpr_smr.eval.report.results import (
    Order,
    Splits,
    WrittenFigure,
    WrittenTable,
    ground_truth_text,
    provenance_text,
    unique,
)
from vpr_smr.eval.report.rows import SeqLenRow, cells
from vpr_smr.eval.report.table1 import UNDEFINED, evaluation_order, is_reduction, tex_escape
from vpr_smr.eval.report.tabulate import Inputs, by_key, seq_len_rows
from vpr_smr.eval.scoring.adaptive_records import AdaptiveResult, AdaptiveTiming
from vpr_smr.eval.scoring.deployment_records import DeploymentResult
from vpr_smr.eval.scoring.matcher_comparison import MatcherComparison
from vpr_smr.eval.scoring.records import (
    KEY_META,
    Baselines,
    Evaluation,
    HeldOut,
    ModeRemoval,
    Timing,
    VPRMetrics,
)
from vpr_smr.eval.scoring.speed import SpeedResult

# Every table's columns, in its files' order, and how its rows are made: registry.TABLES

# --- writing ----------------------------------------------------------------------------------------------------


def _cell(value: Any, column: str = "") -> str:
    if value is None:
        return UNDEFINED if is_reduction(column) else ""
    if isinstance(value, float):
        return f"{value:.4f}"
    return str(value)


def _shown(columns: Sequence[str]) -> list[str]:
    """The Markdown and LaTeX columns: a number's interval bounds (``bounds``) go into its cell, and the bounds of
    an interval without its number (a paired difference) into one column ``<name>_ci``."""
    out: list[str] = []
    for column in columns:
        name = bounds.base(column)
        if not bounds.is_bound(column):
            out.append(column)
        elif name not in columns and f"{name}_ci" not in out:
            out.append(f"{name}_ci")
    return out


def _text(row: dict[str, Any], column: str, columns: Sequence[str]) -> str:
    """A Markdown or LaTeX cell: the number with its interval ``78.2000 [70.1000, 85.0000]`` where the table has its
    bounds, the interval alone in a ``<name>_ci`` column; ``[n/a]`` without one."""
    if column.endswith("_ci") and column not in columns:
        return bounds.bracket(bounds.of(row, column.removesuffix("_ci")), ".4f")
    text = _cell(row.get(column), column)
    if bounds.columns(column)[0] in columns and row.get(column) is not None:
        text += " " + bounds.bracket(bounds.of(row, column), ".4f")
    return text


def markdown_table(columns: Sequence[str], rows: Iterable[dict[str, Any]], title: str = "") -> str:
    shown = _shown(columns)
    out = [f"# {title}", ""] if title else []
    out += ["| " + " | ".join(shown) + " |", "|" + "---|" * len(shown)]
    out += ["| " + " | ".join(_text(row, c, columns) for c in shown) + " |" for row in rows]
    return "\n".join(out) + "\n"


def latex_table(columns: Sequence[str], rows: Iterable[dict[str, Any]], title: str = "") -> str:
    shown = _shown(columns)
    out = [f"% {title}"] if title else []
    out += [r"\begin{tabular}{" + "l" * len(shown) + "}", " & ".join(tex_escape(c) for c in shown) + r"\\",
            r"\hline"]
    out += [" & ".join(tex_escape(_text(row, c, columns)) for c in shown) + r"\\" for row in rows]
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


def overlap_notes(datasets: dict[str, dict[str, Any]] | None, order: Order | None = None) -> dict[str, str]:
    """Per dataset whose splits share frames (``allow_split_overlap``), the sentence every table carries, in the
    configuration's ``order`` (default: as given)."""
    order = order or Order(tuple(datasets or {}))
    return {name: "splits share frames (allow_split_overlap: true): " + "; ".join(info["overlaps"])
            for name, info in sorted((datasets or {}).items(), key=lambda item: order.dataset(item[0]))
            if info.get("overlaps")}


def _flagged(text: str, notes: dict[str, str], latex: bool = False) -> str:
    """The table's text with a warning under its title line for every dataset whose splits overlap."""
    if not notes:
        return text
    if latex:
        lines = [f"\\noindent\\textbf{{Warning, {tex_escape(d)}:}} {tex_escape(n)}\\par" for d, n in notes.items()]
        return "\n".join(lines) + "\n" + text
    title, _, rest = text.partition("\n")
    lines = [f"**Warning, {d}: {n}**" for d, n in notes.items()]
    return f"{title}\n\n" + "\n".join(lines) + "\n" + rest


def protocol_line(rows: Iterable[dict[str, Any]], protocols: Mapping[str, str]) -> str:
    """``Correct matches: d within 2 frames``: the ground truth of each dataset of ``rows`` (``protocols``: dataset ->
    ``GroundTruth.describe``'s text), in the rows' order; empty when none is known."""
    named = unique(str(row["dataset"]) for row in rows if "dataset" in row)
    parts = [f"{name} {protocols[name]}" for name in named if protocols.get(name)]
    return "Correct matches: " + "; ".join(parts) if parts else ""


def _with_protocol(text: str, line: str, latex: bool = False) -> str:
    """The table's text with ``line`` (``protocol_line``) under its title line."""
    if not line:
        return text
    title, _, rest = text.partition("\n")
    return f"{title}\n% {line}\n{rest}" if latex else f"{title}\n\n{line}\n{rest}"


def _write_table(stem: Path, columns: Sequence[str], rows: list[dict[str, Any]], title: str,
                 suffixes: Sequence[str] = (".csv", ".md", ".tex"), markdown: str | None = None,
                 latex: str | None = None, notes: dict[str, str] | None = None,
                 protocols: Mapping[str, str] | None = None) -> list[Path]:
    """``<stem>.csv`` (full precision), ``.md`` and ``.tex`` (4 decimals, or the given special layouts): those of
    ``suffixes``, in that order.

    ``notes``: per dataset whose splits overlap, a warning under the title and a ``split_overlap`` CSV column
    (``registry.SPLIT_OVERLAP``). ``protocols``: per dataset the ground truth the numbers were scored with, a line
    under the title of the Markdown and LaTeX files (``protocol_line``) and a ``correct_matches`` CSV column
    (``registry.CORRECT_MATCHES``, each row its dataset's): a CSV has no place for a line that every reader skips.
    """
    notes, protocols = notes or {}, protocols or {}
    protocol = protocol_line(rows, protocols)
    markdown = _flagged(_with_protocol(markdown if markdown is not None else markdown_table(columns, rows, title),
                                       protocol), notes)
    latex = _flagged(_with_protocol(latex if latex is not None else latex_table(columns, rows, title), protocol,
                                    latex=True), notes, latex=True)
    if notes:
        overlap = registry.SPLIT_OVERLAP.name
        columns = [*columns, overlap]
        rows = [{**row, overlap: notes.get(row.get("dataset", ""), "")} for row in rows]
    if protocol:
        correct = registry.CORRECT_MATCHES.name
        columns = [*columns, correct]
        rows = [{**row, correct: protocols.get(str(row.get("dataset", "")), "")} for row in rows]
    texts = {".md": markdown, ".tex": latex}
    return [_write_csv(stem.with_suffix(suffix), columns, rows) if suffix == ".csv"
            else _write_text(stem.with_suffix(suffix), texts[suffix]) for suffix in suffixes]


def _flat_mode(numbers: ModeRemoval) -> dict[str, Any]:
    """One mode's numbers as JSON, the reduction's and the curves' entries beside recall@1 and the trust levels
    (what a figure's panel reads)."""
    data = numbers.to_json()
    return {**{key: value for key, value in data.items() if key not in ("reduction", "curves")},
            **data["reduction"], **data.get("curves", {})}


def _figure_panels(items: list[Evaluation], split: str, mode: str, restoration: bool = False
                   ) -> list[tuple[str, dict[str, Any]]]:
    """(method, the numbers of one mode as written) per evaluation; with ``restoration``, restoration's numbers
    with the baseline and removal curves, which an evaluation keeps once, under the mode's removal curves."""
    panels = []
    for evaluation in items:
        result = evaluation.splits[split]
        numbers = result.modes[mode]
        if not restoration:
            panels.append((evaluation.method, {**_flat_mode(numbers), "n_queries": result.n_queries,
                                                       "removed": result.removed}))
            continue
        if result.restoration is None or numbers.curves is None:
            raise ValueError(f"{evaluation.key}: no restoration or no removal curves in split {split!r}")
        restored = replace(result.restoration.modes[mode], curve_vpr_sm=numbers.curves.curve_vpr_sm,
                           curve_removal=numbers.curves.curve_vpr_sm_pred)
        panels.append((evaluation.method, restored.to_json()))
    return panels


def protocols(datasets: Mapping[str, dict[str, Any]] | None, metrics: Sequence[VPRMetrics]) -> dict[str, str]:
    """Per dataset the ground truth its numbers were scored with, as the tables and figures say it: from its card
    (``results.ground_truth_text``), else from what its VPR metrics recorded (``GroundTruth.provenance``)."""
    out = {name: ground_truth_text(info) for name, info in (datasets or {}).items()}
    for record in metrics:
        recorded = record.meta.get("ground_truth")
        if record.key[0] not in out and isinstance(recorded, dict):
            out[record.key[0]] = provenance_text(recorded)
    return out


def _tables(out_dir: Path, inputs: Inputs, notes: dict[str, str]) -> list[WrittenTable]:
    """Each registered table whose ``make`` gives rows for this run, written in the registry's order with its
    columns, title and files."""
    written = []
    for spec in registry.TABLES:
        made = spec.make(inputs)
        if made is None:  # the run has not what the table is of
            continue
        if any(not isinstance(row, spec.row) for row in made):
            raise TypeError(f"table {spec.name!r}: its rows are {spec.row.__name__} records")
        rows = [cells(row) for row in made]
        columns = spec.expanded(inputs.splits)  # a column per split where the registry says so
        title = spec.run_title(inputs) if spec.run_title is not None else spec.title
        files = _write_table(out_dir / registry.TABLES_DIR / spec.name, [c.name for c in columns], rows, title,
                             spec.suffixes, notes=notes, protocols=inputs.protocols if spec.protocol else {},
                             markdown=spec.markdown(made, inputs) if spec.markdown is not None else None,
                             latex=spec.latex(made, inputs) if spec.latex is not None else None)
        written.append(WrittenTable(spec.name, columns, tuple(made), tuple(files),
                                    None if title == spec.title else title))
    return written


def _figures(out_dir: Path, inputs: Inputs) -> list[WrittenFigure]:
    split, order = inputs.split, inputs.order
    figures: list[WrittenFigure] = []

    def file(name: str, **names: Any) -> Path:
        """The file of the registered figure ``name`` (only a declared figure is written)."""
        return out_dir / registry.figure(name).file(**names)

    def keep(name: str, caption: str, path: Path, dataset: str, seq_len: int, mode: str | None = None) -> None:
        figures.append(WrittenFigure(name, f"{registry.figure(name).title}: {caption}", path, dataset, seq_len, mode))

    for (dataset, seq_len), items in by_key(inputs.evaluations, order).items():
        if inputs.table_seq_lens is not None and seq_len not in inputs.table_seq_lens:
            continue
        result0 = items[0].splits[split]
        for mode in sorted(result0.modes, key=order.mode):
            title = f"{dataset}, L={seq_len}, {mode} mode ({split}{inputs.correct(dataset)})"
            names = {"dataset": dataset, "seq_len": seq_len, "mode": mode}
            panels = _figure_panels(items, split, mode)
            keep("pr", title, fig.pr_figure(file("pr", **names), panels, title), dataset, seq_len, mode)
            if result0.modes[mode].trust is not None:
                path = fig.trust_figure(file("trust", **names), panels, f"{title}: predictor trust levels")
                keep("trust", title, path, dataset, seq_len, mode)
            if result0.restoration is not None:
                restored = _figure_panels(items, split, mode, restoration=True)
                path = fig.restoration_figure(file("restoration", **names), restored,
                                              f"{title}: match removal and restoration")
                keep("restoration", title, path, dataset, seq_len, mode)
                path = fig.difference_bars(file("restoration_auc", **names), [m for m, _ in restored],
                                           [n["auc_difference"] for _, n in restored],
                                           f"{title}: restoration - removal", "PR AUC, restoration - removal")
                keep("restoration_auc", title, path, dataset, seq_len, mode)
        matrix = np.sum([np.array(e.splits[split].confusion_matrix) for e in items], axis=0)
        path = fig.confusion_figure(file("confusion", dataset=dataset, seq_len=seq_len), matrix,
                                    f"{dataset}, L={seq_len}: all methods ({split}{inputs.correct(dataset)})")
        keep("confusion", f"{dataset}, L={seq_len}", path, dataset, seq_len)
    if inputs.seq_len_ablation and inputs.evaluations:  # the best training-free scorer's PR AUC marked beside
        figures += _seq_len_figures(out_dir, seq_len_rows(inputs), order, inputs)
    if inputs.baselines:
        figures += _baseline_figures(out_dir, inputs)
    for spec in registry.FIGURES:  # the experiments' figures, each drawn by its experiment's module (``draw``)
        if spec.draw is not None:
            figures += spec.draw(spec, out_dir, inputs)
    return figures


def _baseline_figures(out_dir: Path, inputs: Inputs) -> list[WrittenFigure]:
    """Per dataset and table L: per mode, each scorer's reduction at the predictor's budget per method
    (``baselines``); and the precision-recall curves of detecting wrong matches, a panel per method
    (``detection``)."""
    split, order = inputs.split, inputs.order
    out = []
    rows = baseline_rows(inputs.baselines, split, inputs.table_seq_lens, order)
    spec = registry.figure("baselines")
    for comparison in comparisons(rows):
        shown = [r for r in rows if (r.dataset, r.mode, r.seq_len) ==
                 (comparison.dataset, comparison.mode, comparison.seq_len)]
        title = (f"{comparison.dataset}, L={comparison.seq_len}, {comparison.mode} mode ({split}): AOC reduction at "
                 "the seed-0 predictor's budget")
        path = fig.baselines_figure(out_dir / spec.file(dataset=comparison.dataset, seq_len=comparison.seq_len,
                                                        mode=comparison.mode), shown, comparison, title)
        out.append(WrittenFigure("baselines", f"{spec.title}: {comparison.dataset}, L={comparison.seq_len}, "
                                 f"{comparison.mode} mode", path, comparison.dataset, comparison.seq_len,
                                 comparison.mode))
    spec = registry.figure("detection")
    groups: dict[tuple[str, int], list[Baselines]] = {}
    for record in inputs.baselines:
        dataset, _, seq_len = record.key
        if inputs.table_seq_lens is None or seq_len in inputs.table_seq_lens:
            groups.setdefault((dataset, seq_len), []).append(record)
    for (dataset, seq_len), records in sorted(groups.items(), key=lambda item: (order.dataset(item[0][0]),
                                                                                item[0][1])):
        records = sorted(records, key=lambda r: order.method(r.key[1]))
        title = f"{dataset}, L={seq_len} ({split}): detecting wrong sequence matches"
        path = fig.detection_figure(out_dir / spec.file(dataset=dataset, seq_len=seq_len),
                                    [(r.key[1], r.splits[split]) for r in records], title)
        out.append(WrittenFigure("detection", f"{spec.title}: {dataset}, L={seq_len}", path, dataset, seq_len))
    return out


def _seq_len_figures(out_dir: Path, rows: Sequence[SeqLenRow], order: Order, inputs: Inputs) -> list[WrittenFigure]:
    out = []
    groups: dict[tuple[str, str], list[SeqLenRow]] = {}
    for row in rows:
        groups.setdefault((row.dataset, row.mode), []).append(row)
    for (dataset, mode), group in sorted(groups.items(), key=lambda item: (order.dataset(item[0][0]),
                                                                           order.mode(item[0][1]))):
        methods = order.sorted_methods(r.method for r in group)
        seq_lens = sorted({r.seq_len for r in group})
        bottoms = np.full((len(methods), len(seq_lens)), np.nan)
        tops = np.full_like(bottoms, np.nan)
        best = np.full_like(bottoms, np.nan)
        for r in group:
            i, j = methods.index(r.method), seq_lens.index(r.seq_len)
            bottoms[i, j], tops[i, j] = r.auc_vpr_sm, r.auc_vpr_sm_pred
            if r.best_scorer_auc is not None:
                best[i, j] = r.best_scorer_auc
        title = f"{dataset}, {mode} mode{inputs.correct(dataset)}\nPR AUC, VPR+SM (bar bottom) -> VPR+SM+Pred (top)"
        spec = registry.figure("seq_len")
        path = fig.change_bars(out_dir / spec.file(dataset=dataset, mode=mode), methods, [f"L{s}" for s in seq_lens],
                               np.nan_to_num(bottoms), np.nan_to_num(tops), title,
                               markers=best if not np.isnan(best).all() else None,
                               marker_label="best training-free scorer, same budget (compare with the bar top)")
        out.append(WrittenFigure("seq_len", f"{spec.title}: {dataset}, {mode} mode", path, dataset, mode=mode))
    return out


INSPECTOR = {  # the match inspector's figures: name, file name (core.paths) and caption
    "matches": (match_figure_path, "the {split} split's sampled queries (a few per true class and the predictor's "
                "most confident mistakes): the L query frames, the single-frame match, the sequence match and the "
                "true reference, framed green (correct) or red (wrong), and what the predictor decided"),
    "distance_matrix": (matrix_figure_path, "the {split} split's distance matrix with the ground-truth band and "
                        "every sequence match, kept or removed by the predictor"),
}


def inspector_figures(paths: dict[str, Sequence[Path | str]], keys: Iterable[tuple[str, str, int]],
                      datasets: Iterable[str], split: str, order: Order | None = None) -> list[WrittenFigure]:
    """The match inspector's figures (``paths``: ``matches`` and ``distance_matrix`` files), each placed by its
    file name (``core.paths``): against the (dataset, method, L) ``keys`` of the run, else split at a known
    dataset name. In the configuration's order, the match figure of a method before its matrix."""
    order = order or Order()
    known = list(dict.fromkeys(keys))
    out = []
    for name, (path_of, caption) in INSPECTOR.items():
        by_file = {Path(path_of("", *key)).name: key for key in known}
        prefix = Path(path_of("", "{d}", "{m}", "{L}")).name.split("{d}")[0]
        for path in paths.get(name, ()):
            path = Path(path)
            if not path.is_file():
                raise FileNotFoundError(f"match inspector figure not found: {path}")
            key = by_file.get(path.name) or _split_name(path.name, prefix, datasets)
            if key is None:
                raise ValueError(f"{path.name} names no dataset, method and L of the run (expected "
                                 f"{Path(path_of('', 'DATASET', 'METHOD', 'L')).name})")
            dataset, method, seq_len = key
            text = caption.format(split=split)
            out.append(WrittenFigure(name, f"{method} on {dataset}, L={seq_len}: {text}", path, dataset, seq_len,
                                     method=method))
    return sorted(out, key=lambda f: (order.dataset(f.dataset), order.method(f.method or ""), f.seq_len or 0,
                                      list(INSPECTOR).index(f.name)))


def _split_name(name: str, prefix: str, datasets: Iterable[str]) -> tuple[str, str, int] | None:
    """(dataset, method, L) of ``<prefix><dataset>_<method>_L<L>.png`` for one of the ``datasets``."""
    match = re.fullmatch(re.escape(prefix) + r"(.+)_L(\d+)\.png", name)
    if match is None:
        return None
    for dataset in sorted(datasets, key=len, reverse=True):  # the longest name first: "a_b" before "a"
        if match.group(1).startswith(f"{dataset}_"):
            return dataset, match.group(1)[len(dataset) + 1:], int(match.group(2))
    return None


class _Record(Protocol):
    @property
    def meta(self) -> dict[str, Any]: ...


Record = TypeVar("Record", bound=_Record)

# What each kind of input needs in its meta (the tables' keys), and how a user's file gets it.
PREDICTOR_META = ("dataset", "seq_len")
ADAPTIVE_META = ("dataset", "method", "tag")  # the experiment adaptive_seq_len's keys: one file per each
METRICS_HINT = "rerun vpr-smr metrics with --dataset and --method (the run's names), as the workflow does"


def _article(what: str) -> str:
    return f"an {what}" if what[:1].lower() in "aeiou" else f"a {what}"


def _reason(error: Exception) -> str:
    """What is wrong with a file's content, in words (a KeyError's text is only the key)."""
    if isinstance(error, KeyError):  # most often a file an earlier version wrote, before the entry existed
        return (f"it has no {error.args[0]!r} entry (written by an earlier vpr-smr? `vpr-smr run` computes it again "
                "with this version; a stage's file, its command)")
    return str(error) or type(error).__name__


def _load(paths: Sequence[Path | str], what: str) -> list[tuple[Path, dict[str, Any]]]:
    """Each file of ``paths`` with its JSON object; a missing file, or one that is not a JSON object, raises
    naming it and ``what`` it should be."""
    out = []
    for path in map(Path, paths):
        if not path.is_file():
            raise FileNotFoundError(f"{what} file not found: {path}")
        try:
            data = json.loads(path.read_text())
        except (UnicodeDecodeError, json.JSONDecodeError) as error:
            raise ValueError(f"{path}: not {_article(what)} file: {error}") from None
        if not isinstance(data, dict):
            raise ValueError(f"{path}: not {_article(what)} file: it holds a JSON {type(data).__name__}, not an "
                             "object")
        out.append((path, data))
    return out


def _read(paths: Sequence[Path | str], what: str, from_json: Callable[[dict[str, Any]], Record],
          meta: Sequence[str] = (), hint: str = "") -> list[Record]:
    """The records of the files ``paths`` (``what``: the kind of file, for the error), each with the ``meta``
    entries the tables need (``hint``: how to make a file that has them)."""
    out = []
    for path, data in _load(paths, what):
        try:
            record = from_json(data)
        except FormatError as error:  # of another vpr-smr: say which format and to compute it again
            raise FormatError(f"{path}: {_article(what)} file {error}") from None
        except (KeyError, TypeError, ValueError, AttributeError, IndexError) as error:
            raise ValueError(f"{path}: not {_article(what)} file: {_reason(error)}") from None
        missing = [key for key in meta if key not in record.meta]
        if missing:
            raise ValueError(f"{path}: {_article(what)} file without {', '.join(missing)} in its meta, which the "
                             f"report needs" + (f": {hint}" if hint else ""))
        out.append(record)
    return out


@dataclass(frozen=True)
class ReportOptions:
    """How the report shows the run: the configuration's choices.

    ``split``, ``eval_splits``, ``train_split``: the configuration's table_split, eval_splits and train_split, which
    the tables show and name (``results.Splits.resolve``; default: the one split every evaluation holds, the
    splits of the inputs with it last, ``train``). ``table_seq_lens``: the sequence lengths of Table I and of the
    per-L figures (None: all); ``seq_len_ablation``: also the sequence-length table and figure over every L.
    Datasets and methods keep the order the evaluations come in (the workflow gives them in the configuration's
    order), or ``methods``' order when given. ``config`` (YAML text or a dict) and ``provenance`` (e.g. package
    version, checkpoint and frame-list hashes) go into the HTML page. ``datasets``: per dataset its card
    (``pipeline.plan.dataset_cards``: traverses, frames, tolerance, splits, pairing, ``overlaps``, the frame lists'
    SHA-256 and the images' source): the datasets table and the page's cards; overlaps flag every table.
    ``html``: also write ``report.html``.
    """

    split: str | None = None
    eval_splits: Sequence[str] | None = None
    train_split: str | None = None
    table_seq_lens: Collection[int] | None = None
    seq_len_ablation: bool = False
    methods: Sequence[str] = ()
    config: str | dict[str, Any] | None = None
    provenance: dict[str, Any] | None = None
    html: bool = True
    datasets: dict[str, dict[str, Any]] | None = None


def main(job: ReportJob) -> list[Path]:
    """The ``report`` stage: ``write`` of the job's files under ``job.out``, with this package's version as the
    page's provenance; return the files written."""
    datasets = job.datasets.to_dict()
    options = ReportOptions(split=job.split, eval_splits=job.eval_splits, train_split=job.train_split,
                            table_seq_lens=job.table_seq_lens, seq_len_ablation=job.seq_len_ablation,
                            config=job.settings.to_dict(), provenance={"vpr_smr_version": package_version()},
                            datasets=datasets)
    return write(job.out, job.files, options)


def write(out_dir: Path | str, files: RunFiles, options: ReportOptions | None = None) -> list[Path]:
    """Write ``tables/``, ``figures/`` and ``report.html`` under the run folder ``out_dir`` from the stages'
    ``files``, shown as ``options`` say (default: ``ReportOptions()``); return the files written."""
    from vpr_smr.eval.report import html as html_report

    out_dir, options = Path(out_dir), options or ReportOptions()
    split, datasets = options.split, options.datasets
    read_evaluations = _read(files.evaluations, "evaluation", Evaluation.from_json, KEY_META)
    read_metrics = _read(files.metrics, "VPR metrics", VPRMetrics.from_json, KEY_META, METRICS_HINT)
    read_predictors = _read(files.predictors, "predictor report", PredictorReport.from_json, PREDICTOR_META)
    read_lomo = _read(files.leave_one_out, "leave-one-method-out", HeldOut.from_json, KEY_META)
    read_speed = _read(files.speed, "speed experiment", SpeedResult.from_json, ("dataset", "seq_len", "profile"))
    read_baselines = _read(files.baselines, "baselines", Baselines.from_json, KEY_META)
    read_matchers = _read(files.matchers, "matchers experiment", MatcherComparison.from_json, KEY_META)
    read_adaptive = read_adaptive_files(files.adaptive)
    read_deployment = _read(files.deployment, "deployment experiment", DeploymentResult.from_json, KEY_META)

    splits = Splits.resolve(split, options.eval_splits, options.train_split,
                            [*(list(e.splits) for e in read_evaluations), *(list(m.splits) for m in read_metrics),
                             *(list(b.splits) for b in read_baselines)],
                            [name for report in read_predictors for name in report.seeds[0].splits])
    split = splits.table or ""  # none only without evaluations and metrics, which alone show a split
    base = evaluation_order(read_evaluations, options.methods)
    order = Order.of([*(e.meta for e in read_evaluations), *(m.meta for m in read_metrics),
                      *(b.meta for b in read_baselines),
                      *(h.meta for h in read_lomo), *(p.meta for p in read_predictors),
                      *({"dataset": name} for name in datasets or {}),
                      # a speed file lists its methods in the configuration's order, under each matcher
                      *({"dataset": r.meta["dataset"], "method": method} for r in read_speed
                        for matcher in r.matchers.values() for method in matcher.methods),
                      *(result.meta for result, _ in read_adaptive)],
                     base.modes, base.methods)
    inputs = Inputs(
        read_evaluations, _read(files.timings, "timing", Timing.from_json, KEY_META), read_predictors,
        _read(files.attribute_ablations, "attribute ablation", AttributeAblation.from_json, PREDICTOR_META), read_lomo,
        read_metrics, dict(datasets or {}), split,
        None if options.table_seq_lens is None else {int(s) for s in options.table_seq_lens},
        options.seq_len_ablation, order, read_speed, splits, protocols(datasets, read_metrics), read_baselines,
        read_matchers, read_adaptive, experiment_files(out_dir, options.config), deployment=read_deployment)
    tables = _tables(out_dir, inputs, overlap_notes(datasets, order))
    figures = _figures(out_dir, inputs)
    written = [path for table in tables for path in table.files] + [figure.path for figure in figures]
    if options.html:
        keys = [*(e.key for e in read_evaluations), *(m.key for m in read_metrics)]
        inspected = inspector_figures({"matches": files.match_figures, "distance_matrix": files.matrix_figures},
                                      keys, [*order.datasets], split, order)
        written.append(html_report.main(
            out_dir / registry.HTML, tables, [*figures, *inspected], order=order, split=split, config=options.config,
            provenance=options.provenance, descriptor_paths=files.descriptors, datasets=datasets, splits=splits,
            protocols=inputs.protocols, matchers=_matchers(read_evaluations)))
    return written


def experiment_files(out_dir: Path, config: str | dict[str, Any] | None) -> dict[str, Sequence[Path]]:
    """The files of the installed experiments the run's settings (``ReportOptions.config``) turn on, per experiment,
    where the workflow wrote them under the run folder ``out_dir`` (``eval.report.experiments.files``): their tables
    read them from ``Inputs.experiments``."""
    return experiments.files(out_dir, config if isinstance(config, dict) else None)


def read_adaptive_files(paths: Sequence[Path | str]) -> list[tuple[AdaptiveResult, AdaptiveTiming | None]]:
    """The experiment adaptive_seq_len's files, each with the live timing file beside it (None where there is none:
    its table leaves the live time empty); a second file of the same dataset, matcher and method, or a timing file
    of another one, raises naming the files."""
    results = _read(paths, "adaptive sequence length", AdaptiveResult.from_json, ADAPTIVE_META)
    out: list[tuple[AdaptiveResult, AdaptiveTiming | None]] = []
    seen: dict[tuple[str, ...], Path] = {}
    for path, result in zip(map(Path, paths), results, strict=True):
        key = tuple(str(result.meta[name]) for name in ADAPTIVE_META)
        if key in seen:
            raise ValueError(f"{path} and {seen[key]}: two adaptive sequence length files of the same "
                             f"{', '.join(f'{n} {v!r}' for n, v in zip(ADAPTIVE_META, key, strict=True))}: give "
                             "one file each")
        seen[key] = path
        beside = Path(timing_path(path))
        if not beside.is_file():
            out.append((result, None))
            continue
        timing = _read([beside], "adaptive live timing", AdaptiveTiming.from_json)[0]
        other = [name for name in ADAPTIVE_META if name in timing.meta and str(timing.meta[name]) != str(
            result.meta[name])]
        if other:
            raise ValueError(f"{beside}: the live timing of another {', '.join(other)} than {path} beside it "
                             f"({', '.join(f'{n} {timing.meta[n]!r}, not {result.meta[n]!r}' for n in other)}): "
                             "rerun vpr-smr adaptive to write both files again")
        out.append((result, timing))
    return out


def _matchers(evaluations: Sequence[Evaluation]) -> list[str]:
    """The sequence matchers (name and settings) the evaluations record, each once, in the order they come."""
    from vpr_smr.eval.matching.attributes import recorded_matcher

    found = [str(recorded_matcher(e.meta, f"the evaluation of {e.dataset}/{e.method}/L{e.seq_len}"))
             for e in evaluations]
    return list(dict.fromkeys(found))
