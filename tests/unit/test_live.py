"""The live matcher against the batch computation, frame by frame and rank by rank."""

import numpy as np
import pytest
from helpers import seqslam

from vpr_smr.eval.matching.attributes import query_features
from vpr_smr.eval.matching.distances import distance_matrix
from vpr_smr.eval.matching.live import LiveMatcher


class ThresholdPredictor:
    """A stand-in for SMRPredictor with a known rule: class 2 when A1 < threshold, else class 1 (test only)."""

    classes_ = np.array([0, 1, 2, 3])

    def __init__(self, threshold):
        self.threshold = threshold

    def predict_proba(self, features):
        features = np.asarray(features)
        assert features.shape == (1, 4)
        low = features[:, 0] < self.threshold
        return np.stack([np.zeros(len(features)), (~low) * 1.0, low * 1.0, np.zeros(len(features))], axis=1)


def stopped_train(n_ref=300, n_query=80, seed=0):
    rng = np.random.default_rng(seed)
    matrix = rng.random((n_ref, n_query)).astype(np.float32) + 0.5
    matrix[100:110] = rng.random(n_query).astype(np.float32) * 0.1  # repeated reference frames: exact ties
    matrix[:, 30:45] = matrix[:, 30:31]
    return matrix


@pytest.mark.parametrize("seq_len, velocities", [(2, (1.0,)), (5, (1.0,)), (4, (0.5, 1.0, 1.5, 2.0)),
                                                 (5, (1.25, 2.0))])
def test_live_equals_batch_every_frame(seq_len, velocities):
    # method §11's velocity search too: each frame's result is the batch's for that query, bit for bit
    matrix = stopped_train()
    batch = query_features(matrix, seq_len, matcher=seqslam(*velocities))
    threshold = np.median(batch.attributes[:, 0, 0])
    matcher = LiveMatcher(seq_len, predictor=ThresholdPredictor(threshold), matcher=seqslam(*velocities))
    labels = set()
    for a in range(matrix.shape[1]):
        result = matcher.step_distances(matrix[:, a])
        if a < seq_len - 1:
            assert result is None
            continue
        n = a - seq_len + 1
        assert result.query == a == batch.queries[n]
        assert result.single_match == batch.single_match[n]
        assert result.sequence_match == batch.sequence_match[n]
        assert result.sequence_distance == batch.sequence_distance[n]
        np.testing.assert_array_equal(result.attributes, batch.attributes[n])  # every rank, bit for bit
        np.testing.assert_array_equal(result.rank_references, batch.rank_references[n])
        assert result.label == (2 if batch.attributes[n, 0, 0] < threshold else 1)
        assert result.keep == (result.label == 2)
        labels.add(result.label)
    assert labels == {1, 2}  # both of the stand-in's decisions occur


def test_step_with_references_uses_the_distance_of_eval_distances():
    rng = np.random.default_rng(1)
    references, queries = rng.normal(size=(40, 16)), rng.normal(size=(12, 16))
    for metric in ("l2", "cosine", "mad"):
        matcher = LiveMatcher(3, references=references, distance=metric)
        by_columns = LiveMatcher(3)
        for q in queries:
            column = distance_matrix(references, q[None, :], metric)[:, 0]
            result, expected = matcher.step(q), by_columns.step_distances(column)
            assert (result is None) == (expected is None)
            if result is not None:
                assert result.sequence_match == expected.sequence_match
                np.testing.assert_array_equal(result.attributes, expected.attributes)
                assert result.label is None and result.keep is None
        # and those columns are the batch matrix's, up to float32 rounding of the blocked products
        np.testing.assert_allclose(distance_matrix(references, queries[:1], metric)[:, 0],
                                   distance_matrix(references, queries, metric)[:, 0], rtol=1e-5, atol=1e-6)


def test_errors():
    with pytest.raises(ValueError, match="needs references"):
        LiveMatcher(3).step(np.zeros(8))
    matcher = LiveMatcher(3)
    matcher.step_distances(np.ones(10))
    with pytest.raises(ValueError, match="expected 10 distances"):
        matcher.step_distances(np.ones(9))
    with pytest.raises(ValueError, match="too few"):
        LiveMatcher(4).step_distances(np.ones(3))
    with pytest.raises(ValueError, match=r"too few for sequence length 4 at velocities \[3.0\]"):
        LiveMatcher(4, matcher=seqslam(3.0)).step_distances(np.ones(9))  # the trajectory spans 10 references
    with pytest.raises(ValueError, match="must be > 0, got 0.0"):
        LiveMatcher(4, matcher=seqslam(0.0, 1.0))
    matcher = LiveMatcher(2)
    matcher.step_distances(np.ones(10))
    with pytest.raises(ValueError, match="non-finite"):
        matcher.step_distances(np.full(10, np.nan))
