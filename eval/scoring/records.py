"""Typed results of the scoring stages, each the one home of its keys in the JSON files (SPEC 7-10).

A stage builds these records and writes ``to_json()`` with ``core.io.write_json``; the report reads them back with
``from_json``, which takes exactly the layout ``to_json`` writes (a missing key is an error, not a default).
``write_json`` sorts keys, so the keys and values here alone decide a file's bytes. Optional parts (curves, trust
levels, restoration) are absent from a file when not computed, never null; ``reduction_pct`` is null when undefined.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, fields
from typing import Any, TypeVar

import numpy as np

from vpr_smr.eval.scoring.curves import Curve

Json = dict[str, Any]
R = TypeVar("R")


def _flat_to_json(record: Any) -> Json:
    return {f.name: getattr(record, f.name) for f in fields(record)}


def _flat_from_json(cls: type[R], data: Json) -> R:
    return cls(**{f.name: data[f.name] for f in fields(cls)})  # type: ignore[arg-type]


def _each_to_json(items: dict[str, Any]) -> Json:
    return {key: item.to_json() for key, item in items.items()}


def _each_from_json(read: Callable[[Json], R], data: Json) -> dict[str, R]:
    return {key: read(item) for key, item in data.items()}


def _ints(values: Any) -> tuple[int, ...]:
    return tuple(values)


# --- curves and per-mode numbers of match removal ----------------------------------------------------------------


@dataclass(frozen=True)
class PRCurve:
    """A precision-recall curve as written: the two lists of ``curves.Curve``."""

    recall: tuple[float, ...]
    precision: tuple[float, ...]

    @classmethod
    def of(cls, curve_: Curve) -> PRCurve:
        # tolist: the same Python numbers the files always held (write_json turned arrays into lists this way)
        return cls(tuple(np.asarray(curve_.recall).tolist()), tuple(np.asarray(curve_.precision).tolist()))

    def to_json(self) -> Json:
        return {"recall": list(self.recall), "precision": list(self.precision)}

    @classmethod
    def from_json(cls, data: Json) -> PRCurve:
        return cls(tuple(data["recall"]), tuple(data["precision"]))


@dataclass(frozen=True)
class Reduction:
    """Baseline (VPR+SM) against match removal (+Pred) in one mode: the numbers every predictor seed has.

    ``max_recall`` is the predictor's, where both AOCs are taken; ``max_recall_vpr_sm`` and ``aoc_vpr_sm_own`` are
    the baseline's own maximum recall and AOC there, which stand in for it when the predictor leaves no recall to
    compare at. ``outcome`` is ``curves.outcome``'s: what the removal did, in a word a table can show.
    """

    max_recall: float
    auc_vpr_sm: float
    auc_vpr_sm_pred: float
    aoc_vpr_sm: float
    aoc_vpr_sm_pred: float
    reduction_pct: float | None  # None (null) when the baseline's AOC is 0
    max_recall_vpr_sm: float
    aoc_vpr_sm_own: float
    outcome: str

    def to_json(self) -> Json:
        return _flat_to_json(self)

    @classmethod
    def from_json(cls, data: Json) -> Reduction:
        return _flat_from_json(cls, data)


@dataclass(frozen=True)
class RemovalCurves:
    """The seed-0 predictor's curves in one mode and their recall at precision 1."""

    recall_at_100_precision_vpr_sm: float
    recall_at_100_precision_vpr_sm_pred: float
    curve_vpr_sm: PRCurve
    curve_vpr_sm_pred: PRCurve

    def to_json(self) -> Json:
        return {"recall_at_100_precision_vpr_sm": self.recall_at_100_precision_vpr_sm,
                "recall_at_100_precision_vpr_sm_pred": self.recall_at_100_precision_vpr_sm_pred,
                "curve_vpr_sm": self.curve_vpr_sm.to_json(), "curve_vpr_sm_pred": self.curve_vpr_sm_pred.to_json()}

    @classmethod
    def from_json(cls, data: Json) -> RemovalCurves:
        return cls(data["recall_at_100_precision_vpr_sm"], data["recall_at_100_precision_vpr_sm_pred"],
                   PRCurve.from_json(data["curve_vpr_sm"]), PRCurve.from_json(data["curve_vpr_sm_pred"]))


@dataclass(frozen=True)
class TrustNumbers:
    """Match removal at one trust level against the baseline (``outcome``: as ``Reduction``'s)."""

    removed: int
    max_recall: float
    auc: float
    aoc: float
    auc_vpr_sm: float
    aoc_vpr_sm: float
    reduction_pct: float | None
    outcome: str

    def to_json(self) -> Json:
        return _flat_to_json(self)

    @classmethod
    def from_json(cls, data: Json) -> TrustNumbers:
        return _flat_from_json(cls, data)


@dataclass(frozen=True)
class ModeRemoval:
    """One mode of match removal, written flat: recall@1, the reduction numbers, and the optional curves and trust
    levels (keys ``trust_auc``, level -> numbers, and ``trust``, level -> curve, both keyed by ``str(level)``)."""

    recall_at_1_single: float
    recall_at_1_sequence: float
    reduction: Reduction
    curves: RemovalCurves | None = None
    trust_auc: dict[str, TrustNumbers] | None = None
    trust: dict[str, PRCurve] | None = None

    def to_json(self) -> Json:
        out = {"recall_at_1_single": self.recall_at_1_single, "recall_at_1_sequence": self.recall_at_1_sequence,
               **self.reduction.to_json()}
        if self.curves is not None:
            out.update(self.curves.to_json())
        if self.trust_auc is not None:
            out["trust_auc"] = _each_to_json(self.trust_auc)
        if self.trust is not None:
            out["trust"] = _each_to_json(self.trust)
        return out

    @classmethod
    def from_json(cls, data: Json) -> ModeRemoval:
        return cls(
            data["recall_at_1_single"], data["recall_at_1_sequence"], Reduction.from_json(data),
            RemovalCurves.from_json(data) if "curve_vpr_sm" in data else None,
            _each_from_json(TrustNumbers.from_json, data["trust_auc"]) if "trust_auc" in data else None,
            _each_from_json(PRCurve.from_json, data["trust"]) if "trust" in data else None,
        )


@dataclass(frozen=True)
class Removal:
    """What match removal by one predictor computed: its predicted classes (kept in memory, never written), macro
    F1, the number of matches removed and the numbers per mode."""

    predicted: np.ndarray = field(compare=False, repr=False)
    f1_macro: float
    removed: int
    modes: dict[str, ModeRemoval]


# --- seeds ------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SeedNumbers:
    """One predictor seed's removal: its reduction numbers per mode."""

    seed: int
    f1_macro: float
    removed: int
    modes: dict[str, Reduction]

    @classmethod
    def of(cls, seed: int, removal: Removal) -> SeedNumbers:
        return cls(seed, removal.f1_macro, removal.removed,
                   {mode: numbers.reduction for mode, numbers in removal.modes.items()})

    def to_json(self) -> Json:
        return {"seed": self.seed, "f1_macro": self.f1_macro, "removed": self.removed,
                "modes": _each_to_json(self.modes)}

    @classmethod
    def from_json(cls, data: Json) -> SeedNumbers:
        return cls(data["seed"], data["f1_macro"], data["removed"], _each_from_json(Reduction.from_json,
                                                                                    data["modes"]))


@dataclass(frozen=True)
class SeedSummary:
    """``reduction_pct`` over the seeds of one mode: all None when no seed's reduction is defined.
    ``outcomes``: every seed's outcome (``Reduction.outcome``) by seed, so that a table can say which seeds the
    spread leaves out and why."""

    n_seeds: int
    n_seeds_defined: int
    reduction_pct_mean: float | None
    reduction_pct_std: float | None
    reduction_pct_min: float | None
    reduction_pct_max: float | None
    outcomes: dict[int, str]

    def to_json(self) -> Json:
        return {**_flat_to_json(self), "outcomes": {str(seed): value for seed, value in self.outcomes.items()}}

    @classmethod
    def from_json(cls, data: Json) -> SeedSummary:
        return cls(**{**{f.name: data[f.name] for f in fields(cls)},
                      "outcomes": {int(seed): str(value) for seed, value in data["outcomes"].items()}})


# --- restoration -------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class RestorationMode:
    """Removal against restoration in one mode. ``curve_vpr_sm`` and ``curve_removal`` are None in an evaluation
    file, which keeps them once, as the mode's ``curve_vpr_sm`` and ``curve_vpr_sm_pred``."""

    max_recall: float
    max_recall_removal: float
    max_recall_restoration: float
    auc_vpr_sm: float
    auc_removal: float
    auc_restoration: float
    auc_difference: float
    aoc_removal: float
    aoc_restoration: float
    aoc_difference: float
    reduction_pct: float | None  # None when removal's AOC is 0
    curve_restoration: PRCurve
    curve_vpr_sm: PRCurve | None = None
    curve_removal: PRCurve | None = None

    NUMBERS = ("max_recall", "max_recall_removal", "max_recall_restoration", "auc_vpr_sm", "auc_removal",
               "auc_restoration", "auc_difference", "aoc_removal", "aoc_restoration", "aoc_difference",
               "reduction_pct")

    def to_json(self) -> Json:
        out = {name: getattr(self, name) for name in self.NUMBERS}
        out["curve_restoration"] = self.curve_restoration.to_json()
        for name in ("curve_vpr_sm", "curve_removal"):
            curve_ = getattr(self, name)
            if curve_ is not None:
                out[name] = curve_.to_json()
        return out

    @classmethod
    def from_json(cls, data: Json) -> RestorationMode:
        optional = {name: PRCurve.from_json(data[name]) for name in ("curve_vpr_sm", "curve_removal") if name in data}
        return cls(**{name: data[name] for name in cls.NUMBERS},
                   curve_restoration=PRCurve.from_json(data["curve_restoration"]),
                   curve_vpr_sm=optional.get("curve_vpr_sm"), curve_removal=optional.get("curve_removal"))


@dataclass(frozen=True)
class RestorationNumbers:
    """Counts of the second filter and, per mode, removal against restoration."""

    trust: float
    min_score: float
    removed: int
    restored: int
    restored_correct: int
    restored_wrong: int
    wrong_to_right: int  # a wrong removed match replaced by a right one
    right_to_wrong: int  # and the reverse
    restored_by_rank: tuple[int, ...]  # ranks 1..K-1
    modes: dict[str, RestorationMode]

    COUNTS = ("trust", "min_score", "removed", "restored", "restored_correct", "restored_wrong", "wrong_to_right",
              "right_to_wrong")

    def counts(self) -> Json:
        """The scalar counts, as a table row takes them."""
        return {name: getattr(self, name) for name in self.COUNTS}

    def to_json(self) -> Json:
        return {**self.counts(), "restored_by_rank": list(self.restored_by_rank),
                "modes": _each_to_json(self.modes)}

    @classmethod
    def from_json(cls, data: Json) -> RestorationNumbers:
        return cls(**{name: data[name] for name in cls.COUNTS}, restored_by_rank=_ints(data["restored_by_rank"]),
                   modes=_each_from_json(RestorationMode.from_json, data["modes"]))


# --- an evaluation file and its timings --------------------------------------------------------------------------


@dataclass(frozen=True)
class EvaluationSplit:
    """One split of an evaluation: the seed-0 predictor's numbers and curves, every seed, and restoration."""

    n_queries: int  # queries with a sequence match, which every sequence number is over
    n_queries_split: int  # every query of the split (paper mode's single-frame recall@1)
    recall_at_1_single_all: float
    recall_at_1_single_evaluated: float
    recall_at_1_sequence: float
    f1_macro: float
    confusion_matrix: tuple[tuple[int, ...], ...]
    class_counts: tuple[int, ...]
    predicted_counts: tuple[int, ...]
    removed: int
    modes: dict[str, ModeRemoval]
    seeds: tuple[SeedNumbers, ...]
    seed_summary: dict[str, SeedSummary]
    restoration: RestorationNumbers | None = None

    def to_json(self) -> Json:
        out = {
            "n_queries": self.n_queries, "n_queries_split": self.n_queries_split,
            "recall_at_1_single_all": self.recall_at_1_single_all,
            "recall_at_1_single_evaluated": self.recall_at_1_single_evaluated,
            "recall_at_1_sequence": self.recall_at_1_sequence, "f1_macro": self.f1_macro,
            "confusion_matrix": [list(row) for row in self.confusion_matrix],
            "class_counts": list(self.class_counts), "predicted_counts": list(self.predicted_counts),
            "removed": self.removed, "modes": _each_to_json(self.modes),
            "seeds": [seed.to_json() for seed in self.seeds], "seed_summary": _each_to_json(self.seed_summary),
        }
        if self.restoration is not None:
            out["restoration"] = self.restoration.to_json()
        return out

    @classmethod
    def from_json(cls, data: Json) -> EvaluationSplit:
        return cls(
            data["n_queries"], data["n_queries_split"], data["recall_at_1_single_all"],
            data["recall_at_1_single_evaluated"], data["recall_at_1_sequence"], data["f1_macro"],
            tuple(_ints(row) for row in data["confusion_matrix"]), _ints(data["class_counts"]),
            _ints(data["predicted_counts"]), data["removed"], _each_from_json(ModeRemoval.from_json, data["modes"]),
            tuple(SeedNumbers.from_json(seed) for seed in data["seeds"]),
            _each_from_json(SeedSummary.from_json, data["seed_summary"]),
            RestorationNumbers.from_json(data["restoration"]) if "restoration" in data else None,
        )


KEY_META = ("dataset", "method", "seq_len")


def meta_key(meta: Json) -> tuple[str, str, int]:
    """What an evaluation and its timings share: (dataset, method, sequence length). A meta without them (e.g. of
    ``vpr-smr metrics`` run without ``--dataset`` and ``--method``) raises a ValueError naming what it lacks."""
    missing = [key for key in KEY_META if key not in meta]
    if missing:
        raise ValueError(f"the meta has no {', '.join(missing)} (it has {', '.join(map(str, meta)) or 'nothing'}): "
                         "the file does not say which dataset, method and sequence length it is of")
    return str(meta["dataset"]), str(meta["method"]), int(meta["seq_len"])


@dataclass(frozen=True)
class Evaluation:
    """One method on one dataset at one L (``evaluate.main``): the predictor files and every split."""

    meta: Json
    predictors: tuple[str, ...]
    splits: dict[str, EvaluationSplit]

    @property
    def key(self) -> tuple[str, str, int]:
        return meta_key(self.meta)

    def to_json(self) -> Json:
        return {"meta": dict(self.meta), "predictors": list(self.predictors), "splits": _each_to_json(self.splits)}

    @classmethod
    def from_json(cls, data: Json) -> Evaluation:
        return cls(dict(data["meta"]), tuple(data["predictors"]),
                   _each_from_json(EvaluationSplit.from_json, data["splits"]))


@dataclass(frozen=True)
class SplitTiming:
    """Inference time of one split: attributes (from the features file) and prediction, and their sum per query."""

    attributes_seconds: float
    predict_seconds: float
    seconds_per_query: float
    n_queries: int

    @classmethod
    def of(cls, attributes_seconds: float, predict_seconds: float, n_queries: int) -> SplitTiming:
        return cls(attributes_seconds, predict_seconds, (attributes_seconds + predict_seconds) / max(n_queries, 1),
                   n_queries)

    def to_json(self) -> Json:
        return _flat_to_json(self)

    @classmethod
    def from_json(cls, data: Json) -> SplitTiming:
        return _flat_from_json(cls, data)


@dataclass(frozen=True)
class Timing:
    """The timings of one evaluation, in their own file: they change from run to run, the evaluation must not."""

    meta: Json
    splits: dict[str, SplitTiming]

    @property
    def key(self) -> tuple[str, str, int]:
        return meta_key(self.meta)

    def to_json(self) -> Json:
        return {"meta": dict(self.meta), "splits": _each_to_json(self.splits)}

    @classmethod
    def from_json(cls, data: Json) -> Timing:
        return cls(dict(data["meta"]), _each_from_json(SplitTiming.from_json, data["splits"]))


# --- leave one method out ----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class HeldOutScores:
    """The held-out method's test split under one predictor (its file ``path``)."""

    path: str
    f1_macro: float
    removed: int
    modes: dict[str, ModeRemoval]

    @classmethod
    def of(cls, path: str, removal: Removal) -> HeldOutScores:
        return cls(path, removal.f1_macro, removal.removed, removal.modes)

    def to_json(self) -> Json:
        return {"path": self.path, "f1_macro": self.f1_macro, "removed": self.removed,
                "modes": _each_to_json(self.modes)}

    @classmethod
    def from_json(cls, data: Json) -> HeldOutScores:
        return cls(data["path"], data["f1_macro"], data["removed"], _each_from_json(ModeRemoval.from_json,
                                                                                    data["modes"]))


@dataclass(frozen=True)
class HeldOut:
    """A method's test split under the pooled predictor and the one trained without it (``ablation held-out``)."""

    meta: Json
    n_queries: int
    pooled: HeldOutScores
    without: HeldOutScores

    def to_json(self) -> Json:
        return {"meta": dict(self.meta), "n_queries": self.n_queries,
                "predictors": {"pooled": self.pooled.to_json(), "without": self.without.to_json()}}

    @classmethod
    def from_json(cls, data: Json) -> HeldOut:
        predictors = data["predictors"]
        return cls(dict(data["meta"]), data["n_queries"], HeldOutScores.from_json(predictors["pooled"]),
                   HeldOutScores.from_json(predictors["without"]))


# --- the standard VPR metrics (eval.scoring.vpr_metrics) --------------------------------------------------------


@dataclass(frozen=True)
class MatcherMetrics:
    """The standard VPR metrics of one matcher in one mode (definitions: README "Standard VPR metrics").

    ``n_queries`` is recall@N's denominator; ``recall_at`` maps N (``core.constants.RECALL_AT``) to recall@N.
    ``recall_at_100p``, ``pr_auc`` and ``extended_precision`` come from the mode's PR curve (SPEC 8).
    """

    n_queries: int
    recall_at: dict[int, float]
    recall_at_100p: float
    pr_auc: float
    extended_precision: float

    def to_json(self) -> Json:
        return {"n_queries": self.n_queries, "recall_at": {str(n): v for n, v in self.recall_at.items()},
                "recall_at_100p": self.recall_at_100p, "pr_auc": self.pr_auc,
                "extended_precision": self.extended_precision}

    @classmethod
    def from_json(cls, data: Json) -> MatcherMetrics:
        return cls(int(data["n_queries"]), {int(n): float(v) for n, v in data["recall_at"].items()},
                   float(data["recall_at_100p"]), float(data["pr_auc"]), float(data["extended_precision"]))


@dataclass(frozen=True)
class SplitMetrics:
    """One split: per mode (``core.constants.MODES``), per matcher (``core.constants.MATCHERS``; without a
    predictor, ``sequence_predictor`` is absent)."""

    modes: dict[str, dict[str, MatcherMetrics]]

    def to_json(self) -> Json:
        return {"modes": {mode: _each_to_json(matchers) for mode, matchers in self.modes.items()}}

    @classmethod
    def from_json(cls, data: Json) -> SplitMetrics:
        return cls({mode: _each_from_json(MatcherMetrics.from_json, matchers)
                    for mode, matchers in data["modes"].items()})


@dataclass(frozen=True)
class VPRMetrics:
    """The standard VPR metrics of one distance matrix per split (``vpr-smr metrics``; in a run, one method on one
    dataset at one L). ``meta``: dataset, method, seq_len, tolerance and the predictor file (seed 0) when given."""

    meta: Json
    splits: dict[str, SplitMetrics]

    @property
    def key(self) -> tuple[str, str, int]:
        return meta_key(self.meta)

    def to_json(self) -> Json:
        return {"meta": dict(self.meta), "splits": _each_to_json(self.splits)}

    @classmethod
    def from_json(cls, data: Json) -> VPRMetrics:
        return cls(dict(data["meta"]), _each_from_json(SplitMetrics.from_json, data["splits"]))

