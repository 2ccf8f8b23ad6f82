"""The scorers' registry (eval/scoring/scorers.py): every entry declares its colour, description and settings record,
and one more training-free entry, registered by an installed package, reaches the scores, both protocols, the
per-query table and the figure with no other edit."""

from __future__ import annotations

import csv
from types import SimpleNamespace

import numpy as np
import pytest
from matplotlib.colors import is_color_like, to_rgba
from row_records import records

from vpr_smr.eval.matching.attributes import query_features
from vpr_smr.eval.report import figures
from vpr_smr.eval.report.baselines import Comparison
from vpr_smr.eval.report.rows import BaselineRow
from vpr_smr.eval.scoring import scorers
from vpr_smr.eval.scoring.baselines import (
    SCORERS,
    TRAINING_FREE,
    BaselineSettings,
    Prediction,
    query_scores,
    split_baselines,
)
from vpr_smr.eval.scoring.queries import SplitQueries, write_queries


def test_every_scorer_declares_its_colour_description_and_settings():
    assert scorers.names() == SCORERS == ("uniqueness", "single_uniqueness", "spread", "distance", "native",
                                          "random", "oracle", "predictor")
    assert TRAINING_FREE == ("uniqueness", "single_uniqueness", "spread", "distance", "native", "random")  # by kind
    fields = set(BaselineSettings().meta())
    for one in scorers.entries():
        assert is_color_like(one.colour) and one.description.strip(), one.name
        assert set(one.settings) <= fields, one.name
    assert len({one.colour for one in scorers.entries()}) == len(scorers.entries()) == 8  # told apart in a figure
    # what each reads of the configuration's baselines, by its record
    assert {one.name: one.settings for one in scorers.entries() if one.settings} == {
        "uniqueness": ("r_window",), "single_uniqueness": ("r_window",), "spread": ("spread_k",),
        "native": ("r_window",)}
    assert scorers.REGISTRY == scorers.entries()  # the name its readers of 0.16 use
    assert scorers.colour("oracle") == "black"
    with pytest.raises(ValueError, match=r"no scorer 'nope' is registered .* uniqueness, single_uniqueness"):
        scorers.scorer("nope")


def test_a_scorer_without_its_confidence_or_colour_is_refused():
    with pytest.raises(ValueError, match="every scorer but the predictor computes its own confidence"):
        scorers.Scorer("x", "training-free", "tab:red", "an x", None, None)
    with pytest.raises(ValueError, match="'x' needs a colour and a description"):
        scorers.Scorer("x", "training-free", "", "an x", None, lambda f, s, p, seed: f.sequence_distance)
    with pytest.raises(ValueError, match="'x': its Settings .* is none of the baselines' records \\(Uniqueness"):
        scorers.Scorer("x", "training-free", "tab:red", "an x", BaselineSettings, lambda f, s, p, seed: f.queries)


def _single_distance(features, settings, positions, seed):
    return -features.single_candidates[:, 0]


NEW = scorers.Scorer("single_distance", "training-free", "tab:red", "minus the single-frame distance", None,
                     _single_distance)


def _install(monkeypatch, version="1.2", **points):
    """Entry points of the group ``vpr_smr.scorers`` an installed package (its distribution of ``version``) would
    declare."""
    found = [SimpleNamespace(name=name, load=lambda item=item: item, dist=SimpleNamespace(version=version))
             for name, item in points.items()]
    for where in ("vpr_smr.core.registry", "vpr_smr.eval.scoring.scorers"):  # the registry's, and the versions'
        monkeypatch.setattr(f"{where}.entry_points", lambda group: found if group == scorers.ENTRY_POINT_GROUP else [])


def test_a_plugin_scorer_that_is_no_training_free_scorer_of_its_name_is_refused(monkeypatch):
    _install(monkeypatch, other=NEW)
    with pytest.raises(ValueError, match="entry point 'other' .* gives the training-free scorer 'single_distance': "
                                         "give a Scorer named 'other' of kind training-free"):
        scorers.entries()
    _install(monkeypatch, ceiling=scorers.scorer("oracle"))
    with pytest.raises(ValueError, match="'ceiling' .* gives the oracle scorer 'oracle'"):
        scorers.scorer("ceiling")
    with pytest.raises(ValueError, match="no scorer 'nope' is registered .* group vpr_smr.scorers"):
        scorers.scorer("nope")


def test_one_more_entry_reaches_everything(monkeypatch, tmp_path):
    _install(monkeypatch, single_distance=NEW)
    d = np.random.default_rng(11).random((40, 30))
    settings = BaselineSettings()
    features = query_features(d, 3, n_candidates=settings.candidates)
    positions = np.arange(40.0)
    rng = np.random.default_rng(2)
    prediction = Prediction(0, rng.dirichlet(np.ones(4), len(features.queries)), np.arange(4))

    scores = query_scores(features, settings, positions, 0, prediction)
    # an installed package's scorer comes before random
    assert list(scores) == ["uniqueness", "single_uniqueness", "spread", "distance", "native", "single_distance",
                            "random", "oracle", "predictor"]
    np.testing.assert_array_equal(scores["single_distance"], -d.min(axis=0)[features.queries])  # -D[single, a]

    found = split_baselines(features, settings, positions, [prediction])
    assert "single_distance" in found.detection and "single_distance" in found.removal[0].scorers
    assert "single_distance" in found.versus_predictor  # a training-free scorer against the predictor

    path = tmp_path / "queries.csv"
    write_queries(path, [SplitQueries("test", 0, features, d.min(axis=0)[features.queries], None, scores=scores)])
    with open(path, newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert [float(r["c_single_distance"]) for r in rows] == scores["single_distance"].tolist()

    drawn = {}

    def keep(fig, p):
        drawn["fig"] = fig
        return p

    monkeypatch.setattr(figures, "save", keep)
    methods = ("hog", "sad")
    rows = [{"method": m, "scorer": s, "outcome": "improved", "reduction_pct": 5.0, "reduction_pct_mean": 5.0,
             "reduction_pct_std": 1.0} for m in methods for s in scorers.names()]
    comparison = Comparison("corridor", "paper", 5, methods, "uniqueness", (20.0, 18.0), (12.0, 12.0),
                            (60.0, 60.0), (3, 4))
    figures.baselines_figure(tmp_path / "b.png", records(BaselineRow, rows), comparison, "corridor")
    (ax,) = drawn["fig"].axes
    labels = [text.get_text() for text in ax.get_legend().get_texts()]
    assert "single_distance" in labels and "native" in labels  # the matcher's own confidence, a bar of its own
    native_bars = [c for c in ax.containers if c.get_label() == "native"]
    assert native_bars and all(patch.get_facecolor() == to_rgba("tab:purple") for patch in native_bars[0])
    bars = [c for c in ax.containers if c.get_label() == "single_distance"]
    assert bars and all(patch.get_facecolor() == to_rgba("tab:red") for patch in bars[0])
    figures._pyplot().close(drawn["fig"])


def test_the_best_training_free_scorer_by_hand():
    from vpr_smr.eval.scoring.scorers import best_training_free

    # oracle and predictor are not training-free; spread and native tie at 7: spread comes first in the registry
    values = {"oracle": 100.0, "predictor": 50.0, "uniqueness": 3.0, "native": 7.0, "spread": 7.0, "random": None}
    assert best_training_free(values) == "spread"
    assert best_training_free({"distance": -2.0, "uniqueness": None}) == "distance"  # a negative one is the best
    assert best_training_free({"oracle": 1.0, "uniqueness": None}) is None


BUILT_IN = "uniqueness,single_uniqueness,spread,distance,native,random,oracle,predictor"


def test_the_registered_scorers_name_each_plugin_s_version(monkeypatch):
    # the same for every run of this version without plugins: nothing reruns for them
    assert scorers.registered() == BUILT_IN
    _install(monkeypatch, single_distance=NEW)
    assert scorers.registered() == ("uniqueness,single_uniqueness,spread,distance,native,single_distance==1.2,random,"
                                    "oracle,predictor")
    _install(monkeypatch, version="1.3", single_distance=NEW)  # an upgrade
    assert scorers.registered() == ("uniqueness,single_uniqueness,spread,distance,native,single_distance==1.3,random,"
                                    "oracle,predictor")
    _install(monkeypatch)  # removed
    assert scorers.registered() == BUILT_IN


def test_a_file_without_an_installed_scorer_is_named_stale(monkeypatch):
    from vpr_smr.eval.report.baselines import baseline_rows, detection_rows
    from vpr_smr.eval.scoring.records import Baselines

    d = np.random.default_rng(11).random((40, 30))
    settings = BaselineSettings()
    features = query_features(d, 3, n_candidates=settings.candidates)
    positions = np.arange(40.0)
    rng = np.random.default_rng(2)
    prediction = Prediction(0, rng.dirichlet(np.ones(4), len(features.queries)), np.arange(4))
    meta = {"dataset": "corridor", "method": "hog", "seq_len": 3}
    before = Baselines(meta, {"test": split_baselines(features, settings, positions, [prediction])})
    assert {row.scorer for row in baseline_rows([before], "test")} == set(BUILT_IN.split(","))

    _install(monkeypatch, single_distance=NEW)
    for rows in (baseline_rows, detection_rows):
        with pytest.raises(ValueError, match="the baselines of corridor, hog, L3 lack the installed scorer "
                                             "single_distance: they were computed before its plugin was installed"):
            rows([before], "test")
    after = Baselines(meta, {"test": split_baselines(features, settings, positions, [prediction])})
    assert "single_distance" in {row.scorer for row in baseline_rows([after], "test")}
    assert "single_distance" in {row.scorer for row in detection_rows([after], "test")}
