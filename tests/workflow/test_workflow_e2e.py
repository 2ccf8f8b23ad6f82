"""The real workflow (Snakemake calling our CLI) on a slice of the shipped Nordland sample, every experiment on.

Checks that every table and figure exists and that they agree with each other and with values worked out here:
the L = 4 rows of the sequence-length ablation are Table I's, leave-one-method-out trained on exactly the other
methods' train queries, SAD's recall@1 equals a from-scratch computation.
"""

import csv
import json
import subprocess
import sys

import cv2
import numpy as np
import pytest

from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT

pytestmark = pytest.mark.slow

FRAMES = (1000, 1360)  # 360 frames: train 0-150, val 150-250, test 250-360 of the slice
CONFIG = f"""
run: e2e
output: {{out}}
seq_lens: [3, 4]
seeds: 2
trust_levels: [0.0, 0.5]
datasets:
  sample:
    loader: nordland_sample
    root: {DEFAULT_ROOT}
    frames: [{FRAMES[0]}, {FRAMES[1]}]
    splits: {{train: [0, 150], val: [150, 250], test: [250, 360]}}
methods:
  sad: {{backend: sad}}
  hog: {{backend: hog}}
  effnet: {{backend: efficientnet_lite0_gem, checkpoint: package, image_size: [64, 128]}}
predictor: {{max_iter: 300}}
speed: {{profiles: [1.0, 2.0, varying]}}  # three of the default seven: the aligned pair, the fastest, the varying
experiments: {{matchers: false}}  # tests/workflow/test_plugin_matcher_workflow.py runs the matchers experiment
"""


def naive_sad_recall(lo, hi, seq_len):
    """Single-frame R@1 of SAD on frames lo..hi-1 of the sample, computed from scratch (tolerance 2)."""
    def descriptor(path):
        grey = cv2.cvtColor(cv2.imread(str(path)), cv2.COLOR_BGR2GRAY).astype(np.float64)
        out = np.zeros_like(grey)
        for y in range(0, 32, 8):
            for x in range(0, 64, 8):
                patch = grey[y:y + 8, x:x + 8]
                out[y:y + 8, x:x + 8] = 0 if patch.std() == 0 else (patch - patch.mean()) / patch.std()
        return out.ravel()

    names = sorted(p.name for p in (DEFAULT_ROOT / "summer").iterdir())[lo:hi]
    ref = np.array([descriptor(DEFAULT_ROOT / "summer" / n) for n in names])
    qry = np.array([descriptor(DEFAULT_ROOT / "winter" / n) for n in names])
    hits = [abs(int(np.argmin(np.abs(ref - qry[q]).mean(axis=1))) - q) <= 2 for q in range(seq_len - 1, len(names))]
    return float(np.mean(hits))


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("e2e")
    config = tmp / "e2e.yaml"
    config.write_text(CONFIG.replace("{out}", str(tmp / "results")))
    result = subprocess.run([sys.executable, "-m", "vpr_smr.pipeline", "run", str(config), "--cores", "2"],
                            cwd=tmp, capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    return tmp / "results" / "e2e", result.stdout


TABLES = ["table1", "predictor_methods", "predictor_confusion", "trust_levels", "restoration", "timing",
          "ablation_seq_len", "vpr_metrics", "predictor", "table2", "leave_one_method_out", "datasets", "speed",
          "baselines", "wrong_match_detection", "protocol_sweep", "adaptive_seq_len", "deployment"]
METHODS = ("sad", "hog", "effnet")


def table(out, name):
    return list(csv.DictReader(open(out / "tables" / f"{name}.csv")))


def test_every_table_and_figure(run):
    out, stdout = run
    assert f"tables:  {out / 'tables'}" in stdout and f"report:  {out / 'report.html'}" in stdout
    assert sorted(p.name for p in (out / "tables").iterdir()) == sorted(
        f"{name}.{ext}" for name in TABLES for ext in ("csv", "md", "tex"))
    per_mode = [f"{kind}_sample_L4_{mode}.png" for kind in ("pr", "trust", "restoration", "restoration_auc",
                                                            "baselines", "protocol_sweep")
                for mode in ("paper", "standard")]
    inspector = [f"{kind}_sample_{method}_L4.png" for kind in ("matches", "distance_matrix") for method in METHODS]
    assert sorted(p.name for p in (out / "figures").iterdir()) == sorted(
        [*per_mode, "confusion_sample_L4.png", "seq_len_sample_paper.png", "seq_len_sample_standard.png",
         "speed_sample_L4.png", "detection_sample_L4.png", "adaptive_sample_paper.png",
         "adaptive_sample_standard.png", "deployment_sample_L4.png", *inspector])
    html = (out / "report.html").read_text()  # the report's figures and the match inspector's, each once
    assert html.count("<img") == 20 + len(inspector) and "http://" not in html and "https://" not in html


def test_table1_has_the_seed_spread(run):
    out, _ = run
    rows = table(out, "table1")
    # each AOC and the reduction with its interval's bounds beside it; the ground truth last
    assert list(rows[0]) == ["dataset", "method", "seq_len", "mode", "recall_at_1_single", "recall_at_1_sequence",
                             "max_recall", "aoc_vpr_sm", "aoc_vpr_sm_ci_low", "aoc_vpr_sm_ci_high", "aoc_vpr_sm_pred",
                             "aoc_vpr_sm_pred_ci_low", "aoc_vpr_sm_pred_ci_high", "reduction_pct",
                             "reduction_pct_ci_low", "reduction_pct_ci_high", "aoc_difference_ci_low",
                             "aoc_difference_ci_high", "reduction_pct_mean",
                             "reduction_pct_std", "reduction_pct_min", "reduction_pct_max", "n_seeds", "n_queries",
                             "n_queries_single", "n_seeds_defined", "outcome", "removed", "max_recall_vpr_sm",
                             "aoc_vpr_sm_own", "seeds_left_out", "correct_matches"]
    assert {(r["method"], r["seq_len"], r["mode"]) for r in rows} == {
        (m, "4", mode) for m in METHODS for mode in ("paper", "standard")}
    for r in rows:
        aoc_base, aoc_pred, max_recall = float(r["aoc_vpr_sm"]), float(r["aoc_vpr_sm_pred"]), float(r["max_recall"])
        assert 0 <= aoc_base <= max_recall <= 1 and 0 <= aoc_pred <= max_recall
        if aoc_base > 0:  # a method whose baseline curve is perfect has nothing to reduce
            assert float(r["reduction_pct"]) == pytest.approx(100 * (aoc_base - aoc_pred) / aoc_base)
            low, high = float(r["reduction_pct_min"]), float(r["reduction_pct_max"])
            assert low <= float(r["reduction_pct"]) <= high and low <= float(r["reduction_pct_mean"]) <= high
        else:  # undefined: an empty cell, not 0
            assert r["reduction_pct"] == ""
        # the test split is frames 250-359 of the slice: 110 queries, 110 - 4 + 1 = 107 with a sequence match;
        # paper mode's single-frame recall@1 is over all 110
        assert r["n_queries"] == "107" and r["n_queries_single"] == ("110" if r["mode"] == "paper" else "107")
    md = (out / "tables" / "table1.md").read_text()
    assert "| sample | VPR+SM |" in md and " ± " in md and "(2 seeds)" in md
    assert r"\begin{tabular}" in (out / "tables" / "table1.tex").read_text()


def test_tables_agree_with_each_other(run):
    out, _ = run
    table1 = {(r["method"], r["mode"]): r for r in table(out, "table1")}
    ablation = table(out, "ablation_seq_len")
    assert {(r["method"], r["seq_len"]) for r in ablation} == {(m, s) for m in METHODS for s in ("3", "4")}
    for r in ablation:
        if r["seq_len"] == "4":
            assert {k: r[k] for k in table1[r["method"], r["mode"]]} == table1[r["method"], r["mode"]]
    trust = {(r["method"], r["mode"], r["trust"]): r for r in table(out, "trust_levels") if r["seq_len"] == "4"}
    restoration = {(r["method"], r["mode"]): r for r in table(out, "restoration") if r["seq_len"] == "4"}
    for (method, mode), r in table1.items():
        # trust 0 removes every match predicted unreceptive: the same curve as Table I's VPR+SM+Pred
        assert float(trust[method, mode, "0.0"]["aoc"]) == pytest.approx(float(r["aoc_vpr_sm_pred"]))
    for r in ablation:
        if r["seq_len"] == "4":  # restoration starts from the same removal as Table I's VPR+SM+Pred
            removal = restoration[r["method"], r["mode"]]["auc_removal"]
            assert float(removal) == pytest.approx(float(r["auc_vpr_sm_pred"]))
    table2 = table(out, "table2")
    assert [r["attributes"] for r in table2] == ["A1", "A2", "A3", "A4", "all"]
    assert all(0 < float(r[k]) <= 1 for r in table2 for k in ("f1_cv", "f1_val", "f1_test"))
    predictor = table(out, "predictor")
    assert [(p["dataset"], p["seq_len"]) for p in predictor] == [("sample", "3"), ("sample", "4")]
    assert all(0 < float(p[k]) <= 1 for p in predictor for k in ("f1_cv", "f1_val", "f1_test"))
    # every method's train split (frames 0-149) has 150 - 4 + 1 = 147 queries with a sequence match at L = 4
    assert next(p for p in predictor if p["seq_len"] == "4")["n_train"] == str(3 * 147)
    # the speed experiment's aligned profile with the fixed matcher is Table I (its seed-0 predictor, paper mode)
    speed = {(r["method"], r["profile"], r["matcher"]): r for r in table(out, "speed")}
    assert {(m, p) for m, p, _ in speed} == {(m, p) for m in METHODS for p in ("1x", "2x", "varying")}
    for method in METHODS:
        row, paper = speed[method, "1x", "fixed"], table1[method, "paper"]
        assert {k: row[k] for k in ("recall_at_1_single", "recall_at_1_sequence", "max_recall", "aoc_vpr_sm",
                                    "aoc_vpr_sm_pred", "reduction_pct", "n_queries", "n_queries_single")} == {
            k: paper[k] for k in ("recall_at_1_single", "recall_at_1_sequence", "max_recall", "aoc_vpr_sm",
                                  "aoc_vpr_sm_pred", "reduction_pct", "n_queries", "n_queries_single")}
        # 2x: the test split's 110 frames driven twice as fast are 55 queries, 52 with a sequence match
        assert speed[method, "2x", "velocity"]["n_queries"] == "52"


def test_the_adaptive_sequence_length_agrees_with_table1(run):
    """L_m = 4 is Table I's L: on the same queries (a >= 3), the adaptive experiment's longest fixed length is Table
    I's VPR+SM, and with its predictor Table I's VPR+SM+Pred (standard mode: a score per frame ranks as the sum)."""
    out, _ = run
    table1 = {(r["method"], r["mode"]): r for r in table(out, "table1")}
    rows = {(r["method"], r["mode"], r["name"]): r for r in table(out, "adaptive_seq_len")}
    names = ("L3", "L4", "L3+pred", "L4+pred", "adaptive", "adaptive_fallback", "adaptive_uniqueness")
    assert set(rows) == {(m, mode, n) for m in METHODS for mode in ("paper", "standard") for n in names}
    for method in METHODS:
        first = table1[method, "standard"]
        longest, predicted = rows[method, "standard", "L4"], rows[method, "standard", "L4+pred"]
        assert longest["n_queries"] == first["n_queries"] == "107" and longest["matcher"] == "seqslam"
        assert float(longest["max_recall"]) == pytest.approx(float(first["recall_at_1_sequence"]), abs=1e-12)
        assert float(predicted["aoc"]) == pytest.approx(float(first["aoc_vpr_sm_pred"]), abs=1e-12)
        assert predicted["removed"] == first["removed"]
        if first["reduction_pct"]:
            assert float(predicted["reduction_pct"]) == pytest.approx(float(first["reduction_pct"]), rel=1e-9)
        adaptive = rows[method, "standard", "adaptive"]
        assert 3 <= float(adaptive["mean_length"]) <= 4
        counts = dict(item.split(": ") for item in adaptive["lengths"].split(", "))
        assert sum(map(int, counts.values())) == 107 and int(counts.get("none", 0)) == int(adaptive["removed"])
    timing = json.loads((out / "adaptive" / "sample" / "seqslam" / "hog.timing.json").read_text())
    assert timing["n_queries"] == 107 and timing["seconds_adaptive"] > 0 and timing["seconds_longest"] > 0
    html = (out / "report.html").read_text()
    assert "Choosing the sequence length per query" in html and "method-matcher pair" in html


def test_the_baselines_agree_with_table1_and_the_per_query_table(run):
    out, _ = run
    table1 = {(r["method"], r["mode"]): r for r in table(out, "table1")}
    rows = table(out, "baselines")
    assert {(r["method"], r["mode"], r["scorer"]) for r in rows} == {
        (m, mode, s) for m in METHODS for mode in ("paper", "standard")
        for s in ("uniqueness", "single_uniqueness", "spread", "distance", "native", "random", "oracle", "predictor")}
    for r in rows:
        paper = table1[r["method"], r["mode"]]
        # every scorer removes as many matches as the seed-0 predictor (the oracle at most every wrong one)
        assert r["budget"] == paper["removed"] and int(r["removed"]) <= int(r["budget"])
        if r["scorer"] == "predictor":  # the predictor's own removal: Table I's numbers
            assert {k: r[k] for k in ("max_recall", "aoc_vpr_sm", "reduction_pct", "outcome")} == {
                k: paper[k] for k in ("max_recall", "aoc_vpr_sm", "reduction_pct", "outcome")}
            assert r["aoc"] == paper["aoc_vpr_sm_pred"] and r["reduction_pct_mean"] == paper["reduction_pct_mean"]
        if r["scorer"] == "oracle" and r["reduction_pct"]:
            assert float(r["reduction_pct"]) >= 0  # removing wrong matches never makes the curve worse
        if r["scorer"] == "distance" and r["mode"] == "standard" and r["reduction_pct"]:
            assert float(r["reduction_pct"]) == pytest.approx(0, abs=1e-9)  # a threshold on m_a: nothing new
    detection = {(r["method"], r["scorer"]): r for r in table(out, "wrong_match_detection")}
    for method in METHODS:  # the oracle finds every wrong match first; with none there is nothing to detect
        oracle = detection[method, "oracle"]
        assert oracle["average_precision"] == ("1.0" if oracle["n_wrong"] != "0" else "")
    # the sequence-length ablation names the best training-free scorer at every L beside the predictor, none where
    # no training-free reduction is defined (a perfect VPR+SM: nothing to reduce)
    for r in table(out, "ablation_seq_len"):
        scorers = ("uniqueness", "single_uniqueness", "spread", "distance", "native", "random")
        assert r["best_scorer"] in scorers or (r["best_scorer"] == r["best_scorer_reduction_pct"] == ""
                                               and r["outcome"] == "nothing_to_reduce"), r
    queries = list(csv.DictReader(open(out / "queries" / "sample" / "hog" / "L4.csv")))
    assert all(r["c_oracle"] == ("1.0" if r["sequence_correct"] == "1" else "0.0") for r in queries)
    assert all(float(r["c_distance"]) == -float(r["sequence_distance"]) for r in queries)
    assert all(r["c_native"] == r["c_uniqueness"] for r in queries)  # seqslam's native confidence: its uniqueness
    html = (out / "report.html").read_text()
    assert "the predictor beats the best training-free scorer (" in html


def test_leave_one_method_out_never_saw_the_method(run):
    out, _ = run
    rows = table(out, "leave_one_method_out")
    assert {(r["held_out"], r["mode"]) for r in rows} == {(m, mode) for m in METHODS for mode in ("paper", "standard")}
    table1 = {(r["method"], r["mode"]): r for r in table(out, "table1")}
    for r in rows:
        report = json.loads((out / "predictors" / "sample" / "L4" / f"without_{r['held_out']}.json").read_text())
        assert report["meta"]["trained_on"] == [m for m in METHODS if m != r["held_out"]]
        assert report["n_train"] == 2 * 147
        assert r["n_queries"] == str(110 - 4 + 1)  # the held-out method's test split
        assert float(r["aoc_pooled"]) == pytest.approx(float(table1[r["held_out"], r["mode"]]["aoc_vpr_sm_pred"]))


def test_sad_recall_matches_an_independent_computation(run):
    out, _ = run
    rows = list(csv.DictReader(open(out / "tables" / "table1.csv")))
    sad = {r["mode"]: r for r in rows if r["method"] == "sad" and r["seq_len"] == "4"}
    lo = FRAMES[0] + 250
    # paper mode divides by every query of the split (method §8), standard mode by those with a sequence match
    assert float(sad["paper"]["recall_at_1_single"]) == pytest.approx(naive_sad_recall(lo, FRAMES[1], 1), abs=1e-9)
    assert float(sad["standard"]["recall_at_1_single"]) == pytest.approx(naive_sad_recall(lo, FRAMES[1], 4),
                                                                         abs=1e-9)


def test_outputs_carry_provenance_and_a_rerun_does_nothing(run, tmp_path):
    import h5py

    out, _ = run
    with h5py.File(out / "descriptors" / "sample" / "effnet.h5", "r") as f:
        assert f["reference"].shape == (360, 1280) and f.attrs["method"] == "effnet"
        assert len(f.attrs["frames_sha256"]) == 64
    evaluation = json.loads((out / "evaluation" / "sample" / "hog" / "L4.json").read_text())
    assert set(evaluation["splits"]) == {"val", "test"}
    html = (out / "report.html").read_text()
    with h5py.File(out / "descriptors" / "sample" / "effnet.h5", "r") as f:
        for key in ("frames_sha256", "checkpoint_sha256"):
            assert f.attrs[key] and f.attrs[key] in html  # the report shows the provenance of its inputs
    config = out.parent.parent / "e2e.yaml"
    again = subprocess.run([sys.executable, "-m", "vpr_smr.pipeline", "run", str(config)], cwd=out.parent.parent,
                           capture_output=True, text=True, timeout=300)
    assert again.returncode == 0 and "Nothing to be done" in again.stdout + again.stderr


def test_no_predictor_was_trained_on_the_frames_it_scores(run):
    """Every predictor file of the run (pooled, every seed, leave-one-method-out) was trained on the train split
    [0, 150) of the slice only: disjoint from val [150, 250) and test [250, 360), which all scores come from."""
    from vpr_smr.eval.predictor.leakage import FrameRange, trained_on

    out, _ = run
    files = sorted((out / "predictors" / "sample").rglob("*.h5"))
    assert len(files) == 2 * 2 + 3  # L3, L4 x seeds 0, 1; without_<m> at L4
    for path in files:
        assert trained_on(path) == [FrameRange("sample", "train", 0, 150)], path
    attributes = sorted((out / "attributes" / "sample").rglob("*.h5"))
    assert attributes  # the attributes stage's folder
    for path in attributes:
        from vpr_smr.eval.predictor.leakage import frame_range

        split = frame_range(path)
        assert split.split == path.stem
        assert (split.lo, split.hi) == {"train": (0, 150), "val": (150, 250), "test": (250, 360)}[path.stem]
