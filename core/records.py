"""Result records declared once: a frozen dataclass is the layout of its JSON, through one codec.

``encode`` turns a record into JSON data and ``decode`` turns the data back into the record, both driven by the
dataclass's fields and their type hints, so that a record's fields are the one place its keys are declared:

- a dataclass is an object with one entry per field, named as the field; a field whose default is None is left out
  while None (and is None when absent); every other entry must be there (``MissingEntry``, a KeyError naming its
  path in the data), and an entry that is no field is refused;
- tuples and lists are arrays (``tuple[X, ...]``, ``tuple[X, Y]``, ``list[X]``); ``dict[str, X]`` and
  ``dict[int, X]`` are objects (an int key as its decimal text); ``X | None`` is null or X;
- float, int, str and bool are themselves (an int where a float is declared is read as that float; NaN and the
  infinities as ``json`` writes them: ``NaN``, ``Infinity``, ``-Infinity``); ``Any`` (a meta's values) is kept as
  given; NumPy scalars and arrays are written as Python numbers and lists, and an ``np.ndarray`` field is read back
  as an array.

A record whose JSON is a whole file (``FileRecord``) also writes the results format (``FORMAT``) as its ``"format"``
entry, and refuses data of another format (``FormatError``, saying to compute the file again). ``save`` and ``load``
write and read such a file (``load``'s errors name it); ``Record`` gives every record ``to_json`` and ``from_json``.
"""

from __future__ import annotations

import dataclasses
import json
import re
import types
from collections.abc import Mapping
from functools import cache
from pathlib import Path
from typing import Any, Self, TypeVar, Union, cast, get_args, get_origin, get_type_hints

import numpy as np

from vpr_smr.core.constants import RESULTS_LAYOUT
from vpr_smr.core.io import package_version, write_json

# The results format every file of a record records: the layout constant the workflow's rules carry, so that a run
# made in another format computes its files again instead of failing to read them.
FORMAT = RESULTS_LAYOUT
FORMAT_KEY = "format"

T = TypeVar("T")
_INT_KEY = re.compile(r"-?[0-9]+")


class MissingEntry(KeyError):
    """An entry a record needs is not in the data: ``args[0]`` is its path (e.g. ``splits.test.seed_summary``)."""


class FormatError(ValueError):
    """Data written in another results format than this version's ``FORMAT``."""


# --- encoding ---------------------------------------------------------------------------------------------------


def encode(value: Any) -> Any:
    """``value`` as JSON data: a dataclass as an object of its fields (a field whose default is None left out while
    None), tuples and lists as lists, mappings as objects (int keys as text), NumPy values as Python ones."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        out = {}
        for f in dataclasses.fields(value):
            item = getattr(value, f.name)
            if item is None and f.default is None:
                continue
            out[f.name] = encode(item)
        return out
    if isinstance(value, tuple | list):
        return [encode(item) for item in value]
    if isinstance(value, Mapping):
        return {_key(key): encode(item) for key, item in value.items()}
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def _key(key: Any) -> str:
    if isinstance(key, str):
        return key
    if isinstance(key, int | np.integer) and not isinstance(key, bool):
        return str(int(key))
    raise TypeError(f"a key of a record's mapping must be a str or an int, not {type(key).__name__} ({key!r})")


# --- decoding ---------------------------------------------------------------------------------------------------


def decode(cls: type[T], data: Any, where: str = "") -> T:
    """The ``cls`` record (or any type ``encode`` writes) of JSON ``data``; ``where``: the data's path, for errors.

    A missing entry raises ``MissingEntry``; a value of the wrong type a TypeError, an unexpected entry or a wrong
    length a ValueError, each naming the entry's path."""
    return cast(T, _decode(cls, data, where))


@cache
def _hints(cls: type) -> dict[str, Any]:
    return get_type_hints(cls)


def _at(where: str, name: str) -> str:
    return f"{where}.{name}" if where else name


def _decode(hint: Any, data: Any, where: str) -> Any:
    if hint is Any:
        return data
    origin = get_origin(hint)
    if origin is Union or origin is types.UnionType:
        args = get_args(hint)
        if data is None and type(None) in args:
            return None
        others = [arg for arg in args if arg is not type(None)]
        if len(others) != 1:
            raise TypeError(f"{where}: a record field may be X or X | None, not {hint}")
        return _decode(others[0], data, where)
    if isinstance(hint, type) and dataclasses.is_dataclass(hint):
        return _record(hint, data, where)
    if origin is tuple:
        items, args = _array(data, where), get_args(hint)
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_decode(args[0], item, f"{where}[{i}]") for i, item in enumerate(items))
        if len(items) != len(args):
            raise ValueError(f"{where}: {len(args)} items expected, found {len(items)}")
        return tuple(_decode(arg, item, f"{where}[{i}]") for i, (arg, item) in enumerate(zip(args, items,
                                                                                              strict=True)))
    if origin is list:
        (arg,) = get_args(hint)
        return [_decode(arg, item, f"{where}[{i}]") for i, item in enumerate(_array(data, where))]
    if origin is dict or hint is dict:
        key_type, value_type = get_args(hint) or (str, Any)
        return {_read_key(key_type, key, where): _decode(value_type, item, _at(where, key))
                for key, item in _object(data, where).items()}
    if hint is float:
        if isinstance(data, bool) or not isinstance(data, int | float):
            raise TypeError(f"{where}: a number expected, found {_shown(data)}")
        return float(data)
    if hint is int:
        if isinstance(data, bool) or not isinstance(data, int):
            raise TypeError(f"{where}: an integer expected, found {_shown(data)}")
        return data
    if hint is str or hint is bool:
        if not isinstance(data, hint):
            raise TypeError(f"{where}: a {hint.__name__} expected, found {_shown(data)}")
        return data
    if hint is np.ndarray:
        return np.asarray(data)
    raise TypeError(f"{where}: no JSON layout for the type {hint!r}")


def _record(cls: type, data: Any, where: str) -> Any:
    entries = _object(data, where)
    hints = _hints(cls)
    values, names = {}, set()
    for f in dataclasses.fields(cls):
        if not f.init:
            continue
        names.add(f.name)
        if f.name in entries:
            values[f.name] = _decode(hints[f.name], entries[f.name], _at(where, f.name))
        elif f.default is None:
            values[f.name] = None
        else:
            raise MissingEntry(_at(where, f.name))
    unexpected = sorted(set(entries) - names)
    if unexpected:
        raise ValueError(f"{where or 'the data'}: unexpected entries {', '.join(map(repr, unexpected))} (a "
                         f"{cls.__name__} has {', '.join(sorted(names))})")
    return cls(**values)


def _array(data: Any, where: str) -> list[Any]:
    if not isinstance(data, list | tuple):
        raise TypeError(f"{where}: a list expected, found {_shown(data)}")
    return list(data)


def _object(data: Any, where: str) -> Mapping[str, Any]:
    if not isinstance(data, Mapping):
        raise TypeError(f"{where or 'the data'}: an object expected, found {_shown(data)}")
    return data


def _read_key(key_type: Any, key: Any, where: str) -> Any:
    if key_type is int:
        if not isinstance(key, str) or not _INT_KEY.fullmatch(key):
            raise ValueError(f"{where}: an integer key expected, found {key!r}")
        return int(key)
    if key_type is not str and key_type is not Any:
        raise TypeError(f"{where}: a record's mapping has str or int keys, not {key_type!r}")
    return key


def _shown(data: Any) -> str:
    text = repr(data)
    return f"{type(data).__name__} {text if len(text) <= 40 else text[:37] + '...'}"


# --- the records and their files --------------------------------------------------------------------------------


class Record:
    """A frozen dataclass's ``to_json`` and ``from_json``, through ``encode`` and ``decode``."""

    __slots__ = ()

    def to_json(self) -> dict[str, Any]:
        return cast(dict[str, Any], encode(self))

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> Self:
        return decode(cls, data)


class FileRecord(Record):
    """A record that is a whole file: its JSON holds the results format too, and data of another is refused."""

    __slots__ = ()

    def to_json(self) -> dict[str, Any]:
        return {FORMAT_KEY: FORMAT, **super().to_json()}

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> Self:
        check_format(data)
        return decode(cls, {key: value for key, value in data.items() if key != FORMAT_KEY})


def check_format(data: Any) -> None:
    """Raise ``FormatError`` unless ``data`` (a file's JSON object) was written in this version's ``FORMAT``."""
    if not isinstance(data, Mapping):
        raise TypeError(f"the data: an object expected, found {_shown(data)}")
    found = data.get(FORMAT_KEY)
    if found == FORMAT and not isinstance(found, bool):
        return
    written = ("written by an earlier vpr-smr (it records no results format)" if found is None
               else f"written in results format {found!r}")
    raise FormatError(f"{written}, but this vpr-smr ({package_version()}) reads results format {FORMAT}: compute it "
                      "again with this version (`vpr-smr run` does for a run's files; a single file, by the command "
                      "of the stage that wrote it)")


def save(path: Path | str, record: FileRecord) -> None:
    """Write ``record`` to the JSON file ``path`` (``core.io.write_json``: keys sorted, written atomically)."""
    write_json(path, record.to_json())


F = TypeVar("F", bound=FileRecord)


def load(path: Path | str, cls: type[F]) -> F:
    """The ``cls`` record of the JSON file ``path``; an error names the file (``FormatError``: another results
    format, to compute again; ValueError: not such a record's data)."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise ValueError(f"{path}: not a JSON file: {error}") from None
    try:
        return cls.from_json(data)
    except FormatError as error:
        raise FormatError(f"{path}: {error}") from None
    except MissingEntry as error:
        raise ValueError(f"{path}: not {cls.__name__} data: it has no {error.args[0]!r} entry") from None
    except (TypeError, ValueError) as error:
        raise ValueError(f"{path}: not {cls.__name__} data: {error}") from None
