"""Each table's rows from the run's inputs (``Inputs``: the stages' records, read, and how the report shows them):
the ``make`` of the tables ``registry.TABLES`` declares, and Table I's and Table II's own Markdown and LaTeX layouts.

A ``make`` is a function of ``Inputs`` that returns the table's row records, or None when the run has not what the
table is of (the table is then not written; an empty list writes its header alone).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vpr_smr.core.constants import MATCHERS
from vpr_smr.eval.predictor.records import AttributeAblation, PredictorReport
from vpr_smr.eval.report.baselines import baseline_rows, detection_rows, with_best
from vpr_smr.eval.report.results import Order, Splits, split_word, unique
from vpr_smr.eval.report.rows import (
    Column,
    ConfusionRow,
    HeldOutRow,
    PredictorMethodRow,
    PredictorRow,
    RestorationRow,
    Row,
    SeqLenRow,
    SpeedRow,
    SweepRow,
    Table1Row,
    Table2Row,
    TimingRow,
    TrustRow,
    VPRMetricsRow,
    cells,
    columns,
)
from vpr_smr.eval.report.table1 import evaluation_order, table1_latex, table1_markdown, table1_rows, tex_escape
from vpr_smr.eval.scoring.adaptive_records import AdaptiveResult, AdaptiveTiming
from vpr_smr.eval.scoring.deployment_records import DeploymentResult
from vpr_smr.eval.scoring.matcher_comparison import MatcherComparison
from vpr_smr.eval.scoring.records import Baselines, Evaluation, HeldOut, Timing, VPRMetrics
from vpr_smr.eval.scoring.speed import MATCHERS as SPEED_MATCHERS
from vpr_smr.eval.scoring.speed import SpeedResult


@dataclass(frozen=True)
class Inputs:
    """The run's result files, read, and how the report is to show them."""

    evaluations: list[Evaluation]
    timings: list[Timing]
    predictors: list[PredictorReport]
    ablations: list[AttributeAblation]
    lomo: list[HeldOut]
    metrics: list[VPRMetrics]
    datasets: dict[str, dict[str, Any]]
    split: str
    table_seq_lens: Collection[int] | None
    seq_len_ablation: bool
    order: Order
    speed: list[SpeedResult]
    splits: Splits  # the configuration's split names by role (``split`` is their table split)
    protocols: dict[str, str]  # per dataset its ground truth as the tables say it ("within 2 frames")
    baselines: list[Baselines] = dataclasses.field(default_factory=list)
    matchers: list[MatcherComparison] = dataclasses.field(default_factory=list)  # the experiment matchers (§14)
    # the experiment adaptive_seq_len (§15): each result with the live timing file beside it (None without one)
    adaptive: list[tuple[AdaptiveResult, AdaptiveTiming | None]] = dataclasses.field(default_factory=list)
    # the experiments installed packages register (``eval.report.experiments``): per name its jobs' files
    experiments: Mapping[str, Sequence[Path]] = dataclasses.field(default_factory=dict)
    # the experiment deployment (§16): one result per dataset and method at the table's L
    deployment: list[DeploymentResult] = dataclasses.field(default_factory=list)

    def correct(self, dataset: str) -> str:
        """``; correct: within 2 frames``: what a figure's title adds of its dataset's ground truth (empty if none)."""
        text = self.protocols.get(dataset)
        return f"; correct: {text}" if text else ""


def seq_len_rows(inputs: Inputs) -> list[SeqLenRow]:
    """The sequence-length ablation: Table I's rows of every L, with the best training-free scorer of each."""
    best = baseline_rows(inputs.baselines, inputs.split, order=inputs.order) if inputs.baselines else []
    return with_best(table1_rows(inputs.evaluations, inputs.split, order=inputs.order), best)



ATTRIBUTE_ORDER = ("A1", "A2", "A3", "A4", "all")
# Table II's compact columns on the page (``registry``'s ``page``): the F1 columns, then the samples they are over,
# which the page says in a note
TABLE2_PAGE = ("f1_cv", "f1_{validation}", "f1_{last}", "f1_{last}_method_mean", "n_train", "n_{validation}",
               "n_{last}")

# --- Table II ---------------------------------------------------------------------------------------------------


def _table2_f1_columns(splits: Splits) -> list[Column]:
    """Table II's F1 columns (its page's columns but the samples, which its notes say) named by ``splits``."""
    declared = {column.name: column for column in columns(Table2Row)}
    return [one for name in TABLE2_PAGE for one in declared[name].expand(splits) if not one.note]


def table2_f1(splits: Splits) -> tuple[str, ...]:
    return tuple(column.name for column in _table2_f1_columns(splits))


def table2_splits(ablations: Sequence[AttributeAblation]) -> Splits:
    """The split names of Table II when none are given: the records' own, in the order first seen (the validation
    split first, the last evaluation split last)."""
    names = unique(name for ablation in ablations for numbers in ablation.attributes.values()
                   for name in numbers.splits)
    return Splits(names[-1] if names else None, names)


def table2_rows(ablations: Sequence[AttributeAblation], order: Order | None = None,
                splits: Splits | None = None) -> list[Table2Row]:
    """Table II's rows, the columns of the validation and the last evaluation split named by ``splits`` (default:
    the records' own names, ``table2_splits``)."""
    order = order or Order.of(ablation.meta for ablation in ablations)
    splits = splits or table2_splits(ablations)
    rows = [Table2Row.of(ablation, name, splits) for ablation in ablations for name in ATTRIBUTE_ORDER
            if name in ablation.attributes]
    return sorted(rows, key=lambda r: (order.dataset(r.dataset), int(r.seq_len), ATTRIBUTE_ORDER.index(r.attributes)))


def _marks(name: str, yes: str, no: str) -> list[str]:
    return [yes if name in (attribute, "all") else no for attribute in ATTRIBUTE_ORDER[:4]]


def _f1(value: Any) -> str:
    return "" if value is None else f"{value:.2f}"


def _sample_note(group: list[dict[str, Any]], splits: Splits) -> str:
    """The samples Table II's F1 is over: the pooled train split (cross-validation), the validation and the last
    evaluation split, each by its name."""
    first = group[0]
    named = [(splits.train, "n_train"), *((name, f"n_{name}") for name in unique(
        name for name in (splits.validation, splits.last) if name is not None))]
    parts = [f"{split_word(str(name))} {first[key]} samples" for name, key in named if first.get(key) is not None]
    return "F1 over " + ", ".join(parts) + " (every method pooled)" if parts else ""


def _table2_headings(splits: Splits, long: bool) -> list[str]:
    """Table II's F1 headings: cross-validation, the validation and the last split by name, the method mean; the
    declared labels (``long``, Markdown) or LaTeX's short ones."""
    if long:
        return [column.header for column in _table2_f1_columns(splits)]
    validation, table = splits.validation, tex_escape(str(splits.last))
    return ["F1 (CV)", *([f"F1 ({tex_escape(validation)})"] if validation is not None else []), f"F1 ({table})",
            f"F1 ({table}, method mean)"]


def table2_markdown(table2: Sequence[Table2Row], splits: Splits | None = None) -> str:
    splits, rows = splits or Splits("test", ("val", "test")), [cells(row) for row in table2]
    f1 = table2_f1(splits)
    out = ["# Table II: macro F1 of the predictor by attribute (A1 minimum sum rate, A2 minimum value rate, "
           "A3 block sum rate, A4 group sum rate)", ""]
    groups: dict[tuple[str, int], list[dict[str, Any]]] = {}
    for row in rows:
        groups.setdefault((row["dataset"], row["seq_len"]), []).append(row)
    for (dataset, seq_len), group in groups.items():
        note = _sample_note(group, splits)
        headings = ["A1", "A2", "A3", "A4", *_table2_headings(splits, long=True)]
        out += [f"## {dataset}, sequence length {seq_len}", ""] + ([note, ""] if note else []) + [
                "| " + " | ".join(headings) + " |", "|" + "---|" * len(headings)]
        for row in group:
            texts = _marks(row["attributes"], "✓", "×") + [_f1(row.get(k)) for k in f1]
            out.append("| " + " | ".join(texts) + " |")
        out.append("")
    return "\n".join(out)


def table2_latex(table2: Sequence[Table2Row], splits: Splits | None = None) -> str:
    splits, rows = splits or Splits("test", ("val", "test")), [cells(row) for row in table2]
    f1 = table2_f1(splits)
    out = []
    groups: dict[tuple[str, int], list[dict[str, Any]]] = {}
    for row in rows:
        groups.setdefault((row["dataset"], row["seq_len"]), []).append(row)
    for (dataset, seq_len), group in groups.items():
        headings = ["A1", "A2", "A3", "A4", *_table2_headings(splits, long=False)]
        out += [f"% {dataset}, sequence length {seq_len}", r"\begin{tabular}{" + "|".join("c" * len(headings)) + "}",
                " & ".join(headings) + r"\\", r"\hline"]
        for row in group:
            texts = _marks(row["attributes"], r"$\checkmark$", r"$\times$") + [_f1(row.get(k)) for k in f1]
            out.append(" & ".join(texts) + r"\\")
        note = _sample_note(group, splits)
        if note:
            out.append(rf"\multicolumn{{{len(headings)}}}{{l}}{{\footnotesize {tex_escape(note)}}}\\")
        out += [r"\end{tabular}", ""]
    return "\n".join(out)


# --- the other tables -----------------------------------------------------------------------------------------


def predictor_rows(predictors: Sequence[PredictorReport], order: Order | None = None,
                   splits: Splits | None = None) -> list[PredictorRow]:
    """The pooled predictors' numbers (``PredictorRow``'s columns) and warnings, judged on ``splits``'
    validation split (default: the reports' splits, in the order first seen, the first of them the validation
    split)."""
    order = order or Order.of(report.meta for report in predictors)
    seen = tuple(dict.fromkeys(name for report in predictors for name in report.seeds[0].splits))
    validation = splits.validation if splits is not None else next(iter(seen), None)
    evaluation = splits.evaluation if splits is not None else seen
    rows = [PredictorRow.of(report, evaluation, validation) for report in predictors]
    return sorted(rows, key=lambda r: (order.dataset(r.dataset), int(r.seq_len)))


def by_key(evaluations: Sequence[Evaluation], order: Order | None = None
            ) -> dict[tuple[str, int], list[Evaluation]]:
    """(dataset, L) -> evaluations, datasets and methods in the configuration's ``order`` (default: the
    evaluations' own)."""
    order = order or evaluation_order(evaluations)
    out: dict[tuple[str, int], list[Evaluation]] = {}
    for evaluation in evaluations:
        out.setdefault((evaluation.dataset, evaluation.seq_len), []).append(evaluation)
    return {key: sorted(out[key], key=lambda e: order.method(e.method))
            for key in sorted(out, key=lambda k: (order.dataset(k[0]), k[1]))}


def predictor_method_rows(evaluations: Sequence[Evaluation], split: str, order: Order | None = None
                          ) -> list[PredictorMethodRow]:
    return [PredictorMethodRow.of(dataset, seq_len, evaluation.method, split, evaluation.splits[split])
            for (dataset, seq_len), items in by_key(evaluations, order).items() for evaluation in items]


def confusion_rows(evaluations: Sequence[Evaluation], split: str, order: Order | None = None
                   ) -> list[ConfusionRow]:
    """The seed-0 confusion matrix per dataset, L and method, and summed over the methods (method ``all``)."""
    rows = []
    for (dataset, seq_len), items in by_key(evaluations, order).items():
        matrices = [(e.method, np.array(e.splits[split].confusion_matrix)) for e in items]
        matrices.append(("all", np.sum([m for _, m in matrices], axis=0)))
        for method, matrix in matrices:
            rows += [ConfusionRow.of(dataset, seq_len, method, true_class, counts)
                     for true_class, counts in enumerate(matrix)]
    return rows


def trust_rows(evaluations: Sequence[Evaluation], split: str, order: Order | None = None) -> list[TrustRow]:
    return [TrustRow.of(evaluation.key, mode, float(level), values, result.n_queries)
            for items in by_key(evaluations, order).values() for evaluation in items
            for result in (evaluation.splits[split],) for mode, numbers in result.modes.items()
            for level, values in (numbers.trust_auc or {}).items()]


def restoration_rows(evaluations: Sequence[Evaluation], split: str, order: Order | None = None
                     ) -> list[RestorationRow]:
    return [RestorationRow.of(evaluation.key, mode, result.restoration, result.n_queries)
            for items in by_key(evaluations, order).values() for evaluation in items
            for result in (evaluation.splits[split],) if result.restoration is not None
            for mode in result.restoration.modes]


def lomo_rows(results: Sequence[HeldOut], order: Order | None = None) -> list[HeldOutRow]:
    order = order or Order.of(result.meta for result in results)
    rows = [HeldOutRow.of(result.key, mode, result) for result in results for mode in result.pooled.modes]
    return sorted(rows, key=lambda r: (order.mode(r.mode), order.dataset(r.dataset), r.seq_len,
                                       order.method(r.held_out)))


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


def timing_rows(evaluations: Sequence[Evaluation], timings: Sequence[Timing], order: Order | None = None
                ) -> list[TimingRow]:
    """Per evaluation and split, its timing (matched by meta); evaluations whose timings are not given are left
    out."""
    matched = match_timings(evaluations, timings)
    return [TimingRow.of(dataset, evaluation.method, seq_len, split, timing.splits[split])
            for (dataset, seq_len), items in by_key(evaluations, order).items() for evaluation in items
            if (timing := matched.get(evaluation.key)) is not None for split in evaluation.splits]


def vpr_metrics_rows(records: Sequence[VPRMetrics], split: str, order: Order | None = None) -> list[VPRMetricsRow]:
    """The standard VPR metrics of the table ``split``: one row per dataset, method, L, mode and matcher (in the
    configuration's order, the matchers in ``core.constants.MATCHERS``' order)."""
    order = order or Order.of(record.meta for record in records)
    seen: set[tuple[str, str, int]] = set()
    rows = []
    for record in sorted(records, key=lambda r: (order.dataset(r.key[0]), order.method(r.key[1]), r.key[2])):
        dataset, method, seq_len = record.key
        if record.key in seen:
            raise ValueError(f"two VPR metrics files of {dataset}, {method}, L{seq_len}")
        seen.add(record.key)
        if split not in record.splits:
            raise ValueError(f"the VPR metrics of {dataset}, {method}, L{seq_len} have no split {split!r} (the "
                             f"table split); they have {', '.join(record.splits) or 'none'}")
        modes = record.splits[split].modes
        for mode in sorted(modes, key=order.mode):
            matchers = sorted(modes[mode], key=lambda m: (MATCHERS.index(m) if m in MATCHERS else len(MATCHERS), m))
            rows += [VPRMetricsRow.of(record.key, split, mode, matcher, modes[mode][matcher]) for matcher in matchers]
    return rows


def speed_rows(results: Sequence[SpeedResult], order: Order | None = None) -> list[SpeedRow]:
    """The speed experiment: one row per dataset, L, method, profile and matcher (fixed, then velocity search), the
    datasets and methods in the configuration's order and the profiles in the order given (the configuration's)."""
    order = order or Order.of(result.meta for result in results)
    profiles: dict[str, int] = {}
    seen: set[tuple[str, int, str]] = set()
    rows = []
    for result in results:
        dataset, seq_len, profile = str(result.meta["dataset"]), int(result.meta["seq_len"]), result.profile
        if (dataset, seq_len, profile) in seen:
            raise ValueError(f"two speed files of {dataset}, L{seq_len}, profile {profile}")
        seen.add((dataset, seq_len, profile))
        profiles.setdefault(profile, len(profiles))
        rows += [SpeedRow.of(result, matcher, numbers.velocities, method, scores)
                 for matcher, numbers in result.matchers.items() for method, scores in numbers.methods.items()]
    matchers = list(SPEED_MATCHERS)
    return sorted(rows, key=lambda r: (order.dataset(r.dataset), r.seq_len, order.method(r.method),
                                       profiles[r.profile], matchers.index(r.matcher)
                                       if r.matcher in matchers else len(matchers), r.matcher))


def sweep_rows(records: Sequence[VPRMetrics], split: str, order: Order | None = None) -> list[SweepRow]:
    """The protocol sweep of the table ``split`` (``records.ProtocolSweep``, in the VPR metrics of a run with the
    sweep): one row per dataset, method, L, mode and tolerance or radius, in the configuration's order."""
    order = order or Order.of(record.meta for record in records)
    rows = []
    for record in records:
        found = record.splits.get(split)
        if found is None or found.sweep is None:
            continue
        for mode, points in found.sweep.modes.items():
            # the evaluated queries: the sequence matcher's recall@1 denominator
            sequence = found.modes.get(mode, {}).get("sequence")
            rows += [SweepRow.of(record.key, split, mode, found.sweep.kind, point,
                                 None if sequence is None else sequence.n_queries) for point in points]
    return sorted(rows, key=lambda r: (order.dataset(r.dataset), r.seq_len, order.mode(r.mode),
                                       order.method(r.method), r.threshold))




# --- each table's make: its rows from the run's inputs, None when the run has not what it is of -------------------


def make_table1(inputs: Inputs) -> list[Table1Row] | None:
    if not inputs.evaluations:
        return None
    return table1_rows(inputs.evaluations, inputs.split, inputs.table_seq_lens, inputs.order)


def table1_md(rows: Sequence[Row], inputs: Inputs) -> str:
    return table1_markdown([row for row in rows if isinstance(row, Table1Row)], inputs.split)


def table1_tex(rows: Sequence[Row], inputs: Inputs) -> str:
    return table1_latex([row for row in rows if isinstance(row, Table1Row)], inputs.split)


def make_predictor_methods(inputs: Inputs) -> list[PredictorMethodRow] | None:
    if not inputs.evaluations:
        return None
    return predictor_method_rows(inputs.evaluations, inputs.split, inputs.order)


def make_confusion(inputs: Inputs) -> list[ConfusionRow] | None:
    if not inputs.evaluations:
        return None
    return confusion_rows(inputs.evaluations, inputs.split, inputs.order)


def make_trust(inputs: Inputs) -> list[TrustRow] | None:
    if not inputs.evaluations:
        return None
    return trust_rows(inputs.evaluations, inputs.split, inputs.order) or None


def make_restoration(inputs: Inputs) -> list[RestorationRow] | None:
    if not inputs.evaluations:
        return None
    return restoration_rows(inputs.evaluations, inputs.split, inputs.order) or None


def make_timing(inputs: Inputs) -> list[TimingRow] | None:
    # with evaluations always written: a run whose timings are not given has its header alone
    return timing_rows(inputs.evaluations, inputs.timings, inputs.order) if inputs.evaluations else None


def make_seq_len(inputs: Inputs) -> list[SeqLenRow] | None:
    # with the best training-free scorer of every L beside the predictor
    return seq_len_rows(inputs) if inputs.evaluations and inputs.seq_len_ablation else None


def make_baselines(inputs: Inputs) -> list[Any] | None:
    if not inputs.baselines:
        return None
    return baseline_rows(inputs.baselines, inputs.split, inputs.table_seq_lens, inputs.order)


def make_detection(inputs: Inputs) -> list[Any] | None:
    if not inputs.baselines:
        return None
    return detection_rows(inputs.baselines, inputs.split, inputs.table_seq_lens, inputs.order)


def make_vpr_metrics(inputs: Inputs) -> list[VPRMetricsRow] | None:
    return vpr_metrics_rows(inputs.metrics, inputs.split, inputs.order) if inputs.metrics else None


def make_predictor(inputs: Inputs) -> list[PredictorRow] | None:
    return predictor_rows(inputs.predictors, inputs.order, inputs.splits) if inputs.predictors else None


def make_table2(inputs: Inputs) -> list[Table2Row] | None:
    return table2_rows(inputs.ablations, inputs.order, inputs.splits) if inputs.ablations else None


def table2_md(rows: Sequence[Row], inputs: Inputs) -> str:
    return table2_markdown([row for row in rows if isinstance(row, Table2Row)], inputs.splits)


def table2_tex(rows: Sequence[Row], inputs: Inputs) -> str:
    return table2_latex([row for row in rows if isinstance(row, Table2Row)], inputs.splits)


def make_lomo(inputs: Inputs) -> list[HeldOutRow] | None:
    return lomo_rows(inputs.lomo, inputs.order) if inputs.lomo else None


def make_speed(inputs: Inputs) -> list[SpeedRow] | None:
    return speed_rows(inputs.speed, inputs.order) if inputs.speed else None


def make_sweep(inputs: Inputs) -> list[SweepRow] | None:
    return sweep_rows(inputs.metrics, inputs.split, inputs.order) or None
