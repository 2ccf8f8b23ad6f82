"""report.html without a browser: the provenance of the descriptor files on the page, the version to cite, and the
template escaping what it is given (the page in a real browser: test_html_report.py)."""

import html


def test_provenance_of_descriptor_files_in_the_page(tmp_path):
    from vpr_smr.core.io import atomic_h5
    from vpr_smr.eval.report.build import ReportOptions, RunFiles, main

    descriptors = tmp_path / "hog.h5"
    with atomic_h5(descriptors, {"dataset": "toy", "method": "hog", "checkpoint_sha256": "11" * 32,
                                 "frames_sha256": "22" * 32}):
        pass
    main(tmp_path / "run", RunFiles(descriptors=[descriptors]),
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
    from vpr_smr.eval.report.build import ReportOptions, RunFiles, main

    main(tmp_path / "run", RunFiles(),
         ReportOptions(config="note: <script>alert(1)</script> & more", provenance={"by": "<b>x</b>"}))
    page = (tmp_path / "run" / "report.html").read_text()
    assert "<script>alert(1)</script>" not in page and "&lt;script&gt;alert(1)&lt;/script&gt; &amp; more" in page
    assert "<b>x</b>" not in page and page.count("<script>") == 1  # the page's own sorting script


def test_the_first_screen_says_each_finding_in_one_sentence(tmp_path):
    import re

    from vpr_smr.eval.report import html as report_html
    from vpr_smr.eval.report import registry
    from vpr_smr.eval.report.results import WrittenTable

    # a 28-query split: sad's reduction 3.2 % with an interval containing 0, hog's 40 % with one above 0
    rows = [{"dataset": "corridor", "method": method, "seq_len": 4, "mode": "paper", "aoc_vpr_sm": 0.5,
             "aoc_vpr_sm_pred": aoc, "reduction_pct": reduction, "outcome": "improved", "max_recall": 0.9,
             "max_recall_vpr_sm": 0.9, "reduction_pct_ci_low": low, "reduction_pct_ci_high": high, "n_queries": 28,
             "reduction_pct_mean": reduction, "reduction_pct_std": None, "n_seeds": 1, "n_seeds_defined": 1}
            for method, aoc, reduction, low, high in (("sad", 0.484, 3.2, -40.0, 35.0), ("hog", 0.3, 40.0, 20.0, 55.0))]
    table = WrittenTable("table1", registry.table("table1").columns, tuple(rows), (tmp_path / "tables" / "t.csv",))
    page = report_html.main(tmp_path / "report.html", [table], [], split="test",
                            protocols={"corridor": "within 2 frames"}).read_text()
    text = html.unescape(page)
    first = text[text.index('id="findings"'):text.index('<article class="finding">')]
    assert "Correct matches: corridor within 2 frames" in first
    assert re.findall(r"<li>(.*?)</li>", first) == [
        "corridor (28 test queries, L = 4, paper mode): the seed-0 predictor's AOC reduction with its 95 % interval "
        "is sad 3.2 % [-40.0, 35.0], too few queries to tell; hog 40.0 % [20.0, 55.0], it helps."]
    # a finding of another section is on the first screen too, in one sentence, with a link to its section
    scored = [{"dataset": "corridor", "method": method, "seq_len": 4, "mode": "paper", "scorer": scorer,
               "budget": 5, "reduction_pct": value, "reduction_pct_mean": value, "outcome": "improved",
               "n_queries": 28, **({"reduction_pct_difference_ci_low": low, "reduction_pct_difference_ci_high": high}
                                   if scorer == "uniqueness" else {})}
              for method, low, high in (("sad", -30.0, -2.0), ("hog", -5.0, 9.0))
              for scorer, value in (("uniqueness", 1.0), ("predictor", 20.0))]
    baselines = WrittenTable("baselines", registry.table("baselines").columns, tuple(scored),
                             (tmp_path / "tables" / "b.csv",))
    page_with = report_html.main(tmp_path / "with.html", [table, baselines], [], split="test").read_text()
    first_with = html.unescape(page_with)
    first_with = first_with[first_with.index('id="findings"'):first_with.index('<article class="finding">')]
    assert re.findall(r"<li>(.*?)</li>", first_with)[1] == (
        "corridor (L = 4, paper mode), the predictor against the best training-free scorer (uniqueness) at its "
        'budget: better for sad; too few queries to tell for hog. <a href="#baselines">Is the predictor better '
        "than a simple rule?</a>")
    # the sentences in full are folded below the table, the seed note among them
    details = text[text.index('<details class="finding-details">'):]
    assert "On the test split's 28 queries the interval of sad's reduction, -40.0 % to 35.0 %, contains 0" in details
    assert "One predictor seed was run" in details
    # sad's cell is not green; hog's is
    assert '<td class="num">3.20 [-40.00, 35.00]</td>' in page.replace(' data-sort="3.2"', "")
    assert '<td class="up">40.00 [20.00, 55.00]</td>' in page.replace(' data-sort="40.0"', "")
