"""The standard VPR metrics (``vpr-smr metrics``): every metric worked out by hand on a 6 x 6 matrix, recall@N
against a naive loop, evaluate's recall@1 and the command on a user's .npy (its workflow rule:
test_vpr_metrics_workflow.py)."""

import csv
import json

import numpy as np
import pytest
from helpers import SEQSLAM_PROVENANCE, write_distance_matrix
from oracles import naive_recalls, sequence_matrix, stable_top
from training_sets import PARAMS, train_job
from worked_matrix import DECISION, SEQ_LEN, TOLERANCE, D, FixedPredictor

from vpr_smr.core.constants import KEPT_CLASSES, MATCHERS, MODES, RECALL_AT
from vpr_smr.eval.matching.attributes import AttributesJob, query_features, write_features
from vpr_smr.eval.matching.attributes import main as attributes_main
from vpr_smr.eval.matching.sources import TruthSource
from vpr_smr.eval.predictor import train
from vpr_smr.eval.predictor.estimator import SMRPredictor
from vpr_smr.eval.predictor.leakage import SplitLeakError
from vpr_smr.eval.scoring.evaluate import recall_at_1
from vpr_smr.eval.scoring.vpr_metrics import MetricsJob, main, retrieval, score_split
from vpr_smr.pipeline.cli import main as cli

EXPECTED = {
    # mode -> matcher -> (n_queries, recall@1, recall@5, R@100P, PR-AUC, EP); recall@10 and @20 equal recall@5.
    "standard": {
        # ranks of q1..q5: 1, 0, 2, 1, 0 -> R@1 2/5, R@5 1. Curve over q1..q5, distances 2 1 1 2 0, right F T F F T:
        # t=0 TP1 FP0 (.2, 1); t=1 TP2 FP1 (.4, 2/3); t=2 TP2 FP3 (.4, .4). AUC .2 + .2 (1 + 2/3) / 2 = 11/30.
        "single": (5, 0.4, 1.0, 0.2, 11 / 30, (1 + 0.2) / 2),
        # ranks 0 0 0 1 1. Curve: 2.5 F -> (0, 0); 4 T T -> (.4, 2/3); 5 T -> (.6, .75); 6 F -> (.6, .6).
        # AUC .4 (2/3) / 2 + .2 (2/3 + 3/4) / 2 = 2/15 + 17/120 = 33/120. P_R0 0 (VPR-Bench: the most confident
        # match, 2.5, is wrong), R@100P 0: EP 0.
        "sequence": (5, 0.6, 1.0, 0.0, 33 / 120, 0.0),
        # kept a2 (4 T), a3 (5 T), a5 (2.5 F): R@1 a2, a3 = 2/5; R@5 a2, a3, a5 = 3/5.
        # Curve: 2.5 -> (0, 0); 4 -> (.2, .5); 5 -> (.4, 2/3). AUC .2 (.5) / 2 + .2 (.5 + 2/3) / 2 = 1/6.
        # The most confident kept match (2.5) is wrong: P_R0 0, EP 0.
        "sequence_predictor": (5, 0.4, 0.6, 0.0, 1 / 6, 0.0),
    },
    "paper": {
        # every query q0..q5: ranks 0 1 0 2 1 0 -> R@1 3/6. Curve: 1999 thresholds over [0, 5], recall over the
        # 3 right matches: t=0 (1/3, 1); from 1 TP3 FP1 (1, .75); from 2 TP3 FP3 (1, .5) (no distance is on the
        # grid 5 k / 1998). AUC 1/3 + (2/3)(1 + .75) / 2 = 11/12; R@100P 1/3; EP (1 + 1/3) / 2.
        "single": (6, 0.5, 1.0, 1 / 3, 11 / 12, (1 + 1 / 3) / 2),
        # thresholds over [2.5, 10], recall over the 3 right sequence matches: (0, 0); from 4 (2/3, 2/3); from 5
        # (1, .75); from 6 (1, .6). AUC (2/3)(2/3) / 2 + (1/3)(2/3 + 3/4) / 2 = 2/9 + 17/72 = 33/72. EP 0 (2.5 wrong).
        "sequence": (5, 0.6, 1.0, 0.0, 33 / 72, 0.0),
        # recall over the 3 right matches (removed a1 included): (0, 0); from 4 (1/3, .5); from 5 (2/3, 2/3).
        # AUC (1/3)(.5) / 2 + (1/3)(.5 + 2/3) / 2 = 1/12 + 7/36 = 5/18. EP 0 (2.5 wrong).
        "sequence_predictor": (5, 0.4, 0.6, 0.0, 5 / 18, 0.0),
    },
}


def test_every_metric_by_hand():
    scored = score_split(D, SEQ_LEN, TOLERANCE, FixedPredictor(DECISION))
    features = scored.queries.features
    assert features.labels.tolist() == [2, 0, 2, 3, 1]
    assert scored.queries.prediction.kept.tolist() == [False, True, True, False, True]
    assert list(scored.metrics.modes) == list(MODES)
    for mode, matchers in EXPECTED.items():
        assert list(scored.metrics.modes[mode]) == list(MATCHERS)
        for matcher, (n, r1, r5, r100p, auc, ep) in matchers.items():
            got = scored.metrics.modes[mode][matcher]
            assert got.n_queries == n, (mode, matcher)
            assert list(got.recall_at) == list(RECALL_AT)
            assert [got.recall_at[k] for k in RECALL_AT] == pytest.approx([r1, r5, r5, r5]), (mode, matcher)
            assert got.recall_at_100p == pytest.approx(r100p), (mode, matcher)
            assert got.pr_auc == pytest.approx(auc), (mode, matcher)
            assert got.extended_precision == pytest.approx(ep), (mode, matcher)


def test_cli_prints_every_metric_as_a_table(tmp_path, capsys):
    np.save(tmp_path / "D.npy", D)
    assert cli(["metrics", "--distances", str(tmp_path / "D.npy"), "--seq-len", str(SEQ_LEN), "--tolerance",
                str(TOLERANCE), "--out", str(tmp_path / "m.json")]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split() == ["split", "mode", "matcher", "queries", "R@1", "R@5", "R@10", "R@20", "R@100P",
                                "PR-AUC", "EP"]
    rows = [line.split() for line in lines[1 : lines.index("")]]  # the training-free scorers follow
    # one row per mode and matcher, in the JSON's order; the numbers worked out by hand above (EXPECTED), rounded
    assert [row[:3] for row in rows] == [["all", mode, matcher] for mode in MODES for matcher in ("single",
                                                                                                  "sequence")]
    for _, mode, matcher, *cells in rows:
        n, r1, r5, r100p, auc, ep = EXPECTED[mode][matcher]
        assert cells == [str(n), *(f"{v:.4f}" for v in (r1, r5, r5, r5, r100p, auc, ep))], (mode, matcher)
    assert ["all", "paper", "single", "6", "0.5000", "1.0000", "1.0000", "1.0000", "0.3333", "0.9167",
            "0.6667"] in rows  # the paper's single frame spelt out: recall@1 3/6, AUC 11/12, EP (1 + 1/3) / 2


def test_without_a_predictor_there_is_no_predictor_matcher():
    scored = score_split(D, SEQ_LEN, TOLERANCE, modes=("standard",))
    assert list(scored.metrics.modes) == ["standard"]
    assert list(scored.metrics.modes["standard"]) == ["single", "sequence"]
    assert scored.queries.prediction is None


def test_tolerance_one_by_hand():
    # tolerance 1: q1's second-best reference r1 is right: single ranks 0 0 0 ... Column by column, the best
    # right reference (|r - q| <= 1): q0 r0 rank 0; q1 r2 rank 0; q2 r2 rank 0; q3 r4 rank 0; q4 r3/r4/r5: r4 = 3
    # ranks 1; q5 r5 rank 0 -> paper R@1 5/6. Sequence: a4's i4 (6) is now right (|4 - 3| <= 1): rank 0; a5's
    # right diagonals i3 (10), i4 (3): i4 ranks 1 -> R@1 4/5.
    modes = score_split(D, SEQ_LEN, 1).metrics.modes
    assert modes["paper"]["single"].recall_at[1] == pytest.approx(5 / 6)
    assert modes["standard"]["single"].recall_at[1] == pytest.approx(4 / 5)
    assert modes["paper"]["sequence"].recall_at[1] == pytest.approx(4 / 5)
    assert modes["paper"]["sequence"].recall_at[5] == 1.0


# --- recall@N against a naive loop ---------------------------------------------------------------------------


@pytest.mark.parametrize("shape, seq_len, tolerance, high", [
    ((30, 30), 3, 2, 4), ((25, 25), 2, 0, 3), ((40, 33), 5, 1, 6), ((12, 12), 4, 3, 2), ((28, 28), 6, 2, 10),
])
def test_recall_at_n_matches_a_naive_loop(shape, seq_len, tolerance, high):
    rng = np.random.default_rng(sum(shape) + seq_len)
    d = rng.integers(0, high, size=shape).astype(float)  # few distinct values: many ties
    single, sequence = naive_recalls(d, seq_len, tolerance)
    modes = score_split(d, seq_len, tolerance).metrics.modes
    assert modes["paper"]["single"].recall_at == pytest.approx(single)
    assert modes["paper"]["sequence"].recall_at == pytest.approx(sequence)
    assert modes["standard"]["sequence"].recall_at == pytest.approx(sequence)
    # standard single: the evaluated queries only
    evaluated = {n: np.mean([any(abs(r - q) <= tolerance for r in stable_top(list(d[:, q]), n))
                             for q in range(seq_len - 1, shape[1])]) for n in RECALL_AT}
    assert modes["standard"]["single"].recall_at == pytest.approx(evaluated)


def test_block_wise_equals_whole_matrix():
    rng = np.random.default_rng(7)
    d = rng.integers(0, 5, size=(50, 47)).astype(np.float32)
    whole = retrieval(d, 4, 2, block_queries=47)
    for block in (1, 3, 5, 16):
        part = retrieval(d, 4, 2, block_queries=block)
        for name in ("single_rank", "single_match", "single_distance", "sequence_rank", "sequence_match",
                     "sequence_distance"):
            np.testing.assert_array_equal(getattr(part, name), getattr(whole, name), err_msg=f"{name}, {block}")
        assert (part.distance_min, part.distance_max) == (whole.distance_min, whole.distance_max)


@pytest.mark.parametrize("seed, seq_len, tolerance", [(0, 3, 2), (1, 2, 0), (2, 5, 1), (3, 4, 2)])
def test_recall_at_1_equals_evaluate(seed, seq_len, tolerance):
    rng = np.random.default_rng(seed)
    d = rng.random((40, 40)) if seed % 2 else rng.integers(0, 4, size=(40, 40)).astype(float)
    features = query_features(d, seq_len, tolerance)
    modes = score_split(d, seq_len, tolerance, features=features).metrics.modes
    for mode in MODES:
        single, sequence = recall_at_1(features, mode)
        assert modes[mode]["single"].recall_at[1] == single
        assert modes[mode]["sequence"].recall_at[1] == sequence
    assert modes["standard"]["sequence"].recall_at[1] == features.sequence_correct.mean()


def test_attributes_of_another_matrix_are_refused():
    rng = np.random.default_rng(0)
    d = rng.random((20, 20))
    other = query_features(rng.random((20, 20)), 3, 2)
    with pytest.raises(ValueError, match="do not belong to this distance matrix"):
        score_split(d, 3, 2, features=other)


# --- the command on a user's matrix --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def matrix_predictor(tmp_path_factory):
    """A predictor trained at L = 3 on the attributes of a 160 x 160 matrix like ``user_matrix``'s (frames 0..159
    of dataset "d"): on ``user_matrix`` it keeps some sequence matches and removes others, right ones among both."""
    folder = tmp_path_factory.mktemp("matrix_predictor")
    rng = np.random.default_rng(21)
    features = query_features(np.abs(rng.normal(size=(160, 160))) + 0.5 * (1 - np.eye(160)), 3, 2)
    write_features(folder / "train.h5", features, {"dataset": "d", "split": "train", "split_range": [0, 160]})
    train.main(train_job([folder / "train.h5"], folder / "L3.h5", PARAMS, seq_len=3))
    return folder / "L3.h5"


@pytest.fixture
def user_matrix(tmp_path):
    rng = np.random.default_rng(3)
    d = np.abs(rng.normal(size=(40, 40))) + 3 * (1 - np.eye(40))  # the diagonal is mostly nearest
    np.save(tmp_path / "D.npy", d)
    return tmp_path / "D.npy", d


def test_cli_on_a_users_npy(user_matrix, tmp_path):
    path, d = user_matrix
    out = tmp_path / "m.json"
    assert cli(["metrics", "--distances", str(path), "--seq-len", "3", "--out", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["meta"] == {"seq_len": 3, "tolerance": 2, "ground_truth": {"kind": "frames", "tolerance": 2},
                            "r_window": 10, "spread_k": 10, "matcher": SEQSLAM_PROVENANCE}
    assert list(data["splits"]) == ["all"]
    # a square matrix within 2 frames: every query has a correct reference
    assert data["splits"]["all"]["queries_without_correct"] == data["splits"]["all"]["evaluated_without_correct"] == 0
    single, sequence = naive_recalls(d, 3, 2)
    paper = data["splits"]["all"]["modes"]["paper"]
    assert set(paper) == {"single", "sequence"}
    assert paper["single"]["recall_at"] == pytest.approx({str(n): v for n, v in single.items()})
    assert paper["sequence"]["recall_at"] == pytest.approx({str(n): v for n, v in sequence.items()})
    assert paper["single"]["n_queries"] == 40 and paper["sequence"]["n_queries"] == 38


def test_cli_with_a_predictor(user_matrix, matrix_predictor, tmp_path):
    path, d = user_matrix
    predictor_file = matrix_predictor
    out, queries = tmp_path / "m.json", tmp_path / "q.csv"
    assert cli(["metrics", "--distances", f"test={path}", "--seq-len", "3", "--predictor", str(predictor_file),
                "--modes", "standard", "--queries", str(queries), "--dataset", "d", "--method", "mine",
                "--out", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["meta"] == {"dataset": "d", "method": "mine", "seq_len": 3, "tolerance": 2,
                            "ground_truth": {"kind": "frames", "tolerance": 2}, "predictor": str(predictor_file),
                            "r_window": 10, "spread_k": 10, "matcher": SEQSLAM_PROVENANCE}
    standard = data["splits"]["test"]["modes"]["standard"]
    assert list(data["splits"]["test"]["modes"]) == ["standard"]
    # recall@1 of the predictor matcher, worked out apart from the command: the predictor file's own decision on the
    # rank-0 attributes of the queries a = 2 .. 39 (kept: a class of KEPT_CLASSES, trust level 0), and whether the
    # best diagonal of a naive S (ties: the lower diagonal) is right
    features = query_features(d, 3, 2)
    assert features.queries.tolist() == list(range(2, 40))
    model = SMRPredictor.load(predictor_file)
    probabilities = model.predict_proba(features.attributes[:, 0, :])
    kept = np.isin(np.asarray(model.classes_)[probabilities.argmax(axis=1)], KEPT_CLASSES)
    s = sequence_matrix(d, 3)
    right = np.array([abs(stable_top(list(s[:, j]), 1)[0] - j) <= 2 for j in range(s.shape[1])])
    assert np.any(right & kept) and np.any(right & ~kept)  # it keeps some right matches and removes others
    assert standard["sequence_predictor"]["recall_at"]["1"] == pytest.approx(np.mean(right & kept))
    assert standard["sequence"]["recall_at"]["1"] == pytest.approx(np.mean(right))
    rows = list(csv.DictReader(open(queries)))
    assert standard["sequence_predictor"]["n_queries"] == len(rows) == 38
    assert [r["kept"] for r in rows] == [str(int(k)) for k in kept]


def test_predictor_of_another_seq_len_is_refused(user_matrix, predictor_file, tmp_path, capsys):
    path, _ = user_matrix
    assert cli(["metrics", "--distances", str(path), "--seq-len", "4", "--predictor", str(predictor_file),
                "--out", str(tmp_path / "m.json")]) == 2
    err = capsys.readouterr().err
    assert "trained at sequence length 3" in err and "--seq-len 3" in err
    assert not (tmp_path / "m.json").exists()


def test_predictor_never_scores_its_training_frames(predictor_file, tmp_path):
    rng = np.random.default_rng(0)
    provenance = {"dataset": "d", "split": "val", "split_range": [40, 70], "method": "m"}
    write_distance_matrix(tmp_path / "val.h5", rng.random((30, 30)), provenance)
    matrix = (f"val={tmp_path / 'val.h5'}",)  # a split of frames 40..69 of dataset "d"
    with pytest.raises(SplitLeakError, match="shares frames"):
        main(MetricsJob(matrix, 3, predictor=str(predictor_file), out=str(tmp_path / "m.json")))
    result = main(MetricsJob(matrix, 3, predictor=str(predictor_file), allow_split_overlap=True,
                             out=str(tmp_path / "m.json")))
    assert "sequence_predictor" in result.splits["val"].modes["paper"]


@pytest.mark.parametrize("args, message", [
    (["--out", "m.csv"], "--out m.csv: the VPR metrics (JSON) must end in .json"),
    (["--out", "m.json", "--queries", "q.txt"], "--queries q.txt: the per-query table (CSV) must end in .csv"),
    (["--out", "m.json", "--predictor", "p.pkl"], "--predictor p.pkl: the predictor (HDF5) must end in .h5"),
    (["--out", "m.json", "--predictor", "nope.h5"], "predictor file not found: nope.h5"),
    (["--out", "m.json", "--attributes", "val=a.h5"], "--attributes names splits ['val']"),
    (["--out", "m.json", "--attributes", "all=nope.h5"], "attributes of split 'all' not found: nope.h5"),
    (["--out", "m.json", "--seq-len", "50"], "too small for sequence length 50"),
])
def test_bad_arguments_are_named(user_matrix, tmp_path, monkeypatch, capsys, args, message):
    path, _ = user_matrix
    monkeypatch.chdir(tmp_path)
    argv = ["metrics", "--distances", str(path), "--seq-len", "3", *args]
    assert cli(argv) == 2
    err = capsys.readouterr().err
    assert message in err
    assert not list(tmp_path.glob("m.*")) and not list(tmp_path.glob("*.tmp"))


def test_missing_distances_and_wrong_suffix(tmp_path, capsys):
    assert cli(["metrics", "--distances", str(tmp_path / "nope.npy"), "--seq-len", "3",
                "--out", str(tmp_path / "m.json")]) == 2
    assert "distance matrix of split 'all' not found" in capsys.readouterr().err
    (tmp_path / "D.txt").write_text("1 2\n3 4\n")
    assert cli(["metrics", "--distances", f"val={tmp_path / 'D.txt'}", "--seq-len", "3",
                "--out", str(tmp_path / "m.json")]) == 2
    assert "must end in .npy, .npz, .mat, .h5 or .hdf5" in capsys.readouterr().err
    assert cli(["metrics", "--distances", "a.npy", "b.npy", "--seq-len", "3", "--out", str(tmp_path / "m.json")]) == 2
    assert "--distances takes SPLIT=PATH items" in capsys.readouterr().err


def test_attributes_files_are_used_and_checked(tmp_path):
    rng = np.random.default_rng(5)
    d = rng.random((30, 30))
    np.save(tmp_path / "D.npy", d)
    attributes_main(AttributesJob(str(tmp_path / "D.npy"), 3, TruthSource(tolerance=2), out=str(tmp_path / "a3.h5")))
    matrix, given = (str(tmp_path / "D.npy"),), {"all": str(tmp_path / "a3.h5")}
    with_file = main(MetricsJob(matrix, 3, TruthSource(tolerance=2), attributes=given, out=str(tmp_path / "m1.json")))
    computed = main(MetricsJob(matrix, 3, TruthSource(tolerance=2), out=str(tmp_path / "m2.json")))
    assert with_file == computed
    with pytest.raises(ValueError, match="sequence length 3, but --seq-len is 4"):
        main(MetricsJob(matrix, 4, TruthSource(tolerance=2), attributes=given, out=str(tmp_path / "m.json")))
    with pytest.raises(ValueError, match="at tolerance 2, but --tolerance is 1"):
        main(MetricsJob(matrix, 3, TruthSource(tolerance=1), attributes=given, out=str(tmp_path / "m.json")))
