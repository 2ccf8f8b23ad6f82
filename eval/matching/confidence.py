"""SeqSLAM's windowed uniqueness (method §12's scorer ``uniqueness``), the native confidence of the matchers that name
it (method §14): here, below the scorers, so that the live matcher (``live.LiveMatcher``) gives each frame the
numbers the batch scorers give its query."""

from __future__ import annotations

import numpy as np

__all__ = ["uniqueness"]


def uniqueness(values: np.ndarray, references: np.ndarray, window: int) -> np.ndarray:
    """SeqSLAM's windowed uniqueness per row: the smallest value whose reference lies more than ``window`` from the
    first candidate's (the best), divided by the best value. ``values``/``references``: each row's smallest values
    ascending with their references (``-1``: none), as the matcher keeps them; they must reach past the window
    (``2 window + 2`` candidates, or every reference). 1 where no reference lies outside the window or both values
    are 0, ``+inf`` where only the best is 0. A best value at or below 0 counts as 0 (a negative one is float
    rounding of 0: distances of identical descriptors)."""
    values, references = np.asarray(values, dtype=np.float64), np.asarray(references)
    best, match = values[:, 0], references[:, 0]
    outside = (references >= 0) & (np.abs(references - match[:, None]) > window)
    found = outside.any(axis=1)
    second = values[np.arange(len(values)), np.argmax(outside, axis=1)]
    zero = best <= 0
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = second / best
    out: np.ndarray = np.where(~found, 1.0, np.where(zero, np.where(second <= 0, 1.0, np.inf), ratio))
    return out
