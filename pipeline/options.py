"""A settings record (``core.settings``) on the command line: its fields as options (``add_options``: ``max_iter``
is ``--max-iter``, with the field's type, default and help), the options read back as the record (``read_options``),
and a record as the options that give it (``flags``: the descriptors rule's speed settings). A group of settings
(``core.settings.group``) gives its options too; the sequence matcher is ``--matcher NAME`` plus the options of
that matcher's own ``Settings`` (``add_matcher_options``, ``read_matcher``), one ``MatcherSpec``."""

from __future__ import annotations

import argparse
import json
import shlex
from collections.abc import Callable
from typing import Any, TypeVar

from vpr_smr.core.settings import OPTIONAL, REQUIRED, Declared, Marker, declared, parse, read
from vpr_smr.eval.matching.matchers import DEFAULT_MATCHER, MATCHERS, MatcherSpec, available_matchers, matcher_class

__all__ = ["add_matcher_options", "add_options", "flags", "given_options", "matcher_of", "option",
           "read_matcher", "read_options"]

T = TypeVar("T")
MATCHER = "--matcher"
NULL = "none"  # the command line's word for a setting's null (``null`` in a configuration)
SCALARS: dict[str, Callable[[str], Any]] = {"float": float, "int": int, "str": str}
METAVARS = {"float": "X", "int": "N"}


def option(name: str) -> str:
    """The option of the setting ``name``: ``max_iter`` -> ``--max-iter``."""
    return "--" + name.replace("_", "-")


def _dest(group: str, name: str) -> str:
    return f"{group}:{name}"  # records side by side in one command keep their settings apart


def _element(kind: str) -> str:
    """The type of a setting's values: ``tuple[float, ...] | None`` -> ``float``."""
    base = kind.removesuffix(OPTIONAL)
    return base[len("tuple["):-len(", ...]")] if base.startswith("tuple[") else base


def _converter(kind: str) -> Callable[[str], Any]:
    """A word of the command line as the JSON value of a setting (or an item of a list setting) of type ``kind``."""
    optional = kind.endswith(OPTIONAL)
    element = _element(kind)
    scalar = SCALARS.get(element, str)

    def convert(word: str) -> Any:
        if optional and word == NULL:
            return None
        return scalar(word)

    convert.__name__ = element  # argparse names the type in its message: "invalid int value: 'x'"
    return convert


def _shown(value: Any) -> str:
    if value is None:
        return NULL
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, tuple | list):
        return " ".join(map(_shown, value))
    return str(value)


MAPPING = "dict[str, str]"  # NAME=VALUE items of one option
LISTS = "dict[str, tuple[str, ...]]"  # an option repeated per name: --evaluate val a.h5 b.h5 --evaluate test ...


def add_options(parser: argparse.ArgumentParser, cls: type, group: str, matcher: str = DEFAULT_MATCHER,
                required: bool = True) -> None:
    """``cls``'s settings as options of ``parser`` (``group``: a name that keeps them apart from another record's);
    an option not given keeps the setting's default (``read_options``). A group's settings (``settings.group``) are
    options of ``parser`` too; a ``MatcherSpec`` setting is ``--matcher`` and ``matcher``'s settings. ``required``:
    a ``REQUIRED`` setting's option must be given (not where another option gives them all, ``--job``)."""
    for item in declared(cls):
        if item.group is not None:
            add_options(parser, item.group, f"{group}.{item.name}", matcher, required)
            continue
        if item.value_class is MatcherSpec:
            add_matcher_options(parser, matcher)
            continue
        kind = item.type.removesuffix(OPTIONAL)
        extra = f"; {NULL}: null" if item.type.endswith(OPTIONAL) and item.default is not None else ""
        # no default shown: none to show, an empty list, or the help says it in words
        said = isinstance(item.default, Marker) or item.default == () or "(default" in item.help
        default = "" if said else f" (default: {_shown(item.default)}{extra})"
        text = f"{item.help}{default}".replace("%", "%%")
        names = (option(item.name), *map(option, item.aliases))  # an alias: the same option, another name
        common: dict[str, Any] = {"dest": _dest(group, item.name), "default": argparse.SUPPRESS, "help": text,
                                  "required": required and item.default is REQUIRED}
        if kind == "bool":
            parser.add_argument(*names, action=argparse.BooleanOptionalAction, **common)
            continue
        choices = item.constraints.get("choices")
        metavar = item.metavar or (None if choices else METAVARS.get(_element(kind), "TEXT"))
        if kind == LISTS:  # "SPLIT PATH": argparse shows SPLIT [PATH ...]
            shown = tuple(metavar.split()) if metavar and " " in metavar else metavar
            parser.add_argument(*names, nargs="+", action="append", metavar=shown, **common)
            continue
        many = kind.startswith("tuple[") or kind == MAPPING
        # a list whose default is empty, or that declares it may be, may be given with no items (the value ())
        empty = kind.startswith("tuple[") and (item.default == () or item.constraints.get("min_items") == 0)
        parser.add_argument(*names, type=_converter(item.type), choices=choices,
                            nargs=("*" if empty else "+") if many else None, metavar=metavar, **common)


def _mapping(item: Declared, value: Any) -> Any:
    """A mapping setting's words as JSON: NAME=VALUE items, or a repeated option's NAME ITEM... lists."""
    kind = item.type.removesuffix(OPTIONAL)
    name = option(item.name)
    if value == [None]:  # the word for null (``NULL``) of an optional one
        return value
    if kind == MAPPING:
        pairs = [word.split("=", 1) for word in value]
        bad = [word for word, pair in zip(value, pairs, strict=True) if len(pair) != 2]
        if bad:
            raise ValueError(f"{name} takes NAME=VALUE items, e.g. val=a.h5, got {', '.join(bad)}")
        return dict(pairs)
    if kind == LISTS:
        out: dict[str, list[str]] = {}
        for first, *rest in value:
            if not rest:
                raise ValueError(f"{name} {first}: give the name, then its items")
            if first in out:
                raise ValueError(f"{name} {first}: the name is given twice; give all its items after one {name}")
            out[first] = rest
        return out
    return value


def _given(args: argparse.Namespace, cls: type, group: str) -> dict[str, Any]:
    """The settings of ``cls`` given as options, each checked (a ValueError naming its option); a group's as an
    object of its own, a matcher's as its ``MatcherSpec``."""
    values: dict[str, Any] = {}
    for item in declared(cls):
        if item.group is not None:
            values[item.name] = _given(args, item.group, f"{group}.{item.name}")
        elif item.value_class is MatcherSpec:
            values[item.name] = read_matcher(args)
        elif hasattr(args, _dest(group, item.name)):
            value = _mapping(item, getattr(args, _dest(group, item.name)))
            values[item.name] = read(item, None if value == [None] else value, option(item.name))
    return values


def given_options(args: argparse.Namespace, cls: type, group: str) -> dict[str, Any]:
    """The settings of ``cls`` given as options, checked (a group's as an object of those of its settings given;
    a matcher's as its ``MatcherSpec``, given or not)."""
    return _given(args, cls, group)


def read_options(args: argparse.Namespace, cls: type[T], group: str) -> T:
    """The ``cls`` record of the options ``add_options`` added (the ones not given at their defaults)."""
    return parse(cls, _given(args, cls, group), "the options")


def _words(item: Declared, value: Any) -> list[str]:
    name = option(item.name)
    if isinstance(value, bool):
        return [name if value else "--no-" + name[2:]]
    if value is None:
        return [] if item.default is None else [name, NULL]
    return [name, *map(str, value)] if isinstance(value, tuple | list) else [name, str(value)]


def flags(record: Any) -> str:
    """The options that give ``record`` (a settings record), every setting, quoted: a rule's param, used unquoted in
    its shell command."""
    return shlex.join(word for item in declared(type(record)) for word in _words(item, getattr(record, item.name)))


# --- the sequence matcher: --matcher NAME and its settings ------------------------------------------------------


def add_matcher_options(parser: argparse.ArgumentParser, name: str = DEFAULT_MATCHER) -> None:
    """``--matcher`` and the options of ``name``'s settings (another matcher's options: give ``--matcher`` first on
    the command line, ``pipeline.cli`` builds the parser for it)."""
    # no argparse choices: listing the installed matchers reads every package's entry points (about 6 ms per
    # command that has the option, whenever a parser is built); read_matcher names an unknown one with the list
    parser.add_argument(MATCHER, default=name, metavar="NAME",
                        help=f"the sequence matcher (default {DEFAULT_MATCHER}; `vpr-smr matchers` lists them); its "
                             f"settings follow as options, e.g. vpr-smr COMMAND {MATCHER} NAME --help")
    add_options(parser, matcher_class(name).Settings, "matcher")
    parser.set_defaults(matcher_options=name)


def read_matcher(args: argparse.Namespace) -> MatcherSpec:
    """The ``MatcherSpec`` of ``--matcher`` and its settings' options."""
    name = args.matcher
    settings = matcher_class(name).Settings  # an unknown name: ValueError listing the available matchers
    if name != args.matcher_options:  # the options were built for another matcher (pipeline.cli reads --matcher first)
        raise ValueError(f"{MATCHER} {name}: write the option out in full ({MATCHER} {name} or {MATCHER}={name}): "
                         "the options of a matcher's settings come with the matcher named so")
    return MatcherSpec.of(name, _given(args, settings, "matcher"), f"{MATCHER} {name}")




def matcher_of(argv: list[str]) -> str:
    """The matcher ``argv`` names (``--matcher NAME`` or ``--matcher=NAME``, argparse's first pass of the command
    line), else the default: the parser is built with that matcher's options. An unknown name gives the default's,
    and ``read_matcher`` refuses the name listing the available ones."""
    first = argparse.ArgumentParser(add_help=False, allow_abbrev=False)
    first.add_argument(MATCHER, default=DEFAULT_MATCHER)
    name: str = first.parse_known_args(argv)[0].matcher
    return name if name in MATCHERS or name in available_matchers() else DEFAULT_MATCHER


def matcher_catalogue() -> str:
    """Every sequence matcher (built in, or registered by an installed package): its description, its native
    confidence, and each setting as a configuration key and an option, with its default and help."""
    lines = []
    for name in available_matchers():
        cls = matcher_class(name)
        default = " (the default)" if name == DEFAULT_MATCHER else ""
        lines.append(f"{name}{default}: {cls.description}")
        lines.append(f"  native confidence: the training-free scorer {cls.native_scorer}" if cls.native_scorer
                     else "  native confidence: its own, per query (the training-free scorer native)")
        for item in declared(cls.Settings):
            shown = json.dumps(list(item.default) if isinstance(item.default, tuple) else item.default)
            lines.append(f"  {item.name} ({option(item.name)}, default {shown}): {item.help}")
    lines.append("In a configuration: sequence_matching: {matcher: NAME, SETTING: VALUE, ...}; on the command line: "
                 "--matcher NAME --SETTING VALUE")
    return "\n".join(lines)
