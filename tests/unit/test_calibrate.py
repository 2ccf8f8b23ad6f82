"""vpr-smr calibrate and deploy (method §16): the threshold file, its checks, the numbers against naive loops written
here, and every refusal of a bad input, each before anything is written."""

from __future__ import annotations

import csv
import hashlib
import json

import numpy as np
import pytest
from oracles import naive_empirical, naive_guaranteed

from vpr_smr import api
from vpr_smr.eval.scoring.queries import QUERY_COLUMNS, score_columns
from vpr_smr.eval.scoring.threshold_file import read_thresholds
from vpr_smr.pipeline.cli import main

MATCHER = "seqslam (velocities [1.0])"

NAMED = ("--method", "sad", "--seq-len", "4")  # what every threshold file must say (deploy and live compare them)


def split_data(n, seed, quality):
    """Integer confidences with ties; a query is correct more often the higher its confidence."""
    rng = np.random.default_rng(seed)
    c = rng.integers(0, 40, n).astype(float)
    y = rng.random(n) < np.clip(c / 40 + quality, 0, 1)
    return c, y


def write_table(path, splits, source="uniqueness", labelled=True, matcher=MATCHER):
    """A per-query table as vpr-smr queries writes it (its header), the given splits' confidences and labels."""
    header = [*QUERY_COLUMNS, *score_columns()]
    with open(path, "w", newline="") as handle:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(header)
        for name, (c, y) in splits.items():
            for a, (value, ok) in enumerate(zip(c, y, strict=True)):
                row = dict.fromkeys(header, "")
                row.update(split=name, query=str(a + 3), sequence_match=str(a + 3 + (0 if ok else 50)),
                           sequence_correct=(str(int(ok)) if labelled else ""), matcher=matcher)
                row[f"c_{source}"] = repr(float(value))
                row["c_random"] = "1.0"
                writer.writerow([row[h] for h in header])


@pytest.fixture
def table(tmp_path):
    val, test = split_data(400, 1, 0.3), split_data(300, 2, 0.25)
    path = tmp_path / "queries.csv"
    write_table(path, {"val": val, "test": test})
    return path, val, test


@pytest.mark.parametrize("rule", ["empirical", "guaranteed", "same_fraction"])
def test_calibrate_writes_the_rules_threshold(tmp_path, table, rule, capsys):
    path, (c, y), _ = table
    out = tmp_path / "thr.json"
    assert main(["calibrate", "--queries", str(path), "--split", "val", "--source", "uniqueness", "--precision",
                 "0.9", "--rule", rule, "--risk", "0.1", "--seq-len", "4", "--method", "sad", "--out",
                 str(out)]) == 0
    expected = naive_guaranteed(list(c), list(y), 0.9, 0.1) if rule == "guaranteed" else naive_empirical(
        list(c), list(y), 0.9)
    assert expected is not None
    found = read_thresholds(out)
    assert found.threshold == expected
    assert (found.source, found.method, found.seq_len, found.matcher, found.rule, found.split) == (
        "uniqueness", "sad", 4, MATCHER, rule, "val")
    assert found.n_queries == 400 and found.accepted == int((c >= expected).sum())
    assert found.wrong == int(((c >= expected) & ~y).sum())
    printed = capsys.readouterr().out
    precision = (found.accepted - found.wrong) / found.accepted
    assert f"precision {precision:.4f}" in printed
    assert f"recall {(found.accepted - found.wrong) / 400:.4f}" in printed
    if rule == "guaranteed":
        assert "calibration queries for precision 0.9 at risk 0.1" in printed


def test_a_hand_edited_file_is_refused(tmp_path, table, capsys):
    path, _, _ = table
    out = tmp_path / "thr.json"
    assert main(["calibrate", "--queries", str(path), "--source", "uniqueness", "--rule", "empirical", *NAMED,
                 "--out", str(out)]) == 0
    data = json.loads(out.read_text())
    data["threshold"] = data["threshold"] - 1
    out.write_text(json.dumps(data))
    assert main(["deploy", "--thresholds", str(out), "--queries", str(path), "--split", "test", "--out",
                 str(tmp_path / "d.json")]) != 0
    err = capsys.readouterr().err
    assert "was edited after vpr-smr calibrate wrote it (its hash does not match): calibrate again" in err
    assert not (tmp_path / "d.json").exists()


def test_deploy_numbers_and_accepted_table(tmp_path, table, capsys):
    path, _, (c, y) = table
    thr, out, accepted = tmp_path / "thr.json", tmp_path / "d.json", tmp_path / "accepted.csv"
    assert main(["calibrate", "--queries", str(path), "--source", "uniqueness", "--rule", "empirical", *NAMED,
                 "--out", str(thr)]) == 0
    t = read_thresholds(thr).threshold
    assert main(["deploy", "--thresholds", str(thr), "--queries", str(path), "--split", "test", "--segment", "100",
                 "--accepted", str(accepted), "--out", str(out)]) == 0
    found = json.loads(out.read_text())
    taken = [v >= t for v in c]
    n = sum(taken)
    right = sum(1 for a, ok in zip(taken, y, strict=True) if a and ok)
    assert found["accepted"] == n and found["labelled"] is True
    assert found["realised"]["precision"] == right / n
    assert found["realised"]["recall"] == right / 300
    assert found["outcome"] == ("held" if right / n >= 0.9 else "violated")
    # segments of 100 queries: 3, each's precision by a loop
    below = 0
    for start in (0, 100, 200):
        seg = [(a, ok) for a, ok in zip(taken[start:start + 100], y[start:start + 100], strict=True) if a]
        below += bool(seg) and sum(ok for _, ok in seg) / len(seg) < 0.9
    assert found["segments"]["n_segments"] == 3 and found["segments"]["violated"] == below
    with open(accepted) as handle:
        rows = list(csv.DictReader(handle))
    assert [int(r["accepted"]) for r in rows] == [int(a) for a in taken]
    assert [float(r["confidence"]) for r in rows] == list(c)
    assert [int(r["query"]) for r in rows] == list(range(3, 303))


def test_deploy_without_labels_gives_the_accepted_only(tmp_path, table, capsys):
    path, val, test = table
    thr = tmp_path / "thr.json"
    assert main(["calibrate", "--queries", str(path), "--source", "uniqueness", "--rule", "same_fraction", *NAMED,
                 "--out", str(thr)]) == 0
    bare = tmp_path / "bare.csv"
    write_table(bare, {"drive": test}, labelled=False)
    capsys.readouterr()
    assert main(["deploy", "--thresholds", str(thr), "--queries", str(bare), "--out", str(tmp_path / "d.json")]) == 0
    assert "has no labels: the accepted matches only" in capsys.readouterr().out
    found = json.loads((tmp_path / "d.json").read_text())
    file = read_thresholds(thr)
    wanted = -(-file.accepted * 300 // 400)  # ceil of the calibration's fraction of 300, in integers
    cut = sorted(test[0], reverse=True)[wanted - 1]
    assert found["accepted"] == sum(1 for v in test[0] if v >= cut) and "realised" not in found


def test_the_table_and_its_matrices_give_the_same_file(tmp_path):
    rng = np.random.default_rng(3)
    matrix = rng.random((60, 60)) + 0.6 - np.eye(60) * 0.6 * (rng.random(60) < 0.7)
    np.save(tmp_path / "D.npy", matrix)
    table = tmp_path / "q.csv"
    assert main(["queries", "--distances", f"val={tmp_path / 'D.npy'}", "--seq-len", "3", "--out", str(table)]) == 0
    common = ["--source", "uniqueness", "--rule", "empirical", "--precision", "0.8", "--seq-len", "3", "--method",
              "sad"]
    assert main(["calibrate", "--queries", str(table), *common, "--out", str(tmp_path / "a.json")]) == 0
    assert main(["calibrate", "--distances", f"val={tmp_path / 'D.npy'}", *common,
                 "--out", str(tmp_path / "b.json")]) == 0
    assert (tmp_path / "a.json").read_text() == (tmp_path / "b.json").read_text()
    assert read_thresholds(tmp_path / "a.json").threshold is not None


def fails(capsys, argv, *fragments):
    assert main(argv) != 0
    err = capsys.readouterr().err
    assert "Traceback" not in err
    for fragment in fragments:
        assert fragment in err, err


@pytest.mark.parametrize("extra, fragments", [
    (["--precision", "1.5"], ["precision"]),
    (["--precision", "0"], ["precision"]),
    (["--risk", "1"], ["risk 1.0 is no risk"]),
    (["--precision", "1"], ["precision 1 cannot be guaranteed"]),
    (["--precision", "0.999"], ["needs at least", "calibration queries for precision 0.999 at risk 0.1 (with distinct",
                                "confidences, every one correct); you gave 400 and it sets no threshold",
                                "calibrate on a longer split, lower the target or raise the risk"]),
    (["--split", "train"], ["holds the splits val, test", "'train' is not one of them"]),
])
def test_bad_calibrations_are_refused_before_writing(tmp_path, table, capsys, extra, fragments):
    path, _, _ = table
    out = tmp_path / "thr.json"
    fails(capsys, ["calibrate", "--queries", str(path), "--source", "uniqueness", *NAMED, *extra, "--out", str(out)],
          *fragments)
    assert not out.exists() and not list(tmp_path.glob("*.tmp"))


def test_unknown_and_random_sources_and_no_correct_match(tmp_path, table, capsys):
    path, _, _ = table
    out = tmp_path / "thr.json"
    fails(capsys, ["calibrate", "--queries", str(path), "--source", "spreadd", *NAMED, "--out", str(out)],
          "no column c_spreadd", "its sources: uniqueness, single_uniqueness")
    fails(capsys, ["calibrate", "--queries", str(path), "--source", "random", *NAMED, "--out", str(out)],
          "a random order has nothing to calibrate")
    wrong = tmp_path / "wrong.csv"
    write_table(wrong, {"val": (np.arange(20.0), np.zeros(20, bool))})
    fails(capsys, ["calibrate", "--queries", str(wrong), "--source", "uniqueness", "--rule", "empirical", *NAMED,
                   "--out", str(out)], "has no correct sequence match among its 20 queries")
    assert not out.exists()


def test_a_file_of_another_matcher_length_or_method_is_refused(tmp_path, table, capsys):
    path, _, test = table
    thr = tmp_path / "thr.json"
    assert main(["calibrate", "--queries", str(path), "--source", "uniqueness", "--rule", "empirical", "--seq-len",
                 "4", "--method", "sad", "--out", str(thr)]) == 0
    other = tmp_path / "other.csv"
    write_table(other, {"test": test}, matcher="seqslam (velocities [0.5, 1.0])")
    out = tmp_path / "d.json"
    fails(capsys, ["deploy", "--thresholds", str(thr), "--queries", str(other), "--out", str(out)],
          "for the matcher 'seqslam (velocities [1.0])'", "has the matcher 'seqslam (velocities [0.5, 1.0])'")
    fails(capsys, ["deploy", "--thresholds", str(thr), "--queries", str(path), "--split", "test", "--seq-len", "8",
                   "--out", str(out)], "for the sequence length 4", "has the sequence length 8")
    fails(capsys, ["deploy", "--thresholds", str(thr), "--queries", str(path), "--split", "test", "--method",
                   "netvlad", "--out", str(out)], "for the method 'sad'", "has the method 'netvlad'")
    assert not out.exists()


def test_api_calibrate_and_deploy_against_loops():
    for seed in range(4):
        c, y = split_data(300, seed + 10, 0.3)
        d, z = split_data(200, seed + 20, 0.3)
        for rule in ("empirical", "guaranteed"):
            found = api.calibrate(c, y, precision=0.85, risk=0.1, rule=rule)
            expected = (naive_guaranteed(list(c), list(y), 0.85, 0.1) if rule == "guaranteed"
                        else naive_empirical(list(c), list(y), 0.85))
            assert found.threshold == expected
            deployed = api.deploy(d, found, z, segment=50)
            taken = np.array([expected is not None and v >= expected for v in d])
            np.testing.assert_array_equal(deployed.accepted, taken)
            if taken.any():
                assert deployed.realised.precision == (taken & z).sum() / taken.sum()
            assert deployed.segments.n_segments == 4
    with pytest.raises(ValueError, match="needs at least"):
        api.calibrate(np.arange(10.0), np.ones(10, bool), precision=0.95)
    assert api.deploy(np.arange(5.0), api.calibrate(np.arange(10.0), np.ones(10, bool), rule="empirical")
                      ).realised is None


def test_the_predictor_file_is_compared_by_its_hash(tmp_path, capsys):
    c, y = split_data(200, 5, 0.3)
    path = tmp_path / "q.csv"
    write_table(path, {"val": (c / 40, y), "test": (c / 40, y)}, source="predictor")
    (tmp_path / "a.h5").write_bytes(b"predictor a")
    (tmp_path / "b.h5").write_bytes(b"predictor b")
    thr = tmp_path / "thr.json"
    assert main(["calibrate", "--queries", str(path), "--source", "predictor", "--rule", "empirical", "--precision",
                 "0.8", "--predictor", str(tmp_path / "a.h5"), *NAMED, "--out", str(thr)]) == 0
    assert read_thresholds(thr).predictor_sha256 == hashlib.sha256(b"predictor a").hexdigest()
    out = tmp_path / "d.json"
    fails(capsys, ["deploy", "--thresholds", str(thr), "--queries", str(path), "--split", "test", "--predictor",
                   str(tmp_path / "b.h5"), "--out", str(out)], "calibrated with the predictor of SHA-256",
          "calibrate again with this predictor")
    assert not out.exists()
    assert main(["deploy", "--thresholds", str(thr), "--queries", str(path), "--split", "test", "--predictor",
                 str(tmp_path / "a.h5"), "--out", str(out)]) == 0


def test_a_file_says_its_method_length_and_scorers_and_deploy_compares_them(tmp_path, table, capsys):
    path, _, _ = table
    thr = tmp_path / "thr.json"
    fails(capsys, ["calibrate", "--queries", str(path), "--source", "uniqueness", "--out", str(thr)],
          "give --method NAME and --seq-len L")
    fails(capsys, ["calibrate", "--queries", str(path), "--source", "predictor", *NAMED, "--out", str(thr)],
          "--predictor PATH")
    assert not thr.exists()
    assert main(["calibrate", "--queries", str(path), "--source", "uniqueness", "--rule", "empirical", *NAMED,
                 "--out", str(thr)]) == 0
    assert read_thresholds(thr).scorers == {"r_window": 10, "spread_k": 10}
    out = tmp_path / "d.json"
    fails(capsys, ["deploy", "--thresholds", str(thr), "--queries", str(path), "--split", "test", "--r-window", "4",
                   "--out", str(out)], "is for the scorers' r_window 10", "has the scorers' r_window 4")
    assert not out.exists()


def test_tied_confidences_let_guaranteed_set_a_threshold_below_the_distinct_size():
    # 600 correct queries tied at confidence 1 and 100 wrong below: the first step accepts all 600 tied ones,
    # whose bound at p = 0.99 is 1 - (0.1 / 10)^(1/600) = 0.0076 <= 0.01, though 700 < 917 distinct ones
    confidence = np.concatenate([np.ones(600), np.linspace(0.0, 0.5, 100)])
    correct = np.concatenate([np.ones(600, bool), np.zeros(100, bool)])
    assert 1 - (0.1 / 10) ** (1 / 600) <= 0.01
    found = api.calibrate(confidence, correct, precision=0.99, risk=0.1, rule="guaranteed")
    assert (found.threshold, found.accepted, found.wrong) == (1.0, 600, 0)
