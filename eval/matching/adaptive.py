"""The adaptive sequence length's one rule (method §15): per query, the shortest of the lengths ``L_1 < .. < L_m``
that accepts its match, a predictor keeping it (``adaptive``, ``adaptive_fallback``) or its uniqueness reaching a
threshold (``adaptive_uniqueness``). Here, below the scorers, so that the live matcher (``live.AdaptiveLiveMatcher``)
and the batch experiment (``eval.scoring.adaptive``) choose by the same function.
"""

from __future__ import annotations

import numpy as np

__all__ = ["NONE", "first_accepted", "used_lengths"]

NONE = -1  # no length accepts the query's match


def first_accepted(accepted: np.ndarray) -> np.ndarray:
    """Per query (a column of ``accepted``, ``(m, N)`` bool, row ``i`` the ``i``-th shortest length), the row of
    the shortest length that accepts its match; ``NONE`` where none does."""
    accepted = np.asarray(accepted, dtype=bool)
    if accepted.ndim != 2 or len(accepted) == 0:
        raise ValueError(f"expected one row per sequence length (m, N), got shape {accepted.shape}")
    found: np.ndarray = np.where(accepted.any(axis=0), np.argmax(accepted, axis=0), NONE).astype(np.int64)
    return found


def used_lengths(chosen: np.ndarray, lengths: tuple[int, ...] | list[int]) -> np.ndarray:
    """The sequence length each query used: its chosen length, or the longest where none accepted (every length was
    computed, up to the longest)."""
    table = np.asarray(lengths, dtype=np.int64)
    used: np.ndarray = np.where(np.asarray(chosen) == NONE, table[-1], table[np.asarray(chosen)])
    return used
