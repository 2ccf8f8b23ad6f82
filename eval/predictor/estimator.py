"""The SMR predictor (method §§5 and 7): column order, SMOTE, StandardScaler, MLPClassifier; stored without pickle.

``SMRPredictor`` is a scikit-learn estimator (``clone``, ``get_params(deep=True)``, ``cross_validate`` work). Its
``fit`` builds and fits an imbalanced-learn ``Pipeline`` (so SMOTE resamples the training samples only, also inside
every cross-validation fold) and keeps the fitted arrays (scaler statistics, the MLP's weights) as attributes ending
with ``_``. ``predict_proba`` runs the MLP's forward pass from those arrays, so the predictor is saved to HDF5 and
loaded back without unpickling anything.

Callers always pass the attributes in the paper's names order A1, A2, A3, A4 (``QueryFeatures.attributes[:, k, :]``);
``column_order`` (default ``(0, 1, 3, 2)``) picks the network's input columns from them: the authors' code order
``[A1, A2, A4, A3]`` (min sum, min value, group, block), which changes the trained network (method §5).
"""

from __future__ import annotations

import json
import logging
import warnings
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.exceptions import ConvergenceWarning, UndefinedMetricWarning
from sklearn.metrics import f1_score
from sklearn.model_selection import StratifiedKFold, cross_validate
from sklearn.neural_network import MLPClassifier
from sklearn.preprocessing import FunctionTransformer, StandardScaler
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_is_fitted, validate_data

from vpr_smr.core.constants import N_LABELS
from vpr_smr.core.io import open_h5
from vpr_smr.eval.matching.attributes import Matching
from vpr_smr.eval.predictor.defaults import (
    CV_FOLDS,
    DEFAULTS,
    MIN_FIT_SAMPLES,
    MIN_VALIDATION,
    VALIDATION_FRACTION,
)
from vpr_smr.eval.predictor.leakage import Training, read_training, write_training

log = logging.getLogger(__name__)

MATCHING = "matching"  # a predictor file's attribute: the ``Matching`` of the attributes it was trained on
# scikit-learn's MLP catches KeyboardInterrupt in its training loop, warns this, and returns the half-trained network
INTERRUPT_WARNING = "Training interrupted by user."
TRAINING_FIX = ("lengthen the train split (the dataset's `splits` entry named by `train_split`), shorten seq_lens, "
                "or pool more methods")


class TrainingDataError(ValueError):
    """The training labels cannot train the predictor (one class only, or too few samples of a class)."""


def class_counts(labels: np.ndarray) -> list[int]:
    """Samples per label 0..3 (method §6), zeros included."""
    counts: list[int] = np.bincount(np.asarray(labels, dtype=np.int64), minlength=N_LABELS).tolist()
    return counts


def format_counts(counts: Sequence[int]) -> str:
    return ", ".join(f"{label}: {count}" for label, count in enumerate(counts))


def count_text(labels: np.ndarray) -> str:
    """``0: 17, 1: 0, 2: 0, 3: 1``: every label 0..3 (method §6) counted; other labels (scikit-learn's checks) as
    found."""
    labels = np.asarray(labels)
    if labels.dtype.kind in "iu" and (labels.size == 0 or (labels.min() >= 0 and labels.max() < N_LABELS)):
        return format_counts(class_counts(labels))
    values, counts = np.unique(labels, return_counts=True)
    return ", ".join(f"{value}: {count}" for value, count in zip(values, counts, strict=True))


def fit_problem(counts: Iterable[int], smote: bool = True) -> str | None:
    """Why fitting on training labels with these counts per label would fail, or None when it can fit.

    SMOTE (on when ``smote`` and every present class has 2 samples) raises every class to the largest one's
    count; MLPClassifier's early stopping then holds out ``ceil(0.1 n)`` samples, which must be at least 2, and
    stratifies them by class when there are exactly two classes (so each class needs 2 samples).
    """
    present = [int(c) for c in counts if c > 0]
    if len(present) < 2:
        return "one class only, and the predictor needs at least two"
    resampled = [max(present)] * len(present) if smote and min(present) >= 2 else present
    n = sum(resampled)
    if n < MIN_FIT_SAMPLES:
        after = " after SMOTE" if resampled != present else ""
        return (f"{n} samples{after}, fewer than {MIN_FIT_SAMPLES}: early stopping's {VALIDATION_FRACTION:.0%} "
                f"validation split would hold fewer than {MIN_VALIDATION}")
    if len(present) == 2 and min(resampled) < MIN_VALIDATION:
        return ("two classes, one with a single sample: early stopping's validation split is stratified by class "
                f"for two classes and needs {MIN_VALIDATION} samples of each")
    return None


def label_problems(labels: np.ndarray, smote: bool = True, n_splits: int = CV_FOLDS, random_state: int = 0
                   ) -> list[str]:
    """Why ``cross_validated_f1`` and then ``fit`` on ``labels`` (in this order: the folds depend on it) would
    fail; empty when both can run. Exact: the folds are those of ``cross_validated_f1``'s ``StratifiedKFold``."""
    labels = np.asarray(labels)
    counts = np.unique(labels, return_counts=True)[1] if labels.size else np.zeros(1, int)
    problems = []
    folds = min(n_splits, int(counts.max()))
    if folds < 2:
        problems.append("cross-validation needs 2 samples of some class")
    else:
        splitter = StratifiedKFold(n_splits=folds, shuffle=True, random_state=random_state)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "the least populated class has fewer members than folds"
            splits = list(splitter.split(np.zeros((len(labels), 1)), labels))
        for i, (train, _) in enumerate(splits):
            problem = fit_problem(np.unique(labels[train], return_counts=True)[1], smote)
            if problem is not None:
                problems.append(f"cross-validation fold {i + 1} of {folds} trains on class counts "
                                f"{count_text(labels[train])}: {problem}")
                break
    problem = fit_problem(counts, smote)
    if problem is not None:
        problems.append(f"the final fit: {problem}")
    return problems


def check_training_labels(labels: np.ndarray, where: str, smote: bool = True, random_state: int = 0) -> None:
    """Raise ``TrainingDataError`` naming ``where`` (e.g. the dataset and L), the class counts per label and the
    fix when ``label_problems`` finds any."""
    problems = label_problems(labels, smote, random_state=random_state)
    if problems:
        raise TrainingDataError(
            f"{where}: the predictor cannot be trained on {len(labels)} samples with class counts "
            f"{count_text(labels)} (labels 0..3 of method §6): {'; '.join(problems)}. "
            f"Fix: {TRAINING_FIX}")


def smote_neighbours(labels: np.ndarray) -> int:
    """``max(1, min(5, smallest class - 1))``."""
    return max(1, min(5, int(np.unique(labels, return_counts=True)[1].min()) - 1))


def select_columns(features: np.ndarray, columns: tuple[int, ...] | None) -> np.ndarray:
    """``features[:, columns]`` (all columns, in their order, when ``columns`` is None)."""
    return features if columns is None else features[:, list(columns)]


# scikit-learn ships no type information: its base classes are Any to mypy (pyproject's [tool.mypy] overrides)
class SMRPredictor(ClassifierMixin, BaseEstimator):  # type: ignore[misc]
    """MLP predicting the label (0..3) of a query from its rank-0 attributes, given in A1..A4 order.

    ``column_order``: indices into the A1..A4 input fed to the network, in that order (the authors' code order by
    default; ``(k,)`` for attribute ``k`` alone; None for the input as given). ``smote=False`` (or a class with a
    single training sample) skips SMOTE. The other parameters are the MLP's (method §7).
    """

    def __init__(
        self,
        hidden_layer_sizes: Sequence[int] = DEFAULTS["hidden_layer_sizes"],
        alpha: float = DEFAULTS["alpha"],
        learning_rate_init: float = DEFAULTS["learning_rate_init"],
        max_iter: int = DEFAULTS["max_iter"],
        smote: bool = DEFAULTS["smote"],
        random_state: int = DEFAULTS["random_state"],
        smote_random_state: int = DEFAULTS["smote_random_state"],
        column_order: Sequence[int] | None = DEFAULTS["column_order"],
    ) -> None:
        # stored unchanged, as scikit-learn's clone requires; checked and converted in fit
        self.hidden_layer_sizes = hidden_layer_sizes
        self.alpha = alpha
        self.learning_rate_init = learning_rate_init
        self.max_iter = max_iter
        self.smote = smote
        self.random_state = random_state
        self.smote_random_state = smote_random_state
        self.column_order = column_order

    def _columns(self, n_features: int) -> tuple[int, ...] | None:
        if self.column_order is None:
            return None
        columns = tuple(int(c) for c in self.column_order)
        if not columns or any(c < 0 or c >= n_features for c in columns) or len(set(columns)) != len(columns):
            raise ValueError(f"predictor setting column_order={list(self.column_order)} must list distinct column "
                             f"indices of the {n_features} input attributes (0..{n_features - 1}, A1..A4 order)")
        return columns

    def pipeline(self, labels: np.ndarray, n_features: int) -> Any:
        """The unfitted imbalanced-learn pipeline for training labels ``labels`` and ``n_features`` input columns:
        column selection, SMOTE (unless off or a class has a single sample), StandardScaler, MLPClassifier."""
        from imblearn.over_sampling import SMOTE
        from imblearn.pipeline import Pipeline

        steps: list[tuple[str, Any]] = [
            ("columns", FunctionTransformer(select_columns, kw_args={"columns": self._columns(n_features)})),
        ]
        if self.smote and np.unique(labels, return_counts=True)[1].min() >= 2:
            steps.append(("smote", SMOTE(random_state=self.smote_random_state, k_neighbors=smote_neighbours(labels))))
        steps.append(("scaler", StandardScaler()))
        steps.append(("mlp", MLPClassifier(
            hidden_layer_sizes=tuple(self.hidden_layer_sizes), activation="relu", solver="adam", alpha=self.alpha,
            learning_rate_init=self.learning_rate_init, early_stopping=True, max_iter=self.max_iter,
            random_state=self.random_state,
        )))
        return Pipeline(steps)

    def fit(self, X: np.ndarray, y: np.ndarray) -> SMRPredictor:  # noqa: N803 (scikit-learn's argument names)
        """Fit on ``X`` (A1..A4 columns) and labels ``y``; raises ``KeyboardInterrupt`` if interrupted."""
        features, labels = validate_data(self, X, y, dtype=np.float64)
        check_classification_targets(labels)
        if len(np.unique(labels)) < 2:
            raise TrainingDataError(f"the predictor needs at least two classes among the training labels, got one "
                                    f"class only: {np.unique(labels)} ({len(labels)} samples); {TRAINING_FIX}")
        problem = fit_problem(np.unique(labels, return_counts=True)[1], self.smote)
        if problem is not None:  # say what scikit-learn would fail on, and why, with the counts
            raise TrainingDataError(f"the predictor cannot be trained on class counts {count_text(labels)}: "
                                    f"{problem}; {TRAINING_FIX}")
        fitted = self.pipeline(labels, features.shape[1])
        with warnings.catch_warnings():
            # turn the MLP's "interrupted" warning into an error, so that a half-trained network is never kept
            warnings.filterwarnings("error", message=INTERRUPT_WARNING, category=UserWarning)
            try:
                fitted.fit(features, labels)
            except UserWarning as warning:
                if str(warning) == INTERRUPT_WARNING:
                    raise KeyboardInterrupt("predictor training interrupted; nothing was kept") from warning
                raise
        scaler, mlp = fitted.named_steps["scaler"], fitted.named_steps["mlp"]
        self.mean_: np.ndarray = scaler.mean_.copy()
        self.scale_: np.ndarray = scaler.scale_.copy()
        self.coefs_: list[np.ndarray] = [c.copy() for c in mlp.coefs_]
        self.intercepts_: list[np.ndarray] = [b.copy() for b in mlp.intercepts_]
        self.classes_: np.ndarray = mlp.classes_.copy()
        self.n_iter_ = int(mlp.n_iter_)
        return self

    def _plain_input(self, features: Any) -> bool:
        """A finite 2-D float array of the fitted width (what the pipeline always passes)."""
        return (isinstance(features, np.ndarray) and features.ndim == 2 and features.dtype.kind == "f"
                and features.shape[1] == self.n_features_in_ and not hasattr(self, "feature_names_in_")
                and bool(np.isfinite(features).all()))

    def predict_proba(self, features: np.ndarray) -> np.ndarray:
        """Class probabilities, columns in ``classes_`` order: the MLP's forward pass from its stored arrays."""
        if not hasattr(self, "coefs_"):  # check_is_fitted's own test, without its cost per live frame
            check_is_fitted(self, "coefs_")
        if not self._plain_input(features):  # scikit-learn's checks and messages, 150 us a call: not per live frame
            features = validate_data(self, features, dtype=np.float64, reset=False)
        features = np.asarray(features, dtype=np.float64)
        hidden = (select_columns(features, self._columns(features.shape[1])) - self.mean_) / self.scale_
        for weights, bias in zip(self.coefs_[:-1], self.intercepts_[:-1], strict=True):
            hidden = np.maximum(hidden @ weights + bias, 0.0)
        logits = hidden @ self.coefs_[-1] + self.intercepts_[-1]
        if logits.shape[1] == 1:  # scikit-learn's binary case: one logistic output
            positive = 1.0 / (1.0 + np.exp(-logits[:, 0]))
            return np.stack([1.0 - positive, positive], axis=1)
        logits = logits - logits.max(axis=1, keepdims=True)
        exp = np.exp(logits)
        probabilities: np.ndarray = exp / exp.sum(axis=1, keepdims=True)
        return probabilities

    def predict(self, features: np.ndarray) -> np.ndarray:
        check_is_fitted(self, "coefs_")
        predicted: np.ndarray = self.classes_[np.argmax(self.predict_proba(features), axis=1)]
        return predicted

    def save(self, path: Path | str, matching: Matching | None = None, training: Training | None = None,
             **attrs: Any) -> None:
        """Write the parameters and fitted arrays to HDF5 (temporary name, then rename); ``matching``: the
        sequence matcher and ground truth of the attributes it was trained on (``check_matching``; without it
        the stages that apply a predictor refuse the file); ``training``: its length, methods, frames and matrices
        (``leakage.Training``; default its ``training_``, which the Python API's ``train`` records; without a
        length the stages that apply it refuse the file); ``attrs`` as attributes."""
        from vpr_smr.core.io import atomic_h5

        check_is_fitted(self, "coefs_")
        if self.classes_.dtype.kind not in "iub":
            raise ValueError(f"cannot save {path}: the predictor's classes must be integers, got {self.classes_}")
        provenance = {**attrs, "params": self.get_params(), "n_iter": self.n_iter_,
                      "n_features_in": int(self.n_features_in_)}
        if matching is not None:
            provenance[MATCHING] = matching.to_json()
            provenance["matcher"] = matching.matcher.provenance()
        training = training if training is not None else getattr(self, "training_", None)
        with atomic_h5(path, provenance) as f:
            if training is not None:
                write_training(f, training)
            f["mean"], f["scale"], f["classes"] = self.mean_, self.scale_, self.classes_
            for i, (w, b) in enumerate(zip(self.coefs_, self.intercepts_, strict=True)):
                f[f"layers/{i}/weights"], f[f"layers/{i}/bias"] = w, b

    @classmethod
    def load(cls, path: Path | str) -> SMRPredictor:
        """A predictor written by ``save``. Files from before ``column_order`` existed fed the A1..A4 input as given:
        they load with ``column_order=None``."""
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"predictor file not found: {path} (train it first: vpr-smr train)")
        with open_h5(path, "a predictor written by vpr-smr train") as f:
            params = json.loads(f.attrs["params"])
            unknown = set(params) - set(cls._get_param_names())
            if unknown:
                raise ValueError(f"{path}: unknown predictor settings {sorted(unknown)}; was it written by a newer "
                                 f"vpr-smr? Retrain it with this version (vpr-smr train)")
            params["hidden_layer_sizes"] = tuple(params["hidden_layer_sizes"])
            order = params.get("column_order")
            params["column_order"] = None if order is None else tuple(order)
            predictor = cls(**params)
            predictor.mean_, predictor.scale_ = f["mean"][()], f["scale"][()]
            predictor.classes_ = f["classes"][()]
            n_layers = len(f["layers"])
            predictor.coefs_ = [f[f"layers/{i}/weights"][()] for i in range(n_layers)]
            predictor.intercepts_ = [f[f"layers/{i}/bias"][()] for i in range(n_layers)]
            predictor.n_iter_ = int(f.attrs["n_iter"])
            predictor.n_features_in_ = int(f.attrs.get("n_features_in", len(predictor.mean_)))
            stored = f.attrs.get(MATCHING)
            # None: a file from before predictors recorded their matching (check_matching refuses to guess)
            predictor.matching_ = None if stored is None else Matching.from_json(json.loads(stored))
            # its length, methods, frames and matrices (leakage.check_length, check_disjoint, check_matrices)
            predictor.training_ = read_training(f, str(path))
            predictor.seq_len_ = predictor.training_.seq_len
            predictor.path_ = str(path)
        return predictor


def macro_f1(labels: np.ndarray, predicted: np.ndarray) -> float:
    return float(f1_score(labels, predicted, average="macro"))


def cross_validated_f1(
    predictor: SMRPredictor, features: np.ndarray, labels: np.ndarray, n_splits: int = 5, random_state: int = 0,
    where: str = "the pooled train split",
) -> float:
    """Mean macro F1 of stratified k-fold ``cross_validate`` (``min(n_splits, largest class)`` folds) of a clone of
    ``predictor``; SMOTE sits in the predictor's pipeline, so it resamples each training fold only. scikit-learn's
    warnings on the way are logged as one line in our words, naming ``where`` (``fold_warning``)."""
    labels = np.asarray(labels)
    problems = label_problems(labels, predictor.smote, n_splits, random_state)
    if problems:
        raise TrainingDataError(f"cross-validation on class counts {count_text(labels)}: {'; '.join(problems)}; "
                                f"{TRAINING_FIX}")
    n_splits = min(n_splits, int(np.unique(labels, return_counts=True)[1].max()))
    folds = StratifiedKFold(n_splits=n_splits, shuffle=True, random_state=random_state)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scores = cross_validate(predictor, features, labels, cv=folds, scoring="f1_macro", error_score="raise")
    note = fold_warning([w.message for w in caught], labels, n_splits, where)
    if note:
        log.warning(note)
    return float(np.mean(scores["test_score"]))


def fold_warning(messages: Sequence[Warning | str], labels: np.ndarray, n_splits: int, where: str) -> str | None:
    """scikit-learn's warnings of a cross-validation as one line: ``where``, the class counts, and what each kind
    of warning means for the cross-validated F1 (others quoted as scikit-learn words them); None without any."""
    said: dict[str, str] = {}
    for message in messages:
        text = str(message)
        if "least populated class" in text:
            values, counts = np.unique(labels, return_counts=True)
            label, smallest = values[np.argmin(counts)], int(counts.min())
            said["folds"] = (f"class {label} has {smallest} samples for {n_splits} folds, so {n_splits - smallest} "
                             "of the folds test without it: the cross-validated F1 averages folds that score "
                             "different classes, and says less of that class than of the others")
        elif isinstance(message, UndefinedMetricWarning):
            said["undefined"] = ("in some fold a class was never predicted or never present, and its F1 there "
                                 "counts as 0, which lowers the cross-validated F1")
        elif isinstance(message, ConvergenceWarning):
            said["converged"] = ("the network stopped at its max_iter before converging in some fold: the "
                                 "cross-validated F1 is that of an unfinished fit (raise max_iter in the predictor's "
                                 "settings)")
        else:
            said.setdefault(text, f"scikit-learn warned: {text}")
    if not said:
        return None
    return f"{where}, cross-validated on class counts {count_text(labels)}: {'; '.join(said.values())}"


def fit_warning(messages: Sequence[Warning | str], where: str) -> str | None:
    """scikit-learn's warnings of a final fit and its scoring on the evaluation splits as one line: ``where`` and
    what each kind means for the predictor and its F1 (others quoted as scikit-learn words them); None without any."""
    said: dict[str, str] = {}
    for message in messages:
        if isinstance(message, ConvergenceWarning):
            said["converged"] = ("the network stopped at its max_iter before converging: the predictor is an "
                                 "unfinished fit (raise max_iter in the predictor's settings)")
        elif isinstance(message, UndefinedMetricWarning):
            said["undefined"] = ("on an evaluation split a class was never predicted or never present, and its F1 "
                                 "there counts as 0, which lowers that split's macro F1")
        else:
            said.setdefault(str(message), f"scikit-learn warned: {message}")
    return f"{where}: {'; '.join(said.values())}" if said else None
