"""The report page as typed data: what ``html.build_page`` makes from the run's results and the template lays out.

Every text here is plain text; the template escapes it (Jinja2 autoescaping). A cell carries its number as
``sort`` too, so that sorting a column by clicking its header orders by value, not by the rounded text.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any

from vpr_smr.eval.report import bounds
from vpr_smr.eval.report.table1 import UNDEFINED, is_reduction


@dataclass(frozen=True)
class Cell:
    """One table cell. ``kind``: its CSS class: ``num`` (right-aligned), ``text``, ``code`` (hashes and paths,
    monospace, broken anywhere), ``na`` (no value), ``up`` / ``down`` (a reduction: better / worse)."""

    text: str
    sort: str = ""  # the number behind ``text`` (``data-sort``), empty for text
    kind: str = "num"
    header: bool = False  # the row's header cell (<th scope="row">)
    detail: str = ""  # a second, smaller line: a verdict's interval under its word and number


@dataclass(frozen=True)
class Column:
    label: str
    kind: str = "num"  # ``num`` (right-aligned) or ``text``
    title: str = ""  # the column's full name (the CSV column), shown on hover when the label is shorter


@dataclass(frozen=True)
class TableView:
    """A table of the page. ``sortable``: a click on a column header sorts the rows by that column."""

    id: str
    columns: tuple[Column, ...]
    rows: tuple[tuple[Cell, ...], ...]
    caption: str = ""
    note: str = ""
    sortable: bool = True
    css: str = ""  # an extra class of the <table>: ``paper`` (Table I's layout), ``cards``
    groups: tuple[tuple[str, int], ...] = ()  # a header row above the columns': (label, columns it spans)


@dataclass(frozen=True)
class Folded:
    """A long table, folded (<details>): the whole CSV of a registered table."""

    summary: str
    table: TableView


@dataclass(frozen=True)
class FigureView:
    caption: str
    uri: str  # data:image/png;base64,...
    file: str  # its file, relative to the run folder


@dataclass(frozen=True)
class Block:
    """A figure (or a few) next to its compact table(s), under a heading; ``aside``: smaller figures shown with the
    tables."""

    title: str
    figures: tuple[FigureView, ...] = ()
    tables: tuple[TableView, ...] = ()
    text: tuple[str, ...] = ()
    aside: tuple[FigureView, ...] = ()


@dataclass(frozen=True)
class Section:
    """One experiment: intro text, blocks, folded tables."""

    id: str
    title: str
    intro: tuple[str, ...] = ()
    blocks: tuple[Block, ...] = ()
    folded: tuple[Folded, ...] = ()
    headlines: tuple[str, ...] = ()  # its findings' one sentence each, on the first screen


@dataclass(frozen=True)
class Finding:
    """Table I of one dataset in one mode at one L, in the paper's layout, with what it shows in words."""

    title: str
    sentences: tuple[str, ...]  # the details, folded below the table: warnings, every sentence, the seeds
    table: TableView
    note: str = ""  # the queries the numbers are over
    headline: str = ""  # the first screen's one sentence (``findings.headline``)


@dataclass(frozen=True)
class VerdictBlock:
    """One dataset's answers in one mode (``verdicts``): its title, the queries its numbers are over (said once)
    and its verdict tables."""

    title: str
    queries: str
    tables: tuple[TableView, ...]


@dataclass(frozen=True)
class VerdictMode:
    """The verdict tables of one mode; the first mode of the page is shown, the others folded."""

    mode: str
    blocks: tuple[VerdictBlock, ...]


@dataclass(frozen=True)
class Card:
    """A dataset's card: (label, value, whether the value is a hash or path) items."""

    dataset: str
    items: tuple[tuple[str, str, bool], ...]


@dataclass(frozen=True)
class Page:
    title: str
    subtitle: str  # version, time, split, Table I's L
    warnings: tuple[str, ...]  # splits that share frames
    findings: tuple[Finding, ...]
    findings_files: str  # where Table I is as files
    sections: tuple[Section, ...]  # the experiments, in the page's order
    cards: tuple[Card, ...]
    datasets_table: Folded | None
    cite: str
    provenance: TableView
    descriptor_files: TableView | None
    configuration: str
    nav: tuple[tuple[str, str], ...] = field(default=())  # (anchor, title) of every section on the page
    verdicts: tuple[VerdictMode, ...] = ()  # the first screen: each question's answer per dataset and method
    ground_truth: str = ""  # the first screen's line: each dataset's ground truth ("Correct matches: ...")
    across_machines: str = ""  # which numbers another machine may change, in the provenance section


# --- cells ------------------------------------------------------------------------------------------------------


def cell(value: Any, column: str = "", header: bool = False, fmt: str = ".4f") -> Cell:
    """The cell of a table value: a float written with its column's ``fmt`` (``registry.Column``'s) and kept whole
    for sorting; a reduction coloured by its sign; None as ``n/a`` in a reduction column, else empty."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return Cell(UNDEFINED if is_reduction(column) else "", kind="na", header=header)
    if isinstance(value, bool):
        return Cell(str(value).lower(), kind="text", header=header)
    if isinstance(value, int):
        return Cell(str(value), sort=str(value), header=header)
    if isinstance(value, float):
        kind = "num"
        if is_reduction(column) and value != 0 and not bounds.is_bound(column):
            kind = "up" if value > 0 else "down"
        return Cell(f"{value:{fmt}}", sort=repr(value), kind=kind, header=header)
    text = str(value)
    code = "sha256" in column or column == "file" or (len(text) > 40 and " " not in text)
    return Cell(text, kind="code" if code else "text", header=header)


def anchor(*parts: Any) -> str:
    """An HTML id from ``parts``: lower case, letters, digits and dashes."""
    return re.sub(r"[^a-z0-9]+", "-", "-".join(str(p) for p in parts).lower()).strip("-")


def text_cell(text: str, header: bool = False) -> Cell:
    return Cell(text, kind="text", header=header)
