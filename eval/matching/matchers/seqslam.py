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
