"""A JSON object as one setting (``core.settings``' value class ``JsonObject``): on the command line its text, or
``@file`` holding it; in a job's JSON the object itself. For the settings whose shape another reader checks (the
report's run settings and dataset cards), so that the job carries the object, not text to parse again."""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from types import MappingProxyType
from typing import Any

__all__ = ["JsonObject", "json_object"]


def json_object(value: Any, where: str) -> dict[str, Any]:
    """``value`` as a JSON object: a mapping, or text of one (``@file``: the file holding it); ValueError naming
    ``where`` (the option or the setting) otherwise."""
    if isinstance(value, str):
        text = Path(value[1:]).read_text() if value.startswith("@") else value
        try:
            value = json.loads(text)
        except json.JSONDecodeError as error:
            raise ValueError(f"{where} is not valid JSON: {error}") from None
    if not isinstance(value, Mapping):
        raise ValueError(f"{where} must be a JSON object, got {value!r}")
    return dict(value)


class JsonObject:
    """A JSON object a setting holds whole (read only: ``data``); empty means not given."""

    def __init__(self, data: Mapping[str, Any] | None = None) -> None:
        self._data = json.loads(json.dumps(dict(data or {}), allow_nan=False))  # a copy of plain JSON values

    @property
    def data(self) -> Mapping[str, Any]:
        return MappingProxyType(self._data)

    def to_dict(self) -> dict[str, Any] | None:
        """A fresh copy of the object, None when it is empty (not given)."""
        return self.to_setting() if self._data else None

    @classmethod
    def from_setting(cls, value: Any, where: str) -> JsonObject:
        return cls(json_object(value, where))

    def to_setting(self) -> dict[str, Any]:
        """A fresh copy of the object (``core.settings``' value classes)."""
        copy: dict[str, Any] = json.loads(json.dumps(self._data))
        return copy

    def __eq__(self, other: object) -> bool:
        return isinstance(other, JsonObject) and self._data == other._data

    def __hash__(self) -> int:
        return hash(json.dumps(self._data, sort_keys=True))

    def __repr__(self) -> str:
        return f"JsonObject({self._data!r})"
