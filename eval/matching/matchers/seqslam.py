"""``seqslam``: SeqSLAM with an identity kernel along trajectories of the given velocities (method §4 and §11).

The matcher of the paper (``velocities [1.0]``, the fixed diagonals) and its velocity search. Its numbers come from
the trajectory engine ``eval.matching.matcher.SequenceMatcher`` and its fast paths (``fixed``, ``kernels``,
``velocity``, ``velocity_kernels``), private to this matcher and to the attributes, which describe the same
trajectories: ``s_a[r]`` is ``S[r, a]``, the smallest sum of ``D`` along the trajectories ending at ``r``, so the
shared pass that computes the attributes (``eval.matching.features``) gives its match and candidates too.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from vpr_smr.core.constants import DEFAULT_VELOCITIES
from vpr_smr.core.settings import parse, setting
from vpr_smr.eval.matching.matcher import SequenceMatcher
from vpr_smr.eval.matching.matchers.base import MatchBlock, Matcher

__all__ = ["SeqSLAM", "SeqSLAMSettings"]


@dataclass(frozen=True)
class SeqSLAMSettings:
    """The settings of ``seqslam``."""

    velocities: tuple[float, ...] = setting(
        DEFAULT_VELOCITIES, "velocities searched, in reference frames per query frame ([1.0]: the fixed matcher)",
        exclusive_minimum=0, min_items=1, unique=True)


class SeqSLAM(Matcher):
    """SeqSLAM over trailing windows of ``L`` queries: ``s_a[r] = S[r, a]``, the match its argmin (lowest ``r`` on
    ties), ``+inf`` below ``r_min`` (no trajectory of any velocity ends there)."""

    name: ClassVar[str] = "seqslam"
    Settings: ClassVar[type] = SeqSLAMSettings
    description: ClassVar[str] = ("SeqSLAM with an identity kernel: the smallest sum of D along straight "
                                  "trajectories of the given velocities over the trailing L queries")
    native_scorer: ClassVar[str | None] = "uniqueness"
    scores_are_attribute_sums: ClassVar[bool] = True

    def __init__(self, seq_len: int, settings: Any) -> None:
        super().__init__(seq_len, settings)
        self.engine = SequenceMatcher(seq_len, tuple(settings.velocities))

    @classmethod
    def settings_of(cls, values: Mapping[str, Any], where: str) -> SeqSLAMSettings:
        """As ``Matcher.settings_of``, the velocities sorted: the same set in another order is the same matcher."""
        record: SeqSLAMSettings = parse(SeqSLAMSettings, values, where)
        return SeqSLAMSettings(tuple(sorted(record.velocities)))

    @property
    def attribute_velocities(self) -> tuple[float, ...]:
        return self.engine.velocities

    @property
    def lookback(self) -> int:
        return self.seq_len - 1

    def check(self, shape: tuple[int, ...], name: str = "distance matrix") -> None:
        self.engine.check(shape, name)

    def block(self, columns: np.ndarray, first_column: int, state: Any) -> tuple[MatchBlock, Any]:
        found = self.engine.sequences(columns, first_column)  # checks the block for NaN and inf first
        n_queries, n_index = found.sums.shape
        scores = np.full((n_queries, n_index + found.first_reference), np.inf)
        scores[:, found.first_reference :] = found.sums
        queries = np.arange(first_column + self.lookback, first_column + self.lookback + n_queries)
        return MatchBlock(queries, scores, np.argmin(scores, axis=1).astype(np.int64)), state
