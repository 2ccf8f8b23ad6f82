"""SeqSLAM's velocity search (SPEC 11): sequence matching along trajectories of several slopes, and the four
attributes of the best trajectory ending at each reference.

A velocity ``v`` is reference frames per query frame. The trajectory of length ``L`` ending at reference ``r`` and
query ``a`` visits ``(r - o_k(v), a - L + 1 + k)`` for ``k = 0 .. L-1``, with ``o_k(v) = floor(v (L-1-k) + 0.5)``.
With the velocities ``(1.0,)`` this is SPEC 4's diagonal, and ``eval.matching.attributes`` computes it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

__all__ = ["check_velocities", "first_reference", "offsets", "search_order"]


def check_velocities(velocities: Sequence[float], name: str = "velocities") -> tuple[float, ...]:
    """The velocities as a tuple of floats, or ValueError naming ``name``: at least one, each finite and > 0, no
    repeats."""
    values = tuple(float(v) for v in velocities)
    if not values:
        raise ValueError(f"{name}: give at least one velocity (reference frames per query frame), e.g. [1.0]")
    bad = [v for v in values if not (math.isfinite(v) and v > 0)]
    if bad:
        raise ValueError(f"{name}: velocities are reference frames per query frame, each > 0; got {bad[0]}")
    if len(set(values)) != len(values):
        raise ValueError(f"{name}: {list(values)} repeats a velocity")
    return values


def offsets(velocity: float, seq_len: int) -> np.ndarray:
    """``o_k(v) = floor(v (L-1-k) + 0.5)`` for ``k = 0 .. L-1``: how far before the end reference the trajectory
    is at the ``k``-th query of the window (``o_{L-1} = 0``)."""
    k = np.arange(seq_len)
    out: np.ndarray = np.floor(velocity * (seq_len - 1 - k) + 0.5).astype(np.int64)
    return out


def first_reference(seq_len: int, velocities: Sequence[float]) -> int:
    """``r_min``: the lowest end reference with a valid trajectory (``r - o_0(v) >= 0`` for some ``v``); the
    attributes' index ``i`` counts from it (``L - 1`` for the fixed matcher)."""
    return min(int(offsets(v, seq_len)[0]) for v in velocities)


def search_order(velocities: Sequence[float]) -> tuple[float, ...]:
    """The velocities in the order of SPEC 11's tie rule: closest to 1 first, then the smaller. Scanning them in
    this order and keeping a trajectory only when it is strictly better implements that rule."""
    return tuple(sorted(velocities, key=lambda v: (abs(v - 1.0), v)))
