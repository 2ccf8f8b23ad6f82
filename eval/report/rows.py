"""A table's row as a typed record: the record's fields are the table's columns, in its files' order.

A row record is a frozen dataclass whose fields are declared here: ``column`` (one column: its header on the page
and how the page writes it), ``interval`` (a field ``<name>_ci``, a 95 % interval or None: the two columns
``<name>_ci_low`` and ``<name>_ci_high``, as ``bounds`` reads them), ``each`` (a mapping written as one column
per key: ``recall_at_{}`` per N, ``f1_{evaluation}`` per evaluation split) or ``extra`` (what the page or a
figure reads beside the columns, never written). ``columns(RowType)`` lists the declared columns, which
``registry.Table`` takes from its row record; ``cells(row)`` is the row as the writer and the page read it (a
mapping by column name, the extras beside).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, ClassVar, Protocol, TypeVar

from vpr_smr.core.constants import RECALL_AT
from vpr_smr.eval.predictor.records import AttributeAblation, PredictorReport
from vpr_smr.eval.report import names
from vpr_smr.eval.report import outcome_words as words
from vpr_smr.eval.report.bounds import HIGH, LOW
from vpr_smr.eval.report.results import Splits, split_word
from vpr_smr.eval.scoring.curves import earned
from vpr_smr.eval.scoring.intervals import Interval
from vpr_smr.eval.scoring.records import (
    EvaluationSplit,
    HeldOut,
    MatcherMetrics,
    RestorationNumbers,
    SplitTiming,
    SweepPoint,
    TrustNumbers,
)
from vpr_smr.eval.scoring.speed import SpeedResult, SpeedScores

R = TypeVar("R")
# The label of a from-zero outcome's interval (``records.Reduction.aoc_difference_ci``): no reduction to show, the AOC
# difference's interval judged the word
AOC_DIFFERENCE = "AOC difference (+Pred - VPR+SM)"
SPLIT_ROLES = ("evaluation", "validation", "last")  # ``results.Splits``' roles a column can be one per split of


@dataclass(frozen=True)
class Column:
    """A table's column: ``name`` in its files (the headers of the CSV, Markdown and LaTeX tables) and in the page's
    whole table; ``label`` its header in the page's compact tables (default: the name, underscores as spaces);
    ``fmt`` how the page writes a float of it (a format spec; the CSV keeps every digit, Markdown and LaTeX 4
    decimals).

    A name with ``{evaluation}``, ``{validation}`` or ``{last}`` stands for one column per split of that role of
    ``results.Splits`` (``expand``); its label says the split as ``{split}`` (the name) or ``{word}``
    (``results.split_word``). ``if_any``: a compact table shows it only when a row has a value in it; ``note``:
    a compact table says it in its note (first row's value, then label), not as a column.
    """

    name: str
    label: str = ""
    fmt: str = ".4f"
    if_any: bool = False
    note: bool = False

    @property
    def header(self) -> str:
        return self.label or self.name.replace("_", " ")

    def expand(self, splits: Splits | None = None) -> tuple[Column, ...]:
        """The column, or one per split of its role in ``splits`` (none when the role has no split)."""
        role = next((role for role in SPLIT_ROLES if f"{{{role}}}" in self.name), None)
        if role is None:
            return (self,)
        if splits is None:
            raise ValueError(f"column {self.name!r} is one per split: name the run's splits")
        return tuple(replace(self, name=self.name.format(**{role: name}),
                             label=self.label.format(split=name, word=split_word(name)))
                     for name in _split_names(role, splits))


def _split_names(role: str, splits: Splits) -> list[str]:
    """The splits of ``role`` (``SPLIT_ROLES``) in ``splits``."""
    names: Sequence[str | None] = splits.evaluation if role == "evaluation" else (
        [splits.validation] if role == "validation" else [splits.last])
    return [name for name in names if name is not None]


class Row(Protocol):
    """A row record: a dataclass whose fields are declared by this module."""

    __dataclass_fields__: ClassVar[dict[str, dataclasses.Field[Any]]]


_KIND = "vpr_smr.column"  # the field metadata key: what kind of column a field is, and its column's declaration

# Columns of several tables: the same header and format wherever a row record has a field of that name
SHARED = {column.name: column for column in (
    Column("seq_len", "L"), Column("n_queries", "queries"), Column(names.AOC_VPR_SM, "AOC VPR+SM"),
    Column(names.AOC_VPR_SM_PRED, "AOC VPR+SM+Pred"), Column(names.REDUCTION, "AOC reduction (%)", ".2f"),
    Column(names.RECALL_SINGLE, "R@1 single"), Column(names.RECALL_SEQUENCE, "R@1 sequence"),
    Column("f1_macro", "macro F1"), Column("f1_cv", "F1 cross-validation"))}


def _shared(name: str, label: str, fmt: str | None) -> Column:
    """The column ``name`` with ``label`` and ``fmt`` where given, else the shared column's (``SHARED``)."""
    found = SHARED.get(name, Column(name))
    return replace(found, label=label or found.label, fmt=fmt or found.fmt)


def column(label: str = "", fmt: str | None = None, *, if_any: bool = False, note: bool = False,
           default: Any = dataclasses.MISSING) -> Any:
    """A field that is one column, named as the field (``label``, ``fmt``, ``if_any``, ``note``: ``Column``'s;
    ``label`` and ``fmt`` default to ``SHARED``'s column of that name, else to ``Column``'s defaults)."""
    declared = ("one", label, fmt, if_any, note)
    return dataclasses.field(default=default, metadata={_KIND: declared})


def interval(label: str = "", fmt: str | None = None, *, default: Any = dataclasses.MISSING) -> Any:
    """A field ``<name>_ci`` holding an ``Interval`` or None: the two columns ``<name>_ci_low`` and
    ``<name>_ci_high`` (``bounds``), labelled ``<label>, low`` and ``<label>, high`` (``label`` and ``fmt``: the
    number's; default: those of the record's column ``<name>``, else ``SHARED``'s, else its name, underscores as
    spaces)."""
    return dataclasses.field(default=default, metadata={_KIND: ("interval", label, fmt)})


def each(keys: Sequence[Any], name: str, label: str = "", fmt: str = ".4f", *, note: bool = False,
         default: Any = dataclasses.MISSING) -> Any:
    """A field holding a mapping, one column per key: ``name`` and ``label`` with ``{}`` for the key (``keys``: the
    columns' order), or with a split role (``{evaluation}``, ``{validation}``, ``{last}``: ``keys`` empty, one column
    per split of that role, ``Column.expand``). A key the mapping lacks leaves its cell empty."""
    return dataclasses.field(default=default, metadata={_KIND: ("each", Column(name, label, fmt, note=note),
                                                                tuple(keys))})


def extra(default: Any = dataclasses.MISSING) -> Any:
    """A field the page or a figure reads beside the columns (e.g. every seed's outcome); never written."""
    return dataclasses.field(default=default, metadata={_KIND: ("extra",)})


def _declared(field: dataclasses.Field[Any]) -> tuple[Any, ...]:
    found = field.metadata.get(_KIND)
    if found is None:
        raise TypeError(f"row field {field.name!r} is not declared by eval/report/rows.py (column, interval, each "
                        "or extra)")
    declared: tuple[Any, ...] = found
    return declared


def _columns(field: dataclasses.Field[Any], numbers: Mapping[str, Column]) -> tuple[Column, ...]:
    """A field's columns; ``numbers``: the record's one-column fields' columns, whose header and format an
    interval of one of them takes when it declares none."""
    kind, *rest = _declared(field)
    if kind == "one":
        label, fmt, if_any, note = rest
        return (replace(_shared(field.name, label, fmt), if_any=if_any, note=note),)
    if kind == "interval":
        base, (label, fmt) = _base(field), rest
        number = numbers.get(base) if not label and not fmt else None
        number = number or _shared(base, label, fmt)
        return tuple(Column(f"{base}{end}", f"{number.header}, {word}", number.fmt)
                     for end, word in ((LOW, "low"), (HIGH, "high")))
    if kind == "each":
        declared, keys = rest
        if not keys:  # one per split of a role: ``Column.expand`` names them
            return (declared,)
        return tuple(replace(declared, name=declared.name.format(key), label=declared.label.format(key))
                     for key in keys)
    return ()


def _base(field: dataclasses.Field[Any]) -> str:
    """The number an interval field is of: ``reduction_pct_ci`` -> ``reduction_pct``."""
    if not field.name.endswith("_ci"):
        raise TypeError(f"interval field {field.name!r}: name it <number>_ci")
    return field.name.removesuffix("_ci")


def columns(row_type: type[Row]) -> tuple[Column, ...]:
    """The columns of a row record, in its fields' order (a split role's column still one per role)."""
    fields = dataclasses.fields(row_type)
    numbers = {field.name: column for field in fields if _declared(field)[0] == "one"
               for column in _columns(field, {})}
    return tuple(found for field in fields for found in _columns(field, numbers))


def cells(row: Row) -> dict[str, Any]:
    """The row as its table's files and the page read it: each column's value by name (an interval as its two
    bounds, a mapping as one column per key it holds), the extras beside."""
    out: dict[str, Any] = {}
    for field in dataclasses.fields(row):
        kind, *rest = _declared(field)
        value = getattr(row, field.name)
        if kind in ("one", "extra"):
            out[field.name] = value
        elif kind == "interval":
            low, high = (None, None) if value is None else (value.low, value.high)
            out.update({f"{_base(field)}{LOW}": low, f"{_base(field)}{HIGH}": high})
        else:
            declared, keys = rest
            role = next((role for role in SPLIT_ROLES if f"{{{role}}}" in declared.name), None)
            items: Mapping[Any, Any] = value
            for key, one in items.items():
                out[declared.name.format(**{role: key}) if role else declared.name.format(key)] = one
    return out


def parse(row_type: type[R], found: Mapping[str, Any], splits: Splits | None = None) -> R:
    """A row record of ``row_type`` from its cells (``cells``' mapping: each column's value by name, an interval as
    its two bounds, a mapping as one column per key, the extras beside; ``splits``: the run's, where a field is a
    column per split): the one way back from a table's cells to its typed row. A column the cells lack is refused,
    naming it."""
    values: dict[str, Any] = {}
    for field in dataclasses.fields(row_type):  # type: ignore[arg-type]
        kind, *rest = _declared(field)
        if kind == "interval":
            low, high = (_cell(found, f"{_base(field)}{end}", row_type) for end in (LOW, HIGH))
            values[field.name] = None if low is None or high is None else Interval(float(low), float(high))
        elif kind == "each":
            declared, keys = rest
            role = next((role for role in SPLIT_ROLES if f"{{{role}}}" in declared.name), None)
            if role is None:  # one column per given key; a key without a cell is one the mapping lacked
                values[field.name] = {key: found[declared.name.format(key)] for key in keys
                                      if declared.name.format(key) in found}
            elif splits is None:
                raise ValueError(f"{row_type.__name__}.{field.name} is a column per split: name the run's splits")
            else:  # one column per split of the role that the cells hold
                columns = {name: declared.name.format(**{role: name}) for name in _split_names(role, splits)}
                values[field.name] = {name: found[column] for name, column in columns.items() if column in found}
        else:
            values[field.name] = _cell(found, field.name, row_type)
    return row_type(**values)


def _cell(found: Mapping[str, Any], name: str, row_type: type[Any]) -> Any:
    if name not in found:
        raise KeyError(f"a {row_type.__name__} row has a column {name!r}: these cells have none")
    return found[name]


# --- the row records of the tables ``build`` computes -------------------------------------------------------------
# Each is built from the stage's record by its ``of`` (the baselines' by ``report.baselines``, which computes their
# spread over the seeds): the columns are spelt here, once.

CLASSES = range(4)  # the predictor's classes (method §6)


@dataclass(frozen=True)
class ConfusionRow:
    """``predictor_confusion``: one true class of the seed-0 confusion matrix of a dataset, L and method (or
    ``all``, summed over the methods)."""

    dataset: str = column()
    seq_len: int = column()
    method: str = column()
    true_class: int = column()
    predicted: Mapping[int, int] = each(CLASSES, "predicted_{}", "predicted {}")
    total: int = column()

    @classmethod
    def of(cls, dataset: str, seq_len: int, method: str, true_class: int, counts: Sequence[int]) -> ConfusionRow:
        return cls(dataset, seq_len, method, true_class, {c: int(counts[c]) for c in CLASSES}, int(sum(counts)))


@dataclass(frozen=True)
class PredictorMethodRow:
    """``predictor_methods``: the seed-0 predictor on one method's table split: macro F1, the true and the
    predicted classes' counts."""

    dataset: str = column()
    seq_len: int = column()
    method: str = column()
    split: str = column()
    n_queries: int = column()
    f1_macro: float = column()
    true: Mapping[int, int] = each(CLASSES, "class_{}", "true {}")
    predicted: Mapping[int, int] = each(CLASSES, "predicted_{}", "predicted {}")

    @classmethod
    def of(cls, dataset: str, seq_len: int, method: str, split: str, result: EvaluationSplit) -> PredictorMethodRow:
        return cls(dataset, seq_len, method, split, result.n_queries, result.f1_macro,
                   {c: result.class_counts[c] for c in CLASSES}, {c: result.predicted_counts[c] for c in CLASSES})


MS = ".3f"  # times on the page


@dataclass(frozen=True)
class TimingRow:
    """``timing``: one evaluation's split: the seconds of the attributes and of the prediction, and per query."""

    dataset: str = column()
    method: str = column()
    seq_len: int = column()
    split: str = column()
    n_queries: int = column()
    attributes_seconds: float = column(fmt=MS)
    predict_seconds: float = column(fmt=MS)
    ms_per_query: float = column(fmt=MS)
    ms_attributes_per_query: float = column("attributes (ms)", MS)
    ms_predict_per_query: float = column("prediction (ms)", MS)

    @classmethod
    def of(cls, dataset: str, method: str, seq_len: int, split: str, numbers: SplitTiming) -> TimingRow:
        n = max(numbers.n_queries, 1)
        attributes, predict = numbers.attributes_seconds, numbers.predict_seconds
        return cls(dataset, method, seq_len, split, numbers.n_queries, attributes, predict,
                   1e3 * (attributes + predict) / n, 1e3 * attributes / n, 1e3 * predict / n)


@dataclass(frozen=True)
class VPRMetricsRow:
    """``vpr_metrics``: the standard VPR metrics of one matcher (single frame, sequence, sequence + predictor)."""

    dataset: str = column()
    method: str = column()
    seq_len: int = column()
    split: str = column()
    mode: str = column()
    matcher: str = column()
    n_queries: int = column()
    recall_at: Mapping[int, float | None] = each(RECALL_AT, "recall_at_{}", "R@{}")
    recall_at_100p: float = column("R@100P")
    pr_auc: float = column("PR-AUC")
    extended_precision: float = column("EP")

    @classmethod
    def of(cls, key: tuple[str, str, int], split: str, mode: str, matcher: str,
           numbers: MatcherMetrics) -> VPRMetricsRow:
        dataset, method, seq_len = key
        return cls(dataset, method, seq_len, split, mode, matcher, numbers.n_queries,
                   {n: numbers.recall_at.get(n) for n in RECALL_AT}, numbers.recall_at_100p, numbers.pr_auc,
                   numbers.extended_precision)


@dataclass(frozen=True)
class HeldOutRow:
    """``leave_one_method_out``: one held-out method in one mode under the pooled predictor and under one trained
    without it."""

    dataset: str = column()
    seq_len: int = column()
    held_out: str = column()
    mode: str = column()
    n_queries: int = column()
    f1_pooled: float = column("F1 pooled")
    f1_without: float = column("F1 without")
    removed_pooled: int = column()
    removed_without: int = column()
    aoc_vpr_sm: float = column()
    aoc_pooled: float = column("AOC pooled")
    aoc_without: float = column("AOC without")
    reduction_pct_pooled: float | None = column("reduction pooled (%)", ".2f")
    reduction_pct_pooled_ci: Interval | None = interval("reduction pooled (%)", ".2f")
    reduction_pct_without: float | None = column("reduction without (%)", ".2f")
    reduction_pct_without_ci: Interval | None = interval("reduction without (%)", ".2f")
    # the interval that judged a from-zero outcome (VPR+SM's AOC 0: no reduction), empty for any other
    aoc_difference_pooled_ci: Interval | None = interval("AOC difference pooled", ".4f")
    aoc_difference_without_ci: Interval | None = interval("AOC difference without", ".4f")
    outcome_pooled: str = column()
    outcome_without: str = column()

    @classmethod
    def of(cls, key: tuple[str, str, int], mode: str, result: HeldOut) -> HeldOutRow:
        dataset, method, seq_len = key
        pooled, without = result.pooled.modes[mode].reduction, result.without.modes[mode].reduction
        return cls(dataset, seq_len, method, mode, result.n_queries, result.pooled.f1_macro,
                   result.without.f1_macro, result.pooled.removed, result.without.removed, pooled.aoc_vpr_sm,
                   pooled.aoc_vpr_sm_pred, without.aoc_vpr_sm_pred, pooled.reduction_pct, pooled.reduction_pct_ci,
                   without.reduction_pct, without.reduction_pct_ci, pooled.aoc_difference_ci,
                   without.aoc_difference_ci, earned(pooled.outcome, pooled.reduction_pct_ci),
                   earned(without.outcome, without.reduction_pct_ci))


@dataclass(frozen=True)
class TrustRow:
    """``trust_levels``: match removal at one trust level against the baseline (``records.TrustNumbers``)."""

    dataset: str = column()
    method: str = column()
    seq_len: int = column()
    mode: str = column()
    trust: float = column("trust level", "g")
    removed: int = column()
    max_recall: float = column()
    auc: float = column()
    aoc: float = column()
    auc_vpr_sm: float = column()
    aoc_vpr_sm: float = column()
    reduction_pct: float | None = column()
    reduction_pct_ci: Interval | None = interval()
    outcome: str = column()
    n_queries: int = column()

    @classmethod
    def of(cls, key: tuple[str, str, int], mode: str, trust: float, numbers: TrustNumbers,
           n_queries: int) -> TrustRow:
        dataset, method, seq_len = key
        return cls(dataset, method, seq_len, mode, trust, numbers.removed, numbers.max_recall, numbers.auc,
                   numbers.aoc, numbers.auc_vpr_sm, numbers.aoc_vpr_sm, numbers.reduction_pct,
                   numbers.reduction_pct_ci, earned(numbers.outcome, numbers.reduction_pct_ci), n_queries)


@dataclass(frozen=True)
class RestorationRow:
    """``restoration``: one method's match restoration (the second filter) against removal alone, in one mode."""

    dataset: str = column()
    method: str = column()
    seq_len: int = column()
    mode: str = column()
    removed: int = column()
    restored: int = column()
    restored_correct: int = column()
    restored_wrong: int = column()
    wrong_to_right: int = column()
    right_to_wrong: int = column()
    max_recall_removal: float = column()
    max_recall_restoration: float = column()
    auc_vpr_sm: float = column()
    auc_removal: float = column("PR AUC removal")
    auc_restoration: float = column("PR AUC restoration")
    auc_difference: float = column("PR AUC difference")
    aoc_removal: float = column()
    aoc_restoration: float = column()
    aoc_difference: float = column()
    reduction_pct: float | None = column()
    reduction_pct_ci: Interval | None = interval()
    n_queries: int = column()

    @classmethod
    def of(cls, key: tuple[str, str, int], mode: str, restoration: RestorationNumbers,
           n_queries: int) -> RestorationRow:
        dataset, method, seq_len = key
        r, numbers = restoration, restoration.modes[mode]
        return cls(dataset, method, seq_len, mode, r.removed, r.restored, r.restored_correct, r.restored_wrong,
                   r.wrong_to_right, r.right_to_wrong, numbers.max_recall_removal, numbers.max_recall_restoration,
                   numbers.auc_vpr_sm, numbers.auc_removal, numbers.auc_restoration, numbers.auc_difference,
                   numbers.aoc_removal, numbers.aoc_restoration, numbers.aoc_difference, numbers.reduction_pct,
                   numbers.reduction_pct_ci, n_queries)


@dataclass(frozen=True)
class SweepRow:
    """``protocol_sweep``: one tolerance or radius of one method and mode: recall@1 and, with a predictor, Table
    I's numbers of its removal (none without)."""

    dataset: str = column()
    method: str = column()
    seq_len: int = column()
    split: str = column()
    mode: str = column()
    ground_truth: str = column()  # the kind swept: frames or positions
    threshold: float = column("tolerance or radius", "g")  # its tolerance in frames or its radius
    recall_at_1_single: float = column()
    recall_at_1_sequence: float = column()
    # single-frame recall@1 over the sequence recall's queries, and the paired interval of the change
    recall_at_1_single_evaluated: float | None = column("R@1 single, same queries")
    recall_change_ci: Interval | None = interval("R@1 sequence minus single")
    max_recall: float | None = column(default=None)
    aoc_vpr_sm: float | None = column(default=None)
    aoc_vpr_sm_pred: float | None = column(default=None)
    reduction_pct: float | None = column(default=None)
    reduction_pct_ci: Interval | None = interval(default=None)
    aoc_difference_ci: Interval | None = interval(AOC_DIFFERENCE, ".4f", default=None)  # as Table1Row's
    outcome: str | None = column(default=None)
    n_queries: int | None = column(default=None)  # the evaluated queries: the sequence recall@1's denominator

    @classmethod
    def of(cls, key: tuple[str, str, int], split: str, mode: str, kind: str, point: SweepPoint,
           n_queries: int | None) -> SweepRow:
        dataset, method, seq_len = key
        row = cls(dataset, method, seq_len, split, mode, kind, point.threshold, point.recall_at_1_single,
                  point.recall_at_1_sequence, point.recall_at_1_single_evaluated, point.recall_change_ci,
                  n_queries=n_queries)
        r = point.reduction  # none without a predictor
        return row if r is None else replace(
            row, max_recall=r.max_recall, aoc_vpr_sm=r.aoc_vpr_sm, aoc_vpr_sm_pred=r.aoc_vpr_sm_pred,
            reduction_pct=r.reduction_pct, reduction_pct_ci=r.reduction_pct_ci, aoc_difference_ci=r.aoc_difference_ci,
            outcome=earned(r.outcome, r.reduction_pct_ci))


@dataclass(frozen=True, kw_only=True)
class Table1Row:
    """``table1``: one dataset, method, L and mode of the table split: recall@1, the seed-0 predictor's AOCs and
    reduction with their intervals, the reduction's spread over the seeds, the queries they are over, and what the
    seed-0 predictor did (``curves.outcome``, the matches it removed, the baseline's own maximum recall and AOC, the
    seeds the spread leaves out)."""

    dataset: str = column()
    method: str = column()
    seq_len: int = column()
    mode: str = column()
    # recall@1 single by the mode's rule: paper mode over every query of the split (n_queries_single)
    recall_at_1_single: float = column()
    recall_at_1_sequence: float = column()
    max_recall: float = column()
    aoc_vpr_sm: float = column()
    aoc_vpr_sm_ci: Interval | None = interval()
    aoc_vpr_sm_pred: float = column()
    aoc_vpr_sm_pred_ci: Interval | None = interval()
    reduction_pct: float | None = column()  # None where the baseline's AOC is 0
    reduction_pct_ci: Interval | None = interval()
    # the interval over queries of the AOC difference (+Pred minus VPR+SM) that judged a from-zero outcome
    # (``curves.is_from_zero``: VPR+SM's AOC 0, no reduction), shown beside its word; empty for any other
    aoc_difference_ci: Interval | None = interval(AOC_DIFFERENCE, ".4f")
    # over the seeds whose reduction is defined (n_seeds_defined); the std None under two (``seed_summary``)
    reduction_pct_mean: float | None = column(fmt=".2f")
    reduction_pct_std: float | None = column(fmt=".2f")
    reduction_pct_min: float | None = column(fmt=".2f")
    reduction_pct_max: float | None = column(fmt=".2f")
    n_seeds: int = column()
    auc_vpr_sm: float = extra()  # the PR AUCs: the sequence-length table's columns and figure
    auc_vpr_sm_pred: float = extra()
    n_queries: int = column()  # the queries with a sequence match (Q - L + 1): every sequence number is over them
    n_queries_single: int = column()  # those recall_at_1_single is over (paper mode: every query of the split)
    n_seeds_defined: int = column()
    outcome: str = column()
    removed: int = column()
    max_recall_vpr_sm: float = column()
    aoc_vpr_sm_own: float = column()
    seeds_left_out: str = column()
    seed_outcomes: Mapping[int, str] = extra()  # every seed's outcome, by seed

    @classmethod
    def of(cls, key: tuple[str, str, int], mode: str, result: EvaluationSplit) -> Table1Row:
        dataset, method, seq_len = key
        numbers, summary = result.modes[mode], result.seed_summary[mode]
        r = numbers.reduction
        return cls(dataset=dataset, method=method, seq_len=seq_len, mode=mode,
                   recall_at_1_single=numbers.recall_at_1_single, recall_at_1_sequence=numbers.recall_at_1_sequence,
                   max_recall=r.max_recall, aoc_vpr_sm=r.aoc_vpr_sm, aoc_vpr_sm_ci=r.aoc_vpr_sm_ci,
                   aoc_vpr_sm_pred=r.aoc_vpr_sm_pred, aoc_vpr_sm_pred_ci=r.aoc_vpr_sm_pred_ci,
                   reduction_pct=r.reduction_pct, reduction_pct_ci=r.reduction_pct_ci,
                   aoc_difference_ci=r.aoc_difference_ci, reduction_pct_mean=summary.reduction_pct_mean,
                   reduction_pct_std=summary.reduction_pct_std,
                   reduction_pct_min=summary.reduction_pct_min, reduction_pct_max=summary.reduction_pct_max,
                   n_seeds=summary.n_seeds, auc_vpr_sm=r.auc_vpr_sm, auc_vpr_sm_pred=r.auc_vpr_sm_pred,
                   n_queries=result.n_queries,
                   n_queries_single=result.n_queries_split if mode == "paper" else result.n_queries,
                   n_seeds_defined=summary.n_seeds_defined, outcome=earned(r.outcome, r.reduction_pct_ci),
                   removed=result.removed,
                   max_recall_vpr_sm=r.max_recall_vpr_sm, aoc_vpr_sm_own=r.aoc_vpr_sm_own,
                   seeds_left_out=words.seeds_left_out_of(result, mode), seed_outcomes=summary.outcomes)


@dataclass(frozen=True, kw_only=True)
class SeqLenRow(Table1Row):
    """``ablation_seq_len``: Table I's row of every L, its PR AUCs, and the best training-free scorer of its
    dataset, method, L and mode beside the predictor (method §12; ``baselines.with_best``)."""

    auc_vpr_sm: float = column()
    auc_vpr_sm_pred: float = column()
    best_scorer: str | None = column("best training-free scorer", default=None)
    best_scorer_reduction_pct: float | None = column("its AOC reduction (%)", ".2f", default=None)
    # where no training-free reduction is defined, the outcome they share (e.g. nothing to reduce) and no scorer
    best_scorer_outcome: str | None = extra(None)
    best_scorer_auc: float | None = extra(None)  # its PR AUC at the seed-0 budget, which the figure marks


@dataclass(frozen=True, kw_only=True)
class BaselineRow:
    """``baselines``: one training-free scorer (or the oracle, or the predictor) removing as many matches as the
    seed-0 predictor (``budget``) on one dataset, method, L and mode (method §12): what it removed (the oracle at most
    every wrong match), the baseline's AOC and its own at its maximum recall, its reduction, and the paired interval
    of its reduction minus the seed-0 predictor's; the reduction's spread over every seed's budget."""

    dataset: str = column()
    method: str = column()
    seq_len: int = column()
    split: str = column()
    mode: str = column()
    scorer: str = column()
    budget: int = column()
    removed: int = column()
    max_recall: float = column()
    aoc_vpr_sm: float = column()
    aoc_vpr_sm_ci: Interval | None = interval()
    aoc: float = column("AOC")  # the scorer's AOC at its own maximum recall
    aoc_ci: Interval | None = interval()
    reduction_pct: float | None = column()
    reduction_pct_ci: Interval | None = interval()
    aoc_difference_ci: Interval | None = interval(AOC_DIFFERENCE, ".4f")  # as Table1Row's (the scorer's AOC)
    outcome: str = column()
    reduction_pct_difference_ci: Interval | None = interval("reduction minus the predictor's (%)", ".2f")
    reduction_pct_mean: float | None = column(fmt=".2f")
    reduction_pct_std: float | None = column(fmt=".2f")
    reduction_pct_min: float | None = column(fmt=".2f")
    reduction_pct_max: float | None = column(fmt=".2f")
    n_seeds: int = column()
    n_seeds_defined: int = column()
    n_queries: int = column()
    auc: float = extra()  # its PR AUC at the budget, which the sequence-length figure marks


@dataclass(frozen=True, kw_only=True)
class DetectionRow:
    """``wrong_match_detection``: how well one scorer detects the wrong sequence matches of one dataset, method and
    L (method §12): average precision with its interval and the paired interval of its difference from the seed-0
    predictor's, ROC AUC (``random`` and ``predictor``: the first seed's; ``random`` also their mean and sample
    standard deviation over its seeds), and the wrong matches they are over."""

    dataset: str = column()
    method: str = column()
    seq_len: int = column()
    split: str = column()
    scorer: str = column()
    average_precision: float | None = column("AP")
    average_precision_ci: Interval | None = interval()
    average_precision_difference_ci: Interval | None = interval("AP minus the predictor's")
    roc_auc: float | None = column("ROC AUC")
    average_precision_mean: float | None = column("AP mean", default=None)
    average_precision_std: float | None = column("AP std", default=None)
    roc_auc_mean: float | None = column("ROC AUC mean", default=None)
    roc_auc_std: float | None = column("ROC AUC std", default=None)
    n_seeds: int = column(default=1)  # the seeds the numbers are of: the first seed's, random's all (below)
    wrong_fraction: float = column("wrong matches (random's AP)")
    n_wrong: int = column()
    n_queries: int = column()


@dataclass(frozen=True, kw_only=True)
class SpeedRow:
    """``speed``: one method's simulated table split under one speed profile and one matcher (method §11): recall@1
    and Table I's numbers of its own seed-0 predictor, paper mode."""

    dataset: str = column()
    method: str = column()
    seq_len: int = column()
    profile: str = column()
    speed: float | None = column()  # the constant profile's speed (empty for varying)
    mean_speed: float = column()  # the simulated table query's mean step
    matcher: str = column()
    velocities: str = column()
    recall_at_1_single: float = column()
    recall_at_1_sequence: float = column()
    max_recall: float = column()
    aoc_vpr_sm: float = column()
    aoc_vpr_sm_pred: float = column()
    reduction_pct: float | None = column()
    reduction_pct_ci: Interval | None = interval()  # none computed by the speed experiment: its outcome says so
    outcome: str = column()
    f1_macro: float = column()
    n_queries: int = column()
    n_queries_single: int = column()

    @classmethod
    def of(cls, result: SpeedResult, matcher: str, velocities: Sequence[float], method: str,
           scores: SpeedScores) -> SpeedRow:
        r = scores.reduction
        return cls(dataset=str(result.meta["dataset"]), method=method, seq_len=int(result.meta["seq_len"]),
                   profile=result.profile, speed=result.speed, mean_speed=result.mean_speed, matcher=matcher,
                   velocities=" ".join(f"{v:g}" for v in velocities), recall_at_1_single=scores.recall_at_1_single,
                   recall_at_1_sequence=scores.recall_at_1_sequence, max_recall=r.max_recall,
                   aoc_vpr_sm=r.aoc_vpr_sm, aoc_vpr_sm_pred=r.aoc_vpr_sm_pred, reduction_pct=r.reduction_pct,
                   reduction_pct_ci=r.reduction_pct_ci, outcome=earned(r.outcome, r.reduction_pct_ci),
                   f1_macro=scores.f1_macro, n_queries=scores.n_queries, n_queries_single=scores.n_queries_single)


@dataclass(frozen=True, kw_only=True)
class PredictorRow:
    """``predictor``: the pooled predictor (its file's seed) of one dataset and L: its training samples and their
    classes, cross-validated F1, F1 and samples of each evaluation split by its name, and the seeds whose predictor
    cannot be trusted on the validation split, and why (``PredictorReport.warning``)."""

    dataset: str = column()
    seq_len: int = column()
    n_train: int = column("train samples")
    train_class: Mapping[int, int] = each(CLASSES, "train_class_{}")
    f1_cv: float | None = column()
    f1: Mapping[str, float | None] = each((), "f1_{evaluation}", "F1 {word}")
    n: Mapping[str, int | None] = each((), "n_{evaluation}", "{split} samples")
    warning: str = column(if_any=True)

    @classmethod
    def of(cls, report: PredictorReport, evaluation: Sequence[str], validation: str | None) -> PredictorRow:
        first = report.seeds[0]
        scores = {name: first.splits.get(name) for name in evaluation}
        return cls(dataset=report.meta["dataset"], seq_len=report.meta["seq_len"], n_train=report.n_train,
                   train_class={c: first.train_class_counts[c] for c in CLASSES}, f1_cv=first.f1_cv,
                   f1={name: None if s is None else s.f1 for name, s in scores.items()},
                   n={name: None if s is None else s.n for name, s in scores.items()},
                   warning=report.warning(validation) if validation is not None else "")


@dataclass(frozen=True, kw_only=True)
class Table2Row:
    """``table2``: one attribute set's predictor (Table II): macro F1 by cross-validation, on the validation split
    and on the last evaluation split (and its mean over methods), each split by its name; the samples each is over,
    which the page says in a note."""

    dataset: str = column()
    seq_len: int = column()
    attributes: str = column()
    f1_cv: float | None = column()
    f1_validation: Mapping[str, float] = each((), "f1_{validation}", "F1 {word}")
    f1_last: Mapping[str, float] = each((), "f1_{last}", "F1 {word}")
    f1_last_method_mean: Mapping[str, float] = each((), "f1_{last}_method_mean", "F1 {word}, mean over methods")
    n_train: int = column("training samples (cross-validation)", note=True)
    n_validation: Mapping[str, int] = each((), "n_{validation}", "{word}", note=True)
    n_last: Mapping[str, int] = each((), "n_{last}", "{word} samples", note=True)

    @classmethod
    def of(cls, ablation: AttributeAblation, name: str, splits: Splits) -> Table2Row:
        """Attribute set ``name``; the splits of ``splits``' roles that the record holds (a split it does not hold
        has no cells)."""
        numbers = ablation.attributes[name]
        held = {role: {split: numbers.splits[split]} if split is not None and split in numbers.splits else {}
                for role, split in (("validation", splits.validation), ("last", splits.last))}
        return cls(dataset=ablation.meta["dataset"], seq_len=ablation.meta["seq_len"], attributes=name,
                   f1_cv=numbers.f1_cv, f1_validation={k: v.f1 for k, v in held["validation"].items()},
                   f1_last={k: v.f1 for k, v in held["last"].items()},
                   f1_last_method_mean={k: v.f1_method_mean for k, v in held["last"].items()},
                   n_train=ablation.n_train, n_validation={k: v.n for k, v in held["validation"].items()},
                   n_last={k: v.n for k, v in held["last"].items()})
