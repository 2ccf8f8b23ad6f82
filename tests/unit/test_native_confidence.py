"""The matcher's native confidence (method §14) everywhere it is computed: kept per evaluated query by the shared
features code when the matcher gives its own (the plugin ``toy``: the margin from its best score to the second),
stored in and read from the attributes files, the training-free scorer ``native`` (seqslam's: its uniqueness, the
same numbers), and the per-query table's ``c_native`` column. Values are checked against the toy's naive rule
(tests/toy_plugin.py) and a naive SeqSLAM uniqueness written here."""

from __future__ import annotations

import csv
from typing import Any

import h5py
import numpy as np
import pytest
from toy_plugin import PLUGIN_SITE, toy_rule

from vpr_smr.eval.matching.attributes import AttributesJob, query_features, read_features
from vpr_smr.eval.matching.attributes import main as attributes_main
from vpr_smr.eval.matching.matchers import MatcherSpec
from vpr_smr.eval.matching.matchers.base import MatchBlock, Matcher
from vpr_smr.eval.scoring import scorers
from vpr_smr.eval.scoring.baselines import BaselineSettings, check_candidates, query_scores

L = 3


@pytest.fixture
def toy(monkeypatch):
    monkeypatch.syspath_prepend(str(PLUGIN_SITE))


def naive_toy(d: np.ndarray) -> tuple[list[int], list[int], list[float]]:
    """The toy's queries with a window of L columns (it evaluates every query), their matches and margins."""
    _, matches, margins = toy_rule(d, 0.5, 1)
    queries = list(range(L - 1, d.shape[1]))
    return queries, [matches[a] for a in queries], [margins[a] for a in queries]


@pytest.mark.parametrize("block_queries", [1, 3, None])
def test_the_toys_native_confidence_is_kept_per_query_block_by_block(toy, block_queries):
    d = np.random.default_rng(5).random((12, 17))
    queries, matches, margins = naive_toy(d)
    features = query_features(d, L, matcher=MatcherSpec.of("toy"), block_queries=block_queries)
    assert features.queries.tolist() == queries and features.sequence_match.tolist() == matches
    assert features.native_scorer is None and features.sequence_native.dtype == np.float64
    np.testing.assert_allclose(features.sequence_native, margins, rtol=0, atol=1e-12)
    whole = query_features(d, L, matcher=MatcherSpec.of("toy"))
    assert features.sequence_native.tobytes() == whole.sequence_native.tobytes()  # bit for bit, any block size


class _Settings:
    pass


class Silent(Matcher):
    """Every query, the single-frame column as its scores; its native confidence is ``native`` (None: none)."""

    name = "silent"
    Settings = _Settings
    description = "a test's matcher"
    native: Any = None

    @property
    def lookback(self) -> int:
        return 0

    def check(self, shape: tuple[int, ...], name: str = "distance matrix") -> None:
        pass

    def block(self, columns: np.ndarray, first_column: int, state: Any) -> tuple[MatchBlock, Any]:
        scores = np.asarray(columns, dtype=np.float64)
        queries = first_column + np.arange(len(scores))
        native = None if self.native is None else self.native(len(scores))
        return MatchBlock(queries, scores, np.argmin(scores, axis=1), native), state


@pytest.mark.parametrize(("native", "given"), [(None, "none"), (lambda n: np.zeros(n + 1), r"shape \(5,\)"),
                                               (lambda n: np.zeros((n, 1)), r"shape \(4, 1\)")])
def test_a_matcher_that_names_no_scorer_and_gives_no_native_confidence_is_named(native, given):
    matcher = Silent(L, _Settings())
    matcher.native = native
    with pytest.raises(ValueError, match=r"the matcher 'silent' names no scorer of method §12 as its native "
                                         r"confidence \(native_scorer None\), so each block must give it "
                                         r"\(MatchBlock.native of shape \(4,\), one per query\), but a block gave "
                                         f"{given}: give the native confidence in block\\(\\), or name its "
                                         "native_scorer"):
        query_features(np.random.default_rng(1).random((6, 6)), L, matcher=matcher, block_queries=4)


def naive_uniqueness(d: np.ndarray, window: int) -> list[float]:
    """SeqSLAM's uniqueness of every query a >= L-1 on the fixed diagonals' S (r >= L-1), by loops: the smallest S
    farther than ``window`` from the match over the match's (both positive here)."""
    n_ref, n_query = d.shape
    out = []
    for a in range(L - 1, n_query):
        s = {r: sum(d[r - k, a - k] for k in range(L - 1, -1, -1)) for r in range(L - 1, n_ref)}
        best = min(s, key=lambda r: (s[r], r))
        out.append(min(v for r, v in s.items() if abs(r - best) > window) / s[best])
    return out


def test_seqslams_native_confidence_is_its_uniqueness():
    d = np.random.default_rng(7).random((30, 25)) + 0.1
    settings = BaselineSettings()
    features = query_features(d, L, n_candidates=settings.candidates)
    assert features.sequence_native is None and features.native_scorer == "uniqueness"
    scores = query_scores(features, settings, np.arange(30.0))
    np.testing.assert_allclose(scores["native"], naive_uniqueness(d, settings.half_window), rtol=1e-12)
    assert scores["native"].tobytes() == scores["uniqueness"].tobytes()  # the same numbers as that scorer's


def test_the_native_scorer_is_the_toys_margin_higher_is_more_confident(toy):
    d = np.random.default_rng(9).random((20, 20))
    settings = BaselineSettings()
    features = query_features(d, L, matcher=MatcherSpec.of("toy"), n_candidates=settings.candidates)
    scores = query_scores(features, settings, np.arange(20.0))
    np.testing.assert_allclose(scores["native"], naive_toy(d)[2], rtol=0, atol=1e-12)
    assert scores["native"].tolist() != scores["uniqueness"].tolist()  # its own, not the default's
    native = scorers.scorer("native")
    assert native.kind == "training-free" and native.colour == "tab:purple"
    assert native.colour not in {s.colour for s in scorers.entries() if s.name != "native"}


def test_the_attributes_file_stores_it_and_an_old_file_reads(toy, tmp_path):
    d = np.random.default_rng(3).random((15, 15))
    np.save(tmp_path / "D.npy", d)
    toy = MatcherSpec.of("toy")
    attributes_main(AttributesJob(str(tmp_path / "D.npy"), L, matcher=toy, out=str(tmp_path / "toy.h5")))
    attributes_main(AttributesJob(str(tmp_path / "D.npy"), L, out=str(tmp_path / "seqslam.h5")))
    stored = read_features(tmp_path / "toy.h5")
    assert stored.native_scorer is None
    np.testing.assert_allclose(stored.sequence_native, naive_toy(d)[2], rtol=0, atol=1e-12)
    with h5py.File(tmp_path / "seqslam.h5", "r") as f:
        assert "sequence_native" not in f  # seqslam's is a scorer: nothing to store
    fixed = read_features(tmp_path / "seqslam.h5")
    assert fixed.sequence_native is None and fixed.native_scorer == "uniqueness"
    check_candidates(fixed, BaselineSettings(), "seqslam.h5")  # an old seqslam file has all it needs
    with h5py.File(tmp_path / "toy.h5", "a") as f:  # a toy file written before the native confidence was stored
        del f["sequence_native"]
    old = read_features(tmp_path / "toy.h5")
    assert old.sequence_native is None and old.native_scorer is None
    with pytest.raises(ValueError, match=r"toy.h5: the attributes hold no native confidence of their matcher "
                                         r"\(sequence_native: .*\): compute the attributes again with vpr-smr "
                                         "attributes"):
        check_candidates(old, BaselineSettings(), str(tmp_path / "toy.h5"))


def test_the_per_query_table_gives_each_querys_match_and_native_confidence(toy, tmp_path):
    from vpr_smr.pipeline.cli import main

    d = np.random.default_rng(4).random((16, 16))
    np.save(tmp_path / "D.npy", d)
    assert main(["queries", "--distances", str(tmp_path / "D.npy"), "--seq-len", str(L), "--matcher", "toy",
                 "--out", str(tmp_path / "q.csv")]) in (0, None)
    with open(tmp_path / "q.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    queries, matches, margins = naive_toy(d)
    assert [int(r["query"]) for r in rows] == queries
    assert [int(r["sequence_match"]) for r in rows] == matches
    np.testing.assert_allclose([float(r["c_native"]) for r in rows], margins, rtol=0, atol=1e-12)
    assert {r["matcher"] for r in rows} == {"toy (decay 0.5, step 1)"}
