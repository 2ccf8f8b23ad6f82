"""Thresholds that hold on the next traverse (method §16): the rules that set an acceptance threshold on a
calibration split, and what a threshold does on another split.

A confidence ``c_a`` per evaluated query (higher: the sequence match more likely correct) and a label per query
(its sequence match correct) make a split. A threshold ``t`` accepts ``c_a >= t``; a rule that finds no threshold
abstains (``threshold`` None: accepts nothing), which is a state of its own, not ``+inf``: the uniqueness ratio
itself may be ``+inf``. On a split, ``n`` accepted and ``k`` wrong among them give the precision ``(n - k) / n``
(undefined, None, when ``n = 0``), the recall ``(n - k) / N`` over every query of the split (method §8's standard
mode) and the accepted fraction ``n / N``.

The rules (candidates: the calibration split's distinct confidences; a precision is the float ``(n - k) / n``
compared ``>= p``):

- ``empirical``: the smallest ``t`` whose precision on the calibration split reaches ``p``;
- ``guaranteed``: Selection with Guaranteed Risk (Geifman and El-Yaniv, 2017), a binary search over the sorted
  confidences with a one-sided Clopper-Pearson bound on the risk at ``1 - delta / steps`` (a union bound over the
  steps): under exchangeable queries the precision on new queries is at least ``p`` with probability at least
  ``1 - delta``; a route's queries are not exchangeable, which the deployments measure;
- ``same_fraction``: accept on another split the same fraction of its queries as ``empirical`` accepts on the
  calibration split (its ``ceil(f |D|)`` most confident, ties at the cut included): no labels of that split needed;
- ``oracle_threshold``: ``empirical`` on the deployment split itself, the ceiling a rule is compared with.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial

import numpy as np

from vpr_smr.core.records import Record
from vpr_smr.eval.scoring.intervals import draws, percentile_interval, query_weights
from vpr_smr.eval.scoring.records import Interval

__all__ = [
    "ABSTAINED", "DEFAULT_PRECISIONS", "DEFAULT_RISK", "DEFAULT_SEGMENT", "EMPIRICAL", "GUARANTEED", "HELD",
    "ORACLE_THRESHOLD", "RULES", "SAME_FRACTION", "VIOLATED",
    "Calibration", "Realised", "Segments", "accept", "bootstrap_weights", "calibrate", "check_precision", "check_risk",
    "empirical",
    "guaranteed", "outcome", "realise", "risk_coverage", "segment_bounds", "segments", "smallest_calibration",
    "steps",
]

EMPIRICAL, GUARANTEED, SAME_FRACTION, ORACLE_THRESHOLD = "empirical", "guaranteed", "same_fraction", "oracle_threshold"
RULES = (EMPIRICAL, GUARANTEED, SAME_FRACTION)  # set on the calibration split (same_fraction: + D's confidences)
DEFAULT_PRECISIONS = (0.9, 0.95, 0.99)
DEFAULT_RISK = 0.1
DEFAULT_SEGMENT = 100
HELD, VIOLATED, ABSTAINED = "held", "violated", "abstained"  # a realised precision against its target


# --- checks ------------------------------------------------------------------------------------------------------


def _number(value: object, setting: str, wanted: str) -> float:
    """``value`` as a float (what ``float`` reads, as before), or a ValueError naming ``setting`` and the fix
    rather than ``float``'s own message or a TypeError."""
    try:
        return float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ValueError(f"{setting} {value!r} is not a number: give {wanted}") from None


def check_precision(value: float, setting: str = "precision") -> float:
    """``value`` as a target precision: ValueError naming ``setting`` unless ``0 < value <= 1``."""
    found = _number(value, setting, "a target precision in (0, 1], e.g. 0.9")
    if not (math.isfinite(found) and 0 < found <= 1):
        raise ValueError(f"{setting} {value!r} is no target precision: give a number in (0, 1], e.g. 0.9")
    return found


def check_risk(value: float, setting: str = "risk") -> float:
    """``value`` as the risk ``delta`` of ``guaranteed``: ValueError naming ``setting`` unless ``0 < value < 1``."""
    found = _number(value, setting, "a risk in (0, 1), e.g. 0.1")
    if not (math.isfinite(found) and 0 < found < 1):
        raise ValueError(f"{setting} {value!r} is no risk: give the probability in (0, 1) that the guaranteed "
                         "threshold misses its precision, e.g. 0.1")
    return found


def _split(confidence: np.ndarray, correct: np.ndarray, what: str = "the split") -> tuple[np.ndarray, np.ndarray]:
    """The confidences as float64 and the labels as bool, checked: one of each per query, no NaN."""
    values = np.asarray(confidence, dtype=np.float64).ravel()
    labels = np.asarray(correct).ravel()
    if len(values) != len(labels):
        raise ValueError(f"{what}: {len(values)} confidences but {len(labels)} labels; give one of each per query")
    if np.isnan(values).any():
        raise ValueError(f"{what}: confidence NaN at query {int(np.flatnonzero(np.isnan(values))[0])}; a source "
                         "must give every query a number (+inf is allowed)")
    if labels.dtype != bool:
        if not np.isin(labels, (0, 1)).all():
            raise ValueError(f"{what}: labels must be true/false (1/0), one per query")
        labels = labels.astype(bool)
    return values, labels


# --- counts at every candidate threshold -------------------------------------------------------------------------


def _sorted(values: np.ndarray, labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The confidences descending and the cumulative count of wrong labels along them (stable: equal confidences
    keep the split's order, which changes no count at a threshold)."""
    order = np.argsort(-values, kind="stable")
    return values[order], np.cumsum(~labels[order])


def _at(descending: np.ndarray, wrong: np.ndarray, t: float) -> tuple[int, int]:
    """``n`` accepted and ``k`` wrong of ``c >= t`` (ties included)."""
    n = int(np.searchsorted(-descending, -t, side="right"))
    return n, int(wrong[n - 1]) if n else 0


def _distinct_counts(values: np.ndarray, labels: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each distinct confidence (descending) with ``n`` and ``k`` of accepting from it on."""
    descending, wrong = _sorted(values, labels)
    last = np.flatnonzero(np.append(descending[1:] != descending[:-1], True))  # the last of each run of equals
    return descending[last], last + 1, wrong[last]


# --- the rules ---------------------------------------------------------------------------------------------------


def empirical(confidence: np.ndarray, correct: np.ndarray, precision: float) -> float | None:
    """The smallest candidate threshold whose precision on the split is at least ``precision``; None if none."""
    values, labels = _split(confidence, correct)
    if not len(values):
        return None
    thresholds, n, k = _distinct_counts(values, labels)
    reach = np.flatnonzero((n - k) / n >= precision)
    return float(thresholds[reach[-1]]) if len(reach) else None  # descending: the last is the smallest


def steps(m: int) -> int:
    """The binary search's steps over ``m`` calibration queries: ``max(1, ceil(log2 m))``."""
    return max(1, math.ceil(math.log2(m))) if m > 1 else 1


def _bound(n: int, k: int, risk: float, n_steps: int) -> float:
    """The Clopper-Pearson upper bound of the risk of ``k`` wrong among ``n``, at ``1 - risk / n_steps``."""
    from scipy.stats import beta  # here: the configuration imports this module's settings, not SciPy's statistics

    return 1.0 if k >= n else float(beta.ppf(1 - risk / n_steps, k + 1, n - k))


def guaranteed(confidence: np.ndarray, correct: np.ndarray, precision: float, risk: float) -> float | None:
    """Selection with Guaranteed Risk: sort the confidences descending, ``c_(1) >= .. >= c_(m)``; over
    ``steps(m)`` steps of a binary search on ``z`` (``lo = 0``, ``hi = m``, ``z = ceil((lo + hi) / 2)``), accept
    ``c >= c_(z)`` (ties included), bound its risk by Clopper-Pearson at ``1 - risk / steps``, and keep ``c_(z)``
    (``lo = z``) when the bound is at most ``1 - precision``, else ``hi = z``; stop when ``hi <= lo``. The last kept
    threshold, or None. Under exchangeable queries, a new query set's precision is at least ``precision`` with
    probability at least ``1 - risk``; a route's neighbouring queries are not exchangeable. One sort and a
    ``searchsorted`` per step: O(m log m)."""
    values, labels = _split(confidence, correct)
    m = len(values)
    if m == 0:
        return None
    descending, wrong = _sorted(values, labels)
    n_steps = steps(m)
    lo, hi, kept = 0, m, None
    for _ in range(n_steps):
        if hi <= lo:
            break
        z = -(-(lo + hi) // 2)
        t = float(descending[z - 1])
        n, k = _at(descending, wrong, t)
        if _bound(n, k, risk, n_steps) <= 1 - precision:
            kept, lo = t, z
        else:
            hi = z
    return kept


def smallest_calibration(precision: float, risk: float) -> int:
    """The fewest calibration queries with which ``guaranteed`` sets a threshold at all: every one of them correct,
    their confidences distinct. The search's first step tests the most confident half, ``z = ceil(m / 2)``; with
    no wrong match its bound is ``1 - (risk / steps(m)) ** (1 / z)``, and when that exceeds ``1 - precision`` every
    later step (fewer queries) fails too. So the answer is the smallest ``m`` whose first step passes (about twice
    the ``n`` with ``1 - (risk / steps) ** (1 / n) <= 1 - precision``: 917 at precision 0.99 and risk 0.1).
    ValueError at precision 1, which no finite split guarantees (the bound is never 0)."""
    precision, risk = check_precision(precision), check_risk(risk)
    if precision == 1:
        raise ValueError("precision 1 cannot be guaranteed from a finite calibration split (the Clopper-Pearson "
                         "bound of the risk is above 0 however many correct matches it holds): choose a target "
                         "below 1, or the rule empirical")
    start, chunk = 1, 1 << 12
    while True:  # the first m in order (steps(m) grows at powers of 2, so the test is not monotone in m)
        m = np.arange(start, start + chunk)
        n_steps = np.maximum(1, np.ceil(np.log2(np.maximum(m, 1)))).astype(np.float64)
        bound = 1 - (risk / n_steps) ** (1 / np.ceil(m / 2))
        found = np.flatnonzero(bound <= 1 - precision)
        if len(found):
            first = int(m[found[0]])
            # the closed form and the rule's SciPy bound agree to rounding: confirm the neighbour on the rule's own
            while first > 1 and _bound(-(-(first - 1) // 2), 0, risk, steps(first - 1)) <= 1 - precision:
                first -= 1
            while _bound(-(-first // 2), 0, risk, steps(first)) > 1 - precision:
                first += 1
            return first
        start, chunk = start + chunk, chunk * 2


@dataclass(frozen=True)
class Calibration(Record):
    """A rule's threshold set on a split (``calibrate``): ``threshold`` None when it abstains (accepts nothing),
    else it accepts ``c >= threshold``; ``accepted`` and ``wrong`` its counts on that split of ``n_queries``
    (``same_fraction`` keeps ``empirical``'s: its fraction is ``accepted / n_queries``). ``risk`` is ``guaranteed``'s
    ``delta`` (None for the other rules)."""

    rule: str
    precision: float
    risk: float | None
    threshold: float | None
    n_queries: int
    accepted: int
    wrong: int

    @property
    def abstains(self) -> bool:
        return self.threshold is None

    @property
    def fraction(self) -> tuple[int, int]:
        """``same_fraction``'s ``f`` as the exact pair (accepted, n_queries)."""
        return self.accepted, self.n_queries


def calibrate(confidence: np.ndarray, correct: np.ndarray, precision: float, rule: str,
              risk: float = DEFAULT_RISK) -> Calibration:
    """``rule``'s threshold on one split (``ORACLE_THRESHOLD`` is ``empirical``: give it the deployment split).
    ValueError for an unknown rule, a target outside (0, 1], a risk outside (0, 1) or an empty split."""
    if rule not in (*RULES, ORACLE_THRESHOLD):
        raise ValueError(f"unknown rule {rule!r}; choose one of {', '.join((*RULES, ORACLE_THRESHOLD))}")
    precision = check_precision(precision)
    values, labels = _split(confidence, correct, "the calibration split")
    if not len(values):
        raise ValueError("the calibration split is empty: give a split with evaluated queries")
    if rule == GUARANTEED:
        risk = check_risk(risk)
        threshold = guaranteed(values, labels, precision, risk)
    else:
        threshold = empirical(values, labels, precision)
    n, k = (0, 0) if threshold is None else _at(*_sorted(values, labels), threshold)
    return Calibration(rule, precision, risk if rule == GUARANTEED else None, threshold, len(values), n, k)


def accept(confidence: np.ndarray, calibration: Calibration) -> np.ndarray:
    """The queries of a split the calibration accepts: ``c >= threshold`` (none when it abstains); for
    ``same_fraction`` the ``ceil(accepted * N / n_queries)`` most confident of the ``N`` queries (integers, no
    rounding of a fraction), and every query tied with the last of them."""
    values = np.asarray(confidence, dtype=np.float64).ravel()
    if np.isnan(values).any():
        raise ValueError("a confidence is NaN: a source must give every query a number (+inf is allowed)")
    if calibration.abstains or not len(values):
        return np.zeros(len(values), dtype=bool)
    if calibration.rule != SAME_FRACTION:
        assert calibration.threshold is not None
        return values >= calibration.threshold
    accepted, n_queries = calibration.fraction
    wanted = -(-accepted * len(values) // n_queries)
    if wanted == 0:
        return np.zeros(len(values), dtype=bool)
    cut = float(np.sort(values)[::-1][wanted - 1])
    taken: np.ndarray = values >= cut
    return taken


# --- what a threshold does on a split ------------------------------------------------------------------------


@dataclass(frozen=True)
class Realised(Record):
    """The accepted queries of a split against their labels: ``precision`` None when nothing is accepted, the
    recall over every query of the split (method §8's standard mode), the block-bootstrap intervals over the split's
    queries (method §8.7; None without intervals or with too few defined draws)."""

    n_queries: int
    accepted: int
    wrong: int
    precision: float | None
    recall: float
    accepted_fraction: float
    precision_ci: Interval | None = None
    recall_ci: Interval | None = None


def _weighted_precision(hits: np.ndarray, taken: np.ndarray, weights: np.ndarray) -> np.ndarray:
    accepted = weights @ taken
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(accepted > 0, (weights @ hits) / np.where(accepted > 0, accepted, 1), np.nan)


def _weighted_recall(hits: np.ndarray, weights: np.ndarray) -> np.ndarray:
    out: np.ndarray = (weights @ hits) / weights.sum(axis=1)
    return out


def bootstrap_weights(n_queries: int) -> np.ndarray:
    """Every draw's per-query multiplicities of a split (``intervals.query_weights``, all chunks at once): the
    draws of every interval of the split, computed once for the many thresholds scored on it."""
    return np.concatenate(list(query_weights(n_queries))).astype(np.float64)


def realise(accepted: np.ndarray, correct: np.ndarray, intervals: bool = True,
            weights: np.ndarray | None = None) -> Realised:
    """Precision, recall and accepted fraction of ``accepted`` on a split, with their bootstrap intervals over the
    split's queries when ``intervals``: on every draw the same acceptances (the threshold was set before this split),
    each query counted as often as drawn (``weights``: the split's ``bootstrap_weights``, when the caller scores
    many thresholds on it; else drawn here). ValueError for an empty split."""
    taken = np.asarray(accepted, dtype=bool).ravel()
    labels = np.asarray(correct, dtype=bool).ravel()
    if len(taken) != len(labels):
        raise ValueError(f"{len(taken)} acceptances but {len(labels)} labels; give one of each per query")
    n_queries = len(labels)
    if n_queries == 0:
        raise ValueError("the split is empty: nothing to deploy on")
    n, hits = int(taken.sum()), taken & labels
    k = n - int(hits.sum())
    precision_ci = recall_ci = None
    if intervals:
        as_float = hits.astype(np.float64)
        if weights is None:
            precision_ci = percentile_interval(draws(partial(_weighted_precision, as_float,
                                                             taken.astype(np.float64)), n_queries))
            recall_ci = percentile_interval(draws(partial(_weighted_recall, as_float), n_queries))
        else:
            precision_ci = percentile_interval(_weighted_precision(as_float, taken.astype(np.float64), weights))
            recall_ci = percentile_interval(_weighted_recall(as_float, weights))
    return Realised(n_queries, n, k, (n - k) / n if n else None, (n - k) / n_queries, n / n_queries,
                    precision_ci, recall_ci)


def outcome(realised: Realised, precision: float) -> str:
    """``HELD`` (precision at least the target), ``VIOLATED`` (below it) or ``ABSTAINED`` (nothing accepted: no
    precision, never counted as a success)."""
    if realised.precision is None:
        return ABSTAINED
    return HELD if realised.precision >= precision else VIOLATED


@dataclass(frozen=True)
class Segments(Record):
    """A split cut into consecutive segments of ``size`` queries (the shorter last one merged into the one before
    it): how many, how many accept anything, and how many of those have a precision below the target."""

    size: int
    n_segments: int
    with_acceptance: int
    violated: int


def segment_bounds(n_queries: int, size: int) -> list[tuple[int, int]]:
    """The segments' [start, stop) of a split of ``n_queries``: runs of ``size``, the last shorter one merged into
    its neighbour (a split shorter than ``size`` is one segment)."""
    if size < 1:
        raise ValueError(f"segment {size!r}: give the queries per segment, at least 1")
    count = max(1, n_queries // size)
    return [(i * size, (i + 1) * size if i < count - 1 else n_queries) for i in range(count)]


def segments(accepted: np.ndarray, correct: np.ndarray, precision: float, size: int = DEFAULT_SEGMENT) -> Segments:
    """``Segments`` of ``accepted`` against ``correct`` (in the split's query order) at target ``precision``."""
    taken = np.asarray(accepted, dtype=bool).ravel()
    labels = np.asarray(correct, dtype=bool).ravel()
    bounds = segment_bounds(len(taken), size)
    with_acceptance = violated = 0
    for start, stop in bounds:
        n = int(taken[start:stop].sum())
        if n:
            with_acceptance += 1
            violated += int(int((taken[start:stop] & labels[start:stop]).sum()) / n < precision)
    return Segments(int(size), len(bounds), with_acceptance, violated)


def risk_coverage(confidence: np.ndarray, correct: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """At each distinct confidence ``t`` of a split, descending: the coverage ``n(t) / N``, the risk
    ``k(t) / n(t)`` (one minus the precision) of accepting ``c >= t``, and ``t``."""
    values, labels = _split(confidence, correct)
    if not len(values):
        return np.zeros(0), np.zeros(0), np.zeros(0)
    thresholds, n, k = _distinct_counts(values, labels)
    return n / len(values), k / n, thresholds
