"""Loaders of the full benchmarks (Nordland, Oxford RobotCar, SFU Mountain) and the dataset check.

Every test builds a small tree in the dataset's layout from the real 64x32 Nordland sample frames, with short
frame lists in the published formats; RobotCar frames are turned back into GBRG Bayer mosaics.
"""

from __future__ import annotations

import pickle
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest
from benchmark_trees import (
    DUSK,
    RAIN,
    SAMPLE,
    SAMPLE_NAMES,
    colourise,
    mosaic_gbrg,
    nordland_lists,
    nordland_tree,
    robotcar_list,
    robotcar_tree,
    sample_rgb,
    sfu_tree,
    write_lines,
    write_rgb,
)

from vpr_smr.datasets import DatasetError, Traverse, load_dataset
from vpr_smr.datasets import check as check_module
from vpr_smr.datasets.nordland import REFERENCE_LIST as NORDLAND_LIST
from vpr_smr.datasets.nordland import nordland
from vpr_smr.datasets.robotcar import GBRG_TO_RGB, BayerTraverse, demosaic_gbrg, read_bayer_image, robotcar
from vpr_smr.datasets.sfu_mountain import sfu_mountain

# --- helpers ---


def interior_error(a: np.ndarray, b: np.ndarray) -> float:
    """Mean absolute difference away from the 2-pixel border (demosaicing extrapolates at the edges)."""
    return float(np.abs(a.astype(np.int64) - b.astype(np.int64))[2:-2, 2:-2].mean())


def corrupt(path: Path) -> None:
    path.write_bytes(b"\x89PNG\r\n\x1a\n this is not an image")


# --- Nordland ---


def test_nordland_frames_follow_the_list_order(tmp_path: Path) -> None:
    root = tmp_path / "nordland"
    nordland_tree(root, SAMPLE_NAMES)
    chosen = SAMPLE_NAMES[::-1][:24]  # a subset in an order that is not the sorted one
    lists = nordland_lists(tmp_path, chosen)
    pair = nordland(root, **lists, splits={"train": (0, 8), "val": (8, 16), "test": (16, 24)}, tolerance=3)
    assert len(pair) == 24 and pair.tolerance == 3
    assert pair.reference.images == tuple(root / "summer" / n for n in chosen)
    assert pair.query.images == tuple(root / "winter" / n for n in chosen)
    assert (pair.reference.name, pair.query.name) == ("summer", "winter")
    assert pair.split_range("val") == (8, 16)
    np.testing.assert_array_equal(pair.reference.read(5), sample_rgb("summer", chosen[5]))
    np.testing.assert_array_equal(pair.query.read(5), sample_rgb("winter", chosen[5]))
    assert check_module.check_dataset(pair).ok


def test_nordland_default_list_order_and_missing_files(tmp_path: Path) -> None:
    listed = [Path(line).name for line in NORDLAND_LIST.read_text().split()]
    assert len(listed) == 27592 and listed[0] == "images-00202.png" and listed[-1] == "images-35582.png"
    present = [0, 1, 2, 700, 5000]  # three train frames, one val, one test
    root = tmp_path / "nordland"
    for season in ("summer", "winter"):
        (root / season).mkdir(parents=True)
        for i in present:
            shutil.copy(SAMPLE / season / SAMPLE_NAMES[0], root / season / listed[i])

    with pytest.raises(DatasetError) as error:
        nordland(root)
    message = str(error.value)
    assert str(root) in message
    assert "55174 of the 55184 images" in message
    assert f"summer/{listed[3]}, summer/{listed[4]}" in message and "and 55169 more" in message

    pair = nordland(root, check_files=False)  # what `dataset check` does
    assert len(pair) == 27592
    assert [p.name for p in pair.reference.images] == listed
    assert [p.name for p in pair.query.images] == listed
    assert pair.splits == {"train": (0, 500), "val": (500, 1000), "test": (1000, 10000)}
    assert pair.tolerance == 2

    report = check_module.check_dataset(pair)
    assert report.status == 1
    assert [t.found for t in report.traverses] == [5, 5]
    assert [(s.name, s.both) for s in report.splits] == [("train", 3), ("val", 1), ("test", 1)]
    text = check_module.format_report(report)
    assert "reference summer: 5 of 27592 frames found and readable, 27587 missing" in text
    assert "split test [1000, 10000): 9000 frames; reference 1, query 1, both 1 (8999 incomplete)" in text
    assert f"missing files (query winter, 27587): {root / 'winter' / listed[3]}" in text
    assert "and 27582 more" in text
    assert text.endswith("status: PROBLEMS (55174 missing files, 0 unreadable files)")


def test_nordland_missing_root(tmp_path: Path) -> None:
    with pytest.raises(DatasetError, match="root folder .*nowhere does not exist") as error:
        nordland(tmp_path / "nowhere")
    fix = "set datasets.nordland.root (or --root) to the folder that holds summer/ and winter/"
    assert fix in str(error.value)


def test_nordland_root_one_level_too_high(tmp_path: Path) -> None:
    nordland_tree(tmp_path / "data" / "nordland", SAMPLE_NAMES[:3])
    lists = nordland_lists(tmp_path, SAMPLE_NAMES[:3])
    with pytest.raises(DatasetError) as error:
        nordland(tmp_path / "data", **lists)
    message = str(error.value)
    assert f"2 image folder(s) missing under root {tmp_path / 'data'}: summer, winter" in message
    assert f"did you mean root = {tmp_path / 'data' / 'nordland'}?" in message


def test_nordland_mismatched_lists(tmp_path: Path) -> None:
    nordland_tree(tmp_path, SAMPLE_NAMES[:6])
    shorter = nordland_lists(tmp_path, SAMPLE_NAMES[:6], SAMPLE_NAMES[:5])
    with pytest.raises(DatasetError, match=r"index\.txt names 6 frames but .*query\.txt names 5"):
        nordland(tmp_path, **shorter)
    swapped = [SAMPLE_NAMES[0], SAMPLE_NAMES[2], SAMPLE_NAMES[1], *SAMPLE_NAMES[3:6]]
    other = nordland_lists(tmp_path, SAMPLE_NAMES[:6], swapped)
    with pytest.raises(DatasetError, match="name different frames") as error:
        nordland(tmp_path, **other)
    assert f"line 2: {SAMPLE_NAMES[1]} vs {SAMPLE_NAMES[2]}; line 3: " in str(error.value)


def test_nordland_bad_list_and_splits(tmp_path: Path) -> None:
    nordland_tree(tmp_path, SAMPLE_NAMES[:6])
    with pytest.raises(DatasetError, match=r"frame list .*absent\.txt not found; fix or remove query_list"):
        nordland(tmp_path, query_list=tmp_path / "absent.txt")
    lists = nordland_lists(tmp_path, SAMPLE_NAMES[:6])
    with pytest.raises(DatasetError, match=r"split 'train' = \[0, 500\) is outside the 6 frames"):
        nordland(tmp_path, **lists)  # the default splits need the full list


def test_nordland_corrupt_image_is_named(tmp_path: Path) -> None:
    nordland_tree(tmp_path, SAMPLE_NAMES[:6])
    corrupt(tmp_path / "winter" / SAMPLE_NAMES[4])
    pair = nordland(tmp_path, **nordland_lists(tmp_path, SAMPLE_NAMES[:6]), splits={"all": (0, 6)})
    with pytest.raises(DatasetError, match=f"cannot decode image .*winter/{SAMPLE_NAMES[4]}"):
        pair.query.read(4)
    report = check_module.check_dataset(pair, workers=2)
    assert report.status == 1 and report.traverses[1].unreadable == [4]
    text = check_module.format_report(report)
    bad = tmp_path / "winter" / SAMPLE_NAMES[4]
    assert f"unreadable files (query winter, 1): {bad} (cannot decode" in text
    assert "split all [0, 6): 6 frames; reference 6, query 5, both 5 (1 incomplete)" in text


# --- Oxford RobotCar ---


def test_gbrg_demosaic_recovers_a_known_image() -> None:
    rgb = colourise(sample_rgb("summer", SAMPLE_NAMES[0]))
    raw = mosaic_gbrg(rgb)
    assert interior_error(demosaic_gbrg(raw), rgb) < 4
    if hasattr(cv2, "COLOR_BayerGBRG2RGB"):  # OpenCV >= 4.x spells the same code by the usual naming
        assert GBRG_TO_RGB == cv2.COLOR_BayerGBRG2RGB
    # Every other pattern, including the tempting COLOR_BayerGB2RGB, gets the colours badly wrong.
    for code in (cv2.COLOR_BayerGB2RGB, cv2.COLOR_BayerRG2RGB, cv2.COLOR_BayerBG2RGB, cv2.COLOR_BayerGR2BGR):
        assert interior_error(cv2.cvtColor(raw, code), rgb) > 20
    # A flat colour comes back exactly, channel by channel.
    flat = np.empty((8, 10, 3), np.uint8)
    flat[:] = (200, 120, 40)
    np.testing.assert_array_equal(demosaic_gbrg(mosaic_gbrg(flat)), flat)


def test_robotcar_frames_lists_and_demosaicing(tmp_path: Path) -> None:
    rain = [1446121102254997, 1446121102254997, *range(1446121102400000, 1446121102400022)]  # a repeat
    dusk = list(range(1416586027583964, 1416586027583988))
    truth = robotcar_tree(tmp_path, {RAIN: rain, DUSK: dusk})
    lists = {
        "reference_list": robotcar_list(tmp_path / "rain.csv", rain),
        "query_list": robotcar_list(tmp_path / "dusk.csv", dusk),
    }
    pair = robotcar(tmp_path, **lists, splits={"train": (0, 10), "test": (10, 24)})
    assert len(pair) == 24 and pair.tolerance == 2
    assert isinstance(pair.reference, BayerTraverse) and isinstance(pair.query, BayerTraverse)
    assert (pair.reference.name, pair.query.name) == (RAIN, DUSK)
    assert pair.reference.images == tuple(tmp_path / RAIN / "stereo" / "left" / f"{s}.png" for s in rain)
    assert pair.query.images[7] == tmp_path / DUSK / "stereo" / "left" / f"{dusk[7]}.png"
    assert pair.reference.images[0] == pair.reference.images[1]

    image = pair.reference.read(3)
    assert image.shape == (32, 64, 3) and image.dtype == np.uint8
    assert interior_error(image, truth[RAIN, rain[3]]) < 4
    assert interior_error(pair.query.read(20), truth[DUSK, dusk[20]]) < 4

    # An already demosaiced 3-channel copy is taken as it is.
    write_rgb(pair.query.images[5], truth[DUSK, dusk[5]])
    np.testing.assert_array_equal(pair.query.read(5), truth[DUSK, dusk[5]])

    report = check_module.check_dataset(pair, workers=2)
    assert report.ok and report.traverses[0].sizes == {"64x32x3": 23}  # 24 frames, 23 files

    # Through the configuration, as the pipeline loads it.
    conf = {"loader": "robotcar", "root": str(tmp_path), **lists, "splits": {"all": [0, 24]}}
    loaded = load_dataset("orc", conf)
    assert loaded.name == "orc" and isinstance(loaded.query, BayerTraverse)
    assert interior_error(loaded.query.read(0), truth[DUSK, dusk[0]]) < 4


def test_bayer_traverse_pickles(tmp_path: Path) -> None:
    stamps = [1, 2, 3]
    truth = robotcar_tree(tmp_path, {RAIN: stamps})
    traverse = BayerTraverse(RAIN, tuple(tmp_path / RAIN / "stereo" / "left" / f"{s}.png" for s in stamps))
    copy = pickle.loads(pickle.dumps(traverse))
    assert type(copy) is BayerTraverse and copy == traverse
    assert interior_error(copy.read(1), truth[RAIN, 2]) < 4
    assert isinstance(copy, Traverse)


def test_load_dataset_frames_slice_keeps_the_bayer_reader(tmp_path: Path) -> None:
    stamps = list(range(100, 112))
    robotcar_tree(tmp_path, {RAIN: stamps, DUSK: stamps})
    conf = {
        "loader": "robotcar",
        "root": str(tmp_path),
        "reference_list": robotcar_list(tmp_path / "rain.csv", stamps),
        "query_list": robotcar_list(tmp_path / "dusk.csv", stamps),
        "splits": {"all": [0, 6]},
        "frames": [2, 8],
    }
    assert isinstance(load_dataset("orc", conf).reference, BayerTraverse)


def test_robotcar_default_lists(tmp_path: Path) -> None:
    (tmp_path / RAIN / "stereo" / "left").mkdir(parents=True)
    (tmp_path / DUSK / "stereo" / "left").mkdir(parents=True)
    pair = robotcar(tmp_path, check_files=False)
    assert len(pair) == 3876
    assert pair.splits == {"train": (0, 500), "val": (500, 1000), "test": (1000, 2000)}
    assert pair.reference.images[0].name == pair.reference.images[1].name == "1446121102254997.png"
    assert pair.query.images[0] == tmp_path / DUSK / "stereo" / "left" / "1416586027583964.png"
    assert pair.reference.images[-1].name == "1446122140640110.png"
    assert len(set(pair.reference.images)) == 3689 and len(set(pair.query.images)) == 3723


def test_robotcar_errors(tmp_path: Path) -> None:
    with pytest.raises(DatasetError, match="root folder .*absent does not exist") as error:
        robotcar(tmp_path / "absent")
    assert f"run folders {RAIN}/ and {DUSK}/, each with stereo/left/<timestamp>.png" in str(error.value)

    stamps = list(range(10, 22))
    robotcar_tree(tmp_path, {RAIN: stamps})  # no Dusk run
    lists = {
        "reference_list": robotcar_list(tmp_path / "rain.csv", stamps),
        "query_list": robotcar_list(tmp_path / "dusk.csv", stamps),
    }
    missing_run = f"1 image folder.* missing under root {tmp_path}: {DUSK}/stereo/left;"
    with pytest.raises(DatasetError, match=missing_run):
        robotcar(tmp_path, **lists)

    robotcar_tree(tmp_path, {DUSK: stamps[:4]})
    missing_files = f"8 of the 24 images .*: {DUSK}/stereo/left/14.png, .* and 3 more"
    with pytest.raises(DatasetError, match=missing_files):
        robotcar(tmp_path, **lists)

    short = robotcar_list(tmp_path / "short.csv", stamps[:11])
    with pytest.raises(DatasetError, match=r"rain\.csv has 12 places but .*short\.csv has 11"):
        robotcar(tmp_path, reference_list=lists["reference_list"], query_list=short)

    gap = write_lines(tmp_path / "gap.csv", ["000000.png,10.png", "000002.png,11.png"])
    with pytest.raises(DatasetError, match=r"gap\.csv row 2 has index 000002\.png where 1 was expected"):
        robotcar(tmp_path, reference_list=gap, query_list=gap)


def test_robotcar_corrupt_image(tmp_path: Path) -> None:
    stamps = list(range(10, 16))
    robotcar_tree(tmp_path, {RAIN: stamps, DUSK: stamps})
    bad = tmp_path / RAIN / "stereo" / "left" / "12.png"
    corrupt(bad)
    lists = {
        "reference_list": robotcar_list(tmp_path / "rain.csv", stamps),
        "query_list": robotcar_list(tmp_path / "dusk.csv", stamps),
    }
    pair = robotcar(tmp_path, **lists, splits={"all": (0, 6)})
    with pytest.raises(DatasetError, match=f"cannot decode image {bad}"):
        read_bayer_image(bad)
    report = check_module.check_dataset(pair, workers=1)
    assert report.traverses[0].unreadable == [2] and report.status == 1


# --- SFU Mountain ---


def test_sfu_mountain_frames(tmp_path: Path) -> None:
    lines = sfu_tree(tmp_path, {"part_a": 14, "part_b": 10})
    lists = {
        "reference_list": write_lines(tmp_path / "dry.txt", lines["dry"]),
        "query_list": write_lines(tmp_path / "dusk.txt", lines["dusk"]),
    }
    pair = sfu_mountain(tmp_path, **lists, splits={"train": (0, 8), "val": (8, 16), "test": (16, 24)})
    assert len(pair) == 24 and (pair.reference.name, pair.query.name) == ("dry", "dusk")
    assert pair.reference.images[0] == tmp_path / "part_a" / "stereo_right" / "dry" / "frames" / "a001.jpg"
    assert pair.reference.images[14] == tmp_path / "part_b" / "stereo_right" / "dry" / "frames" / "b001.jpg"
    assert pair.query.images[23] == tmp_path / "part_b" / "stereo_right" / "dusk" / "frames" / "b010.jpg"
    # JPEG is lossy: compare loosely with the frame that was written.
    assert interior_error(pair.query.read(3), sample_rgb("winter", SAMPLE_NAMES[3])) < 6
    assert check_module.check_dataset(pair).ok


def test_sfu_mountain_default_lists(tmp_path: Path) -> None:
    pair = sfu_mountain(tmp_path, check_files=False)
    assert len(pair) == 375
    assert pair.splits == {"train": (0, 100), "val": (100, 200), "test": (200, 375)}
    assert pair.reference.images[238] == tmp_path / "part_a" / "stereo_right" / "dry" / "frames" / "a239.jpg"
    assert pair.query.images[239] == tmp_path / "part_b" / "stereo_right" / "dusk" / "frames" / "b001.jpg"


def test_sfu_mountain_errors(tmp_path: Path) -> None:
    with pytest.raises(DatasetError, match="root folder .*absent does not exist") as error:
        sfu_mountain(tmp_path / "absent")
    assert "set datasets.sfu_mountain.root (or --root) to the folder that holds part_a/ and part_b/" in str(
        error.value
    )

    lines = sfu_tree(tmp_path, {"part_a": 6})
    dry = write_lines(tmp_path / "dry.txt", lines["dry"])
    dusk = write_lines(tmp_path / "dusk.txt", lines["dusk"])
    (tmp_path / "part_a" / "stereo_right" / "dusk" / "frames" / "a002.jpg").unlink()
    missing_file = r"1 of the 12 images .*: part_a/stereo_right/dusk/frames/a002\.jpg\."
    with pytest.raises(DatasetError, match=missing_file):
        sfu_mountain(tmp_path, reference_list=dry, query_list=dusk)

    short = write_lines(tmp_path / "short.txt", lines["dusk"][:5])
    with pytest.raises(DatasetError, match=r"dry\.txt names 6 frames but .*short\.txt names 5"):
        sfu_mountain(tmp_path, reference_list=dry, query_list=short)

    escape = write_lines(tmp_path / "escape.txt", ["../outside/a001.jpg"])
    with pytest.raises(DatasetError, match="lines must be paths relative to the dataset folder"):
        sfu_mountain(tmp_path, reference_list=escape, query_list=escape)


# --- the dataset check command ---


def test_check_main(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    lines = sfu_tree(tmp_path, {"part_a": 5})
    lists = {
        "reference_list": str(write_lines(tmp_path / "dry.txt", lines["dry"])),
        "query_list": str(write_lines(tmp_path / "dusk.txt", lines["dusk"])),
        "splits": {"all": (0, 5)},
    }
    sfu = {"loader": "sfu_mountain", "root": str(tmp_path), **lists}
    assert check_module.main(sfu) == 0
    out = capsys.readouterr().out
    assert "reference dry: 5 of 5 frames found and readable" in out and out.rstrip().endswith("status: OK")

    corrupt(tmp_path / "part_a" / "stereo_right" / "dry" / "frames" / "a003.jpg")
    (tmp_path / "part_a" / "stereo_right" / "dusk" / "frames" / "a005.jpg").unlink()
    assert check_module.main(sfu) == 1
    out = capsys.readouterr().out
    assert "unreadable files (reference dry, 1): " in out and "a003.jpg (cannot decode image" in out
    assert "missing files (query dusk, 1): " in out and "a005.jpg" in out
    assert "status: PROBLEMS (1 missing files, 1 unreadable files)" in out

    assert check_module.main({"loader": "sfu_mountain", "root": str(tmp_path / "absent")}) == 2
    assert "root folder" in capsys.readouterr().err
    assert check_module.main({"loader": "no_such_loader", "root": str(tmp_path)}) == 2
    assert "choose one of" in capsys.readouterr().err
    assert check_module.main({"loader": "sfu_mountain", "root": str(tmp_path), "colour": "red"}) == 2
    assert "has no setting 'colour'" in capsys.readouterr().err
