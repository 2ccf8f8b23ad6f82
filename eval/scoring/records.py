"""Typed results of the scoring stages, each the one home of its keys in the JSON files (method §§7-10).

Each record's fields are its JSON layout, an embedded record its own object (``core.records``, the one codec of
every record): a stage writes a file's record with ``core.records.save`` and the report reads it back with
``from_json``, which takes exactly that layout (a missing entry is an error, not a default; a file of another results
format is refused). ``write_json`` sorts keys, so the fields and values here alone decide a file's bytes. Optional
parts (curves, trust levels, restoration: the fields that default to None) are absent from a file when not computed,
never null; ``reduction_pct`` is null when undefined.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from vpr_smr.core.records import FileRecord, Record
from vpr_smr.eval.scoring.curves import DIRECTED, by_sign, earned

if TYPE_CHECKING:
    from vpr_smr.eval.scoring.curves import Curve

Json = dict[str, Any]


# --- curves and per-mode numbers of match removal ----------------------------------------------------------------


@dataclass(frozen=True)
class Interval(Record):
    """A ``intervals.CONFIDENCE`` percentile bootstrap interval over queries (method §8.7): ``low <= high``. Its
    rules are ``eval.scoring.intervals``'; the record lives here, with the records that hold it, so that reading a
    file needs no scikit-learn."""

    low: float
    high: float

    def excludes_zero(self) -> bool:
        """True when the interval lies wholly above or wholly below 0: only then does a number have a direction."""
        return self.low > 0 or self.high < 0

    def sign(self) -> int:
        """+1 wholly above 0, -1 wholly below, 0 when it contains 0."""
        return 1 if self.low > 0 else -1 if self.high < 0 else 0


@dataclass(frozen=True)
class PRCurve(Record):
    """A precision-recall curve as written: the two lists of ``curves.Curve``."""

    recall: tuple[float, ...]
    precision: tuple[float, ...]

    @classmethod
    def of(cls, curve_: Curve) -> PRCurve:
        # tolist: the same Python numbers the files always held (write_json turned arrays into lists this way)
        return cls(tuple(np.asarray(curve_.recall).tolist()), tuple(np.asarray(curve_.precision).tolist()))


@dataclass(frozen=True)
class Reduction(Record):
    """Baseline (VPR+SM) against match removal (+Pred) in one mode: the numbers every predictor seed has.

    ``max_recall`` is the predictor's, where both AOCs are taken; ``max_recall_vpr_sm`` and ``aoc_vpr_sm_own`` are
    the baseline's own maximum recall and AOC there, which stand in for it when the predictor leaves no recall to
    compare at. ``outcome`` is ``curves.outcome``'s: what the removal did, in a word a table can show, a direction
    (improved, worse) only where ``reduction_pct_ci`` earns it (``curves.earned``: else ``interval_holds_0``,
    ``no_interval``, ``interval_against_sign``), however the record is made or read. The
    ``_ci`` fields are the bootstrap intervals over queries (method §8.7) of ``reduction_pct``, ``aoc_vpr_sm`` and
    ``aoc_vpr_sm_pred``, for the numbers a table shows (the first seed's, a scorer's at its budget, held out, the
    sweep's); absent elsewhere, and None where too few draws define the number. ``aoc_difference_ci`` is the
    interval of the predictor's AOC minus the baseline's (``intervals.aoc_difference``) that judged a from-zero
    outcome (``curves.is_from_zero``: the baseline's AOC 0, no reduction to take an interval of), so that its word
    is shown beside it; None for any other outcome, and in a file written before it existed.
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
    reduction_pct_ci: Interval | None = None
    aoc_vpr_sm_ci: Interval | None = None
    aoc_vpr_sm_pred_ci: Interval | None = None
    aoc_difference_ci: Interval | None = None

    def __post_init__(self) -> None:
        _earn(self)


@dataclass(frozen=True)
class RemovalCurves(Record):
    """The seed-0 predictor's curves in one mode and their recall at precision 1."""

    recall_at_100_precision_vpr_sm: float
    recall_at_100_precision_vpr_sm_pred: float
    curve_vpr_sm: PRCurve
    curve_vpr_sm_pred: PRCurve


@dataclass(frozen=True)
class TrustNumbers(Record):
    """Match removal at one trust level against the baseline (``outcome``, ``reduction_pct_ci``: as
    ``Reduction``'s)."""

    removed: int
    max_recall: float
    auc: float
    aoc: float
    auc_vpr_sm: float
    aoc_vpr_sm: float
    reduction_pct: float | None
    outcome: str
    reduction_pct_ci: Interval | None = None

    def __post_init__(self) -> None:
        _earn(self)


def _earn(record: Reduction | TrustNumbers) -> None:
    """A record's outcome by the one rule for direction words (``curves.earned``), judged afresh from the estimate's
    sign whenever the record is made: a seed's removal is made without its interval, which is added later
    (``dataclasses.replace``)."""
    if record.outcome in DIRECTED and record.reduction_pct is not None:
        object.__setattr__(record, "outcome", earned(by_sign(record.reduction_pct), record.reduction_pct_ci))


@dataclass(frozen=True)
class ModeRemoval(Record):
    """One mode of match removal: recall@1, the reduction numbers, and the optional curves and trust levels
    (``trust_auc``, level -> numbers, and ``trust``, level -> curve, both keyed by ``str(level)``)."""

    recall_at_1_single: float
    recall_at_1_sequence: float
    reduction: Reduction
    curves: RemovalCurves | None = None
    trust_auc: dict[str, TrustNumbers] | None = None
    trust: dict[str, PRCurve] | None = None


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
class SeedNumbers(Record):
    """One predictor seed's removal: its reduction numbers per mode."""

    seed: int
    f1_macro: float
    removed: int
    modes: dict[str, Reduction]

    @classmethod
    def of(cls, seed: int, removal: Removal) -> SeedNumbers:
        return cls(seed, removal.f1_macro, removal.removed,
                   {mode: numbers.reduction for mode, numbers in removal.modes.items()})


@dataclass(frozen=True)
class SeedSummary(Record):
    """``reduction_pct`` over the seeds of one mode: all None when no seed's reduction is defined, the standard
    deviation (ddof 1) None when fewer than two are.
    ``outcomes``: every seed's outcome (``Reduction.outcome``) by seed, so that a table can say which seeds the
    spread leaves out and why."""

    n_seeds: int
    n_seeds_defined: int
    reduction_pct_mean: float | None
    reduction_pct_std: float | None
    reduction_pct_min: float | None
    reduction_pct_max: float | None
    outcomes: dict[int, str]  # written keyed by str(seed)


# --- restoration -------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class RestorationMode(Record):
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
    reduction_pct_ci: Interval | None = None  # its bootstrap interval over queries (method §8.7)

    NUMBERS = ("max_recall", "max_recall_removal", "max_recall_restoration", "auc_vpr_sm", "auc_removal",
               "auc_restoration", "auc_difference", "aoc_removal", "aoc_restoration", "aoc_difference",
               "reduction_pct")


@dataclass(frozen=True)
class RestorationNumbers(Record):
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


# --- an evaluation file and its timings --------------------------------------------------------------------------


@dataclass(frozen=True)
class EvaluationSplit(Record):
    """One split of an evaluation: the first predictor's numbers and curves (its seed ``seed``), the other seeds'
    numbers, the summary over every seed, and restoration. ``seeds`` gives every seed's numbers, the first seed's
    taken from its own (they are written once)."""

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
    seed: int  # the first predictor's seed, whose numbers f1_macro, removed and modes are
    other_seeds: tuple[SeedNumbers, ...]  # the other predictors' numbers, in seed order
    seed_summary: dict[str, SeedSummary]
    restoration: RestorationNumbers | None = None

    @property
    def seeds(self) -> tuple[SeedNumbers, ...]:
        """Every seed's numbers, the first seed's first."""
        first = SeedNumbers(self.seed, self.f1_macro, self.removed,
                            {mode: numbers.reduction for mode, numbers in self.modes.items()})
        return (first, *self.other_seeds)


KEY_META = ("dataset", "method", "seq_len")


def meta_key(meta: Json) -> tuple[str, str, int]:
    """What an evaluation and its timings share: (dataset, method, sequence length). A meta without them (e.g. of
    ``vpr-smr metrics`` run without ``--dataset`` and ``--method``) raises a ValueError naming what it lacks."""
    missing = [key for key in KEY_META if key not in meta]
    if missing:
        raise ValueError(f"the meta has no {', '.join(missing)} (it has {', '.join(map(str, meta)) or 'nothing'}): "
                         "the file does not say which dataset, method and sequence length it is of")
    return str(meta["dataset"]), str(meta["method"]), int(meta["seq_len"])


class Keyed:
    """A file of one dataset, method and L: what its ``meta`` says of them, typed (``meta_key``: a meta without them
    raises naming what it has)."""

    meta: Json

    @property
    def key(self) -> tuple[str, str, int]:
        return meta_key(self.meta)

    @property
    def dataset(self) -> str:
        return self.key[0]

    @property
    def method(self) -> str:
        return self.key[1]

    @property
    def seq_len(self) -> int:
        return self.key[2]


@dataclass(frozen=True)
class Evaluation(Keyed, FileRecord):
    """One method on one dataset at one L (``evaluate.main``): the predictor files and every split."""

    meta: Json
    predictors: tuple[str, ...]
    splits: dict[str, EvaluationSplit]


@dataclass(frozen=True)
class SplitTiming(Record):
    """Inference time of one split: attributes (from the features file) and prediction, and their sum per query."""

    attributes_seconds: float
    predict_seconds: float
    seconds_per_query: float
    n_queries: int

    @classmethod
    def of(cls, attributes_seconds: float, predict_seconds: float, n_queries: int) -> SplitTiming:
        return cls(attributes_seconds, predict_seconds, (attributes_seconds + predict_seconds) / max(n_queries, 1),
                   n_queries)


@dataclass(frozen=True)
class Timing(Keyed, FileRecord):
    """The timings of one evaluation, in their own file: they change from run to run, the evaluation must not."""

    meta: Json
    splits: dict[str, SplitTiming]


# --- leave one method out ----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class HeldOutScores(Record):
    """The held-out method's test split under one predictor (its file ``path``)."""

    path: str
    f1_macro: float
    removed: int
    modes: dict[str, ModeRemoval]

    @classmethod
    def of(cls, path: str, removal: Removal) -> HeldOutScores:
        return cls(path, removal.f1_macro, removal.removed, removal.modes)


@dataclass(frozen=True)
class HeldOutPredictors(Record):
    """The held-out method's scores under both predictors."""

    pooled: HeldOutScores  # the predictor trained on every method
    without: HeldOutScores  # the one trained without the held-out method


@dataclass(frozen=True)
class HeldOut(Keyed, FileRecord):
    """A method's test split under the pooled predictor and the one trained without it (``ablation held-out``)."""

    meta: Json
    n_queries: int
    predictors: HeldOutPredictors

    @property
    def pooled(self) -> HeldOutScores:
        return self.predictors.pooled

    @property
    def without(self) -> HeldOutScores:
        return self.predictors.without


# --- training-free baselines (eval.scoring.baselines, method §12) ------------------------------------------------


@dataclass(frozen=True)
class Detection(Record):
    """How well one scorer detects wrong sequence matches (method §12.3): the queries whose sequence match is wrong
    are the positives, ranked by ``-c_a``. ``average_precision`` is None without a wrong match, ``roc_auc`` when
    every match or none is wrong. ``curve``: its precision-recall curve at each threshold where recall grows (the
    points the average precision sums), for the figure; None where a table needs the numbers only.
    ``average_precision_ci``: its bootstrap interval over queries (method §8.7), for the first seed's detection."""

    average_precision: float | None
    roc_auc: float | None
    curve: PRCurve | None = None
    average_precision_ci: Interval | None = None


@dataclass(frozen=True)
class ScorerRemoval(Record):
    """One scorer's removal at a predictor seed's budget: how many matches it removed (the budget, or fewer for
    ``oracle`` when there are fewer wrong matches) and Table I's numbers of that removal per mode."""

    removed: int
    modes: dict[str, Reduction]


@dataclass(frozen=True)
class BudgetRemoval(Record):
    """Removal at the budget of the seed-``seed`` predictor (method §12.2): ``budget`` is how many matches that
    predictor removes; every scorer of ``scorers`` (``predictor`` itself included, by its own removal) removes as
    many."""

    seed: int
    budget: int
    scorers: dict[str, ScorerRemoval]


@dataclass(frozen=True)
class Versus(Record):
    """A training-free scorer against the seed-0 predictor, paired over the same draws of the queries (method
    §8.7): per mode the interval of its reduction at the seed-0 budget minus the predictor's, and of its detection's
    average precision minus the predictor's (None where too few draws define them)."""

    reduction_pct_difference_ci: dict[str, Interval | None]
    average_precision_difference_ci: Interval | None


@dataclass(frozen=True)
class SplitBaselines(Record):
    """The training-free scorers, the oracle and the predictor on one split (method §12). ``detection``: each
    scorer's wrong-match detection, ``random`` and ``predictor`` by the first seed; ``random_detection``: random's
    for every seed of ``seeds``, in that order (without curves); ``removal``: per predictor seed, every scorer's
    removal at its budget (None without a predictor); ``versus_predictor``: every training-free scorer against the
    seed-0 predictor (``Versus``; None without a predictor)."""

    n_queries: int
    n_wrong: int  # queries whose sequence match is wrong: the positives of detection
    seeds: tuple[int, ...]
    detection: dict[str, Detection]
    random_detection: tuple[Detection, ...]
    removal: tuple[BudgetRemoval, ...] | None = None
    versus_predictor: dict[str, Versus] | None = None

    @property
    def wrong_fraction(self) -> float:
        """The fraction of wrong matches: the average precision of a random ranking."""
        return self.n_wrong / max(self.n_queries, 1)


@dataclass(frozen=True)
class Baselines(Keyed, FileRecord):
    """The training-free baselines of one method on one dataset at one L (``baselines.main``): ``meta`` holds the
    dataset, method, seq_len, the scorers' settings (``r_window``, ``spread_k``), the ground truth and the predictor
    files (one per seed, seed 0 first); one ``SplitBaselines`` per evaluated split."""

    meta: Json
    splits: dict[str, SplitBaselines]


# --- the standard VPR metrics (eval.scoring.vpr_metrics) --------------------------------------------------------


@dataclass(frozen=True)
class MatcherMetrics(Record):
    """The standard VPR metrics of one matcher in one mode, as method §8.6 defines them (docs/method.md).

    ``n_queries`` is recall@N's denominator; ``recall_at`` maps N (``core.constants.RECALL_AT``) to recall@N.
    ``recall_at_100p``, ``pr_auc`` and ``extended_precision`` come from the mode's PR curve (method §8).
    """

    n_queries: int
    recall_at: dict[int, float]  # written keyed by str(N)
    recall_at_100p: float
    pr_auc: float
    extended_precision: float


@dataclass(frozen=True)
class SweepPoint(Record):
    """One tolerance (frames) or radius (the positions' unit): recall@1 by the mode's rule (method §8.5) and, with a
    predictor, Table I's numbers of its removal. ``recall_at_1_single_evaluated``: single-frame recall@1 over the
    same evaluated queries as ``recall_at_1_sequence`` (in both modes), and ``recall_change_ci`` the paired
    bootstrap interval (method §8.7) of ``recall_at_1_sequence - recall_at_1_single_evaluated``: the change that
    sequence matching makes over the same queries."""

    threshold: float
    recall_at_1_single: float
    recall_at_1_sequence: float
    reduction: Reduction | None = None
    recall_at_1_single_evaluated: float | None = None
    recall_change_ci: Interval | None = None


@dataclass(frozen=True)
class ProtocolSweep(Record):
    """One split's sweep: ``kind`` (``frames``: tolerances; ``positions``: radii), and per mode a point per
    threshold, in order."""

    kind: str
    modes: dict[str, tuple[SweepPoint, ...]]


@dataclass(frozen=True)
class SplitMetrics(Record):
    """One split: per mode (``core.constants.MODES``), per matcher (``core.constants.MATCHERS``; without a
    predictor, ``sequence_predictor`` is absent). ``queries_without_correct``: how many of the split's queries no
    reference is correct for (never correct, counted in every denominator: paper-mode single-frame recall's, all
    queries); ``evaluated_without_correct``: how many of those have a sequence match (every other denominator's
    queries). Both absent in files written before they were recorded."""

    modes: dict[str, dict[str, MatcherMetrics]]
    queries_without_correct: int | None = None
    evaluated_without_correct: int | None = None
    sweep: ProtocolSweep | None = None  # recall@1 and the reduction over tolerances or radii (``sweep``), when asked
    baselines: SplitBaselines | None = None  # the training-free scorers (method §12), when computed


@dataclass(frozen=True)
class VPRMetrics(Keyed, FileRecord):
    """The standard VPR metrics of one distance matrix per split (``vpr-smr metrics``; in a run, one method on one
    dataset at one L). ``meta``: dataset, method, seq_len, tolerance, the ground truth (``ground_truth``:
    ``GroundTruth.provenance``; absent in files written before it was recorded) and the predictor file (seed 0)
    when given."""

    meta: Json
    splits: dict[str, SplitMetrics]

