"""The generated references (docs/configuration.md, docs/cli.md) say what the code does, for each claim that can
drift from it: where a relative path is looked for (checked against what the loaders do), the default of a flag
(checked against what argparse parses without it) and the type of a setting whose default is null."""

import json
import re

import numpy as np
import yaml
from PIL import Image

from vpr_smr.datasets import load_frames
from vpr_smr.pipeline.cli import build_parser
from vpr_smr.pipeline.config import load_config
from vpr_smr.pipeline.reference import SCHEMA_PATH, cli_reference, commands, config_schema, configuration_reference


def _rows(text):
    """Every table row of a Markdown page as its cells (the bars escaped in cells left in)."""
    return [[cell.strip() for cell in re.split(r"(?<!\\)\|", line)[1:-1]] for line in text.splitlines()
            if line.startswith("| `")]


def _configuration():
    return configuration_reference(config_schema(json.loads(SCHEMA_PATH.read_text())))


def _rule(description):
    found = re.search(r"from the (working folder|configuration's folder)", description)
    assert found, f"the description names no folder for a relative path: {description}"
    return found.group(1)


def _images(folder, n):
    folder.mkdir(parents=True)
    for i in range(n):
        Image.fromarray(np.full((8, 8, 3), 40 * i, np.uint8)).save(folder / f"{i:04d}.png")


def test_relative_paths_are_read_from_the_folder_the_reference_names(tmp_path, monkeypatch):
    work, conf_dir = tmp_path / "work", tmp_path / "conf"
    _images(work / "spring", 6)
    _images(work / "winter", 6)
    (conf_dir / "gt").mkdir(parents=True)
    np.save(conf_dir / "gt" / "truth.npy", np.eye(6, dtype=bool))
    config = conf_dir / "c.yaml"
    config.write_text(yaml.safe_dump({
        "run": "r", "seq_lens": [2],
        "datasets": {"mine": {"loader": "folders", "reference": "spring", "query": "winter",
                              "ground_truth": {"matrix": "gt/truth.npy"},
                              "splits": {"train": [0, 2], "val": [2, 4], "test": [4, 6]}}},
        "methods": {"sad": {"backend": "sad"}}}))
    monkeypatch.chdir(work)  # the image folders are here only, the ground truth beside the configuration only
    entry = load_config(config).datasets["mine"].to_json()
    pair = load_frames("mine", entry)
    image_rule = "working folder" if pair.reference.images[0].resolve().parent == (work / "spring").resolve() \
        else "configuration's folder"
    truth_rule = "configuration's folder" if (conf_dir / "gt" / "truth.npy").samefile(
        entry["ground_truth"]["matrix"]) else "working folder"
    rows: dict[str, str] = {}
    for cells in _rows(_configuration()):
        rows.setdefault(cells[0], cells[3])  # the entry's own rows come first, the loaders' after
    assert _rule(rows["`datasets.NAME.reference`"]) == image_rule == "working folder"
    assert _rule(rows["`datasets.NAME.ground_truth`"]) == truth_rule == "configuration's folder"


def test_a_flag_shows_no_default_and_is_off_unless_given():
    page = {cells[0]: cells[2] for cells in _rows(cli_reference()) if len(cells) == 4}  # the options tables
    checked = []
    for command in commands(build_parser()).values():
        defaults = {action.dest: action.default for action in command._actions}
        for action in command._actions:
            shown = page.get(f"`{', '.join(action.option_strings)}`")
            if action.nargs != 0 or not action.option_strings or shown is None:
                continue  # not a flag, or not in the reference (help, hidden)
            # argparse's own parsed value without the flag differs from the one it sets: off unless given
            assert defaults[action.dest] != action.const, action.option_strings
            assert shown == "", (action.option_strings, shown)
            checked.append(action.option_strings[-1])
    assert "--no-restoration" in checked and len(checked) > 10, checked


def test_every_setting_whose_default_is_null_allows_null_in_its_type():
    rows = [cells for cells in _rows(_configuration()) if len(cells) >= 3 and cells[2] == "`null`"]
    assert len(rows) > 10
    missing = [cells[0] for cells in rows if not re.search(r"\bnull\b", cells[1])]
    assert missing == []
    assert any(cells[0] == "`methods.NAME.half`" and cells[1] == "true/false or null" for cells in rows)

