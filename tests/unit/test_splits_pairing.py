"""Splits that never leak and pairings that are checked: refused unless a setting accepts the risk (an allowed
overlap through the whole workflow: test_splits_pairing_workflow.py)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
import yaml

from vpr_smr.datasets import DatasetError, load_dataset
from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT
from vpr_smr.pipeline.cli import main as cli
from vpr_smr.pipeline.config import ConfigError, validate
from vpr_smr.pipeline.plan import preflight, split_overlaps

SAMPLE = sorted(p.name for p in (DEFAULT_ROOT / "summer").iterdir())


def folders(tmp_path: Path, n: int, reference_name: str = "{}.png", query_name: str = "{}.png") -> tuple[Path, Path]:
    reference, query = tmp_path / "ref", tmp_path / "qry"
    for folder, season, name in ((reference, "summer", reference_name), (query, "winter", query_name)):
        folder.mkdir()
        for i in range(n):
            shutil.copy(DEFAULT_ROOT / season / SAMPLE[i], folder / name.format(i))
    return reference, query


def config(tmp_path: Path, splits: dict, **extra) -> dict:
    reference, query = folders(tmp_path, 111, "frame{}.png", "frame{}.png")
    dataset = {"loader": "folders", "reference": str(reference), "query": str(query), "splits": splits}
    # the matchers experiment off: openseqslam's ratio window needs 14 references of a split
    extra["experiments"] = {"matchers": False, **extra.get("experiments", {})}
    return {"run": "r", "output": str(tmp_path / "out"), "datasets": {"corridor": dataset},
            "methods": {"sad": {"backend": "sad"}}, **extra}


# --- overlapping splits ---


def test_split_overlaps_by_hand():
    assert split_overlaps({"train": (0, 60), "val": (60, 70), "test": (70, 111)}) == []
    assert split_overlaps({"train": (0, 60), "test": (40, 111)}) == [
        "'train' [0, 60) and 'test' [40, 111) share frames [40, 60)"]
    assert split_overlaps({"train": (0, 40), "val": (50, 60), "test": (45, 111)}) == [
        "'val' [50, 60) and 'test' [45, 111) share frames [50, 60)"]


def test_overlapping_train_and_test_are_refused_before_the_first_job(tmp_path):
    conf = validate(config(tmp_path, {"train": [0, 60], "val": [60, 70], "test": [40, 111]}))
    with pytest.raises(ConfigError) as error:
        preflight(conf)
    message = str(error.value)
    assert "datasets.corridor: splits 'train' [0, 60) and 'test' [40, 111) share frames [40, 60)" in message
    assert "'val' [60, 70) and 'test' [40, 111) share frames [60, 70)" in message  # a val inside test too
    assert "allow_split_overlap: true" in message


def test_overlap_allowed_explicitly_is_recorded(tmp_path):
    conf = validate(config(tmp_path, {"train": [0, 60], "val": [60, 70], "test": [40, 111]},
                           allow_split_overlap=True))
    plan = preflight(conf)
    assert plan.datasets["corridor"].overlaps == (
        "'train' [0, 60) and 'test' [40, 111) share frames [40, 60)",
        "'val' [60, 70) and 'test' [40, 111) share frames [60, 70)",
    )


def test_disjoint_splits_pass(tmp_path):
    plan = preflight(validate(config(tmp_path, {"train": [0, 60], "val": [60, 80], "test": [80, 111]})))
    assert plan.datasets["corridor"].overlaps == ()


# --- pairing of two folders ---


def test_same_names_pair_by_name(tmp_path):
    reference, query = folders(tmp_path, 5)
    pair = load_dataset("c", {"loader": "folders", "reference": str(reference), "query": str(query)})
    assert pair.pairing == "by file name (the same names in both folders)"


def test_same_numbers_pair_by_number(tmp_path):
    reference, query = folders(tmp_path, 12, "summer_{:03d}.png", "winter-{}.png")
    pair = load_dataset("c", {"loader": "folders", "reference": str(reference), "query": str(query)})
    assert pair.pairing.startswith("by the frame numbers in the file names")
    assert [p.name for p in pair.query.images][:3] == ["winter-0.png", "winter-1.png", "winter-2.png"]
    assert pair.reference.images[10].name == "summer_010.png" and pair.query.images[10].name == "winter-10.png"


def test_different_names_are_refused_unless_by_order(tmp_path):
    reference, query = folders(tmp_path, 6, "{}.png", "{}.png")
    for i, path in enumerate(sorted(query.iterdir(), key=lambda p: int(p.stem))):
        path.rename(query / f"shot{i + 100}.png")
    conf = {"loader": "folders", "reference": str(reference), "query": str(query)}
    with pytest.raises(DatasetError) as error:
        load_dataset("corridor", conf)
    message = str(error.value)
    assert "frame 0: 0.png vs shot100.png; frame 1: 1.png vs shot101.png; frame 2: 2.png vs shot102.png and 3 more" \
        in message
    assert "reference_list, query_list" in message and "pairing: by_order" in message
    pair = load_dataset("corridor", {**conf, "pairing": "by_order"})
    assert pair.pairing == "by position in natural order (pairing: by_order; the file names differ)"
    assert pair.query.images[5].name == "shot105.png"


def test_frame_lists_pair_line_by_line_and_must_come_together(tmp_path):
    reference, query = folders(tmp_path, 4, "a{}.png", "b{}.png")
    (tmp_path / "r.txt").write_text("a3.png\na1.png\n")
    (tmp_path / "q.txt").write_text("b0.png\nb2.png\n")
    conf = {"loader": "folders", "reference": str(reference), "query": str(query),
            "reference_list": str(tmp_path / "r.txt"), "query_list": str(tmp_path / "q.txt")}
    pair = load_dataset("c", conf)
    assert [p.name for p in pair.reference.images] == ["a3.png", "a1.png"]
    assert pair.pairing == "by the frame lists (line i of r.txt and q.txt)"
    del conf["query_list"]
    with pytest.raises(DatasetError, match="reference_list is set but query_list is not"):
        load_dataset("c", conf)


# --- dataset check: the configuration's keys as options ---


def test_dataset_check_with_options(tmp_path, capsys):
    reference, query = folders(tmp_path, 12, "s{}.png", "w{}.png")
    status = cli(["dataset", "check", "folders", "--reference", str(reference), "--query", str(query),
                  "--splits", "train=0:4", "val=4:6", "test=6:12"])
    out = capsys.readouterr().out
    assert status == 0, out
    assert "paired by the frame numbers in the file names (e.g. s0.png with w0.png):" in out
    assert "         0  s0.png   <->  w0.png" in out and "        11  s11.png  <->  w11.png" in out
    assert "split train [0, 4): 4 frames" in out and "split test [6, 12): 6 frames" in out


def test_dataset_check_with_a_configuration(tmp_path, capsys):
    conf = config(tmp_path, {"train": [0, 60], "val": [60, 80], "test": [80, 111]})
    path = tmp_path / "my.yaml"
    path.write_text(yaml.safe_dump(conf))
    assert cli(["dataset", "check", "--config", str(path), "--dataset", "corridor"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("dataset 'corridor': 111 aligned frames") and "split val [60, 80): 20 frames" in out
    assert cli(["dataset", "check", "--config", str(path)]) == 0  # its only dataset
    capsys.readouterr()
    assert cli(["dataset", "check", "--config", str(path), "--dataset", "other"]) == 2
    assert "datasets has no 'other'; it has corridor" in capsys.readouterr().err


def test_dataset_check_names_what_is_missing(tmp_path, capsys):
    assert cli(["dataset", "check", "folders"]) == 2
    err = capsys.readouterr().err
    assert "loader 'folders' needs --reference, --query" in err
    assert "vpr-smr dataset check folders --reference my_route/reference --query my_route/query" in err
    assert cli(["dataset", "check", "folders", "--root", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "loader 'folders' has no setting 'root'" in err and "--reference, --query" in err
    assert cli(["dataset", "check", "sfu_mountain"]) == 2
    assert "vpr-smr dataset check sfu_mountain --root /data/sfu_mountain" in capsys.readouterr().err
    assert cli(["dataset", "check", "folders", "--reference", "a", "--query", "b", "--splits", "train=0-40"]) == 2
    assert "--splits train: '0-40' is not a frame range LO:HI" in capsys.readouterr().err
    assert cli(["dataset", "check"]) == 2
    assert "--config my.yaml --dataset NAME" in capsys.readouterr().err
