"""Your own data, end to end (the evaluation side): undefined reductions, query counts in every table, the
configuration's own order in the report, --out suffixes, negative distances, LiveMatcher.from_descriptors with the
README's live example executed as written, and train splits too small for the predictor."""

import csv
import json
import shutil
import warnings
from pathlib import Path

import h5py
import numpy as np
import pytest
from helpers import doc_block, write_distance_matrix

from vpr_smr.core.io import write_json
from vpr_smr.core.records import FORMAT, load
from vpr_smr.eval.matching.attributes import Matching, QueryFeatures, query_features, write_features
from vpr_smr.eval.predictor.defaults import MIN_TRAIN_SAMPLES, training_problems
from vpr_smr.eval.predictor.estimator import SMRPredictor, fit_problem, label_problems
from vpr_smr.eval.predictor.records import (
    AttributeAblation,
    AttributeScores,
    AttributeSplit,
    PredictorReport,
    SeedReport,
)
from vpr_smr.eval.report import build as report
from vpr_smr.eval.report import registry, tabulate
from vpr_smr.eval.report.rows import cells
from vpr_smr.eval.scoring.curves import Curve, compare_curves, reduction_pct
from vpr_smr.eval.scoring.records import Evaluation
from vpr_smr.pipeline.cli import main

TINY = {"hidden_layer_sizes": [8], "max_iter": 30}


def files_in(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")}


# --- 1. a reduction whose baseline AOC is 0 is undefined --------------------------------------------------------


def test_reduction_by_hand_and_undefined_cases():
    assert reduction_pct(0.2, 0.05) == pytest.approx(75.0)  # 100 (0.2 - 0.05) / 0.2
    assert reduction_pct(0.1, 0.15) == pytest.approx(-50.0)
    assert reduction_pct(0.0, 0.0) is None
    assert reduction_pct(1.1e-16, 0.0) is None  # the trapezoid sum's rounding of a perfect curve is 0 too
    assert reduction_pct(float("nan"), 0.1) is None and reduction_pct(0.2, float("inf")) is None
    # a baseline with precision 1 everywhere: AUC = R_max, AOC 0, whatever the predictor does
    perfect = Curve(np.array([0.0, 0.25, 0.5, 1.0]), np.array([1.0, 1.0, 1.0, 1.0]))
    worse = Curve(np.array([0.0, 0.5, 1.0]), np.array([1.0, 0.5, 0.5]))
    assert compare_curves(perfect, perfect).reduction_pct is None
    assert compare_curves(perfect, worse).reduction_pct is None


def test_restoration_reduction_is_undefined_when_removal_is_perfect():
    from vpr_smr.eval.scoring.restoration import compare

    perfect = Curve(np.array([0.0, 0.5, 1.0]), np.array([1.0, 1.0, 1.0]))
    half = Curve(np.array([0.0, 1.0]), np.array([1.0, 0.5]))  # AUC 0.75, AOC 0.25
    assert compare(half, perfect, half).reduction_pct is None
    assert compare(half, half, perfect).reduction_pct == pytest.approx(100.0)  # (0.25 - 0) / 0.25


def perfect_features(n: int = 30, seq_len: int = 4) -> QueryFeatures:
    """Every single-frame and sequence match correct: the diagonal is 0, everything else 0.5 to 1."""
    matrix = 0.5 + 0.5 * np.random.default_rng(0).random((n, n))
    np.fill_diagonal(matrix, 0.0)
    return query_features(matrix, seq_len)


def small_predictor(path: Path, seed: int = 0) -> Path:
    rng = np.random.default_rng(seed)
    y = np.repeat(np.arange(4), 15)
    x = rng.normal(size=(60, 4)) + y[:, None]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        SMRPredictor(hidden_layer_sizes=(8,), max_iter=30, random_state=seed).fit(x, y).save(path, Matching())
    return path


def test_perfect_baseline_gives_null_reductions_in_the_evaluation(tmp_path, capsys):
    features = perfect_features()
    assert features.labels.tolist() == [0] * 27  # 30 - 4 + 1 queries, all correct before and after
    write_features(tmp_path / "test.h5", features, {})
    predictors = [small_predictor(tmp_path / "p.h5"), small_predictor(tmp_path / "p.seed1.h5", 1)]
    assert main(["evaluate", "--dataset", "d", "--method", "m", "--seq-len", "4", "--attributes",
                 f"test={tmp_path / 'test.h5'}", "--predictors", *map(str, predictors), "--trust-levels", "0.5",
                 "--out", str(tmp_path / "e.json")]) == 0
    text = (tmp_path / "e.json").read_text()
    result = json.loads(text)["splits"]["test"]
    seeds = load(tmp_path / "e.json", Evaluation).splits["test"].seeds
    for mode in ("paper", "standard"):
        numbers = result["modes"][mode]
        assert numbers["reduction"]["aoc_vpr_sm"] == pytest.approx(0.0, abs=1e-12)
        assert numbers["reduction"]["reduction_pct"] is None and numbers["trust_auc"]["0.5"]["reduction_pct"] is None
        assert [s.modes[mode].reduction_pct for s in seeds] == [None, None]
        # nothing to reduce, unless a seed's predictor removed every one of the 27 matches (then recall 0)
        outcomes = {str(s.seed): "removed_all" if s.removed == 27 else "nothing_to_reduce" for s in seeds}
        assert result["seed_summary"][mode] == {
            "n_seeds": 2, "n_seeds_defined": 0, "reduction_pct_mean": None, "reduction_pct_std": None,
            "reduction_pct_min": None, "reduction_pct_max": None, "outcomes": outcomes}
    assert '"reduction_pct": null' in text


def hand_evaluation(method: str, aoc_base: float, aoc_pred: float, reduction: float | None,
                    seeds: tuple[float | None, ...]) -> dict:
    """An evaluation file's numbers, written by hand: 60 queries in the test split, 57 of them matched at L = 4."""
    defined = [s for s in seeds if s is not None]

    def outcome(value: float | None) -> str:  # a baseline AOC of 0 here: nothing to reduce
        return "nothing_to_reduce" if value is None else "improved" if value > 0 else "worse"

    summary = {"n_seeds": len(seeds), "n_seeds_defined": len(defined),
               "reduction_pct_mean": float(np.mean(defined)) if defined else None,
               "reduction_pct_std": float(np.std(defined, ddof=1)) if len(defined) > 1 else None,
               "reduction_pct_min": min(defined) if defined else None,
               "reduction_pct_max": max(defined) if defined else None,
               "outcomes": {str(i): outcome(seed) for i, seed in enumerate(seeds)}}
    line = {"recall": [0.0, 1.0], "precision": [1.0, 0.5]}

    def removal(value: float | None) -> dict:
        return {"max_recall": 1.0, "auc_vpr_sm": 1 - aoc_base, "auc_vpr_sm_pred": 1 - aoc_pred, "aoc_vpr_sm": aoc_base,
                "aoc_vpr_sm_pred": aoc_pred, "reduction_pct": value, "max_recall_vpr_sm": 1.0,
                "aoc_vpr_sm_own": aoc_base, "outcome": outcome(value)}

    numbers = {"recall_at_1_single": 0.5, "recall_at_1_sequence": 0.7, "reduction": removal(reduction),
               "curves": {"curve_vpr_sm": line, "curve_vpr_sm_pred": line, "recall_at_100_precision_vpr_sm": 0.0,
                          "recall_at_100_precision_vpr_sm_pred": 0.0},
               "trust_auc": {"0.5": {"removed": 1, "max_recall": 1.0, "auc": 0.9, "aoc": 0.1, "auc_vpr_sm": 0.8,
                                     "aoc_vpr_sm": aoc_base, "reduction_pct": reduction,
                                     "outcome": outcome(reduction)}}}
    split = {"n_queries": 57, "n_queries_split": 60, "recall_at_1_single_all": 0.5, "recall_at_1_single_evaluated": 0.5,
             "recall_at_1_sequence": 0.7, "f1_macro": 0.5, "confusion_matrix": np.eye(4, dtype=int).tolist(),
             "class_counts": [1, 1, 1, 1], "predicted_counts": [1, 1, 1, 1], "removed": 1,
             "modes": {"paper": numbers}, "seed_summary": {"paper": summary},
             # seed 0's numbers are the split's own; the other seeds' apart
             "seed": 0, "other_seeds": [{"seed": i, "f1_macro": 0.5, "removed": 1, "modes": {"paper": removal(seed)}}
                                        for i, seed in enumerate(seeds) if i > 0]}
    return {"format": FORMAT, "meta": {"dataset": "d", "method": method, "seq_len": 4}, "predictors": ["p.h5"],
            "splits": {"test": split}}


@pytest.fixture
def hand_run(tmp_path):
    """Three methods, the second with a perfect baseline: reductions 10, n/a, 30 (seed-0); over 3 seeds 10, 12, 14
    (mean 12, std 2), none, and 20, 28, 36 (mean 28, std 8)."""
    evaluations = []
    for method, numbers in (("m1", (0.2, 0.18, 10.0, (10.0, 12.0, 14.0))), ("m2", (0.0, 0.0, None, (None,) * 3)),
                            ("m3", (0.4, 0.28, 30.0, (20.0, 28.0, 36.0)))):
        path = tmp_path / f"{method}.json"
        write_json(path, hand_evaluation(method, *numbers))
        evaluations.append(path)
    predictors = tmp_path / "p.json"
    seed = SeedReport(0, {}, 0.5, 10, (30, 10, 10, 7), {})  # trained without val and test splits
    write_json(predictors, PredictorReport({"dataset": "d", "seq_len": 4}, 57, (seed,)).to_json())
    return tmp_path, evaluations, predictors


def test_table1_shows_na_and_averages_the_defined_reductions_only(hand_run):
    tmp_path, evaluations, predictors = hand_run
    run = tmp_path / "run"
    report.write(run, report.RunFiles(evaluations, [predictors]))
    md = (run / "tables" / "table1.md").read_text()
    # AOCs: every method, (0.2 + 0 + 0.4) / 3; these hand-made files have no intervals: [n/a]
    assert "| d | VPR+SM | 0.2000 [n/a] | 0.0000 [n/a] | 0.4000 [n/a] | 0.2000 |  |" in md
    # (10 + 30) / 2 = 20; m1 and m3 are above 0 by their estimates but have no interval, so none is counted
    # improved (m2, nothing to reduce, is not either): 0 of the 3, 2 without an interval
    assert ("|  | Reduction (%) | 10.00 [n/a] | n/a: nothing to reduce | 30.00 [n/a] | 20.00 (mean over 2 of 3 "
            "methods: m1, m3) | 0 / 3 (2 without an interval) |") in md
    # seed means 12 ± 2 and 28 ± 8, their mean 20; m2's three seeds are left out, and why
    assert ("|  | Reduction over seeds (%) | 12.00 ± 2.00 | n/a: seeds 0, 1, 2: nothing to reduce | 28.00 ± 8.00 "
            "| 20.00 (mean over 2 of 3 methods, those with all 3 seeds: m1, m3) | no interval (3 seeds) |") in md
    assert ("m2: baseline AOC 0 up to the predictor's maximum recall 1.0000: nothing to reduce, the reduction is "
            "undefined.") in md
    assert "n/a: the reduction is undefined (why: beside it, and below)" in md
    assert "d: 57 queries with a sequence match (single-frame recall@1 over all 60 of the split)" in md
    tex = (run / "tables" / "table1.tex").read_text()
    assert r"& n/a: nothing to reduce &" in tex
    # a Mean has no interval: not coloured
    assert r"& 20.00 (mean over 2 of 3 methods: m1, m3) & 0 / 3 (2 without an interval)\\" in tex
    rows = list(csv.DictReader(open(run / "tables" / "table1.csv")))
    assert [r["reduction_pct"] for r in rows] == ["10.0", "", "30.0"]  # undefined: an empty CSV cell
    assert [r["reduction_pct_mean"] for r in rows] == ["12.0", "", "28.0"]
    assert {(r["n_queries"], r["n_queries_single"]) for r in rows} == {("57", "60")}
    trust = list(csv.DictReader(open(run / "tables" / "trust_levels.csv")))
    assert [r["reduction_pct"] for r in trust] == ["10.0", "", "30.0"] and {r["n_queries"] for r in trust} == {"57"}
    assert "| n/a | nothing_to_reduce | 57 |" in (run / "tables" / "trust_levels.md").read_text()
    html = (run / "report.html").read_text()

    def undefined(table_id, text='<td class="na">n/a</td>'):
        return html.split(f'<table id="{table_id}"')[1].split("</table>")[0].count(text)

    # m2's reduction_pct (with its outcome's reason) and its seed mean, std, min and max in Table I's CSV; its
    # reduction in the trust table
    reason = '<td class="na">n/a: nothing to reduce</td>'
    # and every row's reduction interval bounds (none in these files: 3 rows x 2 bounds)
    assert undefined("all-table1") == 4 + 6 and undefined("all-table1", reason) == 1
    assert undefined("all-trust_levels") == 0 + 6 and undefined("all-trust_levels", reason) == 1
    # the paper's layout: m2's Reduction and Reduction over seeds, each with its reason
    assert undefined("table1-d-paper-4", reason) == 1
    assert html.count('<td class="na">n/a: seeds 0, 1, 2: nothing to reduce</td>') == 1
    # Table I's whole table, the paper layout, the PR section's table, the whole trust table (no trust figure here);
    # the reason also in the first screen's verdict table
    assert undefined("verdicts-d-paper", reason) == 1
    assert html.count('<td class="na">n/a</td>') == 4 + 6 + 6 and html.count(reason) == 1 + 1 + 1 + 1 + 1


def test_leave_one_out_rows_show_na():
    from vpr_smr.eval.scoring.records import HeldOut, HeldOutPredictors, HeldOutScores, ModeRemoval, Reduction

    nothing = Reduction(1.0, 1.0, 1.0, 0.0, 0.0, None, 1.0, 0.0, "nothing_to_reduce")
    numbers = HeldOutScores("p.h5", 0.5, 3, {"paper": ModeRemoval(0.5, 0.5, nothing)})
    rows = tabulate.lomo_rows([HeldOut({"dataset": "d", "method": "m", "seq_len": 4}, 57,
                                     HeldOutPredictors(numbers, numbers))])
    text = report.markdown_table(registry.table("leave_one_method_out").names(), map(cells, rows))
    assert text.splitlines()[-1] == ("| d | 4 | m | paper | 57 | 0.5000 | 0.5000 | 3 | 3 | 0.0000 | 0.0000 | 0.0000 "
                                     "| n/a | n/a | [n/a] | [n/a] | nothing_to_reduce | nothing_to_reduce |")
    # (the intervals of the AOC difference, pooled and without: none, the outcome is not from zero)


# --- 2. every evaluation table gives the number of queries it is over ------------------------------------------


def test_query_counts_in_every_evaluation_table(tmp_path):
    from report_runs import build_run

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run, _ = build_run(tmp_path)  # two methods, a 60 x 60 test split, L = 2 and 4, both modes
    tables = run / "tables"

    def rows(name):
        return list(csv.DictReader(open(tables / f"{name}.csv")))

    # 60 - L + 1 queries have a sequence match; paper mode's single-frame recall@1 is over all 60
    for row in rows("table1") + rows("ablation_seq_len"):
        assert int(row["n_queries"]) == 60 - int(row["seq_len"]) + 1
        assert row["n_queries_single"] == ("60" if row["mode"] == "paper" else row["n_queries"])
    for name in ("trust_levels", "restoration", "predictor_methods"):
        assert {(r["seq_len"], r["n_queries"]) for r in rows(name)} <= {("2", "59"), ("4", "57")}, name
    # the existing columns keep their order, the counts come last
    assert list(rows("table1")[0])[:15] == list(registry.table("table1").names()[:15])
    assert list(rows("ablation_seq_len")[0])[23:] == ["auc_vpr_sm", "auc_vpr_sm_pred", "n_queries",
                                                     "n_queries_single", "n_seeds_defined", "outcome", "removed",
                                                     "max_recall_vpr_sm", "aoc_vpr_sm_own", "seeds_left_out",
                                                     "best_scorer", "best_scorer_reduction_pct",
                                                     registry.CORRECT_MATCHES.name]
    assert list(rows("restoration")[0])[-5:] == ["reduction_pct", "reduction_pct_ci_low", "reduction_pct_ci_high",
                                                 "n_queries", registry.CORRECT_MATCHES.name]
    assert "d: 57 queries with a sequence match (single-frame recall@1 over all 60 of the split)" in (
        tables / "table1.md").read_text()
    assert r"d: 57 queries with a sequence match" in (tables / "table1.tex").read_text()


def test_table2_gives_its_sample_counts():
    ablation = AttributeAblation({"dataset": "d", "seq_len": 4}, {}, 147, {
        name: AttributeScores(None, 0.5, {"val": AttributeSplit(0.5, 97, 0.5), "test": AttributeSplit(0.5, 107, 0.5)})
        for name in ("A1", "A2", "A3", "A4", "all")})
    rows = tabulate.table2_rows([ablation])
    assert {(r.n_train, r.n_validation["val"], r.n_last["test"]) for r in rows} == {(147, 97, 107)}
    assert "F1 over train 147 samples, validation 97 samples, test 107 samples" in tabulate.table2_markdown(rows)


# --- 3. the report shows the configuration's sections, each in its own order ------------------------------------------


def test_report_keeps_the_configurations_method_order(hand_run, capsys):
    from vpr_smr.pipeline.rule_helpers import report_settings

    tmp_path, evaluations, predictors = hand_run
    conf = {"run": "r", "seq_lens": [4], "methods": {"sad": {"backend": "sad"}, "hog": {"backend": "hog"},
                                                    "apgem": {"backend": "apgem", "checkpoint": "a.pt"}},
            "extraction": {"batch_size": 8}, "datasets": {"zeta": {"loader": "folders"}, "alpha": {}}}
    settings = report_settings(conf)  # the report rule's param
    # the sections in the schema's order (writing one out at its defaults reruns nothing), each in its own order;
    # extraction: speed only
    assert list(json.loads(settings)) == ["run", "seq_lens", "datasets", "methods"]
    run = tmp_path / "run"
    assert main(["report", "--evaluations", *map(str, evaluations), "--predictors", str(predictors),
                 "--settings", settings, "--out", str(run)]) == 0
    shown = (run / "report.html").read_text().split('id="configuration"')[1]
    positions = [shown.index(f"{name}:") for name in ("run", "seq_lens", "datasets", "zeta", "alpha", "methods",
                                                      "sad", "hog", "apgem")]
    assert positions == sorted(positions)  # sad, hog, apgem: the pooled training order, not alphabetical


# --- 4. --out suffixes and negative distances ------------------------------------------------------------------


@pytest.mark.parametrize("command, out, allowed", [
    (["attributes", "--distances", "D.npy", "--seq-len", "4"], "o.txt", ".csv, .h5 or .hdf5"),
    (["descriptors", "--dataset", "d", "--method", "m"], "d.json", ".h5 or .hdf5"),
    (["distances", "--descriptors", "d.h5", "--split", "test", "--frames", "0", "10"], "D.npy", ".h5 or .hdf5"),
    (["train", "--dataset", "d", "--seq-len", "4", "--train", "a.h5"], "L4.json", ".h5 or .hdf5"),
    (["evaluate", "--dataset", "d", "--method", "m", "--seq-len", "4", "--attributes", "test=t.h5",
      "--predictors", "L4.h5"], "L4.h5", ".json"),
    (["ablation", "attributes", "--dataset", "d", "--seq-len", "4", "--train", "a.h5"], "t2", ".json"),
    (["ablation", "without", "--dataset", "d", "--method", "m", "--seq-len", "4", "--train", "a=a.h5"],
     "w.json", ".h5 or .hdf5"),
    (["ablation", "held-out", "--dataset", "d", "--method", "m", "--seq-len", "4", "--attributes", "f.h5",
      "--pooled", "p.h5", "--without", "w.h5"], "m.csv", ".json"),
])
def test_out_suffix_is_checked_first(tmp_path, capsys, monkeypatch, command, out, allowed):
    monkeypatch.chdir(tmp_path)
    np.save("D.npy", np.ones((8, 8)))
    before = files_in(tmp_path)
    assert main([*command, "--out", out]) == 2
    err = capsys.readouterr().err.strip()
    suffix = Path(out).suffix
    given = f"got suffix {suffix!r}" if suffix else "got no suffix"
    assert err.startswith(f"vpr-smr {command[0]}: error: --out {out}: ") and f"must end in {allowed}, {given}" in err
    assert len(err.splitlines()) == 1 and files_in(tmp_path) == before  # nothing written


def test_attributes_out_accepts_csv_and_hdf5(tmp_path):
    rng = np.random.default_rng(0)
    np.save(tmp_path / "D.npy", rng.random((12, 12)))
    for name in ("a.csv", "a.h5", "a.HDF5"):
        assert main(["attributes", "--distances", str(tmp_path / "D.npy"), "--seq-len", "3",
                     "--out", str(tmp_path / name)]) == 0
    assert (tmp_path / "a.csv").read_text().startswith("query,A1,A2,A3,A4,label")
    assert h5py.is_hdf5(tmp_path / "a.h5") and h5py.is_hdf5(tmp_path / "a.HDF5")


@pytest.mark.parametrize("kind", ["npy", "h5"])
def test_negative_distances_are_refused_naming_count_minimum_and_fix(tmp_path, capsys, kind):
    matrix = np.random.default_rng(0).random((10, 10))
    matrix[2, 3], matrix[5, 5], matrix[9, 0] = -0.5, -1e-3, -2.25  # 3 negative values, the least -2.25
    path = tmp_path / f"S.{kind}"
    if kind == "npy":
        np.save(path, matrix)
    else:
        write_distance_matrix(path, matrix, {"dataset": "d"})
    out = tmp_path / "a.csv"
    assert main(["attributes", "--distances", str(path), "--seq-len", "3", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"{path}: 3 negative values in the distance matrix (minimum -2.25)" in err
    assert "D = 1 - S" in err and "D = S.max() - S" in err and "weights_only" not in err
    assert ("give --similarity (read as distances max(M) - M)" in err) == (kind == "npy")  # .npy: a user's matrix
    assert not out.exists() and not list(tmp_path.glob("*.tmp"))


def test_rounding_sized_negative_distances_pass_unchanged(tmp_path):
    """Squared L2 of identical L2-normalised descriptors is about -1e-6 in float32 (faiss, as the authors' code
    computes it): kept as it is (clamping moves Table I) and accepted by the attributes stage."""
    from vpr_smr.eval.matching.distances import distance_matrix

    x = np.random.default_rng(0).normal(size=(64, 256)).astype(np.float32)
    unit = x / np.linalg.norm(x, axis=1, keepdims=True)
    naive = {"l2": ((unit[:, None, :] - unit[None, :, :]) ** 2).sum(-1), "cosine": 1 - unit @ unit.T}
    for metric, expected in naive.items():
        d = distance_matrix(x, x, metric)
        np.testing.assert_allclose(d, expected, atol=2e-6)
        assert d.min() > -1e-5
    d = distance_matrix(x, x, "l2")
    assert (d < 0).any()  # what faiss gives: not clamped
    np.save(tmp_path / "D.npy", d)
    assert main(["attributes", "--distances", str(tmp_path / "D.npy"), "--seq-len", "3",
                 "--out", str(tmp_path / "a.csv")]) == 0


# --- 5. LiveMatcher takes its distance from the descriptor file; the README's example runs -----------------------


@pytest.fixture(scope="module")
def sad_descriptors(tmp_path_factory):
    """SAD descriptors of 100 frames of the shipped Nordland sample (descriptors.extract.main), and the pair."""
    from vpr_smr.datasets import load_dataset
    from vpr_smr.descriptors import extract

    folder = tmp_path_factory.mktemp("sad")
    pair = load_dataset("sample", {"loader": "nordland_sample", "frames": [1500, 1600],
                                   "splits": {"all": [0, 100]}})
    return extract.main(pair, "sad", {"backend": "sad"}, folder / "descriptors.h5"), pair


def test_from_descriptors_takes_the_files_distance(sad_descriptors):
    from vpr_smr.eval.matching.distances import distance_matrix
    from vpr_smr.eval.matching.live import LiveMatcher

    path, _ = sad_descriptors
    with h5py.File(path, "r") as f:
        reference, query = f["reference"][()], f["query"][()]
    matcher = LiveMatcher.from_descriptors(path, seq_len=4)
    assert matcher.distance == "mad" and matcher.method == "sad" and matcher.method_settings == {"backend": "sad"}
    batch = query_features(distance_matrix(reference, query, "mad"), 4)
    l2 = query_features(distance_matrix(reference, query, "l2"), 4)
    matches = [r.sequence_match for r in map(matcher.step, query) if r is not None]
    assert matches == batch.sequence_match.tolist()
    assert matches != l2.sequence_match.tolist()  # the default l2 of before gave other matches on these frames
    assert LiveMatcher.from_descriptors(path, seq_len=4).distance == "mad"  # SAD's, from the file
    # a run that set `distance: l2` for SAD computed its matrices with l2: the matcher follows when told
    assert LiveMatcher.from_descriptors(path, seq_len=4, distance="l2").distance == "l2"
    with pytest.raises(ValueError, match="needs distance="):
        LiveMatcher(4, references=reference)
    split = LiveMatcher.from_descriptors(path, seq_len=4, frames=(20, 60))
    assert split.references.shape == (40, reference.shape[1])


def live_example() -> str:
    return doc_block("live-example")


def test_live_example_runs_as_written(sad_descriptors, tmp_path, monkeypatch, capsys):
    from vpr_smr.eval.matching.distances import distance_matrix

    path, pair = sad_descriptors
    # the files the example names: descriptors.h5, a predictor L4.h5 and camera frames (the query traverse)
    shutil.copy(path, tmp_path / "descriptors.h5")
    with h5py.File(path, "r") as f:
        reference, query = f["reference"][()], f["query"][()]
    batch = query_features(distance_matrix(reference, query, "mad"), 4)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        predictor = SMRPredictor(hidden_layer_sizes=(16,), max_iter=200).fit(batch.attributes[:, 0], batch.labels)
    predictor.save(tmp_path / "L4.h5", Matching())  # as vpr-smr train writes it: the fixed matcher
    (tmp_path / "camera").mkdir()
    for image in pair.query.images:
        shutil.copy(image, tmp_path / "camera" / image.name)
    monkeypatch.chdir(tmp_path)
    exec(compile(live_example(), "docs/speed.md (live-example)", "exec"), {"__name__": "live_example"})
    printed = capsys.readouterr().out.splitlines()
    # what the batch computation says: the kept queries (predicted class 0 or 2) and their sequence matches
    kept = np.isin(predictor.predict(batch.attributes[:, 0]), (0, 2))
    names = [image.name for image in pair.query.images]
    expected = [f"{names[q]} is at reference frame {m}"
                for q, m, keep in zip(batch.queries, batch.sequence_match, kept, strict=True) if keep]
    assert printed == expected and len(expected) > 0


# --- 6. train splits too small for the predictor ---------------------------------------------------------------


def write_labels(path: Path, labels: list[int], seed: int = 0) -> Path:
    n = len(labels)
    x = np.random.default_rng(seed).normal(size=(n, 1, 4))
    features = QueryFeatures(
        queries=np.arange(n) + 3, attributes=x, rank_references=np.zeros((n, 1), int), single_match=np.zeros(n, int),
        sequence_match=np.zeros(n, int), sequence_distance=np.linspace(0, 1, n), labels=np.array(labels),
        single_correct=np.ones(n, bool), sequence_correct=np.ones(n, bool), rank_correct=np.ones((n, 1), bool),
        sequence_min=0.0, sequence_max=1.0, all_single_correct=np.ones(n + 3, bool))
    write_features(path, features, {})
    return path


def test_a_class_with_one_member_fails_up_front_naming_counts_and_fix(tmp_path, capsys):
    # scikit-learn's own error here: "The least populated classes in y have only 1 member ... ['True']" (the MLP's
    # early-stopping validation split is stratified for two classes, and SMOTE is off with a single sample)
    train = write_labels(tmp_path / "a.h5", [0] * 17 + [3])
    assert main(["train", "--dataset", "mine", "--seq-len", "4", "--predictor", json.dumps(TINY), "--train",
                 str(train), "--out", str(tmp_path / "L4.h5")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("vpr-smr train: error: dataset 'mine', sequence length 4, train split of 1 method(s)")
    assert "18 samples with class counts 0: 17, 1: 0, 2: 0, 3: 1" in err
    assert "two classes, one with a single sample" in err and "Fix: lengthen the train split" in err
    assert "shorten seq_lens" in err and len(err.strip().splitlines()) == 1
    assert files_in(tmp_path) == {"a.h5"}
    assert main(["ablation", "attributes", "--dataset", "mine", "--seq-len", "4", "--train", str(train),
                 "--out", str(tmp_path / "t2.json")]) == 2
    assert "0: 17, 1: 0, 2: 0, 3: 1" in capsys.readouterr().err and files_in(tmp_path) == {"a.h5"}


def test_sequence_length_equal_to_the_split_fails_naming_counts_and_fix(tmp_path, capsys):
    # a 4-frame split at L = 4: one query per method with a sequence match (4 - 4 + 1), correct before and after
    for method in ("m1", "m2"):
        write_features(tmp_path / f"{method}.h5", query_features(1.0 - np.eye(4), 4), {})
    assert main(["train", "--dataset", "mine", "--seq-len", "4", "--train", str(tmp_path / "m1.h5"),
                 str(tmp_path / "m2.h5"), "--out", str(tmp_path / "L4.h5")]) == 2
    err = capsys.readouterr().err
    assert "dataset 'mine', sequence length 4, train split of 2 method(s) pooled" in err
    assert "2 samples with class counts 0: 2, 1: 0, 2: 0, 3: 0" in err and "one class only" in err
    assert "Fix: lengthen the train split" in err
    assert files_in(tmp_path) == {"m1.h5", "m2.h5"}


def sklearn_trains(labels: np.ndarray, smote: bool = True) -> bool:
    """Whether cross-validation (5 stratified folds at most, SMOTE inside) and the fit run in scikit-learn itself,
    without the project's checks: the predictor's own pipeline, fitted on each training fold and on all."""
    from sklearn.model_selection import StratifiedKFold

    predictor = SMRPredictor(hidden_layer_sizes=(4,), max_iter=2, smote=smote)
    x = np.random.default_rng(0).normal(size=(len(labels), 4))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            folds = min(5, np.bincount(labels).max())
            if folds < 2:
                return False
            splits = StratifiedKFold(folds, shuffle=True, random_state=0).split(x, labels)
            for part in [train for train, _ in splits] + [np.arange(len(labels))]:
                if len(np.unique(labels[part])) < 2:
                    return False
                predictor.pipeline(labels[part], 4).fit(x[part], labels[part])
    except ValueError:
        return False
    return True


def test_label_problems_agree_with_scikit_learn():
    rng = np.random.default_rng(1)
    outcomes = []
    for _ in range(40):
        labels = rng.choice(4, size=int(rng.integers(4, 30)), p=rng.dirichlet(np.full(4, 0.5)))
        outcomes.append(sklearn_trains(labels))
        assert outcomes[-1] == (label_problems(labels) == []), np.bincount(labels, minlength=4)
    assert 5 < sum(outcomes) < 35  # both outcomes occur


def test_the_fewest_samples_that_can_train():
    import itertools

    # 11 samples can: labels 2 and 3 with 3 and 8 samples train in scikit-learn (5 folds, SMOTE, early stopping)
    assert sklearn_trains(np.array([2] * 3 + [3] * 8))
    # 10 cannot, whatever the labels and their order (label_problems agrees with scikit-learn, test above)
    for counts in itertools.product(range(11), repeat=4):
        if sum(counts) == 10:
            for order in itertools.permutations([c for c in range(4) if counts[c]]):
                labels = np.concatenate([np.full(counts[c], c) for c in order])
                assert fit_problem(counts) is not None or label_problems(labels), counts
    assert MIN_TRAIN_SAMPLES[True] == 11


def test_training_problems_from_split_lengths():
    # 13 frames at L = 4: 13 - 4 + 1 = 10 samples < 11; 14 frames: 11
    (problem,) = training_problems(13, 4)
    assert "split 'train' has 13 frames: 10 training samples per method at sequence length 4" in problem
    assert "at least 11" in problem and "lengthen split 'train' to at least 14 frames" in problem
    assert "shorten seq_lens" in problem
    assert training_problems(14, 4) == []
    # three methods pooled: 3 x (6 - 4 + 1) = 9 < 11; 3 x (7 - 4 + 1) = 12
    assert "9 pooled over 3 method(s)" in training_problems(6, 4, n_methods=3)[0]
    assert training_problems(7, 4, n_methods=3) == []
    assert training_problems(4, 4, n_methods=2)[0].startswith("split 'train' has 4 frames: 1 training samples")
    assert training_problems(4, 4, n_methods=11) == []
    # without SMOTE the minority class is not raised: 14 samples are needed (labels 3 and 11 of two classes)
    assert training_problems(16, 4, smote=False) and training_problems(17, 4, smote=False) == []
    assert sklearn_trains(np.array([0] * 11 + [1] * 3), smote=False)
    assert not sklearn_trains(np.array([0] * 10 + [1] * 3), smote=False)


def test_a_negative_value_beside_a_nan_is_still_counted(tmp_path):
    """The scan's first pass of minima: a block whose minimum is NaN is read again for its negative values."""
    from vpr_smr.eval.matching.io import check_non_negative

    matrix = np.ones((20, 20))
    matrix[3, 4], matrix[3, 5], matrix[17, 1] = np.nan, -2.0, -0.5
    with pytest.raises(ValueError, match=r"D\.npy: 2 negative values in the distance matrix \(minimum -2\)"):
        check_non_negative(tmp_path / "D.npy", matrix)
    matrix[3, 5] = matrix[17, 1] = 0.0
    check_non_negative(tmp_path / "D.npy", matrix)  # NaN alone passes here: the attributes stage names it
