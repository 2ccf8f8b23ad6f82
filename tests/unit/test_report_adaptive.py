"""The report of the experiment adaptive_seq_len (method §15): its rows from hand-built results and live timings, the
sentence's counts on hand-made pairs, its figure, its files read with the timing beside them, and the page."""

import csv
import dataclasses
import html
import re

import pytest
from report_runs import adaptive_files, adaptive_result, build_run

from vpr_smr.core.io import write_json
from vpr_smr.core.paths import timing_path
from vpr_smr.eval.report.results import Order
from vpr_smr.eval.report.rows import cells
from vpr_smr.eval.report.tables.adaptive import adaptive_rows, adaptive_sentence, histogram
from vpr_smr.eval.scoring.adaptive_records import AdaptiveTiming

META = {"dataset": "d", "method": "sad", "tag": "seqslam"}


def test_the_histogram_reads_shortest_first_and_the_unaccepted_last():
    assert histogram({4: 301, -1: 12, 2: 812}) == "2: 812, 4: 301, none: 12"
    assert histogram({4: 57}) == "4: 57"


def test_the_rows_of_a_hand_built_result_with_its_live_timing():
    result = adaptive_result("sad")
    rows = adaptive_rows([(result, AdaptiveTiming(META, 60, 57, 0.57, 1.14))])
    # name, kind, L, mean length, histogram, removed, AOC, reduction vs L4's 0.16 (%), live ms per query
    assert [(r.name, r.kind, r.seq_len, r.mean_length, r.lengths, r.removed, r.aoc) for r in rows] == [
        ("L2", "fixed", 2, 2.0, "2: 57", 0, 0.20), ("L4", "fixed", 4, 4.0, "4: 57", 0, 0.16),
        ("L2+pred", "fixed+predictor", 2, 2.0, "2: 57", 9, 0.12),
        ("L4+pred", "fixed+predictor", 4, 4.0, "4: 57", 9, 0.08),
        ("adaptive", "rule", None, 2.5, "2: 30, 4: 15, none: 12", 12, 0.05),
        ("adaptive_fallback", "rule", None, 3.0, "2: 30, 4: 15, none: 12", 12, 0.07),
        ("adaptive_uniqueness", "rule", None, 3.5, "2: 30, 4: 15, none: 12", 12, 0.30)]
    assert [r.reduction_pct for r in rows] == pytest.approx([-25.0, 0.0, 25.0, 50.0, 68.75, 56.25, -87.5])
    # 0.57 s over 57 queries: 10 ms for the adaptive matcher (both rules it runs), 1.14 s: 20 ms for L4 + predictor
    assert [r.ms_per_query for r in rows] == pytest.approx([None, None, None, 20.0, 10.0, 10.0, None])
    assert {r.best_fixed for r in rows} == {"L4+pred"} and {r.dataset for r in rows} == {"d"}
    assert [r.minus_best_fixed_ci and (r.minus_best_fixed_ci.low, r.minus_best_fixed_ci.high) for r in rows][4:] == [
        (-0.05, -0.01), (-0.03, 0.01), (0.1, 0.3)]
    assert [r.threshold for r in rows] == [None] * 6 + [0.25]
    assert [r.reduction_pct_mean for r in rows][:2] == [None, None]  # no seeds without a predictor
    first = cells(rows[4])
    assert (first["aoc_ci_low"], first["aoc_ci_high"]) == pytest.approx((0.03, 0.07))
    assert (first["minus_best_fixed_ci_low"], first["minus_best_fixed_ci_high"]) == (-0.05, -0.01)


def test_the_live_time_is_empty_without_a_timing_and_a_refusal_is_said():
    result = adaptive_result("sad")
    assert {r.ms_per_query for r in adaptive_rows([(result, None)])} == {None}
    refused = AdaptiveTiming(META, 60, 57, None, None, "openseqslam centres its window")
    rows = adaptive_rows([(result, refused)])
    assert {r.ms_per_query for r in rows} == {None}
    assert [(r.name, r.live_note) for r in rows if r.live_note] == [
        (name, "refused: openseqslam centres its window") for name in ("L4+pred", "adaptive", "adaptive_fallback")]
    assert {r.ms_per_query for r in adaptive_rows([(result, AdaptiveTiming(META, 60, 0, 0.0, 0.0))])} == {None}


def test_the_rows_run_by_dataset_matcher_mode_and_method_in_the_configurations_order():
    found = [(adaptive_result(method, tag, modes=("standard", "paper"), dataset=dataset), None)
             for dataset in ("e", "d") for tag in ("seqslam", "bayes_filter") for method in ("m2", "m1")]
    rows = adaptive_rows(found, Order(("d", "e"), ("m1", "m2"), ("paper", "standard")))
    firsts = [(r.dataset, r.matcher, r.mode, r.method) for r in rows if r.name == "L2"]
    assert firsts == [(dataset, tag, mode, method) for dataset in ("d", "e") for tag in ("seqslam", "bayes_filter")
                      for mode in ("paper", "standard") for method in ("m1", "m2")]


def _pair(method, tag="seqslam", best_fixed="L4+pred", **rules):
    result = adaptive_result(method, tag, rules=rules)
    result = dataclasses.replace(result, best_fixed={"paper": best_fixed})
    return adaptive_rows([(result, None)])


def test_the_sentence_counts_the_pairs_by_the_best_rules_interval():
    rows = [
        *_pair("m1", adaptive=(0.05, 2.5, "improved", (-0.05, -0.01))),  # below the best fixed row's: better
        *_pair("m2", adaptive=(0.07, 3.0, "improved", (-0.02, 0.01))),  # holds 0, mean 3.0 shorter than L4
        *_pair("m3", best_fixed="L2+pred", adaptive=(0.09, 3.0, "improved", (-0.01, 0.02))),  # holds 0, not < L2
        *_pair("m4", adaptive=(0.12, 3.0, "improved", (0.01, 0.06))),  # above: worse
        *_pair("m5", adaptive=(0.06, 2.2, "improved", None)),  # no interval
        # the degenerate rule (every match removed, AOC 0) is not the best: adaptive_fallback is; holds 0, 3.5 < 4
        *_pair("m6", adaptive=(0.0, 2.0, "removed_all", (-0.08, -0.08)),
               adaptive_fallback=(0.08, 3.5, "improved", (-0.01, 0.01))),
        *_pair("m8", adaptive=(0.08, 4.0, "improved", (-0.01, 0.01))),  # holds 0, mean 4.0 not shorter than L4
        *_pair("m7", "bayes_filter", adaptive=(0.0, 2.0, "removed_all", None),
               adaptive_fallback=(0.0, 4.0, "kept_none_correct", None)),
    ]
    assert adaptive_sentence(rows) == (
        "On d (paper mode, the 57 queries every length evaluates, 8 method-matcher pairs), the best rule's AOC, at "
        "the recall both reach, is below the best fixed row's for 1 (the paired 95 % interval of the difference "
        "below 0; 1 of them with a shorter mean length used than the best fixed row's length), cannot be told apart "
        "from it for 4 (the interval holds 0; 2 of them with a shorter mean length) and is above it for 1; no "
        "interval of the difference for m5 · seqslam; no rule or no fixed row keeps a correct match for m7 · "
        "bayes_filter.")
    assert adaptive_sentence([]) == ""
    one = _pair("m1", adaptive=(0.05, 2.5, "improved", (-0.05, -0.01)))
    assert adaptive_sentence(one).startswith("On d (paper mode, the 57 queries every length evaluates, 1 "
                                             "method-matcher pair), the best rule's AOC, at the recall both reach, "
                                             "is below the best fixed row's for 1 ")
    # without a best fixed row in paper mode (the experiment compares rows in standard mode only): said in words
    unpaired = [dataclasses.replace(r, best_fixed="") for r in one]
    assert adaptive_sentence(unpaired) == (
        "On d (paper mode), the rows are not compared: a row's recall divides by its own correct matches, which "
        "differ from row to row; the standard mode's sentence compares them.")
    # queries counted per matcher where they differ (a centred window evaluates fewer)
    mixed = [*one, *(dataclasses.replace(r, matcher="openseqslam", n_queries=55)
                     for r in _pair("m1", "openseqslam", adaptive=(0.05, 2.5, "improved", (-0.05, -0.01))))]
    assert "the 57 (seqslam) to 55 (openseqslam) queries every length evaluates, 2 method-matcher pairs" in (
        adaptive_sentence(mixed))


def test_the_figure_is_written_with_a_row_that_keeps_no_correct_match(tmp_path):
    from vpr_smr.eval.report.figures import adaptive_figure

    rows = [*_pair("m1", adaptive=(0.0, 2.0, "removed_all", None)),
            *_pair("m2", "bayes_filter", adaptive=(0.05, 2.5, "improved", (-0.05, -0.01)))]
    path = adaptive_figure(tmp_path / "a.png", rows, ["m1", "m2"], ["seqslam", "bayes_filter"], "d, paper mode")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_report_command_reads_the_files_and_their_timings(tmp_path):
    from vpr_smr.pipeline.cli import main as cli

    made = tmp_path / "made"
    build_run(made, modes=("paper",), seq_lens=(4,), ablations=False, inspector=False, metrics=False,
              baselines=False)
    files = adaptive_files(made, modes=("paper",))
    untimed = adaptive_files(made / "untimed", methods=("m3",), modes=("paper",), timed=False)
    run = tmp_path / "run"
    assert cli(["report", "--evaluations", str(made / "e_m1_L4.json"), "--predictors", str(made / "p_L4.json"),
                "--adaptive", *map(str, files + untimed), "--out", str(run)]) == 0
    with open(run / "tables" / "adaptive_seq_len.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert [(r["method"], r["name"]) for r in rows] == [(m, n) for m in ("m1", "m2", "m3") for n in (
        "L2", "L4", "L2+pred", "L4+pred", "adaptive", "adaptive_fallback", "adaptive_uniqueness")]
    timed = {(r["method"], r["name"]): r["ms_per_query"] for r in rows if r["ms_per_query"]}
    assert {key: float(value) for key, value in timed.items()} == pytest.approx(
        {(m, n): ms for m in ("m1", "m2") for n, ms in (("L4+pred", 20.0), ("adaptive", 10.0),
                                                       ("adaptive_fallback", 10.0))})
    assert (run / "figures" / "adaptive_d_paper.png").is_file()
    page = html.unescape(re.sub(r"\s+", " ", (run / "report.html").read_text()))
    assert '<section id="adaptive-seq-len">' in page and "Choosing the sequence length per query" in page
    assert ("On d (paper mode, the 57 queries every length evaluates, 3 method-matcher pairs), the best rule's AOC, "
            "at the recall both reach, is below the best fixed row's for 3 ") in page


def test_a_second_file_of_the_same_key_or_a_timing_of_another_method_is_refused(tmp_path):
    from vpr_smr.eval.report.build import read_adaptive_files

    first, second = adaptive_files(tmp_path, modes=("paper",))
    copy = tmp_path / "copy.json"
    copy.write_text(first.read_text())
    with pytest.raises(ValueError, match=r"copy.json and .*m1.json: two adaptive sequence length files of the same "
                                         r"dataset 'd', method 'm1', tag 'seqslam': give one file each"):
        read_adaptive_files([first, copy])
    write_json(timing_path(second), AdaptiveTiming({**META, "method": "m1", "dataset": "d"}, 60, 57, 1.0,
                                                   2.0).to_json())
    with pytest.raises(ValueError, match=r"m2.timing.json: the live timing of another method than .*m2.json beside "
                                         r"it \(method 'm1', not 'm2'\): rerun vpr-smr adaptive"):
        read_adaptive_files([second])
    untagged = tmp_path / "untagged.json"
    data = adaptive_result("m1").to_json()
    data["meta"].pop("tag")
    write_json(untagged, data)
    with pytest.raises(ValueError, match=r"untagged.json: an adaptive sequence length file without tag in its meta"):
        read_adaptive_files([untagged])


def test_the_section_follows_the_sequence_length_ablation(full_report_run):
    run, _ = full_report_run
    page = (run / "report.html").read_text()
    at = [page.index(f'<section id="{name}">') for name in ("sequence-length", "adaptive-seq-len", "speed")]
    assert at == sorted(at)
