"""Small hand-made training sets of the predictor: attributes shifted by their label, written in the attributes
stage's layout, and a predictor trained on one (the training, leakage, records and metrics tests)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vpr_smr.eval.matching.attributes import QueryFeatures, write_features

PARAMS = {"hidden_layer_sizes": [12, 12], "max_iter": 40}


def method_samples(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A small hand-made set of one method: labels 0..3 (0 most common), A1..A4 shifted by the label."""
    rng = np.random.default_rng(seed)
    y = np.array([0] * (n // 2) + [1] * (n // 6) + [2] * (n // 6) + [3] * (n - n // 2 - 2 * (n // 6)))
    x = rng.normal(size=(n, 4)) + y[:, None] * np.array([0.8, -0.5, 0.3, 1.1])
    return x, y


def write_samples(path, x, y):
    """``x`` as the rank-0 attributes and ``y`` as the labels of an attributes file (no provenance)."""
    n = len(y)
    attributes = np.zeros((n, 2, 4))
    attributes[:, 0], attributes[:, 1] = x, x + 10.0  # rank 1 must never be used for training
    features = QueryFeatures(
        queries=np.arange(n) + 3, attributes=attributes, rank_references=np.zeros((n, 2), int),
        single_match=np.zeros(n, int), sequence_match=np.zeros(n, int), sequence_distance=np.linspace(0, 1, n),
        labels=y, single_correct=np.ones(n, bool), sequence_correct=np.ones(n, bool),
        rank_correct=np.ones((n, 2), bool), sequence_min=0.0, sequence_max=1.0,
        all_single_correct=np.ones(n + 3, bool))
    write_features(path, features, {})
    return path


def features_with_range(n, seed, frames):
    """A small training set (``method_samples``) whose provenance says which frames it came from."""
    x, y = method_samples(n, seed)
    attributes = np.zeros((n, 1, 4))
    attributes[:, 0] = x
    return QueryFeatures(
        queries=np.arange(n) + 2, attributes=attributes, rank_references=np.zeros((n, 1), int),
        single_match=np.zeros(n, int), sequence_match=np.zeros(n, int), sequence_distance=np.linspace(0, 1, n),
        labels=y, single_correct=np.ones(n, bool), sequence_correct=np.ones(n, bool),
        rank_correct=np.ones((n, 1), bool), sequence_min=0.0, sequence_max=1.0,
        all_single_correct=np.ones(n + 2, bool)), {"dataset": "d", "split": "train", "split_range": list(frames)}


def train_predictor(folder: Path) -> Path:
    """A predictor trained at L = 3 on frames 0..47 of dataset "d" (``features_with_range``, ``PARAMS``)."""
    from vpr_smr.eval.predictor import train

    features, provenance = features_with_range(48, 0, (0, 48))
    write_features(folder / "train.h5", features, provenance)
    train.main(train_job([folder / "train.h5"], folder / "L3.h5", PARAMS, seq_len=3))
    return folder / "L3.h5"


# --- the predictor stages' job records, as the tests give them (paths as text, the others at their defaults) -------


def _texts(paths):
    return tuple(str(path) for path in paths)


def train_job(train, out, params=None, evaluate=None, seeds=1, dataset="d", seq_len=4, validation=None,
              allow_split_overlap=False):
    """The ``train`` stage's job of these files (``evaluate``: split name -> files)."""
    from vpr_smr.eval.predictor.defaults import PredictorParams, PredictorTraining
    from vpr_smr.eval.predictor.jobs import TrainJob

    return TrainJob(dataset, seq_len, _texts(train),
                    None if evaluate is None else {name: _texts(files) for name, files in evaluate.items()},
                    PredictorTraining(PredictorParams.of(params), validation, allow_split_overlap), seeds, str(out))


def ablation_job(train, out, params=None, evaluate=None, dataset="d", seq_len=4, allow_split_overlap=False):
    """The ``ablation attributes`` stage's job of these files (``evaluate``: split name -> files)."""
    from vpr_smr.eval.predictor.defaults import PredictorParams
    from vpr_smr.eval.predictor.jobs import AttributeAblationJob

    return AttributeAblationJob(dataset, seq_len, PredictorParams.of(params), _texts(train),
                                None if evaluate is None else {name: _texts(files) for name, files in evaluate.items()},
                                allow_split_overlap, str(out))


def without_job(train, method, out, params=None, evaluate=None, dataset="d", seq_len=4, validation=None):
    """The ``ablation without`` stage's job: ``train`` method -> file, ``evaluate`` split -> (method -> file)."""
    from vpr_smr.eval.predictor.defaults import PredictorParams, PredictorTraining
    from vpr_smr.eval.predictor.jobs import WithoutJob

    splits = None if evaluate is None else {name: tuple(f"{m}={path}" for m, path in files.items())
                                            for name, files in evaluate.items()}
    return WithoutJob(dataset, seq_len, method, {m: str(path) for m, path in train.items()}, splits,
                      PredictorTraining(PredictorParams.of(params), validation), str(out))


def evaluate_job(attributes, predictors, out, modes=("paper", "standard"), trust_levels=(0.0, 0.5, 0.7, 0.9, 1.0),
                 restoration=True, allow_split_overlap=False, dataset="d", method="m", seq_len=4):
    """The ``evaluate`` stage's job: ``attributes`` split -> file, the seeds' predictor files."""
    from vpr_smr.eval.predictor.jobs import EvaluateJob

    return EvaluateJob(dataset, method, seq_len, {name: str(path) for name, path in attributes.items()},
                       _texts(predictors), tuple(modes), tuple(trust_levels), restoration, allow_split_overlap,
                       str(out))


def held_out_job(attributes, pooled, without, out, modes=("paper", "standard"), allow_split_overlap=False,
                 dataset="d", method="m", seq_len=4):
    """The ``ablation held-out`` stage's job."""
    from vpr_smr.eval.predictor.jobs import HeldOutJob

    return HeldOutJob(dataset, method, seq_len, str(attributes), str(pooled), str(without), tuple(modes),
                      allow_split_overlap, str(out))
