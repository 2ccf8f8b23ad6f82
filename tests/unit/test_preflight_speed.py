"""The check before the first job knows velocity search (``sequence_matching.velocities``) and the speed experiment's
simulated profiles (method §11): a configuration they cannot run stops there, not inside a job; and the dataset cards
of a pair with positions give the query traverse's frames too."""

from __future__ import annotations

import json

import pytest
from street_dataset import plan_config

from vpr_smr.eval.matching.matcher import first_reference
from vpr_smr.eval.report.html import cards
from vpr_smr.eval.report.results import Order
from vpr_smr.eval.report.tables.datasets import dataset_rows
from vpr_smr.eval.scoring.speed import SpeedProfile, simulate
from vpr_smr.pipeline import plan as plan_module
from vpr_smr.pipeline.config import ConfigError, validate
from vpr_smr.pipeline.plan import dataset_cards, plan_from_json, plan_to_json, preflight

SPLITS = {"train": [0, 40], "val": [40, 60], "test": [60, 100]}


def config(tmp_path, splits=None, **extra) -> dict:
    """The shipped sample's 100 frames (no images written), one method, L = 3; the matchers experiment off (a split of
    fewer than 14 frames is too short for openseqslam's ratio window)."""
    extra["experiments"] = {"matchers": False, **extra.get("experiments", {})}
    return validate({"run": "r", "output": str(tmp_path / "out"), "seq_lens": [3],
                     "datasets": {"sample": {"loader": "nordland_sample", "frames": [1000, 1100],
                                             "splits": splits or SPLITS}},
                     "methods": {"sad": {"backend": "sad"}}, **extra})


def problems_of(conf: dict) -> list[str]:
    plan_module._check_datasets(conf, problems := [])
    return problems


def test_a_configuration_that_fits_passes(tmp_path):
    conf = config(tmp_path, sequence_matching={"velocities": [0.5, 1.0, 2.0]})
    assert "speed" in plan_module.experiments(conf)  # the default profiles 0.5x .. 2x and varying
    plan = preflight(conf)
    assert plan.datasets["sample"].n_query_frames == plan.datasets["sample"].n_frames == 100


def test_velocity_search_needs_the_slowest_trajectorys_references(tmp_path):
    # first_reference(5, [2.0]) = floor(2 * 4 + 0.5) = 8: 9 references; 'val' [40, 48) has 8
    assert first_reference(5, [2.0]) + 1 == 9
    conf = config(tmp_path, {"train": [0, 40], "val": [40, 48], "test": [60, 100]}, seq_lens=[3, 5],
                  sequence_matching={"velocities": [2.0]}, experiments={"speed": False})
    with pytest.raises(ConfigError) as error:
        preflight(conf)
    message = str(error.value)
    assert ("datasets.sample: split 'val' (references [40, 48), queries [40, 48)) cannot be matched by the matcher "
            "seqslam (velocities [2.0]) (sequence_matching) at sequence length 5: 8 references are too few for "
            "sequence length 5 at velocities [2.0]: the slowest trajectory spans 9 references; lengthen the split "
            "(its reference or query range), or change sequence_matching") in message
    assert "'train'" not in message and "'test'" not in message  # 40 frames each: enough
    # a velocity of 1 or less among them: L references suffice, as without velocity search
    assert problems_of(config(tmp_path, {"train": [0, 40], "val": [40, 48], "test": [60, 100]}, seq_lens=[3, 5],
                              sequence_matching={"velocities": [1.0, 2.0]},
                              experiments={"speed": False})) == []


def test_a_fast_profile_that_leaves_too_few_training_samples_is_named(tmp_path):
    # train [0, 16): 14 samples aligned (enough); at 4x 4 queries, 2 samples (fewer than the 11 needed)
    conf = config(tmp_path, {"train": [0, 16], "val": [40, 60], "test": [60, 100]},
                  speed={"profiles": [1.0, 4.0]})
    assert len(simulate(SpeedProfile.parse(4.0), 0, 16)[0]) == 4
    with pytest.raises(ConfigError) as error:
        preflight(conf)
    (problem,) = str(error.value).split("\n  ")[1:]
    assert problem.startswith("datasets.sample: speed experiment, split 'train' [0, 16) (train_split): the 4x "
                              "profile leaves 4 queries, 2 training samples per method at sequence length 3 "
                              "(table_seq_len), 2 pooled over 1 method(s); the experiment's pooled predictor needs "
                              "at least 11: ")
    assert problem.endswith("drop 4x from speed.profiles, lengthen split 'train', or set experiments: "
                            "{speed: false}")
    assert problems_of(config(tmp_path, {"train": [0, 16], "val": [40, 60], "test": [60, 100]},
                              speed={"profiles": [1.0, 4.0]}, experiments={"speed": False})) == []


def test_a_profile_that_leaves_fewer_queries_than_the_sequence_is_named(tmp_path):
    # test [60, 100) at 20x: 2 queries, fewer than L = 3; train [0, 40) at 20x: 2 too
    problems = problems_of(config(tmp_path, speed={"profiles": [0.5, 20.0]}))
    assert problems == [
        f"datasets.sample: speed experiment, split {split!r} [{lo}, {hi}) ({role}): the 20x profile leaves 2 "
        f"queries, fewer than the sequence length 3 (table_seq_len): drop 20x from speed.profiles, lengthen split "
        f"{split!r}, or set experiments: {{speed: false}}"
        for split, lo, hi, role in (("train", 0, 40, "train_split"), ("test", 60, 100, "table_split"))]


def test_the_speed_velocities_need_their_references(tmp_path):
    # table_seq_len 3 at velocities [30.0]: first_reference = 60, 61 references; the splits have 40
    problems = problems_of(config(tmp_path, speed={"profiles": [1.0], "velocities": [30.0]}))
    assert len(problems) == 2
    assert problems[0] == ("datasets.sample: speed experiment, split 'train' [0, 40) (train_split): velocity search "
                           "at sequence length 3 (table_seq_len) with velocities [30.0] (speed.velocities) needs at "
                           "least 61 reference frames, the split has 40: lengthen the split, give smaller "
                           "speed.velocities, or switch the experiment off (experiments: {speed: false})")


def test_datasets_with_positions_are_left_out_of_the_speed_checks_and_their_cards_count_queries(tmp_path):
    splits = {"train": {"reference": [0, 4], "query": [0, 2]}, "val": {"reference": [4, 5], "query": [2, 4]},
              "test": {"reference": [5, 8], "query": [4, 5]}}
    conf = plan_config(tmp_path, splits, speed={"profiles": [100.0]})
    datasets = plan_module._check_datasets(conf, problems := [])
    assert problems and not any("speed" in p for p in problems)  # too short to train, as ever; no speed check
    d = datasets["street"]
    assert (d.n_frames, d.n_query_frames) == (8, 5)
    plan = plan_module.Plan(datasets, {"sad": None}, (), {"sad": "mad"})
    assert plan_from_json(json.loads(json.dumps(plan_to_json(plan, conf))), conf) == plan
    card = dataset_cards(plan)["street"]
    assert (card["n_frames"], card["n_query_frames"]) == (8, 5)
    (shown,) = cards({"street": card}, Order(("street",)))
    assert ("frames", "8 reference, 5 query", False) in shown.items
    assert dataset_rows({"street": card})[0].n_frames == "8 / 5"


def test_a_frame_aligned_card_is_unchanged(tmp_path):
    plan = preflight(config(tmp_path, experiments={"speed": False}))
    card = dataset_cards(plan)["sample"]
    assert "n_query_frames" not in card and card["n_frames"] == 100
    (shown,) = cards({"sample": card}, Order(("sample",)))
    assert ("frames", "100", False) in shown.items
    assert dataset_rows({"sample": card})[0].n_frames == 100
