"""Row records for the report's tests: a test names the cells it is about (as the CSV names them: an interval as its
two bound columns), every other field of the record takes a neutral value (0, an empty text, None, no keys)."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping
from typing import Any, TypeVar

from vpr_smr.eval.report.bounds import HIGH, LOW
from vpr_smr.eval.scoring.intervals import Interval

R = TypeVar("R")


def _neutral(annotation: str) -> Any:
    """The value of a field a test leaves out, by its annotation (the record modules' annotations are strings)."""
    if "None" in annotation:
        return None
    if annotation.startswith("Mapping"):
        return {}
    return {"int": 0, "float": 0.0, "str": ""}[annotation]


def record(row_type: type[R], cells: Mapping[str, Any]) -> R:
    """A ``row_type`` record of ``cells``; a cell the record has no column of is refused (a misspelt name)."""
    left = dict(cells)
    values = {}
    for field in dataclasses.fields(row_type):  # type: ignore[arg-type]
        base = field.name.removesuffix("_ci")
        if field.name.endswith("_ci") and f"{base}{LOW}" in left:
            low, high = left.pop(f"{base}{LOW}"), left.pop(f"{base}{HIGH}")
            values[field.name] = None if low is None else Interval(float(low), float(high))
        else:
            values[field.name] = left.pop(field.name) if field.name in left else _neutral(str(field.type))
    if left:
        raise KeyError(f"{row_type.__name__} has no column {sorted(left)}")
    return row_type(**values)


def records(row_type: type[R], rows: Iterable[Mapping[str, Any]]) -> list[R]:
    return [record(row_type, row) for row in rows]
