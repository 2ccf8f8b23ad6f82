"""The stages that score distance matrices and attributes: ``metrics`` (the standard VPR metrics), ``queries`` (the
per-query table of the same scoring) and ``baselines`` (the training-free scorers against the predictor, method
§12). Their job records are ``eval.scoring.matrix_jobs``'; the work's modules are imported when a stage runs (they
import scikit-learn, which the other commands do without)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from vpr_smr.eval.scoring.matrix_jobs import BaselinesJob, MetricsJob, QueriesJob
from vpr_smr.pipeline.stage import Stage, wrote

if TYPE_CHECKING:
    from vpr_smr.eval.scoring.records import Baselines, VPRMetrics

__all__ = ["BASELINES", "METRICS", "QUERIES", "STAGES"]


def _metrics(job: MetricsJob) -> VPRMetrics:
    from vpr_smr.eval.scoring import vpr_metrics

    return vpr_metrics.main(job)


def _metrics_tables(job: MetricsJob, result: VPRMetrics) -> str:
    """The metrics per split, mode and matcher, then the training-free scorers' table (when scored)."""
    from vpr_smr.eval.scoring import vpr_metrics

    text = vpr_metrics.format_metrics(result)
    found = vpr_metrics.format_baselines(result)
    if found:
        shown = ", ".join(f"{key} {value}" for key, value in job.scorers.meta().items())
        text += f"\n\ntraining-free scorers (method §12; {shown}):\n{found}"
    return text


def _metrics_summary(job: MetricsJob, result: VPRMetrics) -> str:
    mode = job.modes[0] if job.modes else None
    headline = "; ".join(f"{name}: sequence recall@1 {split.modes[mode]['sequence'].recall_at[1]:.4f} ({mode} mode)"
                         for name, split in result.splits.items() if mode in split.modes)
    return wrote("the metrics", job.out, headline)


def _queries(job: QueriesJob) -> Path:
    from vpr_smr.eval.scoring import queries_stage

    return queries_stage.main(job)  # it says what it wrote: the queries and splits it counts


def _baselines(job: BaselinesJob) -> Baselines:
    from vpr_smr.eval.scoring import baselines_stage

    return baselines_stage.main(job)


def _baselines_summary(job: BaselinesJob, found: Baselines) -> str:
    headline = "; ".join(
        f"{name}: {split.n_wrong} wrong sequence matches of {split.n_queries}, average precision "
        + ", ".join(f"{scorer} {detection.average_precision:.4f}" for scorer, detection in split.detection.items()
                    if detection.average_precision is not None)
        for name, split in found.splits.items())
    return wrote(f"the training-free scorers of {job.method}", job.out, headline)


METRICS = Stage(
    "metrics", "standard VPR metrics (recall@N, R@100P, PR-AUC, EP) of distance matrices", MetricsJob, _metrics,
    summary=_metrics_summary, show=_metrics_tables,
    epilog="e.g. vpr-smr metrics --distances D.npy --seq-len 4 --out metrics.json;  vpr-smr metrics --distances "
           "val=val.h5 test=test.h5 --seq-len 4 --predictor L4.h5 --queries queries.csv --out metrics.json")

QUERIES = Stage(
    "queries", "one row per evaluated query of distance matrices: matches, distances, attributes, true class and the "
               "predictor's decision (CSV)", QueriesJob, _queries,
    epilog="e.g. vpr-smr queries --distances val=val.h5 test=test.h5 --seq-len 4 --predictor L4.h5 --out queries.csv "
           "(the same table as vpr-smr metrics --queries)")

BASELINES = Stage(
    "baselines", "training-free scorers against the predictor: wrong-match detection and removal at every predictor "
                 "seed's budget (method §12)", BaselinesJob, _baselines, summary=_baselines_summary,
    epilog="e.g. vpr-smr baselines --dataset D --method M --seq-len 4 --distances val=v.h5 test=t.h5 --attributes "
           "val=va.h5 test=ta.h5 --predictors L4.h5 L4.seed1.h5 --out L4.json")

STAGES: tuple[Stage, ...] = (METRICS, QUERIES, BASELINES)
