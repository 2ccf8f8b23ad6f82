"""Settings declared once: a settings record is a frozen dataclass whose every field is a ``setting``.

``setting(default, help, **constraints)`` declares one field: its type (the annotation), its default, one line of
help and its constraints (``minimum``, ``exclusive_minimum``, ``maximum``, ``choices``, ``min_items``, ``unique``).
Everything a user sees of a setting follows from that one declaration: the configuration schema, the CLI option,
the Snakemake param and the configuration reference in the docs (``pipeline`` builds them from ``declared``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

__all__ = ["Declared", "declared", "setting"]

HELP = "help"
CONSTRAINTS = ("minimum", "exclusive_minimum", "maximum", "choices", "min_items", "unique")


def setting(default: Any, help: str, **constraints: Any) -> Any:
    """A field of a settings record: ``default`` (a tuple for a list of values: records are frozen), one line of
    ``help``, and constraints of ``CONSTRAINTS``."""
    unknown = set(constraints) - set(CONSTRAINTS)
    if unknown:
        raise TypeError(f"setting: unknown constraints {sorted(unknown)}; known: {', '.join(CONSTRAINTS)}")
    return dataclasses.field(default=default, metadata={HELP: help, **constraints})


@dataclass(frozen=True)
class Declared:
    """One declared setting: its name, type annotation (as text), default, help and constraints."""

    name: str
    type: str
    default: Any
    help: str
    constraints: dict[str, Any]


def declared(cls: type) -> tuple[Declared, ...]:
    """The settings ``cls`` declares, in order; TypeError naming a field that is not a ``setting``."""
    out = []
    for f in dataclasses.fields(cls):
        if HELP not in f.metadata:
            raise TypeError(f"{cls.__name__}.{f.name} is not declared with setting(default, help)")
        out.append(Declared(f.name, str(f.type), f.default, f.metadata[HELP],
                            {k: f.metadata[k] for k in CONSTRAINTS if k in f.metadata}))
    return tuple(out)
