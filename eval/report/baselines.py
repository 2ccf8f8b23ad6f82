"""The training-free baselines' tables (method §12): the rows of ``baselines`` (removal at the predictor's budget)
and ``wrong_match_detection``, the best training-free scorer of each row of the sequence-length ablation, and the
comparison of one dataset, mode and L that the findings sentence and the figure show.

Every number comes from the ``vpr-smr baselines`` files (``records.Baselines``), unrounded. A scorer's number at a
budget is the seed-0 predictor's budget (as Table I is the seed-0 predictor's), and every seed's budget gives the
mean and sample standard deviation over the seeds (undefined with fewer than two seeds whose reduction is
defined); ``random``'s table cell shows that mean, since one draw of a random order says little. Comparisons (the
best scorer, the sentences) set like against like: every scorer's seed-0 number against the seed-0 predictor's,
each with its interval over queries and the paired interval of its difference from the predictor's (``bounds``).
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Iterable, Sequence
from dataclasses import dataclass, fields, replace
from typing import TypeVar

import numpy as np

from vpr_smr.eval.report.results import Order
from vpr_smr.eval.report.rows import BaselineRow, DetectionRow, SeqLenRow, Table1Row
from vpr_smr.eval.scoring import scorers
from vpr_smr.eval.scoring.curves import earned
from vpr_smr.eval.scoring.intervals import Interval
from vpr_smr.eval.scoring.records import Baselines, SplitBaselines, Versus
from vpr_smr.eval.scoring.scorers import ORACLE, PREDICTOR, RANDOM

Scored = TypeVar("Scored", BaselineRow, DetectionRow)  # a row of one scorer


def _split(record: Baselines, split: str) -> SplitBaselines:
    dataset, method, seq_len = record.key
    if split not in record.splits:
        raise ValueError(f"the baselines of {dataset}, {method}, L{seq_len} have no split {split!r} (the table "
                         f"split); they have {', '.join(record.splits) or 'none'}")
    return record.splits[split]


def _complete(record: Baselines, held: Collection[str]) -> None:
    """ValueError when ``held`` (the scorers of one of the record's splits) lacks an installed package's scorer: the
    file was computed before that plugin was installed, a stale result that would leave the scorer out of the tables
    and of the best training-free scorer. (Every file of this version holds every built-in scorer.)"""
    built_in = set(scorers.SCORERS.builtins())
    missing = [name for name in scorers.names() if name not in built_in and name not in held]
    if missing:
        dataset, method, seq_len = record.key
        many = len(missing) > 1
        raise ValueError(f"the baselines of {dataset}, {method}, L{seq_len} lack the installed scorer"
                         f"{'s' if many else ''} {', '.join(missing)}: they were computed before "
                         f"{'those plugins were' if many else 'its plugin was'} installed (a stale result); compute "
                         "them again: vpr-smr run reruns the baselines, metrics and queries jobs when the registered "
                         "scorers change (vpr-smr baselines for a file of your own)")


def _spread(values: Sequence[float | None]) -> tuple[float | None, float | None, int]:
    """Mean and sample standard deviation (ddof 1) of the defined values, and how many are defined; the standard
    deviation is undefined (None) with fewer than two."""
    defined = np.array([v for v in values if v is not None], dtype=np.float64)
    if not len(defined):
        return None, None, 0
    return float(defined.mean()), (float(defined.std(ddof=1)) if len(defined) > 1 else None), len(defined)


def _extremes(values: Sequence[float | None]) -> tuple[float | None, float | None]:
    defined = [v for v in values if v is not None]
    return (min(defined), max(defined)) if defined else (None, None)


def _sorted(records: Iterable[Baselines], order: Order | None) -> list[Baselines]:
    records = list(records)
    order = order or Order.of(record.meta for record in records)
    seen: set[tuple[str, str, int]] = set()
    for record in records:
        if record.key in seen:
            dataset, method, seq_len = record.key
            raise ValueError(f"two baselines files of {dataset}, {method}, L{seq_len}")
        seen.add(record.key)
    return sorted(records, key=lambda r: (order.dataset(r.key[0]), r.key[2], order.method(r.key[1])))


def headline(row: BaselineRow) -> float | None:
    """The number a scorer's table cell shows: its reduction at the seed-0 predictor's budget; random's mean over the
    seeds (beside its spread). Comparisons take every scorer's seed-0 number instead (like with like)."""
    return row.reduction_pct_mean if row.scorer == RANDOM else row.reduction_pct


def baseline_rows(records: Sequence[Baselines], split: str, seq_lens: Collection[int] | None = None,
                  order: Order | None = None) -> list[BaselineRow]:
    """The ``baselines`` table: one row per dataset, method, L, mode and scorer (in the registry's order) of the
    records' ``split`` (a record without a predictor has none), optionally only the sequence lengths given; by mode,
    L, dataset and method in the configuration's ``order``."""
    order = order or Order.of(record.meta for record in records)
    rows = []
    for record in _sorted(records, order):
        dataset, method, seq_len = record.key
        found = _split(record, split)
        if (seq_lens is not None and seq_len not in seq_lens) or not found.removal:
            continue
        first = found.removal[0]
        _complete(record, first.scorers)
        versus: dict[str, Versus] = found.versus_predictor or {}
        modes = sorted({mode for removal in first.scorers.values() for mode in removal.modes}, key=order.mode)
        for mode in modes:
            for scorer in (name for name in scorers.names() if name in first.scorers):
                numbers = first.scorers[scorer].modes[mode]
                values = [budget.scorers[scorer].modes[mode].reduction_pct for budget in found.removal]
                mean, std, defined = _spread(values)
                low, high = _extremes(values)
                rows.append(BaselineRow(
                    dataset=dataset, method=method, seq_len=seq_len, split=split, mode=mode, scorer=scorer,
                    budget=first.budget, removed=first.scorers[scorer].removed, max_recall=numbers.max_recall,
                    aoc_vpr_sm=numbers.aoc_vpr_sm, aoc_vpr_sm_ci=numbers.aoc_vpr_sm_ci, aoc=numbers.aoc_vpr_sm_pred,
                    aoc_ci=numbers.aoc_vpr_sm_pred_ci, reduction_pct=numbers.reduction_pct,
                    reduction_pct_ci=numbers.reduction_pct_ci, aoc_difference_ci=numbers.aoc_difference_ci,
                    outcome=earned(numbers.outcome, numbers.reduction_pct_ci),
                    reduction_pct_difference_ci=versus[scorer].reduction_pct_difference_ci.get(mode)
                    if scorer in versus else None, reduction_pct_mean=mean, reduction_pct_std=std,
                    reduction_pct_min=low, reduction_pct_max=high, n_seeds=len(values), n_seeds_defined=defined,
                    n_queries=found.n_queries, auc=numbers.auc_vpr_sm_pred))
    return sorted(rows, key=lambda r: (order.mode(r.mode), r.seq_len, order.dataset(r.dataset),
                                       order.method(r.method), scorers.names().index(r.scorer)))


def detection_rows(records: Sequence[Baselines], split: str, seq_lens: Collection[int] | None = None,
                   order: Order | None = None) -> list[DetectionRow]:
    """The ``wrong_match_detection`` table: one row per dataset, method, L and scorer of the records' ``split``:
    average precision and ROC AUC (``random`` and ``predictor``: the first seed's; ``random`` also their mean and
    sample standard deviation over its seeds), and the wrong matches they are over."""
    order = order or Order.of(record.meta for record in records)
    rows = []
    for record in _sorted(records, order):
        dataset, method, seq_len = record.key
        if seq_lens is not None and seq_len not in seq_lens:
            continue
        found = _split(record, split)
        versus = found.versus_predictor or {}
        _complete(record, found.detection)
        for scorer in (name for name in scorers.names() if name in found.detection):
            numbers = found.detection[scorer]
            row = DetectionRow(
                dataset=dataset, method=method, seq_len=seq_len, split=split, scorer=scorer,
                average_precision=numbers.average_precision, average_precision_ci=numbers.average_precision_ci,
                average_precision_difference_ci=versus[scorer].average_precision_difference_ci
                if scorer in versus else None, roc_auc=numbers.roc_auc, wrong_fraction=found.wrong_fraction,
                n_wrong=found.n_wrong, n_queries=found.n_queries)
            if scorer == RANDOM:  # the first seed's, and the mean and spread over every seed
                ap = _spread([d.average_precision for d in found.random_detection])
                auc = _spread([d.roc_auc for d in found.random_detection])
                row = replace(row, average_precision_mean=ap[0], average_precision_std=ap[1], roc_auc_mean=auc[0],
                              roc_auc_std=auc[1], n_seeds=len(found.random_detection))
            rows.append(row)
    return rows


def best_scorer(rows: Iterable[Scored], value: Callable[[Scored], float | None]) -> Scored | None:
    """The row of the training-free scorer with the largest seed-0 ``value`` among ``rows`` (one method's, one
    mode's: as the seed-0 predictor's), the first in the registry's order on a tie; None when none is defined."""
    by_scorer = {r.scorer: r for r in rows}
    best = scorers.best_training_free({name: value(row) for name, row in by_scorer.items()})
    return None if best is None else by_scorer[best]


def _groups(rows: Sequence[BaselineRow]) -> dict[tuple[str, str, int, str], list[BaselineRow]]:
    """``baseline_rows`` by (dataset, method, L, mode)."""
    groups: dict[tuple[str, str, int, str], list[BaselineRow]] = {}
    for row in rows:
        groups.setdefault((row.dataset, row.method, row.seq_len, row.mode), []).append(row)
    return groups


def with_best(table_rows: Sequence[Table1Row], rows: Sequence[BaselineRow]) -> list[SeqLenRow]:
    """The sequence-length ablation's rows (Table I's) with the best training-free scorer of each (dataset,
    method, L, mode) of ``baseline_rows``' ``rows`` beside the predictor: its name, reduction, PR AUC at the seed-0
    budget (which the sequence-length figure marks) and outcome; where no training-free reduction is defined, the
    outcome they share (e.g. nothing to reduce) says why, and no scorer is named."""
    groups = _groups(rows)
    out = []
    for row in table_rows:
        group = groups.get((row.dataset, row.method, row.seq_len, row.mode), [])
        numbers = {field.name: getattr(row, field.name) for field in fields(row)}
        found = best_scorer(group, lambda r: r.reduction_pct)
        if found is not None:
            out.append(SeqLenRow(**numbers, best_scorer=found.scorer, best_scorer_reduction_pct=found.reduction_pct,
                                 best_scorer_outcome=found.outcome, best_scorer_auc=found.auc))
            continue
        outcomes = {r.outcome for r in group if r.scorer in scorers.training_free()}
        out.append(SeqLenRow(**numbers, best_scorer_outcome=outcomes.pop() if len(outcomes) == 1 else None))
    return out


@dataclass(frozen=True)
class Comparison:
    """One dataset, mode and L: per method the predictor's reduction, the best training-free scorer's (the one
    with the largest mean over the methods of its seed-0 reductions, ``best``) and the oracle's, all seed 0's at the
    seed-0 predictor's budget; ``differences``: per method the paired interval of the best scorer's reduction minus
    the predictor's (None without one); ``n_queries``: per method the queries they are over."""

    dataset: str
    mode: str
    seq_len: int
    methods: tuple[str, ...]
    best: str | None
    predictor: tuple[float | None, ...]
    best_values: tuple[float | None, ...]
    oracle: tuple[float | None, ...]
    budgets: tuple[int, ...]
    differences: tuple[Interval | None, ...] = ()
    n_queries: tuple[int | None, ...] = ()

    @property
    def beaten(self) -> int:
        """Methods where the predictor beats the best training-free scorer: the interval of the scorer's reduction
        minus the predictor's lies below 0."""
        return sum(d is not None and d.sign() < 0 for d in self.differences)

    @property
    def undefined(self) -> tuple[str, ...]:
        """Methods where either reduction is undefined: neither beats the other there."""
        return tuple(m for m, p, b in zip(self.methods, self.predictor, self.best_values, strict=True)
                     if p is None or b is None)

    @property
    def best_mean(self) -> float | None:
        return _spread(self.best_values)[0]

    @property
    def oracle_mean(self) -> float | None:
        return _spread(self.oracle)[0]


def comparisons(rows: Sequence[BaselineRow]) -> list[Comparison]:
    """``baseline_rows`` grouped by dataset, mode and L (in the rows' order), each a ``Comparison``."""
    groups: dict[tuple[str, str, int], list[BaselineRow]] = {}
    for row in rows:
        groups.setdefault((row.dataset, row.mode, row.seq_len), []).append(row)
    out = []
    for (dataset, mode, seq_len), group in groups.items():
        methods = tuple(dict.fromkeys(r.method for r in group))
        by = {(r.method, r.scorer): r for r in group}
        values = {name: tuple(by[(m, name)].reduction_pct if (m, name) in by else None for m in methods)
                  for name in scorers.names()}
        # like with like: the scorers are ranked by their means over the methods where every one of them is
        # defined (each over its own only where no method is); the ranking picks whom to compare, the paired
        # intervals per method then decide
        free = scorers.training_free()
        common = [i for i in range(len(methods)) if all(values[name][i] is not None for name in free)]
        means = {name: _spread([values[name][i] for i in common] if common else values[name])[0] for name in free}
        defined = [name for name in free if means[name] is not None]
        best = max(defined, key=lambda name: (means[name] or 0.0, -scorers.names().index(name))) if defined else None
        differences = tuple(by[(m, best)].reduction_pct_difference_ci if (m, best) in by else None
                            for m in methods) if best is not None else tuple(None for _ in methods)
        out.append(Comparison(dataset, mode, seq_len, methods, best, values[PREDICTOR],
                              values[best] if best is not None else tuple(None for _ in methods), values[ORACLE],
                              tuple(by[(m, PREDICTOR)].budget for m in methods if (m, PREDICTOR) in by),
                              differences, tuple(by[(m, PREDICTOR)].n_queries if (m, PREDICTOR) in by
                                                 else None for m in methods)))
    return out


@dataclass(frozen=True)
class DetectionComparison:
    """One dataset, L and method: the training-free scorer with the highest seed-0 average precision of detecting
    wrong matches (``best``, None when none is defined), its and the seed-0 predictor's, and the paired interval of
    the difference (the scorer's minus the predictor's)."""

    dataset: str
    seq_len: int
    method: str
    best: str | None
    average_precision: float | None
    predictor: float | None
    difference: Interval | None
    n_queries: int


def detection_comparisons(rows: Sequence[DetectionRow]) -> list[DetectionComparison]:
    """``detection_rows`` per dataset, L and method (in the rows' order), each a ``DetectionComparison``."""
    groups: dict[tuple[str, int, str], list[DetectionRow]] = {}
    for row in rows:
        groups.setdefault((row.dataset, row.seq_len, row.method), []).append(row)
    out = []
    for (dataset, seq_len, method), group in groups.items():
        best = best_scorer(group, lambda r: r.average_precision)
        predictor = next((r for r in group if r.scorer == PREDICTOR), None)
        out.append(DetectionComparison(
            dataset, seq_len, method, None if best is None else best.scorer,
            None if best is None else best.average_precision,
            None if predictor is None else predictor.average_precision,
            None if best is None else best.average_precision_difference_ci, group[0].n_queries))
    return out
