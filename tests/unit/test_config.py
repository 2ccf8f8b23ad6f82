import json
import re
import textwrap

import pytest
import yaml

from vpr_smr.pipeline.config import ConfigError, experiments, load_config
from vpr_smr.pipeline.plan import preflight

DEMO = "configs/demo.yaml"


def write(tmp_path, text):
    path = tmp_path / "c.yaml"
    path.write_text(textwrap.dedent(text))
    return path


def test_demo_config_is_valid_and_gets_defaults():
    conf = load_config(DEMO)
    assert conf.seq_lens == (2, 4, 6, 8, 10) and conf.modes == ("paper", "standard")
    assert conf.eval_splits == ("val", "test") and conf.output == "results"
    assert conf.table_seq_len == 4 and conf.seeds == 5
    assert experiments(conf) == {"table1", "predictor", "baselines", "trust_levels", "restoration", "attributes",
                                 "leave_one_method_out", "seq_len", "speed", "protocol_sweep", "matchers",
                                 "adaptive_seq_len", "deployment"}
    assert (conf.baselines.r_window, conf.baselines.spread_k, conf.baselines.candidates) == (10, 10, 12)
    preflight(conf)


@pytest.mark.parametrize(("settings", "table_seq_len"), [("seq_lens: [2, 4]", 4), ("seq_lens: [6, 3]", 6),
                                                         ("{seq_lens: [6, 3], table_seq_len: 3}", 3)])
def test_table_seq_len_defaults_to_4_else_the_first(tmp_path, settings, table_seq_len):
    path = write(tmp_path, """
        run: x
        datasets: {d: {loader: nordland_sample}}
        methods: {m: {backend: sad}}
    """)
    conf = load_config(path, yaml.safe_load(settings))
    assert conf.table_seq_len == table_seq_len


@pytest.mark.parametrize(("overrides", "message"), [
    ({"seq_lens": [2, 6], "table_seq_len": 4}, "table_seq_len 4 is not among seq_lens [2, 6]"),
    ({"table_split": "train"}, "table_split 'train' is not among eval_splits"),
    ({"eval_splits": ["train", "test"]}, "train_split 'train' is also in eval_splits"),
    ({"seq_lens": [4, 4]}, "repeats a length"),
])
def test_settings_that_do_not_go_together(tmp_path, overrides, message):
    path = write(tmp_path, """
        run: x
        datasets: {d: {loader: nordland_sample}}
        methods: {m: {backend: sad}}
    """)
    with pytest.raises(ConfigError, match=re.escape(message)):
        load_config(path, overrides)


def test_experiments_follow_the_settings(tmp_path):
    path = write(tmp_path, """
        run: x
        seq_lens: [4]
        datasets: {d: {loader: nordland_sample}}
        methods: {m: {backend: sad}}
        experiments: {restoration: false}
    """)
    # one method: no leave-one-method-out; one L: no sequence-length ablation; restoration switched off
    assert experiments(load_config(path)) == {"table1", "predictor", "baselines", "trust_levels", "attributes", "speed",
                                              "protocol_sweep", "matchers", "deployment"}
    # deployment needs a second evaluation split or dataset to deploy on
    assert "deployment" not in experiments(load_config(path, {"eval_splits": ["test"]}))
    assert "matchers" not in experiments(load_config(path, {"experiments": {"matchers": False}}))
    assert "trust_levels" not in experiments(load_config(path, {"trust_levels": []}))


def test_the_compared_matchers_default_to_every_built_in_one_and_bad_ones_are_refused(tmp_path):
    from vpr_smr.eval.matching.matchers import MATCHERS, MatcherSpec

    path = write(tmp_path, """
        run: x
        datasets: {d: {loader: nordland_sample}}
        methods: {m: {backend: sad}}
    """)
    conf = load_config(path)
    assert conf.matchers == tuple(MatcherSpec.of(name) for name in MATCHERS)
    assert conf.to_json()["matchers"] == [{"matcher": name, **MatcherSpec.of(name).values} for name in MATCHERS]
    given = load_config(path, {"matchers": [{"matcher": "seqslam", "velocities": [2, 1]}]})
    assert given.matchers == (MatcherSpec.of("seqslam", {"velocities": [1.0, 2.0]}),)
    for matchers, message in (([], "matchers: [] should be non-empty"),
                              ([{"velocities": [1.0]}], "'matcher' is a required property"),
                              ([{"matcher": "seqslam"}, {"matcher": "seqslam", "velocities": [1]}],
                               "matchers lists the matcher seqslam twice with the same settings: give each once"),
                              ([{"matcher": "seqslam", "velocity": [1]}], "matchers[0]")):
        with pytest.raises(ConfigError, match=re.escape(message)):
            load_config(path, {"matchers": matchers})


def test_schema_errors_name_the_setting(tmp_path):
    path = write(tmp_path, """
        run: x
        seq_lens: [1]
        datasets: {d: {root: here}}
        methods: {m: {backend: sad}}
        colour: blue
    """)
    with pytest.raises(ConfigError) as error:
        load_config(path)
    text = str(error.value)
    assert "c.yaml is invalid" in text
    assert "seq_lens.0: 1 is less than the minimum of 2" in text
    assert "datasets.d: 'loader' is a required property" in text
    assert "colour: unexpected key 'colour'; the top level allows: run, output, seq_lens" in text


def test_unexpected_keys_get_the_closest_allowed_one(tmp_path):
    path = write(tmp_path, """
        run: x
        seq_len: [4]
        datasets: {d: {loader: folders, splits: {test: {reference: [0, 9], quer: [0, 9]}}}}
        methods: {m: {backend: sad}}
        experiments: {sped: false}
    """)
    with pytest.raises(ConfigError) as error:
        load_config(path)
    text = str(error.value)
    assert "  seq_len: unexpected key 'seq_len' (did you mean 'seq_lens'?); the top level allows: run, output, " \
           "seq_lens," in text
    # inside a nested object, and inside one form of a setting that takes several (a split)
    assert "  experiments.sped: unexpected key 'sped' (did you mean 'speed'?); experiments allows: trust_levels, " \
           "restoration, attribute_ablation, leave_one_method_out, seq_len_ablation, speed" in text
    assert "  datasets.d.splits.test.quer: unexpected key 'quer' (did you mean 'query'?); datasets.d.splits.test " \
           "allows: reference, query" in text
    assert "Additional properties" not in text


def test_names_with_characters_that_are_not_allowed(tmp_path):
    path = write(tmp_path, """
        run: corridor ü
        datasets: {my set: {loader: nordland_sample}}
        methods: {"sad/2": {backend: sad}}
    """)
    with pytest.raises(ConfigError) as error:
        load_config(path)
    text = str(error.value)
    allowed = "use only letters A-Z a-z, digits 0-9, '_', '.' and '-'"
    assert f"  run: 'corridor ü' is not allowed: it has a space (character 9) and 'ü' (character 10); {allowed}" in text
    assert f"  datasets: the name 'my set' is not allowed: it has a space (character 3); {allowed}" in text
    assert f"  methods: the name 'sad/2' is not allowed: it has '/' (character 4); {allowed}" in text
    assert "^[A-Za-z0-9_.-]+$" not in text


def test_preflight_names_missing_checkpoint_and_root(tmp_path):
    path = write(tmp_path, """
        run: x
        datasets: {d: {loader: nordland_sample, root: /nowhere}}
        methods:
          effnet: {backend: efficientnet_lite0_gem}
          other: {backend: no_such_backend}
    """)
    with pytest.raises(ConfigError) as error:
        preflight(load_config(path))
    text = str(error.value)
    assert "image folder not found: /nowhere/summer" in text
    assert "methods.effnet.checkpoint is not set" in text
    assert "methods.other.backend: unknown descriptor backend 'no_such_backend'" in text


def test_schema_defaults_agree_with_the_library():
    # The schema repeats what a JSON schema cannot import: core.constants owns these values.
    from vpr_smr.core.constants import DEFAULT_R_WINDOW, DEFAULT_SPREAD_K, DEFAULT_TRUST_LEVELS, MODES
    from vpr_smr.pipeline.config import SCHEMA_PATH, schema_default

    assert tuple(schema_default("trust_levels")) == DEFAULT_TRUST_LEVELS
    assert schema_default("baselines", "r_window") == DEFAULT_R_WINDOW
    assert schema_default("baselines", "spread_k") == DEFAULT_SPREAD_K
    assert tuple(schema_default("modes")) == MODES
    assert tuple(json.loads(SCHEMA_PATH.read_text())["properties"]["modes"]["items"]["enum"]) == MODES


def test_predictor_gets_the_estimators_defaults_under_the_users_values(tmp_path):
    # eval/predictor/defaults.py owns the defaults (the schema shows them, checked below); validation fills them in.
    from vpr_smr.eval.predictor.estimator import SMRPredictor
    from vpr_smr.pipeline.config import SCHEMA_PATH

    settings = json.loads(SCHEMA_PATH.read_text())["properties"]["predictor"]["properties"]
    defaults = SMRPredictor().get_params()
    assert set(settings) == set(defaults)
    assert all(setting.get("description") for setting in settings.values())
    conf = load_config(DEMO, {"predictor": {"max_iter": 7, "column_order": None}})
    assert conf.predictor.to_json() == {**json.loads(json.dumps(defaults)), "max_iter": 7, "column_order": None}
    assert conf.predictor.max_iter == 7 and conf.predictor.column_order is None
    assert load_config(DEMO).predictor.hidden_layer_sizes == tuple(defaults["hidden_layer_sizes"])


def test_the_schema_shows_the_predictors_defaults():
    """The schema lists the predictor's defaults for readers; eval/predictor/defaults.py owns them."""
    import json

    from vpr_smr.eval.predictor.defaults import DEFAULTS
    from vpr_smr.eval.predictor.estimator import SMRPredictor
    from vpr_smr.pipeline.config import SCHEMA_PATH

    shown = {k: v["default"] for k, v in json.loads(SCHEMA_PATH.read_text())["properties"]["predictor"]
             ["properties"].items()}
    assert shown == json.loads(json.dumps(DEFAULTS))
    assert SMRPredictor().get_params() == DEFAULTS  # the estimator's keyword defaults are the same values
