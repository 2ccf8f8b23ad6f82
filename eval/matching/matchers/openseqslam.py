"""``openseqslam``: SeqSLAM as OpenSeqSLAM and its Python port pySeqSLAM compute it (method §14).

Three steps. (1) Local contrast enhancement: every distance against the ``E + 1`` reference rows around it in its
query column (mean and ``ddof = 1`` standard deviation, fewer rows at the ends), then minus the smallest enhanced
value of the whole split (``prepare``). (2) For every start reference ``s``, the smallest sum of the enhanced values
along straight trajectories of the velocities ``m / ds`` (``m = floor(v_min ds) .. floor(v_max ds)``, ``ds`` = L
rounded up to even) through ``ds + 1`` query columns, centred on the query or ending at it; a visit past the last
reference costs ``+inf``. (3) The match is the best start plus ``ds / 2`` (centred) or ``ds`` (trailing); the native
confidence is minus the ratio of its score to the best score outside a window of ``ratio_window`` references around it.

Every number of a column depends on that column alone (and on the split's minimum), so a block's numbers equal the
whole split's bit for bit. The enhancement has a compiled twin (``eval.matching.openseqslam_kernels``, the same bits),
which ``prepare`` chooses for a split as the fixed matcher's kernels are chosen (``matcher.fixed_kernels``).
Where the published code is loose: ``floor(k m / ds)`` in integers (pySeqSLAM's float
product ends some trajectories a row short, first at ``ds = 26`` with the default velocities); the velocity bounds
``floor(v ds)`` of the decimal as written (``0.7 x 90 = 63``, where the float product gives 62); a window of equal
distances (``0 / 0``) is left out (``+inf``), as the MATLAB original's ``min`` skips NaN, where pySeqSLAM's NumPy
makes every number NaN; a start whose match would be past the last reference is no candidate (possible only when
``floor(v_min ds)`` is below the offset: trailing with ``v_min < 1``); a ratio of two zero scores is 1.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from fractions import Fraction
from types import ModuleType
from typing import Any, ClassVar

import numpy as np

from vpr_smr.core.settings import parse, setting
from vpr_smr.eval.matching.checks import check_finite
from vpr_smr.eval.matching.matcher import SequenceMatcher, fixed_kernels, read_columns
from vpr_smr.eval.matching.matchers.base import MatchBlock, Matcher

__all__ = ["OpenSeqSLAM", "OpenSeqSLAMSettings"]

ALIGNMENTS = ("centred", "trailing")
ENHANCE_COLUMNS = 8  # query columns enhanced together (measured at R = 27592: 1-16 alike, 38 a third slower)
TILE_QUERIES = 8  # evaluated queries summed together (measured: 8 to 32 about twice as fast as a whole block)


@dataclass(frozen=True)
class OpenSeqSLAMSettings:
    """The settings of ``openseqslam``."""

    enhance_window: int = setting(
        10, "the local contrast enhancement's window: E + 1 reference rows centred on each distance (E even)",
        minimum=2)
    v_min: float = setting(0.8, "slowest velocity searched, in reference frames per query frame", exclusive_minimum=0)
    v_max: float = setting(1.2, "fastest velocity searched, in reference frames per query frame", exclusive_minimum=0)
    ratio_window: int = setting(
        10, "references around the match left out of the ratio's second best (even)", minimum=2)
    alignment: str = setting(
        "centred", "the ds + 1 query columns centred on the query (the published code) or ending at it (causal)",
        choices=ALIGNMENTS)


class OpenSeqSLAM(Matcher):
    """OpenSeqSLAM's matches (see the module's text): ``s_a[r] = score_a[r - offset]`` (``offset = ds / 2``
    centred, ``ds`` trailing; ``+inf`` below ``offset`` and where every trajectory leaves the references), the match
    its argmin (lowest ``r`` on ties), the native confidence ``-ratio``."""

    name: ClassVar[str] = "openseqslam"
    Settings: ClassVar[type] = OpenSeqSLAMSettings
    description: ClassVar[str] = ("SeqSLAM as OpenSeqSLAM computes it: local contrast enhancement, straight "
                                  "trajectories of velocities v_min..v_max over ds + 1 queries around the query, "
                                  "confidence the best score's ratio to the best outside ratio_window references")
    native_scorer: ClassVar[str | None] = None

    def __init__(self, seq_len: int, settings: Any) -> None:
        super().__init__(seq_len, settings)
        self.ds = self.seq_len + self.seq_len % 2  # the published code rounds the sequence up to even
        self.half_enhance = int(settings.enhance_window) // 2
        self.half_window = int(settings.ratio_window) // 2
        self.centred = settings.alignment == "centred"
        self.offset = self.ds // 2 if self.centred else self.ds  # match = best start + offset
        m_lo, m_hi = (math.floor(Fraction(repr(float(v))) * self.ds) for v in (settings.v_min, settings.v_max))
        # moves[i, k]: the rows a trajectory of velocity m / ds has moved after k query columns, floor(k m / ds)
        self.moves = np.array([[k * m // self.ds for k in range(self.ds + 1)] for m in range(m_lo, m_hi + 1)],
                              dtype=np.int64)
        # the enhancement's compiled twin (eval.matching.openseqslam_kernels), chosen by prepare for the split's size
        self.kernels: ModuleType | None = None

    @classmethod
    def settings_of(cls, values: Mapping[str, Any], where: str) -> OpenSeqSLAMSettings:
        """As ``Matcher.settings_of``, with the rules between settings: ``v_min <= v_max``, even windows."""
        record: OpenSeqSLAMSettings = parse(OpenSeqSLAMSettings, values, where)
        if record.v_min > record.v_max:
            raise ValueError(f"{where}.v_min: {record.v_min} is above v_max {record.v_max}: the velocities searched "
                             "are v_min .. v_max; set v_min <= v_max (default 0.8 and 1.2)")
        for key in ("enhance_window", "ratio_window"):
            value = getattr(record, key)
            if value % 2:
                raise ValueError(f"{where}.{key}: {value} is odd; the window reaches {key} / 2 references either "
                                 f"side, so it must be even: use {value - 1} or {value + 1} (default 10)")
        return record

    @property
    def score_frames(self) -> int:
        return self.ds + 1  # a trajectory visits the columns start .. start + ds

    @property
    def lookback(self) -> int:
        return self.offset  # the window's first column is the query's minus the match's offset from its start

    @property
    def lookahead(self) -> int:
        return self.ds // 2 if self.centred else 0

    def check(self, shape: tuple[int, ...], name: str = "distance matrix") -> None:
        if len(shape) != 2:
            raise ValueError(f"{name} must be 2-D (references x queries), got shape {tuple(shape)}")
        n_ref, n_query = (int(n) for n in shape)
        what = f"openseqslam at L = {self.seq_len} (ds = {self.ds})"
        if n_query < self.ds + 1:
            raise ValueError(f"{name} has {n_query} query columns; {what} reads {self.ds + 1} consecutive ones per "
                             f"query, so it needs at least {self.ds + 1}")
        # starts whose slowest trajectory stays within the references and whose match is a reference: more of them
        # than the ratio's window holds, so that every match has a second best outside it
        needed = max(int(self.moves[0, -1]), self.offset) + 2 * self.half_window + 1
        if n_ref < needed:
            raise ValueError(f"{name} has {n_ref} references; {what} with v_min {self.settings.v_min}, alignment "
                             f"{self.settings.alignment} and ratio_window {self.settings.ratio_window} needs at least "
                             f"{needed}, so that a second best lies outside the ratio's window: lower "
                             "openseqslam.ratio_window or give more references")

    def enhanced(self, columns: np.ndarray) -> np.ndarray:
        """The local contrast enhancement (before the split's minimum is subtracted) of ``columns`` (``(n, R)``:
        query columns as rows), float64; ``+inf`` where the window's distances are all equal (``0 / 0``: duplicate
        reference frames), so that no trajectory visits it. ``ENHANCE_COLUMNS`` columns at a time: the window's
        ``2 (E + 1)`` passes then stay in the cache (at R = 27592 a quarter less time than a block of 38 at once);
        the compiled twin takes a column at a time itself."""
        if self.kernels is not None:
            values = np.ascontiguousarray(columns, dtype=np.float64)
            compiled = np.empty(values.shape)
            self.kernels.enhance(values, self.half_enhance, compiled)
            return compiled
        if len(columns) > ENHANCE_COLUMNS:
            return np.concatenate([self._enhanced(columns[i : i + ENHANCE_COLUMNS])
                                   for i in range(0, len(columns), ENHANCE_COLUMNS)])
        return self._enhanced(columns)

    def _enhanced(self, columns: np.ndarray) -> np.ndarray:
        values = np.asarray(columns, dtype=np.float64)
        n_cols, n_ref = values.shape
        half = self.half_enhance
        rows = np.arange(n_ref)
        lo, hi = np.maximum(0, rows - half), np.minimum(n_ref, rows + half + 1)
        count = (hi - lo).astype(np.float64)
        padded = np.zeros((n_cols, n_ref + 2 * half))
        padded[:, half : half + n_ref] = values
        # the window's rows in order, one shifted copy at a time (no (n, R, E + 1) array): each column's numbers
        # depend on that column only, and the sums run in the order numpy's mean over rows uses
        total = np.zeros((n_cols, n_ref))
        for j in range(2 * half + 1):
            total += padded[:, j : j + n_ref]
        mean = total / count
        squares = np.zeros((n_cols, n_ref))
        deviation = np.empty((n_cols, n_ref))
        for j in range(2 * half + 1):
            np.subtract(padded[:, j : j + n_ref], mean, out=deviation)
            deviation *= deviation
            # the row r - half + j lies outside the split for the first half - j and the last j - half rows
            if j < half:
                deviation[:, : half - j] = 0.0
            elif j > half:
                deviation[:, max(0, n_ref - (j - half)) :] = 0.0
            squares += deviation
        std = np.sqrt(squares / (count - 1))
        # a window of equal distances, exactly: no change between neighbouring rows within it (integer counts)
        changes = np.zeros((n_cols, n_ref), dtype=np.int64)
        np.cumsum(values[:, 1:] != values[:, :-1], axis=1, out=changes[:, 1:])
        equal = changes[:, hi - 1] == changes[:, lo]
        out: np.ndarray = np.full((n_cols, n_ref), np.inf)
        np.divide(values - mean, std, out=out, where=~equal)
        return out

    def prepare(self, matrix: Any) -> float:
        """The smallest contrast-enhanced value of the whole split ``matrix`` (read in blocks of columns)."""
        n_ref, n_query = (int(n) for n in matrix.shape)
        self.kernels = fixed_kernels(n_ref * n_query, "openseqslam_kernels")  # the split's size chooses the path
        step = SequenceMatcher.block_queries(n_ref)
        smallest = np.inf
        for lo in range(0, n_query, step):
            columns = read_columns(matrix, lo, min(n_query, lo + step))
            check_finite(columns, first_column=lo, queries_first=True)
            smallest = min(smallest, float(np.min(self.enhanced(columns))))
        if not np.isfinite(smallest):
            raise ValueError(f"openseqslam's local contrast enhancement is undefined throughout this {n_ref} x "
                             f"{n_query} distance matrix: every window of {2 * self.half_enhance + 1} reference rows "
                             "holds equal distances; use another descriptor or matcher for this split")
        return smallest

    def block(self, columns: np.ndarray, first_column: int, state: Any) -> tuple[MatchBlock, Any]:
        if state is None:
            raise ValueError("openseqslam needs the split's smallest contrast-enhanced value before its first block: "
                             "start from prepare(matrix) over the whole split (features.match_blocks does)")
        values = np.asarray(columns, dtype=np.float64)
        check_finite(values, first_column=first_column, queries_first=True)
        n_cols, n_ref = values.shape
        n_eval = n_cols - self.ds  # evaluated query i reads the block's columns i .. i + ds
        reach = int(self.moves[-1, -1])
        padded = np.full((n_cols, n_ref + reach), np.inf)  # a visit past the last reference costs +inf
        padded[:, :n_ref] = self.enhanced(values) - float(state)
        best = np.full((n_eval, n_ref), np.inf)  # score_a[s], every start s
        total = np.empty((min(TILE_QUERIES, n_eval), n_ref))
        for i in range(0, n_eval, TILE_QUERIES):  # a few queries at a time: their running sums stay in the cache
            stop = min(n_eval, i + TILE_QUERIES)
            running = total[: stop - i]
            for moved in self.moves:
                np.copyto(running, padded[i:stop, :n_ref])
                for k in range(1, self.ds + 1):
                    shift = int(moved[k])
                    running += padded[i + k : stop + k, shift : shift + n_ref]
                np.minimum(best[i:stop], running, out=best[i:stop])
        scores = np.full((n_eval, n_ref), np.inf)
        scores[:, self.offset :] = best[:, : n_ref - self.offset]  # a start whose match is no reference is dropped
        queries = np.arange(first_column + self.lookback, first_column + self.lookback + n_eval)
        match = np.argmin(scores, axis=1).astype(np.int64)
        value = scores[np.arange(n_eval), match]
        references = np.arange(n_ref)
        w = self.half_window
        inside = (references[None, :] >= match[:, None] - w) & (references[None, :] < match[:, None] + w)
        second = np.min(np.where(inside, np.inf, scores), axis=1)
        self._refuse_degenerate(queries, match, value, second)
        # second >= value >= 0; both 0 (two trajectories on the split's smallest values): equal, ratio 1
        ratio = np.divide(value, second, out=np.ones(n_eval), where=second > 0)
        return MatchBlock(queries, scores, match, -ratio), state

    def _refuse_degenerate(self, queries: np.ndarray, match: np.ndarray, value: np.ndarray,
                           second: np.ndarray) -> None:
        """ValueError for the first query without a finite score, or without one outside the ratio's window (the
        check on the shape rules both out unless windows of equal distances leave trajectories out)."""
        for bad, what in ((~np.isfinite(value), "has no trajectory of finite cost"),
                          (~np.isfinite(second), f"has no finite score outside the ratio's window of "
                                                 f"{self.settings.ratio_window} references around its match")):
            if np.any(bad):
                i = int(np.argmax(bad))
                raise ValueError(
                    f"openseqslam: query {int(queries[i])} of the distance matrix (match {int(match[i])}) {what}: its "
                    "trajectories visit distances whose enhancement window holds equal distances (duplicate "
                    "reference frames) or leave the references; use a longer split, lower openseqslam.ratio_window, "
                    "or another matcher")
