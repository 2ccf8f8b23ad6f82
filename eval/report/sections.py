"""A section of the report's page, declared: what ``html``'s one builder (``html._Builder.section``) renders.

The page's own sections are ``html.SECTIONS``; an experiment's section (the tool's own, in its module of
``pipeline/experiments/``, or an installed one's) and a table declared in a module of ``eval/report/tables/`` come
as their table's ``registry.Table.section``, placed after the section their ``after`` names (``placed``). This
module imports neither, so that such a module can declare both; ``prose`` gives a section its intro from
``templates/sections.yaml``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vpr_smr.eval.report.results import WrittenFigure
from vpr_smr.eval.report.view import Block, TableView

if TYPE_CHECKING:
    from vpr_smr.eval.report.html import _Builder

Rows = Sequence[Any]  # the row records (``registry.Table.row``) of a section's first table
INSPECTOR_FIGURES = ("matches", "distance_matrix")  # the match inspector's figures (``build.INSPECTOR``)
PROSE = Path(__file__).resolve().parent / "templates" / "sections.yaml"  # the sections' intros, by id


@dataclass(frozen=True)
class Declared:
    """A section of the page, below the findings: ``id`` (its anchor) and ``title``; ``tables``, the registered
    tables it shows (the first one's row records are its blocks'; each folded whole at its foot); ``intro``, its
    sentences under the title (a text, or made from the run); a block per written figure of the registered
    ``figure``, with ``view`` (its tables of the figure's rows), ``sentences`` (said under it), ``headline`` (its one
    sentence on the first screen) and the figures of ``aside`` of the same dataset, L and mode beside it; or
    ``blocks`` made otherwise (per dataset, per dataset and L); ``headlines``: the section's own sentences on the
    first screen. With neither a figure nor blocks, the section is its intro and its tables, folded.

    ``after``: the id of the section it follows on the page (``placed``); empty: after the page's own sections.
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
    after: str = ""

    def check(self) -> None:
        """Refuse a table or figure the registry does not declare (only a declared one is shown)."""
        from vpr_smr.eval.report import registry  # the registry collects the tables that declare sections

        for name in self.tables:
            registry.table(name)
        for name in (self.figure, self.aside):
            if name and name not in INSPECTOR_FIGURES:
                registry.figure(name)


def placed(own: Sequence[Declared], more: Sequence[Declared]) -> tuple[Declared, ...]:
    """The page's order: its ``own`` sections in theirs, then each of ``more`` (in their order) right after the
    section its ``after`` names and after those placed there before it (and the sections that follow them); one
    without ``after`` at the end. ValueError naming a section whose ``after`` is no section's id."""
    out, waiting = list(own), list(more)
    while waiting:
        ids = [spec.id for spec in out]
        ready = [spec for spec in waiting if not spec.after or spec.after in ids]
        if not ready:
            raise ValueError(f"section {waiting[0].id!r} follows {waiting[0].after!r}, which is no section's id "
                             f"(the page's: {', '.join(ids)})")
        for spec in ready:
            at = len(out)
            if spec.after:
                at = [s.id for s in out].index(spec.after) + 1
                while at < len(out) and _follows(out[at], spec.after, out):
                    at += 1
            out.insert(at, spec)
        waiting = [spec for spec in waiting if spec not in ready]
    return tuple(out)


def _follows(spec: Declared, anchor: str, sections: Sequence[Declared]) -> bool:
    """Whether ``spec`` follows the section ``anchor``, directly or after sections that follow it."""
    by_id = {found.id: found for found in sections}
    seen: Declared | None = spec
    while seen is not None and seen.after:
        if seen.after == anchor:
            return True
        seen = by_id.get(seen.after)
    return False


@cache
def _prose() -> dict[str, str]:
    """``templates/sections.yaml``: each section's intro by its id, read once."""
    import yaml

    found = yaml.safe_load(PROSE.read_text(encoding="utf-8"))
    if not isinstance(found, dict) or not all(isinstance(text, str) for text in found.values()):
        raise ValueError(f"{PROSE} must map each section's id to its intro (a text)")
    return found


def prose(section: str, **values: str) -> str:
    """The intro of ``section`` (its id) from ``templates/sections.yaml``, its ``{name}`` fields filled by
    ``values``; KeyError naming the file for an id it lacks."""
    texts = _prose()
    if section not in texts:
        raise KeyError(f"{PROSE} has no intro of the section {section!r}; it has {', '.join(texts)}")
    return texts[section].format(**values) if values else texts[section]
