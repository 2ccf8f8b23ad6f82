"""Run configurations: YAML validated against ``config_schema.json``, with the schema's defaults filled in, as a
typed frozen record (``Config``) that the workflow, its rules and the plan read by attribute. The sections that are
settings records (``RECORDS``) are the records themselves; ``pipeline.reference`` writes their part of the schema."""

from __future__ import annotations

import dataclasses
import json
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

from vpr_smr.core.settings import declared, parse, setting
from vpr_smr.core.suggest import did_you_mean
from vpr_smr.eval.matching.matchers import NAME_KEY, MatcherSpec, matcher_class
from vpr_smr.eval.predictor.defaults import PredictorSettings
from vpr_smr.eval.scoring.deployment_jobs import DeploymentSettings
from vpr_smr.eval.scoring.scorers import BaselineSettings
from vpr_smr.eval.scoring.study_jobs import SpeedExperiment

SCHEMA_PATH = Path(__file__).with_name("config_schema.json")


class ConfigError(ValueError):
    """The configuration is invalid; the message names the file and the setting."""


def _fill_defaults(schema: dict[str, Any], value: dict[str, Any]) -> None:
    for key, sub in schema.get("properties", {}).items():
        if key not in value and "default" in sub:
            value[key] = json.loads(json.dumps(sub["default"]))
        if isinstance(value.get(key), dict) and sub.get("type") == "object":
            _fill_defaults(sub, value[key])


def schema_default(*keys: str) -> Any:
    """The schema's default of a setting, e.g. ``schema_default("predictor", "seeds")``."""
    node = json.loads(SCHEMA_PATH.read_text())
    for key in keys:
        node = node["properties"][key]
    return node["default"]


def _hint(error: Any) -> str:
    """What a value that fits none of a setting's forms should look like: that setting's own description (the
    message of ``oneOf``/``anyOf`` names no form)."""
    described = error.validator in ("oneOf", "anyOf") and isinstance(error.schema.get("description"), str)
    return f" ({error.schema['description']})" if described else ""


def _where(path: Iterable[Any]) -> str:
    return ".".join(str(p) for p in path)


def _unexpected_keys(error: Any) -> list[str]:
    """An object with keys its schema does not allow: each key with the closest allowed one and all of them
    (jsonschema's own message names the key only)."""
    allowed = list(error.schema.get("properties", {}))
    where = _where(error.absolute_path)
    lines = []
    for key in error.instance:
        if key in allowed:
            continue
        lines.append(f"{_where([*error.absolute_path, key])}: unexpected key {key!r}{did_you_mean(str(key), allowed)}; "
                     f"{where or 'the top level'} allows: {', '.join(allowed)}")
    return lines


def _character_class(pattern: str) -> str | None:
    """The body of a pattern of the form ``^[...]+$`` (a name of allowed characters), else None."""
    match = re.fullmatch(r"\^\[([^\]^\\]+)\][+*]\$", pattern)
    return match.group(1) if match else None


def _describe_class(body: str) -> str:
    """``A-Za-z0-9_.-`` -> ``letters A-Z a-z, digits 0-9, '_', '.' and '-'``: the allowed characters in words."""
    letters, parts, i = [], [], 0
    while i < len(body):
        if i + 2 < len(body) and body[i + 1] == "-":
            lo, hi = body[i], body[i + 2]
            if lo.isalpha():
                letters.append(f"{lo}-{hi}")
            else:
                parts.append(f"digits {lo}-{hi}" if lo.isdigit() else f"{lo!r} to {hi!r}")
            i += 3
        else:
            parts.append(repr(body[i]))
            i += 1
    if letters:
        parts.insert(0, "letters " + " ".join(letters))
    return parts[0] if len(parts) == 1 else f"{', '.join(parts[:-1])} and {parts[-1]}"


def _shown(character: str) -> str:
    return "a space" if character == " " else repr(character)


def _pattern_message(error: Any) -> str:
    """A string that does not match its pattern: which characters are allowed and which of the string's are not,
    in words (the regular expression alone tells a user little)."""
    body = _character_class(error.validator_value)
    what = f"the name {error.instance!r}" if "propertyNames" in error.schema_path else repr(error.instance)
    if body is None or not isinstance(error.instance, str):
        return f"{what} does not have the form {error.validator_value}"
    allowed = _describe_class(body)
    if not error.instance:
        return f"{what} is empty; use at least one of {allowed}"
    bad: dict[str, int] = {}
    for position, character in enumerate(error.instance, 1):
        if re.fullmatch(f"[{body}]", character) is None:
            bad.setdefault(character, position)
    listed = [f"{_shown(c)} (character {position})" for c, position in bad.items()]
    has = listed[0] if len(listed) == 1 else f"{', '.join(listed[:-1])} and {listed[-1]}"
    return f"{what} is not allowed: it has {has}; use only {allowed}"


def _messages(error: Any) -> list[str]:
    """One line per problem of a jsonschema error, each starting with the setting's dotted path."""
    if error.validator == "additionalProperties" and isinstance(error.instance, dict) and error.schema.get(
            "additionalProperties") is False:
        return _unexpected_keys(error)
    where = _where(error.absolute_path) or "(top level)"
    if error.validator == "pattern":
        return [f"{where}: {_pattern_message(error)}"]
    lines = [f"{where}: {error.message}{_hint(error)}"]
    if error.validator in ("oneOf", "anyOf"):
        # a form that is an object with a misspelt key: name the key, as for any other object
        for sub in error.context:
            if sub.validator == "additionalProperties" and sub.schema.get("additionalProperties") is False:
                lines += _unexpected_keys(sub)
    return lines


# --- the validated configuration as a record -----------------------------------------------------------------


@dataclass(frozen=True)
class Section:
    """A part of a validated configuration: its settings as typed fields, and as the validated JSON they were read
    from (``to_json``, a fresh copy each time), which the jobs' params, the report's settings and the plan's digest
    take: their texts are what the configuration gives (``1`` stays ``1``, the keys keep their order), so that a
    run reruns exactly what it did before."""

    source: str = field(repr=False, kw_only=True)  # the validated JSON text

    def to_json(self) -> Any:
        return json.loads(self.source)


def _text(value: Any) -> str:
    return json.dumps(value)


def _own(record: type, values: dict[str, Any]) -> dict[str, Any]:
    """The settings of ``values`` that ``record`` declares."""
    names = {item.name for item in declared(record)}
    return {key: value for key, value in values.items() if key in names}


@dataclass(frozen=True)
class PredictorSection(PredictorSettings, Section):
    """``predictor``: ``SMRPredictor``'s arguments, every one (validation fills in the record's defaults), and the
    validated JSON the jobs' params take."""


@dataclass(frozen=True)
class Extraction:
    """How fast descriptors are computed: a job's resource, not a param (no result depends on it)."""

    batch_size: int | None = setting(
        None, "images per batch; null: about 600k input values a batch on the CPU, 32 images on a GPU", minimum=1)
    num_workers: int | None = setting(
        None, "image-decoding worker processes; null: one per 4 CPU cores (at most 4) on the CPU, up to 4 with a GPU",
        minimum=0)


@dataclass(frozen=True)
class Experiments:
    """Which experiments beyond Table I and the predictor's own scores run."""

    trust_levels: bool = setting(True, "PR curves and AUC at every trust level")
    restoration: bool = setting(True, "match restoration (method §9)")
    attribute_ablation: bool = setting(True, "Table II: a predictor per attribute")
    leave_one_method_out: bool = setting(True, "a predictor without each method, tested on it")
    seq_len_ablation: bool = setting(True, "table and figure over every L of seq_lens (needs two or more)")
    speed: bool = setting(True, "simulated speed profiles (method §11) at table_seq_len: the fixed matcher against "
                                "velocity search, see `speed`")
    protocol_sweep: bool = setting(True, "method §13: recall@1 and Table I's reduction at table_seq_len over the "
                                         "tolerances 0, 1, 2, 5 and 10 frames (radii 5, 10, 25 and 50 with "
                                         "positions); datasets whose ground truth is a file have none")
    matchers: bool = setting(True, "method §14: each matcher of `matchers` with its own predictor at table_seq_len: "
                                   "Table I's numbers, the best training-free scorer and the matcher's own "
                                   "confidence, on the queries every matcher evaluates")
    adaptive_seq_len: bool = setting(True, "method §15: the sequence length chosen per query by each length's "
                                           "predictor (or uniqueness) against every fixed length, for every "
                                           "matcher of the run (needs two or more seq_lens)")
    deployment: bool = setting(True, "method §16: thresholds calibrated on the calibration split by each rule "
                                     "(empirical, guaranteed, same_fraction) for every confidence source and "
                                     "scored on the other evaluation splits and datasets, at table_seq_len, for "
                                     "every matcher of the run (needs a second evaluation split or dataset), see "
                                     "`deployment`")


# The sections of a configuration that are settings records (core.settings): their part of config_schema.json (the
# record's docstring its description), of docs/configuration.md and of ``Config`` follows from the record
# (pipeline.reference).
RECORDS: dict[str, type] = {"baselines": BaselineSettings, "extraction": Extraction, "predictor": PredictorSettings,
                            "experiments": Experiments, "speed": SpeedExperiment,
                            "deployment": DeploymentSettings}
# ``sequence_matching``: {matcher: NAME, ...that matcher's settings}, validated by the matcher's own record
MATCHER_KEY = NAME_KEY  # the matcher's name among its settings


@dataclass(frozen=True)
class DatasetSettings(Section):
    """A dataset of ``datasets``: its name, loader and the settings every loader shares; ``to_json`` is the whole
    entry as given, which the loader reads (each loader has its own keys and checks them)."""

    name: str
    loader: str
    root: str | None  # None: not given, or null
    tolerance: int | None  # None: the loader's
    radius: float | None  # frames with positions only


@dataclass(frozen=True)
class MethodSettings(Section):
    """A method of ``methods``: its name, backend, checkpoint and distance; ``to_json`` is the whole entry as given,
    which the backend reads (each backend has its own settings and checks them)."""

    name: str
    backend: str
    checkpoint: str | None
    distance: str | None  # None: the backend's


@dataclass(frozen=True)
class Config(Section):
    """A validated run configuration (``validate``), with every default filled in: ``config_schema.json``'s (those
    of the settings records, ``RECORDS``, among them), the matcher's and ``table_seq_len``'s. ``datasets`` and
    ``methods`` keep the configuration's order (the methods': the pooled training order)."""

    run: str
    output: str
    seq_lens: tuple[int, ...]
    modes: tuple[str, ...]
    sequence_matching: MatcherSpec
    baselines: BaselineSettings
    train_split: str
    allow_split_overlap: bool
    eval_splits: tuple[str, ...]
    table_split: str
    trust_levels: tuple[float, ...]
    seeds: int
    extraction: Extraction
    predictor: PredictorSection
    datasets: Mapping[str, DatasetSettings]
    methods: Mapping[str, MethodSettings]
    table_seq_len: int
    experiments: Experiments
    speed: SpeedExperiment  # the speed experiment's profiles and velocity search set
    matchers: tuple[MatcherSpec, ...]  # the experiment ``matchers``' compared matchers (its default: every built-in)
    deployment: DeploymentSettings  # the experiment deployment's targets, risk, segment and calibration split

    @property
    def calibration_split(self) -> str:
        """The experiment deployment's calibration split (method §16): ``deployment.calibration``, else the
        validation split (the first of eval_splits)."""
        return self.deployment.calibration or self.eval_splits[0]

    @property
    def run_dir(self) -> Path:
        """``<output>/<run>``: the run's folder."""
        return Path(self.output) / self.run

    @property
    def validation_split(self) -> str | None:
        """The predictor's validation split (``predictor.defaults.validation_split``: the first of eval_splits)."""
        from vpr_smr.eval.predictor.defaults import validation_split

        return validation_split(self.eval_splits)

    @classmethod
    def from_json(cls, conf: dict[str, Any]) -> Config:
        """The record of a validated configuration (``validate``'s JSON, every default filled in)."""
        datasets = {name: DatasetSettings(name, str(d["loader"]), d.get("root"), d.get("tolerance"), d.get("radius"),
                                          source=_text(d)) for name, d in conf["datasets"].items()}
        methods = {name: MethodSettings(name, str(m["backend"]), m.get("checkpoint"), m.get("distance"),
                                        source=_text(m)) for name, m in conf["methods"].items()}
        # a record's own settings: ``experiments`` holds the installed packages' experiments too (``experiments``)
        sections: dict[str, Any] = {name: parse(record, _own(record, conf[name]), name)
                                    for name, record in RECORDS.items()}
        matching = {key: value for key, value in conf["sequence_matching"].items() if key != MATCHER_KEY}
        return cls(
            conf["run"], conf["output"], tuple(conf["seq_lens"]), tuple(conf["modes"]),
            MatcherSpec.of(conf["sequence_matching"][MATCHER_KEY], matching), sections["baselines"],
            conf["train_split"], conf["allow_split_overlap"], tuple(conf["eval_splits"]), conf["table_split"],
            tuple(conf["trust_levels"]), conf["seeds"], sections["extraction"],
            PredictorSection(**dataclasses.asdict(sections["predictor"]), source=_text(conf["predictor"])),
            MappingProxyType(datasets), MappingProxyType(methods), conf["table_seq_len"], sections["experiments"],
            # profiles: its schema fragment keeps the JSON list; a tuple in the frozen record
            dataclasses.replace(sections["speed"], profiles=tuple(sections["speed"].profiles)),
            tuple(_experiment_matchers(conf["matchers"])),
            dataclasses.replace(sections["deployment"], precisions=tuple(sections["deployment"].precisions)),
            source=_text(conf))


def validate(conf: dict[str, Any], source: str = "configuration") -> Config:
    """The configuration ``conf`` (a mapping of settings, e.g. a YAML file's) checked against the schema and for
    settings that are valid alone but not together, with every default filled in, as a ``Config``; a
    ``ConfigError`` names every problem (``source``: the file, for the message)."""
    return Config.from_json(validated_json(conf, source))


def validated_json(conf: dict[str, Any], source: str = "configuration") -> dict[str, Any]:
    """``validate``'s configuration as JSON: the mapping ``Config`` is read from (and ``Config.to_json`` gives)."""
    import jsonschema

    schema = _with_plugin_experiments(json.loads(SCHEMA_PATH.read_text()))
    validator = jsonschema.Draft202012Validator(schema)
    errors = sorted(validator.iter_errors(conf), key=lambda e: list(e.absolute_path))
    if errors:
        lines = [f"  {line}" for e in errors for line in _messages(e)]
        raise ConfigError(f"{source} is invalid:\n" + "\n".join(lines))
    conf = json.loads(json.dumps(conf))
    _fill_defaults(schema, conf)
    # the predictor's settings in its record's order, as SMRPredictor lists its arguments (the report shows them)
    conf["predictor"] = {item.name: conf["predictor"][item.name] for item in declared(PredictorSettings)}
    _sequence_matching(conf, source)
    _compared_matchers(conf, source)
    _check_together(conf, source)
    _resolve_ground_truth_files(conf, source)
    return conf


def _with_plugin_experiments(schema: dict[str, Any]) -> dict[str, Any]:
    """``schema`` with each experiment an installed package registers (``pipeline.experiment``) as a key of
    ``experiments`` (off unless given; no default, so that a configuration's JSON is the same with or without the
    package installed): an unknown key's message lists them with the built-in ones."""
    from vpr_smr.pipeline.experiment import plugin_experiments  # here: it loads the installed packages' modules

    section = schema["properties"]["experiments"]["properties"]
    for experiment in plugin_experiments():
        section.setdefault(experiment.name, {"type": "boolean", "description": experiment.help})
    return schema


def _resolve_ground_truth_files(conf: dict[str, Any], source: str) -> None:
    """A dataset's ground-truth file given relative is looked for from the configuration's folder (method §13): the
    file belongs to the configuration, wherever vpr-smr runs. Written back as that path, so that the jobs, the
    report and the plan name the one file."""
    folder = Path(source).parent if Path(source).is_file() else Path(".")
    for dataset in conf["datasets"].values():
        entry = dataset.get("ground_truth")
        for form in ("matrix", "lists"):
            if entry is not None and form in entry and not Path(entry[form]).is_absolute():
                entry[form] = str(folder / entry[form])


def _sequence_matching(conf: dict[str, Any], source: str) -> None:
    """``sequence_matching`` checked by its matcher's settings record (a plugin matcher's too) and written back
    complete and canonical (``MatcherSpec``: every setting, defaults filled in), so that the jobs' params, the
    report and the plan name one matcher; without ``matcher``, the settings are the default matcher's."""
    given = conf["sequence_matching"]
    name = given[MATCHER_KEY]
    try:
        matcher_class(name)  # an unknown name: the message lists the available matchers
    except ValueError as error:
        raise ConfigError(f"{source} is invalid:\n  sequence_matching.{MATCHER_KEY}: {error}") from None
    try:
        spec = MatcherSpec.of(name, {key: value for key, value in given.items() if key != MATCHER_KEY},
                              "sequence_matching")
    except ValueError as error:
        raise ConfigError(f"{source} is invalid:\n  {error}") from None
    conf["sequence_matching"] = {MATCHER_KEY: spec.name, **spec.values}


def _experiment_matchers(values: Any) -> list[MatcherSpec]:
    # imported here: every stage command imports this module, and the experiment's module (with the scoring
    # records it needs) cost `vpr-smr attributes` 37 ms
    from vpr_smr.eval.scoring.matcher_comparison import experiment_matchers

    return experiment_matchers(values)


def _compared_matchers(conf: dict[str, Any], source: str) -> None:
    """``matchers`` (the experiment ``matchers``, method §14) checked by each matcher's settings record and written
    back complete and canonical, as ``sequence_matching`` is (``null``: every built-in matcher at its defaults)."""
    try:
        specs = _experiment_matchers(conf["matchers"])
    except ValueError as error:
        raise ConfigError(f"{source} is invalid:\n  {error}") from None
    conf["matchers"] = [{MATCHER_KEY: spec.name, **spec.values} for spec in specs]


def _check_together(conf: dict[str, Any], source: str) -> None:
    """Settings that are valid alone but not together; ``table_seq_len`` is resolved here (its one default)."""
    if conf["table_split"] not in conf["eval_splits"]:
        raise ConfigError(f"{source}: table_split {conf['table_split']!r} is not among eval_splits "
                          f"{conf['eval_splits']}; add it there or choose one of them")
    if conf["train_split"] in conf["eval_splits"]:
        raise ConfigError(f"{source}: train_split {conf['train_split']!r} is also in eval_splits; the predictor "
                          "would be scored on its own training data")
    from vpr_smr.eval.predictor.defaults import RESERVED_SPLIT_NAMES

    reserved = [name for name in conf["eval_splits"] if name in RESERVED_SPLIT_NAMES]
    if reserved:
        raise ConfigError(f"{source}: eval_splits may not name a split {reserved[0]!r}: the predictor's numbers "
                          f"use the names {', '.join(map(repr, RESERVED_SPLIT_NAMES))} for its training split and "
                          "cross-validation; rename that split")
    calibration = conf["deployment"].get("calibration")
    if calibration is not None and calibration not in conf["eval_splits"]:
        raise ConfigError(f"{source}: deployment.calibration {calibration!r} is not among eval_splits "
                          f"{conf['eval_splits']}; choose one of them (or leave it out: the validation split)")
    if len(set(conf["seq_lens"])) != len(conf["seq_lens"]):
        raise ConfigError(f"{source}: seq_lens {conf['seq_lens']} repeats a length")
    # the speed experiment's velocities are numbers of reference frames per query frame: 1 and 1.0 are one setting
    # (the jobs' params and the report's configuration alike; sequence_matching's are its matcher's record's)
    conf["speed"]["velocities"] = [float(v) for v in conf["speed"]["velocities"]]
    if conf["table_seq_len"] is None:
        conf["table_seq_len"] = 4 if 4 in conf["seq_lens"] else conf["seq_lens"][0]
    elif conf["table_seq_len"] not in conf["seq_lens"]:
        raise ConfigError(f"{source}: table_seq_len {conf['table_seq_len']} is not among seq_lens {conf['seq_lens']}")


def experiments(conf: Config) -> set[str]:
    """The experiments a validated configuration runs, by the names of ``eval.report.registry.expected_outputs``
    (a built-in experiment's: its key of ``experiments:``), and those of installed packages it turns on
    (``pipeline.experiment``), by theirs."""
    chosen = conf.experiments
    names = {"table1", "predictor", "baselines"}
    if chosen.trust_levels and conf.trust_levels:
        names.add("trust_levels")
    if chosen.restoration:
        names.add("restoration")
    if chosen.attribute_ablation:
        names.add("attributes")
    if chosen.leave_one_method_out and len(conf.methods) > 1:
        names.add("leave_one_method_out")
    if chosen.seq_len_ablation and len(conf.seq_lens) > 1:
        names.add("seq_len")
    if chosen.speed:
        names.add("speed")
    if chosen.protocol_sweep:
        names.add("protocol_sweep")
    if chosen.matchers:
        names.add("matchers")
    if chosen.adaptive_seq_len and len(conf.seq_lens) > 1:
        names.add("adaptive_seq_len")
    if chosen.deployment and (len(conf.eval_splits) > 1 or len(conf.datasets) > 1):
        names.add("deployment")
    # the installed packages' experiments (``pipeline.experiment``) turned on by name: ``experiments: {NAME: true}``
    names.update(key for key, value in conf.to_json()["experiments"].items()
                 if value is True and key not in {item.name for item in declared(Experiments)})
    return names


def read_config(path: Path | str) -> dict[str, Any]:
    """The YAML mapping of ``path``, unvalidated."""
    import yaml  # here: the stages that take no configuration (e.g. ``vpr-smr attributes``) skip its import

    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"configuration file not found: {path}")
    try:
        conf = yaml.safe_load(path.read_text())
    except yaml.YAMLError as error:
        raise ConfigError(f"{path} is not valid YAML: {error}") from None
    if not isinstance(conf, dict):
        raise ConfigError(f"{path} must hold a mapping of settings")
    return conf


def parse_overrides(items: list[str] | None) -> dict[str, Any]:
    """``["predictor.max_iter=50", "seq_lens=[2, 4]"]`` -> nested dict; values parsed as YAML, as in the file."""
    import yaml

    overrides: dict[str, Any] = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise ConfigError(f"--config {item!r} is not of the form key=value (dotted keys reach nested settings)")
        node = overrides
        *parents, last = key.split(".")
        for part in parents:
            node = node.setdefault(part, {})
        node[last] = yaml.safe_load(value)
    return overrides


def merge(base: dict[str, Any], overrides: dict[str, Any]) -> dict[str, Any]:
    """Nested update, as Snakemake merges ``--config`` into the configuration file."""
    out = dict(base)
    for key, value in overrides.items():
        out[key] = merge(out[key], value) if isinstance(value, dict) and isinstance(out.get(key), dict) else value
    return out


def load_config(path: Path | str, overrides: dict[str, Any] | None = None) -> Config:
    """The configuration file ``path`` with ``overrides`` merged in (``merge``), validated (``validate``)."""
    return validate(merge(read_config(path), overrides or {}), str(path))
