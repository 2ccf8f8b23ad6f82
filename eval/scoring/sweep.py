"""How a conclusion depends on the ground-truth protocol (method §13.4): recall@1 before and after sequence matching
and Table I's reduction over a range of frame tolerances or position radii.

Neither the matches nor the predictor's decisions depend on the ground truth (the attributes are computed from the
distances alone), so one split's matches and one predictor's keep-mask are scored again under each tolerance; nothing
is matched or predicted again. A ground truth given as a matrix or lists has no tolerance to vary: it has no sweep.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from functools import partial
from typing import Any

import numpy as np

from vpr_smr.eval.matching.attributes import QueryFeatures, verdicts
from vpr_smr.eval.matching.ground_truth import FRAMES, GroundTruth, PositionTruth
from vpr_smr.eval.scoring.evaluate import compare_removal, recall_at_1
from vpr_smr.eval.scoring.intervals import difference, weighted_mean
from vpr_smr.eval.scoring.records import ProtocolSweep, SweepPoint

# The protocols the field reports: Nordland within 0 (the same frame), 1, 2 or 10 frames; 25 m and its neighbours
# for positions (seqNet reports recall over such a sweep of radii).
FRAME_TOLERANCES: tuple[float, ...] = (0, 1, 2, 5, 10)
RADII: tuple[float, ...] = (5, 10, 25, 50)


def within(kind: str, threshold: float) -> str:
    """``within 1 frame``, ``within 2 frames``, ``positions within 25``: one point of a sweep in words."""
    if kind == FRAMES:
        return f"within {threshold:g} frame{'' if threshold == 1 else 's'}"
    return f"positions within {threshold:g}"


def sweep_thresholds(truth: GroundTruth) -> tuple[str, tuple[float, ...]]:
    """The kind and the thresholds a ground truth is swept over: frame tolerances for frames, radii for positions;
    a ground truth given as a matrix or lists has none (ValueError)."""
    if not isinstance(truth, PositionTruth):
        raise ValueError(f"the ground truth {truth.describe()} has no tolerance or radius to vary: the protocol "
                         "sweep needs frame indices within a tolerance or positions within a radius")
    return (truth.kind, FRAME_TOLERANCES if truth.kind == FRAMES else RADII)


def rescored(features: QueryFeatures, single_matches: np.ndarray, truth: GroundTruth) -> QueryFeatures:
    """``features`` with every correctness and label of ``truth`` (the matches are kept): ``single_matches`` is the
    single-frame match of every query of the split, the first ``L - 1`` too (paper mode's recall@1 counts them)."""
    changes: dict[str, Any] = verdicts(truth, features.queries, features.single_match, features.sequence_match,
                                       features.rank_references, single_matches)
    return replace(features, **changes)


def protocol_sweep(features: QueryFeatures, single_matches: np.ndarray, truth: GroundTruth, modes: Sequence[str],
                   kept: np.ndarray | None = None, thresholds: Sequence[float] | None = None) -> ProtocolSweep:
    """Recall@1 and, with ``kept`` (the predictor's keep-mask of the evaluated queries), the reduction of its
    removal, per mode, under ``truth`` with each of ``thresholds`` (default ``sweep_thresholds``) as its tolerance or
    radius; with the change sequence matching makes to recall@1 over the same evaluated queries, and the bootstrap
    intervals over queries (method §8.7) of that change and of the reduction."""
    kind, default = sweep_thresholds(truth)
    assert isinstance(truth, PositionTruth)  # sweep_thresholds refuses the others
    points: dict[str, list[SweepPoint]] = {mode: [] for mode in modes}
    for threshold in (default if thresholds is None else thresholds):
        scored = rescored(features, single_matches, truth.within(float(threshold)))
        single = np.asarray(scored.single_correct, dtype=np.float64)
        sequence = np.asarray(scored.sequence_correct, dtype=np.float64)
        change = difference(partial(weighted_mean, sequence), partial(weighted_mean, single), len(single))
        for mode in modes:
            reduction = compare_removal(scored, mode, kept, intervals=True)[2] if kept is not None else None
            points[mode].append(SweepPoint(float(threshold), *recall_at_1(scored, mode), reduction,
                                           float(single.mean()) if len(single) else None, change))
    return ProtocolSweep(kind, {mode: tuple(found) for mode, found in points.items()})
