"""``toy``: a causal filter that lives only in the tests, registered as a plugin (entry point group
``vpr_smr.matchers``) to show that a matcher which is not SeqSLAM runs everywhere by name.

Each query's score of reference ``r`` is its own distance plus ``decay`` times the previous query's score ``step``
references back (clamped to the first reference): an exponentially fading sum along the diagonal,

    s_first[r] = D[r, first],    s_a[r] = D[r, a] + decay * s_{a-1}[max(r - step, 0)],

so it keeps no window, only the previous query's scores (its state, carried from block to block). It evaluates
every query; the match is the lowest score (the lowest reference on ties); its native confidence is the margin from
the best score to the second best. The sequence length is not used.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from vpr_smr.core.settings import setting
from vpr_smr.eval.matching.matchers.base import MatchBlock, Matcher


@dataclass(frozen=True)
class ToySettings:
    """The settings of ``toy``."""

    decay: float = setting(0.5, "weight of the previous query's score carried along the diagonal", minimum=0,
                           maximum=1)
    step: int = setting(1, "reference frames the diagonal advances per query frame", minimum=0)


class ToyMatcher(Matcher):
    name = "toy"
    Settings = ToySettings
    description = "a fading sum of distances along the diagonal (a test plugin)"

    @property
    def score_frames(self) -> int:
        return 1  # a fading sum over every frame so far, whatever L: no sum of L frames to divide

    @property
    def lookback(self) -> int:
        return 0  # a filter: its memory is its state, not a window of columns

    def check(self, shape: tuple[int, ...], name: str = "distance matrix") -> None:
        if len(shape) != 2 or shape[0] < 2 or shape[1] < 1:
            raise ValueError(f"{name} has shape {shape}; the toy matcher needs references x queries with at least "
                             "2 references (its confidence is a margin to the second best) and 1 query")

    def block(self, columns: np.ndarray, first_column: int, state: Any) -> tuple[MatchBlock, Any]:
        columns = np.asarray(columns, dtype=np.float64)
        n, n_refs = columns.shape
        previous = np.maximum(np.arange(n_refs) - self.settings.step, 0)
        scores = np.empty((n, n_refs))
        for i, column in enumerate(columns):
            scores[i] = column if state is None else column + self.settings.decay * state[previous]
            state = scores[i]
        match = np.argmin(scores, axis=1).astype(np.int64)
        best_two = np.partition(scores, 1, axis=1)[:, :2]
        block = MatchBlock(np.arange(first_column, first_column + n, dtype=np.int64), scores, match,
                           best_two[:, 1] - best_two[:, 0])
        return block, None if state is None else state.copy()
