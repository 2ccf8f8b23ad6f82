"""report.html without a browser: the provenance of the descriptor files on the page, the version to cite, and the
template escaping what it is given (the page in a real browser: test_html_report.py)."""

import html

from row_records import record, records

from vpr_smr.eval.report.rows import BaselineRow, Table1Row


def test_provenance_of_descriptor_files_in_the_page(tmp_path):
    from vpr_smr.core.io import atomic_h5
    from vpr_smr.eval.report.build import ReportOptions, RunFiles, write

    descriptors = tmp_path / "hog.h5"
    with atomic_h5(descriptors, {"dataset": "toy", "method": "hog", "checkpoint_sha256": "11" * 32,
                                 "frames_sha256": "22" * 32}):
        pass
    write(tmp_path / "run", RunFiles(descriptors=[descriptors]),
         ReportOptions(config={"run": "toy", "seq_lens": [4]}, provenance={"vpr_smr_version": "9.9"}))
    page = (tmp_path / "run" / "report.html").read_text()
    assert "11" * 32 in page and "22" * 32 in page and str(descriptors) in page
    assert "run: toy" in page and "seq_lens: [4]" in page and "9.9" in page
    # The version to cite is the one that made the results (the run's provenance), not the installed one.
    text = html.unescape(page)
    assert 'vpr-smr: sequence-matching receptiveness for visual place recognition", version 9.9' in text
    assert "Hussaini, T. Fischer and M. Milford" in text
    # what another machine may change, said in the provenance section
    provenance = text[text.index('<section id="provenance">'):text.index('<section id="configuration">')]
    assert "On another machine:" in provenance and "the same bytes on every CPU" in provenance
    # no experiment given: no section of one, nothing about Table I
    assert 'id="findings"' not in page and 'id="pr-curves"' not in page and "<img" not in page


def test_the_template_escapes_what_it_is_given(tmp_path):
    from vpr_smr.eval.report.build import ReportOptions, RunFiles, write

    write(tmp_path / "run", RunFiles(),
         ReportOptions(config="note: <script>alert(1)</script> & more", provenance={"by": "<b>x</b>"}))
    page = (tmp_path / "run" / "report.html").read_text()
    assert "<script>alert(1)</script>" not in page and "&lt;script&gt;alert(1)&lt;/script&gt; &amp; more" in page
    assert "<b>x</b>" not in page and page.count("<script>") == 1  # the page's own sorting script


# Every word of direction a verdict cell may say; a cell whose interval holds 0 says none of them
DIRECTION_WORDS = ("reduces", "raises", "beats", "behind", "better", "worse", "lower", "higher", "helps", "improved")


def _table1_rows(mode: str = "paper") -> list[dict]:
    """A 28-query split: sad's reduction 3.2 % with an interval containing 0, hog's 40 % with one above 0."""
    return [{"dataset": "corridor", "method": method, "seq_len": 4, "mode": mode, "aoc_vpr_sm": 0.5,
             "aoc_vpr_sm_pred": aoc, "reduction_pct": reduction, "outcome": "improved", "max_recall": 0.9,
             "max_recall_vpr_sm": 0.9, "reduction_pct_ci_low": low, "reduction_pct_ci_high": high, "n_queries": 28,
             "reduction_pct_mean": reduction, "reduction_pct_std": None, "n_seeds": 1, "n_seeds_defined": 1}
            for method, aoc, reduction, low, high in (("sad", 0.484, 3.2, -40.0, 35.0),
                                                      ("hog", 0.3, 40.0, 20.0, 55.0))]


def _verdict_rows(page: str, table_id: str) -> tuple[list[str], dict[str, list[str]]]:
    """A verdict table of the page: its column headers, and per row (its first header cell) each cell's class and
    text (the interval's line after a bar)."""
    import re

    found = page[page.index(f'<table id="{table_id}"'):]
    found = found[:found.index("</table>")]
    head = found[found.index("<thead>"):found.index("</thead>")]
    columns = re.findall(r'<th scope="col"[^>]*>(.*?)</th>', head)
    rows = {}
    for row in re.findall(r"<tr>(.*?)</tr>", found[found.index("<tbody>"):], re.S):
        label = re.findall(r'<th scope="row"[^>]*>(.*?)</th>', row)[0]
        cells = [f"{kind}|{html.unescape(text)}|{html.unescape(detail).strip()}"
                 for kind, text, detail in re.findall(
                     r'<td class="([a-z]+)">([^<]*)(?:<span class="detail">([^<]*)</span>)?</td>', row)]
        rows[label] = cells
    return columns, rows


def test_the_first_screen_answers_each_question_in_a_verdict_table(tmp_path):
    import re

    from vpr_smr.eval.report import html as report_html
    from vpr_smr.eval.report import registry
    from vpr_smr.eval.report.results import WrittenTable

    table = WrittenTable("table1", registry.table("table1").columns, tuple(records(Table1Row, _table1_rows())),
                         (tmp_path / "tables" / "t.csv",))
    page = report_html.main(tmp_path / "report.html", [table], [], split="test",
                            protocols={"corridor": "within 2 frames"}).read_text()
    text = html.unescape(page)
    first = text[text.index('id="findings"'):text.index('<article class="finding">')]
    # the queries and the ground truth said once, above the dataset's table
    assert "corridor <span class=\"queries\">· 28 test queries; correct within 2 frames</span>" in first
    assert first.count("28 test queries") == 2  # the verdict block's and the one sentence's below it
    # only the question the run asked: does the predictor reduce the AOC; none of the baselines', none of the
    # matchers' (no "nothing is compared")
    columns, rows = _verdict_rows(page, "verdicts-corridor-paper")
    assert columns == ["method", "reduces the AOC?"]
    assert "verdicts-matchers" not in page and "training-free" not in first and "compared" not in first
    # the configuration's order (as given); sad's interval holds 0: no direction word, hog's lies above 0
    assert list(rows) == ["sad", "hog"]
    assert rows["sad"] == ["hold|holds 0: 3.2 %|[-40.0, 35.0]"]
    assert rows["hog"] == ["up|reduces 40.0 %|[20.0, 55.0]"]
    assert not any(word in rows["sad"][0] for word in DIRECTION_WORDS)
    # the only mode shown, said once; no other mode to fold
    assert "<strong>Paper mode</strong>" in first and "The same in" not in first
    # the sentence of Table I follows the table, under its own heading
    assert first.index("verdicts-corridor-paper") < first.index('<h3 class="in-sentences">In sentences</h3>')
    assert len(re.findall(r"<li>corridor \(28 test queries, L = 4, paper mode\)", first)) == 1

    # the baselines add their question: the predictor's reduction minus the best scorer's (uniqueness, mean 1.0
    # against mean 0.5 of ratio), its paired interval flipped from the file's (scorer - predictor)
    scored = [{"dataset": "corridor", "method": method, "seq_len": 4, "mode": "paper", "scorer": scorer,
               "budget": 5, "reduction_pct": value, "reduction_pct_mean": value, "outcome": "improved",
               "n_queries": 28, **({"reduction_pct_difference_ci_low": low, "reduction_pct_difference_ci_high": high}
                                   if scorer != "predictor" else {})}
              for method, low, high in (("sad", -30.0, -2.0), ("hog", -5.0, 9.0))
              for scorer, value in (("uniqueness", 1.0), ("predictor", 20.0))]
    baselines = WrittenTable("baselines", registry.table("baselines").columns, tuple(records(BaselineRow, scored)),
                             (tmp_path / "tables" / "b.csv",))
    page_with = report_html.main(tmp_path / "with.html", [table, baselines], [], split="test").read_text()
    columns, rows = _verdict_rows(page_with, "verdicts-corridor-paper")
    assert columns == ["method", "reduces the AOC?", "beats the best training-free rule?"]
    # sad: 20 - 1 = +19.0 points, the interval of uniqueness - predictor [-30, -2] is [2, 30] from the predictor's
    # side: above 0; hog: [-9, 5] holds 0
    assert rows["sad"][1] == "up|beats uniqueness +19.0|[2.0, 30.0]"
    assert rows["hog"][1] == "hold|holds 0: +19.0|[-9.0, 5.0]"
    # the baselines' sentence follows the table, with a link to its section
    first_with = html.unescape(page_with)
    first_with = first_with[first_with.index('id="findings"'):first_with.index('<article class="finding">')]
    assert re.findall(r"<li>(.*?)</li>", first_with)[1].endswith(
        '<a href="#baselines">Is the predictor better than a simple rule?</a>')
    # sad's Table I cell is not green; hog's is
    assert '<td class="num">3.20 [-40.00, 35.00]</td>' in page.replace(' data-sort="3.2"', "")
    assert '<td class="up">40.00 [20.00, 55.00]</td>' in page.replace(' data-sort="40.0"', "")


def _matcher_row(method: str, matcher: str, mode: str, pct: float, ci: tuple[float, float], native: float,
                 native_ci: tuple[float, float] | None, ap: tuple[float, float], ap_ci: tuple[float, float]) -> dict:
    """A ``matchers`` row by hand: the predictor's reduction ``pct`` (interval ``ci``), the native confidence's
    ``native`` (interval of native - predictor ``native_ci``), the average precisions (predictor, native) and the
    interval of native - predictor ``ap_ci``."""
    return {"dataset": "corridor", "seq_len": 4, "mode": mode, "method": method, "matcher": matcher,
            "n_queries": 25, "reduction_pct": pct, "reduction_pct_ci_low": ci[0], "reduction_pct_ci_high": ci[1],
            "outcome": "improved" if pct > 0 else "worse", "native_reduction_pct": native,
            "native_minus_predictor_ci_low": None if native_ci is None else native_ci[0],
            "native_minus_predictor_ci_high": None if native_ci is None else native_ci[1],
            "ap_predictor": ap[0], "ap_native": ap[1], "ap_native_minus_predictor_ci_low": ap_ci[0],
            "ap_native_minus_predictor_ci_high": ap_ci[1]}


def _rule_row(method: str, mode: str, name: str, minus: float | None, ci: tuple[float, float] | None) -> dict:
    """An ``adaptive_seq_len`` rule row of matcher seqslam by hand: its AOC minus the best fixed row's ``minus``
    and that difference's paired interval ``ci`` (standard mode has a best fixed row, paper mode none)."""
    return {"dataset": "corridor", "matcher": "seqslam", "mode": mode, "method": method, "name": name,
            "kind": "rule", "n_queries": 24, "outcome": "improved", "max_recall": 0.8,
            "best_fixed": "L4+pred" if mode == "standard" else "", "minus_best_fixed": minus,
            "minus_best_fixed_ci_low": None if ci is None else ci[0],
            "minus_best_fixed_ci_high": None if ci is None else ci[1]}


def test_the_verdicts_per_matcher_and_length_rule_follow_their_intervals():
    from vpr_smr.eval.report.results import Order
    from vpr_smr.eval.report.tables.adaptive import AdaptiveSeqLenRow
    from vpr_smr.eval.report.tables.matchers import MatchersRow
    from vpr_smr.eval.report.verdicts import Answers, verdicts

    matchers = [
        # reduces (interval above 0); beats its native confidence (native - predictor [-6, -1]: [1, 6] for the
        # predictor); detects better (AP 0.6 - 0.4 = +0.2, native - predictor [-0.3, -0.1])
        *(_matcher_row("sad", "seqslam", mode, 20.0, (5.0, 30.0), 16.5, (-6.0, -1.0), (0.6, 0.4), (-0.3, -0.1))
          for mode in ("paper", "standard")),
        # holds 0 everywhere: no word of direction; no interval of the native comparison
        *(_matcher_row("sad", "bayes_filter", mode, 3.0, (-2.0, 8.0), 1.0, None, (0.5, 0.52), (-0.05, 0.1))
          for mode in ("paper", "standard")),
        # raises the AOC; behind its native confidence (-6 - 2 = -8 points, native - predictor [3, 8])
        *(_matcher_row("hog", "bayes_filter", mode, -6.0, (-9.0, -1.0), 2.0, (3.0, 8.0), (0.3, 0.4), (0.02, 0.2))
          for mode in ("paper", "standard")),
    ]
    rules = [_rule_row("sad", "standard", "adaptive", -0.03, (-0.05, -0.01)),
             _rule_row("sad", "standard", "adaptive_fallback", -0.01, (-0.03, 0.01)),
             _rule_row("sad", "standard", "adaptive_uniqueness", 0.2, (0.1, 0.3)),
             *(_rule_row("sad", "paper", name, None, None) for name in ("adaptive", "adaptive_fallback"))]
    answers = Answers(matchers=tuple(records(MatchersRow, matchers)), adaptive=tuple(records(AdaptiveSeqLenRow, rules)))
    found = verdicts(answers, Order(("corridor",), ("sad", "hog")), "test")
    # standard mode first, paper mode after it
    assert [mode.mode for mode in found] == ["standard", "paper"]
    standard = found[0].blocks[0]
    assert standard.title == "corridor"
    # the queries once: the table split's are unknown here (no Table I), the matchers' shared ones and the rules'
    assert standard.queries == "25 that every matcher evaluates; 24 that every length evaluates"
    (table,) = standard.tables
    assert [c.label for c in table.columns] == [
        "method", "matcher", "reduces the AOC?", "beats its own confidence?", "detects wrong matches better?",
        "adaptive", "adaptive_fallback", "adaptive_uniqueness"]
    assert [label for label, _ in table.groups] == ["", "the matcher with its own predictor",
                                                    "each length rule's AOC minus the best fixed length's"]
    cells = {(row[0].text or "sad", row[1].text): [(c.kind, c.text, c.detail) for c in row[2:]]
             for row in table.rows}
    assert list(cells) == [("sad", "seqslam"), ("sad", "bayes_filter"), ("hog", "bayes_filter")]
    assert cells[("sad", "seqslam")] == [
        ("up", "reduces 20.0 %", "[5.0, 30.0]"), ("up", "beats +3.5", "[1.0, 6.0]"),
        ("up", "better +0.200", "[0.100, 0.300]"), ("up", "lower -0.030", "[-0.050, -0.010]"),
        ("hold", "holds 0: -0.010", "[-0.030, 0.010]"), ("down", "higher +0.200", "[0.100, 0.300]")]
    assert cells[("sad", "bayes_filter")][:3] == [
        ("hold", "holds 0: 3.0 %", "[-2.0, 8.0]"), ("hold", "no interval: +2.0", ""),
        ("hold", "holds 0: -0.020", "[-0.100, 0.050]")]
    assert cells[("hog", "bayes_filter")][:3] == [
        ("down", "raises -6.0 %", "[-9.0, -1.0]"), ("down", "behind -8.0", "[-8.0, -3.0]"),
        ("down", "worse -0.100", "[-0.200, -0.020]")]
    for kind, text, _ in (c for row in cells.values() for c in row if c[1]):  # a rule-less row's empty cells
        assert (kind == "hold") == (not any(word in text for word in DIRECTION_WORDS)), text
    # paper mode compares no rule with the best fixed row: the rules' questions are absent there
    (paper,) = found[1].blocks[0].tables
    assert [c.label for c in paper.columns][2:] == [
        "reduces the AOC?", "beats its own confidence?", "detects wrong matches better?"]
    assert not paper.groups[-1][0].startswith("each length rule")


def test_a_verdict_names_a_degenerate_removal_and_an_equal_comparison():
    from vpr_smr.eval.report.verdicts import paired_cell, reduction_cell

    removed = record(Table1Row, {"reduction_pct": None, "outcome": "removed_all", "reduction_pct_ci_low": None,
                                 "reduction_pct_ci_high": None})
    assert (reduction_cell(removed).text, reduction_cell(removed).kind) == ("n/a: removed every match", "na")
    unchanged = record(Table1Row, {"reduction_pct": 0.0, "outcome": "kept_all"})
    assert reduction_cell(unchanged).text == "n/a: kept every match"
    no_interval = record(Table1Row, {"reduction_pct": 12.5, "outcome": "improved"})
    assert (reduction_cell(no_interval).text, reduction_cell(no_interval).kind) == ("no interval: 12.5 %", "hold")
    from vpr_smr.eval.report.verdicts import BEATS
    from vpr_smr.eval.scoring.records import Interval

    same = paired_cell(4.0, 4.0, Interval(0.0, 0.0), BEATS, ".1f")
    assert (same.text, same.kind) == ("equal on every draw", "hold")
    assert paired_cell(None, 4.0, Interval(-1.0, 1.0), BEATS, ".1f").kind == "na"
    # an interval wholly below 0 beside an outcome of improved: no word of direction, and not "holds 0" either
    odd = record(Table1Row, {"reduction_pct": 2.0, "outcome": "improved", "reduction_pct_ci_low": -5.0,
                             "reduction_pct_ci_high": -1.0})
    assert (reduction_cell(odd).text, reduction_cell(odd).detail) == ("no direction: 2.0 %", "[-5.0, -1.0]")
