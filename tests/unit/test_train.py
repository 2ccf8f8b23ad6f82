"""The training recipe (method §7): pooled in the given order, shuffled with the seed, the code's column order,
seeds."""

import json
import warnings

import h5py
import numpy as np
import pytest
from imblearn.over_sampling import SMOTE
from sklearn.metrics import f1_score
from sklearn.model_selection import StratifiedKFold
from sklearn.neural_network import MLPClassifier
from sklearn.preprocessing import StandardScaler
from sklearn.utils import shuffle
from training_sets import PARAMS, method_samples, train_job, write_samples

from vpr_smr.eval.predictor import train
from vpr_smr.eval.predictor.estimator import SMRPredictor


@pytest.fixture
def files(tmp_path):
    parts = {name: method_samples(n, seed) for name, n, seed in (("a", 48, 0), ("b", 36, 1), ("val", 30, 2),
                                                                   ("test", 24, 3))}
    return parts, {name: write_samples(tmp_path / f"{name}.h5", *xy) for name, xy in parts.items()}


def authors_recipe(x, y, shuffle_seed=0, smote_seed=42, mlp_seed=0, columns=(0, 1, 3, 2)):
    """The authors' training code written out: shuffle, their column order, SMOTE, scaler, MLP."""
    if shuffle_seed is not None:
        x, y = shuffle(x, y, random_state=shuffle_seed)
    x = x[:, list(columns)]
    k = max(1, min(5, np.bincount(y).min() - 1))
    x, y = SMOTE(random_state=smote_seed, k_neighbors=k).fit_resample(x, y)
    scaler = StandardScaler().fit(x)
    mlp = MLPClassifier(hidden_layer_sizes=(12, 12), activation="relu", solver="adam", alpha=1e-4,
                        learning_rate_init=1e-3, early_stopping=True, max_iter=40, random_state=mlp_seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mlp.fit(scaler.transform(x), y)
    return mlp


def test_pooled_stacks_rank_zero_in_the_given_order(files):
    parts, paths = files
    x, y = train.pooled([paths["b"], paths["a"]])
    np.testing.assert_array_equal(x, np.concatenate([parts["b"][0], parts["a"][0]]))
    np.testing.assert_array_equal(y, np.concatenate([parts["b"][1], parts["a"][1]]))
    with pytest.raises(FileNotFoundError, match="missing.h5"):
        train.pooled([paths["a"], paths["a"].with_name("missing.h5")])


def test_seeded_params_shift_both_seeds():
    assert train.seeded_params({}, 0) == {"random_state": 0, "smote_random_state": 42}
    assert train.seeded_params({"alpha": 0.1}, 3) == {"alpha": 0.1, "random_state": 3, "smote_random_state": 45}
    assert train.seeded_params({"random_state": 7, "smote_random_state": 1}, 2) == {
        "random_state": 9, "smote_random_state": 3}


def test_seed_zero_is_the_authors_recipe_and_the_shuffle_and_order_matter(files, tmp_path):
    parts, paths = files
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = train.main(train_job([paths["a"], paths["b"]], tmp_path / "p.h5", PARAMS, seeds=2))
    x = np.concatenate([parts["a"][0], parts["b"][0]])
    y = np.concatenate([parts["a"][1], parts["b"][1]])
    ours = SMRPredictor.load(tmp_path / "p.h5")
    expected = authors_recipe(x, y)
    for got, want in zip(ours.coefs_ + ours.intercepts_, expected.coefs_ + expected.intercepts_, strict=True):
        np.testing.assert_array_equal(got, want)
    assert report.seeds[0].n_iter == expected.n_iter_
    # seed 1 shifts the shuffle, SMOTE and MLP seeds together
    seed1 = SMRPredictor.load(tmp_path / "p.seed1.h5")
    np.testing.assert_array_equal(seed1.coefs_[0], authors_recipe(x, y, 1, 43, 1).coefs_[0])
    assert not np.array_equal(seed1.coefs_[0], ours.coefs_[0])
    # each training detail changes the network: no shuffle, the paper's column order, the other pooling order
    for changed in (authors_recipe(x, y, shuffle_seed=None), authors_recipe(x, y, columns=(0, 1, 2, 3)),
                    authors_recipe(np.concatenate([parts["b"][0], parts["a"][0]]),
                                   np.concatenate([parts["b"][1], parts["a"][1]]))):
        assert not np.array_equal(changed.coefs_[0], ours.coefs_[0])


def test_report_per_seed_and_files(files, tmp_path):
    parts, paths = files
    out = tmp_path / "pred" / "L4.h5"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = train.main(train_job([paths["a"], paths["b"]], out, PARAMS,
                                      evaluate={"val": [paths["val"]], "test": [paths["test"]]}, seeds=3))
    assert sorted(p.name for p in out.parent.iterdir()) == ["L4.h5", "L4.json", "L4.seed1.h5", "L4.seed2.h5"]
    written = json.loads(out.with_suffix(".json").read_text())
    assert written == json.loads(json.dumps(report.to_json()))
    assert written["seed_models"] == [str(out), str(out.with_name("L4.seed1.h5")), str(out.with_name("L4.seed2.h5"))]
    assert [s["seed"] for s in written["seeds"]] == [0, 1, 2]
    seed2 = written["seeds"][2]["params"]
    assert seed2["random_state"] == 2 and seed2["smote_random_state"] == 44
    # every seed once: no top-level copy of seed 0's numbers (PredictorReport.first_seed gives them)
    assert set(written) == {"format", "meta", "n_train", "seeds", "seed_models"}
    first = written["seeds"][0]
    assert report.first_seed()["f1_val"] == first["splits"]["val"]["f1"] and report.first_seed()["n_test"] == 24
    # the numeric environment (BLAS kernel and threads) is recorded beside the given meta
    given = {key: value for key, value in written["meta"].items() if key != "environment"}
    assert {pool["api"] for pool in written["meta"]["environment"]["thread_pools"]} >= {"blas"}
    # the attributes files record no matcher (written as by vpr-smr 0.10): seqslam with velocities [1.0]
    assert given == {"dataset": "d", "seq_len": 4, "matcher": {"name": "seqslam", "settings": {"velocities": [1.0]}}}
    assert first["params"]["column_order"] == [0, 1, 3, 2]
    assert written["n_train"] == 84 and first["splits"]["val"]["n"] == 30 and first["splits"]["test"]["n"] == 24
    # class counts worked out from method_samples: n//2 zeros, n//6 ones and twos, the rest threes
    assert first["train_class_counts"] == [24 + 18, 8 + 6, 8 + 6, 8 + 6]
    assert written["seeds"][2]["train_class_counts"] == [42, 14, 14, 14]
    assert {name: s["class_counts"] for name, s in written["seeds"][2]["splits"].items()} == {
        "val": [15, 5, 5, 5], "test": [12, 4, 4, 4]}
    seed_files = (out, out.with_name("L4.seed1.h5"), out.with_name("L4.seed2.h5"))
    for seed_report, path in zip(written["seeds"], seed_files, strict=True):
        predictor = SMRPredictor.load(path)
        for split in ("val", "test"):
            x, y = parts[split]
            predicted = predictor.predict(x)
            matrix = np.zeros((4, 4), int)
            np.add.at(matrix, (y, predicted), 1)  # rows true label, columns predicted
            assert seed_report["splits"][split]["confusion"] == matrix.tolist()
            assert seed_report["splits"][split]["f1"] == pytest.approx(
                np.mean([2 * matrix[c, c] / (matrix[c].sum() + matrix[:, c].sum()) for c in range(4)
                         if matrix[c].sum() + matrix[:, c].sum()]))
    with h5py.File(out, "r") as f:  # the predictor files hold the report; the other seed's a report of its seed
        assert json.loads(f.attrs["report"]) == written
    with h5py.File(out.with_name("L4.seed2.h5"), "r") as f:
        assert json.loads(f.attrs["report"])["seeds"] == written["seeds"][2:]


def test_only_the_first_seed_is_cross_validated_and_the_fit_does_not_depend_on_it(files, tmp_path):
    parts, paths = files
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = train.main(train_job([paths["a"], paths["b"]], tmp_path / "p.h5", PARAMS, seeds=2))
        unchecked = train.fit(train_job([paths["a"], paths["b"]], tmp_path / "q.h5", PARAMS, seeds=2),
                              cross_validate=False)
        # seed 0's cross-validation written out: 5 stratified folds (seeded 0) of the shuffled pooled samples, SMOTE
        # fitted on each training fold only (the predictor's pipeline), the mean macro F1 of the held-out folds
        x, y = shuffle(*(np.concatenate(a) for a in zip(parts["a"], parts["b"], strict=True)), random_state=0)
        scores = []
        for fit, held in StratifiedKFold(5, shuffle=True, random_state=0).split(x, y):
            model = SMRPredictor(**train.seeded_params(PARAMS, 0)).fit(x[fit], y[fit])
            scores.append(f1_score(y[held], model.predict(x[held]), average="macro"))
    assert report.seeds[0].f1_cv == pytest.approx(np.mean(scores), abs=1e-12)
    assert report.seeds[1].f1_cv is None and [s.f1_cv for s in unchecked.seeds] == [None, None]
    assert json.loads((tmp_path / "p.json").read_text())["seeds"][1]["f1_cv"] is None
    for a, b in (("p.h5", "q.h5"), ("p.seed1.h5", "q.seed1.h5")):  # the folds fit clones: the same predictor
        first, second = SMRPredictor.load(tmp_path / a), SMRPredictor.load(tmp_path / b)
        assert all(np.array_equal(u, v) for u, v in zip(first.coefs_, second.coefs_, strict=True))
        assert first.n_iter_ == second.n_iter_


def test_single_seed_report_has_no_seed_models(files, tmp_path):
    _, paths = files
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = train.main(train_job([paths["a"]], tmp_path / "p.h5", PARAMS))
    assert report.seed_models is None and len(report.seeds) == 1 and report.n_train == 48
    assert "seed_models" not in json.loads((tmp_path / "p.json").read_text())
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith("p.")) == ["p.h5", "p.json"]


def test_interrupted_training_writes_nothing(files, tmp_path, monkeypatch):
    _, paths = files
    calls = []
    original = MLPClassifier._update_no_improvement_count

    def interrupt(self, *args, **kwargs):
        calls.append(1)
        # two epochs a fit: seed 0 (5 folds + final fit) takes 12 calls, seed 1 (its fit alone: only the first seed
        # is cross-validated) 2; call 13 is in the fit of seed 1, after seed 0 has finished
        if len(calls) == 13:
            raise KeyboardInterrupt
        return original(self, *args, **kwargs)

    monkeypatch.setattr(MLPClassifier, "_update_no_improvement_count", interrupt)
    out = tmp_path / "out"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(KeyboardInterrupt):
            train.main(train_job([paths["a"], paths["b"]], out / "p.h5", {**PARAMS, "max_iter": 2}, seeds=2))
    assert len(calls) == 13
    assert not out.exists() or list(out.iterdir()) == []


def test_bad_settings_are_named(files, tmp_path):
    from vpr_smr.core.settings import parse
    from vpr_smr.eval.predictor.jobs import TrainJob

    _, paths = files
    with pytest.raises(ValueError, match="unknown predictor settings.*'layers'"):
        train.predictor_params({"layers": [3]})
    with pytest.raises(ValueError, match=r"--predictor\.layers: unexpected setting 'layers'"):
        train_job([paths["a"]], tmp_path / "p.h5", {"layers": [3]})
    job = {"dataset": "d", "seq_len": 4, "train": [str(paths["a"])], "out": str(tmp_path / "p.h5")}
    with pytest.raises(ValueError, match=r"job\.seeds: .*must be >= 1, got 0"):
        parse(TrainJob, {**job, "seeds": 0}, "job")
    with pytest.raises(ValueError, match=r"job\.train: .*give at least 1"):
        parse(TrainJob, {**job, "train": []}, "job")
