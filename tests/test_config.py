import textwrap

import pytest

from vpr_smr.pipeline.config import ConfigError, load_config
from vpr_smr.pipeline.plan import preflight

DEMO = "configs/demo.yaml"


def write(tmp_path, text):
    path = tmp_path / "c.yaml"
    path.write_text(textwrap.dedent(text))
    return path


def test_demo_config_is_valid_and_gets_defaults():
    conf = load_config(DEMO)
    assert conf["seq_lens"] == [4] and conf["modes"] == ["paper", "standard"]
    assert conf["eval_splits"] == ["val", "test"] and conf["output"] == "results"
    preflight(conf)


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
    assert "'colour' was unexpected" in text


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
