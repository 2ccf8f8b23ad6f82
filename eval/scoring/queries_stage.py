"""The ``queries`` stage (``vpr-smr queries``): the per-query table of every split (``queries.QUERY_COLUMNS`` and
the scorers' columns), scored as ``vpr-smr metrics`` scores them (``vpr_metrics.score_all``: one implementation)."""

from __future__ import annotations

import logging
from pathlib import Path

from vpr_smr.core.io import CSV_SUFFIXES, check_suffix
from vpr_smr.eval.scoring.matrix_jobs import QueriesJob
from vpr_smr.eval.scoring.queries import write_queries
from vpr_smr.eval.scoring.vpr_metrics import score_all

__all__ = ["QueriesJob", "main"]

log = logging.getLogger("vpr_smr")


def main(job: QueriesJob) -> Path:
    """The ``queries`` stage: the per-query table (``queries.QUERY_COLUMNS`` and ``SCORE_COLUMNS``) of every split
    of ``job.distances`` in the given order, written to ``job.out`` (CSV), as ``vpr_metrics.main``'s ``queries``
    (the same code; no metric mode changes it). The inputs as ``vpr_metrics.main``'s (``matcher``: the sequence
    matcher, default ``MatcherSpec.of()``, the paper's; ``truth``: the ground truth, default frames within the
    tolerance)."""
    out = check_suffix(job.out, CSV_SUFFIXES, "the per-query table (CSV)")
    scored = score_all(job)
    write_queries(out, [scored_split.queries for scored_split in scored.splits.values()])
    n_splits = len(scored.splits)
    log.info("wrote %d queries of %d split%s to %s", sum(len(r.queries.features.queries)
                                                       for r in scored.splits.values()),
             n_splits, "" if n_splits == 1 else "s", out)
    return out
