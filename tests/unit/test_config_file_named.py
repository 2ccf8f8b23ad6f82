"""A dataset setting the loader refuses is named with the configuration file it came from (``vpr-smr run`` and
``vpr-smr dataset check --config``), with the closest valid key; a relative root that is not found is said to be
relative once."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from vpr_smr.pipeline.cli import main as cli
from vpr_smr.pipeline.config import ConfigError, load_config
from vpr_smr.pipeline.plan import preflight
from vpr_smr.pipeline.workflow import run

RELATIVE = "(a relative path, looked for from the working folder"


def write(folder: Path, entry: dict) -> Path:
    path = folder / "cafe_route.yaml"
    path.write_text(yaml.safe_dump({"run": "r", "output": str(folder / "out"), "seq_lens": [3],
                                    "datasets": {"cafe": entry}, "methods": {"sad": {"backend": "sad"}}}))
    return path


def test_a_misspelt_loader_key_names_the_file_and_the_closest_key(tmp_path, capsys):
    (tmp_path / "ref").mkdir()
    (tmp_path / "qry").mkdir()
    config = write(tmp_path, {"loader": "folders", "reference": str(tmp_path / "ref"), "queyr": str(tmp_path / "qry")})
    expected = "datasets.cafe.queyr: loader 'folders' has no setting 'queyr' (did you mean 'query'?)"
    with pytest.raises(ConfigError) as raised:
        run(config)
    assert str(raised.value).startswith(f"{config} cannot run:\n  {expected}; its settings: loader, reference, ")
    assert cli(["dataset", "check", "--config", str(config)]) == 2
    assert capsys.readouterr().err.startswith(f"error: {config}: {expected}; its settings: loader, reference, ")


def test_a_relative_root_not_found_is_said_once(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    config = write(tmp_path, {"loader": "nordland_sample", "root": "no_such_folder"})
    with pytest.raises(ConfigError) as raised:
        preflight(load_config(config))
    message = str(raised.value)
    assert message.count(RELATIVE) == 1
    assert f"image folder not found: no_such_folder/summer {RELATIVE} {tmp_path})" in message
    assert cli(["dataset", "check", "--config", str(config)]) == 2
    assert capsys.readouterr().err.count(RELATIVE) == 1
