"""``monotone``: hidden-Markov sequence matching, Viterbi over the trailing ``L`` queries with band transitions
(method §14; Hansen and Browning 2014, Multi-Process Fusion).

On ``Dn = D / (column maximum)`` (method §5's normalisation, ``velocity.column_max``), a path moves ``t`` in
``0 .. max_step`` reference frames per query frame at the cost ``step_penalty * |t - 1|``:
``C_0[r] = Dn[r, a-L+1]``, ``C_k[r] = min_t (C_{k-1}[r - t] + step_penalty |t - 1|) + Dn[r, a-L+1+k]`` over
``r - t >= 0``, and ``s_a[r] = C_{L-1}[r]``; the match is the lowest ``r`` of the smallest score. Every value is
that float64 expression in that order (a minimum is exact), so a block gives the whole split's bits and a plain
loop gives the same. Every reference is reached (the path may stay, ``t = 0``), so every score is finite.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from vpr_smr.core.settings import setting
from vpr_smr.eval.matching.checks import check_shape
from vpr_smr.eval.matching.matchers.base import MatchBlock, Matcher
from vpr_smr.eval.matching.velocity import CHUNK_VALUES, column_max  # CHUNK_VALUES: queries per pass

__all__ = ["Monotone", "MonotoneSettings", "viterbi_scores"]



@dataclass(frozen=True)
class MonotoneSettings:
    """The settings of ``monotone``."""

    max_step: int = setting(2, "the largest step of a path, in reference frames per query frame (steps 0 .. max_step)",
                            minimum=1)
    step_penalty: float = setting(0.1, "the cost of a step t, step_penalty * |t - 1| (0: every step is free)",
                                  minimum=0)


def viterbi_scores(normalised: np.ndarray, seq_len: int, max_step: int, step_penalty: float) -> np.ndarray:
    """``s_a[r]`` ``(n - L + 1, R)`` of the queries whose windows the rows of ``normalised`` (``(n, R)``: columns of
    ``Dn`` as rows, float64) hold, the first ending at its row ``L - 1``."""
    n_rows, n_ref = normalised.shape
    n_queries = n_rows - seq_len + 1
    costs = [step_penalty * abs(t - 1) for t in range(max_step + 1)]
    score = normalised[:n_queries].copy()  # C_0
    best, moved = np.empty_like(score), np.empty_like(score)
    for k in range(1, seq_len):
        np.add(score, costs[0], out=best)  # t = 0: the path stays on its row
        for t in range(1, min(max_step, n_ref - 1) + 1):  # rows r >= t come from r - t
            np.add(score[:, : n_ref - t], costs[t], out=moved[:, t:])
            np.minimum(best[:, t:], moved[:, t:], out=best[:, t:])
        np.add(best, normalised[k : k + n_queries], out=score)
    return score


class Monotone(Matcher):
    """Viterbi over band transitions of ``0 .. max_step`` reference frames per query frame (see the module's text);
    its native confidence is method §12's ``uniqueness`` on ``s_a``."""

    name: ClassVar[str] = "monotone"
    Settings: ClassVar[type] = MonotoneSettings
    description: ClassVar[str] = ("hidden-Markov Viterbi over the trailing L queries: the cheapest path through the "
                                  "column-normalised D moving 0 .. max_step references per query, each step t "
                                  "costing step_penalty |t - 1|")
    native_scorer: ClassVar[str | None] = "uniqueness"

    @property
    def lookback(self) -> int:
        return self.seq_len - 1

    def check(self, shape: tuple[int, ...], name: str = "distance matrix") -> None:
        if len(shape) != 2:
            check_shape(tuple(shape), self.seq_len, name)  # names the shape it expects
        n_ref, n_query = (int(n) for n in shape)
        if n_ref < 1 or n_query < self.seq_len:
            raise ValueError(f"{name} of shape {n_ref}x{n_query} is too short for the matcher monotone at sequence "
                             f"length {self.seq_len}: it needs at least 1 reference and {self.seq_len} query columns")

    def block(self, columns: np.ndarray, first_column: int, state: Any) -> tuple[MatchBlock, Any]:
        n_cols, n_ref = columns.shape
        lookback = self.lookback
        col_max = column_max(columns, first_column)  # checks the block for NaN and inf first
        n_queries = n_cols - lookback
        scores = np.empty((max(n_queries, 0), n_ref))
        step = max(1, CHUNK_VALUES // max(n_ref, 1))
        for j in range(0, n_queries, step):
            stop = min(n_queries, j + step)
            rows = slice(j, stop + lookback)
            normalised = columns[rows].astype(np.float64) / col_max[rows, None]
            scores[j:stop] = viterbi_scores(normalised, self.seq_len, self.settings.max_step,
                                            self.settings.step_penalty)
        queries = np.arange(first_column + lookback, first_column + lookback + len(scores))
        return MatchBlock(queries, scores, np.argmin(scores, axis=1).astype(np.int64)), state
