"""The typed results: each file's layout is its records' fields (core.records), and records survive a round trip."""

import json
import warnings

import numpy as np
import pytest
from training_sets import evaluate_job, held_out_job

from vpr_smr.core.io import read_provenance, write_json
from vpr_smr.core.records import FORMAT
from vpr_smr.eval.matching.attributes import Matching, query_features, write_features
from vpr_smr.eval.predictor import ablation, train
from vpr_smr.eval.predictor.estimator import SMRPredictor
from vpr_smr.eval.predictor.records import AttributeAblation, PredictorReport
from vpr_smr.eval.report.tabulate import match_timings
from vpr_smr.eval.scoring import evaluate, held_out
from vpr_smr.eval.scoring.records import Evaluation, HeldOut, Timing

# The keys of one split of an evaluation file and of one mode in it (seed 0, with curves and trust levels): the
# first seed's numbers once (f1_macro, removed, modes), the other seeds' under other_seeds
SPLIT_KEYS = {"n_queries", "n_queries_split", "recall_at_1_single_all", "recall_at_1_single_evaluated",
              "recall_at_1_sequence", "f1_macro", "confusion_matrix", "class_counts", "predicted_counts", "removed",
              "modes", "seed", "other_seeds", "seed_summary", "restoration"}
MODE_KEYS = {"recall_at_1_single", "recall_at_1_sequence", "reduction", "curves", "trust_auc", "trust"}
REDUCTION_KEYS = {"max_recall", "auc_vpr_sm", "auc_vpr_sm_pred", "aoc_vpr_sm", "aoc_vpr_sm_pred", "reduction_pct",
                  "max_recall_vpr_sm", "aoc_vpr_sm_own", "outcome"}
# the first seed's numbers carry their bootstrap intervals (method §8.7); a None one is absent
INTERVAL_KEYS = {"reduction_pct_ci", "aoc_vpr_sm_ci", "aoc_vpr_sm_pred_ci"}
CURVES_KEYS = {"recall_at_100_precision_vpr_sm", "recall_at_100_precision_vpr_sm_pred", "curve_vpr_sm",
               "curve_vpr_sm_pred"}
RESTORATION_MODE_KEYS = {"max_recall", "max_recall_removal", "max_recall_restoration", "auc_vpr_sm", "auc_removal",
                         "auc_restoration", "auc_difference", "aoc_removal", "aoc_restoration", "aoc_difference",
                         "reduction_pct", "curve_restoration"}  # the baseline and removal curves are kept once
HELD_OUT_MODE_KEYS = {"recall_at_1_single", "recall_at_1_sequence", "reduction"}


@pytest.fixture(scope="module")
def stage_files(tmp_path_factory):
    """An evaluation (two splits, two seeds, trust levels, restoration), its timings and a held-out file."""
    tmp = tmp_path_factory.mktemp("records")
    rng = np.random.default_rng(0)
    paths = {}
    for split in ("val", "test"):
        features = query_features(rng.random((40, 40)) + 0.6 * (1 - np.eye(40)), 4)
        paths[split] = tmp / f"{split}.h5"
        write_features(paths[split], features, {"attributes_seconds": 0.25})
    predictors = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for seed in (0, 1):
            predictors.append(tmp / f"p{seed}.h5")
            SMRPredictor(hidden_layer_sizes=(8,), max_iter=30, random_state=seed).fit(
                features.attributes[:, 0], features.labels).save(predictors[-1], Matching())
    evaluation, timing = evaluate.main(evaluate_job(paths, predictors, tmp / "e.json", trust_levels=(0.0, 0.9),
                                                    allow_split_overlap=True))
    scores = held_out.main(held_out_job(paths["test"], predictors[0], predictors[1], tmp / "h.json",
                                        allow_split_overlap=True))
    return tmp, evaluation, timing, scores


def _dumped(record) -> str:
    """The bytes ``write_json`` gives a record."""
    return json.dumps(record.to_json(), indent=1, sort_keys=True)


def test_evaluation_file_layout(stage_files):
    tmp, evaluation, timing, _ = stage_files
    data = json.loads((tmp / "e.json").read_text())
    assert list(data) == ["format", "meta", "predictors", "splits"] and set(data["splits"]) == {"test", "val"}
    assert data["format"] == FORMAT
    split = data["splits"]["test"]
    assert set(split) == SPLIT_KEYS
    paper = split["modes"]["paper"]
    assert set(paper) == MODE_KEYS and set(paper["trust_auc"]) == {"0.0", "0.9"}
    assert set(paper["curves"]) == CURVES_KEYS
    # both AOCs have intervals; the reduction is undefined here (its baseline AOC is 0), and so is its interval
    assert paper["reduction"]["reduction_pct"] is None
    assert set(paper["reduction"]) == REDUCTION_KEYS | INTERVAL_KEYS - {"reduction_pct_ci"}
    # seed 0's numbers are written once: the split's own; the other seed's under other_seeds
    assert split["seed"] == 0 and [seed["seed"] for seed in split["other_seeds"]] == [1]
    assert set(split["other_seeds"][0]["modes"]["standard"]) == REDUCTION_KEYS
    test = evaluation.splits["test"]
    assert [seed.seed for seed in test.seeds] == [0, 1] and test.seeds[1] == test.other_seeds[0]
    assert test.seeds[0].modes["paper"] == test.modes["paper"].reduction and test.seeds[0].f1_macro == test.f1_macro
    assert set(split["restoration"]["modes"]["standard"]) == RESTORATION_MODE_KEYS
    timings = json.loads((tmp / "e.timing.json").read_text())
    assert timings["meta"] == data["meta"] and timings["format"] == FORMAT
    assert set(timings["splits"]["test"]) == {"attributes_seconds", "predict_seconds", "seconds_per_query",
                                              "n_queries"}


def test_records_round_trip_byte_for_byte(stage_files):
    tmp, evaluation, timing, scores = stage_files
    for path, record, kind in ((tmp / "e.json", evaluation, Evaluation), (tmp / "e.timing.json", timing, Timing),
                               (tmp / "h.json", scores, HeldOut)):
        text = path.read_text()
        assert _dumped(record) == text
        read = kind.from_json(json.loads(text))
        assert read == record and kind.from_json(record.to_json()) == record
        assert _dumped(read) == text
        write_json(tmp / "again.json", read.to_json())
        assert (tmp / "again.json").read_text() == text


def test_held_out_file_layout(stage_files):
    tmp, evaluation, _, scores = stage_files
    data = json.loads((tmp / "h.json").read_text())
    assert set(data) == {"format", "meta", "n_queries", "predictors"}
    assert set(data["predictors"]) == {"pooled", "without"}
    assert set(data["predictors"]["pooled"]) == {"path", "f1_macro", "removed", "modes"}
    assert set(data["predictors"]["without"]["modes"]["paper"]) == HELD_OUT_MODE_KEYS
    assert scores.n_queries == data["n_queries"] == 37
    # the held-out reductions carry their bootstrap intervals: the pooled predictor is the evaluation's seed 0 on
    # the same test split, so its numbers are that split's, intervals and all
    for mode in ("paper", "standard"):
        assert scores.pooled.modes[mode].reduction == evaluation.splits["test"].modes[mode].reduction
        assert scores.pooled.modes[mode].reduction.aoc_vpr_sm_ci is not None


def test_a_file_missing_a_key_is_refused(stage_files):
    tmp, _, _, _ = stage_files
    data = json.loads((tmp / "e.json").read_text())
    del data["splits"]["test"]["seed_summary"]
    with pytest.raises(KeyError, match="seed_summary"):
        Evaluation.from_json(data)


def test_timings_are_matched_to_their_evaluation_by_meta(stage_files):
    _, evaluation, timing, _ = stage_files
    assert match_timings([evaluation], [timing]) == {("d", "m", 4): timing}
    other = Timing({**timing.meta, "seq_len": 8}, timing.splits)
    with pytest.raises(ValueError, match="d, m, L8 match no evaluation"):
        match_timings([evaluation], [timing, other])
    with pytest.raises(ValueError, match="two timing files"):
        match_timings([evaluation], [timing, timing])


@pytest.fixture(scope="module")
def predictor_files(tmp_path_factory):
    """A two-seed predictor report (val and test given) and an attribute ablation, as the stages write them."""
    from training_sets import PARAMS, ablation_job, method_samples, train_job, write_samples

    tmp = tmp_path_factory.mktemp("predictor_records")
    paths = {name: write_samples(tmp / f"{name}.h5", *method_samples(n, seed))
             for name, n, seed in (("a", 48, 0), ("b", 36, 1), ("val", 30, 2), ("test", 24, 3))}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scored = {"val": [paths["val"]], "test": [paths["test"]]}
        report = train.main(train_job([paths["a"], paths["b"]], tmp / "L4.h5", PARAMS, evaluate=scored, seeds=2))
        table2 = ablation.attributes_main(ablation_job([paths["a"], paths["b"]], tmp / "t2.json", PARAMS,
                                                       evaluate=scored))
    return tmp, report, table2


def test_predictor_records_round_trip_byte_for_byte(predictor_files):
    tmp, report, table2 = predictor_files
    assert isinstance(report, PredictorReport) and isinstance(table2, AttributeAblation)
    for path, record, kind in ((tmp / "L4.json", report, PredictorReport), (tmp / "t2.json", table2,
                                                                             AttributeAblation)):
        text = path.read_text()
        assert _dumped(record) == text
        read = kind.from_json(json.loads(text))
        assert read == record and kind.from_json(record.to_json()) == record
        write_json(tmp / "again.json", read.to_json())
        assert (tmp / "again.json").read_text() == text
    # the predictor file keeps the whole report; the other seed's file a report of its own seed alone
    assert read_provenance(tmp / "L4.h5")["report"] == json.loads(json.dumps(report.to_json()))
    own = PredictorReport(report.meta, report.n_train, (report.seeds[1],))
    assert PredictorReport.from_json(read_provenance(tmp / "L4.seed1.h5")["report"]) == own


def test_predictor_file_layouts(predictor_files):
    tmp, report, _ = predictor_files
    data = json.loads((tmp / "L4.json").read_text())
    # every seed once, the first seed's numbers not repeated at the top level
    assert set(data) == {"format", "meta", "n_train", "seeds", "seed_models"}
    assert set(data["seeds"][1]) == {"seed", "params", "f1_cv", "n_iter", "train_class_counts", "splits"}
    assert set(data["seeds"][1]["splits"]) == {"val", "test"}
    assert set(data["seeds"][1]["splits"]["val"]) == {"f1", "n", "class_counts", "confusion"}
    first = data["seeds"][0]
    assert report.seeds[0].f1("val") == first["splits"]["val"]["f1"]
    assert report.seeds[0].splits["test"].n == first["splits"]["test"]["n"] == 24
    assert report.first_seed()["f1_val"] == first["splits"]["val"]["f1"] and report.first_seed()["n_test"] == 24
    table2 = json.loads((tmp / "t2.json").read_text())
    assert set(table2) == {"format", "meta", "params", "n_train", "attributes"}
    assert set(table2["attributes"]["A3"]) == {"columns", "f1_cv", "splits"}
    assert set(table2["attributes"]["A3"]["splits"]) == {"val", "test"}
    assert set(table2["attributes"]["A3"]["splits"]["val"]) == {"f1", "n", "f1_method_mean"}


def test_a_predictor_file_missing_a_key_or_disagreeing_is_refused(predictor_files):
    tmp, _, _ = predictor_files
    data = json.loads((tmp / "L4.json").read_text())
    del data["seeds"][0]["splits"]["test"]["confusion"]
    with pytest.raises(KeyError, match="seeds\\[0\\].splits.test.confusion"):
        PredictorReport.from_json(data)
    data = json.loads((tmp / "L4.json").read_text())
    data["f1_cv"] = -1.0  # the first seed's numbers at the top level, as earlier reports had them: not an entry
    with pytest.raises(ValueError, match="unexpected entries 'f1_cv'"):
        PredictorReport.from_json(data)
    data = json.loads((tmp / "t2.json").read_text())
    del data["attributes"]["all"]["f1_cv"]
    with pytest.raises(KeyError, match="f1_cv"):
        AttributeAblation.from_json(data)
