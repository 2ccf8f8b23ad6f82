import numpy as np
import pytest
from sklearn.datasets import make_classification

from vpr_smr.eval.predictor import SMRPredictor, cross_validated_f1, oversample, smote_neighbours


@pytest.fixture(scope="module")
def data():
    x, y = make_classification(n_samples=240, n_features=4, n_informative=4, n_redundant=0, n_classes=4,
                               weights=[.5, .1, .15, .25], random_state=3)
    return x, y


def test_smote_neighbours():
    assert smote_neighbours(np.array([0] * 50 + [1] * 3 + [2] * 10)) == 2
    assert smote_neighbours(np.array([0] * 50 + [1] * 20)) == 5
    assert smote_neighbours(np.array([0] * 5 + [3] * 2)) == 1


def test_oversample_balances_classes(data):
    x, y = data
    xs, ys = oversample(x, y)
    counts = np.bincount(ys)
    assert counts.min() == counts.max() == np.bincount(y).max()
    np.testing.assert_array_equal(xs[: len(x)], x)  # originals first, then synthetic samples


def test_forward_pass_equals_sklearn(data):
    # The stored-array forward pass must reproduce scikit-learn's own pipeline on the same training data.
    x, y = data
    predictor = SMRPredictor(hidden_layer_sizes=(16, 16), max_iter=300).fit(x, y)
    xs, ys = oversample(x, y)
    reference = predictor.pipeline().fit(xs, ys)
    np.testing.assert_allclose(predictor.predict_proba(x), reference.predict_proba(x), rtol=1e-9, atol=1e-12)
    np.testing.assert_array_equal(predictor.predict(x), reference.predict(x))


def test_binary_forward_pass_equals_sklearn(data):
    x, y = data
    y = (y > 1).astype(int)
    predictor = SMRPredictor(hidden_layer_sizes=(8,), max_iter=200, smote=False).fit(x, y)
    reference = predictor.pipeline().fit(x, y)
    np.testing.assert_allclose(predictor.predict_proba(x), reference.predict_proba(x), rtol=1e-9, atol=1e-12)


def test_save_load_round_trip(tmp_path, data):
    x, y = data
    predictor = SMRPredictor(hidden_layer_sizes=(8, 8), max_iter=100).fit(x, y)
    predictor.save(tmp_path / "p.h5")
    loaded = SMRPredictor.load(tmp_path / "p.h5")
    np.testing.assert_array_equal(loaded.predict_proba(x), predictor.predict_proba(x))
    assert loaded.get_params() == predictor.get_params()
    assert not (tmp_path / "p.h5.tmp").exists()


def test_cross_validation_resamples_inside_folds_only(data, monkeypatch):
    # Every call to SMOTE must see only training-fold samples: 4/5 of the data, never all of it.
    x, y = data
    seen = []
    import vpr_smr.eval.predictor as module

    original = module.oversample

    def spy(features, labels, random_state=42):
        seen.append(len(labels))
        return original(features, labels, random_state)

    monkeypatch.setattr(module, "oversample", spy)
    score = cross_validated_f1(SMRPredictor(hidden_layer_sizes=(8,), max_iter=50), x, y)
    assert seen == [192] * 5
    assert 0.0 <= score <= 1.0


def test_single_class_is_an_error():
    with pytest.raises(ValueError, match="two classes"):
        SMRPredictor().fit(np.zeros((5, 4)), np.zeros(5, dtype=int))
