"""One split's matches, SMR attributes and candidates, for any matcher (method §5, §11.4, §12 and §14).

The attributes A1-A4 describe the window of ``D``: the ``K`` best trajectories of ``matcher.attribute_velocities``
(the fixed diagonals unless the matcher is SeqSLAM's velocity search), whatever the matcher. They are computed here,
once, by the trajectory engine (``matcher.SequenceMatcher``), never by a matcher. Then:

- a matcher whose ``s_a`` are those trajectories' sums (``Matcher.scores_are_attribute_sums``: ``seqslam``) takes
  its match, ``S`` range and candidates from the same pass (its fast paths: no second pass over the matrix);
- any other matcher's scores come from its ``block`` (``match_blocks``: its evaluated queries block by block, its
  state carried in order), its match is its own, and its candidates are the ``n`` smallest ``s_a[r]`` ascending
  (equal values lowest ``r`` first; ``+inf`` and reference ``-1`` where fewer than ``n`` are finite);
- a matcher whose native confidence is its own (``Matcher.native_scorer`` None) gives it per block
  (``MatchBlock.native``), kept as ``sequence_native``; the others' is a scorer of method §12, computed where the
  scorers are.

Queries: those the matcher evaluates that have a window of ``L`` columns (``a >= L - 1``).
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np

from vpr_smr.eval.matching.checks import NonFiniteError
from vpr_smr.eval.matching.matcher import SequenceMatcher, as_matrix, block_dtype, read_columns
from vpr_smr.eval.matching.matchers.base import MatchBlock, Matcher
from vpr_smr.eval.matching.velocity import smallest

__all__ = ["attribute_engine", "block_native", "match_blocks", "smallest_scores", "split_features"]

# the candidates of a split's features (QueryFeatures' names), as the engine and this module give them
SEQUENCE_CANDIDATES = ("sequence_candidates", "sequence_candidate_references")


def attribute_engine(matcher: Matcher) -> SequenceMatcher:
    """The trajectory engine of ``matcher``'s attributes: its sequence length and ``attribute_velocities``."""
    return SequenceMatcher(matcher.seq_len, tuple(matcher.attribute_velocities))


def match_blocks(matcher: Matcher, matrix: Any, block_queries: int | None = None
                 ) -> Iterator[tuple[MatchBlock, int, np.ndarray]]:
    """``matcher.block`` over its evaluated queries of a whole ``R x Q`` matrix, in order, the state carried from
    block to block, starting from ``matcher.prepare(matrix)``: each ``MatchBlock`` with the first column and the
    columns (``read_columns``) it read. Blocks of ``block_queries`` evaluated queries (default
    ``SequenceMatcher.block_queries(R)``); a NaN or infinity a block (or ``prepare``) reports is counted over the
    whole matrix."""
    n_ref, n_query = (int(n) for n in matrix.shape)
    first, stop = matcher.evaluated(n_query)
    step = block_queries or SequenceMatcher.block_queries(n_ref)
    try:
        state = matcher.prepare(matrix)  # inside: a NaN or infinity its pass meets is counted as a block's is
        for start in range(first, stop, step):
            end = min(stop, start + step)
            lo = start - matcher.lookback
            columns = read_columns(matrix, lo, end + matcher.lookahead)
            found, state = matcher.block(columns, lo, state)
            yield found, lo, columns
    except NonFiniteError as error:
        raise error.counted_in(matrix) from None


def smallest_scores(scores: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``count`` smallest ``scores[n, r]`` of each row, ascending (equal values lowest ``r`` first), and their
    references; ``+inf`` and ``-1`` where a row has fewer than ``count`` finite values. The velocity search's
    selection (``velocity.smallest``: a partition of the groups' minima, not a full sort of every row, which cost
    13x a matcher's own block at R = 27592); a row with NaN, which has no place in that order, is sorted (NaN
    last)."""
    kept = min(count, scores.shape[1])
    if np.isnan(scores).any():
        order = np.argsort(scores, axis=1, kind="stable")[:, :kept]
        values = np.take_along_axis(scores, order, axis=1)
    else:
        values, order = smallest(scores, kept)
    width = max(count - values.shape[1], 0)
    values = np.pad(values, ((0, 0), (0, width)), constant_values=np.inf)
    references = np.where(np.isfinite(values), np.pad(order, ((0, 0), (0, width))), -1).astype(np.int64)
    return values, references


def block_native(matcher: Matcher, found: MatchBlock) -> np.ndarray:
    """The native confidence (float64, one per query) of a block of a matcher whose ``native_scorer`` is None;
    ValueError naming the matcher when the block gives none or another shape."""
    shape = (len(found.queries),)
    if found.native is None or np.shape(found.native) != shape:
        given = "none" if found.native is None else f"shape {np.shape(found.native)}"
        raise ValueError(f"the matcher {matcher.name!r} names no scorer of method §12 as its native confidence "
                         f"(native_scorer None), so each block must give it (MatchBlock.native of shape {shape}, one "
                         f"per query), but a block gave {given}: give the native confidence in block(), or name "
                         "its native_scorer")
    return np.asarray(found.native, dtype=np.float64)


def split_features(matcher: Matcher, distance_matrix: Any, n_ranks: int, block_queries: int | None = None,
                   screen_dtype: Any = np.float32, n_candidates: int = 0) -> dict[str, np.ndarray]:
    """The attributes of the ``n_ranks`` best trajectories (``attributes``, ``rank_references``), the single
    match, the matcher's match (``sequence_match``, its score ``sequence_distance`` and the largest finite score
    ``sequence_max``) and, with ``n_candidates``, the candidates (``SequenceMatcher.block_features``' names) of
    every query of ``queries`` (those ``matcher`` evaluates, ``a >= L - 1``), of a whole ``R x Q`` matrix;
    ``window_single_match``: the single match of every query ``a >= L - 1``, evaluated or not;
    ``sequence_native``: the matcher's native confidence (float64) where its ``native_scorer`` is None.
    ``block_queries``, ``screen_dtype``: as ``SequenceMatcher.features`` (they change no number)."""
    matrix = as_matrix(distance_matrix)
    engine = attribute_engine(matcher)
    matcher.check(tuple(matrix.shape))
    engine.check(tuple(matrix.shape))
    block_dtype(np.dtype(matrix.dtype))
    n_ref, n_query = (int(n) for n in matrix.shape)
    out = engine.features(matrix, n_ranks, block_queries, screen_dtype, n_candidates)
    out.pop("sequence_velocity", None)
    out["window_single_match"] = out["single_match"]  # every query a >= L - 1, the evaluated ones or not
    own_native = matcher.native_scorer is None
    if matcher.scores_are_attribute_sums:  # s_a is S: the match and candidates are the engine's, bit for bit
        if own_native:  # the engine's pass calls no block, so no native confidence could come from one
            raise ValueError(f"the matcher {matcher.name!r} takes its scores from the attributes' pass "
                             "(scores_are_attribute_sums), so its native confidence must be a scorer of method §12: "
                             "set its native_scorer")
        out["queries"] = np.arange(matcher.seq_len - 1, n_query)
        return out
    parts: dict[str, list[np.ndarray]] = {key: [] for key in (
        "queries", "sequence_match", "sequence_distance", "sequence_max", "sequence_native", *SEQUENCE_CANDIDATES)}
    for found, _, _ in match_blocks(matcher, matrix, block_queries):
        scores = np.asarray(found.scores, dtype=np.float64)
        if scores.shape != (len(found.queries), n_ref):
            raise ValueError(f"the matcher {matcher.name!r} gave scores of shape {scores.shape} for "
                             f"{len(found.queries)} queries and {n_ref} references")
        rows = np.arange(len(found.queries))
        match = np.asarray(found.match, dtype=np.int64)
        parts["queries"].append(np.asarray(found.queries, dtype=np.int64))
        parts["sequence_match"].append(match)
        parts["sequence_distance"].append(scores[rows, match])
        parts["sequence_max"].append(np.where(np.isfinite(scores), scores, -np.inf).max(axis=1))
        if own_native:
            parts["sequence_native"].append(block_native(matcher, found))
        if n_candidates:
            values, references = smallest_scores(scores, n_candidates)
            parts["sequence_candidates"].append(values)
            parts["sequence_candidate_references"].append(references)
    joined = {key: np.concatenate(value) for key, value in parts.items() if value}
    keep = joined.get("queries", np.zeros(0, dtype=np.int64)) >= matcher.seq_len - 1  # attributes need L columns
    if not keep.any():
        raise ValueError(f"the matcher {matcher.name!r} evaluates no query of this {n_ref} x {n_query} matrix that "
                         f"has a window of L = {matcher.seq_len} columns (queries {matcher.seq_len - 1} on)")
    window = joined["queries"][keep] - (matcher.seq_len - 1)  # rows of the engine's arrays
    result = {key: value if key == "window_single_match" else value[window] for key, value in out.items()
              if key not in SEQUENCE_CANDIDATES}
    result.update({key: value[keep] for key, value in joined.items()})
    return result
