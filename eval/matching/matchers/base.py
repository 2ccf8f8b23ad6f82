"""The base class of every sequence matcher (method §4, §11 and §14): what a stage needs of a matcher, and nothing
of how it matches.

A matcher is built from a sequence length ``L`` and its settings record (a frozen dataclass of
``core.settings.setting`` fields, the class's ``Settings``). It evaluates the queries ``evaluated(Q)`` of a split of
``Q`` queries; each evaluated query ``a`` reads the columns ``a - lookback .. a + lookahead`` of ``D`` (and, for a
filter, the state the previous block left). Per block of evaluated queries it gives a ``MatchBlock``: the scores
``s_a[r]`` of every reference (float64, lower is better, ``+inf`` where nothing reaches ``r``), the match and the
native confidence. The SMR attributes A1-A4 are not the matcher's: they describe the trajectories
``attribute_velocities`` of the window of ``D`` (method §5, §11.4), computed once, outside any matcher.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from vpr_smr.core import settings

__all__ = ["MatchBlock", "Matcher"]


@dataclass(frozen=True)
class MatchBlock:
    """A matcher's results for the evaluated queries ``queries`` (``(w,)``, the split's query indices) of a block:
    ``scores (w, R)`` float64 ``s_a[r]``, ``match (w,)`` int64 ``r*_a``, ``native (w,)`` float64 its native
    confidence (higher is more confident; None where the matcher's native confidence is a training-free scorer of
    method §12 on ``s_a``, named by ``Matcher.native_scorer``)."""

    queries: np.ndarray
    scores: np.ndarray
    match: np.ndarray
    native: np.ndarray | None = None


class Matcher(ABC):
    """A sequence matcher or filter over a references x queries distance matrix (see the module's text)."""

    name: ClassVar[str]  # its registry name, as a configuration and ``--matcher`` write it
    Settings: ClassVar[type]  # its settings record (core.settings)
    description: ClassVar[str]  # one sentence for `vpr-smr matchers`, the docs and the report
    native_scorer: ClassVar[str | None] = None  # the §12 scorer that is its native confidence, where it is one
    # True where s_a[r] is the smallest sum of D along the ``attribute_velocities`` trajectories ending at r (SeqSLAM):
    # the one pass that computes the attributes then gives the match and the candidates too (eval.matching.features)
    scores_are_attribute_sums: ClassVar[bool] = False

    def __init__(self, seq_len: int, settings: Any) -> None:
        if seq_len < 2:
            raise ValueError(f"sequence length must be at least 2, got {seq_len}")
        self.seq_len = int(seq_len)
        self.settings = settings

    @classmethod
    def settings_of(cls, values: Mapping[str, Any], where: str) -> Any:
        """The ``Settings`` record of JSON ``values`` (missing ones at their defaults, each checked against its
        declaration); ValueError naming ``where`` and the setting."""
        return settings.parse(cls.Settings, values, where)

    @property
    def attribute_velocities(self) -> tuple[float, ...]:
        """The trajectories whose window the SMR attributes describe (method §14: the fixed diagonals unless the
        matcher is SeqSLAM's velocity search)."""
        return (1.0,)

    @property
    def score_frames(self) -> int:
        """How many frames a score ``s_a[r]`` sums (``L`` for a sum along the sequence): ``s_a[r] / score_frames``
        is its per-frame value, which compares the matches of two sequence lengths (the adaptive sequence length,
        method §15); 1 for a score that is no sum over the sequence (a filter's belief)."""
        return self.seq_len

    @property
    @abstractmethod
    def lookback(self) -> int:
        """Columns before an evaluated query that its match reads (``L - 1`` for a trailing window)."""

    @property
    def lookahead(self) -> int:
        """Columns after an evaluated query that its match reads (0: causal)."""
        return 0

    def evaluated(self, n_query: int) -> tuple[int, int]:
        """The evaluated queries of a split of ``n_query`` queries: ``range(first, stop)``."""
        return self.lookback, n_query - self.lookahead

    @abstractmethod
    def check(self, shape: tuple[int, ...], name: str = "distance matrix") -> None:
        """ValueError naming ``name`` when a references x queries matrix of ``shape`` cannot be matched."""

    def initial_state(self) -> Any:
        """The state a filter carries from block to block (None: the matcher keeps none)."""
        return None

    def prepare(self, matrix: Any) -> Any:
        """The state before the first block, from a pass over the whole split ``matrix`` (``R x Q``, an array or an
        h5py dataset: read it in blocks with ``eval.matching.matcher.read_columns``), for a matcher whose numbers
        depend on the whole split (openseqslam: the smallest contrast-enhanced value of the split); default
        ``self.initial_state()``."""
        return self.initial_state()

    @abstractmethod
    def block(self, columns: np.ndarray, first_column: int, state: Any) -> tuple[MatchBlock, Any]:
        """The matches of the evaluated queries whose columns ``columns`` (``(n, R)``: the split's columns
        ``first_column .. first_column + n - 1`` as rows) hold, and the state for the next block."""
