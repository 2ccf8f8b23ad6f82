"""The fast ``without_correct`` and ``columns`` of positions and frames (sorted runs found by bisection, a k-d tree for
2-D) against the naive pass over every reference x query cell, and against cells counted by hand."""

import numpy as np
import pytest

from vpr_smr.eval.matching import ground_truth
from vpr_smr.eval.matching.ground_truth import GroundTruth


def naive_without_correct(truth):
    """Every cell: a query is without a correct reference when ``correct`` holds for none."""
    n_reference, n_query = truth.shape
    return np.array([not any(truth.correct(r, q) for r in range(n_reference)) for q in range(n_query)])


def naive_columns(truth, queries):
    return np.array([[bool(truth.correct(r, q)) for q in queries] for r in range(truth.shape[0])], dtype=bool)


def test_a_band_cut_at_the_matrix_edges_by_hand():
    # references 0..5, queries 0..3 of a split starting 4 frames later (references 4..9 of the whole run), within 1:
    # query 0 (frame 4) has reference 0 (frame 4) and 1; query 3 (frame 7) has 2, 3, 4; a split of references
    # 0..1 (frames 4, 5) leaves queries 2 and 3 (frames 6, 7) without any
    whole = GroundTruth.aligned(12, 12, 1)
    truth = whole.sliced((4, 10), (4, 8))
    assert truth.without_correct().tolist() == [False, False, False, False]
    assert naive_columns(truth, range(4))[:, 3].tolist() == [False, False, True, True, True, False]
    assert np.array_equal(truth.columns(np.arange(4)), naive_columns(truth, range(4)))
    short = whole.sliced((4, 6), (4, 8))
    assert short.without_correct().tolist() == [False, False, False, True]
    # frame 7 is 2 frames from frame 5: without; frame 6 is 1 from 5: with
    late = whole.sliced((0, 3), (4, 8))  # references 0..2, queries frames 4..7: frame 4 is 2 from 2
    assert late.without_correct().tolist() == [True, True, True, True]
    assert whole.sliced((0, 12), (0, 12)).without_correct().tolist() == [False] * 12


@pytest.mark.parametrize("tolerance", [0, 1, 3])
@pytest.mark.parametrize(("references", "queries"), [((0, 20), (0, 20)), ((5, 12), (0, 20)), ((0, 4), (10, 20)),
                                                     ((15, 20), (0, 17)), ((0, 1), (0, 3))])
def test_frames_equal_the_naive_pass(tolerance, references, queries):
    truth = GroundTruth.aligned(20, 20, tolerance).sliced(references, queries)
    assert np.array_equal(truth.without_correct(), naive_without_correct(truth))
    picked = np.array([queries[1] - queries[0] - 1, 0, (queries[1] - queries[0]) // 2])
    assert np.array_equal(truth.columns(picked), naive_columns(truth, picked))


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("radius", [0.0, 0.1, 0.3, 2.5])
def test_1d_positions_equal_the_naive_pass(seed, radius):
    rng = np.random.default_rng(seed)
    # one decimal: repeated positions and differences exactly at the radius; unsorted references too
    references = np.round(rng.normal(size=int(rng.integers(1, 30))) * 3, 1)
    queries = np.round(rng.normal(size=int(rng.integers(1, 30))) * 3, 1)
    for reference_positions in (references, np.sort(references)):
        truth = GroundTruth.positions(reference_positions, queries, radius)
        assert np.array_equal(truth.without_correct(), naive_without_correct(truth))
        assert np.array_equal(truth.columns(np.arange(len(queries))), naive_columns(truth, range(len(queries))))


def test_1d_positions_where_rounding_decides():
    # a query at 0.1 + 0.2 + 0.3 = 0.6000000000000001, radius 0.3: the reference at 0.9000000000000001 is not within
    # it (the difference rounds to 0.30000000000000004), though it is <= q + 0.3 (0.9000000000000001 too); the one at
    # 0.9 is (0.29999999999999993). A bound taken from q + radius would count both.
    queries = np.array([0.1 + 0.2 + 0.3, 1e16, -1e16])
    references = np.array([0.0, 0.9, 0.9000000000000001, 1e16 + 2])
    truth = GroundTruth.positions(references, queries, 0.3)
    assert truth.correct(np.array([1, 2]), np.array([0, 0])).tolist() == [True, False]
    assert truth.columns(np.arange(3))[:, 0].tolist() == [False, True, False, False]
    assert truth.without_correct().tolist() == [False, True, True]
    assert np.array_equal(truth.columns(np.arange(3)), naive_columns(truth, range(3)))
    lone = GroundTruth.positions(np.array([0.0, 0.9000000000000001]), queries[:1], 0.3)
    assert lone.without_correct().tolist() == [True]


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("radius", [0.0, 0.5, 1.0, 2.5])
@pytest.mark.parametrize("margin", [ground_truth.ND_MARGIN, 3.0])
def test_2d_positions_through_the_tree_equal_the_naive_pass(monkeypatch, seed, radius, margin):
    monkeypatch.setattr(ground_truth, "ND_TREE_CELLS", 0)  # the tree for any size
    # a wide margin sends most queries whose nearest reference is wrong through the search within the radius
    monkeypatch.setattr(ground_truth, "ND_MARGIN", margin)
    rng = np.random.default_rng(seed)
    references = np.round(rng.normal(size=(int(rng.integers(1, 30)), 2)) * 3, 1)
    queries = np.round(rng.normal(size=(int(rng.integers(1, 30)), 2)) * 3, 1)
    queries[::3] = references[rng.integers(0, len(references), len(queries[::3]))]  # some exactly on a reference
    truth = GroundTruth.positions(references, queries, radius)
    assert np.array_equal(truth.without_correct(), naive_without_correct(truth))


def test_2d_positions_by_hand(monkeypatch):
    # references on a 3-4-5 triangle's corners: a query 5 from (0, 0) is within 5 and not within 4.99
    monkeypatch.setattr(ground_truth, "ND_TREE_CELLS", 0)
    references = np.array([[0.0, 0.0], [10.0, 10.0]])
    queries = np.array([[3.0, 4.0], [20.0, 20.0], [10.0, 13.0]])
    assert GroundTruth.positions(references, queries, 5.0).without_correct().tolist() == [False, True, False]
    assert GroundTruth.positions(references, queries, 4.99).without_correct().tolist() == [True, True, False]
    assert GroundTruth.positions(references, queries, 2.0).without_correct().tolist() == [True, True, True]


def test_2d_positions_where_the_tree_names_another_nearest(monkeypatch):
    # A tree that rounds its distances otherwise than ``correct`` may name a wrong reference as the nearest, at a
    # distance within the radius: its answer is then checked against every reference it finds within the radius.
    # Here the tree names the second nearest at the nearest's distance.
    from scipy import spatial

    class SecondNearest(spatial.cKDTree):
        def query(self, x, k=1, **kwargs):
            distance, index = super().query(x, k=2, **kwargs)
            return distance[:, 0], index[:, 1]

    monkeypatch.setattr(spatial, "cKDTree", SecondNearest)
    monkeypatch.setattr(ground_truth, "ND_TREE_CELLS", 0)
    references = np.array([[0.0, 0.0], [0.0, 3.0], [10.0, 0.0]])
    queries = np.array([[0.0, 1.0], [10.0, 1.5], [0.0, 1.5], [5.0, 9.0]])
    # query 0: reference 0 at 1 (the tree names reference 1, 2 away, at 1); query 1: reference 2 at 1.5 (the tree
    # names 0 or 1); query 2: 0 and 1 at 1.5; query 3: the nearest is 1 at 7.8, none within 1.6
    truth = GroundTruth.positions(references, queries, 1.6)
    assert truth.without_correct().tolist() == [False, False, False, True]
    assert truth.without_correct().tolist() == naive_without_correct(truth).tolist()


def test_columns_of_a_matrix_and_of_2d_positions_equal_the_naive_cells():
    rng = np.random.default_rng(3)
    correct = rng.random((13, 9)) < 0.3
    correct[:, 4] = False  # a query without any correct reference
    matrix = GroundTruth.matrix(correct)
    picked = np.array([8, 0, 4, 4])
    assert np.array_equal(matrix.columns(picked), correct[:, picked])
    assert np.array_equal(matrix.columns(slice(2, 6)), correct[:, 2:6])
    assert matrix.without_correct().tolist() == (~correct.any(axis=0)).tolist()
    positions = GroundTruth.positions(rng.normal(size=(13, 2)), rng.normal(size=(9, 2)), 0.8)
    assert np.array_equal(positions.columns(picked), naive_columns(positions, picked))
