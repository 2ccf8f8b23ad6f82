"""Table I layout against the paper's own Table I (its Mean and Improved columns are derived values)."""

import csv
import dataclasses
import json

import numpy as np
import pytest
from report_runs import DATASET_CARD, RUN_EXPERIMENTS, build_run, metrics_record, predictor_report, small_png
from row_records import records

from vpr_smr.eval.predictor.records import AttributeAblation, AttributeScores, AttributeSplit
from vpr_smr.eval.report.rows import BaselineRow, DetectionRow, Table1Row
from vpr_smr.eval.report.table1 import table1_latex, table1_markdown, tex_escape
from vpr_smr.eval.report.tabulate import table2_latex, table2_markdown, table2_rows

METHODS = ("AP-GeM", "CosPlace", "EigenPlaces", "MixVPR", "NetVLAD", "SAD", "SALAD")
PAPER = {  # smr_paper.tex, Table I: VPR+SM, VPR+SM+Pred, Reduction (%) per method
    "Nordland": (
        (0.6522, 0.0220, 0.0155, 0.0061, 0.2478, 0.2164, 0.0017),
        (0.4862, 0.0136, 0.0106, 0.0042, 0.1274, 0.1050, 0.0011),
        (25.46, 38.17, 31.31, 31.96, 48.61, 51.46, 37.55),
    ),
    "Oxford RobotCar": (
        (0.0950, 0.0842, 0.0867, 0.0363, 0.0519, 0.1479, 0.0769),
        (0.1085, 0.0880, 0.0682, 0.0257, 0.0312, 0.0975, 0.0561),
        (-14.22, -4.45, 21.31, 29.34, 39.83, 34.07, 26.95),
    ),
}


@pytest.fixture
def rows():
    return [
        {"dataset": dataset, "method": method, "seq_len": 4, "mode": "paper", "aoc_vpr_sm": base[i],
         "aoc_vpr_sm_pred": pred[i], "reduction_pct": reduction[i],
         "outcome": "improved" if reduction[i] > 0 else "worse",
         # three seeds, their mean seed 0's (the paper ran one): every Table I row has its seeds
         "reduction_pct_mean": reduction[i], "reduction_pct_std": 1.0, "n_seeds": 3, "n_seeds_defined": 3}
        for dataset, (base, pred, reduction) in PAPER.items()
        for i, method in enumerate(METHODS)
    ]


def test_markdown_means_and_improved_match_the_paper(rows):
    text = table1_markdown(records(Table1Row, rows))
    assert "| dataset | | AP-GeM | CosPlace | EigenPlaces | MixVPR | NetVLAD | SAD | SALAD | Mean | Improved |" in text
    # The paper's Mean column: 0.1660, 0.1069, 37.79 (Nordland); 0.0827, 0.0679 (RobotCar). The paper's numbers
    # have no interval over queries: each method's cell says [n/a]; a Mean over methods has none to say.
    assert ("| Nordland | VPR+SM | 0.6522 [n/a] | 0.0220 [n/a] | 0.0155 [n/a] | 0.0061 [n/a] | 0.2478 [n/a] | "
            "0.2164 [n/a] | 0.0017 [n/a] | 0.1660 |  |") in text
    assert "|  | VPR+SM+Pred | 0.4862 [n/a] |" in text and "| 0.0011 [n/a] | 0.1069 |  |" in text
    # Improved is a direction: none is named without an interval (the paper's 7 / 7 are 7 estimates above 0)
    assert "| 37.55 [n/a] | 37.79 | 0 / 7 (7 without an interval) |" in text
    assert "| Oxford RobotCar | VPR+SM |" in text and "| 0.0769 [n/a] | 0.0827 |  |" in text
    assert "| 0.0561 [n/a] | 0.0679 |  |" in text
    # The paper prints 18.97, the mean of its unrounded reductions; of the rounded ones here it is
    # 132.83 / 7 = 18.976 -> 18.98.
    assert "|  | Reduction (%) | -14.22 [n/a] | -4.45 [n/a] |" in text
    assert "| 26.95 [n/a] | 18.98 | 0 / 7 (7 without an interval) |" in text
    assert "## paper mode, sequence length 4" in text


def with_intervals(rows, half=5.0):
    """The rows with intervals: each number's +- ``half`` (the AOCs' +- half / 1000)."""
    return [{**r, "reduction_pct_ci_low": r["reduction_pct"] - half, "reduction_pct_ci_high": r["reduction_pct"] + half,
             "aoc_vpr_sm_ci_low": r["aoc_vpr_sm"] - half / 1000, "aoc_vpr_sm_ci_high": r["aoc_vpr_sm"] + half / 1000,
             "aoc_vpr_sm_pred_ci_low": r["aoc_vpr_sm_pred"] - half / 1000,
             "aoc_vpr_sm_pred_ci_high": r["aoc_vpr_sm_pred"] + half / 1000} for r in rows]


def test_latex_colours_reductions(rows):
    # without intervals nothing has a direction: no colour
    assert r"\textcolor{black}{-14.22} [n/a]" in table1_latex(records(Table1Row, rows))
    text = table1_latex(records(Table1Row, with_intervals(rows)))
    # -14.22 [-19.22, -9.22] below 0: red; 25.46 [20.46, 30.46] above: green; -4.45 [-9.45, 0.55] contains 0
    assert r"\textcolor{red}{-14.22} [-19.22, -9.22]" in text and r"\textcolor{green}{25.46} [20.46, 30.46]" in text
    assert r"\textcolor{black}{-4.45} [-9.45, 0.55]" in text
    assert r"Oxford RobotCar & VPR+SM & 0.0950" in text and r"& 5 / 7\\" in text
    assert r"Reduction (\%)" in text


def test_latex_footnotes_an_undefined_reduction_in_its_own_tabular_only(rows):
    from vpr_smr.eval.report.table1 import UNDEFINED, UNDEFINED_NOTE

    # two (mode, L) blocks: L = 4 with one n/a reduction, then L = 8 with every reduction defined
    first = with_intervals(rows)
    first[0].update(reduction_pct=None, outcome="nothing_to_reduce", max_recall=0.5, max_recall_vpr_sm=0.5)
    second = [{**row, "seq_len": 8} for row in with_intervals(rows)]
    text = table1_latex(records(Table1Row, first + second))
    tabulars = text.split(r"\end{tabular}")[:-1]
    assert len(tabulars) == 2 and "sequence length 4" in tabulars[0] and "sequence length 8" in tabulars[1]
    note = tex_escape(UNDEFINED_NOTE)
    assert UNDEFINED in tabulars[0].replace(note, "") and note in tabulars[0]
    assert UNDEFINED not in tabulars[1] and note not in tabulars[1]
    # the other way round: the footnote goes with the second tabular only
    tabulars = table1_latex(records(Table1Row, second + first)).split(r"\end{tabular}")[:-1]
    assert note not in tabulars[0] and note in tabulars[1]


def test_seed_row_shows_mean_and_sample_std(rows):
    for row, values in zip(rows[:7], ((10, 20, 30), (1, 1, 1), (-5, 5, 0), (0, 0, 0), (2, 4, 6), (1, 2, 3),
                                      (3, 3, 3)), strict=True):
        row.update(reduction_pct_mean=float(np.mean(values)), reduction_pct_std=float(np.std(values, ddof=1)))
    for row in rows[7:]:
        row.update(reduction_pct_mean=1.0, reduction_pct_std=0.0)
    text = table1_markdown(records(Table1Row, rows))
    # AP-GeM 10, 20, 30: mean 20, std 10; CosPlace 1, 1, 1: 1 ± 0; EigenPlaces -5, 5, 0: 0 ± 5;
    # the mean of the seven means (20 + 1 + 0 + 0 + 4 + 2 + 3) / 7 = 4.29; the spread over seeds has no interval,
    # so Improved names no direction there
    assert ("|  | Reduction over seeds (%) | 20.00 ± 10.00 | 1.00 ± 0.00 | 0.00 ± 5.00 | 0.00 ± 0.00 | "
            "4.00 ± 2.00 | 2.00 ± 1.00 | 3.00 ± 0.00 | 4.29 | no interval (3 seeds) |") in text
    assert r"20.00 $\pm$ 10.00" in table1_latex(records(Table1Row, rows))


def test_a_seed_row_of_one_defined_seed_says_n_a_and_its_mean_is_like_with_like():
    # the 28-query split: hog's seed-0 reduction undefined and one of its 5 seeds defined (its std None, as
    # evaluate.seed_summary writes it; 0.9 wrote 0.0); sad's seed 0 is 3.20 with an interval containing 0, all 5
    # defined
    hog = {"dataset": "d", "method": "hog", "seq_len": 4, "mode": "paper", "aoc_vpr_sm": 0.0, "aoc_vpr_sm_pred": 0.0,
           "reduction_pct": None, "outcome": "nothing_to_reduce", "max_recall": 0.5, "max_recall_vpr_sm": 0.5,
           "reduction_pct_mean": -88.19, "reduction_pct_std": None, "n_seeds": 5, "n_seeds_defined": 1,
           "seeds_left_out": "seeds 0, 1, 2, 3: nothing to reduce", "n_queries": 28}
    sad = {"dataset": "d", "method": "sad", "seq_len": 4, "mode": "paper", "aoc_vpr_sm": 0.5, "aoc_vpr_sm_pred": 0.484,
           "reduction_pct": 3.2, "outcome": "improved", "max_recall": 0.9, "max_recall_vpr_sm": 0.9,
           "reduction_pct_ci_low": -40.0, "reduction_pct_ci_high": 35.0, "reduction_pct_mean": 4.0,
           "reduction_pct_std": 1.5, "n_seeds": 5, "n_seeds_defined": 5, "n_queries": 28}
    text = table1_markdown(records(Table1Row, [hog, sad]))
    # seed 0: the Mean over sad alone (3.20), named; sad's estimate is above 0 but its interval holds 0: not
    # improved
    assert ("|  | Reduction (%) | n/a: nothing to reduce | 3.20 [-40.00, 35.00] | 3.20 (mean over 1 of 2 methods: "
            "sad) | 0 / 2 |") in text
    # over the seeds: hog's std of one value is n/a (never 0.00); the Mean is sad's alone (4.00, not the
    # (-88.19 + 4.00) / 2 = -42.10 of one seed's number and a mean of five), and says so
    assert ("|  | Reduction over seeds (%) | -88.19 ± n/a (1 of 5 seeds; seeds 0, 1, 2, 3: nothing to reduce) | "
            "4.00 ± 1.50 | 4.00 (mean over 1 of 2 methods, those with all 5 seeds: sad) | no interval (5 seeds) |"
            ) in text
    assert "0.00 (" not in text and "± 0.00" not in text
    # two Means of opposite sign say why
    sad_worse = {**sad, "reduction_pct_mean": -2.0}
    assert ("| -2.00 (mean over 1 of 2 methods, those with all 5 seeds: sad; opposite in sign to the seed-0 Mean "
            "3.20, which is seed 0's predictor alone over sad, this one every seed's over sad) |"
            ) in table1_markdown(records(Table1Row, [hog, sad_worse]))
    assert r"-88.19 $\pm$ n/a" in table1_latex(records(Table1Row, [hog, sad]))


def test_an_unchanged_reduction_is_neutral():
    from vpr_smr.eval.report import html
    from vpr_smr.eval.report.registry import Column
    from vpr_smr.eval.report.table1 import table1_blocks

    # floating-point noise: 2.1e-14 %, which scoring calls unchanged, with an interval that is all but 0
    row = {"dataset": "d", "method": "uniqueness", "seq_len": 4, "mode": "standard", "aoc_vpr_sm": 0.2,
           "aoc_vpr_sm_pred": 0.2, "reduction_pct": 2.1e-14, "outcome": "unchanged", "max_recall": 0.9,
           "max_recall_vpr_sm": 0.9, "reduction_pct_ci_low": 1e-14, "reduction_pct_ci_high": 3e-14}
    (block,) = table1_blocks(records(Table1Row, [row]))
    assert html.table1_view(block, "t").rows[2][1].kind == "num"  # not "up" (green)
    assert html.row_cell(row, Column("reduction_pct", fmt=".2f")).kind == "num"
    assert r"\textcolor{black}{0.00} [0.00, 0.00]" in table1_latex(records(Table1Row, [row]))


def test_table2_marks_the_attributes_used():
    ablation = AttributeAblation({"dataset": "Nordland", "seq_len": 4}, {}, 100, {
        name: AttributeScores(None, f1, {"val": AttributeSplit(f1, 50, f1), "test": AttributeSplit(f1, 60, f1)})
        for name, f1 in (("A1", 0.42), ("A2", 0.42), ("A3", 0.40), ("A4", 0.37), ("all", 0.54))})
    rows = table2_rows([ablation])
    assert [r.attributes for r in rows] == ["A1", "A2", "A3", "A4", "all"]
    text = table2_markdown(rows)
    # the paper's Table II rows
    assert "| × | × | ✓ | × | 0.40 | 0.40 | 0.40 | 0.40 |" in text
    assert "| ✓ | ✓ | ✓ | ✓ | 0.54 | 0.54 | 0.54 | 0.54 |" in text
    assert r"$\times$ & $\times$ & $\times$ & $\checkmark$ & 0.37" in table2_latex(rows)


def test_every_experiment_gives_its_tables_and_figures(tmp_path):
    from vpr_smr.eval.report.registry import expected_outputs

    run, written = build_run(tmp_path)
    expected = expected_outputs(["d"], [2, 4], ["paper", "standard"], RUN_EXPERIMENTS, table_seq_lens=[4])
    assert sorted(str(p.relative_to(run)) for p in written) == sorted(expected)
    assert all((run / p).stat().st_size > 0 for p in expected)
    # Table I holds L = 4 only; the sequence-length table holds both, and its L = 4 rows equal Table I's
    table1 = list(csv.DictReader(open(run / "tables" / "table1.csv")))
    ablation = list(csv.DictReader(open(run / "tables" / "ablation_seq_len.csv")))
    assert {r["seq_len"] for r in table1} == {"4"} and {r["seq_len"] for r in ablation} == {"2", "4"}
    assert [{k: r[k] for k in table1[0]} for r in ablation if r["seq_len"] == "4"] == table1
    assert table1[0]["n_seeds"] == "2"
    restoration = list(csv.DictReader(open(run / "tables" / "restoration.csv")))
    assert len(restoration) == 2 * 2 * 2  # methods x L x modes
    for row in restoration:
        assert float(row["auc_difference"]) == pytest.approx(float(row["auc_restoration"]) - float(row["auc_removal"]))
    confusion = list(csv.DictReader(open(run / "tables" / "predictor_confusion.csv")))
    assert {r["method"] for r in confusion} == {"m1", "m2", "all"}
    for true_class in range(4):  # the "all" rows are the sums of the methods' rows
        rows = [r for r in confusion if r["seq_len"] == "4" and r["true_class"] == str(true_class)]
        total = {r["method"]: int(r["total"]) for r in rows}
        assert total["all"] == total["m1"] + total["m2"]
    trust = list(csv.DictReader(open(run / "tables" / "trust_levels.csv")))
    assert {r["trust"] for r in trust} == {"0.0", "0.9"}


def test_tables_and_figures_with_standard_mode_only(tmp_path):
    import json

    from vpr_smr.core.io import write_json
    from vpr_smr.eval.matching.attributes import query_features
    from vpr_smr.eval.predictor.estimator import SMRPredictor
    from vpr_smr.eval.report.build import ReportOptions, RunFiles, write
    from vpr_smr.eval.scoring.evaluate import evaluate_split
    from vpr_smr.eval.scoring.records import Evaluation

    rng = np.random.default_rng(0)
    matrix = rng.random((60, 60)) + 0.7 * (1 - np.eye(60))  # the diagonal is often, not always, the best
    features = query_features(matrix, 4)
    predictor = SMRPredictor(hidden_layer_sizes=(8,), max_iter=50).fit(features.attributes[:, 0], features.labels)
    result, _ = evaluate_split(features, predictor, modes=("standard",), trust_levels=(0.0, 0.9))
    evaluation = Evaluation({"dataset": "d", "method": "m", "seq_len": 4}, ("p.h5",), {"test": result})
    write_json(tmp_path / "e.json", evaluation.to_json())
    write_json(tmp_path / "p.json", predictor_report(4).to_json())
    write(tmp_path / "out", RunFiles([tmp_path / "e.json"], [tmp_path / "p.json"]), ReportOptions(html=False))
    assert (tmp_path / "out" / "tables" / "table1.csv").read_text().splitlines()[1].startswith("d,m,4,standard,")
    assert sorted(p.name for p in (tmp_path / "out" / "figures").iterdir()) == [
        "confusion_d_L4.png", "pr_d_L4_standard.png", "trust_d_L4_standard.png"]
    assert json.loads((tmp_path / "e.json").read_text())["splits"]["test"]["n_queries"] == 57
    assert not (tmp_path / "out" / "tables" / "restoration.csv").exists()
    assert not (tmp_path / "out" / "report.html").exists()


# --- the HTML page: Table I, the findings in words, the sections of the run ------------------------------------


def _table_texts(page: str, table_id: str) -> list[list[str]]:
    """The cells' texts of the page's table ``table_id``, row by row (header row first)."""
    import html
    import re

    found = re.search(rf'<table id="{re.escape(table_id)}"[^>]*>(.*?)</table>', page, re.S)
    assert found, f"no table {table_id}"
    return [[html.unescape(re.sub(r"<[^>]+>", "", c)).strip() for c in re.findall(r"<t[hd][^>]*>(.*?)</t[hd]>", r,
                                                                                   re.S)]
            for r in re.findall(r"<tr>(.*?)</tr>", found.group(1), re.S)]


def test_table1_in_the_page_has_the_papers_layout_and_numbers(rows, tmp_path):
    from vpr_smr.eval.report import html, registry
    from vpr_smr.eval.report.results import WrittenTable
    from vpr_smr.eval.report.table1 import table1_blocks

    blocks = table1_blocks(records(Table1Row, rows))
    assert [(b.dataset, b.methods) for b in blocks] == [("Nordland", METHODS), ("Oxford RobotCar", METHODS)]
    view = html.table1_view(blocks[1], "t")
    # without intervals no reduction has a direction: none coloured
    assert {c.kind for c in view.rows[2][1:]} == {"num", "text"}
    # with them: -14.22 [-19.22, -9.22] worse, -4.45 [-9.45, 0.55] no direction, 21.31 [16.31, 26.31] better
    view = html.table1_view(table1_blocks(records(Table1Row, with_intervals(rows)))[1], "t")
    assert [c.kind for c in view.rows[2][1:4]] == ["down", "num", "up"]
    assert view.rows[2][1].text == "-14.22 [-19.22, -9.22]"
    table = WrittenTable("table1", registry.table("table1").columns, tuple(records(Table1Row, rows)),
                         (tmp_path / "tables" / "table1.csv",))
    page = html.main(tmp_path / "report.html", [table], [], split="test").read_text()
    nordland = _table_texts(page, "table1-nordland-paper-4")
    assert nordland[0] == ["", *METHODS, "Mean", "Improved"]  # methods as columns, in the rows' order
    # the paper's numbers; its Mean column 0.1660, 0.1069, 37.79 (the paper's numbers have no interval: [n/a]
    # beside each method's, so Improved names no direction for any: the paper's 7 of 7 are estimates above 0)
    assert nordland[1] == ["VPR+SM", *(f"{v} [n/a]" for v in ("0.6522", "0.0220", "0.0155", "0.0061", "0.2478",
                                                               "0.2164", "0.0017")), "0.1660", ""]
    assert nordland[2] == ["VPR+SM+Pred", *(f"{v} [n/a]" for v in ("0.4862", "0.0136", "0.0106", "0.0042", "0.1274",
                                                                    "0.1050", "0.0011")), "0.1069", ""]
    assert nordland[3] == ["Reduction (%)", *(f"{v} [n/a]" for v in ("25.46", "38.17", "31.31", "31.96", "48.61",
                                                                      "51.46", "37.55")), "37.79",
                          "0 / 7 (7 without an interval)"]
    robotcar = _table_texts(page, "table1-oxford-robotcar-paper-4")
    assert robotcar[1][-2:] == ["0.0827", ""] and robotcar[2][-2:] == ["0.0679", ""]
    assert robotcar[3] == ["Reduction (%)", *(f"{v} [n/a]" for v in ("-14.22", "-4.45", "21.31", "29.34", "39.83",
                                                                      "34.07", "26.95")), "18.98",
                          "0 / 7 (7 without an interval)"]
    # the page leads with Table I, then the rest; no sorting on the paper's layout
    assert page.index('id="findings"') < page.index('id="pr-curves"') < page.index('id="provenance"')
    assert 'class="paper table1"' in page


def finding_block(reductions, seeds=None, mode="paper", seq_len=4, dataset="nordland_sample", intervals=None,
                  n_queries=None):
    """A Table I block of one dataset by hand: (method, reduction %) and, optionally, per method
    (mean, std, n_seeds, n_seeds_defined) over the seeds, (low, high) of the reduction's interval (None: none)
    and the queries."""
    from vpr_smr.eval.report.table1 import Table1Block

    rows = []
    for i, (method, reduction) in enumerate(reductions):
        outcome = ("nothing_to_reduce" if reduction is None else "improved" if reduction > 0 else
                   "worse" if reduction < 0 else "unchanged")
        row = {"dataset": dataset, "method": method, "seq_len": seq_len, "mode": mode, "aoc_vpr_sm": 0.5,
               "aoc_vpr_sm_pred": 0.4, "reduction_pct": reduction, "outcome": outcome, "max_recall": 0.9,
               "max_recall_vpr_sm": 0.9}
        # without ``seeds``: one seed, seed 0
        one = (reduction, None, 1, int(reduction is not None))
        mean, std, n_seeds, defined = seeds[i] if seeds is not None else one
        row.update(reduction_pct_mean=mean, reduction_pct_std=std, n_seeds=n_seeds, n_seeds_defined=defined)
        if intervals is not None and intervals[i] is not None:
            row.update(reduction_pct_ci_low=intervals[i][0], reduction_pct_ci_high=intervals[i][1])
        if n_queries is not None:
            row["n_queries"] = n_queries
        rows.append(row)
    return Table1Block(dataset, mode, seq_len, tuple(records(Table1Row, rows)))


ONE_SEED = "One predictor seed was run, so there is no spread over seeds."


def test_the_findings_in_words():
    from vpr_smr.eval.report.findings import headline, sentences

    # the demo's numbers, and a method whose baseline AOC is 0 (its reduction undefined); HOG's and SAD's
    # intervals exclude 0, EfficientNet-Lite0's contains it
    block = finding_block(
        [("SAD", -0.819238062820179), ("HOG", 76.7084537482669), ("EfficientNet-Lite0", 11.585629961797641),
         ("Perfect", None)],
        [(-0.8428717970517386, 0.030005601863029824, 5, 5), (78.37245222695637, 3.5256116744623283, 5, 5),
         (11.976893870677142, 1.0418886489552452, 5, 5), (None, None, 5, 0)],
        intervals=[(-1.5, -0.2), (70.1, 85.0), (-3.04, 25.0), None], n_queries=31)
    # "of 4": a method whose reduction is undefined counts as not improved (and gets its own sentence)
    assert sentences(block, "test") == [
        "On nordland_sample (test split, L = 4, paper mode, seed-0 predictor) the predictor reduced the area over "
        "the PR curve for 1 of 4 methods: HOG by 76.7 % (interval 70.1 % to 85.0 %); it made SAD's 0.8 % "
        "(interval -1.5 % to -0.2 %) worse; no direction for EfficientNet-Lite0 (below).",
        "On the test split, the 95 % interval of EfficientNet-Lite0's reduction [-3.0, 25.0] holds 0 (31 queries), "
        "so it names no direction.",
        "For Perfect, baseline AOC 0 up to the predictor's maximum recall 0.9000: nothing to reduce, the reduction "
        "is undefined.",
        "The mean reduction over these 3 methods is 29.2 % (Table I's Mean, seed 0).",
        "Over 5 predictor seeds (mean ± sample standard deviation) the reduction is SAD -0.8 ± 0.0 %, HOG "
        "78.4 ± 3.5 % and EfficientNet-Lite0 12.0 ± 1.0 %; it is undefined for "
        "Perfect.",
    ]
    # the first screen's sentence: each method's number, interval and what they say
    assert headline(block, "test") == (
        "nordland_sample (31 test queries, L = 4, paper mode): the seed-0 predictor's AOC reduction with its 95 % "
        "interval is SAD -0.8 % [-1.5, -0.2], it hurts; HOG 76.7 % [70.1, 85.0], it helps; EfficientNet-Lite0 "
        "11.6 % [-3.0, 25.0], no direction (interval holds 0); Perfect n/a, nothing to reduce.")
    # the 28-query split: an interval containing 0 gives no direction, whatever the sign of the number
    sad = finding_block([("sad", 3.2)], intervals=[(-40.0, 35.0)], n_queries=28, dataset="corridor")
    assert sentences(sad, "test") == [
        "On corridor (test split, L = 4, paper mode, seed-0 predictor) sad's reduction is 3.2 %.",
        "On the test split, the 95 % interval of sad's reduction [-40.0, 35.0] holds 0 (28 queries), so it names no "
        "direction.", ONE_SEED]
    # the same number with an interval excluding 0: the direction
    assert sentences(finding_block([("sad", 3.2)], intervals=[(0.5, 6.0)], n_queries=28, dataset="corridor"),
                     "test") == ["On corridor (test split, L = 4, paper mode, seed-0 predictor) the predictor reduced "
                                 "sad's area over the PR curve by 3.2 % (interval 0.5 % to 6.0 %).", ONE_SEED]
    # a file without intervals: no direction, the "no interval" wording
    assert sentences(finding_block([("sad", -2.04)], n_queries=28), "test") == [
        "On nordland_sample (test split, L = 4, paper mode, seed-0 predictor) sad's reduction is -2.0 %.",
        "On the test split's 28 queries sad's reduction of -2.0 % has no interval, so it names no direction.",
        ONE_SEED]
    # one method, one seed; its interval below 0
    one = finding_block([("hog", -5.0)], [(5.0, None, 1, 1)], mode="standard", seq_len=2, dataset="d",
                        intervals=[(-9.0, -1.0)])
    assert sentences(one, "val") == [
        "On d (val split, L = 2, standard mode, seed-0 predictor) the predictor made hog's area over the PR curve "
        "5.0 % worse (larger) (interval -9.0 % to -1.0 %).", ONE_SEED]
    # nothing to reduce anywhere; none improved, one unchanged; only some seeds defined
    nothing = finding_block([("a", None), ("b", None)], [(None, None, 3, 0), (None, None, 3, 0)])
    assert sentences(nothing, "test") == [
        "On nordland_sample (test split, L = 4, paper mode, seed-0 predictor) each of the 2 methods' area over the "
        "PR curve is already 0 without the predictor: there is nothing to reduce, so the reduction is undefined.",
        "Over 3 predictor seeds the reduction is undefined for every method."]
    mixed = finding_block([("a", -3.0), ("b", 0.0), ("c", -0.01)], [(-3.0, 1.0, 3, 2), (0.0, 0.0, 3, 3),
                                                                   (0.5, 0.25, 3, 3)],
                          intervals=[(-4.0, -2.0), (0.0, 0.0), (-0.02, -0.005)])
    # a: 2 of 3 seeds defined: its std (of two values) is shown
    assert sentences(mixed, "test") == [
        "On nordland_sample (test split, L = 4, paper mode, seed-0 predictor) the predictor reduced the area over "
        "the PR curve for none of the 3 methods; it made a's 3.0 % (interval -4.0 % to -2.0 %) and c's 0.01 % "
        "(interval -0.02 % to -0.005 %) worse; it left b's unchanged.",
        "The mean reduction over the 3 methods is -1.0 % (Table I's Mean, seed 0).",
        "Over 3 predictor seeds (mean ± sample standard deviation) the reduction is a -3.0 ± 1.0 % (2 of 3 seeds), "
        "b 0.0 ± 0.0 % and c 0.5 ± 0.2 %."]
    # two methods, one reduction defined; m2's one defined seed has no std (its 0.0 is not shown)
    half = finding_block([("m2", 0.0), ("m1", None)], [(0.0, None, 2, 1), (None, None, 2, 0)])
    assert sentences(half, "test") == [
        "On nordland_sample (test split, L = 4, paper mode, seed-0 predictor) the predictor reduced the area over "
        "the PR curve for none of the 2 methods; it left m2's unchanged.",
        "For m1, baseline AOC 0 up to the predictor's maximum recall 0.9000: nothing to reduce, the reduction is "
        "undefined.",
        "Over 2 predictor seeds (mean ± sample standard deviation) the reduction is m2 0.0 % (1 of 2 seeds); "
        "it is undefined for m1."]


SECTIONS = ("findings", "baselines", "pr-curves", "trust-levels", "restoration", "sequence-length", "predictor",
            "table-ii", "leave-one-method-out", "timing", "vpr-metrics", "match-inspector", "datasets", "provenance",
            "configuration")


def test_the_page_has_a_section_per_experiment_in_order(tmp_path):
    import html

    run, _ = build_run(tmp_path, modes=("paper",), seq_lens=(2, 4))
    page = (run / "report.html").read_text()
    positions = [page.index(f'<section id="{name}">') for name in SECTIONS]
    assert positions == sorted(positions)
    assert all(f'<a href="#{name}">' in page for name in SECTIONS)  # and the navigation links each
    text = html.unescape(page)
    assert "On d (test split, L = 4, paper mode, seed-0 predictor) the predictor " in text
    # the AOC's maximum recall is the predictor curve's (curves.compare_curves, method §8), where the dotted line is
    assert "up to VPR+SM+Pred's maximum recall (dotted line); VPR+SM's curve is cut there" in text
    # the match inspector: a figure per method, the per-query CSV named
    assert text.count("figures/matches_d_m1_L4.png") == 1 and "figures/distance_matrix_d_m2_L4.png" in text
    assert "queries/d/m1/L4.csv." in text and "not in the run folder" not in text
    assert DATASET_CARD["source"] in text and "split test" in text  # the dataset card
    assert page.count("<img ") == len(list((run / "figures").iterdir()))  # every figure of the run, once


def test_a_switched_off_experiment_leaves_no_section(tmp_path):
    run, written = build_run(tmp_path, modes=("paper",), seq_lens=(4,), trust_levels=(), restoration=False,
                             ablations=False, metrics=False, inspector=False)
    page = (run / "report.html").read_text()
    # the baselines always run in a workflow (no switch), as Table I does
    kept = ("findings", "baselines", "pr-curves", "predictor", "timing", "datasets", "provenance", "configuration")
    for name in SECTIONS:
        assert (f'<section id="{name}">' in page) == (name in kept), name
        assert (f'href="#{name}"' in page) == (name in kept), name
    assert {p.name for p in written if p.suffix == ".csv"} == {
        "table1.csv", "predictor_methods.csv", "predictor_confusion.csv", "timing.csv", "predictor.csv",
        "datasets.csv", "baselines.csv", "wrong_match_detection.csv"}
    for word in ("Trust level", "restoration", "Table II", "Leave one method out", "VPR metrics", "inspector"):
        assert word not in page.replace("Restoration", ""), word


def test_method_order_is_the_configurations(tmp_path):
    from vpr_smr.eval.report.table1 import evaluation_order, table1_rows
    from vpr_smr.eval.scoring.records import Evaluation

    run, _ = build_run(tmp_path, modes=("paper",), seq_lens=(4,), methods=("zeta", "alpha"))
    tables = run / "tables"
    assert "| dataset | | zeta | alpha | Mean | Improved |" in (tables / "table1.md").read_text()
    assert r"& zeta & alpha & Mean & Improved\\" in (tables / "table1.tex").read_text()
    for name in ("table1", "predictor_methods", "timing", "vpr_metrics", "restoration"):
        methods = [r["method"] for r in csv.DictReader(open(tables / f"{name}.csv"))]
        assert methods.index("zeta") < methods.index("alpha"), name
    confusion = list(dict.fromkeys(r["method"] for r in csv.DictReader(open(tables / "predictor_confusion.csv"))))
    assert confusion == ["zeta", "alpha", "all"]
    page = (run / "report.html").read_text()
    assert _table_texts(page, "table1-d-paper-4")[0] == ["", "zeta", "alpha", "Mean", "Improved"]
    assert page.index("matches_d_zeta_L4.png") < page.index("matches_d_alpha_L4.png")
    # an explicit order wins over the evaluations'
    evaluations = [Evaluation.from_json(json.loads(p.read_text())) for p in sorted(tmp_path.glob("e_*_L4.json"))]
    assert [r.method for r in table1_rows(evaluations)] == ["alpha", "zeta"]  # the order given (here sorted)
    order = evaluation_order(evaluations, methods=("zeta", "alpha"))
    assert [r.method for r in table1_rows(evaluations, order=order)] == ["zeta", "alpha"]


def test_vpr_metrics_table_equals_the_records(tmp_path):
    from vpr_smr.core.constants import MATCHERS, RECALL_AT

    run, _ = build_run(tmp_path, modes=("paper", "standard"), seq_lens=(4,), methods=("m2", "m1"))
    rows = list(csv.DictReader(open(run / "tables" / "vpr_metrics.csv")))
    expected = [(method, mode, matcher) for method in ("m2", "m1") for mode in ("paper", "standard")
                for matcher in MATCHERS]
    assert [(r["method"], r["mode"], r["matcher"]) for r in rows] == expected
    for row in rows:
        numbers = metrics_record(row["method"], 4, ("paper", "standard")).splits["test"].modes[row["mode"]][
            row["matcher"]]
        assert (row["dataset"], row["seq_len"], row["split"]) == ("d", "4", "test")
        assert int(row["n_queries"]) == numbers.n_queries
        assert [float(row[f"recall_at_{n}"]) for n in RECALL_AT] == [numbers.recall_at[n] for n in RECALL_AT]
        assert float(row["recall_at_100p"]) == numbers.recall_at_100p and float(row["pr_auc"]) == numbers.pr_auc
        assert float(row["extended_precision"]) == numbers.extended_precision
    # the page: paper mode's metrics per method and matcher, to 4 decimals
    shown = _table_texts((run / "report.html").read_text(), "metrics-d-4-paper")
    assert shown[0] == ["method", "matcher", "queries", "R@1", "R@5", "R@10", "R@20", "R@100P", "PR-AUC", "EP"]
    first = metrics_record("m2", 4).splits["test"].modes["paper"]["single"]
    assert shown[1] == ["m2", "single frame", str(first.n_queries), *(f"{first.recall_at[n]:.4f}" for n in RECALL_AT),
                        f"{first.recall_at_100p:.4f}", f"{first.pr_auc:.4f}", f"{first.extended_precision:.4f}"]
    assert [r[:2] for r in shown[1:]] == [[m, t] for m in ("m2", "m1")
                                          for t in ("single frame", "sequence", "sequence + predictor")]


def test_the_dataset_card_table(tmp_path):
    run, _ = build_run(tmp_path, modes=("paper",), seq_lens=(4,), metrics=False, inspector=False)
    (row,) = csv.DictReader(open(run / "tables" / "datasets.csv"))
    assert row == {"dataset": "d", "reference": "summer", "query": "winter", "n_frames": "60",
                   "splits": "test [0, 60): 60 frames", "tolerance": "2",
                   "pairing": "by file name (the same names in both folders)", "overlaps": "",
                   "frames_sha256": "cd" * 32, "source": DATASET_CARD["source"]}
    assert "| d | summer | winter | 60 | test [0, 60): 60 frames | 2 |" in (run / "tables" / "datasets.md").read_text()


def test_inspector_figures_are_placed_by_their_names(tmp_path):
    from vpr_smr.eval.report.build import inspector_figures

    a = small_png(tmp_path / "figures" / "matches_my_route_net_vlad_L4.png")
    b = small_png(tmp_path / "figures" / "distance_matrix_my_route_net_vlad_L4.png")
    c = small_png(tmp_path / "figures" / "matches_my_route_hog_L4.png")
    found = inspector_figures({"matches": [a, c], "distance_matrix": [b]}, [("my_route", "hog", 4)],
                              ["my", "my_route"], "test")
    assert [(f.name, f.dataset, f.method, f.seq_len) for f in found] == [
        ("matches", "my_route", "hog", 4), ("matches", "my_route", "net_vlad", 4),
        ("distance_matrix", "my_route", "net_vlad", 4)]
    with pytest.raises(ValueError, match="names no dataset, method and L"):
        inspector_figures({"matches": [small_png(tmp_path / "other.png")]}, [], ["d"], "test")
    with pytest.raises(FileNotFoundError, match="match inspector figure not found"):
        inspector_figures({"matches": [tmp_path / "missing.png"]}, [], ["d"], "test")


def test_a_wrong_file_given_to_the_report_is_named(tmp_path):
    from vpr_smr.eval.report.build import RunFiles, write
    from vpr_smr.eval.scoring import vpr_metrics
    from vpr_smr.eval.scoring.records import meta_key

    build_run(tmp_path / "made", modes=("paper",), seq_lens=(4,), ablations=False, inspector=False)
    made = tmp_path / "made"
    evaluation, metrics = made / "e_m1_L4.json", made / "metrics_m1.json"
    out = tmp_path / "run"

    def report(**inputs):
        write(out, RunFiles(**{"evaluations": [evaluation], "predictors": [made / "p_L4.json"], **inputs}))

    not_json = tmp_path / "notes.json"
    not_json.write_text("dataset: d\n")
    with pytest.raises(ValueError, match=r"notes.json: not an evaluation file: Expecting value: line 1"):
        report(evaluations=[not_json])
    binary = tmp_path / "figure.json"
    binary.write_bytes(b"\x89PNG\r\n\x1a\n\xff\xfe")
    with pytest.raises(ValueError, match=r"figure.json: not a predictor report file: .*decode"):
        report(predictors=[binary])
    listed = tmp_path / "list.json"
    listed.write_text("[1, 2]")
    with pytest.raises(ValueError, match=r"list.json: not a timing file: it holds a JSON list, not an object"):
        report(timings=[listed])
    # the wrong kind of JSON: an evaluation as the VPR metrics, VPR metrics as an evaluation, as a timing
    with pytest.raises(ValueError, match=r"e_m1_L4.json: not a VPR metrics file: "):
        report(metrics=[evaluation])
    with pytest.raises(ValueError, match=r"metrics_m1.json: not an evaluation file: it has no 'predictors' entry"):
        report(evaluations=[metrics])
    with pytest.raises(ValueError, match=r"metrics_m1.json: not a timing file: it has no "
                                         r"'splits.test.attributes_seconds' entry"):
        report(timings=[metrics])
    # `vpr-smr metrics D.npy` without --dataset and --method: no dataset or method in its meta
    matrix = tmp_path / "D.npy"
    np.save(matrix, np.random.default_rng(0).random((30, 30)) + 1 - np.eye(30))
    anonymous = tmp_path / "anonymous.json"
    vpr_metrics.main(vpr_metrics.MetricsJob((str(matrix),), 4, modes=("paper",), out=str(anonymous)))
    with pytest.raises(ValueError, match=r"anonymous.json: a VPR metrics file without dataset, method in its meta, "
                                         r"which the report needs: rerun vpr-smr metrics with --dataset and "
                                         r"--method"):
        report(metrics=[anonymous])
    assert not out.exists()
    with pytest.raises(ValueError, match=r"the meta has no dataset, method \(it has seq_len, tolerance\)"):
        meta_key({"seq_len": 4, "tolerance": 2})


def test_the_report_command_names_a_wrong_file(tmp_path, capsys):
    from vpr_smr.pipeline.cli import main as cli

    build_run(tmp_path / "made", modes=("paper",), seq_lens=(4,), ablations=False, inspector=False)
    made = tmp_path / "made"
    assert cli(["report", "--evaluations", str(made / "e_m1_L4.json"), "--predictors", str(made / "p_L4.json"),
                "--metrics", str(made / "e_m1_L4.json"), "--out", str(tmp_path / "run")]) == 2
    error = capsys.readouterr().err
    assert f"{made / 'e_m1_L4.json'}: not a VPR metrics file: " in error and "--debug" not in error


def test_datasets_and_splits_keep_the_configurations_order(tmp_path):
    import html

    from vpr_smr.eval.report.build import ReportOptions, RunFiles, write

    def card(overlap: str) -> dict:  # splits as configured: train, val, test (alphabetically test, train, val)
        return {**DATASET_CARD, "n_frames": 120, "splits": {"train": [0, 60], "val": [60, 90], "test": [80, 120]},
                "overlaps": [overlap]}

    # as the report rule gives them (pipeline.rule_helpers.report_datasets): JSON text in the configuration's order
    cards = json.loads(json.dumps({"zeta": card("'val' and 'test' share [80, 90)"),
                                   "alpha": card("'val' and 'test' share frames [85, 90)")}))
    run = tmp_path / "run"
    write(run, RunFiles(), ReportOptions(config={"run": "toy"}, datasets=cards))
    rows = list(csv.DictReader(open(run / "tables" / "datasets.csv")))
    splits = "train [0, 60): 60 frames; val [60, 90): 30 frames; test [80, 120): 40 frames"
    assert [(r["dataset"], r["splits"]) for r in rows] == [("zeta", splits), ("alpha", splits)]
    md = (run / "tables" / "datasets.md").read_text()
    assert md.index("| zeta |") < md.index("| alpha |") and f"| {splits} |" in md
    assert md.index("Warning, zeta:") < md.index("Warning, alpha:")  # the overlap warnings, in order too
    tex = (run / "tables" / "datasets.tex").read_text()
    assert tex.index(r"Warning, zeta:") < tex.index(r"Warning, alpha:") and tex.index("zeta &") < tex.index("alpha &")
    text = html.unescape((run / "report.html").read_text())
    assert text.index("Warning, zeta:") < text.index("Warning, alpha:")
    cards_at = text.index('class="cards"')
    zeta, alpha = text.index("<h3>zeta</h3>", cards_at), text.index("<h3>alpha</h3>", cards_at)
    assert zeta < alpha
    shown = [text.index(f"split {name}", zeta) for name in ("train", "val", "test")]
    assert shown == sorted(shown) and shown[-1] < alpha


# --- every table's columns as the registry declares them, in every file and on the page ----------------------------

# the page's compact table of each registered table in build_run's run (dataset d, L = 4, paper mode)
COMPACT = {"table1": "pr-d-4-paper", "restoration": "restoration-d-4-paper", "predictor_methods": "predictor-d-4",
           "predictor": "predictor-pooled-d", "leave_one_method_out": "lomo-d", "timing": "timing-d",
           "vpr_metrics": "metrics-d-4-paper", "table2": "table2-d-4", "trust_levels": "trust-d-4-paper",
           "ablation_seq_len": "seq-len-d-paper", "speed": "speed-d-4", "baselines": "baselines-d-4-paper",
           "wrong_match_detection": "detection-d-4", "protocol_sweep": "protocol-sweep-d-4-paper",
           "matchers": "matchers-d-4-paper", "adaptive_seq_len": "adaptive-seq-len-d-paper",
           "deployment": "deployment-d-4"}
PAPER_LAYOUT = ("table1", "table2")  # their Markdown and LaTeX files have the paper's layout, not the columns


def _headers(page: str, table_id: str) -> list[tuple[str, str]]:
    """(text, title) of the header cells of the page's table ``table_id`` (title: the CSV name, where shown)."""
    import html
    import re

    found = re.search(rf'<table id="{re.escape(table_id)}"[^>]*>.*?<tr>(.*?)</tr>', page, re.S)
    assert found, f"no table {table_id}"
    return [(html.unescape(re.sub(r"<[^>]+>", "", text)).strip(), html.unescape(title or ""))
            for title, text in re.findall(r'<th scope="col"[^>]*?(?: title="([^"]*)")?>(.*?)</th>', found.group(1),
                                          re.S)]


def test_every_declared_column_is_in_the_files_and_on_the_page(full_report_run):
    from vpr_smr.eval.report import registry
    from vpr_smr.eval.report.results import Splits

    run, _ = full_report_run
    page = (run / "report.html").read_text()
    splits = Splits("test", ("val", "test"))  # the run's: its evaluations' test split, its predictors' val and test
    assert {spec.name for spec in registry.TABLES} == set(COMPACT) | {"predictor_confusion", "datasets"}
    for spec in registry.TABLES:
        names = list(spec.names(splits))
        stem = run / "tables" / spec.name
        # the CSV ends with each row's dataset's ground truth (the datasets table has its own column)
        ground_truth = [registry.CORRECT_MATCHES.name] if "dataset" in names and spec.name != "datasets" else []
        with open(stem.with_suffix(".csv"), newline="") as handle:
            reader = csv.DictReader(handle)
            assert reader.fieldnames == [*names, *ground_truth], spec.name
            rows = list(reader)
        assert rows, spec.name
        if spec.name not in PAPER_LAYOUT:
            md = [line for line in stem.with_suffix(".md").read_text().splitlines() if line.startswith("| ")]
            # Markdown and LaTeX write a number's interval in its cell, a difference's interval in one column
            merged = []
            for name in names:
                if name.endswith("_ci_low") and name.removesuffix("_ci_low") not in names:
                    merged.append(name.removesuffix("_low"))
                elif not name.endswith(("_ci_low", "_ci_high")):
                    merged.append(name)
            assert [cell.strip() for cell in md[0].strip("|").split("|")] == merged, spec.name
            tex = stem.with_suffix(".tex").read_text().splitlines()
            head = tex[tex.index(next(line for line in tex if line.startswith(r"\begin{tabular}"))) + 1]
            assert [c.replace(r"\_", "_") for c in head.removesuffix(r"\\").split(" & ")] == merged, spec.name
        # the page's whole table: every column by its name, every number written as its column says
        whole = _table_texts(page, f"all-{spec.name}")
        assert whole[0] == names and len(whole) == len(rows) + 1, spec.name
        for row, shown in zip(rows, whole[1:], strict=True):
            for column, text in zip(spec.expanded(splits), shown, strict=True):
                value = row[column.name]
                if "." in value and value.replace(".", "").replace("-", "").replace("e", "").isdigit():
                    assert text == format(float(value), column.fmt), (spec.name, column.name, value, text)
                elif value:
                    assert text == value, (spec.name, column.name)
        # the compact table: the declared columns by their labels, the name on hover where the label differs
        if spec.pivot is not None:
            header = _headers(page, COMPACT[spec.name])[0][0]
            assert header == spec.column(spec.pivot.rows).header, spec.name
            cells = [row[0] for row in _table_texts(page, COMPACT[spec.name])[1:]]
            if spec.name == "speed":  # a row per profile and value
                assert [c.split(": ")[1] for c in cells] == [spec.column(v).header for v in spec.pivot.values
                                                             for _ in range(3)]
            continue
        shown = [c for c in spec.shown(splits) if not c.if_any or any(row[c.name] for row in rows)]
        headers = _headers(page, COMPACT[spec.name]) if spec.page else []
        if spec.name == "table2":  # the attributes used, then F1; the samples said in the note below
            assert [text for text, _ in headers] == ["A1", "A2", "A3", "A4", *(c.header for c in shown if not c.note)]
            assert all(c.header in page for c in shown if c.note)
            continue
        assert headers == [(c.header, c.name if c.header != c.name else "") for c in shown], spec.name
    # the baselines' compact tables: a row per scorer, a column per method (their own layout, no page columns)
    for table_id in (COMPACT["baselines"], COMPACT["wrong_match_detection"]):
        assert [text for text, _ in _headers(page, table_id)] == ["scorer", "m1", "m2"], table_id
    scorers = [row[0] for row in _table_texts(page, COMPACT["wrong_match_detection"])[1:]]
    assert scorers == ["uniqueness", "single_uniqueness", "spread", "distance", "native", "random", "oracle",
                       "predictor", "wrong fraction"]
    # a few of the labels, spelt out
    assert [text for text, _ in _headers(page, "pr-d-4-paper")] == [
        "method", "R@1 single", "R@1 sequence", "max recall", "AOC reduction (%)"]
    assert _headers(page, "restoration-d-4-paper")[-1] == ("PR AUC difference", "auc_difference")
    assert [text for text, _ in _headers(page, "predictor-pooled-d")] == [
        "L", "train samples", "F1 cross-validation", "F1 validation", "F1 test", "val samples", "test samples"]
    assert _headers(page, "trust-d-4-paper")[0][0] == "trust level" and _headers(page, "timing-d")[-1] == (
        "prediction (ms)", "ms_predict_per_query")
    assert [text for text, _ in _headers(page, "metrics-d-4-paper")][3:] == [
        "R@1", "R@5", "R@10", "R@20", "R@100P", "PR-AUC", "EP"]


def test_the_baselines_sentence_is_computed_from_the_numbers():
    from vpr_smr.eval.report.baselines import best_scorer, comparisons, detection_comparisons, with_best
    from vpr_smr.eval.report.findings import (
        baseline_headline,
        baseline_sentence,
        detection_headline,
        detection_sentence,
    )

    # reductions at the seed-0 budget per method (a, b, c); random's mean over its seeds is 60, its seed 0 1, 2, 3
    numbers = {"uniqueness": (30.0, 10.0, 2.0), "single_uniqueness": (5.0, 40.0, -1.0), "spread": (-3.0, -2.0, -9.0),
               "distance": (0.0, 0.0, 0.0), "native": (30.0, 10.0, 2.0),  # seqslam's: its uniqueness
               "random": (1.0, 2.0, 3.0), "oracle": (90.0, 95.0, None),
               "predictor": (50.0, 20.0, 2.0)}
    # the paired intervals of single_uniqueness's reduction minus the predictor's: a -45 below 0 (the predictor
    # beats it), b +20 above (it beats the predictor), c -3 containing 0
    differences = {"a": (-60.0, -30.0), "b": (5.0, 35.0), "c": (-10.0, 4.0)}
    rows = [{"dataset": "d", "method": method, "seq_len": 4, "mode": "paper", "scorer": scorer, "budget": 7,
             "reduction_pct": values[i], "reduction_pct_mean": 60.0 if scorer == "random" else values[i],
             "outcome": "improved" if values[i] is not None else "nothing_to_reduce", "n_queries": 28,
             **({"reduction_pct_difference_ci_low": differences[method][0],
                 "reduction_pct_difference_ci_high": differences[method][1]} if scorer == "single_uniqueness" else {})}
            for scorer, values in numbers.items() for i, method in enumerate("abc")]
    (found,) = comparisons(records(BaselineRow, rows))
    # like with like: seed 0 against seed 0 (random's 60 over its seeds is not set against seed-0 numbers); means
    # over the methods: uniqueness 14.0, single_uniqueness 14.67, spread -4.67, distance 0, random 2.0
    assert found.best == "single_uniqueness" and found.best_values == (5.0, 40.0, -1.0)
    assert found.beaten == 1 and found.oracle == (90.0, 95.0, None)
    assert baseline_sentence(found, "test") == (
        "On d (test split, L = 4, paper mode), at the seed-0 predictor's budget the predictor beats the best "
        "training-free scorer (single_uniqueness, mean seed-0 reduction 14.7 %) for 1 of 3 methods: a (interval "
        "-60.0 points to -30.0 points); single_uniqueness beats the predictor for b (interval 5.0 points to 35.0 "
        "points); for c (interval -10.0 points to 4.0 points) the 95 % interval of the difference holds 0 (28 "
        "queries), so no direction is named; oracle removal at the same budget would reduce the AOC by 92.5 % "
        "(mean over the 2 methods where it is defined).")
    # a scorer defined for one method only is ranked on the methods every scorer has: spread's 20 on b alone is
    # not set against single_uniqueness's 14.67 over three methods (on b, single_uniqueness has 40)
    partial = [{**r, "reduction_pct": {"b": 20.0}.get(r["method"])} if r["scorer"] == "spread" else r for r in rows]
    assert comparisons(records(BaselineRow, partial))[0].best == "single_uniqueness"
    # the first screen's sentence: the methods by what the paired interval says
    assert baseline_headline(found) == (
        "d (L = 4, paper mode), the predictor against the best training-free scorer (single_uniqueness) at its "
        "budget (the 95 % interval of its reduction minus the predictor's, in points): better for a [-60.0, -30.0]; "
        "worse for b [5.0, 35.0]; holds 0 for c [-10.0, 4.0].")
    # a difference that is 0 on every draw (the scorer removed the predictor's very matches): equal, which is
    # neither a direction nor an interval that holds 0
    same = [{**r, "reduction_pct_difference_ci_low": 0.0, "reduction_pct_difference_ci_high": 0.0}
            if r["method"] == "c" and r["scorer"] == "single_uniqueness" else r for r in rows]
    (tied,) = comparisons(records(BaselineRow, same))
    assert "; for c the two reductions are equal on every draw of the queries (the same matches removed);" in (
        baseline_sentence(tied, "test")) and "holds 0" not in baseline_sentence(tied, "test")
    # a file without the paired intervals: no direction for any method
    (bare,) = comparisons(records(BaselineRow, [{k: v for k, v in r.items() if "difference" not in k}
                                                for r in rows]))
    assert bare.beaten == 0 and "for 0 of 3 methods; no interval of the difference for a, b and c;" in (
        baseline_sentence(bare, "test"))
    # per row of the sequence-length ablation: the best training-free scorer of that method, by seed 0
    scored = records(BaselineRow, rows)
    for method, best in (("a", "uniqueness"), ("b", "single_uniqueness")):
        found_best = best_scorer([r for r in scored if r.method == method], lambda r: r.reduction_pct)
        assert found_best is not None and found_best.scorer == best
    table_row = Table1Row(**{field.name: None for field in dataclasses.fields(Table1Row)}  # only its key matters
                          | {"dataset": "d", "method": "c", "seq_len": 4, "mode": "paper"})
    (row,) = with_best([table_row], scored)
    assert (row.best_scorer, row.best_scorer_reduction_pct) == ("random", 3.0)
    # wrong-match detection (the numbers): the highest seed-0 AP and the paired interval against the
    # predictor's; random's mean over seeds (0.9) is not what it is compared by
    aps = {"a": {"uniqueness": 0.787, "spread": 0.5, "random": 0.3, "predictor": 0.714},
           "b": {"uniqueness": 0.570, "spread": 0.5, "random": 0.3, "predictor": 0.490}}
    ap_differences = {"a": (0.02, 0.13), "b": (-0.05, 0.2)}
    detection = [{"dataset": "d", "method": method, "seq_len": 4, "scorer": scorer, "average_precision": ap,
                  "average_precision_mean": 0.9 if scorer == "random" else None, "n_queries": 28,
                  **({"average_precision_difference_ci_low": ap_differences[method][0],
                      "average_precision_difference_ci_high": ap_differences[method][1]} if scorer == "uniqueness"
                     else {})}
                 for method, scores in aps.items() for scorer, ap in scores.items()]
    assert detection_sentence(detection_comparisons(records(DetectionRow, detection)), "test") == (
        "Detecting wrong matches on d (test split, L = 4), average precision among the training-free scorers "
        "(seed 0): for a uniqueness has the highest, 0.787 against the predictor's 0.714, and beats the predictor "
        "(difference interval 0.020 to 0.130); for b uniqueness has the highest, 0.570 against the predictor's "
        "0.490; the 95 % interval of the difference [-0.050, 0.200] holds 0 (28 queries), so no direction is "
        "named.")
    # uniqueness's AP minus the predictor's is above 0 for a (the predictor worse), contains 0 for b
    assert detection_headline(detection_comparisons(records(DetectionRow, detection))) == (
        "d (L = 4), detecting wrong matches, the predictor against the best training-free scorer (the 95 % interval "
        "of its average precision minus the predictor's): worse for a [0.020, 0.130]; holds 0 for b "
        "[-0.050, 0.200].")
    # the predictor ranks b's wrong matches as uniqueness does: the same AP, and 0 on every draw
    tied_ap = [{**r, "average_precision_difference_ci_low": 0.0, "average_precision_difference_ci_high": 0.0}
               if r["method"] == "b" and r["scorer"] == "uniqueness" else
               {**r, "average_precision": 0.570} if r["method"] == "b" and r["scorer"] == "predictor" else r
               for r in detection]
    assert detection_sentence(detection_comparisons(records(DetectionRow, tied_ap)), "test").endswith(
        "for b uniqueness has the highest, 0.570 against the predictor's 0.570, the same on every draw of the "
        "queries (the same ranking of the wrong matches).")
