"""A researcher's own two image folders: the README's example, loading, decoding, frame order (the README's
commands run end to end: test_own_data_workflow.py)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import cv2
import pytest
from helpers import REPO, doc_block, write_route

from vpr_smr.datasets import DatasetError, frames_settings, load_dataset, load_frames, read_image
from vpr_smr.datasets import check as check_module
from vpr_smr.datasets.base import order_note
from vpr_smr.pipeline.cli import main as cli
from vpr_smr.pipeline.config import load_config

EXAMPLE = REPO / "configs" / "own_folders.yaml"


# --- the README's example ---


def test_readme_shows_the_shipped_example_configuration():
    assert doc_block("own-data-config") == EXAMPLE.read_text()


def test_readme_shows_the_positions_example_and_it_is_valid():
    # the non-aligned example (method §11): shown as shipped, valid, velocity search on, the speed experiment off
    example = REPO / "configs" / "own_positions.yaml"
    assert doc_block("own-positions-config") == example.read_text()
    conf = load_config(example)
    assert conf.datasets["my_drive"].radius == 25
    assert conf.sequence_matching.values["velocities"][4] == 1.0 and not conf.experiments.speed


# --- the folders loader with the four basic settings ---


def basic(tmp_path: Path, n: int = 20, scale: int = 1) -> dict:
    reference, query = write_route(tmp_path, n, scale=scale)
    return {"loader": "folders", "reference": str(reference), "query": str(query), "tolerance": 2,
            "splits": {"train": [0, 8], "test": [8, n]}}


def test_folders_needs_only_reference_query_tolerance_and_splits(tmp_path):
    conf = basic(tmp_path)
    pair = load_dataset("corridor", conf)  # the configuration check's path
    assert pair.splits == {"train": (0, 8), "test": (8, 20)} and pair.tolerance == 2
    frames = load_frames("corridor", frames_settings(conf))  # the descriptors job's path: no splits reach it
    assert frames.reference.images == pair.reference.images and frames.query.images == pair.query.images
    assert frames.fingerprint() == pair.fingerprint()


def test_descriptors_job_runs_on_the_basic_settings(tmp_path):
    conf = basic(tmp_path)
    out = tmp_path / "sad.h5"
    status = cli(["descriptors", "--dataset", "corridor", "--dataset-settings", json.dumps(
        frames_settings(conf)), "--method", "sad", "--method-settings", '{"backend": "sad"}', "--out", str(out)])
    assert status == 0 and out.is_file()


def test_misspelt_loader_setting_is_named_with_the_valid_ones(tmp_path):
    conf = basic(tmp_path)
    conf["refrence"] = conf.pop("reference")
    with pytest.raises(DatasetError) as error:
        load_dataset("corridor", conf)
    message = str(error.value)
    assert "datasets.corridor.refrence" in message and "did you mean 'reference'?" in message
    assert "reference, query, reference_list, query_list, pairing" in message
    del conf["refrence"]
    with pytest.raises(DatasetError, match="loader 'folders' needs reference; e.g. reference: path/to/reference"):
        load_dataset("corridor", conf)


def test_misspelt_split_setting_is_named_with_the_closest_key(tmp_path):
    conf = basic(tmp_path)
    conf["tolerence"] = conf.pop("tolerance", 2)
    with pytest.raises(DatasetError) as error:
        load_dataset("corridor", conf)
    message = str(error.value)
    assert "datasets.corridor.tolerence" in message and "(did you mean 'tolerance'?)" in message
    assert message.endswith("its settings: loader, reference, query, reference_list, query_list, pairing, "
                            "reference_positions, query_positions, positions, frames, splits, tolerance, radius, "
                            "ground_truth")


# --- every image fully decoded ---


def truncate(path: Path, fraction: float = 0.25) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: int(len(data) * fraction)])


def test_truncated_jpeg_is_an_error_naming_it(tmp_path):
    reference, _ = write_route(tmp_path, 3, scale=10)  # 640 x 320: a quarter of the file holds image data
    bad = reference / "img2.jpg"
    assert cv2.imread(str(bad)) is not None
    truncate(bad)
    assert cv2.imread(str(bad)) is not None  # what OpenCV alone does: a grey fill and a warning
    with pytest.raises(DatasetError, match=rf"image {re.escape(str(bad))} is a truncated JPEG"):
        read_image(bad)
    (reference / "img3.jpg").write_bytes(b"")
    with pytest.raises(DatasetError, match="img3.jpg is empty"):
        read_image(reference / "img3.jpg")


def test_dataset_check_reports_a_truncated_jpeg(tmp_path, capsys):
    conf = basic(tmp_path, scale=10)
    truncate(Path(conf["query"]) / "img5.jpg")
    assert check_module.main(conf, name="corridor") == 1
    out = capsys.readouterr().out
    assert "unreadable files (query query, 1)" in out and "img5.jpg (image" in out and "truncated JPEG" in out
    assert "status: PROBLEMS (0 missing files, 1 unreadable files)" in out


def test_descriptors_job_stops_at_a_truncated_jpeg_and_writes_nothing(tmp_path, capsys):
    conf = basic(tmp_path, scale=10)
    truncate(Path(conf["reference"]) / "img7.jpg")
    out = tmp_path / "out" / "sad.h5"
    status = cli(["descriptors", "--dataset", "corridor", "--dataset-settings", json.dumps(
        frames_settings(conf)), "--method", "sad", "--method-settings", '{"backend": "sad"}', "--out", str(out)])
    assert status == 2
    assert "img7.jpg is a truncated JPEG" in capsys.readouterr().err
    assert not out.parent.exists() or not any(out.parent.iterdir())  # no file, not even a temporary one


# --- frame order ---


def test_frames_are_ordered_naturally(tmp_path):
    reference, query = write_route(tmp_path, 12)
    pair = load_frames("x", {"loader": "folders", "reference": str(reference), "query": str(query)})
    assert [p.name for p in pair.reference.images] == [f"img{i}.jpg" for i in range(1, 13)]
    assert pair.reference.order_note is None


@pytest.mark.parametrize(
    ("names", "expected"),
    [
        (["img1.png", "img2.png", "img10.png"], None),
        (["frame_0001_cam2.png", "frame_0002_cam2.png"], None),  # one number varies
        (["a.png", "b.png"], "no frame numbers"),
        (["day1.png", "night2.png"], "2 different patterns"),
        (["r@1@5@.png", "r@2@3@.png"], "2 numbers vary"),
        (["img01.png", "img1.png"], "the same frame number"),
    ],
)
def test_order_note(names, expected):
    note = order_note(names)
    assert note is None if expected is None else expected in note


def test_dataset_check_shows_the_order_and_warns_when_ambiguous(tmp_path, capsys):
    reference, query = write_route(tmp_path, 4, name="shot{}.jpg")
    for folder in (reference, query):
        (folder / "shot4.jpg").rename(folder / "extra.jpg")
    conf = {"loader": "folders", "reference": str(reference), "query": str(query)}
    assert check_module.main(conf) == 0  # a warning, not a problem
    out = capsys.readouterr().out
    assert "order: extra.jpg, shot1.jpg, shot2.jpg ... shot3.jpg" in out
    assert "warning: the names follow 2 different patterns" in out


def test_run_check_refuses_the_basic_settings_only_where_they_are_wrong(tmp_path, monkeypatch):
    """The configuration check and the job build the dataset the same way: what one accepts, the other runs."""
    from vpr_smr.pipeline.config import ConfigError, validate
    from vpr_smr.pipeline.plan import preflight

    conf = basic(tmp_path, 40)
    conf["splits"] = {"train": [0, 20], "val": [20, 30], "test": [30, 40]}
    monkeypatch.chdir(tmp_path)
    # the speed experiment off: its 2x query of a 20-frame train split leaves too few samples (test_preflight_speed);
    # the matchers experiment too: openseqslam's ratio window needs 14 references of a split, val has 10
    plan = preflight(validate({"run": "r", "datasets": {"corridor": conf}, "methods": {"sad": {"backend": "sad"}},
                               "experiments": {"speed": False, "matchers": False}}))
    settings = plan.datasets["corridor"].frames_settings
    assert "splits" not in settings and "tolerance" not in settings
    assert load_frames("corridor", settings).fingerprint() == plan.datasets["corridor"].frames_sha256
    conf["pairing"] = "by_date"
    with pytest.raises(ConfigError, match="datasets.corridor.pairing is 'by_date'; choose one of by_name, by_order"):
        preflight(validate({"run": "r", "datasets": {"corridor": conf}, "methods": {"sad": {"backend": "sad"}}}))


def test_a_train_split_too_short_for_the_predictor_is_refused_before_the_first_job(tmp_path, monkeypatch):
    """1 method, train split of 10 frames, L = 4: 7 samples; the predictor needs at least 11 (worked out in
    tests/unit/test_own_data_eval.py against scikit-learn), i.e. a train split of 11 + 4 - 1 = 14 frames."""
    from vpr_smr.pipeline.config import ConfigError, validate
    from vpr_smr.pipeline.plan import preflight

    conf = basic(tmp_path, 40)
    conf["splits"] = {"train": [0, 10], "val": [10, 20], "test": [20, 40]}
    run = {"run": "r", "datasets": {"corridor": conf}, "methods": {"sad": {"backend": "sad"}},
           # the speed experiment's simulated profiles shorten the train split (test_preflight_speed.py); the matchers
           # experiment's openseqslam needs 14 references of a split
           "experiments": {"speed": False, "matchers": False}}
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError) as error:
        preflight(validate(run))
    message = str(error.value)
    assert "datasets.corridor: split 'train' has 10 frames: 7 training samples per method at sequence length 4" \
        in message
    assert "lengthen split 'train' to at least 14 frames" in message
    conf["splits"]["train"] = [0, 14]
    conf["splits"]["val"] = [14, 20]
    preflight(validate(run))


def test_a_setting_of_the_wrong_kind_is_named(tmp_path):
    conf = basic(tmp_path, 4)
    conf["reference"] = 5  # YAML `reference: 5`: a number where a folder is wanted
    with pytest.raises(DatasetError, match="datasets.corridor: bad settings for loader 'folders'"):
        load_dataset("corridor", conf)
