"""What the report's writer made, as the page reads it: each table with its rows, each figure with what it shows,
and the configuration's order of datasets, methods and modes, which every table, figure and section follows.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vpr_smr.core.constants import MODES


def unique(values: Iterable[str]) -> tuple[str, ...]:
    """``values`` without repeats, in the order first seen."""
    return tuple(dict.fromkeys(values))


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
    """A registered table as written: its columns, its rows (the CSV's, unrounded) and its files (CSV first)."""

    name: str
    columns: tuple[str, ...]
    rows: tuple[dict[str, Any], ...]
    files: tuple[Path, ...]


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
    reference range differs (SPEC 11) gives both: ``train references [0, 400): 400, queries [0, 600): 600``."""
    def one(split: str, lo: int, hi: int) -> str:
        reference = (reference_splits or {}).get(split)
        if reference is None:
            return f"{split} [{lo}, {hi}): {hi - lo} frames"
        r_lo, r_hi = reference
        return f"{split} references [{r_lo}, {r_hi}): {r_hi - r_lo}, queries [{lo}, {hi}): {hi - lo}"
    return "; ".join(one(split, lo, hi) for split, (lo, hi) in splits.items())


def ground_truth_text(info: dict[str, Any]) -> str:
    """A dataset card's ground truth: positions within the radius (SPEC 11), else frames within the tolerance."""
    if info.get("radius") is not None:
        return f"positions within {info['radius']:g} (the positions' unit)"
    return f"{info.get('tolerance', '')} frames"
