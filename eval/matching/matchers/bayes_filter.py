"""``bayes_filter``: the topological Bayes filter over places of ProbFiltersVPR (method §14.7).

A belief ``b`` over the references, set by the split's first query and carried from query to query (and from block
to block of query columns: the recursion is the same whatever the blocks, so block-wise results equal the whole
split's bit for bit). The filter is sequential over queries by nature; within a query every step is one numpy
operation over the references.

Underflow: the observation step is computed in log space, ``log b' - lambda D[:, a]`` shifted by its maximum before
``exp``, which is the same belief (the shift cancels in the normalisation) but cannot underflow to all zeros where
the published code's ``b' exp(-lambda D)`` would (large distances against a narrow spread of the first column), nor
when the likelihood rules out every place the belief holds. Places whose belief underflows to 0 get ``s_a = +inf``.
The one belief that cannot be continued is a prior ``b'`` with no mass at all: a window whose every step moves
the belief (all steps > 0, or all < 0) can carry it off the map; that is an error naming the query column.

The neighbourhood of the match is the published code's, ``max(p - 2w, 0) .. min(p + 2w, R - 1) - 1``: it never
holds the last reference, so a belief whose peak is the last reference and whose mass there is all (its
neighbourhood underflowed to 0) has no weighted mean; its match is then the peak and its native confidence 0.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from vpr_smr.core.settings import parse, setting
from vpr_smr.eval.matching.checks import check_finite
from vpr_smr.eval.matching.matchers.base import MatchBlock, Matcher

__all__ = ["BayesFilter", "BayesFilterSettings", "Belief"]

LOW_QUANTILE, HIGH_QUANTILE = 0.025, 0.975  # the spread of the first column that calibrates lambda


@dataclass(frozen=True)
class BayesFilterSettings:
    """The settings of ``bayes_filter``."""

    delta: float = setting(5.0, "how many times likelier the first query column's 2.5 % distance quantile is than "
                                "its 97.5 % one (calibrates the observation model)", exclusive_minimum=1)
    window_lo: int = setting(0, "the smallest step of the transition window, in reference frames per query frame")
    window_hi: int = setting(3, "one past the largest step of the transition window [window_lo, window_hi)")


@dataclass(frozen=True)
class Belief:
    """The filter's state after a query: ``lam`` (lambda, set at the split's first query) and the normalised
    belief ``(R,)`` float64."""

    lam: float
    belief: np.ndarray


class BayesFilter(Matcher):
    """The topological Bayes filter over every query of the split: ``s_a = -ln b``, the match the belief-weighted
    mean reference around the belief's peak, the native confidence the belief mass there."""

    name: ClassVar[str] = "bayes_filter"
    Settings: ClassVar[type] = BayesFilterSettings
    description: ClassVar[str] = ("a topological Bayes filter over places (ProbFiltersVPR): a belief over the "
                                  "references moved by the transition window and weighted by exp(-lambda D) at "
                                  "every query")

    @classmethod
    def settings_of(cls, values: Mapping[str, Any], where: str) -> BayesFilterSettings:
        """As ``Matcher.settings_of``, and the window checked: it must move the belief (not empty, not only step 0)
        and hold at least two steps (the match averages over 2 floor(width / 2) frames each side of the peak)."""
        record: BayesFilterSettings = parse(BayesFilterSettings, values, where)
        lo, hi = record.window_lo, record.window_hi
        if hi <= lo:
            raise ValueError(f"{where}.window_hi: the transition window [{lo}, {hi}) is empty; give window_hi > "
                             f"window_lo, e.g. window_lo {lo} and window_hi {lo + 3}")
        if (lo, hi) == (0, 1):
            raise ValueError(f"{where}.window_hi: the transition window [0, 1) moves no frame (only step 0); "
                             "widen it to the traverses' speed ratio, e.g. window_lo 0 and window_hi 3 for "
                             "frame-aligned traverses")
        if hi - lo < 2:
            raise ValueError(f"{where}.window_hi: the transition window [{lo}, {hi}) has one step, which leaves "
                             "the neighbourhood the match is averaged over empty; give window_hi >= window_lo + 2, "
                             f"e.g. window_lo {lo - 1} and window_hi {hi + 1}")
        return record

    @property
    def score_frames(self) -> int:
        return 1  # a belief's -log, no sum along a sequence

    @property
    def lookback(self) -> int:
        return 0

    @property
    def half_width(self) -> int:
        """``w = floor((w_hi - w_lo) / 2)``: the neighbourhood of the match spans ``2 w`` frames each side."""
        width: int = self.settings.window_hi - self.settings.window_lo
        return width // 2

    def check(self, shape: tuple[int, ...], name: str = "distance matrix") -> None:
        if len(shape) != 2:
            raise ValueError(f"{name} must be 2-D (references x queries), got shape {tuple(shape)}")
        n_ref, n_query = (int(n) for n in shape)
        if n_ref < 2 or n_query < 2:
            raise ValueError(f"{name} of shape {n_ref}x{n_query} is too small for the matcher bayes_filter: it "
                             "needs at least 2 references and 2 queries (the first query calibrates the filter, "
                             "the next ones follow it)")

    def block(self, columns: np.ndarray, first_column: int, state: Any) -> tuple[MatchBlock, Any]:
        raw = np.asarray(columns)
        if raw.ndim != 2:
            raise ValueError(f"expected a block of query columns (columns x references), got shape {raw.shape}")
        check_finite(raw, first_column=first_column, queries_first=True)
        block = raw.astype(np.float64, copy=False)
        n_queries, n_ref = block.shape
        scores = np.empty((n_queries, n_ref))
        match = np.empty(n_queries, dtype=np.int64)
        native = np.empty(n_queries)
        current: Belief | None = state
        for i in range(n_queries):  # the filter's recursion: one query after the other
            if current is None:
                current = self.initial(block[i], first_column + i)
            else:
                current = Belief(current.lam, self.update(current, block[i], first_column + i))
            scores[i], match[i], native[i] = self.localise(current.belief)
        queries = np.arange(first_column, first_column + n_queries, dtype=np.int64)
        return MatchBlock(queries, scores, match, native), current

    def initial(self, column: np.ndarray, query: int) -> Belief:
        """Lambda from the first query column's spread, and the belief ``exp(-lambda D)`` normalised."""
        low, high = np.quantile(column, [LOW_QUANTILE, HIGH_QUANTILE])
        spread = float(high - low)
        if not spread > 0:
            raise ValueError(f"query column {query}, the split's first, has no spread: its 2.5 % and 97.5 % distance "
                             f"quantiles are both {float(low)!r}, so the filter's lambda = ln(delta) / spread is "
                             "undefined; the filter calibrates on the first query, so give a split whose first "
                             "query's distances to the references differ")
        lam = math.log(self.settings.delta) / spread
        return Belief(lam, self.observe(np.ones(column.shape[0]), lam, column, query))

    def update(self, state: Belief, column: np.ndarray, query: int) -> np.ndarray:
        """The next belief: moved by the transition window, weighted by the observation, normalised."""
        return self.observe(self.predict(state.belief), state.lam, column, query)

    def predict(self, belief: np.ndarray) -> np.ndarray:
        """``b'[r] = sum_{j = w_lo}^{w_hi - 1} b[r - j]`` (terms outside the references left out): one shifted
        copy of the belief added per step ``j``, in ascending order (sums of non-negative terms: no cancellation,
        as a difference of cumulative sums would have in the belief's tails)."""
        n_ref = belief.shape[0]
        out = np.zeros(n_ref)
        for step in range(self.settings.window_lo, self.settings.window_hi):
            if abs(step) < n_ref:
                out[max(step, 0) : n_ref + min(step, 0)] += belief[max(-step, 0) : n_ref - max(step, 0)]
        return out

    def observe(self, prior: np.ndarray, lam: float, column: np.ndarray, query: int) -> np.ndarray:
        """``prior exp(-lambda D[:, a])`` normalised, computed in log space (see the module's text)."""
        if not np.any(prior > 0):
            lo, hi = self.settings.window_lo, self.settings.window_hi
            raise ValueError(
                f"query column {query}: the transition window [{lo}, {hi}) moved the whole belief off the "
                f"{prior.shape[0]} references (every step moves it {'on' if lo > 0 else 'back'}); give a window "
                "that includes step 0 or fits the traverses' speed ratio, or a split whose queries stay within the "
                "references")
        with np.errstate(divide="ignore"):
            log_posterior = np.log(prior) - lam * column
        weights = np.exp(log_posterior - log_posterior.max())
        out: np.ndarray = weights / weights.sum()
        return out

    def localise(self, belief: np.ndarray) -> tuple[np.ndarray, int, float]:
        """``-ln b``, the match (the belief-weighted mean reference of the neighbourhood of the peak, rounded half
        to even) and the native confidence (the belief mass of that neighbourhood)."""
        n_ref, w = belief.shape[0], self.half_width
        peak = int(np.argmax(belief))
        around = np.arange(max(peak - 2 * w, 0), min(peak + 2 * w, n_ref - 1))
        mass = belief[around]
        with np.errstate(divide="ignore"):
            scores = -np.log(belief)
        total = float(mass.sum())
        if total == 0:  # the peak is the last reference and its neighbourhood (which leaves it out) holds nothing
            return scores, peak, 0.0
        return scores, int(np.rint(np.average(around, weights=mass))), total
