"""Run configurations: YAML validated against ``config_schema.json``, with the schema's defaults filled in."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import yaml

SCHEMA_PATH = Path(__file__).with_name("config_schema.json")


class ConfigError(ValueError):
    """The configuration is invalid; the message names the file and the setting."""


def _fill_defaults(schema: dict[str, Any], value: dict[str, Any]) -> None:
    for key, sub in schema.get("properties", {}).items():
        if key not in value and "default" in sub:
            value[key] = json.loads(json.dumps(sub["default"]))
        if isinstance(value.get(key), dict) and sub.get("type") == "object":
            _fill_defaults(sub, value[key])


def validate(conf: dict[str, Any], source: str = "configuration") -> dict[str, Any]:
    import jsonschema

    schema = json.loads(SCHEMA_PATH.read_text())
    validator = jsonschema.Draft202012Validator(schema)
    errors = sorted(validator.iter_errors(conf), key=lambda e: list(e.absolute_path))
    if errors:
        lines = [f"  {'.'.join(str(p) for p in e.absolute_path) or '(top level)'}: {e.message}" for e in errors]
        raise ConfigError(f"{source} is invalid:\n" + "\n".join(lines))
    conf = json.loads(json.dumps(conf))
    _fill_defaults(schema, conf)
    return conf


def load_config(path: Path | str) -> dict[str, Any]:
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"configuration file not found: {path}")
    try:
        conf = yaml.safe_load(path.read_text())
    except yaml.YAMLError as error:
        raise ConfigError(f"{path} is not valid YAML: {error}") from None
    if not isinstance(conf, dict):
        raise ConfigError(f"{path} must hold a mapping of settings")
    return validate(conf, str(path))


def run_dir(conf: dict[str, Any]) -> Path:
    return Path(conf["output"]) / conf["run"]
