"""The baselines figure's note of undefined reductions is readable: drawn whole, and covered by neither the legend
nor the axes and their labels (hand-made records of three methods, four reductions undefined)."""

from __future__ import annotations

import numpy as np
import pytest
from row_records import records

from vpr_smr.eval.report import figures
from vpr_smr.eval.report.baselines import Comparison
from vpr_smr.eval.report.rows import BaselineRow

METHODS = ("hog", "sad", "netvlad")
VALUES = {"uniqueness": 12.0, "single_uniqueness": 8.0, "spread": -3.0, "distance": 5.0, "random": 2.0,
          "oracle": 60.0, "predictor": 20.0}
UNDEFINED = {("netvlad", "spread"), ("netvlad", "distance"), ("netvlad", "uniqueness"), ("sad", "predictor")}


def rows():
    out = []
    for method in METHODS:
        for scorer, value in VALUES.items():
            row = {"method": method, "scorer": scorer, "outcome": "improved"}
            if (method, scorer) in UNDEFINED:
                row.update(reduction_pct=None, outcome="removed_all" if scorer == "predictor" else "nothing_to_reduce")
            elif scorer == "random":
                row.update(reduction_pct_mean=value, reduction_pct_std=1.5)
            else:
                row["reduction_pct"] = value
            out.append(row)
    return out


def overlap(a, b):
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


@pytest.fixture
def drawn(monkeypatch):
    """The figure a call draws, kept instead of saved: ``drawn["fig"]``."""
    kept = {}

    def keep(fig, path):
        kept["fig"] = fig
        return path

    monkeypatch.setattr(figures, "save", keep)
    return kept


def test_the_note_is_covered_by_nothing(tmp_path, drawn):
    comparison = Comparison("corridor", "paper", 5, METHODS, "uniqueness", (20.0, None, 18.0), (12.0, 12.0, None),
                            (60.0, 60.0, 60.0), (3, 4, 5))
    figures.baselines_figure(tmp_path / "b.png", records(BaselineRow, rows()), comparison,
                             "corridor, L=5, paper mode: AOC reduction")
    fig = drawn["fig"]
    renderer = fig.canvas.get_renderer()
    (ax,) = fig.axes
    (note,) = fig.texts
    text = note.get_text()
    for method, scorer in UNDEFINED:
        assert f"{method}: {scorer} (" in text.replace("\n", " ")
    assert "sad: predictor (removed every match)" in text.replace("\n", " ")
    box = note.get_window_extent(renderer)
    assert box.y0 >= 0 and box.x0 >= 0 and box.x1 <= fig.bbox.x1  # whole on the canvas
    legends = [*fig.legends, *[legend for legend in [ax.get_legend()] if legend is not None]]
    assert legends
    for legend in legends:
        assert not overlap(box, legend.get_window_extent(renderer))
    assert not overlap(box, ax.get_tightbbox(renderer))  # the axes with their tick labels and the legend
    figures._pyplot().close(fig)


def test_without_an_undefined_reduction_there_is_no_note(tmp_path, monkeypatch):
    drawn = {}
    monkeypatch.setattr(figures, "save", lambda fig, path: drawn.setdefault("fig", fig) and path)
    defined = [r for r in rows() if r.get("reduction_pct", 0.0) is not None]
    comparison = Comparison("corridor", "paper", 5, METHODS, "uniqueness", (20.0, 20.0, 20.0), (12.0, 12.0, 12.0),
                            (60.0, 60.0, 60.0), (3, 4, 5))
    figures.baselines_figure(tmp_path / "b.png", records(BaselineRow, defined), comparison, "corridor")
    assert drawn["fig"].texts == []
    figures._pyplot().close(drawn["fig"])


def test_each_bar_carries_its_interval_and_random_its_seed_spread(tmp_path, drawn):
    with_intervals = []
    for row in rows():
        if row.get("reduction_pct") is not None:  # each scorer's interval: 4 below its value, 6 above
            value = row["reduction_pct"]
            row.update(reduction_pct_ci_low=value - 4.0, reduction_pct_ci_high=value + 6.0)
        with_intervals.append(row)
    comparison = Comparison("corridor", "paper", 5, METHODS, "uniqueness", (20.0, None, 18.0), (12.0, 12.0, None),
                            (60.0, 60.0, 60.0), (3, 4, 5))
    figures.baselines_figure(tmp_path / "b.png", records(BaselineRow, with_intervals), comparison, "corridor")
    (ax,) = drawn["fig"].axes
    # every error bar's vertical segments: the predictor's hog bar (20) reaches 16 to 26, random's (2 ± 1.5) 0.5 to 3.5
    spans = {tuple(np.round(np.asarray(segment)[:, 1], 6)) for collection in ax.collections
             for segment in collection.get_segments() if np.asarray(segment).ndim == 2}
    assert (16.0, 26.0) in spans and (0.5, 3.5) in spans and (8.0, 18.0) in spans  # uniqueness: 12 - 4 to 12 + 6
    figures._pyplot().close(drawn["fig"])
