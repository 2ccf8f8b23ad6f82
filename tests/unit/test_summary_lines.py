"""Every command that writes a file ends with one line saying what, where and its headline number, a direction
word only where its interval earns it: compare-matchers and adaptive on hand-made records, ablation held-out,
ablation attributes and speed run on small data."""

import json
import warnings

import numpy as np
import pytest
from report_runs import adaptive_result, matchers_records

from vpr_smr.core.records import load
from vpr_smr.eval.matching.attributes import Matching, query_features, write_features
from vpr_smr.eval.predictor.estimator import SMRPredictor
from vpr_smr.eval.predictor.records import AttributeAblation
from vpr_smr.eval.scoring.records import HeldOut
from vpr_smr.eval.scoring.speed import SpeedResult
from vpr_smr.pipeline.cli import main
from vpr_smr.pipeline.stages.studies import lowest_rule, matchers_headline


def _wrote(caplog, out):
    (line,) = [r.getMessage() for r in caplog.records if r.getMessage().startswith("wrote ")
               and str(out) in r.getMessage()]
    return line


def _word(reduction):
    """The word a reduction's interval earns, by hand: a direction only where it excludes 0 on its sign's side."""
    low, high = reduction["reduction_pct_ci"]["low"], reduction["reduction_pct_ci"]["high"]
    pct = reduction["reduction_pct"]
    if pct == low == high == 0 and reduction["aoc_vpr_sm_pred"] == reduction["aoc_vpr_sm"]:
        return "kept every match"  # the predictor removed nothing: named, not a 0 % without a word
    if low > 0 and pct > 0:
        return "improved"
    if high < 0 and pct < 0:
        return "worse"
    return "holds 0" if low <= 0 <= high else "no direction"


def test_compare_matchers_counts_the_pairs_whose_interval_lies_above_0():
    sad, hog = matchers_records(modes=("paper", "standard"))
    # sad: seqslam 20 [5, 30] above 0, bayes_filter 3 [-2, 8] above 0 by its estimate but holding 0;
    # hog: seqslam 10 [2, 15] above 0, bayes_filter -6 [-9, -1] below 0
    for record in (sad, hog):
        assert matchers_headline(record, ("paper", "standard")) == (
            "the seed-0 predictor reduces the AOC, its interval above 0, for 1 of 2 matcher-method pairs (paper "
            "mode), 1 of 2 matcher-method pairs (standard mode)")


def test_adaptive_names_the_rule_of_lowest_aoc_with_its_interval():
    # rules' AOCs 0.05 (adaptive), 0.07, 0.30, each +- 0.02; adaptive minus L4+pred's in [-0.05, -0.01], mean -0.03
    assert lowest_rule(adaptive_result("sad", modes=("paper", "standard"))) == (
        "lowest AOC of the length rules (standard mode, seed 0): adaptive 0.0500 [0.0300, 0.0700], minus the best "
        "fixed length's (L4+pred) -0.0300 [-0.0500, -0.0100]")
    only_paper = adaptive_result("sad", rules={"adaptive_fallback": (0.07, 3.0, "improved", None),
                                               "adaptive": (0.09, 2.5, "improved", None)})
    assert lowest_rule(only_paper) == (
        "lowest AOC of the length rules (paper mode, seed 0): adaptive_fallback 0.0700 [0.0500, 0.0900]")


@pytest.fixture(scope="module")
def held_out_files(tmp_path_factory):
    """A test split's attributes and two small predictors (the pooled and the without one)."""
    folder = tmp_path_factory.mktemp("held_out_line")
    rng = np.random.default_rng(4404)
    features = query_features(rng.random((60, 60)) + 0.12 * (1 - np.eye(60)), 4)  # some matches wrong
    write_features(folder / "test.h5", features, {})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for seed, name in enumerate(("pooled", "without")):
            SMRPredictor(hidden_layer_sizes=(8,), max_iter=30, random_state=seed).fit(
                features.attributes[:, 0], features.labels).save(folder / f"{name}.h5", Matching())
    return folder


def test_held_out_gives_both_reductions_with_their_intervals_and_words(held_out_files, caplog):
    folder = held_out_files
    out = folder / "h.json"
    caplog.set_level("INFO", logger="vpr_smr")
    assert main(["ablation", "held-out", "--dataset", "d", "--method", "m", "--seq-len", "4", "--attributes",
                 str(folder / "test.h5"), "--pooled", str(folder / "pooled.h5"), "--without",
                 str(folder / "without.h5"), "--modes", "standard", "--allow-split-overlap", "--out", str(out)]) == 0
    data = json.loads(out.read_text())["predictors"]
    parts = []
    for name in ("without", "pooled"):
        r = data[name]["modes"]["standard"]["reduction"]
        ci = r["reduction_pct_ci"]
        parts.append(f"{r['reduction_pct']:.2f} % [{ci['low']:.2f}, {ci['high']:.2f}] {_word(r)}")
    assert _wrote(caplog, out) == (f"wrote m's test split under the pooled and the without predictor to {out}: "
                                   f"standard mode: AOC reduction without m {parts[0]}, pooled {parts[1]}")
    assert load(out, HeldOut).n_queries > 0
    # this split's numbers (seed 4404): the without predictor's interval holds 0, the pooled one removed nothing
    assert "holds 0" in parts[0] and parts[1] == "0.00 % [0.00, 0.00] kept every match"


def test_a_held_out_reduction_whose_interval_holds_0_names_no_direction():
    from vpr_smr.eval.scoring.records import Interval, Reduction
    from vpr_smr.pipeline.stages.predictor import reduction_text as _reduction

    # 57.04 by its estimate, [-7.47, 91.65] by its interval (the numbers): no direction
    found = Reduction(0.9, 0.7, 0.8, 0.16, 0.07, 57.04, 0.9, 0.16, "improved", Interval(-7.47, 91.65))
    assert _reduction(found) == "57.04 % [-7.47, 91.65] holds 0"
    assert _reduction(Reduction(0.9, 0.7, 0.8, 0.16, 0.07, 57.04, 0.9, 0.16, "improved")) == (
        "57.04 % [n/a] no interval")


def test_ablation_attributes_gives_the_all_attributes_macro_f1(tmp_path, caplog):
    from training_sets import PARAMS, method_samples, write_samples

    paths = {name: write_samples(tmp_path / f"{name}.h5", *method_samples(n, seed))
             for name, n, seed in (("a", 48, 0), ("b", 36, 1), ("test", 24, 3))}
    out = tmp_path / "t2.json"
    caplog.set_level("INFO", logger="vpr_smr")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["ablation", "attributes", "--dataset", "d", "--seq-len", "4", "--train", str(paths["a"]),
                     str(paths["b"]), "--evaluate", "test", str(paths["test"]), "--predictor", json.dumps(PARAMS),
                     "--out", str(out)]) == 0
    every = json.loads(out.read_text())["attributes"]["all"]
    assert every["columns"] is None  # all four attributes
    assert _wrote(caplog, out) == (f"wrote the attribute ablation (Table II) to {out}: macro F1 with all four "
                                   f"attributes: cross-validated {every['f1_cv']:.3f}; test "
                                   f"{every['splits']['test']['f1']:.3f}")
    assert load(out, AttributeAblation).n_train == 84


def test_speed_gives_the_range_of_sequence_recall(tmp_path, caplog):
    from helpers import write_distance_matrix

    rng = np.random.default_rng(4405)
    files = {"train": [], "test": []}
    for method in ("a", "b"):
        whole = rng.random((120, 120)) + 0.5 * (1 - np.eye(120))
        for split, (lo, hi) in {"train": (0, 60), "test": (60, 120)}.items():
            path = tmp_path / f"{method}_{split}.h5"
            write_distance_matrix(path, whole[lo:hi, lo:hi], {"dataset": "d", "method": method, "split": split,
                                                              "split_range": [lo, hi]})
            files[split].append(f"{method}={path}")
    out = tmp_path / "s.json"
    caplog.set_level("INFO", logger="vpr_smr")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["speed", "--dataset", "d", "--seq-len", "4", "--profile", "2x", "--velocities", "1", "2",
                     "--predictor", json.dumps({"hidden_layer_sizes": [8], "max_iter": 40}),
                     "--train", *files["train"], "--test", *files["test"], "--out", str(out)]) == 0
    matchers = json.loads(out.read_text())["matchers"]
    recalls = [scores["recall_at_1_sequence"] for matcher in matchers.values() for scores in
               matcher["methods"].values()]
    assert len(matchers) == 2 and len(recalls) == 4
    assert _wrote(caplog, out) == (f"wrote the speed profile 2x to {out}: sequence recall@1 {min(recalls):.4f} to "
                                   f"{max(recalls):.4f} over 2 matchers x 2 methods (paper mode, seed 0)")
    assert load(out, SpeedResult).profile == "2x"
