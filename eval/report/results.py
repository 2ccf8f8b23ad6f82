"""What the report's writer made, as the page reads it: each table with its rows, each figure with what it shows,
and the configuration's order of datasets, methods and modes, which every table, figure and section follows.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

from vpr_smr.core.constants import MODES
from vpr_smr.eval.predictor.defaults import validation_split

if TYPE_CHECKING:  # the rows module imports this module
    from vpr_smr.eval.report.rows import Column, Row

R = TypeVar("R")


def unique(values: Iterable[str]) -> tuple[str, ...]:
    """``values`` without repeats, in the order first seen."""
    return tuple(dict.fromkeys(values))


def split_word(name: str) -> str:
    """A split's name as the tables' headings and notes say it: ``val`` spelt out (``validation``), any other name,
    the configuration's, as it is."""
    return "validation" if name == "val" else name


@dataclass(frozen=True)
class Splits:
    """The run's split names by role, the configuration's: ``table`` (table_split: the split of every table and
    figure), ``evaluation`` (eval_splits, in its order) and ``train`` (train_split). ``validation``: the predictor's
    validation split (``predictor.defaults.validation_split``); ``last``: the last evaluation split, Table II's
    other one (``predictor.defaults.ablation_splits``)."""

    table: str | None
    evaluation: tuple[str, ...]
    train: str = "train"

    @property
    def validation(self) -> str | None:
        return validation_split(self.evaluation)

    @property
    def last(self) -> str | None:
        return self.evaluation[-1] if self.evaluation else self.table

    @classmethod
    def resolve(cls, table: str | None, evaluation: Sequence[str] | None, train: str | None,
                tables: Sequence[Iterable[str]], seen: Iterable[str] = ()) -> Splits:
        """The splits given, the others from the inputs': ``table`` defaults to the one split that every input of
        ``tables`` (e.g. each evaluation's splits) holds (None without such inputs), ``evaluation`` to the splits
        of ``tables`` and ``seen`` (e.g. the predictors'), in the order first seen, the table split last."""
        held = [list(names) for names in tables]
        if table is None and held:
            common = [name for name in held[0] if all(name in names for names in held[1:])]
            if len(common) != 1:
                raise ValueError(f"the inputs hold the splits {', '.join(map(repr, common)) or 'none in common'}: "
                                 "name the split the tables show (the configuration's table_split)")
            table = common[0]
        if evaluation is None:
            names = unique([*(name for names in held for name in names), *seen])
            evaluation = [*(name for name in names if name != table), *([table] if table is not None else [])]
        elif table is not None and table not in evaluation:
            raise ValueError(f"the table split {table!r} is not among the evaluation splits "
                             f"{', '.join(map(repr, evaluation))}")
        return cls(table, tuple(evaluation), train or "train")


@dataclass(frozen=True)
class Order:
    """The configuration's order of datasets, methods and modes.

    A run gives the report its evaluations in the configuration's order (the workflow expands datasets, then
    methods), so the order first seen there is the configuration's; names it does not hold sort after the known
    ones, alphabetically (e.g. the confusion table's ``all``).
    """

    datasets: tuple[str, ...] = ()
    methods: tuple[str, ...] = ()
    modes: tuple[str, ...] = MODES

    @classmethod
    def of(cls, metas: Iterable[dict[str, Any]], modes: Iterable[str] = (), methods: Sequence[str] = ()) -> Order:
        """The order of first appearance in ``metas`` (each with ``dataset`` and, but for predictor reports,
        ``method``); ``methods`` first when given (an explicit method order)."""
        metas = list(metas)
        return cls(unique(str(m["dataset"]) for m in metas),
                   unique([*methods, *(str(m["method"]) for m in metas if "method" in m)]),
                   unique([*modes, *MODES]))

    @staticmethod
    def _rank(known: tuple[str, ...], name: str) -> tuple[int, str]:
        return (known.index(name) if name in known else len(known)), name

    def dataset(self, name: str) -> tuple[int, str]:
        """Sort key of a dataset."""
        return self._rank(self.datasets, name)

    def method(self, name: str) -> tuple[int, str]:
        """Sort key of a method."""
        return self._rank(self.methods, name)

    def mode(self, name: str) -> tuple[int, str]:
        """Sort key of a mode."""
        return self._rank(self.modes, name)

    def sorted_methods(self, names: Iterable[str]) -> list[str]:
        return sorted(set(names), key=self.method)


@dataclass(frozen=True)
class WrittenTable:
    """A registered table as written: its columns (the registry's, one per split where it declares so), its rows
    as made (``records``: its row records, ``rows``), its files (CSV first) and its title where it is not the
    registry's (one naming the run's splits)."""

    name: str
    columns: tuple[Column, ...]
    records: tuple[Row, ...]
    files: tuple[Path, ...]
    title: str | None = None

    @property
    def rows(self) -> tuple[dict[str, Any], ...]:
        """The rows as the CSV holds them (unrounded): each column's value by name (``rows.cells``)."""
        from vpr_smr.eval.report.rows import cells  # the rows module imports this module

        return tuple(cells(row) for row in self.records)

    def of(self, row_type: type[R]) -> tuple[R, ...]:
        """The rows as their records, typed: ``row_type`` is the table's (``registry.Table.row``)."""
        found = tuple(row for row in self.records if isinstance(row, row_type))
        if len(found) != len(self.records):
            raise TypeError(f"table {self.name!r}: its rows are not {row_type.__name__} records")
        return found


@dataclass(frozen=True)
class WrittenFigure:
    """A figure of the run: a registered one the report wrote, or a match-inspector figure it was given.

    ``name``: the registry's figure name, or ``matches`` / ``distance_matrix`` for the inspector's; ``seq_len``,
    ``mode`` and ``method`` are None where the figure spans them.
    """

    name: str
    caption: str
    path: Path
    dataset: str
    seq_len: int | None = None
    mode: str | None = None
    method: str | None = None


def split_text(splits: dict[str, Sequence[int]], reference_splits: dict[str, Sequence[int]] | None = None) -> str:
    """``train [0, 500): 500 frames; ...``: each split's frames (half-open) and their number; a split whose
    reference range differs (method §11) gives both: ``train references [0, 400): 400, queries [0, 600): 600``."""
    def one(split: str, lo: int, hi: int) -> str:
        reference = (reference_splits or {}).get(split)
        if reference is None:
            return f"{split} [{lo}, {hi}): {hi - lo} frames"
        r_lo, r_hi = reference
        return f"{split} references [{r_lo}, {r_hi}): {r_hi - r_lo}, queries [{lo}, {hi}): {hi - lo}"
    return "; ".join(one(split, lo, hi) for split, (lo, hi) in splits.items())


def ground_truth_text(info: dict[str, Any]) -> str:
    """A dataset card's ground truth: its file (method §13, as ``GroundTruth.describe`` says it), positions within
    the radius (method §11), else frames within the tolerance."""
    if info.get("ground_truth"):
        return str(info["ground_truth"])
    if info.get("radius") is not None:
        return f"positions within {info['radius']:g} (the positions' unit)"
    tolerance = info.get("tolerance", "")
    return f"within {tolerance} frame{'' if tolerance == 1 else 's'}"


def provenance_text(recorded: dict[str, Any]) -> str:
    """What an output recorded of its ground truth (``GroundTruth.provenance``: kind, tolerance or radius, file), as
    ``ground_truth_text`` says it."""
    if recorded.get("kind") == "matrix":
        name = Path(str(recorded.get("file", ""))).name + (f":{recorded['key']}" if recorded.get("key") else "")
        lists = "lists" in str(recorded.get("form", ""))
        return f"{name} ({'per-query lists' if lists else 'a matrix'})"
    if recorded.get("kind") == "positions":
        return f"positions within {recorded.get('radius', 0):g} (the positions' unit)"
    return ground_truth_text({"tolerance": recorded.get("tolerance", "")})
