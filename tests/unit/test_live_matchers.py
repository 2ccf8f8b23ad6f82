"""The live API takes any matcher of the seam (method §14): per frame its match and native confidence, a filter's
state carried from frame to frame, so frame by frame equals the batch (and the naive rule of the plugin ``toy``);
a matcher that needs frames to come (a centred window, a pass over the whole split) is refused naming the fix."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest
from toy_plugin import PLUGIN_SITE, toy_rule

from vpr_smr.core.settings import setting
from vpr_smr.eval.matching.attributes import query_features
from vpr_smr.eval.matching.live import LiveMatcher
from vpr_smr.eval.matching.matchers import MatcherSpec
from vpr_smr.eval.matching.matchers.base import MatchBlock, Matcher
from vpr_smr.eval.scoring.baselines import BaselineSettings, query_scores

L = 3


@pytest.fixture
def toy(monkeypatch):
    monkeypatch.syspath_prepend(str(PLUGIN_SITE))
    import toy_matcher

    return toy_matcher


def live_run(matcher: Any, d: np.ndarray) -> list[Any]:
    live = LiveMatcher(L, matcher=matcher)
    return [live.step_distances(d[:, a]) for a in range(d.shape[1])]


def test_a_filter_live_keeps_its_state_and_equals_the_batch_and_the_naive_rule(toy):
    d = np.random.default_rng(2).random((14, 18))
    results = live_run(MatcherSpec.of("toy", {"decay": 0.75}), d)
    assert results[: L - 1] == [None] * (L - 1)
    batch = query_features(d, L, matcher=MatcherSpec.of("toy", {"decay": 0.75}))
    live = results[L - 1 :]
    assert [r.query for r in live] == batch.queries.tolist()
    assert [r.sequence_match for r in live] == batch.sequence_match.tolist()
    assert [r.sequence_distance for r in live] == batch.sequence_distance.tolist()  # its state carried, bit for bit
    assert [r.native for r in live] == batch.sequence_native.tolist()
    assert np.array_equal([r.attributes for r in live], batch.attributes)
    scores, matches, margins = toy_rule(d, 0.75, 1)  # the naive rule, every query
    assert [r.sequence_match for r in live] == matches[L - 1 :]
    np.testing.assert_allclose([r.native for r in live], margins[L - 1 :], rtol=0, atol=1e-12)


def test_a_matcher_that_names_uniqueness_gives_the_batch_scorers_numbers(toy):
    class Named(toy.ToyMatcher):  # the toy's scores and state, its native confidence uniqueness on them
        native_scorer = "uniqueness"

        def block(self, columns: np.ndarray, first_column: int, state: Any) -> tuple[MatchBlock, Any]:
            found, state = super().block(columns, first_column, state)
            return MatchBlock(found.queries, found.scores, found.match), state

    d = np.random.default_rng(8).random((30, 20))
    built = Named(L, toy.ToySettings())
    settings = BaselineSettings()
    batch = query_features(d, L, matcher=built, n_candidates=settings.candidates)
    expected = query_scores(batch, settings, np.arange(30.0))["native"]
    results = live_run(Named(L, toy.ToySettings()), d)[L - 1 :]  # a built matcher, not a spec
    assert [r.native for r in results] == expected.tolist()
    assert [r.sequence_match for r in results] == batch.sequence_match.tolist()


def test_seqslams_live_native_confidence_is_its_uniqueness():
    d = np.random.default_rng(3).random((30, 16))
    settings = BaselineSettings()
    batch = query_features(d, L, n_candidates=settings.candidates)
    expected = query_scores(batch, settings, np.arange(30.0))["uniqueness"]
    assert [r.native for r in live_run(None, d)[L - 1 :]] == expected.tolist()


@dataclass(frozen=True)
class LongSettings:
    extra: int = setting(2, "columns read before the attributes' window", minimum=0)


class Long(Matcher):
    """A trailing window longer than L: s_a = the sum of D's columns a - L + 1 - extra .. a (no diagonal), its
    native confidence minus the best score."""

    name = "long"
    Settings = LongSettings
    description = "a test's matcher with a long trailing window"

    @property
    def lookback(self) -> int:
        return self.seq_len - 1 + int(self.settings.extra)

    def check(self, shape: tuple[int, ...], name: str = "distance matrix") -> None:
        pass

    def block(self, columns: np.ndarray, first_column: int, state: Any) -> tuple[MatchBlock, Any]:
        c = np.asarray(columns, dtype=np.float64)
        n = len(c) - self.lookback
        scores = np.array([c[i : i + self.lookback + 1].sum(axis=0) for i in range(n)])
        queries = first_column + self.lookback + np.arange(n)
        return MatchBlock(queries, scores, np.argmin(scores, axis=1), -scores.min(axis=1)), state


def test_a_window_longer_than_l_is_kept_and_matched_from_its_first_evaluated_query():
    d = np.random.default_rng(4).random((9, 15))
    results = live_run(Long(L, LongSettings(3)), d)
    assert results[:5] == [None] * 5  # queries 0 .. 4 read fewer than 6 columns
    batch = query_features(d, L, matcher=Long(L, LongSettings(3)), block_queries=4)
    assert batch.queries.tolist() == list(range(5, 15))
    assert [r.sequence_match for r in results[5:]] == batch.sequence_match.tolist()
    assert [r.native for r in results[5:]] == batch.sequence_native.tolist()
    # by hand: query a sums the columns a - 5 .. a
    assert results[7].native == -d[:, 2:8].sum(axis=1).min()


@dataclass(frozen=True)
class AlignedSettings:
    alignment: str = setting("centred", "where the window lies", choices=("centred", "trailing"))


class Aligned(Long):
    name = "aligned"
    Settings = AlignedSettings

    @property
    def lookback(self) -> int:
        return self.seq_len - 1

    @property
    def lookahead(self) -> int:
        return 1 if self.settings.alignment == "centred" else 0


def test_a_centred_window_cannot_run_live_and_is_told_the_setting():
    with pytest.raises(ValueError, match=r"the matcher 'aligned' reads 1 columns after its query \(a centred "
                                         r"window\): a LiveMatcher has no frame to come; give it the setting "
                                         r"alignment: trailing \(its window ends at the query\)"):
        LiveMatcher(L, matcher=Aligned(L, AlignedSettings()))
    LiveMatcher(L, matcher=Aligned(L, AlignedSettings("trailing")))  # causal: accepted


def test_a_matcher_that_needs_the_whole_split_or_another_scorer_is_refused():
    class Prepared(Long):
        def prepare(self, matrix: Any) -> Any:
            return float(np.min(matrix))

    with pytest.raises(ValueError, match=r"the matcher 'long' prepares its state from a pass over the whole split "
                                         r"before its first block \(its prepare\)"):
        LiveMatcher(L, matcher=Prepared(L, LongSettings()))

    class Spread(Long):
        native_scorer = "spread"

    with pytest.raises(ValueError, match=r"the matcher 'long' names the scorer 'spread' as its native confidence, "
                                         r"which a frame's own scores do not give"):
        LiveMatcher(L, matcher=Spread(L, LongSettings()))
    with pytest.raises(ValueError, match=r"the matcher 'long' was built for sequence length 4, not 3"):
        LiveMatcher(L, matcher=Long(4, LongSettings()))


def test_a_built_matcher_is_compared_with_a_loaded_predictors(predictor_file):
    from vpr_smr.eval.predictor.estimator import SMRPredictor

    predictor = SMRPredictor.load(predictor_file)  # trained with seqslam, velocities [1.0]
    LiveMatcher(L, matcher=MatcherSpec.of().build(L), predictor=predictor)  # the same matcher: accepted
    with pytest.raises(ValueError, match=r"was trained on attributes of the matcher seqslam \(velocities \[1.0\]\), "
                                         r"but it is applied to a LiveMatcher \(matcher=\), of the matcher seqslam "
                                         r"\(velocities \[0.5, 1.0\]\)"):
        LiveMatcher(L, matcher=MatcherSpec.of("seqslam", {"velocities": [0.5, 1.0]}).build(L), predictor=predictor)


def test_a_loaded_predictor_of_another_length_is_refused(predictor_file):
    from vpr_smr.eval.matching.live import AdaptiveLiveMatcher
    from vpr_smr.eval.predictor.estimator import SMRPredictor

    predictor = SMRPredictor.load(predictor_file)  # trained at L = 3 (its report says so)
    assert predictor.seq_len_ == 3
    LiveMatcher(3, predictor=predictor)
    with pytest.raises(ValueError, match=r"L3.h5 was trained at sequence length 3, but it is applied at L = 4 \(this "
                                         r"LiveMatcher matches 4 frames\): give the predictor trained at L = 4"):
        LiveMatcher(4, predictor=predictor)
    with pytest.raises(ValueError, match=r"trained at sequence length 3, but it is applied at L = 4 \(this LiveMatcher "
                                         r"matches 4 frames\)"):
        AdaptiveLiveMatcher((3, 4), [predictor, predictor])  # the same file given for both lengths


@pytest.mark.parametrize(("name", "settings"), [
    ("bayes_filter", {}), ("bayes_filter", {"window_lo": -1, "window_hi": 3}), ("monotone", {}),
    ("monotone", {"max_step": 3, "step_penalty": 0.0}), ("seqslam", {"velocities": [0.8, 1.0, 1.25]}),
])
def test_the_built_in_matchers_live_equal_their_batch_frame_by_frame(name, settings):
    # a band of small distances along the diagonal, so that the filter's belief follows it for the whole run
    rng = np.random.default_rng(11)
    d = rng.random((40, 30)) + 2.0 * (np.abs(np.arange(40)[:, None] - np.arange(30)[None, :]) > 2)
    spec = MatcherSpec.of(name, settings)
    batch = query_features(d, L, matcher=spec, n_candidates=BaselineSettings().candidates)
    results = live_run(spec, d)
    live = [r for r in results if r is not None]
    assert [r.query for r in live] == batch.queries.tolist()
    assert [r.sequence_match for r in live] == batch.sequence_match.tolist()
    assert [r.sequence_distance for r in live] == batch.sequence_distance.tolist()
    native = batch.sequence_native if batch.sequence_native is not None else query_scores(
        batch, BaselineSettings(), np.arange(40.0))["native"]
    assert [r.native for r in live] == native.tolist()
    assert np.array_equal([r.attributes for r in live], batch.attributes)


def test_openseqslam_is_refused_live_in_either_alignment():
    for alignment in ("centred", "trailing"):
        with pytest.raises(ValueError, match="the matcher 'openseqslam' prepares its state from a pass over the "
                                             "whole split"):  # in either alignment: no setting would help
            LiveMatcher(4, matcher=MatcherSpec.of("openseqslam", {"alignment": alignment}))
