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
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, TypeVar

from vpr_smr.core.suggest import did_you_mean

__all__ = ["REQUIRED", "UNSET", "Declared", "declared", "json_default", "json_schema", "parse", "read", "setting"]

T = TypeVar("T")

HELP = "help"
OPTIONAL = " | None"  # the annotation's text of a setting that may be null
CONSTRAINTS = ("minimum", "exclusive_minimum", "maximum", "choices", "min_items", "max_items", "unique")
SCHEMA = "schema"  # the metadata key of a setting's explicit JSON-schema fragment


class Marker:
    """A default that is no value: ``REQUIRED`` or ``UNSET``."""

    def __init__(self, name: str) -> None:
        self.name = name

    def __repr__(self) -> str:
        return self.name


REQUIRED = Marker("REQUIRED")
UNSET = Marker("UNSET")


def setting(default: Any, help: str, *, schema: dict[str, Any] | None = None, **constraints: Any) -> Any:
    """A field of a settings record: ``default`` (a tuple for a list of values: records are frozen; or ``REQUIRED``,
    ``UNSET``), one line of ``help``, and constraints of ``CONSTRAINTS``, or instead the JSON-schema fragment
    ``schema`` of a shape the annotation cannot say."""
    unknown = set(constraints) - set(CONSTRAINTS)
    if unknown:
        raise TypeError(f"setting: unknown constraints {sorted(unknown)}; known: {', '.join(CONSTRAINTS)}")
    if schema is not None and constraints:
        raise TypeError("setting: give constraints or a schema fragment, not both (the fragment says them)")
    extra = {} if schema is None else {SCHEMA: schema}
    return dataclasses.field(default=default, metadata={HELP: help, **constraints, **extra})


@dataclass(frozen=True)
class Declared:
    """One declared setting: its name, type annotation (as text), default, help and constraints."""

    name: str
    type: str
    default: Any
    help: str
    constraints: dict[str, Any]
    schema: dict[str, Any] | None = None  # an explicit JSON-schema fragment (``setting``'s ``schema``)


def declared(cls: type) -> tuple[Declared, ...]:
    """The settings ``cls`` declares, in order; TypeError naming a field that is not a ``setting``."""
    out = []
    for f in dataclasses.fields(cls):
        if HELP not in f.metadata:
            raise TypeError(f"{cls.__name__}.{f.name} is not declared with setting(default, help)")
        kind = f.type.__name__ if isinstance(f.type, type) else str(f.type)
        out.append(Declared(f.name, kind, f.default, f.metadata[HELP],
                            {k: f.metadata[k] for k in CONSTRAINTS if k in f.metadata}, f.metadata.get(SCHEMA)))
    return tuple(out)


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
    for item in ("float", "int"):
        if kind == f"tuple[{item}, ...]":
            if not isinstance(value, list | tuple):
                raise ValueError(f"{where}: expected a list of {item}s, e.g. [1.0], got {value!r}")
            return tuple(_value(item, v, f"{where}[{i}]") for i, v in enumerate(value))
    raise TypeError(f"{where}: settings of type {kind} are not supported (float, int, str, bool, tuples of them)")


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
    ``where`` (a configuration's ``section.setting``, or a command-line option)."""
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


def json_default(item: Declared) -> Any:
    """The default of ``item`` as JSON data (a list for a tuple); TypeError for a marker (``REQUIRED``, ``UNSET``),
    which no configuration holds."""
    if isinstance(item.default, Marker):
        raise TypeError(f"{item.name}: its default is {item.default!r}, not a value")
    return list(item.default) if isinstance(item.default, tuple) else item.default


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
