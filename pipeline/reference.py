"""What follows from the settings records (``core.settings``) and the command line: the configuration schema's
sections that are records (``config_schema``, written into ``config_schema.json``), the configuration reference of the
docs (``configuration_reference``, ``docs/configuration.md``) and the command-line reference (``cli_reference``,
``docs/cli.md``, from ``pipeline.cli``'s argument parser). The three files are generated:
``python -m vpr_smr.pipeline.reference --write`` writes them again after a record or an option changed, and a test
checks that the committed files are what the code gives.

A dataset entry's keys are ``datasets.settings.DatasetEntry``'s. The schema's other parts (the run's name, the
splits, the methods' entries, the speed experiment) are written in ``config_schema.json`` itself; the reference shows
them from there.
"""

from __future__ import annotations

import argparse
import json
import re
from pathlib import Path
from typing import Any

from vpr_smr.core.settings import REQUIRED, json_schema
from vpr_smr.datasets import LOADERS, loader
from vpr_smr.datasets.base import SHIPPED_DATA
from vpr_smr.datasets.settings import DatasetEntry
from vpr_smr.descriptors import BACKENDS, backend_class
from vpr_smr.descriptors.base import COMMON_SETTINGS_HELP
from vpr_smr.eval.matching.matchers import DEFAULT_MATCHER, ENTRY_POINT_GROUP, MATCHERS, matcher_class
from vpr_smr.pipeline.cli import build_parser
from vpr_smr.pipeline.config import MATCHER_KEY, RECORDS, SCHEMA_PATH
from vpr_smr.pipeline.options import option

__all__ = ["CLI_REFERENCE_PATH", "REFERENCE_PATH", "cli_reference", "commands", "config_schema",
           "configuration_reference", "dataset_entry_schema", "main"]

REFERENCE_PATH = Path(__file__).resolve().parents[1] / "docs" / "configuration.md"
CLI_REFERENCE_PATH = REFERENCE_PATH.with_name("cli.md")
WRITE_COMMAND = "python -m vpr_smr.pipeline.reference --write"


def _matching_schema() -> dict[str, Any]:
    """``sequence_matching``: the matcher's name; its settings beside it are checked by the matcher's own record
    (a plugin's too: the schema cannot list them)."""
    return {"type": "object", "default": {},
            "description": "method §§4, 11 and 14: the sequence matcher of every attributes, metrics and queries job: "
                           f"{{{MATCHER_KEY}: NAME, ...its settings}} (without {MATCHER_KEY}: {DEFAULT_MATCHER}'s "
                           "settings); each matcher's settings are listed in docs/configuration.md",
            "properties": {MATCHER_KEY: {"type": "string", "default": DEFAULT_MATCHER,
                                         "description": "the matcher's name: a built-in one or one an installed "
                                                        f"package registers (entry point group {ENTRY_POINT_GROUP})"}}}


def _described(record: type) -> str:
    """A record's docstring as a description: one line, ``code`` as `code`."""
    return " ".join((record.__doc__ or "").split()).replace("``", "`")


def dataset_entry_schema() -> dict[str, Any]:
    """A ``datasets`` entry: ``DatasetEntry``'s settings, with the loader's own keys beside them (the loader checks
    those: ``datasets.unknown_option``) and no default (an entry is never filled in)."""
    return {key: value for key, value in json_schema(DatasetEntry).items()
            if key not in ("additionalProperties", "default")}


def config_schema(committed: dict[str, Any]) -> dict[str, Any]:
    """``committed`` (``config_schema.json``'s JSON) with its record sections as the records give them."""
    schema: dict[str, Any] = json.loads(json.dumps(committed))
    properties = schema["properties"]
    for name, record in RECORDS.items():
        properties[name] = {**json_schema(record), "description": _described(record)}
    properties["sequence_matching"] = _matching_schema()
    properties["datasets"]["additionalProperties"] = dataset_entry_schema()
    return schema


def schema_text(schema: dict[str, Any]) -> str:
    return json.dumps(schema, indent=2, ensure_ascii=False) + "\n"


# --- the reference in the docs ----------------------------------------------------------------------------------

TYPE_WORDS = {"integer": "integer", "number": "number", "string": "text", "boolean": "true/false",
              "object": "mapping", "array": "list", "null": "null"}
BOUNDS = (("minimum", ">= {}"), ("exclusiveMinimum", "> {}"), ("maximum", "<= {}"))


def _type(node: dict[str, Any]) -> str:
    """A schema node's type in words: ``list of integers >= 1``, ``integer or null``."""
    if "enum" in node:
        return "one of " + ", ".join(f"`{json.dumps(value)}`" for value in node["enum"])
    if ("anyOf" in node or "oneOf" in node) and "type" not in node:  # forms of one type: that type
        return " or ".join(_type(sub) for sub in node.get("anyOf", node.get("oneOf", [])))
    if "const" in node:
        return f"`{json.dumps(node['const'])}`"
    kinds = node.get("type", "object")
    kinds = kinds if isinstance(kinds, list) else [kinds]
    words = []
    for kind in kinds:
        if kind == "array":
            items = node.get("items", {})
            if "minItems" in node and node["minItems"] == node.get("maxItems"):
                count = [f"{node['minItems']}"]
            else:
                count = [text.format(node[key]) for key, text in (("minItems", "at least {}"),
                                                                   ("maxItems", "at most {}")) if key in node]
            count += ["distinct"] if node.get("uniqueItems") else []
            what = f"list ({', '.join(count)})" if count else "list"
            words.append(f"{what} of {_type(items)}" if items else what)
        else:
            bounds = [text.format(node[key]) for key, text in BOUNDS if key in node and kind != "null"]
            words.append(" ".join([str(TYPE_WORDS.get(kind, kind)), *bounds]))
    return " or ".join(words)


# the record sections that are also options of stage commands (pipeline.cli adds them with pipeline.options)
COMMANDS = {"baselines": "`vpr-smr metrics`, `queries` and `baselines`", "extraction": "`vpr-smr descriptors`"}


def _sentence(text: str) -> str:
    return (text[:1].upper() + text[1:]).rstrip(".") + "." if text else ""


# Markdown that a help text or description must not trigger: a table's bar, raw HTML (``<output>``), emphasis
# (``r*``) and the docs' maths (``$``).
ESCAPES = str.maketrans({"|": "\\|", "<": "&lt;", "*": "\\*", "$": "\\$", "\n": " "})


def _cell(text: str) -> str:
    """``text`` in a table cell: code spans (between backticks) as they are, the rest escaped."""
    parts = text.split("`")
    return "`".join(part.replace("|", "\\|") if i % 2 else part.translate(ESCAPES) for i, part in enumerate(parts))


def _head(*columns: str) -> list[str]:
    return ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]


def _row(cells: Any) -> str:
    """A table row of ``cells``, each escaped (``_cell``)."""
    return "| " + " | ".join(_cell(cell) for cell in cells) + " |"


def _default(node: dict[str, Any]) -> str:
    return f"`{json.dumps(node['default'])}`" if "default" in node else "required" if node.get("required") else ""


def _table(properties: dict[str, Any], required: list[str], prefix: str = "",
           options: bool = False) -> list[str]:
    lines = _head("setting", "type", "default", *(["option"] if options else []), "description")
    for key, node in properties.items():
        default = _default(node) or ("required" if key in required else "")
        cells = [f"`{prefix}{key}`", _type(node), default]
        if options:
            cells.append(f"`{option(key)}`")
        cells.append(node.get("description", ""))
        lines.append(_row(cells))
    return lines


def configuration_reference(schema: dict[str, Any]) -> str:
    """The configuration reference (Markdown) of the whole ``schema`` and of every built-in matcher's settings."""
    properties = schema["properties"]
    lines = ["# Configuration reference", "",
             "Every setting of a run's configuration (a YAML file, `vpr-smr run my.yaml`), as "
             "`pipeline/config_schema.json` checks it. Generated from the settings records and the schema by "
             f"`{WRITE_COMMAND}`: do not edit it by hand. A section that is a settings record is also a set of "
             "command-line options of the stage commands (`vpr-smr COMMAND --help`).", "",
             "## Top level", ""]
    lines += _table({key: node for key, node in properties.items() if node.get("type") != "object"},
                    schema.get("required", []))
    for key, node in properties.items():
        if node.get("type") != "object":
            continue
        lines += ["", f"## `{key}`", ""] + ([_sentence(node["description"]), ""] if "description" in node else [])
        if key == "sequence_matching":
            lines += _table(node["properties"], [], f"{key}.")
            lines += _matchers(key)
        elif "additionalProperties" in node and isinstance(node["additionalProperties"], dict):
            entry = node["additionalProperties"]
            lines += ["Each entry's keys:", ""]
            lines += _table(entry.get("properties", {}), entry.get("required", []), f"{key}.NAME.")
            if key == "datasets":
                lines += _loaders(key, set(entry.get("properties", {})))
            if key == "methods":
                lines += _backends(key, set(entry.get("properties", {})))
        else:
            if key in COMMANDS:
                lines += [f"Also options of {COMMANDS[key]}.", ""]
            lines += _table(node.get("properties", {}), node.get("required", []), f"{key}.",
                            options=key in COMMANDS)
    return "\n".join(lines) + "\n"


# Python's type names as the schema's (whose words TYPE_WORDS gives)
SCHEMA_TYPES = {"bool": "boolean", "int": "integer", "float": "number", "str": "string", "list": "array",
                "dict": "object", "None": "null", "NoneType": "null"}


def _python_type(annotation: str) -> str:
    """A loader parameter's annotation in the reference's words: ``Path | str | None`` is ``path or null`` (a path
    may be given as text)."""
    parts = [part.strip() for part in annotation.split("|")]
    kinds = ["path" if part == "Path" else _type({"type": SCHEMA_TYPES[part]}) for part in parts
             if not (part == "str" and "Path" in parts)]
    return " or ".join(kinds)


def _shown_default(value: Any) -> str:
    """A default as the reference shows it: a shipped file by its path in a checkout (``data/lists/...``)."""
    if value is REQUIRED:
        return "required"
    if isinstance(value, Path):
        return f"`{value.relative_to(SHIPPED_DATA.parent).as_posix()}`" if value.is_relative_to(SHIPPED_DATA) else \
            f"`{value}`"
    return f"`{json.dumps(value)}`"


def _loaders(key: str, entry_keys: set[str]) -> list[str]:
    """Each built-in loader's own settings (those not among the entry's keys above), as its ``Settings`` record
    declares them."""
    lines: list[str] = []
    for name in sorted(LOADERS):
        own = [item for item in loader(name).settings() if item.name not in entry_keys]
        lines += ["", f"### loader `{name}`", ""]
        if not own:
            lines += [f"No settings of its own: `{key}.NAME.loader: {name}` and the entry's keys above."]
            continue
        lines += [f"With `{key}.NAME.loader: {name}`, besides the entry's keys above:", "",
                  *_head("setting", "type", "default", "description")]
        lines += [_row((f"`{key}.NAME.{item.name}`", _python_type(item.type), _shown_default(item.default),
                        item.help.rstrip("."))) for item in own]
    return lines


def _typed(default: Any, text: str) -> tuple[str, str]:
    """A backend setting's type and meaning. The type follows from the default; a default of null or auto says
    nothing of it, so such a setting's help starts with its type (``integer or null: ...``)."""
    if default is None or default == "auto":
        kind, _, meaning = text.partition(": ")
        # a null default is a value the setting takes: its type says so, whatever the help's words
        return (kind if default is not None or re.search(r"\bnull\b", kind) else f"{kind} or null"), meaning
    return _type({"type": SCHEMA_TYPES[type(default).__name__]}), text


def _backends(key: str, entry_keys: set[str]) -> list[str]:
    """The settings every backend takes (absent or null: each one's default, as its description says), then each
    built-in backend's own: default from its ``default_conf``, meaning from its ``settings_help``."""
    head = _head("setting", "type", "default", "description")
    lines = ["", "### Every backend", "", f"Besides `backend` and `checkpoint`, every entry of `{key}` takes:", "",
             *head]
    for name, text in COMMON_SETTINGS_HELP.items():
        if name not in entry_keys:
            kind, meaning = _typed(None, text)
            lines.append(_row((f"`{key}.NAME.{name}`", kind, "`null`", meaning)))
    for name in sorted(BACKENDS):
        cls = backend_class(name)
        lines += ["", f"### backend `{name}`", ""]
        if not cls.default_conf:
            lines += [f"No settings of its own: `{key}.NAME.backend: {name}` and those of every backend."]
            continue
        lines += [f"With `{key}.NAME.backend: {name}`, besides those of every backend:", "", *head]
        for setting, default in cls.default_conf.items():
            kind, meaning = _typed(default, cls.settings_help.get(setting, ""))
            lines.append(_row((f"`{key}.NAME.{setting}`", kind, f"`{json.dumps(default)}`", meaning)))
    return lines


def _matchers(key: str) -> list[str]:
    """Each built-in matcher's settings, as ``sequence_matching`` and the command line give them."""
    lines: list[str] = []
    for name in sorted(MATCHERS):
        cls = matcher_class(name)
        lines += ["", f"### matcher `{name}`", "", f"{_sentence(cls.description)} On the command line of "
                  f"`vpr-smr attributes`, `metrics`, `queries`, `baselines` and `inspect`: `--matcher {name}` and "
                  "these options.", ""]
        record = {"type": "object", "properties": json_schema(cls.Settings)["properties"]}
        lines += _table(record["properties"], [], f"{key}.", options=True)
    return lines


# --- the command-line reference ----------------------------------------------------------------------------------

def commands(parser: argparse.ArgumentParser, name: str = "") -> dict[str, argparse.ArgumentParser]:
    """Every command of ``parser`` by its words (``""`` for ``vpr-smr`` itself, ``"dataset check"``), in the order
    ``--help`` lists them."""
    found = {name: parser}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for word, subparser in action.choices.items():
                found.update(commands(subparser, f"{name} {word}".strip()))
    return found


def _helps(parser: argparse.ArgumentParser) -> dict[str, str]:
    """Each subcommand's one-line help, by its word (argparse keeps it on the choices action, not the subparser)."""
    return {choice.dest: choice.help or "" for action in parser._actions
            if isinstance(action, argparse._SubParsersAction) for choice in action._choices_actions}


def _description(parser: argparse.ArgumentParser, text: str) -> list[str]:
    """A command's description as Markdown. A raw one (its line breaks kept by the parser, as the top level's) keeps
    its lines: each command line as code, each numbered step as a list item."""
    if parser.formatter_class is not argparse.RawDescriptionHelpFormatter:
        return [_sentence(" ".join(text.split())).translate(ESCAPES)]
    paragraphs = text.strip().split("\n\n")
    lines = [" ".join(paragraphs[0].split()).translate(ESCAPES)]
    for line in "\n".join(paragraphs[1:]).splitlines():
        stripped = line.strip()
        if stripped.startswith("vpr-smr "):
            lines.append(f"   - `{stripped}`")
        elif stripped[:1].isdigit():
            lines.append(stripped.translate(ESCAPES))
        elif stripped:
            lines += ["", stripped.translate(ESCAPES), ""]
    return lines


def _argument(action: argparse.Action) -> str:
    if action.nargs == 0:
        return ""
    shown = action.metavar if isinstance(action.metavar, str) else \
        "{" + ",".join(map(str, action.choices)) + "}" if action.choices else action.dest.upper()
    return {"?": f"[{shown}]", "*": f"[{shown} ...]", "+": f"{shown} [...]"}.get(str(action.nargs), shown)


def _options(parser: argparse.ArgumentParser, skip: set[str] | frozenset[str] = frozenset()) -> list[argparse.Action]:
    return [action for action in parser._actions
            if not isinstance(action, argparse._SubParsersAction | argparse._HelpAction)
            and action.help != argparse.SUPPRESS and not set(action.option_strings) & skip]


def _option_rows(actions: list[argparse.Action]) -> list[str]:
    lines = _head("option", "argument", "default", "description")
    for action in actions:
        names = ", ".join(action.option_strings) or action.dest
        required = action.required or not action.option_strings and action.nargs not in ("?", "*")
        # a flag (no argument) is off unless given, whatever value its destination then holds (--no-restoration
        # leaves restoration true): it has no default to show
        flag = action.nargs == 0
        default = "required" if required else "" if flag or action.default in (None, False, argparse.SUPPRESS) \
            else json.dumps(action.default)
        argument = _argument(action)
        lines.append(_row((f"`{names}`", f"`{argument}`" if argument else "",
                           f"`{default}`" if default and default != "required" else default, action.help or "")))
    return lines


def cli_reference() -> str:
    """The command-line reference (Markdown): every command of ``vpr-smr`` with its options, as the argument parser
    gives them, and each matcher's options of the commands that take ``--matcher``."""
    default = build_parser()
    found = commands(default)
    lines = ["# Command-line reference", "",
             "Every command and option of `vpr-smr`, as its argument parser defines them (`vpr-smr COMMAND --help` "
             f"prints the same). Generated from the parser by `{WRITE_COMMAND}`: do not edit it by hand. The "
             "options of the stage commands that are settings of a run's configuration are listed with their "
             "settings in the [configuration reference](configuration.md). A stage command's options are the "
             "settings of its job record, declared once with the stage (`vpr_smr.pipeline.stages`): `--job` gives "
             "them all as one JSON object instead (`{\"seq_len\": 4, \"truth\": {\"tolerance\": 2}, ...}`, "
             "groups of options as objects), as the workflow's rules do, and `vpr_smr.api.run_stage` runs the same "
             "stage from Python.", ""]
    for words, parser in found.items():
        parent = found[words.rpartition(" ")[0]] if words else None
        text = parser.description or (_helps(parent).get(words.rpartition(" ")[2], "") if parent else "")
        lines += [f"## vpr-smr {words}".rstrip(), ""] + _description(parser, text) + [""]
        subcommands = _helps(parser)
        if subcommands:
            lines += _head("command", "what it does")
            lines += [_row((f"`{f'vpr-smr {words} {word}'.replace('  ', ' ')}`", help_))
                      for word, help_ in subcommands.items()] + [""]
        if _options(parser):
            lines += _option_rows(_options(parser)) + [""]
        if parser.epilog and words:
            lines += [_sentence(_cell(" ".join(parser.epilog.split()))), ""]
    lines += ["## The matchers' options", "",
              "The commands that take `--matcher NAME` (" + ", ".join(
                  f"`vpr-smr {words}`" for words, parser in found.items()
                  if any("--matcher" in action.option_strings for action in parser._actions)) +
              f") take that matcher's settings as options; those of `{DEFAULT_MATCHER}` are listed above.", ""]
    shown = {option for action in _options(found["attributes"]) for option in action.option_strings}
    for name in sorted(MATCHERS):
        if name == DEFAULT_MATCHER:
            continue
        matcher_parser = commands(build_parser(name))["attributes"]
        lines += [f"### `--matcher {name}`", ""]
        lines += _option_rows(_options(matcher_parser, skip=shown)) + [""]
    return "\n".join(lines).rstrip() + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="write the files that follow from the settings records and the "
                                                 "command line")
    parser.add_argument("--write", action="store_true",
                        help="write config_schema.json, docs/configuration.md and docs/cli.md")
    args = parser.parse_args(argv)
    schema = config_schema(json.loads(SCHEMA_PATH.read_text()))
    texts = {SCHEMA_PATH: schema_text(schema), REFERENCE_PATH: configuration_reference(schema),
             CLI_REFERENCE_PATH: cli_reference()}
    stale = [path for path, text in texts.items() if not path.is_file() or path.read_text() != text]
    if args.write:
        for path in stale:
            path.write_text(texts[path])
            print(f"wrote {path}")
        return 0
    for path in stale:
        print(f"{path} is not what the settings records give: run {WRITE_COMMAND}")
    return 1 if stale else 0


if __name__ == "__main__":
    raise SystemExit(main())
