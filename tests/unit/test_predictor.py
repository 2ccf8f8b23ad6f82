"""SMRPredictor: a scikit-learn estimator equal to a hand-built SMOTE + scaler + MLP, stored without pickle."""

import warnings

import numpy as np
import pytest
from imblearn.over_sampling import SMOTE
from sklearn.base import clone
from sklearn.datasets import make_classification
from sklearn.metrics import f1_score
from sklearn.model_selection import StratifiedKFold, cross_validate
from sklearn.neural_network import MLPClassifier
from sklearn.preprocessing import StandardScaler
from sklearn.utils.estimator_checks import check_estimator

from vpr_smr.eval.predictor.estimator import SMRPredictor, cross_validated_f1, smote_neighbours

SMALL = {"hidden_layer_sizes": (16, 16), "max_iter": 60}


@pytest.fixture(scope="module")
def data():
    x, y = make_classification(n_samples=240, n_features=4, n_informative=4, n_redundant=0, n_classes=4,
                               weights=[.5, .1, .15, .25], random_state=3)
    return x, y


def reference_network(x, y, columns, smote_seed=42, mlp_seed=0, hidden=(16, 16), max_iter=60):
    """The authors' steps written out by hand: their column order, SMOTE, scaler, MLP (method §§5 and 7)."""
    x = x[:, list(columns)]
    counts = np.bincount(y)[np.unique(y)]
    x, y = SMOTE(random_state=smote_seed, k_neighbors=max(1, min(5, counts.min() - 1))).fit_resample(x, y)
    scaler = StandardScaler().fit(x)
    mlp = MLPClassifier(hidden_layer_sizes=hidden, activation="relu", solver="adam", alpha=1e-4,
                        learning_rate_init=1e-3, early_stopping=True, max_iter=max_iter, random_state=mlp_seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # max_iter reached
        mlp.fit(scaler.transform(x), y)
    return scaler, mlp


def fit(predictor, x, y):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return predictor.fit(x, y)


def test_smote_neighbours():
    assert smote_neighbours(np.array([0] * 50 + [1] * 3 + [2] * 10)) == 2
    assert smote_neighbours(np.array([0] * 50 + [1] * 20)) == 5
    assert smote_neighbours(np.array([0] * 5 + [3] * 2)) == 1


def test_get_params_and_clone_round_trip():
    predictor = SMRPredictor(hidden_layer_sizes=(8, 4), alpha=0.5, learning_rate_init=0.01, max_iter=7, smote=False,
                             random_state=3, smote_random_state=9, column_order=(2, 0))
    expected = {"hidden_layer_sizes": (8, 4), "alpha": 0.5, "learning_rate_init": 0.01, "max_iter": 7,
                "smote": False, "random_state": 3, "smote_random_state": 9, "column_order": (2, 0)}
    assert predictor.get_params(deep=True) == expected
    copy = clone(predictor)
    assert copy is not predictor and copy.get_params(deep=True) == expected
    assert copy.set_params(alpha=2.0).alpha == 2.0 and predictor.alpha == 0.5
    # the defaults: the authors' code
    assert SMRPredictor().get_params() == {
        "hidden_layer_sizes": (128, 128, 128), "alpha": 1e-4, "learning_rate_init": 1e-3, "max_iter": 10000,
        "smote": True, "random_state": 0, "smote_random_state": 42, "column_order": (0, 1, 3, 2)}


def test_clone_of_a_fitted_predictor_is_unfitted(data):
    fitted = fit(SMRPredictor(**SMALL), *data)
    assert hasattr(fitted, "coefs_") and not hasattr(clone(fitted), "coefs_")


def test_scikit_learn_estimator_checks():
    # column_order=None: the checks feed 1 to 10 features; the default order needs the four attributes.
    # A small, fast-learning network so that the checks' accuracy thresholds are met within seconds.
    predictor = SMRPredictor(hidden_layer_sizes=(16,), learning_rate_init=0.05, max_iter=200, column_order=None)
    skipped = {
        "check_estimators_nan_inf": "fits 10 samples of 2 classes first; early_stopping=True (method §7) holds out a "
                                    "stratified 10 % (one sample), fewer than the number of classes",
    }
    results = check_estimator(predictor, expected_failed_checks=skipped, on_skip=None, on_fail=None)
    failed = [(r["check_name"], repr(r["exception"])) for r in results if r["status"] == "failed"]
    assert failed == []
    assert sum(r["status"] == "passed" for r in results) >= 50


def test_fit_equals_hand_built_reference_in_the_code_column_order(data):
    x, y = data
    predictor = fit(SMRPredictor(**SMALL), x, y)
    scaler, mlp = reference_network(x, y, columns=[0, 1, 3, 2])
    np.testing.assert_array_equal(predictor.mean_, scaler.mean_)
    np.testing.assert_array_equal(predictor.scale_, scaler.scale_)
    for ours, theirs in zip(predictor.coefs_ + predictor.intercepts_, mlp.coefs_ + mlp.intercepts_, strict=True):
        np.testing.assert_array_equal(ours, theirs)
    assert predictor.n_iter_ == mlp.n_iter_
    # the forward pass from the stored arrays, fed A1..A4, equals scikit-learn's on the code-ordered columns
    np.testing.assert_allclose(predictor.predict_proba(x), mlp.predict_proba(scaler.transform(x[:, [0, 1, 3, 2]])),
                               rtol=1e-9, atol=1e-12)
    # the column order changes the network
    identity = fit(SMRPredictor(**SMALL, column_order=(0, 1, 2, 3)), x, y)
    assert not np.array_equal(identity.coefs_[0], predictor.coefs_[0])
    _, mlp_identity = reference_network(x, y, columns=[0, 1, 2, 3])
    np.testing.assert_array_equal(identity.coefs_[0], mlp_identity.coefs_[0])


def test_single_attribute_and_no_smote(data):
    x, y = data
    alone = fit(SMRPredictor(**SMALL, column_order=(2,), smote=False), x, y)
    scaler = StandardScaler().fit(x[:, [2]])
    mlp = MLPClassifier(hidden_layer_sizes=(16, 16), early_stopping=True, max_iter=60, random_state=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mlp.fit(scaler.transform(x[:, [2]]), y)
    assert alone.coefs_[0].shape == (1, 16)
    np.testing.assert_array_equal(alone.coefs_[0], mlp.coefs_[0])
    with pytest.raises(ValueError, match="column_order"):
        SMRPredictor(column_order=(0, 4)).fit(x, y)


def test_binary_forward_pass_equals_sklearn(data):
    x, y = data
    y = (y > 1).astype(int)
    predictor = fit(SMRPredictor(hidden_layer_sizes=(8,), max_iter=200, smote=False), x, y)
    scaler = StandardScaler().fit(x[:, [0, 1, 3, 2]])
    mlp = MLPClassifier(hidden_layer_sizes=(8,), early_stopping=True, max_iter=200, random_state=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mlp.fit(scaler.transform(x[:, [0, 1, 3, 2]]), y)
    np.testing.assert_allclose(predictor.predict_proba(x), mlp.predict_proba(scaler.transform(x[:, [0, 1, 3, 2]])),
                               rtol=1e-9, atol=1e-12)
    np.testing.assert_array_equal(predictor.predict(x), mlp.predict(scaler.transform(x[:, [0, 1, 3, 2]])))


def test_save_load_round_trip_predicts_as_the_fitted_pipeline(tmp_path, data):
    x, y = data
    predictor = fit(SMRPredictor(hidden_layer_sizes=(8, 8), max_iter=100, column_order=(3, 1, 0)), x, y)
    predictor.save(tmp_path / "p.h5")
    loaded = SMRPredictor.load(tmp_path / "p.h5")
    pipeline = predictor.pipeline(y, 4)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pipeline.fit(x, y)
    probe = np.random.default_rng(1).normal(size=(50, 4))
    np.testing.assert_allclose(loaded.predict_proba(probe), pipeline.predict_proba(probe), rtol=1e-9, atol=1e-12)
    np.testing.assert_array_equal(loaded.predict_proba(probe), predictor.predict_proba(probe))
    # a list goes through scikit-learn's validation, an array through the fast path: the same numbers
    np.testing.assert_array_equal(loaded.predict_proba(probe.tolist()), loaded.predict_proba(probe))
    np.testing.assert_array_equal(loaded.predict(x), pipeline.predict(x))
    assert loaded.get_params() == predictor.get_params()
    assert loaded.column_order == (3, 1, 0) and loaded.n_iter_ == predictor.n_iter_
    assert [p.name for p in tmp_path.iterdir()] == ["p.h5"]  # no temporary file left


def test_file_without_column_order_feeds_the_input_as_given(tmp_path, data):
    # predictors saved before column_order existed were trained on A1..A4 as given
    import json

    import h5py

    x, y = data
    predictor = fit(SMRPredictor(**SMALL, column_order=None), x, y)
    predictor.save(tmp_path / "old.h5")
    with h5py.File(tmp_path / "old.h5", "r+") as f:
        params = json.loads(f.attrs["params"])
        del params["column_order"]
        f.attrs["params"] = json.dumps(params)
        del f.attrs["n_features_in"]
    loaded = SMRPredictor.load(tmp_path / "old.h5")
    assert loaded.column_order is None
    np.testing.assert_array_equal(loaded.predict_proba(x), predictor.predict_proba(x))


def test_cross_validation_uses_cross_validate_with_smote_inside_folds(data, monkeypatch):
    x, y = data
    seen = []
    original = SMOTE.fit_resample

    def spy(self, features, labels, **kwargs):
        seen.append(len(labels))
        return original(self, features, labels, **kwargs)

    monkeypatch.setattr(SMOTE, "fit_resample", spy)
    predictor = SMRPredictor(hidden_layer_sizes=(8,), max_iter=50)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        score = cross_validated_f1(predictor, x, y)
        # the same folds and scores by scikit-learn's cross_validate, and by hand with sklearn's f1_score
        direct = cross_validate(predictor, x, y, cv=StratifiedKFold(5, shuffle=True, random_state=0),
                                scoring="f1_macro")["test_score"]
        by_hand = []
        for train, held in StratifiedKFold(5, shuffle=True, random_state=0).split(x, y):
            fold = clone(predictor).fit(x[train], y[train])
            by_hand.append(f1_score(y[held], fold.predict(x[held]), average="macro"))
    assert seen[:5] == [192] * 5  # SMOTE saw the training folds only, never all 240 samples
    assert score == pytest.approx(np.mean(direct)) == pytest.approx(np.mean(by_hand))
    assert not hasattr(predictor, "coefs_")  # cross-validation fits clones


def test_interrupted_fit_raises_and_keeps_nothing(data, monkeypatch):
    # scikit-learn's MLP catches KeyboardInterrupt inside its epoch loop and returns the half-trained network
    x, y = data
    calls = []
    original = MLPClassifier._update_no_improvement_count

    def interrupt_at_third_epoch(self, *args, **kwargs):
        calls.append(1)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return original(self, *args, **kwargs)

    monkeypatch.setattr(MLPClassifier, "_update_no_improvement_count", interrupt_at_third_epoch)
    predictor = SMRPredictor(**SMALL)
    with pytest.raises(KeyboardInterrupt):
        predictor.fit(x, y)
    assert len(calls) == 3 and not hasattr(predictor, "coefs_")
    # the same interruption on the MLP alone is swallowed by scikit-learn (why fit must check)
    calls.clear()
    with pytest.warns(UserWarning, match="Training interrupted by user"):
        MLPClassifier(hidden_layer_sizes=(4,), early_stopping=True, max_iter=10).fit(x, y)


def test_single_class_is_an_error():
    with pytest.raises(ValueError, match="two classes"):
        SMRPredictor().fit(np.zeros((5, 4)), np.zeros(5, dtype=int))


def test_load_missing_file_names_it(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.h5"):
        SMRPredictor.load(tmp_path / "nope.h5")
