import numpy as np
import pytest

from vpr_smr.eval.matching.distances import distance_matrix


@pytest.fixture
def descriptors():
    rng = np.random.default_rng(0)
    return rng.normal(size=(7, 16)).astype(np.float32), rng.normal(size=(5, 16)).astype(np.float32)


def test_squared_l2_of_normalised(descriptors):
    reference, query = descriptors
    r = reference / np.linalg.norm(reference, axis=1, keepdims=True)
    q = query / np.linalg.norm(query, axis=1, keepdims=True)
    naive = np.array([[np.sum((r[i] - q[j]) ** 2) for j in range(5)] for i in range(7)])
    out = distance_matrix(reference, query, "l2")
    assert out.shape == (7, 5) and out.dtype == np.float32
    np.testing.assert_allclose(out, naive, rtol=1e-5, atol=1e-6)


def test_cosine(descriptors):
    reference, query = descriptors
    naive = np.array([[1 - reference[i] @ query[j] / np.linalg.norm(reference[i]) / np.linalg.norm(query[j])
                       for j in range(5)] for i in range(7)])
    np.testing.assert_allclose(distance_matrix(reference, query, "cosine"), naive, rtol=1e-5, atol=1e-6)


def test_mean_absolute_difference(descriptors):
    reference, query = descriptors
    naive = np.array([[np.mean(np.abs(reference[i] - query[j])) for j in range(5)] for i in range(7)])
    np.testing.assert_allclose(distance_matrix(reference, query, "mad", block=3), naive, rtol=1e-5)


def test_errors(descriptors):
    reference, query = descriptors
    with pytest.raises(ValueError, match="same dimension"):
        distance_matrix(reference, query[:, :8])
    with pytest.raises(ValueError, match="unknown distance metric"):
        distance_matrix(reference, query, "manhattan")
