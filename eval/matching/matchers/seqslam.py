"""``seqslam``: SeqSLAM with an identity kernel along trajectories of the given velocities (method §4 and §11)."""

from __future__ import annotations

from dataclasses import dataclass

from vpr_smr.core.constants import DEFAULT_VELOCITIES
from vpr_smr.core.settings import setting

__all__ = ["SeqSLAMSettings"]


@dataclass(frozen=True)
class SeqSLAMSettings:
    """The settings of ``seqslam``."""

    velocities: tuple[float, ...] = setting(
        DEFAULT_VELOCITIES, "velocities searched, in reference frames per query frame ([1.0]: the fixed matcher)",
        exclusive_minimum=0, min_items=1, unique=True)


# The settings branch's stand-in, so that a MatcherSpec of seqslam validates its settings there: the matcher-seam
# branch's SeqSLAM (the matching itself) replaces this class at the merge.
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

from vpr_smr.core import settings as _settings  # noqa: E402
from vpr_smr.eval.matching.matchers.base import MatchBlock, Matcher  # noqa: E402


class SeqSLAM(Matcher):
    """SeqSLAM's settings, validated and canonical (velocities sorted); matching is the seam branch's."""

    name = "seqslam"
    Settings = SeqSLAMSettings
    description = "SeqSLAM: the sum of distances along trajectories of the given velocities (method §4, §11)"
    native_scorer = "uniqueness"

    @classmethod
    def settings_of(cls, values: Any, where: str) -> Any:
        record = _settings.parse(SeqSLAMSettings, values, where)
        return SeqSLAMSettings(tuple(sorted(record.velocities)))

    @property
    def lookback(self) -> int:
        return self.seq_len - 1

    def check(self, shape: tuple[int, ...], name: str = "distance matrix") -> None:
        raise NotImplementedError("the seam branch's SeqSLAM matches")

    def block(self, columns: np.ndarray, first_column: int, state: Any) -> tuple[MatchBlock, Any]:
        raise NotImplementedError("the seam branch's SeqSLAM matches")
