"""The SMR predictor (SPEC section 7): SMOTE + StandardScaler + MLPClassifier, stored without pickle.

``SMRPredictor`` follows scikit-learn's conventions (parameters in ``__init__``, ``fit``/``predict``,
fitted state in attributes ending with ``_``). Its fitted state is a handful of arrays (scaler statistics and
the MLP's weights), so it is saved to HDF5 and loaded back without unpickling anything.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import h5py
import numpy as np
from sklearn.metrics import f1_score
from sklearn.model_selection import StratifiedKFold
from sklearn.neural_network import MLPClassifier
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler

PAPER_PARAMS = {"alpha": 1e-4, "learning_rate_init": 1e-3}  # the authors' code
PAPER_TEXT_PARAMS = {"alpha": 1e-3, "learning_rate_init": 1e-4}  # the paper's text


def smote_neighbours(labels: np.ndarray) -> int:
    """``max(1, min(5, smallest class - 1))``."""
    return max(1, min(5, int(np.bincount(labels)[np.unique(labels)].min()) - 1))


def oversample(features: np.ndarray, labels: np.ndarray, random_state: int = 42) -> tuple[np.ndarray, np.ndarray]:
    """SMOTE on the training samples; returned unchanged when some class has a single sample."""
    from imblearn.over_sampling import SMOTE

    labels = np.asarray(labels)
    counts = np.bincount(labels)[np.unique(labels)]
    if len(counts) < 2 or counts.min() < 2:
        return features, labels
    smote = SMOTE(random_state=random_state, k_neighbors=smote_neighbours(labels))
    return smote.fit_resample(features, labels)


class SMRPredictor:
    """MLP predicting the label (0..3) of a query from its rank-0 attributes."""

    def __init__(
        self,
        hidden_layer_sizes: tuple[int, ...] = (128, 128, 128),
        alpha: float = PAPER_PARAMS["alpha"],
        learning_rate_init: float = PAPER_PARAMS["learning_rate_init"],
        max_iter: int = 10000,
        smote: bool = True,
        random_state: int = 0,
        smote_random_state: int = 42,
    ) -> None:
        self.hidden_layer_sizes = tuple(hidden_layer_sizes)
        self.alpha = alpha
        self.learning_rate_init = learning_rate_init
        self.max_iter = max_iter
        self.smote = smote
        self.random_state = random_state
        self.smote_random_state = smote_random_state

    def get_params(self) -> dict[str, Any]:
        return {
            "hidden_layer_sizes": list(self.hidden_layer_sizes),
            "alpha": self.alpha,
            "learning_rate_init": self.learning_rate_init,
            "max_iter": self.max_iter,
            "smote": self.smote,
            "random_state": self.random_state,
            "smote_random_state": self.smote_random_state,
        }

    def pipeline(self) -> Pipeline:
        return Pipeline([
            ("scaler", StandardScaler()),
            ("mlp", MLPClassifier(
                hidden_layer_sizes=self.hidden_layer_sizes, activation="relu", solver="adam", alpha=self.alpha,
                learning_rate_init=self.learning_rate_init, early_stopping=True, max_iter=self.max_iter,
                random_state=self.random_state,
            )),
        ])

    def fit(self, features: np.ndarray, labels: np.ndarray) -> SMRPredictor:
        features = np.asarray(features, dtype=np.float64)
        labels = np.asarray(labels, dtype=np.int64)
        if len(np.unique(labels)) < 2:
            raise ValueError(
                f"the predictor needs at least two classes among the training labels, got only {np.unique(labels)}"
            )
        if self.smote:
            features, labels = oversample(features, labels, self.smote_random_state)
        fitted = self.pipeline().fit(features, labels)
        scaler, mlp = fitted.named_steps["scaler"], fitted.named_steps["mlp"]
        self.mean_ = scaler.mean_.copy()
        self.scale_ = scaler.scale_.copy()
        self.coefs_ = [c.copy() for c in mlp.coefs_]
        self.intercepts_ = [b.copy() for b in mlp.intercepts_]
        self.classes_ = mlp.classes_.copy()
        self.n_iter_ = int(mlp.n_iter_)
        return self

    def predict_proba(self, features: np.ndarray) -> np.ndarray:
        """Class probabilities, columns in ``classes_`` order: the MLP's forward pass from its stored arrays."""
        hidden = (np.asarray(features, dtype=np.float64) - self.mean_) / self.scale_
        for weights, bias in zip(self.coefs_[:-1], self.intercepts_[:-1], strict=True):
            hidden = np.maximum(hidden @ weights + bias, 0.0)
        logits = hidden @ self.coefs_[-1] + self.intercepts_[-1]
        if logits.shape[1] == 1:  # scikit-learn's binary case: one logistic output
            positive = 1.0 / (1.0 + np.exp(-logits[:, 0]))
            return np.stack([1.0 - positive, positive], axis=1)
        logits = logits - logits.max(axis=1, keepdims=True)
        exp = np.exp(logits)
        return exp / exp.sum(axis=1, keepdims=True)

    def predict(self, features: np.ndarray) -> np.ndarray:
        return self.classes_[np.argmax(self.predict_proba(features), axis=1)]

    def save(self, path: Path | str, **attrs: Any) -> None:
        """Write the fitted arrays to HDF5 (temporary name, then rename)."""
        from .io import atomic_h5

        with atomic_h5(path, {**attrs, "params": self.get_params(), "n_iter": self.n_iter_}) as f:
            f["mean"], f["scale"], f["classes"] = self.mean_, self.scale_, self.classes_
            for i, (w, b) in enumerate(zip(self.coefs_, self.intercepts_, strict=True)):
                f[f"layers/{i}/weights"], f[f"layers/{i}/bias"] = w, b

    @classmethod
    def load(cls, path: Path | str) -> SMRPredictor:
        import json

        with h5py.File(path, "r") as f:
            params = json.loads(f.attrs["params"])
            predictor = cls(**{**params, "hidden_layer_sizes": tuple(params["hidden_layer_sizes"])})
            predictor.mean_, predictor.scale_ = f["mean"][()], f["scale"][()]
            predictor.classes_ = f["classes"][()]
            n_layers = len(f["layers"])
            predictor.coefs_ = [f[f"layers/{i}/weights"][()] for i in range(n_layers)]
            predictor.intercepts_ = [f[f"layers/{i}/bias"][()] for i in range(n_layers)]
            predictor.n_iter_ = int(f.attrs["n_iter"])
        return predictor



def macro_f1(labels: np.ndarray, predicted: np.ndarray) -> float:
    return float(f1_score(labels, predicted, average="macro"))


def cross_validated_f1(
    predictor: SMRPredictor, features: np.ndarray, labels: np.ndarray, n_splits: int = 5, random_state: int = 0
) -> float:
    """Mean macro F1 of stratified k-fold cross-validation, SMOTE applied inside each training fold only."""
    labels = np.asarray(labels)
    n_splits = min(n_splits, int(np.bincount(labels)[np.unique(labels)].max()))
    if n_splits < 2:
        raise ValueError("cross-validation needs at least two samples of some class")
    folds = StratifiedKFold(n_splits=n_splits, shuffle=True, random_state=random_state)
    scores = []
    for train, held_out in folds.split(features, labels):
        fold = SMRPredictor(**{**predictor.get_params(), "hidden_layer_sizes": predictor.hidden_layer_sizes})
        fold.fit(features[train], labels[train])
        scores.append(macro_f1(labels[held_out], fold.predict(features[held_out])))
    return float(np.mean(scores))
