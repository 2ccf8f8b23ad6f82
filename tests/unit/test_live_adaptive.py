"""The adaptive live matcher (method §15): per frame the shortest length whose predictor keeps the match, computed
shortest first and stopping at the first kept; on a hand-made schedule and frame by frame against a naive loop over
each length's batch matches and predictions."""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
import pytest
from helpers import seqslam

from vpr_smr.core.constants import KEPT_CLASSES
from vpr_smr.eval.matching.attributes import query_features
from vpr_smr.eval.matching.distances import distance_matrix
from vpr_smr.eval.matching.live import AdaptiveLiveMatcher, LiveMatcher
from vpr_smr.eval.matching.matchers import MatcherSpec
from vpr_smr.eval.predictor.estimator import SMRPredictor

KEEP, DROP = 2, 1  # a kept class and a removed one (method §6)


class Clock:
    """The frame the test feeds next: what the scripted predictors read (test only)."""

    query = -1


class ScriptedPredictor:
    """Keeps the match of the frames in ``kept`` (class 2), removes the others (class 1), and records the frames it
    was asked about: a stand-in whose decisions the test designs, whatever the attributes (test only)."""

    classes_ = np.array([0, 1, 2, 3])

    def __init__(self, clock: Clock, kept: set[int]) -> None:
        self.clock, self.kept, self.asked = clock, kept, []

    def predict_proba(self, features: np.ndarray) -> np.ndarray:
        assert np.asarray(features).shape == (1, 4)
        self.asked.append(self.clock.query)
        probabilities = np.zeros((1, 4))
        probabilities[0, KEEP if self.clock.query in self.kept else DROP] = 1.0
        return probabilities


def test_a_hand_made_schedule_chooses_the_shortest_kept_length_and_computes_no_further():
    # lengths 2, 3, 5; which length's predictor keeps which frame, designed; frames 0..3 have no L = 5 result
    lengths = (2, 3, 5)
    kept = {2: {4, 8, 10}, 3: {5, 9, 10}, 5: {4, 6, 9}}
    # frame: chosen length (None: no predictor kept) and the lengths computed, worked out by hand from `kept`
    expected = {4: (2, (2,)), 5: (3, (2, 3)), 6: (5, (2, 3, 5)), 7: (None, (2, 3, 5)), 8: (2, (2,)),
                9: (3, (2, 3)), 10: (2, (2,)), 11: (None, (2, 3, 5))}
    clock = Clock()
    predictors = [ScriptedPredictor(clock, kept[length]) for length in lengths]
    matrix = np.random.default_rng(5).random((15, 12))
    live = AdaptiveLiveMatcher(lengths, predictors)
    single = {length: LiveMatcher(length) for length in lengths}  # each length alone: the chosen one's result
    for a in range(matrix.shape[1]):
        clock.query = a
        result = live.step_distances(matrix[:, a])
        alone = {length: matcher.step_distances(matrix[:, a]) for length, matcher in single.items()}
        if a < 4:
            assert result is None
            continue
        seq_len, computed = expected[a]
        assert (result.query, result.seq_len, result.computed) == (a, seq_len, computed)
        chosen = alone[5 if seq_len is None else seq_len]
        assert result.result.sequence_match == chosen.sequence_match
        np.testing.assert_array_equal(result.result.attributes, chosen.attributes)
        assert result.result.keep == (seq_len is not None)
    # every predictor was asked about exactly the frames whose computed lengths hold its length
    for length, predictor in zip(lengths, predictors, strict=True):
        assert predictor.asked == [a for a, (_, computed) in expected.items() if length in computed]


def trained_predictors(matrix: np.ndarray, lengths: tuple[int, ...], spec: MatcherSpec) -> list[SMRPredictor]:
    """A small SMRPredictor per length, labelled kept (2) below a quantile of A1 and removed (1) above it, the
    quantile growing with the length so that the lengths keep different frames."""
    predictors = []
    for i, length in enumerate(lengths):
        a1 = query_features(matrix, length, matcher=spec).attributes[:, 0, 0]
        labels = np.where(a1 < np.quantile(a1, 0.3 + 0.2 * i), KEEP, DROP)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the tiny MLP's convergence warning
            predictor = SMRPredictor(hidden_layer_sizes=(16,), max_iter=300, learning_rate_init=0.03,
                                     random_state=i)
            predictors.append(predictor.fit(query_features(matrix, length, matcher=spec).attributes[:, 0], labels))
    return predictors


Expected = dict[int, tuple[int | None, int, tuple[int, ...], np.ndarray]]


def naive_adaptive(matrix: np.ndarray, lengths: tuple[int, ...], predictors: list[Any], spec: MatcherSpec
                   ) -> Expected:
    """Per query a >= L_m - 1: (the shortest length whose predictor keeps its batch match or None, the match at
    that length or the longest's, the lengths up to it, that length's attributes), from each length's batch
    matches and predictions."""
    batch = {length: query_features(matrix, length, matcher=spec) for length in lengths}
    out = {}
    for a in range(lengths[-1] - 1, matrix.shape[1]):
        chosen = None
        for length in lengths:
            n = a - length + 1  # the batch's row of query a (its first query is L - 1)
            assert batch[length].queries[n] == a
            label = predictors[lengths.index(length)].predict(batch[length].attributes[n, :1])[0]
            if label in KEPT_CLASSES:
                chosen = length
                break
        used = lengths[-1] if chosen is None else chosen
        n = a - used + 1
        out[a] = (chosen, int(batch[used].sequence_match[n]), lengths[: lengths.index(used) + 1],
                  batch[used].attributes[n])
    return out


def check_frame_by_frame(live: AdaptiveLiveMatcher, frames: list[np.ndarray], expected: Expected,
                         descriptors: bool = False) -> list[int | None]:
    """Feed ``frames`` (distance columns, or query descriptors) and compare every result with ``expected``; the
    lengths chosen."""
    chosen = []
    for a, frame in enumerate(frames):
        result = live.step(frame) if descriptors else live.step_distances(frame)
        if a not in expected:
            assert result is None
            continue
        seq_len, match, computed, attributes = expected[a]
        assert (result.query, result.seq_len, result.result.sequence_match, result.computed) == (
            a, seq_len, match, computed)
        # the chosen length's attributes (a filter's match is the same at every length; its attributes are not)
        np.testing.assert_array_equal(result.result.attributes, attributes)
        chosen.append(result.seq_len)
    assert len(chosen) == len(expected)
    return chosen


def band(n_ref: int, n_query: int, seed: int) -> np.ndarray:
    """Small distances along the diagonal, so that a filter's belief follows it."""
    rng = np.random.default_rng(seed)
    return rng.random((n_ref, n_query)) + 2.0 * (np.abs(np.arange(n_ref)[:, None] - np.arange(n_query)) > 2)


@pytest.mark.parametrize("spec", [seqslam(), MatcherSpec.of("bayes_filter"), MatcherSpec.of("monotone")],
                         ids=["seqslam", "bayes_filter", "monotone"])
@pytest.mark.parametrize("kind", ["random", "band"])
def test_live_equals_the_naive_loop_over_each_lengths_batch(spec, kind):
    lengths = (2, 4, 6)
    matrix = np.random.default_rng(3).random((60, 60)) if kind == "random" else band(80, 60, 4)
    predictors = trained_predictors(matrix, lengths, spec)
    expected = naive_adaptive(matrix, lengths, predictors, spec)
    live = AdaptiveLiveMatcher(lengths, predictors, matcher=spec)
    chosen = check_frame_by_frame(live, list(matrix.T), expected)
    assert set(chosen) == {*lengths, None}  # every length and none is chosen somewhere: the rule is seen at work


def test_a_real_matrix_from_descriptors_equals_the_naive_loop(sad_frames):
    # the shipped Nordland sample's SAD descriptors, matched live from the descriptors with the file's distance
    path, reference, query = sad_frames
    lengths = (2, 4, 8)
    matrix = distance_matrix(reference, query, "mad")
    predictors = trained_predictors(matrix, lengths, seqslam())
    live = AdaptiveLiveMatcher.from_descriptors(path, lengths, predictors)
    assert live.distance == "mad" and live.method == "sad"
    expected = naive_adaptive(matrix, lengths, predictors, seqslam())
    chosen = check_frame_by_frame(live, list(query), expected, descriptors=True)
    assert set(chosen) == {*lengths, None}


@pytest.fixture(scope="module")
def sad_frames(tmp_path_factory):
    """SAD descriptors of 60 frames of the shipped Nordland sample: the file, its references and queries."""
    import h5py

    from vpr_smr.datasets import load_dataset
    from vpr_smr.descriptors import extract

    pair = load_dataset("sample", {"loader": "nordland_sample", "frames": [1500, 1560],
                                   "splits": {"all": [0, 60]}})
    path = extract.main(pair, "sad", {"backend": "sad"}, tmp_path_factory.mktemp("sad") / "descriptors.h5")
    with h5py.File(path, "r") as f:
        return path, f["reference"][()], f["query"][()]


def test_refusals_name_the_setting_and_the_fix():
    clock = Clock()
    two = [ScriptedPredictor(clock, set()), ScriptedPredictor(clock, set())]
    for lengths in ([4, 2], [3, 3], [4]):
        with pytest.raises(ValueError, match=r"lengths=\[.*\]: an AdaptiveLiveMatcher chooses among two or more "
                                             r"sequence lengths given in strictly increasing order"):
            AdaptiveLiveMatcher(lengths, two[: len(lengths)])
    with pytest.raises(ValueError, match=r"predictors= has 2 predictor\(s\) for lengths=\[2, 4, 8\]: give one per "
                                         r"length"):
        AdaptiveLiveMatcher([2, 4, 8], two)
    with pytest.raises(ValueError, match=r"predictors= has None for the length\(s\) \[4\]"):
        AdaptiveLiveMatcher([2, 4], [two[0], None])
    with pytest.raises(ValueError, match="the matcher 'openseqslam' prepares its state from a pass over the whole"):
        AdaptiveLiveMatcher([2, 4], two, matcher=MatcherSpec.of("openseqslam", {"alignment": "trailing"}))
    with pytest.raises(ValueError, match="matcher= is the matcher 'seqslam' built for sequence length 4: give its "
                                         "MatcherSpec"):
        AdaptiveLiveMatcher([2, 4], two, matcher=MatcherSpec.of().build(4))
    with pytest.raises(ValueError, match=r"AdaptiveLiveMatcher with references needs distance=.*"
                                         r"AdaptiveLiveMatcher.from_descriptors\(path, lengths, predictors\)"):
        AdaptiveLiveMatcher([2, 4], two, references=np.zeros((10, 3)))
    with pytest.raises(ValueError, match="AdaptiveLiveMatcher.step needs references"):
        AdaptiveLiveMatcher([2, 4], two).step(np.zeros(3))


def test_a_column_refused_by_one_length_is_kept_by_none():
    clock = Clock()
    live = AdaptiveLiveMatcher([2, 4], [ScriptedPredictor(clock, set()), ScriptedPredictor(clock, set())])
    with pytest.raises(ValueError, match="3 references are too few for sequence length 4"):
        live.step_distances(np.ones(3))  # enough for L = 2: still not taken by it
    assert [m.frames for m in live.matchers] == [0, 0] and live.frames == 0
    live.step_distances(np.ones(6))
    with pytest.raises(ValueError, match="non-finite"):
        live.step_distances(np.array([1.0, np.nan, 1.0, 1.0, 1.0, 1.0]))
    assert [m.frames for m in live.matchers] == [1, 1] and live.frames == 1
