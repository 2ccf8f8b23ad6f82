"""The one codec of every result record (core.records): each record type survives a round trip through JSON with its
types (tuples, int keys, None, NaN, nested records), and a file of another results format is refused by name."""

import dataclasses
import json
import math

import h5py
import numpy as np
import pytest
from helpers import seqslam

from vpr_smr.core.environment import NumericEnvironment, ThreadPool
from vpr_smr.core.io import write_json
from vpr_smr.core.records import (
    FORMAT,
    FileRecord,
    FormatError,
    MissingEntry,
    Record,
    decode,
    encode,
    load,
    save,
)
from vpr_smr.eval.matching.attributes import POSITIONS, Matching
from vpr_smr.eval.matching.fingerprint import MatrixPrint
from vpr_smr.eval.predictor.leakage import TRAINED_ON, FrameRange, Training, trained_on
from vpr_smr.eval.predictor.records import (
    AttributeAblation,
    AttributeScores,
    AttributeSplit,
    PredictorReport,
    SeedReport,
    SplitScores,
)
from vpr_smr.eval.scoring.adaptive_records import AdaptiveMode, AdaptiveResult, AdaptiveRow, AdaptiveTiming
from vpr_smr.eval.scoring.calibrate_stage import Deployed, DeployedSplit
from vpr_smr.eval.scoring.deployment_records import Chosen, DeploymentResult, DeploymentRow, RiskCoverage
from vpr_smr.eval.scoring.matcher_comparison import MatcherComparison, MatcherMode, MatcherScores
from vpr_smr.eval.scoring.records import (
    Baselines,
    BudgetRemoval,
    Detection,
    Evaluation,
    EvaluationSplit,
    HeldOut,
    HeldOutPredictors,
    HeldOutScores,
    Interval,
    MatcherMetrics,
    ModeRemoval,
    PRCurve,
    ProtocolSweep,
    Reduction,
    RemovalCurves,
    RestorationMode,
    RestorationNumbers,
    ScorerRemoval,
    SeedNumbers,
    SeedSummary,
    SplitBaselines,
    SplitMetrics,
    SplitTiming,
    SweepPoint,
    Timing,
    TrustNumbers,
    Versus,
    VPRMetrics,
)
from vpr_smr.eval.scoring.speed import SpeedMatcher, SpeedResult, SpeedScores
from vpr_smr.eval.scoring.threshold_file import ThresholdFile
from vpr_smr.eval.scoring.thresholds import Calibration, Realised, Segments
from vpr_smr.pipeline.recipes import Recipe, Recipes

NAN, INF = float("nan"), float("inf")
META = {"dataset": "d", "method": "m", "seq_len": 4, "tolerance": 2, "split": ["test", 10, 60]}

# --- one record of each type, hand-made: NaN and infinities, None (null, and absent), nested records -------------

CURVE = PRCurve((0.0, 0.25, 0.5), (1.0, NAN, 0.5))
REDUCTION = Reduction(0.5, 0.4, 0.45, 0.1, 0.05, 50.0, 0.75, 0.125, "improved")
UNDEFINED = Reduction(1.0, 1.0, 1.0, 0.0, 0.0, None, 1.0, 0.0, "nothing_to_reduce")
SPREAD = Interval(-2.5, 61.0)
# the first seed's numbers, with their bootstrap intervals (one None: absent from the file)
REDUCTION_CI = dataclasses.replace(REDUCTION, reduction_pct_ci=SPREAD, aoc_vpr_sm_ci=Interval(0.05, 0.2),
                                   aoc_vpr_sm_pred_ci=Interval(0.0, 0.0))
UNDEFINED_CI = dataclasses.replace(UNDEFINED, aoc_vpr_sm_ci=Interval(0.0, INF), aoc_vpr_sm_pred_ci=Interval(NAN, 0.0))
CURVES = RemovalCurves(0.25, INF, CURVE, PRCurve((0.5,), (-INF,)))
TRUST = TrustNumbers(3, 0.5, 0.4, NAN, 0.3, 0.2, None, "removed_all")
MODE = ModeRemoval(0.6, 0.7, REDUCTION_CI, CURVES, {"0.0": TRUST, "0.9": dataclasses.replace(
                       TRUST, removed=0, reduction_pct=12.0, outcome="improved", reduction_pct_ci=SPREAD)},
                   {"0.0": CURVE, "0.9": PRCurve((), ())})
BARE_MODE = ModeRemoval(0.6, NAN, UNDEFINED_CI)  # no curves, no trust levels: absent from the file
SEED = SeedNumbers(3, 0.61, 7, {"paper": REDUCTION, "standard": UNDEFINED})
SUMMARY = SeedSummary(3, 2, 12.5, NAN, -3.0, 28.0, {0: "improved", 3: "worse", 12: "nothing_to_reduce"})
NO_SUMMARY = SeedSummary(1, 0, None, None, None, None, {0: "nothing_to_reduce"})
RESTORED = RestorationMode(0.5, 0.4, 0.6, 0.3, 0.35, 0.4, 0.05, 0.1, 0.05, -0.05, None, CURVE)
RESTORED_CURVES = dataclasses.replace(RESTORED, reduction_pct=50.0, curve_vpr_sm=CURVE, curve_removal=CURVE,
                                      reduction_pct_ci=Interval(20.0, 75.5))
RESTORATION = RestorationNumbers(0.9, 0.5, 4, 3, 2, 1, 1, 0, (2, 1, 0), {"paper": RESTORED,
                                                                         "standard": RESTORED_CURVES})
SPLIT = EvaluationSplit(57, 60, 0.5, 0.55, 0.7, 0.61, ((5, 0, 1, 0), (0, 4, 0, 0), (0, 0, 3, 2), (1, 0, 0, 9)),
                        (6, 4, 5, 10), (6, 4, 4, 11), 7, {"paper": MODE, "standard": BARE_MODE}, 0, (SEED,),
                        {"paper": SUMMARY, "standard": NO_SUMMARY}, RESTORATION)
BARE_SPLIT = dataclasses.replace(SPLIT, other_seeds=(), restoration=None, seed=5)
EVALUATION = Evaluation(META, ("p.h5", "p.seed3.h5"), {"val": BARE_SPLIT, "test": SPLIT})
SPLIT_TIMING = SplitTiming.of(0.25, 0.125, 57)
TIMING = Timing(META, {"val": SPLIT_TIMING, "test": SplitTiming(0.0, 0.0, 0.0, 0)})
HELD_OUT_SCORES = HeldOutScores("p.h5", 0.5, 3, {"paper": MODE, "standard": BARE_MODE})
HELD_OUT_PREDICTORS = HeldOutPredictors(HELD_OUT_SCORES, dataclasses.replace(HELD_OUT_SCORES, path="w.h5"))
HELD_OUT = HeldOut(META, 57, HELD_OUT_PREDICTORS)
MATCHER = MatcherMetrics(57, {1: 0.5, 5: 0.75, 10: NAN, 20: 1.0}, 0.25, 0.6, INF)
DETECTION = Detection(0.75, None, CURVE, Interval(0.5, 0.875))
NO_DETECTION = Detection(None, None)  # no wrong match: nothing to detect, no curve
SCORER_REMOVAL = ScorerRemoval(7, {"paper": REDUCTION, "standard": UNDEFINED})
SCORER_REMOVAL_CI = ScorerRemoval(7, {"paper": REDUCTION_CI, "standard": UNDEFINED_CI})
VERSUS = Versus({"paper": Interval(-40.0, -1.5), "standard": None}, Interval(0.0625, 0.25))
BUDGET = BudgetRemoval(3, 7, {"uniqueness": SCORER_REMOVAL, "oracle": dataclasses.replace(SCORER_REMOVAL, removed=5)})
SPLIT_BASELINES = SplitBaselines(57, 12, (0, 3), {"uniqueness": DETECTION, "random": NO_DETECTION},
                                 (NO_DETECTION, Detection(0.2, 0.5)),
                                 (dataclasses.replace(BUDGET, scorers={"uniqueness": SCORER_REMOVAL_CI}), BUDGET),
                                 {"uniqueness": VERSUS, "random": Versus({"paper": None}, None)})
NO_BUDGET = SplitBaselines(57, 0, (0,), {"oracle": NO_DETECTION}, (NO_DETECTION,))  # no predictor: no removal
BASELINES = Baselines({**META, "r_window": 10, "spread_k": 10}, {"val": NO_BUDGET, "test": SPLIT_BASELINES})
SPLIT_METRICS = SplitMetrics({"paper": {"single": MATCHER, "sequence": MATCHER}, "standard": {}})
SWEEP_POINT = SweepPoint(2.0, 0.5, 0.6, REDUCTION_CI, 0.55, Interval(-0.03125, 0.125))
SWEEP = ProtocolSweep("frames", {"paper": (SWEEP_POINT, SweepPoint(0.0, 0.1, 0.2)), "standard": ()})
WITH_BASELINES = dataclasses.replace(SPLIT_METRICS, queries_without_correct=2, evaluated_without_correct=1,
                                     sweep=SWEEP, baselines=SPLIT_BASELINES)
METRICS = VPRMetrics({**META, "predictor": None}, {"test": SPLIT_METRICS, "val": WITH_BASELINES})
SPLIT_SCORES = SplitScores(0.4, 20, (10, 5, 3, 2), ((10, 0, 0, 0), (0, 5, 0, 0), (1, 0, 2, 0), (0, 0, 0, 2)))
SEED_REPORT = SeedReport(2, {"hidden_layer_sizes": [8, 8], "alpha": 1e-4, "smote": True, "column_order": None},
                         0.52, 31, (30, 10, 10, 7), {"check": SPLIT_SCORES,
                                                     "final": dataclasses.replace(SPLIT_SCORES, f1=NAN)})
PREDICTOR = PredictorReport({"dataset": "d", "seq_len": 4}, 57,
                            (SEED_REPORT, dataclasses.replace(SEED_REPORT, seed=3, f1_cv=None, splits={})),
                            ("p.h5", "p.seed3.h5"))
ONE_SEED = PredictorReport({"dataset": "d", "seq_len": 4}, 57, (SEED_REPORT,))
ATTRIBUTE_SCORES = AttributeScores((0, 2), 0.4, {"check": AttributeSplit(0.5, 20, 0.55),
                                                 "final": AttributeSplit(NAN, 24, 0.45)})
ABLATION = AttributeAblation({"dataset": "d", "seq_len": 4}, {"max_iter": 40}, 57,
                             {"A1": AttributeScores((0,), 0.3, {}), "all": dataclasses.replace(ATTRIBUTE_SCORES,
                                                                                           columns=None)})
FRAMES = FrameRange("d", "train", 0, 40, (5, 50))
SPEED_SCORES = SpeedScores(57, 60, 0.3, 0.8, UNDEFINED, 0.5, 3)
SPEED_MATCHER = SpeedMatcher((0.5, 1.0, 2.0), 100, (40, 20, 20, 20), {"m1": SPEED_SCORES,
                                                                      "m2": dataclasses.replace(SPEED_SCORES,
                                                                                                reduction=REDUCTION)})
SPEED = SpeedResult({"dataset": "d", "seq_len": 4, "profile": "varying"}, None, 1.02, 60, 59,
                    {"fixed": SPEED_MATCHER, "velocity": SPEED_MATCHER})

POOL = ThreadPool("blas", "openblas", "0.3.27", 2, "Haswell")
ENVIRONMENT = NumericEnvironment("x86_64", "AMD EPYC 7B13", 2, ("avx", "avx2", "fma"), "0123456789abcdef",
                                 (POOL, ThreadPool("openmp", "libgomp", "", 1, "")), "4.10.0", False, "2.1.3",
                                 "3.11.7")

NO_OPENCV = dataclasses.replace(ENVIRONMENT, opencv=None, opencv_optimised=None)  # a stage that never loaded it

MATCHER_MODE = MatcherMode(0.25, 0.5, REDUCTION_CI, SUMMARY, "uniqueness", REDUCTION, REDUCTION, SPREAD)
BARE_MATCHER_MODE = MatcherMode(0.0, NAN, UNDEFINED, NO_SUMMARY, None, None, UNDEFINED, None)
MATCHER_SCORES = MatcherScores(60, 12, 7, {"paper": MATCHER_MODE, "standard": BARE_MATCHER_MODE}, DETECTION,
                               NO_DETECTION, Interval(0.0625, 0.25), 0.75)
COMPARISON = MatcherComparison({**META, "matchers": {"seqslam": {"name": "seqslam", "settings": {}}}},
                               ("seqslam", "bayes_filter"), 57, None,
                               {"seqslam": {"m": MATCHER_SCORES},
                                "bayes_filter": {"m": dataclasses.replace(MATCHER_SCORES,
                                                                          native_minus_predictor_ap_ci=None,
                                                                          validation_recall_at_1=None)}},
                               None, ("bayes_filter on m: validation recall@1 0.050 is under 0.5 of ...",))

# the experiment adaptive_seq_len (method §15): a fixed row and a rule (its histogram's key -1: none accepted)
ADAPTIVE_MODE = AdaptiveMode(REDUCTION_CI, SUMMARY, -0.03125, Interval(-0.125, 0.0625))
FIXED_ROW = AdaptiveRow("L4+pred", "fixed+predictor", 4, 7, 4.0, {4: 57}, (4.0, 4.0),
                        {"paper": dataclasses.replace(ADAPTIVE_MODE, minus_best_fixed=None, minus_best_fixed_ci=None),
                         "standard": AdaptiveMode(UNDEFINED, None)})
RULE_ROW = AdaptiveRow("adaptive_uniqueness", "rule", None, 12, 2.75, {2: 30, 4: 15, -1: 12}, (2.75, 3.0),
                       {"paper": ADAPTIVE_MODE}, 0.375)
ADAPTIVE = AdaptiveResult({**META, "tag": "seqslam"}, (2, 4), 57, None, (FIXED_ROW, RULE_ROW),
                          {"paper": "L4+pred"}, ("no validation split: no adaptive_uniqueness",))
ADAPTIVE_TIMING = AdaptiveTiming({**META, "tag": "seqslam"}, 60, 57, 0.5, 1.25)
REFUSED_TIMING = AdaptiveTiming(META, 60, 0, None, None, "openseqslam: its window is centred")

RECIPE = Recipe("train", {"settings": '{"max_iter": 10000}', "layout": "5"}, {"data/lists/a.txt": "ab" * 32})
RECIPES = Recipes({"predictors/d/L4.h5": RECIPE, "tables/table1.csv": Recipe("report", {}, {})})

# method §16: the rules' records, the deployment experiment's, the threshold file and what deploy writes
CALIBRATION = Calibration("guaranteed", 0.9, 0.1, 1.25, 200, 90, 4)
REALISED = Realised(300, 120, 10, 11 / 12, 110 / 300, 0.4, Interval(0.85, 0.97), Interval(0.3, 0.42))
NOTHING_REALISED = Realised(300, 0, 0, None, 0.0, 0.0)
SEGMENTS = Segments(100, 3, 2, 1)
DEPLOYMENT_ROW = DeploymentRow("seqslam", "predictor", 0, "guaranteed", 0.9, 0.1, CALIBRATION, "test", REALISED,
                               REALISED, 0.0, SEGMENTS, "held")
DEPLOYMENT = DeploymentResult({"dataset": "d", "method": "sad", "seq_len": 4}, (DEPLOYMENT_ROW,),
                              (RiskCoverage("seqslam", "uniqueness", (0.1, 1.0), (0.0, 0.2), (math.inf, 1.0),
                                            (Chosen("empirical", 0.9, math.inf), Chosen("guaranteed", 0.95, None))),),
                              ("seqslam: a note",))
THRESHOLD_FILE = ThresholdFile("uniqueness", "sad", "seqslam (velocities [1.0])", 4, None, "guaranteed", 0.9, 0.1,
                               1.25, "val", 200, 90, 4, "ab" * 32, "0.18.0", {"r_window": 10, "spread_k": 10}).seal()
DEPLOYED = Deployed(np.array([True]), REALISED, "held", SEGMENTS)  # assert_same compares one-element arrays
DEPLOYED_SPLIT = DeployedSplit(THRESHOLD_FILE, "test", 300, 120, True, REALISED, "held", SEGMENTS)

SAMPLES = {
    "Recipe": RECIPE, "Recipes": RECIPES, "ThreadPool": POOL, "NumericEnvironment": ENVIRONMENT,
    "PRCurve": CURVE, "Reduction": REDUCTION, "RemovalCurves": CURVES, "TrustNumbers": TRUST, "ModeRemoval": MODE,
    "ModeRemoval, bare": BARE_MODE, "SeedNumbers": SEED, "SeedSummary": SUMMARY, "SeedSummary, undefined": NO_SUMMARY,
    "RestorationMode": RESTORED, "RestorationMode, curves": RESTORED_CURVES, "RestorationNumbers": RESTORATION,
    "EvaluationSplit": SPLIT, "EvaluationSplit, bare": BARE_SPLIT, "Evaluation": EVALUATION,
    "SplitTiming": SPLIT_TIMING, "Timing": TIMING, "HeldOutScores": HELD_OUT_SCORES,
    "HeldOutPredictors": HELD_OUT_PREDICTORS, "HeldOut": HELD_OUT, "MatcherMetrics": MATCHER,
    "SplitMetrics": SPLIT_METRICS,
    "VPRMetrics": METRICS, "SplitScores": SPLIT_SCORES, "SeedReport": SEED_REPORT,
    "PredictorReport": PREDICTOR, "PredictorReport, one seed": ONE_SEED, "AttributeScores": ATTRIBUTE_SCORES,
    "AttributeSplit": ATTRIBUTE_SCORES.splits["check"],
    "AttributeAblation": ABLATION, "FrameRange": FRAMES, "FrameRange, aligned": FrameRange("d", "test", 40, 80),
    "MatrixPrint": MatrixPrint("ab" * 32, (5, 7), 2, (3, 2**64 - 1)),
    "Training": Training(4, ("sad",), (FRAMES,), (MatrixPrint("cd" * 32, (9, 9), 1, ()),)),
    "Training, unknown length": Training(),
    "SpeedScores": SPEED_SCORES, "SpeedMatcher": SPEED_MATCHER, "SpeedResult": SPEED,
    "Matching": Matching(seqslam(0.5, 1.0, 2.0), POSITIONS), "Matching, fixed": Matching(),
    "Detection": DETECTION, "Detection, undefined": NO_DETECTION, "ScorerRemoval": SCORER_REMOVAL,
    "BudgetRemoval": BUDGET, "SplitBaselines": SPLIT_BASELINES, "SplitBaselines, no predictor": NO_BUDGET,
    "Baselines": BASELINES, "SplitMetrics, sweep and baselines": WITH_BASELINES, "SweepPoint": SWEEP_POINT,
    "ProtocolSweep": SWEEP, "Interval": SPREAD, "Versus": VERSUS, "ScorerRemoval, intervals": SCORER_REMOVAL_CI,
    "NumericEnvironment, no OpenCV": NO_OPENCV, "MatcherMode": MATCHER_MODE,
    "MatcherMode, undefined": BARE_MATCHER_MODE,
    "MatcherScores": MATCHER_SCORES, "MatcherComparison": COMPARISON,
    "AdaptiveMode": ADAPTIVE_MODE, "AdaptiveRow": FIXED_ROW, "AdaptiveRow, rule": RULE_ROW, "AdaptiveResult": ADAPTIVE,
    "AdaptiveTiming": ADAPTIVE_TIMING, "AdaptiveTiming, refused": REFUSED_TIMING,
    "Calibration": CALIBRATION, "Calibration, abstains": Calibration("empirical", 1.0, None, None, 5, 0, 0),
    "Realised": REALISED, "Realised, nothing accepted": NOTHING_REALISED, "Segments": SEGMENTS,
    "DeploymentRow": DEPLOYMENT_ROW, "DeploymentResult": DEPLOYMENT, "Chosen": DEPLOYMENT.curves[0].chosen[0],
    "RiskCoverage": DEPLOYMENT.curves[0], "ThresholdFile": THRESHOLD_FILE, "Deployed": DEPLOYED,
    "Deployed, unlabelled": Deployed(np.array([False])), "DeployedSplit": DEPLOYED_SPLIT,
}


def assert_same(read, written, where="record"):
    """``read`` is ``written``: the same types all the way down (tuples stay tuples, int keys ints) and the same
    values, NaN equal to NaN (a mapping's keys in any order: a file's are sorted)."""
    assert type(read) is type(written), f"{where}: {type(read).__name__} read, {type(written).__name__} written"
    if dataclasses.is_dataclass(written):
        for f in dataclasses.fields(written):
            assert_same(getattr(read, f.name), getattr(written, f.name), f"{where}.{f.name}")
    elif isinstance(written, tuple | list):
        assert len(read) == len(written), where
        for i, (a, b) in enumerate(zip(read, written, strict=True)):
            assert_same(a, b, f"{where}[{i}]")
    elif isinstance(written, dict):  # in any order: a file's keys are sorted
        assert set(read) == set(written), where
        for key in written:
            assert_same(read[key], written[key], f"{where}.{key}")
    elif isinstance(written, float) and math.isnan(written):
        assert math.isnan(read), where
    else:
        assert read == written, where


def _subclasses(cls):
    for sub in cls.__subclasses__():
        yield sub
        yield from _subclasses(sub)


def test_every_record_type_has_a_sample():
    record_types = {cls for cls in _subclasses(Record) if dataclasses.is_dataclass(cls)}
    assert record_types == {type(record) for record in SAMPLES.values()}


@pytest.mark.parametrize("name", list(SAMPLES))
def test_a_record_survives_the_round_trip_through_a_file(name, tmp_path):
    record = SAMPLES[name]
    assert_same(type(record).from_json(record.to_json()), record)
    write_json(tmp_path / "r.json", record.to_json())  # as a stage writes it: NaN and Infinity, keys sorted
    text = (tmp_path / "r.json").read_text()
    read = type(record).from_json(json.loads(text))
    assert_same(read, record)
    write_json(tmp_path / "again.json", read.to_json())
    assert (tmp_path / "again.json").read_text() == text  # byte for byte


def test_the_layout_is_the_fields():
    data = json.loads(json.dumps(EVALUATION.to_json()))
    assert data["format"] == FORMAT and list(data) == ["format", "meta", "predictors", "splits"]
    test, val = data["splits"]["test"], data["splits"]["val"]
    # a field that defaults to None is absent while None; any other None is null
    assert "restoration" not in val and "curves" not in test["modes"]["standard"]
    assert test["modes"]["standard"]["reduction"]["reduction_pct"] is None
    assert test["restoration"]["modes"]["paper"]["reduction_pct"] is None
    assert "curve_vpr_sm" not in test["restoration"]["modes"]["paper"]
    # an embedded record is its own object; int keys are their decimal text; tuples are lists
    # (its aoc_difference_ci, None for an outcome that is not from zero, is absent)
    assert test["modes"]["paper"]["reduction"] == {key: value for key, value in dataclasses.asdict(REDUCTION_CI).items()
                                                   if key != "aoc_difference_ci"}
    assert test["modes"]["paper"]["reduction"]["reduction_pct_ci"] == {"low": -2.5, "high": 61.0}
    # an interval that is None is absent: the other seeds' numbers have none
    assert test["other_seeds"][0]["modes"]["paper"] == {
        key: value for key, value in dataclasses.asdict(REDUCTION).items() if not key.endswith("_ci")}
    assert "reduction_pct_ci" not in test["modes"]["standard"]["reduction"]
    assert test["seed_summary"]["paper"]["outcomes"] == {"0": "improved", "3": "worse", "12": "nothing_to_reduce"}
    assert test["confusion_matrix"][3] == [1, 0, 0, 9] and test["seed"] == 0 and len(test["other_seeds"]) == 1
    assert SPEED.to_json()["speed"] is None and SPEED.to_json()["matchers"]["fixed"]["methods"]["m1"]["reduction"][
        "outcome"] == "nothing_to_reduce"
    assert FRAMES.to_json() == {"dataset": "d", "split": "train", "lo": 0, "hi": 40, "reference": [5, 50]}
    assert "reference" not in FrameRange("d", "test", 0, 4).to_json()
    # only a whole file's record says its format
    assert "format" not in SPLIT.to_json() and "format" not in SEED_REPORT.to_json()


def test_the_first_seed_is_written_once():
    data = json.loads(json.dumps(PREDICTOR.to_json()))
    assert set(data) == {"format", "meta", "n_train", "seeds", "seed_models"}
    assert PREDICTOR.first_seed()["f1_check"] == 0.4 and PREDICTOR.first_seed()["n_final"] == 20
    assert [seed.seed for seed in SPLIT.seeds] == [0, 3]
    assert SPLIT.seeds[0] == SeedNumbers(0, SPLIT.f1_macro, SPLIT.removed, {"paper": REDUCTION_CI,
                                                                            "standard": UNDEFINED_CI})


def test_numpy_values_are_written_as_python_numbers():
    record = Reduction(np.float64(0.5), np.float32(0.25), 0.5, np.float64(NAN), 0.0, None, 1.0, 0.0, "improved")
    data = encode(record)
    assert type(data["max_recall"]) is float and data["auc_vpr_sm"] == 0.25 and type(data["auc_vpr_sm"]) is float
    assert encode({np.int64(3): np.arange(3)}) == {"3": [0, 1, 2]}
    assert json.dumps(data["aoc_vpr_sm"]) == "NaN"


def test_an_int_where_a_float_is_declared_reads_as_that_float():
    data = {**dataclasses.asdict(REDUCTION), "max_recall": 1, "aoc_vpr_sm": 0}
    read = Reduction.from_json(data)
    assert type(read.max_recall) is float and read.max_recall == 1.0 and read.aoc_vpr_sm == 0.0


def test_bad_data_is_refused_naming_the_entry():
    data = json.loads(json.dumps(EVALUATION.to_json()))
    del data["splits"]["test"]["modes"]["paper"]["reduction"]["outcome"]
    with pytest.raises(MissingEntry, match=r"splits\.test\.modes\.paper\.reduction\.outcome"):
        Evaluation.from_json(data)
    data = json.loads(json.dumps(EVALUATION.to_json()))
    data["splits"]["test"]["seeds"] = []  # the layout of an earlier version
    with pytest.raises(ValueError, match=r"splits\.test: unexpected entries 'seeds'"):
        Evaluation.from_json(data)
    data = json.loads(json.dumps(EVALUATION.to_json()))
    data["splits"]["test"]["other_seeds"][0]["removed"] = "7"
    with pytest.raises(TypeError, match=r"splits\.test\.other_seeds\[0\]\.removed: an integer expected"):
        Evaluation.from_json(data)
    data = json.loads(json.dumps(EVALUATION.to_json()))
    data["splits"]["test"]["seed_summary"]["paper"]["outcomes"]["first"] = "improved"
    with pytest.raises(ValueError, match="an integer key expected, found 'first'"):
        Evaluation.from_json(data)
    with pytest.raises(TypeError, match=r"recall_at_100p: a number expected, found NoneType None"):
        MatcherMetrics.from_json({**MATCHER.to_json(), "recall_at_100p": None})
    with pytest.raises(ValueError, match="2 items expected, found 3"):
        decode(tuple[int, int], [1, 2, 3], "pair")


def test_a_file_of_another_format_is_refused_naming_the_file(tmp_path):
    path = tmp_path / "L4.json"
    save(path, EVALUATION)
    assert_same(load(path, Evaluation), EVALUATION)
    for found, said in ((FORMAT - 1, f"written in results format {FORMAT - 1}"), (None, "records no results format"),
                        ("3x", "written in results format '3x'")):
        data = EVALUATION.to_json()
        if found is None:
            del data["format"]
        else:
            data["format"] = found
        write_json(path, data)
        with pytest.raises(FormatError, match="compute it again") as error:
            load(path, Evaluation)
        assert str(error.value).startswith(f"{path}: ") and said in str(error.value)
        assert f"reads results format {FORMAT}" in str(error.value)
        with pytest.raises(FormatError, match=said):
            Evaluation.from_json(data)
    with pytest.raises(ValueError, match=f"{path}: not a JSON file"):
        path.write_text("{")
        load(path, Evaluation)


@pytest.mark.parametrize("record", [EVALUATION, TIMING, HELD_OUT, METRICS, PREDICTOR, ABLATION, SPEED],
                         ids=lambda record: type(record).__name__)
def test_every_file_record_checks_its_format(record):
    assert isinstance(record, FileRecord)
    data = {**record.to_json(), "format": FORMAT + 1}
    with pytest.raises(FormatError, match=f"written in results format {FORMAT + 1}"):
        type(record).from_json(data)


def test_the_report_names_a_file_of_another_format(tmp_path):
    from vpr_smr.eval.report.build import ReportOptions, RunFiles, write

    old = tmp_path / "e.json"
    write_json(old, {**EVALUATION.to_json(), "format": FORMAT - 1})
    with pytest.raises(FormatError, match=f"{old}: an evaluation file written in results format {FORMAT - 1}.*"
                                          "compute it again"):
        write(tmp_path / "run", RunFiles([old]), ReportOptions(html=False))


def test_a_predictor_of_another_format_says_to_train_it_again(tmp_path):
    path = tmp_path / "p.h5"
    with h5py.File(path, "w") as f:  # the frame ranges as an earlier version wrote them: a list each
        f.attrs[TRAINED_ON] = json.dumps([["d", "train", 0, 40]])
    with pytest.raises(ValueError, match=f"{path}: its {TRAINED_ON} are not in results format {FORMAT}.*train it "
                                         "again"):
        trained_on(path)
    with h5py.File(path, "w") as f:
        f.attrs[TRAINED_ON] = json.dumps([FRAMES.to_json()])
    assert trained_on(path) == [FRAMES]
