"""The dataset cards of the report (pipeline.plan.dataset_cards): where each dataset's images came from, in the
loader's own words (``TraversePair.source``), with the frames, splits and the frame lists' SHA-256."""

import json
import shutil

from vpr_smr.datasets import load_dataset
from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT
from vpr_smr.pipeline.config import validate
from vpr_smr.pipeline.plan import dataset_cards, plan_from_json, plan_to_json, preflight


def test_the_shipped_sample_says_it_is_the_vendored_nordland_sample():
    source = load_dataset("sample", {"loader": "nordland_sample"}).source
    assert source.startswith("the Nordland 64x32 sample vendored with vpr-smr (data/nordland_sample)")
    assert "CC BY 3.0 (NRK / Nordland dataset)" in source and "data/nordland_sample/PROVENANCE.md" in source
    assert f"{DEFAULT_ROOT.resolve()}/summer (reference) and {DEFAULT_ROOT.resolve()}/winter (query)" in source
    sliced = load_dataset("sample", {"loader": "nordland_sample", "frames": [100, 160]}).source
    assert sliced == f"{source}; frames [100, 160) of its 3576 (the frames setting)"


def test_another_folder_names_its_folders_and_frame_lists(tmp_path, monkeypatch):
    for season in ("summer", "winter"):
        (tmp_path / "copy" / season).mkdir(parents=True)
        for n in (10, 20, 30):
            shutil.copy(DEFAULT_ROOT / season / f"images-{n:05d}.png", tmp_path / "copy" / season)
    copy = load_dataset("c", {"loader": "nordland_sample", "root": str(tmp_path / "copy"), "splits": {"all": [0, 3]}})
    assert "vendored" not in copy.source and f"{tmp_path}/copy/summer (reference)" in copy.source
    monkeypatch.chdir(tmp_path)  # relative folders and lists: named resolved
    (tmp_path / "ref.txt").write_text("images-00010.png\nimages-00020.png\n")
    (tmp_path / "qry.txt").write_text("images-00010.png\nimages-00020.png\n")
    folders = load_dataset("f", {"loader": "folders", "reference": "copy/summer", "query": "copy/winter",
                                 "reference_list": "ref.txt", "query_list": "qry.txt", "splits": {"all": [0, 2]}})
    assert folders.source == (f"image folders {tmp_path}/copy/summer (reference) and {tmp_path}/copy/winter (query): "
                              f"the frames named by the lists {tmp_path}/ref.txt and {tmp_path}/qry.txt")


def test_the_cards_carry_the_source_and_a_plan_without_it_is_made_again():
    conf = validate({"run": "r", "seq_lens": [3], "datasets": {"sample": {
        "loader": "nordland_sample", "frames": [1000, 1060], "splits": {"train": [0, 30], "val": [30, 40],
                                                                        "test": [40, 60]}}},
        "methods": {"sad": {"backend": "sad"}}, "experiments": {"matchers": False}})  # 10 frames: no openseqslam
    plan = preflight(conf)
    (card,) = dataset_cards(plan).values()
    assert card["source"].startswith("nordland_sample loader: the Nordland 64x32 sample vendored with vpr-smr")
    assert card["n_frames"] == 60 and card["splits"]["test"] == [40, 60] and len(card["frames_sha256"]) == 64
    saved = json.loads(json.dumps(plan_to_json(plan, conf)))
    assert plan_from_json(saved, conf) == plan
    del saved["plan"]["datasets"]["sample"]["source"]  # a plan written before the cards had a source
    assert plan_from_json(saved, conf) is None


def test_the_report_rule_gives_the_cards_in_the_configurations_order():
    from vpr_smr.pipeline.rule_helpers import report_datasets

    sample = {"loader": "nordland_sample", "splits": {"train": [0, 30], "val": [30, 40], "test": [40, 60]}}
    conf = validate({"run": "r", "seq_lens": [3], "methods": {"sad": {"backend": "sad"}}, "datasets": {
        "zeta": {**sample, "frames": [1000, 1060]}, "alpha": {**sample, "frames": [2000, 2060]}},
        "experiments": {"matchers": False}})  # 10-frame splits: too short for openseqslam's ratio window
    cards = json.loads(report_datasets(preflight(conf)))  # the report rule's --datasets (not sorted)
    assert list(cards) == ["zeta", "alpha"]
    assert all(list(card["splits"]) == ["train", "val", "test"] for card in cards.values())
    assert list(cards["zeta"]) == list(dataset_cards(preflight(conf))["zeta"])


def test_cards_of_a_dataset_with_positions_show_both_ranges_and_the_radius():
    # method §11: a split's reference range apart from its query range, and a radius instead of the tolerance
    from vpr_smr.eval.report.results import ground_truth_text, split_text

    splits = {"train": (0, 600), "test": (600, 900)}
    assert split_text(splits, {"train": (0, 400)}) == (
        "train references [0, 400): 400, queries [0, 600): 600; test [600, 900): 300 frames")
    assert split_text(splits) == "train [0, 600): 600 frames; test [600, 900): 300 frames"
    assert ground_truth_text({"tolerance": 2}) == "within 2 frames"
    assert ground_truth_text({"tolerance": 1}) == "within 1 frame"
    assert ground_truth_text({"tolerance": 2, "ground_truth": "GT.npz:GThard (a matrix)"}) == "GT.npz:GThard (a matrix)"
    assert ground_truth_text({"tolerance": 2, "radius": 25.0}) == "positions within 25 (the positions' unit)"
