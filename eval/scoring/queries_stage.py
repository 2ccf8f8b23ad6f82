"""The ``queries`` stage (``vpr-smr queries``): the per-query table of every split (``queries.QUERY_COLUMNS`` and
the scorers' columns), scored as ``vpr-smr metrics`` scores them (``vpr_metrics.score_all``: one implementation)."""

from __future__ import annotations

import logging
from collections.abc import Mapping
from pathlib import Path

from vpr_smr.core.io import CSV_SUFFIXES, check_suffix
from vpr_smr.eval.scoring.baselines import DEFAULT_SETTINGS, BaselineSettings
from vpr_smr.eval.scoring.queries import write_queries
from vpr_smr.eval.scoring.vpr_metrics import MatcherSettings, score_all

__all__ = ["main"]

log = logging.getLogger("vpr_smr")


def main(
    distances: Mapping[str, Path | str] | Path | str,
    seq_len: int,
    tolerance: int,
    out: Path | str,
    predictor: Path | str | None = None,
    attributes: Mapping[str, Path | str] | None = None,
    allow_split_overlap: bool = False,
    matcher: MatcherSettings | None = None,
    similarity: bool = False,
    key: str | None = None,
    transpose: bool = False,
    baselines: BaselineSettings | None = DEFAULT_SETTINGS,
) -> Path:
    """The ``queries`` stage: the per-query table (``queries.QUERY_COLUMNS`` and ``SCORE_COLUMNS``) of every split
    of ``distances`` in the given order, written to ``out`` (CSV), as ``vpr_metrics.main``'s ``queries`` (the same
    code; no metric mode changes it). The inputs as ``vpr_metrics.main``'s (``matcher``: the sequence matcher and
    the ground truth, default ``MatcherSpec.of()``, the paper's, and frames within ``tolerance``)."""
    out = check_suffix(out, CSV_SUFFIXES, "the per-query table (CSV)")
    matcher = matcher or MatcherSettings()
    scored = score_all(distances, seq_len, tolerance, predictor, attributes, (), allow_split_overlap, matcher,
                       similarity, key, transpose, baselines=baselines)
    write_queries(out, [scored_split.queries for scored_split in scored.splits.values()])
    n_splits = len(scored.splits)
    log.info("wrote %d queries of %d split%s to %s", sum(len(r.queries.features.queries)
                                                       for r in scored.splits.values()),
             n_splits, "" if n_splits == 1 else "s", out)
    return out
