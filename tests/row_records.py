"""Row records for the report's tests: a test names the cells it is about (as the CSV names them: an interval as its
two bound columns), every other field of the record takes a neutral value (0, an empty text, None, no keys), and
``rows.parse`` makes the record."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping
from typing import Any, TypeVar

from vpr_smr.eval.report import rows

R = TypeVar("R")


def _neutral(annotation: str) -> Any:
    """The value of a field a test leaves out, by its annotation (the record modules' annotations are strings)."""
    if "None" in annotation:
        return None
    if annotation.startswith("Mapping"):
        return {}
    return {"int": 0, "float": 0.0, "str": ""}[annotation]


def record(row_type: type[R], cells: Mapping[str, Any]) -> R:
    """A ``row_type`` record of ``cells``; a cell the record has no column or field of is refused (a misspelt
    name)."""
    fields = {field.name: field for field in dataclasses.fields(row_type)}  # type: ignore[arg-type]
    columns = {column.name for column in rows.columns(row_type)}  # type: ignore[arg-type]
    unknown = set(cells) - columns - set(fields)
    if unknown:
        raise KeyError(f"{row_type.__name__} has no column {sorted(unknown)}")
    neutral = {name: _neutral(str(field.type)) for name, field in fields.items()}
    return rows.parse(row_type, {**neutral, **dict.fromkeys(columns - set(fields)), **cells})


def records(row_type: type[R], found: Iterable[Mapping[str, Any]]) -> list[R]:
    return [record(row_type, row) for row in found]
