"""The match inspector with a matcher other than seqslam (method §14): each sampled row shows the matcher's own
scores ``s_a`` around its match (a strip from one pass over the split, the filter's state included) where seqslam's
captions read ``S`` off its path; the queries it expects are those the matcher evaluates. Checked against the
plugin ``toy``'s naive rule (tests/toy_plugin.py)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np
import pytest
from helpers import COLOUR_FRAMES, write_distance_matrix
from toy_plugin import PLUGIN_SITE, toy_rule

from vpr_smr.datasets import load_frames
from vpr_smr.eval.matching.matchers import MatcherSpec
from vpr_smr.eval.matching.matchers.base import Matcher
from vpr_smr.eval.matching.sources import TruthSource
from vpr_smr.eval.report import inspector
from vpr_smr.eval.report.inspector import InspectJob
from vpr_smr.pipeline.cli import main as cli

LO, HI, L, TOL = 0, COLOUR_FRAMES, 3, 2


@pytest.fixture
def toy(monkeypatch):
    monkeypatch.syspath_prepend(str(PLUGIN_SITE))


def test_score_strip_by_hand():
    scores = np.arange(30.0)
    first, values = inspector.score_strip(scores, 4, half=3)  # references 1 .. 7
    assert first == 1 and values.tolist() == [1, 2, 3, 4, 5, 6, 7]
    first, values = inspector.score_strip(scores, 28, half=3)  # 25 .. 29: the last reference ends it
    assert first == 25 and values.tolist() == [25, 26, 27, 28, 29]


def test_a_filters_strip_is_its_own_scores_around_the_match(toy, tmp_path, colour_frames):
    d = np.random.default_rng(6).uniform(0.2, 1.0, (HI - LO, HI - LO)).astype(np.float32)
    pair = load_frames("frames", colour_frames)
    distances = tmp_path / "test.h5"
    write_distance_matrix(distances, d, {"split": "test", "split_range": [LO, HI], "method": "m",
                                         "frames_sha256": pair.fingerprint()})
    queries = tmp_path / "q.csv"
    assert cli(["queries", "--distances", str(distances), "--seq-len", str(L), "--matcher", "toy", "--out",
                str(queries)]) in (0, None)
    spec = MatcherSpec.of("toy")
    rows = inspector.read_queries(queries)
    samples = inspector.sample_queries(rows, "all", per_class=2, mistakes=0)  # a single file: split "all"
    record = inspector.draw_matches(tmp_path / "m.png", pair, samples, inspector.SplitMatrix(d, LO), spec.build(L),
                                    "title")
    scores, matches, _ = toy_rule(d.astype(np.float64), 0.5, 1)  # every query from the split's first
    assert record.strips is not None and len(record.strips) == len(samples) > 0
    for sample, (first, values) in zip(samples, record.strips, strict=True):
        a, m = sample.row.query - LO, matches[sample.row.query - LO]
        assert sample.row.sequence_match == m + LO
        assert first == LO + max(0, m - inspector.STRIP_HALF)
        np.testing.assert_allclose(values, scores[a][first - LO : m + inspector.STRIP_HALF + 1], rtol=0, atol=1e-12)
    # seqslam's figure has no strip: its captions give S (only the frames of these rows matter to it)
    fixed = inspector.draw_matches(tmp_path / "f.png", pair, samples, inspector.SplitMatrix(d, LO),
                                   MatcherSpec.of().build(L), "title")
    assert fixed.strips is None
    # the whole stage runs with the matcher it was given, both figures written
    match, matrix = inspector.main(InspectJob(queries=str(queries), distances=str(distances),
                                              match_figure=str(tmp_path / "match.png"),
                                              matrix_figure=str(tmp_path / "matrix.png"), dataset="frames",
                                              dataset_settings=json.dumps(colour_frames), seq_len=L,
                                              truth=TruthSource(tolerance=TOL), matcher=spec))
    assert match.is_file() and matrix.is_file()


@dataclass(frozen=True)
class _Settings:
    pass


class Centred(Matcher):
    """Reads one column after its query: evaluates queries L - 1 .. Q - 2 (never run here)."""

    name = "centred"
    Settings = _Settings
    description = "a test's matcher with a centred window"
    native_scorer = "uniqueness"

    @property
    def lookback(self) -> int:
        return self.seq_len - 1

    @property
    def lookahead(self) -> int:
        return 1

    def check(self, shape: tuple[int, ...], name: str = "distance matrix") -> None:
        pass

    def block(self, columns, first_column, state):  # type: ignore[no-untyped-def]
        raise AssertionError("not run here")


def test_the_expected_queries_are_those_the_matcher_evaluates(toy, tmp_path, monkeypatch):
    rows = [inspector.QueryRow(**_row_fields(q)) for q in range(L - 1, 10)]
    inspector._check_rows(rows, tmp_path / "q.csv", "test", L, 0, 10, MatcherSpec.of("toy"))  # a >= L - 1
    with pytest.raises(ValueError, match=r"has the evaluated queries 2..9 \(those the matcher toy \(decay 0.5, step "
                                         r"1\) matches with a window of L columns\)"):
        inspector._check_rows(rows[1:], tmp_path / "q.csv", "test", L, 0, 10, MatcherSpec.of("toy"))
    import vpr_smr.eval.matching.matchers as matchers

    point = SimpleNamespace(name="centred", load=lambda: Centred)
    monkeypatch.setattr("vpr_smr.core.registry.entry_points",
                        lambda group: [point] if group == matchers.ENTRY_POINT_GROUP else [])
    inspector._check_rows(rows[:-1], tmp_path / "q.csv", "test", L, 0, 10, MatcherSpec.of("centred"))  # 2 .. 8
    with pytest.raises(ValueError, match=r"split 'test' has queries 2..9, but .* has the evaluated queries 2..8"):
        inspector._check_rows(rows, tmp_path / "q.csv", "test", L, 0, 10, MatcherSpec.of("centred"))


def _row_fields(query: int) -> dict:
    return {"split": "test", "query": query, "single_match": query, "single_distance": 0.1, "single_correct": True,
            "sequence_match": query, "sequence_distance": 0.2, "sequence_correct": True, "true_reference": query,
            "label": 0, "predicted_class": None, "probability": None, "kept": None, "matcher": "toy (decay 0.5, "
            "step 1)"}
