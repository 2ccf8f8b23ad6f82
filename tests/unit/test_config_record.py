"""The validated configuration is a typed frozen record (``pipeline.config.Config``): its settings by attribute,
every default filled in, and the validated JSON it was read from (``to_json``), whose texts the jobs' params take,
so that the same configuration gives the same params (and reruns the same jobs) as the mapping did."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest
from helpers import REPO

from vpr_smr.descriptors import descriptor_settings
from vpr_smr.pipeline.config import (
    SCHEMA_PATH,
    Config,
    DatasetSettings,
    MethodSettings,
    merge,
    read_config,
    validate,
    validated_json,
)
from vpr_smr.pipeline.plan import canonical
from vpr_smr.pipeline.rule_helpers import extraction_options, report_settings

CONFIGS = sorted((REPO / "configs").glob("*.yaml"))
# values whose text a job's param shows as given: an int stays an int, the keys keep the configuration's order
OVERRIDES = {"trust_levels": [0, 0.5, 1], "predictor": {"alpha": 0, "max_iter": 7},
             "extraction": {"batch_size": 8}, "speed": {"velocities": [1, 2]}}


@pytest.mark.parametrize("path", CONFIGS, ids=lambda p: p.stem)
@pytest.mark.parametrize("extra", [{}, OVERRIDES], ids=["as shipped", "overrides"])
def test_the_record_gives_the_params_the_mapping_gave(path, extra):
    raw = merge(read_config(path), extra)
    mapping, conf = validated_json(raw, str(path)), validate(raw, str(path))
    assert json.dumps(conf.to_json()) == json.dumps(mapping)  # the same keys, order and value types
    assert canonical(conf.predictor.to_json()) == canonical(mapping["predictor"])
    shown = json.loads(report_settings(conf.to_json()))
    assert shown == {k: v for k, v in mapping.items() if k != "extraction"}
    schema_order = list(json.loads(SCHEMA_PATH.read_text())["properties"])
    assert list(shown) == [key for key in schema_order if key in shown]  # the sections in the schema's order
    for name, method in mapping["methods"].items():
        assert canonical(descriptor_settings(conf.methods[name].to_json())) == canonical(descriptor_settings(method))
    assert " ".join(map(str, conf.trust_levels)) == " ".join(map(str, mapping["trust_levels"]))
    assert list(conf.datasets) == list(mapping["datasets"]) and list(conf.methods) == list(mapping["methods"])
    expected = " ".join(f"{option} {value}" for option, value in (
        ("--batch-size", mapping["extraction"]["batch_size"]), ("--num-workers", mapping["extraction"]["num_workers"]))
        if value is not None)
    assert extraction_options(conf) == expected


def test_the_record_is_typed_frozen_and_complete():
    conf = validate({"run": "r", "seq_lens": [6, 3], "train_split": "fit", "eval_splits": ["check", "final"],
                     "table_split": "final",
                     "datasets": {"d": {"loader": "folders", "reference": "a", "query": "b", "tolerance": 3}},
                     "methods": {"m": {"backend": "sad"}, "n": {"backend": "hog", "distance": "l2"}}})
    assert isinstance(conf, Config) and conf.run_dir == Path("results") / "r"
    assert conf.seq_lens == (6, 3) and conf.table_seq_len == 6  # 4 not listed: the first
    assert (conf.train_split, conf.eval_splits, conf.table_split, conf.validation_split) == (
        "fit", ("check", "final"), "final", "check")
    assert conf.predictor.hidden_layer_sizes == (128, 128, 128) and conf.predictor.column_order == (0, 1, 3, 2)
    assert conf.experiments.speed and conf.speed.profiles[-1] == "varying" and conf.extraction.batch_size is None
    assert conf.datasets["d"] == DatasetSettings("d", "folders", None, 3, None, source=conf.datasets["d"].source)
    assert conf.methods["n"] == MethodSettings("n", "hog", None, "l2", source=conf.methods["n"].source)
    assert conf.datasets["d"].to_json() == {"loader": "folders", "reference": "a", "query": "b", "tolerance": 3}
    with pytest.raises(dataclasses.FrozenInstanceError):
        conf.seeds = 1  # type: ignore[misc]
    with pytest.raises(TypeError):
        conf.datasets["e"] = conf.datasets["d"]  # type: ignore[index]
    copy = conf.to_json()
    copy["seeds"] = 1  # a copy: the record keeps its own
    assert conf.seeds == 5 and conf.to_json()["seeds"] == 5


def test_a_section_written_out_at_its_defaults_leaves_the_reports_param_as_it_was():
    # the sections in the schema's order: a configuration that adds `sequence_matching: {matcher: seqslam}` at its
    # end (after output) must not rerun the report
    raw = read_config(REPO / "configs" / "demo.yaml")
    plain = report_settings(validate(raw, "demo").to_json())
    named = report_settings(validate({**raw, "sequence_matching": {"matcher": "seqslam"}}, "demo").to_json())
    assert named == plain
