"""The speed experiment (method §11, simulated speed profiles): the simulated query, the stage against Table I's own
computation, velocity search against the fixed matcher, the command line, the configuration and the report."""

import csv
import dataclasses
import html
import math
import re
from pathlib import Path

import h5py
import numpy as np
import pytest
from helpers import write_distance_matrix

from vpr_smr.core.records import load
from vpr_smr.eval.matching.attributes import query_features
from vpr_smr.eval.matching.ground_truth import GroundTruth
from vpr_smr.eval.predictor.defaults import PredictorParams
from vpr_smr.eval.scoring import speed
from vpr_smr.eval.scoring.speed import SpeedProfile, simulate, simulated_split
from vpr_smr.pipeline.cli import main as cli

# --- profiles and the simulated query ----------------------------------------------------------------------------


@pytest.mark.parametrize(("value", "name", "constant"), [
    (0.5, "0.5x", 0.5), ("0.5x", "0.5x", 0.5), ("2", "2x", 2.0), (1.0, "1x", 1.0), ("1.25x", "1.25x", 1.25),
    ("varying", "varying", None),
])
def test_profiles_are_named_by_their_speed(value, name, constant):
    profile = SpeedProfile.parse(value)
    assert (profile.name, profile.speed) == (name, constant)


@pytest.mark.parametrize("value", ["fast", "0x", "-1", "nanx", "inf", "", 0, -0.5, True, 1 / 3])
def test_a_bad_profile_is_refused(value):
    # 1/3: its name would not give its speed back to the job that reads it
    with pytest.raises(ValueError, match="speed profile"):
        SpeedProfile.parse(value)


def test_the_stage_refuses_a_split_with_positions(tmp_path):
    # method §11's simulation starts from a frame-aligned split: a distance file with positions is not one
    path = tmp_path / "test.h5"
    write_distance_matrix(path, np.ones((6, 6)), {"split": "test", "split_range": [0, 6]})
    with h5py.File(path, "a") as f:
        f["reference_positions"], f["query_positions"] = np.arange(6.0), np.arange(6.0)
    with pytest.raises(ValueError, match="a split of a dataset with positions"):
        speed._split_of(path, (6, 6))


def test_constant_profiles_by_hand():
    # 1.5x from lo = 10: p = 10, 11.5, 13, 14.5, 16, 17.5, 19 (then 20.5, frame 21: past hi = 20)
    frames, positions = simulate(SpeedProfile.parse("1.5x"), 10, 20)
    assert positions.tolist() == [10, 11.5, 13, 14.5, 16, 17.5, 19]
    assert frames.tolist() == [10, 12, 13, 15, 16, 18, 19]
    # 0.5x: p = 10, 10.5, ..., 13 (13.5 rounds to frame 14 = hi): every frame twice but the first
    frames, positions = simulate(SpeedProfile.parse("0.5x"), 10, 14)
    assert positions.tolist() == [10, 10.5, 11, 11.5, 12, 12.5, 13]
    assert frames.tolist() == [10, 11, 11, 12, 12, 13, 13]
    # 2x: every other frame; p = 8 is past hi = 7
    frames, positions = simulate(SpeedProfile.parse("2x"), 0, 7)
    assert positions.tolist() == [0, 2, 4, 6] and frames.tolist() == [0, 2, 4, 6]
    # 2x from an odd length: the last frame inside is 6 (p = 8 -> frame 8 >= 8)
    assert simulate(SpeedProfile.parse("2x"), 0, 8)[0].tolist() == [0, 2, 4, 6]


def test_the_varying_profile_speeds_up_and_slows_down():
    frames, positions = simulate(SpeedProfile.parse("varying"), 100, 700)
    # the first steps by hand: s(0) = 1, s(1) = 1 + 0.5 sin(pi / 100) = 1.01570538...
    assert positions[:3] == pytest.approx([100, 101, 102.01570538])
    # the recurrence written out one step at a time, as method §11 states it
    p, t, expected = 100.0, 0, []
    while math.floor(p + 0.5) < 700:
        expected.append(p)
        p += 1 + 0.5 * math.sin(2 * math.pi * t / 200)
        t += 1
    assert positions.tolist() == pytest.approx(expected, abs=1e-9)
    assert frames.tolist() == [math.floor(v + 0.5) for v in expected]
    steps = np.diff(frames)
    # fast near t = 50 (s = 1.5: some frames skipped), slow near t = 150 (s = 0.5: frames repeated)
    assert steps[40:60].max() == 2 and steps[140:160].min() == 0


def test_profile_1x_is_the_aligned_split():
    rng = np.random.default_rng(1)
    matrix = rng.random((30, 30))
    frames, positions = simulate(SpeedProfile.parse(1.0), 40, 70)
    assert frames.tolist() == list(range(40, 70)) and positions.tolist() == list(range(40, 70))
    simulated, truth = simulated_split(matrix, 40, frames, positions, 2)
    assert np.array_equal(simulated, matrix)
    aligned = GroundTruth.aligned(30, 30, 2)
    references, queries = np.meshgrid(np.arange(30), np.arange(30), indexing="ij")
    assert np.array_equal(truth.correct(references, queries), aligned.correct(references, queries))
    assert np.array_equal(truth.correct(references, queries), np.abs(references - queries) <= 2)
    mine, theirs = query_features(simulated, 4, 2, ground_truth=truth), query_features(matrix, 4, 2)
    for field in ("labels", "sequence_match", "single_match", "all_single_correct", "sequence_correct"):
        assert np.array_equal(getattr(mine, field), getattr(theirs, field)), field
    assert np.array_equal(mine.attributes[:, 0], theirs.attributes[:, 0])


def test_the_simulated_matrix_is_the_aligned_ones_columns():
    matrix = np.arange(12 * 12, dtype=np.float32).reshape(12, 12)
    frames, positions = simulate(SpeedProfile.parse("1.5x"), 100, 112)  # frames 100, 102, 103, 105, ...
    simulated, truth = simulated_split(matrix, 100, frames, positions, 1)
    assert np.array_equal(simulated, matrix[:, [0, 2, 3, 5, 6, 8, 9, 11]])
    # query 1 is at place 1.5 of the split: references 1 and 2 are within 1, reference 0 and 3 are not
    assert truth.correct(np.array([0, 1, 2, 3]), np.array([1, 1, 1, 1])).tolist() == [False, True, True, False]


# --- the stage ------------------------------------------------------------------------------------------------------

SPLITS = {"train": (0, 160), "test": (160, 400)}
PARAMS = {"hidden_layer_sizes": [16, 16], "max_iter": 300}


def aligned_matrix(n: int, seed: int) -> np.ndarray:
    """A frame-aligned pair's matrix: uniform noise, 0.5 lower where reference and query are the same place; a
    single frame finds its place about half the time, a sequence of 4 almost always (when aligned)."""
    rng = np.random.default_rng(seed)
    return rng.random((n, n)) + 0.5 * (1 - np.eye(n))


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """Two methods' train and test distance files (HDF5, as the distances stage writes them)."""
    folder = tmp_path_factory.mktemp("speed")
    files: dict[str, dict[str, Path]] = {"train": {}, "test": {}}
    for seed, method in enumerate(("a", "b")):
        whole = aligned_matrix(400, seed)
        for split, (lo, hi) in SPLITS.items():
            path = folder / f"{method}_{split}.h5"
            write_distance_matrix(path, whole[lo:hi, lo:hi], {"dataset": "d", "method": method, "split": split,
                                                              "split_range": [lo, hi]})
            files[split][method] = path
    return files


def job(train, test, out, profile="1x", velocities=(1.0, 2.0)):
    """The stage's job record: the dataset d at L = 4, tolerance 2, the test predictor's settings."""
    return speed.SpeedJob("d", 4, profile, tuple(velocities), 2, {m: str(p) for m, p in train.items()},
                          {m: str(p) for m, p in test.items()}, PredictorParams.of(PARAMS), out=str(out))


def run_stage(dataset, profile, tmp_path, velocities=(0.5, 1.0, 2.0)):
    out = tmp_path / f"{profile}.json"
    speed.main(job(dataset["train"], dataset["test"], out, profile, velocities))
    return load(out, speed.SpeedResult)


def test_profile_1x_gives_table_1s_numbers(dataset, tmp_path):
    from helpers import read_distance_matrix

    from vpr_smr.eval.predictor.train import predictor_params, train_seed
    from vpr_smr.eval.scoring.evaluate import evaluate_split

    result = run_stage(dataset, "1x", tmp_path)
    # Table I's computation: the pooled predictor of seed 0 (train_seed, as vpr-smr train), then evaluate_split
    train = [query_features(read_distance_matrix(dataset["train"][m]), 4, 2) for m in ("a", "b")]
    x = np.concatenate([f.attributes[:, 0] for f in train])
    y = np.concatenate([f.labels for f in train])
    predictor, _ = train_seed(x, y, predictor_params(PARAMS), 0)
    fixed = result.matchers["fixed"]
    assert fixed.velocities == (1.0,) and fixed.n_train == len(y) == 2 * (160 - 3)
    assert fixed.train_class_counts == tuple(np.bincount(y, minlength=4))
    for method in ("a", "b"):
        features = query_features(read_distance_matrix(dataset["test"][method]), 4, 2)
        table1, _ = evaluate_split(features, predictor, modes=("paper",), trust_levels=())
        paper = table1.modes["paper"]
        mine = fixed.methods[method]
        assert mine.n_queries == table1.n_queries == 240 - 3 and mine.n_queries_single == 240
        assert mine.recall_at_1_single == paper.recall_at_1_single == table1.recall_at_1_single_all
        assert mine.recall_at_1_sequence == paper.recall_at_1_sequence
        # every number of Table I's reduction, its outcome too; Table I's alone carries the intervals (method §8.7),
        # so a worse_from_zero, which only an interval earns, is no_interval here whatever Table I's interval said
        outcome = paper.reduction.outcome
        if paper.reduction.reduction_pct is None and outcome in ("worse_from_zero", "interval_holds_0",
                                                                 "interval_against_sign"):
            outcome = "no_interval"
        assert mine.reduction == dataclasses.replace(paper.reduction, reduction_pct_ci=None, aoc_vpr_sm_ci=None,
                                                     aoc_vpr_sm_pred_ci=None, aoc_difference_ci=None, outcome=outcome)
        assert mine.f1_macro == table1.f1_macro
    assert result.meta == {"dataset": "d", "seq_len": 4, "profile": "1x", "tolerance": 2, "mode": "paper", "seed": 0,
                           "train_split": ["train", 0, 160], "table_split": ["test", 160, 400],
                           "matchers": {"fixed": {"name": "seqslam", "settings": {"velocities": [1.0]}},
                                        "velocity": {"name": "seqslam", "settings": {"velocities": [0.5, 1.0, 2.0]}}}}
    assert result.speed == 1.0 and result.mean_speed == 1.0
    assert (result.n_train_queries, result.n_table_queries) == (160, 240)


def test_velocity_search_finds_a_query_driven_twice_as_fast(dataset, tmp_path):
    result = run_stage(dataset, "2x", tmp_path)
    assert result.n_table_queries == 120  # frames 160, 162, ..., 398
    for method in ("a", "b"):
        fixed = result.matchers["fixed"].methods[method]
        velocity = result.matchers["velocity"].methods[method]
        assert velocity.recall_at_1_sequence > fixed.recall_at_1_sequence + 0.3
        # single-frame matching does not depend on the sequence matcher
        assert velocity.recall_at_1_single == fixed.recall_at_1_single
    assert result.matchers["velocity"].velocities == (0.5, 1.0, 2.0)


def test_the_stage_refuses_mismatched_inputs(dataset, tmp_path):
    with pytest.raises(ValueError, match="same methods"):
        speed.main(job(dataset["train"], {"b": dataset["test"]["b"], "a": dataset["test"]["a"]}, tmp_path / "x.json"))
    with pytest.raises(ValueError, match="shares frames"):  # a predictor scored on its own training frames
        speed.main(job(dataset["train"], dataset["train"], tmp_path / "x.json"))
    assert not (tmp_path / "x.json").exists()


# --- the command line ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("options", "message"), [
    (["--profile", "fast"], "vpr-smr speed: error: speed profile 'fast' is not a constant speed such as 0.5x"),
    (["--profile=-2x"], "speed profile '-2x': a speed must be a finite number > 0"),
    (["--profile", "2x", "--velocities", "1", "0"], "vpr-smr speed: error: --velocities: the velocity matcher's search "
                                                    "set (reference frames per query frame"),
    (["--profile", "2x", "--velocities", "1", "0"], "must be > 0, got 0.0"),
    (["--profile", "2x", "--velocities", "1", "-0.5"], "must be > 0, got -0.5"),
])
def test_the_command_refuses_a_bad_profile_or_velocity(dataset, tmp_path, capsys, options, message):
    status = cli(["speed", "--dataset", "d", "--seq-len", "4", *options,
                  "--train", *(f"{m}={p}" for m, p in dataset["train"].items()),
                  "--test", *(f"{m}={p}" for m, p in dataset["test"].items()), "--out", str(tmp_path / "s.json")])
    assert status == 2 and message in capsys.readouterr().err
    assert not (tmp_path / "s.json").exists()


# --- the configuration -------------------------------------------------------------------------------------------


def test_the_configurations_defaults(tmp_path):
    from vpr_smr.pipeline.config import experiments, load_config
    from vpr_smr.pipeline.rule_helpers import speed_profiles

    path = tmp_path / "c.yaml"
    path.write_text("run: x\ndatasets: {d: {loader: nordland_sample}}\nmethods: {m: {backend: sad}}\n")
    conf = load_config(path)
    assert conf.experiments.speed is True and "speed" in experiments(conf)
    assert conf.speed.profiles == (0.5, 0.75, 1.0, 1.25, 1.5, 2.0, "varying")
    assert conf.speed.velocities == (0.5, 0.595, 0.707, 0.841, 1.0, 1.189, 1.414, 1.682, 2.0)
    assert conf.speed.velocities == tuple(round(2 ** (k / 4), 3) for k in range(-4, 5))
    assert speed_profiles(conf) == ["0.5x", "0.75x", "1x", "1.25x", "1.5x", "2x", "varying"]
    assert "speed" not in experiments(load_config(path, {"experiments": {"speed": False}}))
    for bad in ({"profiles": [0]}, {"profiles": ["fast"]}, {"velocities": [1.0, -1.0]}, {"velocities": []}):
        with pytest.raises(ValueError, match="speed"):
            load_config(path, {"speed": bad})


# --- the report --------------------------------------------------------------------------------------------------


def test_the_report_with_and_without_the_speed_experiment(tmp_path):
    from report_runs import RUN_EXPERIMENTS, SPEED_NUMBERS, build_run, speed_files

    from vpr_smr.eval.report.registry import expected_outputs

    run, written = build_run(tmp_path / "with", modes=("paper",), speed=speed_files(tmp_path))
    expected = expected_outputs(["d"], [2, 4], ["paper"], RUN_EXPERIMENTS | {"speed"}, table_seq_lens=[4])
    assert sorted(str(p.relative_to(run)) for p in written) == sorted(expected)
    assert "figures/speed_d_L4.png" in expected and "tables/speed.csv" in expected
    rows = list(csv.DictReader(open(run / "tables" / "speed.csv")))
    assert [(r["method"], r["profile"], r["matcher"]) for r in rows] == [
        (m, p, k) for m in ("m1", "m2") for p in ("1x", "2x", "varying") for k in ("fixed", "velocity")]
    for row in rows:
        recall, reduction = SPEED_NUMBERS[row["profile"]][(row["method"], row["matcher"])]
        assert float(row["recall_at_1_sequence"]) == recall
        assert row["reduction_pct"] == ("" if reduction is None else str(reduction))
    assert {r["speed"] for r in rows if r["profile"] == "varying"} == {""}
    page = html.unescape((run / "report.html").read_text())
    assert '<section id="speed">' in page and 'href="#speed"' in page
    # means over the two methods: fixed 70 % at 1x, 15 % at 2x; velocity search 60 % at 2x, 70 % at 1x; the
    # reductions at 2x: (10 - 30) / 2 = -10 % fixed, (40 + 20) / 2 = 30 % velocity search
    # numbers without a direction ("falls"): each profile's recall is over its own queries, with no interval
    sentence = ("at 2x speed the fixed matcher's sequence recall@1 is 15.0 % (70.0 % at 1x, over that profile's own "
                "queries; mean over 2 methods); velocity search's is 60.0 % there (70.0 % at 1x); the predictor's AOC "
                "reduction at 2x is -10.0 % with the fixed matcher and 30.0 % with velocity search.")
    assert sentence in re.sub(r"\s+", " ", page)
    # varying: fixed (40 + 20) / 2 = 30 %, velocity (70 + 60) / 2 = 65 %
    assert ("Under the varying speed (mean 1.02x) the sequence recall@1 is 30.0 % with the fixed matcher and 65.0 % "
            "with velocity search.") in re.sub(r"\s+", " ", page)

    run, written = build_run(tmp_path / "without", modes=("paper",))
    assert not any("speed" in str(p.relative_to(run)) for p in written)
    page = (run / "report.html").read_text()
    assert '<section id="speed">' not in page and 'href="#speed"' not in page
