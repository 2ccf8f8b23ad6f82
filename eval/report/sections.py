"""A section of the report's page, declared: what ``html``'s one builder (``html._Builder.section``) renders.

The page's own sections are ``html.SECTIONS``; a table declared in a module of ``eval/report/tables/`` brings its
section as its ``registry.Table.section``. This module imports neither, so that such a module can declare both.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from vpr_smr.eval.report.results import WrittenFigure
from vpr_smr.eval.report.view import Block, TableView

if TYPE_CHECKING:
    from vpr_smr.eval.report.html import _Builder

Rows = Sequence[Any]  # the row records (``registry.Table.row``) of a section's first table
INSPECTOR_FIGURES = ("matches", "distance_matrix")  # the match inspector's figures (``build.INSPECTOR``)


@dataclass(frozen=True)
class Declared:
    """A section of the page, below the findings: ``id`` (its anchor) and ``title``; ``tables``, the registered
    tables it shows (the first one's rows are its blocks'; each folded whole at its foot); ``intro``, its sentences
    under the title (a text, or made from the run); a block per written figure of the registered ``figure``, with
    ``view`` (its tables of the figure's rows), ``sentences`` (said under it), ``headline`` (its one sentence on the
    first screen) and the figures of ``aside`` of the same dataset, L and mode beside it; or ``blocks`` made
    otherwise (per dataset, per dataset and L); ``headlines``: the section's own sentences on the first screen.
    With neither a figure nor blocks, the section is its intro and its tables, folded.

    Adding a section is one declaration: in ``html.SECTIONS`` (in the page's order) or as a table's ``section``."""

    id: str
    title: str
    tables: tuple[str, ...]
    intro: str | Callable[[_Builder], tuple[str, ...]]
    figure: str = ""
    view: Callable[[_Builder, WrittenFigure, Rows], tuple[TableView, ...]] | None = None
    sentences: Callable[[_Builder, Rows], Sequence[str]] | None = None
    headline: Callable[[Rows], str] | None = None
    aside: str = ""
    blocks: Callable[[_Builder], Sequence[Block]] | None = None
    headlines: Callable[[_Builder], Sequence[str]] | None = None

    def check(self) -> None:
        """Refuse a table or figure the registry does not declare (only a declared one is shown)."""
        from vpr_smr.eval.report import registry  # the registry collects the tables that declare sections

        for name in self.tables:
            registry.table(name)
        for name in (self.figure, self.aside):
            if name and name not in INSPECTOR_FIGURES:
                registry.figure(name)
