"""The experiment deployment's table, sentences, headline, figure and section (method §16), on hand-built records
(here and in ``tests/deployment_results.py``): every expected cell and count is worked out by hand from them, or
counted from the rows by a naive loop in the test."""

from __future__ import annotations

import csv
import html as escaping
import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from deployment_results import OTHER, OWN, deployment_files, meta, realised, row, several
from report_runs import build_run

from vpr_smr.eval.report import registry
from vpr_smr.eval.report.build import _write_table
from vpr_smr.eval.report.rows import cells
from vpr_smr.eval.report.tables import deployment as table
from vpr_smr.eval.scoring.deployment_records import Chosen, DeploymentResult, RiskCoverage
from vpr_smr.eval.scoring.records import Interval
from vpr_smr.eval.scoring.thresholds import (
    ABSTAINED,
    EMPIRICAL,
    GUARANTEED,
    HELD,
    SAME_FRACTION,
    VIOLATED,
    Segments,
)


def one_deployment() -> DeploymentResult:
    """One method, one deployment split (200 queries). At p = 0.9: predictor/empirical falls to 40/50 = 0.8 with
    its interval (0.72, 0.86) wholly below 0.9 (seeds 1 and 2: violated and held); distance/guaranteed abstains;
    uniqueness/same_fraction holds at 38/40 = 0.95 (interval 0.88-0.99 holds 0.9) with recall 38/200 = 0.19
    against the ceiling's 54/200 = 0.27; oracle/empirical holds at recall 80/200 = 0.4, the ceiling's too. At p =
    0.95: uniqueness/same_fraction falls to 36/40 = 0.9 with an interval (0.85, 0.97) that holds 0.95."""
    ceiling = realised(200, 30, 3)
    rows = (
        row("predictor", EMPIRICAL, 0.9, 0.7, realised(200, 50, 10, Interval(0.72, 0.86)), ceiling, VIOLATED, 0,
            segments=Segments(100, 2, 2, 1)),
        row("predictor", EMPIRICAL, 0.9, 0.6, realised(200, 50, 12), ceiling, VIOLATED, 1),
        row("predictor", EMPIRICAL, 0.9, 0.8, realised(200, 20, 1), ceiling, HELD, 2),
        row("distance", GUARANTEED, 0.9, None, realised(200, 0, 0), realised(200, 10, 1), ABSTAINED,
            segments=Segments(100, 2, 0, 0)),
        row("uniqueness", SAME_FRACTION, 0.9, 2.5, realised(200, 40, 2, Interval(0.88, 0.99)),
            realised(200, 60, 6), HELD),
        row("oracle", EMPIRICAL, 0.9, 1.0, realised(200, 80, 0, Interval(1.0, 1.0)), realised(200, 80, 0), HELD),
        row("uniqueness", SAME_FRACTION, 0.95, 2.5, realised(200, 40, 4, Interval(0.85, 0.97)),
            realised(200, 30, 1), VIOLATED),
        row("oracle", EMPIRICAL, 0.95, 1.0, realised(200, 80, 0, Interval(1.0, 1.0)), realised(200, 80, 0), HELD),
        # a compared matcher: in the table, not in the run's sentences
        row("distance", EMPIRICAL, 0.9, 0.3, realised(200, 10, 5), realised(200, 10, 1), VIOLATED, matcher=OTHER),
    )
    curves = (RiskCoverage(OWN, "predictor", (0.1, 0.5, 1.0), (0.0, 0.05, 0.3), (0.9, 0.5, 0.1),
                           (Chosen(EMPIRICAL, 0.9, 0.5), Chosen(GUARANTEED, 0.9, None))),
              RiskCoverage(OWN, "distance", (0.2, 1.0), (0.1, 0.3), (2.0, 1.0), (Chosen(EMPIRICAL, 0.9, 2.0),)))
    notes = (f"{OWN}: guaranteed needs at least 22 calibration queries for precision 0.99 at risk 0.1",
             f"{OTHER}: the deployment test holds no evaluated query")
    return DeploymentResult(meta(), rows, curves, notes)


def test_rows_give_the_expected_cells(tmp_path: Path) -> None:
    rows = table.deployment_rows([one_deployment()])
    # seed 0 only for the predictor: 9 records less seeds 1 and 2
    assert [(r.matcher, r.source, r.rule, r.precision_target) for r in rows] == [
        (OWN, "predictor", EMPIRICAL, 0.9), (OWN, "distance", GUARANTEED, 0.9), (OWN, "uniqueness", SAME_FRACTION, 0.9),
        (OWN, "oracle", EMPIRICAL, 0.9), (OWN, "uniqueness", SAME_FRACTION, 0.95), (OWN, "oracle", EMPIRICAL, 0.95),
        (OTHER, "distance", EMPIRICAL, 0.9)]
    predictor = cells(rows[0])
    assert predictor["precision"] == pytest.approx(0.8)
    assert (predictor["precision_ci_low"], predictor["precision_ci_high"]) == (0.72, 0.86)
    assert predictor["recall"] == pytest.approx(0.2)
    assert predictor["accepted_fraction"] == pytest.approx(0.25)
    assert predictor["ceiling_recall"] == pytest.approx(0.135)
    assert predictor["recall_lost"] == pytest.approx(-0.065)
    assert predictor["threshold"] == 0.7 and predictor["n_calibration"] == 100 and predictor["n_deployment"] == 200
    assert predictor["outcome"] == VIOLATED and predictor["against_target"] == table.BELOW
    assert predictor["segments_violated"] == "1 of 2"
    assert predictor["seeds_violated"] == "2 of 3"  # seeds 0 and 1 of 3
    assert predictor["risk"] is None and predictor["calibration"] == "val" and predictor["deployment"] == "test"
    abstained = cells(rows[1])
    assert abstained["threshold"] is None and abstained["precision"] is None and abstained["recall"] == 0.0
    assert abstained["outcome"] == ABSTAINED and abstained["against_target"] == table.NO_INTERVAL
    assert abstained["risk"] == 0.1 and abstained["segments_violated"] == "0 of 0" and abstained["seeds_violated"] == ""
    assert cells(rows[2])["against_target"] == table.HOLDS and cells(rows[3])["against_target"] == table.ABOVE
    assert rows[0].notes == (f"{OWN}: guaranteed needs at least 22 calibration queries for precision 0.99 at risk 0.1",)
    assert rows[-1].notes == (f"{OTHER}: the deployment test holds no evaluated query",)

    # written: an undefined precision and an abstaining threshold are empty cells, never 0 or 1
    spec = registry.table(table.NAME)
    files = _write_table(tmp_path / table.NAME, spec.names(), [cells(r) for r in rows], spec.title)
    with open(files[0], newline="") as stream:
        written = list(csv.DictReader(stream))
    assert len(written) == 7
    assert (written[1]["precision"], written[1]["threshold"], written[1]["outcome"]) == ("", "", "abstained")
    assert float(written[0]["precision"]) == pytest.approx(0.8)


def test_sentences_of_one_deployment() -> None:
    rows = table.deployment_rows([one_deployment()])
    said = table.target_sentences(rows)
    assert said == [
        "Precision 0.9 (seqslam, thresholds set on val, deployed on the one deployment split test (one route; not "
        "evidence that a threshold holds elsewhere)): 2 of 4 source-rule pairs held on the one deployment split: "
        "uniqueness/same_fraction (recall 0.190 of the ceiling's 0.270; interval includes p in 1 of 1), "
        "oracle/empirical (recall 0.400 of the ceiling's 0.400); 1 fell below p: predictor/empirical in 1 of 1 (1 "
        "below p beyond its interval); 1 abstained (accepted nothing): distance/guaranteed in 1 of 1.",
        "Precision 0.95 (seqslam, thresholds set on val, deployed on the one deployment split test (one route; not "
        "evidence that a threshold holds elsewhere)): 1 of 2 source-rule pairs held on the one deployment split: "
        "oracle/empirical (recall 0.400 of the ceiling's 0.400); 1 fell below p: uniqueness/same_fraction in 1 of "
        "1 (1 below p, interval includes p).",
        "Note: seqslam: guaranteed needs at least 22 calibration queries for precision 0.99 at risk 0.1."]
    for sentence in said:
        assert "safe" not in sentence and "guarantee" not in sentence.replace("guaranteed", "")
    # the oracle (the check) is neither counted nor the best in the headline; the predictor's cells counted
    assert table.headline(rows) == (
        "On nordland (seqslam, L = 4), thresholds set on val for precision 0.9: 1 of 3 source-rule pairs (the oracle "
        "aside) held on the one deployment split; the highest recall: uniqueness/same_fraction (recall 0.190 of the "
        "ceiling's 0.270; interval includes p in 1 of 1); the predictor's thresholds held in 0, fell below p in 1 "
        "and abstained in 0 of its 1 rule-deployment cell.")


def test_sentences_count_deployments() -> None:
    rows = table.deployment_rows(several())
    (said,) = [s for s in table.target_sentences(rows) if s.startswith("Precision 0.9")]
    assert "deployed on 2 deployments of each of the 2 methods (test, oxford/test)" in said
    assert "one route" not in said and "safe" not in said
    # a naive count over the rows: the pairs held in all four cells, with their mean recalls
    cells_of: dict[tuple[str, str], list[table.DeploymentTableRow]] = {}
    for r in rows:
        cells_of.setdefault((r.source, r.rule), []).append(r)
    held = [key for key, found in cells_of.items() if all(r.outcome == HELD for r in found)]
    assert held == [("predictor", EMPIRICAL)]
    recall = sum(r.recall for r in cells_of["predictor", EMPIRICAL]) / 4
    assert recall == pytest.approx((46 + 57 + 63 + 30) / 400)
    # held as points only: the hand-built rows carry no intervals
    assert all(r.against_target == "no_interval" for r in cells_of["predictor", EMPIRICAL])
    assert (f"1 of 3 source-rule pairs held on 2 of 2 deployments of every method: predictor/empirical (mean recall "
            f"{recall:.3f} of the ceiling's 0.720; no interval in 4 of 4)") in said
    # distance/empirical: 3 of 4 cells below 0.9: once beyond the interval, once with it holding 0.9, once without
    assert ("1 fell below p: distance/empirical in 3 of 4 (1 below p beyond its interval; 1 below p, interval "
            "includes p; 1 without an interval)") in said
    assert "1 abstained (accepted nothing): spread/guaranteed in 2 of 4" in said
    numbers = [int(n) for n in re.findall(r"(\d+) of 3 source-rule pairs", said)]
    assert numbers == [len(held)]
    assert table.headline(rows).endswith(
        f"1 of 3 source-rule pairs (the oracle aside) held on 2 of 2 deployments of every method; the highest recall: "
        f"predictor/empirical (mean recall {recall:.3f} of the ceiling's 0.720; no interval in 4 of 4); the "
        "predictor's thresholds held in "
        "4, fell below p in 0 and abstained in 0 of its 4 rule-deployment cells.")


def test_nothing_held() -> None:
    rows = [r for r in table.deployment_rows([one_deployment()]) if r.source == "predictor"]
    assert table.headline(rows) == (
        "On nordland (seqslam, L = 4), thresholds set on val for precision 0.9: 0 of 1 source-rule pairs (the oracle "
        "aside) held on the one deployment split; the predictor's thresholds held in 0, fell below p in 1 and "
        "abstained in 0 of its 1 rule-deployment cell.")


def test_figure_draws(tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    results = [one_deployment(), replace_method(one_deployment(), "cosplace")]
    inputs = SimpleNamespace(deployment=results, order=None, correct=lambda dataset: "")
    written = table.draw(table.FIGURE, tmp_path, inputs)  # type: ignore[arg-type]
    assert [(w.name, w.dataset, w.seq_len) for w in written] == [(table.NAME, "nordland", 4)]
    assert written[0].path == tmp_path / table.FIGURE.file(dataset="nordland", seq_len=4)
    assert written[0].path.is_file() and written[0].path.stat().st_size > 0


def replace_method(result: DeploymentResult, method: str) -> DeploymentResult:
    return DeploymentResult({**result.meta, "method": method}, result.rows, result.curves, result.notes)


def test_experiment_exports_the_table_and_figure() -> None:
    assert [t.name for t in table.TABLES] == [table.NAME] and [f.name for f in table.FIGURES] == [table.NAME]
    section = table.TABLES[0].section
    assert section is not None and section.after == "baselines" and section.figure == table.NAME


def demo_like(seed: int) -> list[DeploymentResult]:
    """As the demo: three methods, one deployment split, six sources and the predictor's three seeds, three rules,
    three targets; counts drawn at random, the outcome the method's (precision against the target)."""
    rng = np.random.default_rng(seed)
    sources = [("uniqueness", None), ("single_uniqueness", None), ("spread", None), ("distance", None),
               ("native", None), ("oracle", None), ("predictor", 0), ("predictor", 1), ("predictor", 2)]
    results = []
    for method in ("sad", "hog", "netvlad"):
        rows = []
        for p in (0.9, 0.95, 0.99):
            for source, seed in sources:
                for rule in (EMPIRICAL, GUARANTEED, SAME_FRACTION):
                    accepted = int(rng.integers(0, 60)) * int(rng.random() > 0.2)
                    wrong = int(rng.integers(0, 4)) if accepted and rng.random() > 0.3 else 0
                    wrong = min(wrong, accepted)
                    precision = None if accepted == 0 else (accepted - wrong) / accepted
                    outcome = ABSTAINED if precision is None else HELD if precision >= p else VIOLATED
                    ci = None if precision is None or rng.random() < 0.2 else Interval(
                        precision - float(rng.random()) * 0.1, min(1.0, precision + 0.02))
                    rows.append(row(source, rule, p, None if accepted == 0 else 0.5, realised(200, accepted, wrong, ci),
                                    realised(200, int(rng.integers(accepted, 100)), 0), outcome, seed))
        results.append(DeploymentResult(meta(method, ("test",)) | {"precisions": [0.9, 0.95, 0.99]}, tuple(rows),
                                        (), ()))
    return results


@pytest.mark.parametrize("seed", range(5))
def test_sentences_agree_with_demo_like_rows(seed: int) -> None:
    rows = table.deployment_rows(demo_like(seed))
    said = table.target_sentences(rows)
    assert len(said) == 3
    for target, sentence in zip((0.9, 0.95, 0.99), said, strict=True):
        assert sentence.startswith(f"Precision {target:g} (seqslam, thresholds set on val, deployed on the one "
                                   "deployment split test of each of the 3 methods (one route; not evidence that a "
                                   "threshold holds elsewhere))")
        assert "safe" not in sentence
        pairs: dict[tuple[str, str], list[table.DeploymentTableRow]] = {}
        for r in rows:
            if r.precision_target == target:
                pairs.setdefault((r.source, r.rule), []).append(r)
        assert all(len(found) == 3 for found in pairs.values())  # seed 0 of the predictor only
        held = {key for key, found in pairs.items() if all(r.outcome == HELD for r in found)}
        violated = {key: sum(r.outcome == VIOLATED for r in found) for key, found in pairs.items()}
        abstained = {key: sum(r.outcome == ABSTAINED for r in found) for key, found in pairs.items()}
        assert f"{len(held)} of {len(pairs)} source-rule pairs held on the one deployment split of every method" \
            in sentence
        for source, rule, mean, recall, ceiling in re.findall(
                r"(\w+)/(\w+) \((mean )?recall ([\d.]+) of the ceiling's ([\d.]+)[;)]", sentence):
            found = pairs[source, rule]
            assert (source, rule) in held and mean == "mean "
            assert recall == f"{sum(r.recall for r in found) / 3:.3f}"
            assert ceiling == f"{sum(r.ceiling_recall for r in found) / 3:.3f}"
        below = sum(1 for n in violated.values() if n)
        if below:
            part = sentence.split(" fell below p: ")[1].split(" abstained (accepted nothing): ")[0]
            assert f"; {below} fell below p: " in sentence
            named = re.findall(r"(\w+)/(\w+) in (\d+) of 3 \(([^)]*)\)", part)
            assert len(named) == min(below, table.SHOWN)
            for source, rule, n, words in named:
                assert int(n) == violated[source, rule]
                beyond = sum(1 for r in pairs[source, rule] if r.outcome == VIOLATED and r.precision_ci is not None
                             and r.precision_ci.high < target)
                assert (f"{beyond} below p beyond its interval" in words) == (beyond > 0)
        else:
            assert "fell below p" not in sentence
        none = sum(1 for n in abstained.values() if n)
        if none:
            part = sentence.split(" abstained (accepted nothing): ")[1]
            assert f"; {none} abstained (accepted nothing): " in sentence
            named = re.findall(r"(\w+)/(\w+) in (\d+) of 3", part)
            assert len(named) == min(none, table.SHOWN)
            assert all(int(n) == abstained[source, rule] for source, rule, n in named)
        else:
            assert "abstained" not in sentence


def test_the_page_shows_the_section_after_the_baselines_with_its_headline(tmp_path: Path) -> None:
    files = deployment_files(tmp_path)  # the test run's dataset d and methods m1, m2
    run, written = build_run(tmp_path, seq_lens=(4,), inspector=False, restoration=False, deployment=tuple(files))
    assert {run / "tables" / f"deployment{suffix}" for suffix in (".csv", ".md", ".tex")} <= set(written)
    assert run / table.FIGURE.file(dataset="d", seq_len=4) in written
    page = escaping.unescape((run / "report.html").read_text())
    baselines, section = page.index('id="baselines"'), page.index('id="deployment"')
    assert baselines < section
    rows = table.deployment_rows(several())  # the page's rows differ from these in the dataset and methods only
    headline = table.headline(rows).replace("On nordland", "On d")
    assert page.index(headline) < baselines  # on the first screen
    for sentence in table.target_sentences(rows):
        assert sentence in page[section:]
    assert "Note: seqslam: a note." in page[section:]
