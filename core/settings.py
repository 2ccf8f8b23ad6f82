"""Settings declared once: a settings record is a frozen dataclass whose every field is a ``setting``.

``setting(default, help, **constraints)`` declares one field: its type (the annotation), its default, one line of
help and its constraints (``minimum``, ``exclusive_minimum``, ``maximum``, ``choices``, ``min_items``, ``unique``).
Everything a user sees of a setting follows from that one declaration: the configuration schema, the CLI option,
the Snakemake param and the configuration reference in the docs (``pipeline`` builds them from ``declared``).

Two defaults are markers, for settings that a reader other than the record resolves (a dataset entry's, which its
loader reads): ``REQUIRED`` (no default: the setting must be given) and ``UNSET`` (no default in the configuration:
left out, the reader's own applies); neither is written into a configuration. A shape that the annotation cannot
say (a mapping, a choice of forms) is given as ``schema=``, a JSON-schema fragment that the setting's values are
checked against.

A settings record may hold another as one field (``group(Record, help)``): an option group declared once and reused
by every stage that needs it (how a matrix file is read, where the ground truth comes from). In JSON it is an object
of its own; on the command line its settings are options of the stage like any other. A field whose type is a class
with ``from_setting(value, where)`` and ``to_setting()`` (a sequence matcher's ``MatcherSpec``) is one value built
by that class.
"""

from __future__ import annotations

import builtins
import dataclasses
import typing
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, TypeVar

from vpr_smr.core.suggest import did_you_mean

__all__ = ["REQUIRED", "UNSET", "Declared", "declared", "group", "json_default", "json_schema", "parse", "read",
           "setting", "to_json"]

T = TypeVar("T")

HELP = "help"
OPTIONAL = " | None"  # the annotation's text of a setting that may be null
CONSTRAINTS = ("minimum", "exclusive_minimum", "maximum", "choices", "min_items", "max_items", "unique")
SCHEMA = "schema"  # the metadata key of a setting's explicit JSON-schema fragment
GROUP = "group"  # the metadata key of a group's record class (``group``)
METAVAR = "metavar"  # the metadata key of the word the command line's help shows for a value
ALIASES = "aliases"  # the metadata key of a setting's further option names (an earlier version's)


class Marker:
    """A default that is no value: ``REQUIRED`` or ``UNSET``."""

    def __init__(self, name: str) -> None:
        self.name = name

    def __repr__(self) -> str:
        return self.name


REQUIRED = Marker("REQUIRED")
UNSET = Marker("UNSET")


def setting(default: Any, help: str, *, schema: dict[str, Any] | None = None, metavar: str | None = None,
            aliases: tuple[str, ...] = (), **constraints: Any) -> Any:
    """A field of a settings record: ``default`` (a tuple for a list of values: records are frozen; or ``REQUIRED``,
    ``UNSET``), one line of ``help``, and constraints of ``CONSTRAINTS``, or instead the JSON-schema fragment
    ``schema`` of a shape the annotation cannot say; ``metavar``: the word the command line's help shows for its
    value (e.g. ``SPLIT=PATH``); ``aliases``: further names of its option, each the same option (an earlier
    version's name, e.g. ``test`` for ``table``: ``--test``)."""
    unknown = set(constraints) - set(CONSTRAINTS)
    if unknown:
        raise TypeError(f"setting: unknown constraints {sorted(unknown)}; known: {', '.join(CONSTRAINTS)}")
    if schema is not None and constraints:
        raise TypeError("setting: give constraints or a schema fragment, not both (the fragment says them)")
    extra: dict[str, Any] = ({} if schema is None else {SCHEMA: schema}) | ({} if metavar is None else
                                                                            {METAVAR: metavar})
    if aliases:
        extra[ALIASES] = tuple(aliases)
    return dataclasses.field(default=default, metadata={HELP: help, **constraints, **extra})


def group(cls: type, help: str) -> Any:
    """A field of a settings record that is the settings record ``cls`` (every one of its settings with a default
    or ``REQUIRED``): an option group, declared once and shared by the records that hold it."""
    return dataclasses.field(default_factory=cls, metadata={HELP: help, GROUP: cls})


@dataclass(frozen=True)
class Declared:
    """One declared setting: its name, type annotation (as text), default, help and constraints."""

    name: str
    type: str
    default: Any
    help: str
    constraints: dict[str, Any]
    schema: dict[str, Any] | None = None  # an explicit JSON-schema fragment (``setting``'s ``schema``)
    group: builtins.type | None = None  # a group's settings record (``group``)
    value_class: builtins.type | None = None  # a class building the value itself (``from_setting``, ``to_setting``)
    metavar: str | None = None  # the command line's word for its value
    aliases: tuple[str, ...] = ()  # further names of its option (``setting``'s ``aliases``)

    def is_group(self) -> bool:
        return self.group is not None


def declared(cls: type) -> tuple[Declared, ...]:
    """The settings ``cls`` declares, in order; TypeError naming a field that is not a ``setting`` or a ``group``."""
    out = []
    hints = _hints(cls)
    for f in dataclasses.fields(cls):
        if HELP not in f.metadata:
            raise TypeError(f"{cls.__name__}.{f.name} is not declared with setting(default, help)")
        kind = f.type.__name__ if isinstance(f.type, type) else str(f.type)
        hint = hints.get(f.name)
        value_class = hint if isinstance(hint, type) and hasattr(hint, "from_setting") else None
        default: Any = f.default
        if f.default_factory is not dataclasses.MISSING:  # a group: its record with its defaults
            default = f.default_factory()
        out.append(Declared(f.name, kind, default, f.metadata[HELP],
                            {k: f.metadata[k] for k in CONSTRAINTS if k in f.metadata}, f.metadata.get(SCHEMA),
                            f.metadata.get(GROUP), value_class, f.metadata.get(METAVAR),
                            f.metadata.get(ALIASES, ())))
    return tuple(out)


def _hints(cls: type) -> dict[str, Any]:
    """``cls``'s resolved type hints where they resolve (a value class's field needs them); else none."""
    try:
        return typing.get_type_hints(cls)
    except (NameError, TypeError):
        return {}


def _number(value: Any, kind: type, where: str) -> Any:
    if isinstance(value, bool) or not isinstance(value, int | float) or (kind is int and int(value) != value):
        raise ValueError(f"{where}: expected {'an integer' if kind is int else 'a number'}, got {value!r}")
    return kind(value)


def _value(kind: str, value: Any, where: str) -> Any:
    """``value`` as the declared type ``kind`` (the annotation's text), or ValueError naming ``where``."""
    if kind.endswith(OPTIONAL):
        return None if value is None else _value(kind[:-len(OPTIONAL)], value, where)
    if kind in ("float", "int"):
        return _number(value, float if kind == "float" else int, where)
    if kind == "bool":
        if not isinstance(value, bool):
            raise ValueError(f"{where}: expected true or false, got {value!r}")
        return value
    if kind == "str":
        if not isinstance(value, str):
            raise ValueError(f"{where}: expected a name (text), got {value!r}")
        return value
    for item in ("float", "int", "str"):
        if kind == f"tuple[{item}, ...]":
            if not isinstance(value, list | tuple):
                raise ValueError(f"{where}: expected a list of {item}s, e.g. {EXAMPLES[item]}, got {value!r}")
            return tuple(_value(item, v, f"{where}[{i}]") for i, v in enumerate(value))
    for item in ("str", "tuple[str, ...]"):
        if kind == f"dict[str, {item}]":
            if not isinstance(value, Mapping):
                raise ValueError(f"{where}: expected an object of names, e.g. {{\"val\": \"a.h5\"}}, got {value!r}")
            return {_value("str", k, where): _value(item, v, f"{where}.{k}") for k, v in value.items()}
    raise TypeError(f"{where}: settings of type {kind} are not supported (float, int, str, bool, tuples of them, "
                    "mappings of names to text or to tuples of text)")


EXAMPLES = {"float": "[1.0]", "int": "[1]", "str": '["a"]'}


def _check(item: Declared, value: Any, where: str) -> None:
    c = item.constraints
    if value is None:
        return
    values = value if isinstance(value, tuple) else (value,)
    for v in values:
        if "minimum" in c and v < c["minimum"]:
            raise ValueError(f"{where}: {item.help}; must be >= {c['minimum']}, got {v}")
        if "exclusive_minimum" in c and v <= c["exclusive_minimum"]:
            raise ValueError(f"{where}: {item.help}; must be > {c['exclusive_minimum']}, got {v}")
        if "maximum" in c and v > c["maximum"]:
            raise ValueError(f"{where}: {item.help}; must be <= {c['maximum']}, got {v}")
        if "choices" in c and v not in c["choices"]:
            raise ValueError(f"{where}: {v!r} is not one of {', '.join(map(str, c['choices']))}")
    if isinstance(value, tuple):
        if len(value) < c.get("min_items", 0):
            raise ValueError(f"{where}: {item.help}; give at least {c['min_items']}, got {list(value)}")
        if len(value) > c.get("max_items", len(value)):
            raise ValueError(f"{where}: {item.help}; give at most {c['max_items']}, got {list(value)}")
        if c.get("unique") and len(set(value)) != len(value):
            raise ValueError(f"{where}: {list(value)} repeats a value")


def parse(cls: type[T], values: Mapping[str, Any], where: str) -> T:
    """The ``cls`` record of JSON ``values`` (missing settings at their defaults); ValueError naming
    ``where.setting`` for an unknown setting (with the closest known one), a missing ``REQUIRED`` one, a wrong type
    or a broken constraint."""
    items = declared(cls)
    known = [item.name for item in items]
    for key in values:
        if key not in known:
            raise ValueError(f"{where}.{key}: unexpected setting {key!r}{did_you_mean(str(key), known)}; "
                             f"{where} allows: {', '.join(known) or 'none'}")
    for item in items:
        if item.default is REQUIRED and item.name not in values:
            raise ValueError(f"{where}.{item.name}: {item.help}; it has no default: give it")
    out = {item.name: read(item, values[item.name], f"{where}.{item.name}") for item in items if item.name in values}
    return cls(**out)


def read(item: Declared, value: Any, where: str) -> Any:
    """The JSON ``value`` of the setting ``item`` as its type, checked against its constraints; ValueError naming
    ``where`` (a configuration's ``section.setting``, or a command-line option). A group's value is an object of its
    settings (or its record); a value class's, what its ``from_setting`` reads (or its instance)."""
    if item.group is not None:
        if isinstance(value, item.group):
            return value
        if not isinstance(value, Mapping):
            raise ValueError(f"{where}: {item.help}; expected an object of its settings, got {value!r}")
        return parse(item.group, value, where)
    if item.value_class is not None:
        if isinstance(value, item.value_class) or (value is None and item.type.endswith(OPTIONAL)):
            return value
        return item.value_class.from_setting(value, where)  # type: ignore[attr-defined]
    if item.schema is not None:
        import jsonschema  # here: the records without a fragment do not need it

        error = jsonschema.exceptions.best_match(jsonschema.Draft202012Validator(item.schema).iter_errors(value))
        if error is not None:
            inner = "".join(f"[{p!r}]" if isinstance(p, int) else f".{p}" for p in error.absolute_path)
            raise ValueError(f"{where}{inner}: {item.help}; {error.message}")
        return value
    out = _value(item.type, value, where)
    _check(item, out, where)
    return out


def to_json(record: Any) -> dict[str, Any]:
    """A settings record as the JSON object ``parse`` reads back into an equal record: every setting, groups as
    objects, tuples as lists, a value class's value as its ``to_setting``."""
    return {item.name: _json_value(getattr(record, item.name)) for item in declared(type(record))}


def _json_value(value: Any) -> Any:
    if hasattr(value, "to_setting"):
        return value.to_setting()
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return to_json(value)
    if isinstance(value, tuple | list):
        return [_json_value(v) for v in value]
    if isinstance(value, Mapping):
        return {k: _json_value(v) for k, v in value.items()}
    return value


def json_default(item: Declared) -> Any:
    """The default of ``item`` as JSON data (a list for a tuple); TypeError for a marker (``REQUIRED``, ``UNSET``),
    which no configuration holds."""
    if isinstance(item.default, Marker):
        raise TypeError(f"{item.name}: its default is {item.default!r}, not a value")
    return _json_value(item.default)


JSON_TYPES = {"float": "number", "int": "integer", "str": "string", "bool": "boolean"}
# constraints -> JSON schema keywords: those on the values (of a list's items), then those on the list
ITEM_KEYWORDS = {"minimum": "minimum", "exclusive_minimum": "exclusiveMinimum", "maximum": "maximum",
                 "choices": "enum"}
LIST_KEYWORDS = {"min_items": "minItems", "max_items": "maxItems", "unique": "uniqueItems"}


def json_schema(cls: type) -> dict[str, Any]:
    """The JSON schema (draft 2020-12) of an object of ``cls``'s settings: each one's type, constraints, default
    and description (its help); no other key allowed, every one optional (a missing one takes its default) but a
    ``REQUIRED`` one; an ``UNSET`` one has no default."""
    properties = {}
    for item in declared(cls):
        node = _node(cls, item)
        default = {} if isinstance(item.default, Marker) else {"default": json_default(item)}
        properties[item.name] = {**node, **default, "description": item.help}
    required = [item.name for item in declared(cls) if item.default is REQUIRED]
    return {"type": "object", "additionalProperties": False, "default": {}, "properties": properties,
            **({"required": required} if required else {})}


def _node(cls: type, item: Declared) -> dict[str, Any]:
    """The JSON schema of ``item``'s values: its fragment, or its annotation's type with its constraints."""
    if item.schema is not None:
        return dict(item.schema)
    if item.group is not None:
        return json_schema(item.group)
    if item.value_class is not None:
        return {}  # what the class's from_setting reads: it checks the value itself
    kind = item.type.removesuffix(OPTIONAL)
    element = kind[len("tuple["):-len(", ...]")] if kind.startswith("tuple[") else kind
    if element not in JSON_TYPES or kind not in (element, f"tuple[{element}, ...]"):
        raise TypeError(f"{cls.__name__}.{item.name}: settings of type {item.type} are not supported")
    node: dict[str, Any] = {"type": JSON_TYPES[element]}
    node.update({ITEM_KEYWORDS[k]: list(v) if k == "choices" else v
                 for k, v in item.constraints.items() if k in ITEM_KEYWORDS})
    if kind != element:
        node = {"type": "array", "items": node,
                **{LIST_KEYWORDS[k]: v for k, v in item.constraints.items() if k in LIST_KEYWORDS}}
    if item.type.endswith(OPTIONAL):
        node["type"] = [node["type"], "null"]
        if "enum" in node:
            node["enum"] = [*node["enum"], None]
    return node
