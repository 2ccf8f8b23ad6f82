"""A predictor that removes every match (or keeps every one, or makes a perfect baseline worse) is named in words
in Table I, the findings, the PR figure and the seed spread, never shown as a success; one whose validation F1 is
at chance is warned about."""

import csv
import logging
import warnings
from pathlib import Path

import numpy as np
import pytest
from row_records import record, records
from training_sets import evaluate_job, train_job

from vpr_smr.core.io import write_json
from vpr_smr.eval.matching.attributes import Matching, query_features, write_features
from vpr_smr.eval.predictor.estimator import SMRPredictor
from vpr_smr.eval.predictor.records import PredictorReport, SeedReport, SplitScores, chance_f1, seed_problems
from vpr_smr.eval.report import build, tabulate
from vpr_smr.eval.report.figures import pr_title
from vpr_smr.eval.report.rows import Table1Row
from vpr_smr.eval.scoring import curves, evaluate

# --- the outcome of one comparison, on four queries worked out by hand ---------------------------------------------

DISTANCES = np.array([1.0, 2.0, 3.0, 4.0])


def compared(correct, keep):
    correct, keep = np.array(correct, bool), np.array(keep, bool)
    baseline = curves.standard_curve(DISTANCES, correct, np.ones(4, bool))
    comparison = curves.compare_curves(baseline, curves.standard_curve(DISTANCES, correct, keep))
    return comparison, curves.outcome(4, int((~keep).sum()), comparison)


def test_every_removed_match_is_named_and_the_baseline_keeps_its_own_aoc():
    # correct T F T F, in distance order: recall (over 4) 1/4, 1/4, 2/4, 2/4; precision 1, 1/2, 2/3, 1/2.
    # Trapezoids from (0, 1): 1/4 * 1 + 0 + 1/4 * (1/2 + 2/3) / 2 + 0 = 0.25 + 0.1458333 = 0.3958333; R_max 1/2
    comparison, outcome = compared([1, 0, 1, 0], [0, 0, 0, 0])
    assert outcome == curves.REMOVED_ALL
    assert comparison.max_recall == 0 and comparison.reduction_pct is None  # cut at recall 0: both AOCs 0
    assert comparison.max_recall_baseline == 0.5
    assert comparison.aoc_baseline_own == pytest.approx(0.5 - (0.25 + 0.25 * (0.5 + 2 / 3) / 2))


@pytest.mark.parametrize(("correct", "keep", "expected"), [
    ([1, 0, 1, 0], [0, 1, 0, 1], curves.KEPT_NONE_CORRECT),  # two kept, both wrong: recall 0
    ([0, 0, 0, 0], [1, 1, 0, 0], curves.NO_CORRECT_MATCH),  # nothing correct to begin with
    ([1, 0, 1, 0], [1, 1, 1, 1], curves.KEPT_ALL),  # the same curves: a reduction of exactly 0
    ([1, 1, 1, 1], [1, 0, 1, 0], curves.NOTHING_TO_REDUCE),  # precision 1 everywhere, before and after
    # baseline T T F T: up to recall 1/2 precision 1 (AOC 0); keeping d2..d4 gives T F T: precision 1, 1/2, 2/3 up
    # to recall 1/2, an AOC of 0.5 - (0.25 + 0.1458) > 0: worse than a perfect baseline, by an undefined %
    ([1, 1, 0, 1], [0, 1, 1, 1], curves.WORSE_FROM_ZERO),
    ([1, 0, 1, 0], [1, 0, 1, 1], curves.IMPROVED),  # the wrong d2 removed
    # T F T T, keeping d2..d4: AOC at recall 1/2 from 0.1042 (baseline) to 0.2917, a reduction of -180 %
    ([1, 0, 1, 1], [0, 1, 1, 1], curves.WORSE),
])
def test_outcomes(correct, keep, expected):
    comparison, outcome = compared(correct, keep)
    assert outcome == expected
    assert (comparison.reduction_pct is None) == (outcome in curves.UNDEFINED)
    if outcome == curves.KEPT_ALL:
        assert comparison.reduction_pct == 0.0


# --- a predictor that removes every match, through evaluate and the report ----------------------------------------


def constant_predictor(path: Path, features, label: int) -> Path:
    """A predictor file whose network says ``label`` for every input: trained, then its last bias made huge."""
    rng = np.random.default_rng(7)
    x = rng.normal(size=(80, 4))
    y = np.repeat(np.arange(4), 20)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        predictor = SMRPredictor(hidden_layer_sizes=(4,), max_iter=20).fit(x, y)
    predictor.intercepts_[-1] = np.where(np.arange(4) == label, 1e6, 0.0)
    assert set(predictor.predict(features.attributes[:, 0, :]).tolist()) == {label}
    predictor.save(path, Matching())
    return path


def naive_standard_aoc(distances, correct):
    """AOC of the exact curve at its own maximum recall, written out: sort, count, trapezoids from (0, 1)."""
    order = sorted(range(len(distances)), key=lambda i: (distances[i], i))
    points, tp, fp = [(0.0, 1.0)], 0, 0
    for rank, i in enumerate(order):
        tp, fp = tp + bool(correct[i]), fp + (not correct[i])
        last = rank + 1 == len(order) or distances[order[rank + 1]] != distances[i]
        if last:
            points.append((tp / len(distances), tp / (tp + fp)) if tp else (0.0, 0.0))
    area = sum((r1 - r0) * (p0 + p1) / 2 for (r0, p0), (r1, p1) in zip(points[:-1], points[1:], strict=True))
    return points[-1][0] - area, points[-1][0]


@pytest.fixture
def removed_all(tmp_path):
    rng = np.random.default_rng(2025)
    matrix = rng.random((50, 50)) + 0.8 * (1 - np.eye(50))  # a clear diagonal, with noise: some matches wrong
    matrix[:, 30:] = rng.random((50, 20))  # the last queries: no signal
    features = query_features(matrix, 4)
    write_features(tmp_path / "test.h5", features, {})
    predictor = constant_predictor(tmp_path / "p.h5", features, label=1)  # class 1: remove
    evaluate.main(evaluate_job({"test": tmp_path / "test.h5"}, [predictor, predictor], tmp_path / "e.json",
                               allow_split_overlap=True, dataset="corridor", method="sad"), seeds=[0, 3])
    return tmp_path, features


def test_table1_names_a_predictor_that_removed_every_match(removed_all):
    tmp_path, features = removed_all
    n = len(features.queries)  # 47
    aoc, recall = naive_standard_aoc(features.sequence_distance.tolist(), features.sequence_correct.tolist())
    seed = SeedReport(0, {}, 0.5, 10, (30, 10, 10, 7), {})
    write_json(tmp_path / "p.json", PredictorReport({"dataset": "corridor", "seq_len": 4}, 57, (seed,)).to_json())
    build.write(tmp_path / "run", build.RunFiles([tmp_path / "e.json"], [tmp_path / "p.json"]))
    md = (tmp_path / "run" / "tables" / "table1.md").read_text()
    standard = md.split("## standard mode")[1]
    # cut at the predictor's maximum recall 0, VPR+SM's AOC is 0 on every draw of the queries too
    assert f"| corridor | VPR+SM | 0.0000 [0.0000, 0.0000] (own: {aoc:.4f}) |" in standard
    assert "|  | VPR+SM+Pred | removed every match |" in standard
    assert "|  | Reduction (%) | n/a: removed every match | n/a | 0 / 1 |" in standard
    # both seeds removed everything: the spread says which and why; it has no interval, so it names no direction
    assert "| n/a: seeds 0, 3: removed every match | n/a | no interval (2 seeds) |" in standard
    assert (f"sad: the predictor removed all {n} matches: recall 0; VPR+SM's own AOC is {aoc:.4f} at its own "
            f"maximum recall {recall:.4f}.") in standard
    rows = {r["mode"]: r for r in csv.DictReader(open(tmp_path / "run" / "tables" / "table1.csv"))}
    assert rows["standard"]["outcome"] == "removed_all" and rows["standard"]["removed"] == str(n)
    assert float(rows["standard"]["aoc_vpr_sm_own"]) == pytest.approx(aoc)
    assert rows["standard"]["seeds_left_out"] == "seeds 0, 3: removed every match"
    page = (tmp_path / "run" / "report.html").read_text()
    assert f"for sad, the predictor removed all {n} matches: recall 0" in page
    assert "nothing to reduce" not in page.split('id="findings"')[1].split("</section>")[0]


def test_the_pr_panel_title_says_what_happened():
    numbers = {"outcome": curves.REMOVED_ALL, "n_queries": 21, "removed": 21, "aoc_vpr_sm_own": 0.4213,
               "max_recall_vpr_sm": 0.614, "aoc_vpr_sm": 0.0, "aoc_vpr_sm_pred": 0.0}
    assert pr_title("hog", numbers) == "hog\nremoved all 21 matches: recall 0\nVPR+SM AOC 0.421 at R 0.61"
    kept = {**numbers, "outcome": curves.KEPT_NONE_CORRECT, "removed": 18}
    assert pr_title("hog", kept).startswith("hog\nkept 3 of 21 matches, none correct: recall 0")
    worse = {**numbers, "outcome": curves.WORSE_FROM_ZERO, "aoc_vpr_sm_pred": 0.0238}
    assert pr_title("sad", worse) == "sad\nAOC 0.000 -> 0.024 (worse than a perfect baseline)"


ONE_SEED = "One predictor seed was run, so there is no spread over seeds."


def test_a_worse_result_from_a_perfect_baseline_is_not_improved():
    from vpr_smr.eval.report.findings import sentences
    from vpr_smr.eval.report.table1 import Table1Block, table1_markdown

    row = {"dataset": "corridor", "method": "sad", "seq_len": 4, "mode": "paper", "aoc_vpr_sm": 0.0,
           "aoc_vpr_sm_pred": 0.0238, "reduction_pct": None, "outcome": curves.WORSE_FROM_ZERO, "max_recall": 0.8,
           "max_recall_vpr_sm": 1.0, "aoc_vpr_sm_own": 0.05, "n_queries": 108, "removed": 9, "n_seeds": 1}
    text = table1_markdown(records(Table1Row, [row]))
    assert "| n/a: worse than a perfect baseline | n/a | 0 / 1 |" in text
    assert sentences(Table1Block("corridor", "paper", 4, (record(Table1Row, row),)), "test") == [
        "On corridor (test split, L = 4, paper mode, seed-0 predictor), for sad, the predictor made the AOC worse, "
        "from 0 to 0.0238 up to its maximum recall 0.8000: worse, by a percentage that is undefined (the "
        "baseline's AOC being 0).", ONE_SEED]


# --- a predictor at chance ----------------------------------------------------------------------------------------


def test_chance_is_one_over_the_classes_present():
    assert chance_f1((10, 0, 5, 0)) == 0.5 and chance_f1((1, 1, 1, 1)) == 0.25 and chance_f1((0, 0, 0, 0)) == 0.0


def test_a_predictor_that_says_one_class_or_guesses_is_named():
    # 21 validation samples, classes 0 (12) and 1 (9), all predicted 1: F1 of class 1 = 2 * 9 / (21 + 9) = 0.6,
    # of class 0 = 0: macro 0.3 <= 1/2
    one_class = SplitScores(0.3, 21, (12, 9, 0, 0), ((0, 12, 0, 0), (0, 9, 0, 0), (0, 0, 0, 0), (0, 0, 0, 0)))
    seed = SeedReport(2, {}, 0.4, 10, (30, 10, 10, 7), {"val": one_class})
    assert seed_problems(seed, "val") == [
        "its val macro F1 0.30 is at or below chance (0.50: guessing each of the 2 classes present at its own "
        "frequency)", "it predicts class 1 for all 21 val samples"]
    good = SplitScores(0.9, 21, (12, 9, 0, 0), ((11, 1, 0, 0), (1, 8, 0, 0), (0, 0, 0, 0), (0, 0, 0, 0)))
    report = PredictorReport({}, 57, (SeedReport(0, {}, 0.8, 10, (30, 10, 10, 7), {"val": good}), seed))
    assert report.warning("val") == (
        "seed 2: its val macro F1 0.30 is at or below chance (0.50: guessing each of the 2 classes present at its own "
        "frequency); it predicts class 1 for all 21 val samples")
    # no validation split: nothing to say
    assert seed_problems(SeedReport(0, {}, 0.8, 10, (1, 1, 1, 1), {}), "val") == []


def query_features_labels(path):
    from vpr_smr.eval.matching.attributes import read_features

    return read_features(path).labels


def test_training_warns_and_the_tables_say_so(tmp_path, caplog):
    from vpr_smr.eval.predictor import train

    rng = np.random.default_rng(11)
    paths = {}
    for split, size in (("train", 60), ("val", 40)):
        # noise: the labels do not follow from the attributes, so the predictor cannot beat chance on val
        features = query_features(rng.random((size, size)), 3)
        paths[split] = tmp_path / f"{split}.h5"
        write_features(paths[split], features, {})
    with caplog.at_level(logging.WARNING, logger="vpr_smr"), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = train.main(train_job([paths["train"]], tmp_path / "L3.h5", {"hidden_layer_sizes": [8], "max_iter": 30},
                                      evaluate={"val": [paths["val"]]}, dataset="noise", seq_len=3,
                                      allow_split_overlap=True))
    scores = report.seeds[0].splits["val"]
    present = len(np.unique(query_features_labels(paths["val"])))  # the classes the val split holds
    assert scores.f1 <= 1 / present  # noise: at or below chance (1 / K), as the warning says
    assert any("this predictor cannot be trusted: seed 0: its val macro F1" in r.message for r in caplog.records)
    row = tabulate.predictor_rows([report])[0]
    assert row.warning.startswith("seed 0: its val macro F1")


def test_one_class_in_the_validation_split_is_no_reason_to_warn():
    # every validation sample of class 0, every one predicted 0: a macro F1 of 1, and no chance to compare with
    perfect = SplitScores(1.0, 12, (12, 0, 0, 0), ((12, 0, 0, 0), (0, 0, 0, 0), (0, 0, 0, 0), (0, 0, 0, 0)))
    assert seed_problems(SeedReport(0, {}, 0.8, 10, (30, 10, 10, 7), {"val": perfect}), "val") == []


def test_the_findings_lead_with_the_predictors_warning(removed_all):
    from vpr_smr.eval.report import registry
    from vpr_smr.eval.report.html import predictor_warnings
    from vpr_smr.eval.report.results import Splits, WrittenTable
    tmp_path, _ = removed_all
    one_class = SplitScores(0.3, 21, (12, 9, 0, 0), ((0, 12, 0, 0), (0, 9, 0, 0), (0, 0, 0, 0), (0, 0, 0, 0)))
    report = PredictorReport({"dataset": "corridor", "seq_len": 4}, 57,
                             (SeedReport(0, {}, 0.4, 10, (30, 10, 10, 7), {"val": one_class}),))
    rows = tabulate.predictor_rows([report])
    columns = registry.table("predictor").expanded(Splits("test", ("val", "test")))
    table = WrittenTable("predictor", columns, tuple(rows), ())
    assert predictor_warnings(table, "corridor", 4) == [
        "Warning: the predictor of corridor at L = 4 cannot be trusted: seed 0: its val macro F1 0.30 is at or "
        "below chance (0.50: guessing each of the 2 classes present at its own frequency); it predicts class 1 for "
        "all 21 val samples."]
    assert predictor_warnings(table, "corridor", 6) == []
    write_json(tmp_path / "p.json", report.to_json())
    build.write(tmp_path / "run", build.RunFiles([tmp_path / "e.json"], [tmp_path / "p.json"]))
    findings = (tmp_path / "run" / "report.html").read_text().split('id="findings"')[1].split("</section>")[0]
    assert findings.count("Warning: the predictor of corridor at L = 4 cannot be trusted") == 2  # both modes
    assert "| corridor | 4 |" in (tmp_path / "run" / "tables" / "predictor.md").read_text()
    assert "it predicts class 1 for all 21 val samples" in (tmp_path / "run" / "tables" / "predictor.csv").read_text()


def test_a_lowered_recall_is_said_and_the_baseline_keeps_its_own_aoc():
    from vpr_smr.eval.report.findings import sentences
    from vpr_smr.eval.report.table1 import Table1Block, table1_markdown

    # kept a third of the correct matches, all of them correct: nothing to reduce up to recall 1/3
    row = {"dataset": "corridor", "method": "sad", "seq_len": 4, "mode": "paper", "aoc_vpr_sm": 0.0,
           "aoc_vpr_sm_pred": 0.0, "reduction_pct": None, "outcome": curves.NOTHING_TO_REDUCE,
           "max_recall": 1 / 3, "max_recall_vpr_sm": 1.0, "aoc_vpr_sm_own": 0.4, "n_queries": 130, "removed": 90,
           "n_seeds": 1}
    text = table1_markdown(records(Table1Row, [row]))
    assert "| corridor | VPR+SM | 0.0000 [n/a] (own: 0.4000) | 0.0000 |  |" in text
    note = ("baseline AOC 0 up to the predictor's maximum recall 0.3333: nothing to reduce, the reduction is "
            "undefined (the predictor lowered the maximum recall from 1.0000; VPR+SM's own AOC is 0.4000 at its own "
            "maximum recall 1.0000)")
    assert f"sad: {note}." in text
    # not "already 0 without the predictor": its own AOC is 0.4
    assert sentences(Table1Block("corridor", "paper", 4, (record(Table1Row, row),)), "test") == [
        f"On corridor (test split, L = 4, paper mode, seed-0 predictor), for sad, {note}.", ONE_SEED]


def test_the_aoc_means_leave_out_a_method_whose_aocs_are_at_recall_zero():
    from vpr_smr.eval.report.table1 import table1_markdown

    common = {"dataset": "d", "seq_len": 4, "mode": "paper", "n_queries": 21, "n_seeds": 1}
    rows = [{**common, "method": "a", "aoc_vpr_sm": 0.2, "aoc_vpr_sm_pred": 0.1, "reduction_pct": 50.0,
             "outcome": curves.IMPROVED, "max_recall": 0.9, "max_recall_vpr_sm": 0.9, "removed": 3},
            {**common, "method": "b", "aoc_vpr_sm": 0.0, "aoc_vpr_sm_pred": 0.0, "reduction_pct": None,
             "outcome": curves.REMOVED_ALL, "max_recall": 0.0, "max_recall_vpr_sm": 0.6, "aoc_vpr_sm_own": 0.3,
             "removed": 21}]
    text = table1_markdown(records(Table1Row, rows))
    # b's AOCs are taken at recall 0: the means are a's alone, 0.2 and 0.1, not (0.2 + 0) / 2
    # (the methods a Mean is over are named; no interval: [n/a] beside each method's number)
    assert ("| d | VPR+SM | 0.2000 [n/a] | 0.0000 [n/a] (own: 0.3000) | 0.2000 (mean over 1 of 2 methods: a) |  |"
            in text)
    assert "|  | VPR+SM+Pred | 0.1000 [n/a] | removed every match | 0.1000 (mean over 1 of 2 methods: a) |  |" in text
    # a's 50.00 has no interval: Improved names no direction for it
    assert ("|  | Reduction (%) | 50.00 [n/a] | n/a: removed every match | 50.00 (mean over 1 of 2 methods: a) | "
            "0 / 2 (1 without an interval) |") in text
