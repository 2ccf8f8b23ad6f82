"""The training-free scorers of method §12 and their two protocols, against a literal per-query implementation of
the definitions (``oracles.naive_scores``: S summed from D for every end reference, no candidates) and scikit-learn.

The scorers read the candidates the sequence matcher keeps (the n smallest S and D per query), so every case here
also checks that those candidates are enough: ties, a window that covers every reference, m_a = 0, positions in one
and two dimensions, velocity search, a split with fewer end references than candidates, both implementations."""

from dataclasses import replace

import numpy as np
import pytest
from helpers import make_features, seqslam
from oracles import naive_oracle_removed, naive_removed, naive_scores, tied_matrix
from sklearn.metrics import average_precision_score, roc_auc_score

from vpr_smr.core.constants import candidates_needed, half_window
from vpr_smr.eval.matching import matcher
from vpr_smr.eval.matching.attributes import query_features
from vpr_smr.eval.matching.ground_truth import GroundTruth
from vpr_smr.eval.scoring.baselines import (
    SCORERS,
    BaselineSettings,
    Prediction,
    check_candidates,
    detection,
    keep_lowest,
    oracle_keep,
    query_scores,
    removal_at_budget,
    split_baselines,
    spread_positions,
)
from vpr_smr.eval.scoring.curves import curve
from vpr_smr.eval.scoring.evaluate import compare_removal


def zero_matrix(n_ref=40, n_query=30, seed=5):
    """Random distances with exact zeros: queries 5..14 see their own frame at distance 0 (m_a = 0 with every other
    end reference above 0: uniqueness +inf), and queries 20..27 also a far reference at 0 (both numbers 0: 1)."""
    rng = np.random.default_rng(seed)
    d = rng.random((n_ref, n_query)) + 0.1
    d[np.arange(5, 15), np.arange(5, 15)] = 0.0
    d[np.arange(20, 28), np.arange(20, 28)] = 0.0
    d[np.arange(32, 40), np.arange(20, 28)] = 0.0
    return d


CASES = {  # name: (matrix, L, velocities, r_window, spread_k)
    "random float32": (np.random.default_rng(1).random((50, 30), dtype=np.float32), 4, (1.0,), 10, 10),
    "ties (a stopped train)": (tied_matrix(n_ref=80, n_query=40), 3, (1.0,), 10, 10),
    "integers, many ties": (np.random.default_rng(2).integers(0, 3, (30, 25)).astype(np.float64), 3, (1.0,), 4, 6),
    "m_a = 0": (zero_matrix(), 2, (1.0,), 6, 3),
    "window covers every reference": (np.random.default_rng(3).random((12, 15)), 3, (1.0,), 40, 5),
    "odd window, larger K": (np.random.default_rng(4).random((35, 20)), 5, (1.0,), 7, 15),
    "fewer end references than candidates": (np.random.default_rng(6).random((9, 14)), 4, (1.0,), 10, 10),
    "velocities": (np.random.default_rng(7).random((40, 25)), 4, (0.5, 1.0, 2.0), 10, 10),
    "velocities, ties": (np.random.default_rng(8).integers(0, 3, (30, 20)).astype(np.float32), 3, (0.8, 1.25), 6, 8),
}


@pytest.mark.parametrize("kernel", ["numpy", "numba"])
@pytest.mark.parametrize("name", list(CASES))
def test_scorers_equal_the_literal_definition(name, kernel):
    d, seq_len, velocities, r_window, spread_k = CASES[name]
    settings = BaselineSettings(r_window, spread_k)
    previous, matcher.KERNEL = matcher.KERNEL, kernel
    try:
        features = query_features(d, seq_len, 2, matcher=seqslam(*velocities), n_candidates=settings.candidates)
    finally:
        matcher.KERNEL = previous
    positions = np.arange(d.shape[0], dtype=np.float64)
    got = query_scores(features, settings, positions, seed=3)
    expected = naive_scores(d, seq_len, velocities, r_window, spread_k, positions, features.sequence_correct, 3)
    for scorer in ("uniqueness", "single_uniqueness", "distance", "random", "oracle"):  # the same float64 values
        np.testing.assert_array_equal(got[scorer], expected[scorer], err_msg=scorer)
    np.testing.assert_allclose(got["spread"], expected["spread"], rtol=1e-12, atol=1e-12)
    if name == "m_a = 0":  # both rules of a zero match are exercised
        assert np.isinf(got["uniqueness"]).any() and (got["uniqueness"][features.sequence_distance == 0] == 1).any()
    if name == "window covers every reference":
        assert (got["uniqueness"] == 1).all() and (got["single_uniqueness"] == 1).all()


@pytest.mark.parametrize("dimensions", [1, 2])
def test_spread_with_positions(dimensions):
    # a traverse driven at other speeds, positions in metres far from 0 (as UTM's), one or two axes
    rng = np.random.default_rng(9)
    d = rng.random((45, 30))
    steps = rng.uniform(0.5, 3.0, (45, dimensions)).cumsum(axis=0) + 5e6
    reference = steps[:, 0] if dimensions == 1 else steps
    query = reference[np.linspace(0, 44, 30).astype(int)]
    truth = GroundTruth.positions(reference, query, 4.0)
    settings = BaselineSettings(8, 7)
    features = query_features(d, 3, matcher=seqslam(0.8, 1.0, 1.25), ground_truth=truth,
                              n_candidates=settings.candidates)
    positions = spread_positions(truth)
    assert positions is truth.reference_positions  # positions, not frame indices
    got = query_scores(features, settings, positions)["spread"]
    expected = naive_scores(d, 3, (0.8, 1.0, 1.25), 8, 7, positions, features.sequence_correct)["spread"]
    np.testing.assert_allclose(got, expected, rtol=1e-9)
    # frames within a tolerance, and a matrix, measure frame indices
    assert np.array_equal(spread_positions(GroundTruth.aligned(45, 30, 2).sliced((5, 40), (5, 25))), np.arange(35))
    assert np.array_equal(spread_positions(GroundTruth.matrix(np.eye(6, dtype=bool))), np.arange(6))


def test_the_window_and_the_candidates_needed():
    # OpenSeqSLAM2 leaves out |r - r*| <= r_window / 2: floor for whole references, an odd window included
    assert [half_window(r) for r in (0, 1, 9, 10, 11)] == [0, 0, 4, 5, 5]
    assert candidates_needed(10, 10) == 12 and candidates_needed(10, 30) == 30 and candidates_needed(0, 1) == 2
    for bad in ((-1, 10), (10, 0), (2.5, 10)):
        with pytest.raises(ValueError, match="r_window|spread_k"):
            BaselineSettings(*bad)


def test_too_few_candidates_are_refused_with_the_fix():
    d = np.random.default_rng(0).random((30, 20))
    features = query_features(d, 3, n_candidates=12)
    check_candidates(features, BaselineSettings(), "a.h5")
    with pytest.raises(ValueError, match=r"a.h5 holds 12 candidates .* r_window 30 .* need 32 .* --candidates 32"):
        check_candidates(features, BaselineSettings(30, 10), "a.h5")
    with pytest.raises(ValueError, match=r"a.h5 holds no candidates .* --candidates 12"):
        check_candidates(query_features(d, 3), BaselineSettings(), "a.h5")


# --- removal at the predictor's budget -------------------------------------------------------------------------


def random_prediction(n, seed, classes=(0, 1, 2, 3)):
    rng = np.random.default_rng(seed)
    probabilities = rng.dirichlet(np.ones(len(classes)), n)
    return Prediction(seed, probabilities, np.array(classes))


@pytest.mark.parametrize("seed", range(4))
def test_removal_at_budget_equals_the_literal_removal(seed):
    d = tied_matrix(n_ref=70, n_query=60, seed=seed) if seed % 2 else np.random.default_rng(seed).random((70, 60))
    settings = BaselineSettings()
    features = query_features(d, 4, n_candidates=settings.candidates)
    prediction = random_prediction(len(features.queries), seed)
    scores = query_scores(features, settings, np.arange(70.0), seed, prediction)
    found = removal_at_budget(features, scores, prediction)
    keep = prediction.keep
    assert found.seed == seed and found.budget == int((~keep).sum()) and list(found.scorers) == list(SCORERS)
    for name in SCORERS:
        if name == "predictor":
            removed = set(np.flatnonzero(~keep))
        elif name == "oracle":
            removed = naive_oracle_removed(features.sequence_distance, features.sequence_correct, found.budget)
        else:
            removed = naive_removed(scores[name], found.budget)
        naive_keep = np.array([n not in removed for n in range(len(keep))])
        assert found.scorers[name].removed == len(removed), name
        for mode in ("paper", "standard"):
            assert found.scorers[name].modes[mode] == compare_removal(features, mode, naive_keep)[2], (name, mode)


def test_the_oracle_removes_at_most_every_wrong_match():
    correct = np.array([1, 0, 1, 0, 1, 1], dtype=bool)
    distances = np.array([0.5, 0.9, 0.1, 0.2, 0.7, 0.3])
    assert list(~oracle_keep(distances, correct, 1)) == [0, 0, 0, 1, 0, 0]  # the smaller distance first
    assert list(~oracle_keep(distances, correct, 5)) == [0, 1, 0, 1, 0, 0]  # both wrong ones, no correct one
    assert list(~keep_lowest(np.array([1.0, 0.0, 0.0, 2.0]), 2)) == [0, 1, 1, 0]  # ties: the lower index first


def features_of(distances, correct):
    n = len(distances)
    return make_features(correct, np.ones((n, 1), bool), sequence_distance=np.asarray(distances, dtype=float),
                         sequence_min=float(np.min(distances)), sequence_max=float(np.max(distances)),
                         queries=np.arange(n))


def test_the_oracle_never_makes_the_curve_worse_nor_loses_to_removing_only_wrong_matches():
    # Removing wrong matches raises precision at every threshold and leaves recall (and the maximum recall) as it
    # was: the oracle's reduction is never below 0, and no removal of as many wrong matches (keeping every correct
    # one) reaches a smaller AOC than removing those of smallest distance first.
    rng = np.random.default_rng(12)
    for _ in range(1500):
        n = int(rng.integers(2, 14))
        distances = rng.integers(0, 6, n).astype(float) if rng.random() < 0.5 else rng.random(n)
        correct = rng.random(n) < rng.random()
        features = features_of(distances, correct)
        budget = int(rng.integers(0, n + 1))
        oracle = oracle_keep(distances, correct, budget)
        other = np.ones(n, bool)
        wrong = np.flatnonzero(~correct)
        other[rng.permutation(wrong)[: min(budget, len(wrong))]] = False
        for mode in ("paper", "standard"):
            mine, theirs = compare_removal(features, mode, oracle)[2], compare_removal(features, mode, other)[2]
            assert mine.reduction_pct is None or mine.reduction_pct >= -1e-9, (mode, distances, correct, budget)
            assert mine.aoc_vpr_sm_pred <= theirs.aoc_vpr_sm_pred + 1e-12, (mode, distances, correct, budget)


def test_a_removal_that_lowers_the_maximum_recall_can_beat_the_oracle():
    # Why "the oracle never does worse than the predictor" does not hold for method §8's reduction: each removal's
    # AOC is taken at its own maximum recall against VPR+SM cut there, without interpolation. Removing a correct
    # match moves the cut below the baseline's points of low precision, which the oracle (keeping every correct
    # match) must still count. Here the predictor removes one correct match (query 3, distance 2) and reduces the
    # AOC by 29.4 %, the oracle at the same budget (the wrong match of smallest distance, query 4) by 19.2 %.
    distances = np.array([2, 1, 4, 2, 0, 2, 2, 0], dtype=float)
    correct = np.array([1, 1, 0, 1, 0, 0, 1, 0], dtype=bool)
    features = features_of(distances, correct)
    predictor = np.array([1, 1, 1, 0, 1, 1, 1, 1], dtype=bool)
    mine = compare_removal(features, "standard", oracle_keep(distances, correct, 1))[2]
    theirs = compare_removal(features, "standard", predictor)[2]
    assert theirs.max_recall < mine.max_recall == 4 / 8
    assert theirs.reduction_pct == pytest.approx(29.4118, abs=1e-4)
    assert mine.reduction_pct == pytest.approx(19.2308, abs=1e-4)


def test_distance_reduces_nothing_in_standard_mode_and_the_paper_grids_gap_in_paper_mode():
    # Removing the largest sequence distances is a threshold on them, which VPR+SM's curve already sweeps. In
    # standard mode the curve is the baseline's cut at the same recall: a reduction of 0. In paper mode the grid
    # point past the cut lies above the maximum recall and the cut baseline ends at the grid point before it, while
    # the removal's curve reaches the maximum recall at its next grid point: the reduction is exactly that last
    # trapezoid's area, which method §8.4 counts as the baseline's AOC (no interpolation at R_max).
    rng = np.random.default_rng(21)
    for _ in range(300):
        n = int(rng.integers(5, 60))
        distances = rng.random(n)  # distinct: no tie at the budget's edge
        correct = rng.random(n) < rng.uniform(0.2, 0.9)
        if not correct.any():
            continue
        features = features_of(distances, correct)
        keep = keep_lowest(-distances, int(rng.integers(1, n)))
        standard = compare_removal(features, "standard", keep)[2]
        if standard.reduction_pct is not None:
            assert standard.reduction_pct == pytest.approx(0.0, abs=1e-9)
        paper = compare_removal(features, "paper", keep)[2]
        if paper.reduction_pct is None:
            continue
        removal = curve("paper", distances, correct, keep, features.sequence_min, features.sequence_max)
        baseline = curve("paper", distances, correct, np.ones(n, bool), features.sequence_min,
                         features.sequence_max)
        inside = baseline.recall <= paper.max_recall
        last_recall, last_precision = baseline.recall[inside][-1], baseline.precision[inside][-1]
        reached = np.flatnonzero(removal.recall == paper.max_recall)[0]  # the removal's first point at R_max
        gap = (paper.max_recall - last_recall) * (last_precision + removal.precision[reached]) / 2
        assert paper.aoc_vpr_sm - paper.aoc_vpr_sm_pred == pytest.approx(gap, abs=1e-12)


# --- detecting wrong matches ----------------------------------------------------------------------------------


def test_detection_equals_scikit_learn():
    rng = np.random.default_rng(5)
    for trial in range(300):
        n = int(rng.integers(2, 80))
        wrong = rng.random(n) < rng.uniform(0.05, 0.95)
        if not 0 < wrong.sum() < n:
            continue
        confidence = rng.integers(0, 6, n).astype(float) if trial % 2 else rng.normal(size=n)  # ties, or none
        found = detection(wrong, confidence)
        assert found.average_precision == pytest.approx(average_precision_score(wrong, -confidence), rel=1e-12)
        assert found.roc_auc == pytest.approx(roc_auc_score(wrong, -confidence), rel=1e-12)
        # the curve: one point where recall grows, whose steps sum to the average precision
        recall, precision = np.array(found.curve.recall), np.array(found.curve.precision)
        assert np.all(np.diff(recall) > 0) and recall[-1] == 1
        assert np.sum(np.diff(np.r_[0, recall]) * precision) == pytest.approx(found.average_precision, rel=1e-12)


def test_detection_with_infinite_confidences_and_degenerate_classes():
    # uniqueness is +inf where only m_a is 0: it ranks as the most confident, as a large finite value would
    wrong = np.array([1, 0, 1, 0, 0], dtype=bool)
    confidence = np.array([0.5, np.inf, 0.2, 3.0, np.inf])
    finite = np.array([0.5, 99.0, 0.2, 3.0, 99.0])
    assert detection(wrong, confidence) == detection(wrong, finite)
    assert detection(wrong, confidence).average_precision == pytest.approx(average_precision_score(wrong, -finite))
    none = detection(np.zeros(4, bool), np.arange(4.0))
    assert none.average_precision is None and none.roc_auc is None  # no wrong match: nothing to detect
    every = detection(np.ones(4, bool), np.arange(4.0))
    assert every.average_precision == 1.0 and every.roc_auc is None  # one class: no ROC curve


def test_the_oracle_detects_perfectly_and_random_as_the_wrong_fraction():
    d = np.random.default_rng(3).random((200, 400)) + 0.3 * (1 - np.eye(200, 400))
    features = query_features(d, 3, n_candidates=12)
    found = split_baselines(features, BaselineSettings(), np.arange(200.0))
    assert found.detection["oracle"].average_precision == found.detection["oracle"].roc_auc == 1.0
    assert found.seeds == (0,) and found.removal is None and "predictor" not in found.detection
    assert found.n_wrong == int((~features.sequence_correct).sum())
    assert abs(found.random_detection[0].average_precision - found.wrong_fraction) < 0.1
    assert abs(found.random_detection[0].roc_auc - 0.5) < 0.1


def test_every_seed_has_its_budget_and_random_order():
    d = tied_matrix(n_ref=60, n_query=50)
    features = query_features(d, 3, n_candidates=12)
    predictions = [random_prediction(len(features.queries), seed) for seed in (0, 1, 2)]
    found = split_baselines(features, BaselineSettings(), np.arange(60.0), predictions, modes=("standard",))
    assert found.seeds == (0, 1, 2) and [b.seed for b in found.removal] == [0, 1, 2]
    for prediction, budget in zip(predictions, found.removal, strict=True):
        assert budget.budget == int((~prediction.keep).sum())
        scores = query_scores(features, BaselineSettings(), np.arange(60.0), prediction.seed, prediction)
        # the first seed's removal carries its bootstrap intervals (method §8.7), the others' do not
        assert budget == removal_at_budget(features, scores, prediction, ("standard",),
                                           intervals=prediction is predictions[0])
    assert [d.average_precision for d in found.random_detection] == [
        detection(~features.sequence_correct, np.random.default_rng(s).permutation(48).astype(float),
                  curve=False).average_precision for s in (0, 1, 2)]


# --- the stages: vpr-smr baselines and the scorers of vpr-smr metrics -------------------------------------------


@pytest.fixture
def split_files(tmp_path):
    """Two splits of dataset "d" (frames 100..139 and 60..89) in our HDF5 layout, their attributes at L = 3 (with
    the default candidates), and the same matrices."""
    from helpers import write_distance_matrix

    from vpr_smr.eval.matching.attributes import AttributesJob
    from vpr_smr.eval.matching.attributes import main as attributes_main

    rng = np.random.default_rng(17)
    distances, attributes, matrices = {}, {}, {}
    for split, lo, n in (("val", 60, 30), ("test", 100, 40)):
        d = rng.random((n, n)) + 0.6 * (1 - np.eye(n)) * rng.random((n, n))
        distances[split] = tmp_path / f"{split}.h5"
        write_distance_matrix(distances[split], d, {"dataset": "d", "method": "m", "split": split,
                                                    "split_range": [lo, lo + n]})
        attributes[split] = tmp_path / f"{split}_L3.h5"
        attributes_main(AttributesJob(str(distances[split]), 3, out=str(attributes[split])))  # tolerance 2
        matrices[split] = d
    return distances, attributes


def test_the_baselines_command(split_files, predictor_file, tmp_path):
    from vpr_smr.core.records import load
    from vpr_smr.eval.matching.attributes import read_features
    from vpr_smr.eval.predictor.estimator import SMRPredictor
    from vpr_smr.eval.scoring.records import Baselines
    from vpr_smr.pipeline.cli import main as cli

    distances, attributes = split_files
    out = tmp_path / "b.json"
    assert cli(["baselines", "--dataset", "d", "--method", "m", "--seq-len", "3",
                "--distances", *(f"{s}={p}" for s, p in distances.items()),
                "--attributes", *(f"{s}={p}" for s, p in attributes.items()),
                "--predictors", str(predictor_file), str(predictor_file), "--r-window", "6", "--spread-k", "5",
                "--out", str(out)]) == 0
    record = load(out, Baselines)
    assert record.meta == {"dataset": "d", "method": "m", "seq_len": 3, "r_window": 6, "spread_k": 5,
                           "ground_truth": {"kind": "frames", "tolerance": 2},
                           "matcher": {"name": "seqslam", "settings": {"velocities": [1.0]}},
                           "predictors": [str(predictor_file)] * 2}
    predictor = SMRPredictor.load(predictor_file)
    for split, path in attributes.items():  # what the command wrote is split_baselines of the file's features
        features = read_features(path)
        probabilities = predictor.predict_proba(features.attributes[:, 0])
        predictions = [Prediction(seed, probabilities, predictor.classes_) for seed in (0, 1)]
        expected = split_baselines(features, BaselineSettings(6, 5), np.arange(float(features.all_single_correct.size)),
                                   predictions)
        assert record.splits[split] == Baselines.from_json(Baselines({}, {split: expected}).to_json()).splits[split]
    # the settings need more candidates than the files hold: the file and the fix are named
    assert cli(["baselines", "--dataset", "d", "--method", "m", "--seq-len", "3",
                "--distances", *(f"{s}={p}" for s, p in distances.items()),
                "--attributes", *(f"{s}={p}" for s, p in attributes.items()),
                "--predictors", str(predictor_file), "--r-window", "30", "--out", str(tmp_path / "c.json")]) == 2
    with pytest.raises(ValueError, match=r"val_L3.h5 holds 12 candidates .* --candidates 32"):
        from vpr_smr.eval.scoring.baselines_stage import BaselinesJob
        from vpr_smr.eval.scoring.baselines_stage import main as baselines_main

        job = BaselinesJob("d", "m", 3, {s: str(p) for s, p in distances.items()},
                           {s: str(p) for s, p in attributes.items()}, (str(predictor_file),),
                           scorers=BaselineSettings(30, 10), out=str(tmp_path / "c.json"))
        baselines_main(job)
    with pytest.raises(ValueError, match="give every split's attributes and distances"):
        baselines_main(replace(job, distances={"val": str(distances["val"])}, scorers=BaselineSettings()))


def test_metrics_reports_the_scorers_with_and_without_a_predictor(split_files, predictor_file, tmp_path, capsys):
    from vpr_smr.pipeline.cli import main as cli

    distances, attributes = split_files
    arguments = ["metrics", "--distances", f"test={distances['test']}", "--seq-len", "3", "--modes", "standard"]
    assert cli([*arguments, "--out", str(tmp_path / "a.json")]) == 0
    printed = capsys.readouterr().out
    assert "training-free scorers (method §12; r_window 10, spread_k 10)" in printed
    assert "test: detecting the" in printed and "removal at the" not in printed  # no predictor: no budget
    assert cli([*arguments, "--predictor", str(predictor_file), "--out", str(tmp_path / "b.json")]) == 0
    printed = capsys.readouterr().out
    assert "test: removal at the seed-0 predictor's budget of" in printed
    rows = [line.split() for line in printed.splitlines() if line.startswith("standard ")]
    assert [row[1] for row in rows] == list(SCORERS)
    assert cli([*arguments, "--no-baselines", "--out", str(tmp_path / "c.json")]) == 0
    assert "training-free" not in capsys.readouterr().out
