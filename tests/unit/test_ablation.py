"""Attribute ablation (Table II) and leave-one-method-out training, on hand-made samples."""

import json

import numpy as np
import pytest
from helpers import make_features
from sklearn.metrics import f1_score
from training_sets import ablation_job, held_out_job, train_job, without_job

from vpr_smr.eval.matching.attributes import write_features
from vpr_smr.eval.predictor.ablation import attribute_f1, attributes_main, train_without
from vpr_smr.eval.predictor.estimator import SMRPredictor
from vpr_smr.eval.scoring.held_out import main as held_out_main

PARAMS = {"hidden_layer_sizes": (16,), "max_iter": 400, "learning_rate_init": 0.05}


def separable_by_a2(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Labels 0 and 3 decided by A2 alone (far apart), the other attributes pure noise."""
    rng = np.random.default_rng(seed)
    y = np.repeat([0, 3], n // 2)
    x = rng.normal(size=(n, 4))
    x[:, 1] = np.where(y == 0, -3.0, 3.0) + 0.3 * rng.normal(size=n)
    return x, y


def test_the_attribute_that_separates_the_classes_alone_scores_highest():
    test = [separable_by_a2(60, 2), separable_by_a2(40, 3)]
    f1 = attribute_f1(separable_by_a2(120, 0), {"check": [separable_by_a2(60, 1)], "final": test}, params=PARAMS)
    assert list(f1) == ["A1", "A2", "A3", "A4", "all"]
    assert f1["A2"].columns == (1,) and f1["all"].columns is None and list(f1["A2"].splits) == ["check", "final"]

    def numbers(scores):
        return (scores.f1_cv, *(getattr(scores.splits[split], key) for split in ("check", "final")
                                for key in ("f1", "f1_method_mean")))

    for number in range(5):
        assert numbers(f1["A2"])[number] >= 0.98 and numbers(f1["all"])[number] >= 0.9
        # noise alone: about chance (0.5) on two balanced classes, far below A2
        assert max(numbers(f1[name])[number] for name in ("A1", "A3", "A4")) < 0.8
    assert f1["A2"].splits["final"].n == 100 and f1["A2"].splits["check"].n == 60
    # the method mean: the mean of each method's own macro F1 (a predictor of A2 alone, fitted as attribute_f1 fits it)
    predictor = SMRPredictor(**{**PARAMS, "column_order": (1,)}).fit(*separable_by_a2(120, 0))
    expected = np.mean([f1_score(y, predictor.predict(x), average="macro") for x, y in test])
    assert f1["A2"].splits["final"].f1_method_mean == pytest.approx(expected, abs=1e-12)


def _write(path, x, y):
    n = len(y)
    features = make_features(np.ones(n, bool), np.ones((n, 1), bool), sequence_distance=np.linspace(0.1, 1, n),
                             attributes=x[:, None, :].copy(), labels=y, queries=np.arange(n) + 1,
                             single_match=np.zeros(n, int), single_correct=np.ones(n, bool),
                             sequence_match=np.arange(n), rank_references=np.zeros((n, 1), int),
                             all_single_correct=np.ones(n + 1, bool))
    write_features(path, features, {})
    return path


def test_attributes_main_writes_every_attribute_set(tmp_path):
    train = _write(tmp_path / "train.h5", *separable_by_a2(80, 0))
    test = _write(tmp_path / "test.h5", *separable_by_a2(40, 1))
    result = attributes_main(ablation_job([train], tmp_path / "t2.json", PARAMS, evaluate={"test": [test]}))
    written = json.loads((tmp_path / "t2.json").read_text())
    assert written["n_train"] == 80 and set(written["attributes"]) == {"A1", "A2", "A3", "A4", "all"}
    assert written["attributes"]["A2"]["splits"]["test"]["f1"] == result.attributes["A2"].splits["test"].f1 >= 0.98
    assert written["attributes"]["A2"]["columns"] == [1] and written["attributes"]["all"]["columns"] is None


def test_leave_one_method_out_never_reads_the_held_out_method(tmp_path):
    a = _write(tmp_path / "a.h5", *separable_by_a2(40, 0))
    b = _write(tmp_path / "b.h5", *separable_by_a2(40, 1))
    missing = tmp_path / "held_out_train_does_not_exist.h5"  # reading it would fail
    out = tmp_path / "without_c.h5"
    report = train_without(without_job({"a": a, "c": missing, "b": b}, "c", out, PARAMS))
    assert report.n_train == 80 and report.meta["trained_on"] == ["a", "b"]
    assert report.meta["held_out"] == "c"
    # the same predictor as one trained on a then b directly
    x = np.concatenate([separable_by_a2(40, 0)[0], separable_by_a2(40, 1)[0]])
    y = np.concatenate([separable_by_a2(40, 0)[1], separable_by_a2(40, 1)[1]])
    direct_path = tmp_path / "direct.h5"
    from vpr_smr.eval.predictor import train

    train.main(train_job([a, b], direct_path, PARAMS))
    probe = np.random.default_rng(5).normal(size=(30, 4))
    np.testing.assert_array_equal(SMRPredictor.load(out).predict_proba(probe),
                                  SMRPredictor.load(direct_path).predict_proba(probe))
    assert len(y) == len(x) == 80

    test_c = _write(tmp_path / "test_c.h5", *separable_by_a2(40, 2))
    result = held_out_main(held_out_job(test_c, direct_path, out, tmp_path / "lomo.json", modes=("standard",),
                                        method="c"))
    assert result.without.f1_macro == result.pooled.f1_macro
    assert set(json.loads((tmp_path / "lomo.json").read_text())["predictors"]) == {"pooled", "without"}
    assert json.loads((tmp_path / "lomo.json").read_text())["n_queries"] == 40
