"""A table and a figure of the report, declared (``Table``, with its compact ``Pivot``, and ``Figure``): the records
``registry`` collects.

Apart from ``registry`` so that a module declaring a table or a figure (an experiment's: ``pipeline.experiments``)
imports them without importing the registry, which collects the experiments' tables and figures when it is imported.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vpr_smr.eval.report import rows
from vpr_smr.eval.report.results import Splits, WrittenFigure
from vpr_smr.eval.report.rows import Column
from vpr_smr.eval.report.tabulate import Inputs

if TYPE_CHECKING:
    from vpr_smr.eval.report.sections import Declared

__all__ = ["FIGURES_DIR", "TABLES_DIR", "Figure", "Pivot", "Table", "expand"]

TABLES_DIR = "tables"
FIGURES_DIR = "figures"


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
    record (``rows``: its fields are the columns, in the files' order), how its rows are made (``make``: a function
    of the run's ``tabulate.Inputs`` returning the row records, or None when the run has not what the table is of:
    then no file), and what of it the page's compact tables show: ``page`` (the columns by name, in their order) or
    ``pivot``, under ``caption`` (``{split}``: the table split, ``{seq_len}``: the L), in its own ``section`` (a
    ``sections.Declared``, placed after the section its ``after`` names, else after ``html.SECTIONS``) where none of
    those shows it.

    ``markdown`` and ``latex``: a layout of its own for those files (Table I's and Table II's, the paper's), from
    the rows and the inputs; ``run_title``: a title naming the run's choices (its splits); ``protocol``: whether the
    Markdown and LaTeX files say each dataset's ground truth under the title and the CSV in a column of its own
    (``CORRECT_MATCHES``)."""

    name: str  # the file stem under tables/
    title: str  # the heading of its Markdown and LaTeX files and of the HTML page
    experiments: tuple[str, ...]  # written when every one of these is run (``expected_outputs``' names)
    row: Any  # the row record (a dataclass declared with ``rows``)
    make: Callable[[Inputs], Sequence[Any] | None]
    suffixes: tuple[str, ...] = (".csv", ".md", ".tex")  # the CSV first: the HTML page shows it
    page: tuple[str, ...] = ()
    pivot: Pivot | None = None
    caption: str = ""
    markdown: Callable[[Sequence[Any], Inputs], str] | None = None
    latex: Callable[[Sequence[Any], Inputs], str] | None = None
    run_title: Callable[[Inputs], str] | None = None
    protocol: bool = True
    section: Declared | None = None

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
    """A figure of the report: its files (``name``, ``pattern``: the file name under figures/, with ``{dataset}``,
    and ``{seq_len}`` for one figure per sequence length, ``{mode}`` for one per mode), the start of its caption
    (``title``), when it is drawn (``experiments``, as a table's) and how (``draw``).

    ``draw``: a function of the figure, the run folder and the run's ``tabulate.Inputs`` that draws its files
    (``file``) and returns them (``results.WrittenFigure``, named ``name``; none when the run has not what the figure
    is of), so that an experiment's module, a plugin's too, declares its figure and how it is drawn; None for a
    figure the report draws itself (``build``: the evaluations' figures, which share their panels with the PR
    curves, trust levels' and restoration's among them)."""

    name: str
    title: str  # the start of its caption in the HTML page ("<title>: <dataset, L, mode>")
    experiments: tuple[str, ...]  # drawn when every one of these is run (``expected_outputs``' names)
    pattern: str
    draw: Callable[[Figure, Path, Inputs], Sequence[WrittenFigure]] | None = None

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
