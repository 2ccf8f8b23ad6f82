"""``vpr-smr backends``: every registered descriptor backend with what its class says about itself.

The facts come from the backend classes (``default_conf``, ``needs_checkpoint``, ``distance``,
``input_summary``), so a new backend, built in or registered through the entry point group, is listed without an
edit here.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

from vpr_smr.descriptors import available_backends, backend_class


@dataclass(frozen=True)
class BackendFacts:
    """One backend as ``vpr-smr backends`` lists it; ``error`` when its class could not be imported."""

    name: str
    needs_checkpoint: bool = False
    distance: str = ""
    input_summary: str = ""
    settings: dict[str, Any] = field(default_factory=dict)
    error: str | None = None


def backend_facts() -> list[BackendFacts]:
    """Every backend of ``available_backends()`` (built in and entry points), in name order."""
    facts = []
    for name in available_backends():
        try:
            cls = backend_class(name)
        except Exception as error:  # a broken plugin is listed with its error, not a crash of the listing
            facts.append(BackendFacts(name, error=f"{type(error).__name__}: {error}"))
            continue
        facts.append(BackendFacts(name, cls.needs_checkpoint, cls.distance, cls.input_summary,
                                  dict(cls.default_conf)))
    return facts


def _value(value: Any) -> str:
    """A setting as the configuration's YAML writes it: strings bare, ``null``, ``true``, ``[112, 224]``."""
    return value if isinstance(value, str) else json.dumps(value)


def format_backends(facts: list[BackendFacts]) -> str:
    """Plain text: one aligned row per backend (name, checkpoint, distance, input), its default settings indented
    on the next line (they are too long for a column)."""
    from vpr_smr.core.constants import METRICS
    from vpr_smr.descriptors.base import COMMON_SETTINGS, PREPROCESSING

    header = ("backend", "checkpoint", "distance", "input (official evaluation)")
    rows: list[tuple[tuple[str, ...], str]] = [(header, "")]
    for fact in facts:
        if fact.error is not None:
            rows.append(((fact.name, "?", "?", "?"), f"cannot be loaded: {fact.error}"))
            continue
        settings = ", ".join(f"{key}={_value(value)}" for key, value in fact.settings.items()) or "none"
        rows.append(((fact.name, "needed" if fact.needs_checkpoint else "none", fact.distance, fact.input_summary),
                     f"settings: {settings}"))
    widths = [max(len(cells[i]) for cells, _ in rows) for i in range(len(header))]
    lines = []
    for cells, below in rows:
        lines.append("  ".join(cell.ljust(width) for cell, width in zip(cells, widths, strict=True)).rstrip())
        if below:
            lines.append(f"    {below}")
    return "\n".join([
        *lines,
        "",
        f"Every backend also takes {', '.join(COMMON_SETTINGS)}",
        f"(distance: {', '.join(METRICS)}; preprocessing: {', '.join(PREPROCESSING)}).",
        "Set them under methods.<name> in a configuration; check a downloaded checkpoint with",
        "vpr-smr checkpoint check BACKEND FILE.",
    ])
