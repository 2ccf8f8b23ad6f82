"""Settings declared once (``core.settings``): the configuration schema, the command-line options, the Snakemake
params and the configuration reference in the docs follow from the settings records, and agree with them."""

from __future__ import annotations

import json
import re
import shlex
from dataclasses import dataclass, fields
from types import SimpleNamespace

import pytest
from helpers import REPO

from vpr_smr.core.settings import json_schema, setting
from vpr_smr.eval.matching.matchers import MatcherSpec, available_matchers
from vpr_smr.eval.matching.matchers.base import Matcher
from vpr_smr.eval.predictor.defaults import PredictorSettings
from vpr_smr.eval.scoring.scorers import BaselineSettings
from vpr_smr.pipeline.cli import build_parser
from vpr_smr.pipeline.config import SCHEMA_PATH, ConfigError, Extraction, validate
from vpr_smr.pipeline.options import add_options, flags, matcher_of, read_matcher, read_options
from vpr_smr.pipeline.reference import REFERENCE_PATH, config_schema, configuration_reference
from vpr_smr.pipeline.stage import job_of

STAGES = ("attributes", "metrics", "queries", "baselines", "inspect")
MINIMAL = {"run": "r", "datasets": {"d": {"loader": "nordland_sample"}}, "methods": {"m": {"backend": "sad"}}}


def test_the_committed_schema_and_reference_are_what_the_records_give():
    committed = json.loads(SCHEMA_PATH.read_text())
    assert config_schema(committed) == committed, "run python -m vpr_smr.pipeline.reference --write"
    assert REFERENCE_PATH.read_text() == configuration_reference(committed), \
        "run python -m vpr_smr.pipeline.reference --write"


def test_a_records_schema_by_hand():
    # what config_schema.json said of these settings when it was written by hand (0.9)
    baselines = json_schema(BaselineSettings)
    assert baselines["additionalProperties"] is False and baselines["default"] == {}
    r_window = baselines["properties"]["r_window"]
    assert {k: v for k, v in r_window.items() if k != "description"} == {"type": "integer", "minimum": 0,
                                                                         "default": 10}
    assert r_window["description"].startswith("uniqueness (SeqSLAM's, OpenSeqSLAM2's rWindow)")
    order = json_schema(PredictorSettings)["properties"]["column_order"]
    assert {k: v for k, v in order.items() if k != "description"} == {
        "type": ["array", "null"], "items": {"type": "integer", "minimum": 0, "maximum": 3}, "minItems": 4,
        "maxItems": 4, "uniqueItems": True, "default": [0, 1, 3, 2]}
    batch = json_schema(Extraction)["properties"]["batch_size"]
    assert (batch["type"], batch["minimum"], batch["default"]) == (["integer", "null"], 1, None)
    committed = json.loads(SCHEMA_PATH.read_text())["properties"]
    assert committed["baselines"]["properties"]["spread_k"]["minimum"] == 1
    assert committed["experiments"]["properties"]["speed"] == {
        "type": "boolean", "default": True, "description": committed["experiments"]["properties"]["speed"][
            "description"]}


def test_the_reference_names_every_setting_and_option():
    text = REFERENCE_PATH.read_text()
    for row in ("| `baselines.r_window` | integer >= 0 | `10` | `--r-window` |",
                "| `baselines.spread_k` | integer >= 1 | `10` | `--spread-k` |",
                "| `predictor.column_order` | list (4, distinct) of integer >= 0 &lt;= 3 or null | `[0, 1, 3, 2]` |",
                "| `sequence_matching.matcher` | text | `\"seqslam\"` |",
                "| `sequence_matching.velocities` | list (at least 1, distinct) of number > 0 | `[1.0]` | "
                "`--velocities` |",
                "| `run` | text | required |"):
        assert row in text
    readme = (REPO / "README.md").read_text()
    assert "docs/configuration.md" in readme


def _parse(*words: str) -> SimpleNamespace:
    return build_parser().parse_args(list(words))


@pytest.mark.parametrize("command", STAGES)
def test_every_stage_takes_the_matcher_and_its_settings(command):
    options = {o for a in next(p for n, p in _subparsers() if n == command)._actions for o in a.option_strings}
    assert {"--matcher", "--velocities"} <= options
    assert ({"--r-window", "--spread-k"} <= options) == (command in ("metrics", "queries", "baselines"))


def _subparsers():
    import argparse

    action = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return list(action.choices.items())


def _scorers(args: SimpleNamespace) -> BaselineSettings:
    """The training-free scorers' settings of a scoring stage's parsed options (its job record's group)."""
    scorers: BaselineSettings = job_of(args.stage, args).scorers
    return scorers


def test_options_read_back_as_the_records():
    args = _parse("metrics", "--distances", "D.npy", "--seq-len", "4", "--out", "m.json", "--r-window", "6",
                  "--velocities", "2", "1")
    assert _scorers(args) == BaselineSettings(6, 10)  # spread_k: its default
    assert read_matcher(args) == MatcherSpec("seqslam", '{"velocities": [1.0, 2.0]}')  # sorted: one matcher
    default = _parse("metrics", "--distances", "D.npy", "--seq-len", "4", "--out", "m.json")
    assert _scorers(default) == BaselineSettings(10, 10)
    assert read_matcher(default).values == {"velocities": [1.0]}
    bad = _parse("queries", "--distances", "D.npy", "--seq-len", "4", "--out", "q.csv", "--r-window", "-1")
    with pytest.raises(ValueError, match=re.escape("--r-window: uniqueness (SeqSLAM's")):
        _scorers(bad)
    with pytest.raises(ValueError, match=re.escape("must be >= 0, got -1")):
        _scorers(bad)
    zero = _parse("attributes", "--distances", "D.npy", "--seq-len", "4", "--out", "a.h5", "--velocities", "0")
    with pytest.raises(ValueError, match=r"--velocities: velocities searched, .*; must be > 0, got 0.0"):
        read_matcher(zero)


def test_flags_give_the_records_back():
    assert flags(BaselineSettings(6, 3)) == "--r-window 6 --spread-k 3"
    assert flags(Extraction(8, None)) == "--batch-size 8"
    assert flags(Extraction()) == ""
    assert flags(PredictorSettings(smote=False, column_order=None)) == (
        "--hidden-layer-sizes 128 128 128 --alpha 0.0001 --learning-rate-init 0.001 --max-iter 10000 --no-smote "
        "--random-state 0 --smote-random-state 42 --column-order none")
    spec = MatcherSpec.of("seqslam", {"velocities": [2, 0.5]})
    args = _parse("baselines", "--dataset", "d", "--method", "m", "--seq-len", "4", "--distances", "v=v.h5",
                  "--attributes", "v=a.h5", "--predictors", "p.h5", "--out", "b.json",
                  "--matcher", "seqslam", "--velocities", "0.5", "2.0", *shlex.split(flags(BaselineSettings(6, 3))))
    assert read_matcher(args) == spec and _scorers(args) == BaselineSettings(6, 3)


def test_the_rules_spell_no_setting():
    # every rule calls its stage with the job record (pipeline.stage.shell_command, a job_text param): no rule
    # spells an option of a setting, nor the command line of a stage
    for path in (REPO / "pipeline" / "rules").glob("*.smk"):
        text = path.read_text()
        assert "--velocities" not in text and "--r-window" not in text and "--spread-k" not in text, path.name
        assert '"vpr-smr ' not in text and text.count("shell:") == text.count("shell_command("), path.name


def test_sequence_matching_is_the_matchers_spec():
    conf = validate({**MINIMAL, "sequence_matching": {"velocities": [2, 1]}})
    assert conf.sequence_matching == MatcherSpec.of("seqslam", {"velocities": [1.0, 2.0]})
    assert conf.to_json()["sequence_matching"] == {"matcher": "seqslam", "velocities": [1.0, 2.0]}
    assert validate(MINIMAL).to_json()["sequence_matching"] == {"matcher": "seqslam", "velocities": [1.0]}
    assert validate({**MINIMAL, "sequence_matching": {"matcher": "seqslam"}}).sequence_matching == MatcherSpec.of()


@pytest.mark.parametrize(("matching", "message"), [
    ({"matcher": "seqslan"}, "sequence_matching.matcher: unknown sequence matcher 'seqslan' (did you mean "
                             "'seqslam'?); available: " + ", ".join(available_matchers())),
    ({"velocites": [1]}, "sequence_matching.velocites: unexpected setting 'velocites' (did you mean "
                         "'velocities'?); sequence_matching allows: velocities"),
    ({"velocities": [1, 0]}, "sequence_matching.velocities: velocities searched, in reference frames per query "
                             "frame ([1.0]: the fixed matcher); must be > 0, got 0.0"),
    ({"velocities": []}, "sequence_matching.velocities: velocities searched, in reference frames per query "
                         "frame ([1.0]: the fixed matcher); give at least 1, got []"),
])
def test_a_bad_matcher_setting_names_itself(matching, message):
    with pytest.raises(ConfigError, match=re.escape(message)):
        validate({**MINIMAL, "sequence_matching": matching}, "c.yaml")


@dataclass(frozen=True)
class ToySettings:
    width: int = setting(3, "references either side", minimum=1)


class Toy(Matcher):
    """A plugin matcher of this test only: its settings are checked by its record, wherever given."""

    name = "toy"
    Settings = ToySettings
    description = "a test's matcher"

    @property
    def lookback(self) -> int:
        return 0

    def check(self, shape: tuple[int, ...], name: str = "distance matrix") -> None:
        return None

    def block(self, columns, first_column, state):  # type: ignore[no-untyped-def]
        raise AssertionError("not run here")


@pytest.fixture
def toy(monkeypatch):
    import vpr_smr.eval.matching.matchers as matchers

    point = SimpleNamespace(name="toy", load=lambda: Toy)
    monkeypatch.setattr("vpr_smr.core.registry.entry_points",
                        lambda group: [point] if group == matchers.ENTRY_POINT_GROUP else [])


def test_a_plugin_matchers_settings_are_checked_and_given_as_options(toy):
    conf = validate({**MINIMAL, "sequence_matching": {"matcher": "toy", "width": 5}})
    assert conf.sequence_matching == MatcherSpec("toy", '{"width": 5}')
    with pytest.raises(ConfigError, match=re.escape("sequence_matching.width: references either side; must be "
                                                    ">= 1, got 0")):
        validate({**MINIMAL, "sequence_matching": {"matcher": "toy", "width": 0}}, "c.yaml")
    with pytest.raises(ConfigError, match=re.escape("sequence_matching.velocities: unexpected setting "
                                                    "'velocities'; sequence_matching allows: width")):
        validate({**MINIMAL, "sequence_matching": {"matcher": "toy", "velocities": [1.0]}}, "c.yaml")
    args = build_parser("toy").parse_args(["queries", "--distances", "D.npy", "--seq-len", "4", "--out", "q.csv",
                                           "--matcher", "toy", "--width", "7"])
    assert read_matcher(args) == MatcherSpec("toy", '{"width": 7}')
    with pytest.raises(SystemExit):  # seqslam's option is not toy's
        build_parser("toy").parse_args(["queries", "--distances", "D.npy", "--seq-len", "4", "--out", "q.csv",
                                        "--matcher", "toy", "--velocities", "1"])


@pytest.mark.parametrize("record", [PredictorSettings(), PredictorSettings(smote=False, column_order=None),
                                    PredictorSettings(hidden_layer_sizes=(7,), alpha=0.5, column_order=(3, 2, 1, 0)),
                                    Extraction(), Extraction(2, 0), BaselineSettings(0, 1)])
def test_any_record_goes_through_its_options_and_back(record):
    import argparse

    parser = argparse.ArgumentParser()
    add_options(parser, type(record), "r")
    assert read_options(parser.parse_args(shlex.split(flags(record))), type(record), "r") == record
    assert read_options(parser.parse_args([]), type(record), "r") == type(record)()  # none given: the defaults


def test_the_matcher_is_read_before_the_options_it_brings(toy):
    assert matcher_of(["queries", "--matcher", "toy", "--width", "2"]) == "toy"
    assert matcher_of(["queries", "--matcher=toy"]) == "toy"
    assert matcher_of(["queries", "--distances", "D.npy"]) == "seqslam"
    assert matcher_of(["queries", "--matcher", "nope"]) == "seqslam"  # argparse then refuses the name


def test_a_setting_that_may_be_null():
    from vpr_smr.core.settings import parse

    assert parse(PredictorSettings, {"column_order": None}, "predictor").column_order is None
    assert parse(PredictorSettings, {"column_order": [3, 2, 1, 0]}, "predictor").column_order == (3, 2, 1, 0)
    with pytest.raises(ValueError, match=re.escape("predictor.column_order: the network's input columns as indices "
                                                   "of (A1, A2, A3, A4); default: the authors' code's order (method "
                                                   "§7); null keeps A1..A4; give at most 4, got [0, 1, 2, 3, 0]")):
        parse(PredictorSettings, {"column_order": [0, 1, 2, 3, 0]}, "predictor")
    with pytest.raises(ValueError, match=re.escape("predictor.column_order[1]: expected an integer, got 'b'")):
        parse(PredictorSettings, {"column_order": [0, "b", 2, 3]}, "predictor")


def test_a_record_of_an_unsupported_type_is_refused():
    @dataclass(frozen=True)
    class Odd:
        where: dict[str, int] = setting(None, "a mapping")

    with pytest.raises(TypeError, match=re.escape("Odd.where: settings of type dict[str, int] are not supported")):
        json_schema(Odd)


def test_a_dataset_entrys_schema_by_hand():
    # what config_schema.json said of a dataset entry when it was written by hand (0.11)
    entry = json.loads(SCHEMA_PATH.read_text())["properties"]["datasets"]["additionalProperties"]
    assert entry["required"] == ["loader"] and "additionalProperties" not in entry  # the loader's own keys beside
    shapes = {key: {k: v for k, v in node.items() if k != "description"} for key, node in entry["properties"].items()}
    assert list(shapes) == ["loader", "root", "tolerance", "radius", "ground_truth", "reference_positions",
                            "query_positions", "positions", "every", "frames", "splits"]
    assert not [key for key, node in shapes.items() if "default" in node]  # an entry is never filled in
    assert shapes["tolerance"] == {"type": "integer", "minimum": 0}
    assert shapes["radius"] == {"type": "number", "exclusiveMinimum": 0}
    assert shapes["root"] == {"type": ["string", "null"]}
    assert shapes["positions"] == {"type": "string", "enum": ["file_names", "ins"]}
    assert shapes["every"] == {"type": "integer", "minimum": 1}
    assert shapes["frames"] == {"type": "array", "items": {"type": "integer", "minimum": 0}, "minItems": 2,
                                "maxItems": 2}
    assert shapes["ground_truth"]["properties"]["key"] == {"type": "string", "minLength": 1}
    forms = shapes["splits"]["additionalProperties"]["oneOf"]
    assert forms[1]["required"] == ["reference", "query"] and forms[0]["maxItems"] == 2
    assert entry["properties"]["tolerance"]["description"] == "frames; default: the loader's (2, method §1)"
    assert "default 25 for robotcar's positions: ins" in entry["properties"]["radius"]["description"]
    text = REFERENCE_PATH.read_text()
    assert "| `datasets.NAME.loader` | text | required | the dataset's loader" in text
    assert "| `datasets.NAME.frames` | list (2) of integer >= 0 |  | [lo, hi]: keep frames" in text


def test_a_dataset_entry_reaches_the_jobs_as_given():
    # the descriptors job's params hash the entry: a default filled in would rerun every dataset's descriptors
    entry = {"loader": "folders", "reference": "r", "query": "q", "splits": {"s": [0, 3]}}
    conf = validate({**MINIMAL, "datasets": {"d": entry}, "train_split": "s", "eval_splits": ["t"],
                     "table_split": "t"})
    assert conf.to_json()["datasets"] == {"d": entry} and conf.datasets["d"].to_json() == entry


@pytest.mark.parametrize(("entry", "message"), [
    ({"loader": "folders", "tolerance": -1}, "datasets.d.tolerance: -1 is less than the minimum of 0"),
    ({"loader": "folders", "frames": [0, 1, 2]}, "datasets.d.frames: [0, 1, 2] is too long"),
    ({"loader": "folders", "splits": {"s": {"reference": [0, 2]}}}, "datasets.d.splits.s: {'reference': [0, 2]} is "
     "not valid under any of the given schemas (a split is [lo, hi] (frames lo .. hi-1 of both traverses) or, for "
     "frames with positions, {reference: [lo, hi], query: [lo, hi]})"),
    ({"loader": "folders", "ground_truth": {"matrix": "m.npy", "lits": "l.csv"}},
     "datasets.d.ground_truth.lits: unexpected key 'lits' (did you mean 'lists'?)"),
    ({"root": "x"}, "datasets.d: 'loader' is a required property"),
])
def test_a_bad_dataset_entry_names_its_setting(entry, message):
    with pytest.raises(ConfigError, match=re.escape(message)):
        validate({**MINIMAL, "datasets": {"d": entry}}, "c.yaml")


def test_a_dataset_entry_as_its_record():
    from vpr_smr.core.settings import UNSET, parse
    from vpr_smr.datasets import SPLIT_SETTINGS, DatasetEntry

    assert set(SPLIT_SETTINGS) <= {f for f in DatasetEntry.__dataclass_fields__}
    record = parse(DatasetEntry, {"loader": "robotcar", "positions": "ins", "every": 3,
                                  "ground_truth": {"lists": "gt.csv"}}, "datasets.d")
    assert (record.loader, record.every, record.ground_truth, record.tolerance) == ("robotcar", 3, {"lists": "gt.csv"},
                                                                                    UNSET)
    with pytest.raises(ValueError, match=re.escape("datasets.d.loader: the dataset's loader (vpr-smr dataset check "
                                                   "--help names them); it has no default: give it")):
        parse(DatasetEntry, {"root": "x"}, "datasets.d")
    with pytest.raises(ValueError, match=r"^datasets\.d\.ground_truth: method §13: .*; \{'matrix': 'm', 'lists': 'l'\} "
                                         r"is not valid under any of the given schemas$"):
        parse(DatasetEntry, {"loader": "folders", "ground_truth": {"matrix": "m", "lists": "l"}}, "datasets.d")
    with pytest.raises(ValueError, match=re.escape("datasets.d.splits.s[1]: the splits by name")):
        parse(DatasetEntry, {"loader": "folders", "splits": {"s": [0, "b"]}}, "datasets.d")


def test_every_loader_setting_is_in_the_reference_with_a_meaning():
    """Each built-in loader's settings (its ``Settings`` record, less the entry's own keys) each have a row with a
    description, and a shipped default list shows as its checkout path."""
    from vpr_smr.datasets import LOADERS, loader_options
    from vpr_smr.datasets.settings import DatasetEntry

    text = REFERENCE_PATH.read_text()
    entry = {f.name for f in fields(DatasetEntry)}
    for name in LOADERS:
        own = [option for option in loader_options(name) if option not in entry]
        section = text.split(f"### loader `{name}`")[1].split("\n### ")[0]
        for option in own:
            row = next((line for line in section.splitlines() if line.startswith(f"| `datasets.NAME.{option}` |")),
                       None)
            assert row is not None, f"loader {name}: {option} is not in docs/configuration.md"
            assert row.rstrip(" |").split(" | ")[-1].strip(), f"loader {name}: {option} has no description"
    assert "| `data/lists/from_Patch-NetVLAD/nordland_imageNames_index.txt` |" in text


def test_every_backend_setting_is_in_the_reference_with_a_type_and_a_meaning():
    """Each built-in backend's default_conf key, and each setting every backend takes, has a row whose type and
    description are filled (a default of null or auto takes its type from its help's first words)."""
    from vpr_smr.descriptors import BACKENDS, backend_class
    from vpr_smr.descriptors.base import COMMON_SETTINGS

    text = REFERENCE_PATH.read_text()
    common = text.split("### Every backend")[1].split("\n### ")[0]
    for key in COMMON_SETTINGS:
        if key != "checkpoint":  # the entry's own table has it
            row = next(line for line in common.splitlines() if line.startswith(f"| `methods.NAME.{key}` |"))
            assert all(cell.strip() for cell in row.strip("| ").split(" | ")), row
    for name in BACKENDS:
        section = text.split(f"### backend `{name}`")[1].split("\n### ")[0].split("\n## ")[0]
        for key in backend_class(name).default_conf:
            row = next((line for line in section.splitlines() if line.startswith(f"| `methods.NAME.{key}` |")),
                       None)
            assert row is not None, f"backend {name}: {key} is not in docs/configuration.md"
            assert all(cell.strip() for cell in row.strip("| ").split(" | ")), row
