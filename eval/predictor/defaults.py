"""The predictor's defaults (method §7) and what its training needs, in a module without scikit-learn so that
validating and checking a configuration stays fast: ``SMRPredictor``'s keyword defaults are these values, a
validated configuration carries all of them, and the check before the first job asks ``training_problems``.

The settings of the stages that train or score predictors are declared here once (``core.settings``):
``PredictorParams`` (``--predictor``, the predictor's settings as given), ``allow_split_overlap()`` and the option
group ``PredictorTraining`` (the predictor, the validation split, the overlap switch) that ``train`` and ``ablation
without`` share."""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from vpr_smr.core.json_objects import json_object
from vpr_smr.core.settings import parse, setting

PAPER_PARAMS = {"alpha": 1e-4, "learning_rate_init": 1e-3}  # the authors' code (the paper's text says 1e-3 / 1e-4)
CODE_COLUMN_ORDER = (0, 1, 3, 2)  # A1..A4 -> the authors' input [A1, A2, A4, A3] (min sum, min value, group, block)


@dataclass(frozen=True)
class PredictorSettings:
    """The SMR predictor's settings (``SMRPredictor``'s arguments and defaults); validation fills every one of them
    in."""

    hidden_layer_sizes: tuple[int, ...] = setting(
        (128, 128, 128), "neurons of each hidden layer of the MLP", minimum=1)
    alpha: float = setting(
        PAPER_PARAMS["alpha"], "the MLP's L2 penalty; default: the authors' code's value (the paper's text gives 1e-3)",
        minimum=0)
    learning_rate_init: float = setting(
        PAPER_PARAMS["learning_rate_init"], "the MLP's initial learning rate (adam); default: the authors' code's "
        "value (the paper's text gives 1e-4)", exclusive_minimum=0)
    max_iter: int = setting(
        10000, "the most epochs of the MLP's training (early stopping usually ends it sooner)", minimum=1)
    smote: bool = setting(True, "oversample the training samples with SMOTE (inside every cross-validation fold too)")
    random_state: int = setting(0, "the MLP's seed for predictor seed 0; seed s adds s")
    smote_random_state: int = setting(42, "SMOTE's seed for predictor seed 0; seed s adds s")
    column_order: tuple[int, ...] | None = setting(
        CODE_COLUMN_ORDER, "the network's input columns as indices of (A1, A2, A3, A4); default: the authors' code's "
        "order (method §7); null keeps A1..A4", minimum=0, maximum=3, min_items=4, max_items=4, unique=True)


# SMRPredictor's keyword defaults, by name
DEFAULTS: dict[str, Any] = dataclasses.asdict(PredictorSettings())


@dataclass(frozen=True)
class PredictorParams:
    """The predictor's settings as a stage is given them (``--predictor``): a JSON object of some of
    ``PredictorSettings``'s settings, each checked, the others at the predictor's defaults. Those given are kept as
    given (Table II records them), as canonical JSON text so that the record stays frozen and comparable."""

    text: str = "{}"

    @classmethod
    def of(cls, settings: Mapping[str, Any] | None = None, where: str = "--predictor") -> PredictorParams:
        """The params of ``settings``, each checked against its declaration before any file is read; ValueError
        naming ``where`` and the setting."""
        given = dict(settings or {})
        parse(PredictorSettings, given, where)
        return cls(json.dumps(given, sort_keys=True, separators=(",", ":")))

    @classmethod
    def from_setting(cls, data: Any, where: str) -> PredictorParams:
        """The ``predictor`` setting: a JSON object (``--job``), or on the command line its JSON text or ``@file``
        holding it (``core.settings``' value classes)."""
        return cls.of(json_object(data, where), where)

    def to_setting(self) -> dict[str, Any]:
        """The JSON object ``from_setting`` reads: the settings given."""
        return self.values

    @property
    def values(self) -> dict[str, Any]:
        """The settings given, as JSON data (lists for tuples)."""
        data: dict[str, Any] = json.loads(self.text)
        return data

    def __str__(self) -> str:
        return self.text


def predictor_setting() -> Any:
    """The field of a job's predictor settings (the one declaration of ``--predictor``)."""
    return setting(PredictorParams(), "the predictor's settings as a JSON object (or @file holding one), e.g. "
                                      "{\"max_iter\": 500}; those not given keep their defaults", metavar="JSON")


def allow_split_overlap() -> Any:
    """The field of a job's switch that lets a predictor score what it was trained on (the one declaration of
    ``--allow-split-overlap``)."""
    return setting(False, "let a predictor score frames or matrices it was trained on, or blocks overlapping them (a "
                          "deliberate experiment)")


@dataclass(frozen=True)
class PredictorTraining:
    """How a predictor is trained and judged (method §7): its settings, the evaluation split whose macro F1 decides
    whether it can be trusted, and whether it may be scored on what it was trained on."""

    predictor: PredictorParams = predictor_setting()
    validation: str | None = setting(None, "the evaluation split whose F1 decides whether a predictor can be trusted, "
                                           "a warning otherwise (none: the first --evaluate split)", metavar="SPLIT")
    allow_split_overlap: bool = allow_split_overlap()

CV_FOLDS = 5  # method §7: 5-fold StratifiedKFold
# MLPClassifier's default validation_fraction: early_stopping holds out ceil(10 %) of the (resampled) training
# samples, stratified when there are two classes, and refuses a validation set of fewer than 2 samples.
VALIDATION_FRACTION = 0.1
MIN_VALIDATION = 2
# the fewest (resampled) samples whose validation split is large enough: 11
MIN_FIT_SAMPLES = next(n for n in range(1, 1000) if math.ceil(VALIDATION_FRACTION * n) >= MIN_VALIDATION)

# The fewest pooled training samples that can train (cross-validation and fit) with the most favourable labels,
# found by trying every count vector and class order with ``label_problems``: 11 with SMOTE (counts 3 and 8 of
# two labels), 14 without (3 and 11). Real labels are far less favourable (label 0 dominates).
MIN_TRAIN_SAMPLES = {True: 11, False: 14}


# Names an evaluation split may not have: the predictor's numbers of a split ``s`` are ``f1_s`` and ``n_s`` beside
# ``f1_cv`` (cross-validation) and ``n_train``, and its class counts are keyed ``train`` beside the splits'.
RESERVED_SPLIT_NAMES = ("train", "cv")


def validation_split(eval_splits: Sequence[str]) -> str | None:
    """The predictor's validation split: the first of ``eval_splits`` (the configuration's order), none when there
    is one split only. Its macro F1 decides whether a predictor can be trusted (the warnings), and the
    leave-one-method-out predictors are scored on it. It does not depend on the table split, so that choosing
    another table split retrains nothing."""
    return eval_splits[0] if len(eval_splits) > 1 else None


def ablation_splits(eval_splits: Sequence[str]) -> tuple[str, ...]:
    """The splits Table II (the attribute ablation) scores: the validation split and the last of ``eval_splits``
    (the table shows the last one's mean over methods too), or the one split."""
    return tuple(dict.fromkeys([eval_splits[0], eval_splits[-1]]))


def training_problems(n_train_queries: int, seq_len: int, n_methods: int = 1, smote: bool = True,
                      split: str = "train") -> list[str]:
    """What the configuration check can tell from split lengths alone: why a predictor cannot be trained on a
    train split of ``n_train_queries`` frames at sequence length ``seq_len``, pooled over ``n_methods`` methods
    (``smote``: the predictor's setting). Empty when some labelling of that many samples can train; the train
    stage checks the real class counts (``check_training_labels``).

    Each method gives ``n_train_queries - seq_len + 1`` samples (the queries with a sequence match, method §4).
    """
    per_method = max(0, n_train_queries - seq_len + 1)
    pooled = per_method * n_methods
    needed = MIN_TRAIN_SAMPLES[bool(smote)]
    if pooled >= needed:
        return []
    frames = math.ceil(needed / max(n_methods, 1)) + seq_len - 1
    return [f"split {split!r} has {n_train_queries} frames: {per_method} training samples per method at sequence "
            f"length {seq_len} ({n_train_queries} - {seq_len} + 1), {pooled} pooled over {n_methods} method(s); "
            f"the predictor needs at least {needed} even with the most favourable labels ({CV_FOLDS}-fold "
            f"cross-validation{' with SMOTE' if smote else ''}, then early stopping's {VALIDATION_FRACTION:.0%} "
            f"validation split of at least {MIN_VALIDATION}): lengthen split {split!r} to at least {frames} frames "
            f"(many more in practice), or shorten seq_lens"]
