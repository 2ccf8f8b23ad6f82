import shutil

import numpy as np
import pytest

from vpr_smr.datasets import DatasetError, load_dataset, read_image
from vpr_smr.datasets.folders import folder_pair
from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT, SPLITS, nordland_sample


def test_shipped_sample():
    pair = nordland_sample()
    assert len(pair) == 3576
    assert pair.reference.images[0].name == "images-00010.png" == pair.query.images[0].name
    assert pair.reference.images[-1].name == "images-35760.png"
    assert pair.splits == SPLITS
    image = pair.query.read(0)
    assert image.shape == (32, 64, 3) and image.dtype == np.uint8


def make_tree(tmp_path, n_ref=6, n_query=6):
    for folder, n in (("ref", n_ref), ("qry", n_query)):
        (tmp_path / folder).mkdir()
        for i in range(n):
            shutil.copy(DEFAULT_ROOT / "summer" / f"images-{(i + 1) * 10:05d}.png",
                        tmp_path / folder / f"frame{i:03d}.png")
    return tmp_path / "ref", tmp_path / "qry"


def test_folder_pair_sorted(tmp_path):
    ref, qry = make_tree(tmp_path)
    pair = folder_pair("mine", ref, qry, {"all": (0, 6)})
    assert [p.name for p in pair.query.images] == [f"frame{i:03d}.png" for i in range(6)]


def test_mismatched_counts_name_the_files(tmp_path):
    ref, qry = make_tree(tmp_path, 6, 4)
    with pytest.raises(DatasetError, match=r"has 6 images but .* has 4.*only in .*ref: frame004.png, frame005.png"):
        folder_pair("mine", ref, qry, {"all": (0, 4)})


def test_list_file_with_missing_image(tmp_path):
    ref, qry = make_tree(tmp_path)
    (tmp_path / "list.txt").write_text("frame000.png\nframe001.png\nframe009.png\n")
    with pytest.raises(DatasetError, match=r"2 images are missing: .*ref/frame009.png, .*qry/frame009.png"):
        folder_pair("mine", ref, qry, {"all": (0, 3)}, reference_list=tmp_path / "list.txt",
                    query_list=tmp_path / "list.txt")


def test_unreadable_image_names_its_file(tmp_path):
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"not a png")
    with pytest.raises(DatasetError, match="cannot decode image .*bad.png"):
        read_image(bad)


def test_split_outside_frames(tmp_path):
    ref, qry = make_tree(tmp_path)
    with pytest.raises(DatasetError, match=r"split 'test' = \[4, 9\) is outside the 6 frames"):
        folder_pair("mine", ref, qry, {"test": (4, 9)})


def test_load_dataset_slice_and_errors():
    pair = load_dataset("s", {"loader": "nordland_sample", "frames": [100, 160],
                              "splits": {"train": [0, 30], "test": [30, 60]}})
    assert len(pair) == 60 and pair.reference.images[0].name == "images-01010.png"
    assert pair.name == "s"
    with pytest.raises(DatasetError, match="datasets.x.loader is 'nope'"):
        load_dataset("x", {"loader": "nope"})
    with pytest.raises(DatasetError, match="image folder not found"):
        load_dataset("x", {"loader": "nordland_sample", "root": "/does/not/exist"})
