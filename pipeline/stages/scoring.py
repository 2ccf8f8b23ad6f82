"""The stages that score distance matrices and attributes: ``metrics`` (the standard VPR metrics), ``queries`` (the
per-query table of the same scoring) and ``baselines`` (the training-free scorers against the predictor, method
§12). Their job records are ``eval.scoring.matrix_jobs``'; the work's modules are imported when a stage runs (they
import scikit-learn, which the other commands do without). Their workflow jobs: ``JOBS`` (each one's output, inputs
and record, of which ``pipeline/rules/jobs.smk`` makes its rule)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vpr_smr.core.paths import baselines_path, queries_path, vpr_metrics_path
from vpr_smr.eval.scoring.matrix_jobs import BaselinesJob, MetricsJob, QueriesJob
from vpr_smr.pipeline.experiment import Job, relative
from vpr_smr.pipeline.rule_helpers import RuleFiles, rule_files
from vpr_smr.pipeline.stage import Stage, wrote

if TYPE_CHECKING:
    from vpr_smr.eval.scoring.records import Baselines, VPRMetrics
    from vpr_smr.pipeline.config import Config
    from vpr_smr.pipeline.plan import Plan

__all__ = ["BASELINES", "JOBS", "METRICS", "QUERIES", "SCORERS_PARAM", "STAGES"]


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


# --- the workflow's jobs of these stages (``pipeline/rules/jobs.smk`` makes a rule of each) --------------------------


def _baselines_record(conf: Config, plan: Plan, wildcards: Mapping[str, str], files: Mapping[str, Any], out: str
                      ) -> BaselinesJob:
    """The splits' files by name, the dataset's ground truth (method §§11, 13: a file is an input, cut to each split
    by the stage), the run's matcher and the scorers' settings (method §12)."""
    return BaselinesJob(wildcards["dataset"], wildcards["method"], int(wildcards["seq_len"]),
                        dict(zip(conf.eval_splits, files["distances"], strict=True)),
                        dict(zip(conf.eval_splits, files["attributes"], strict=True)), tuple(files["predictors"]),
                        plan.datasets[wildcards["dataset"]].truth, conf.sequence_matching, scorers=conf.baselines,
                        modes=tuple(conf.modes), allow_split_overlap=conf.allow_split_overlap, out=out)


def _sweeps(conf: Config, plan: Plan, dataset: str) -> bool:
    """Whether the protocol sweep runs on ``dataset``: the experiment is on and the dataset has a tolerance or a
    radius to vary (method §13: a ground-truth file has none)."""
    from vpr_smr.pipeline.config import experiments

    return "protocol_sweep" in experiments(conf) and plan.datasets[dataset].ground_truth is None


def _items(conf: Config, files: Mapping[str, Any]) -> tuple[tuple[str, ...], dict[str, str]]:
    """The metrics' and the per-query table's SPLIT=PATH items of the distances, and the attributes by split."""
    return (tuple(f"{split}={path}" for split, path in zip(conf.eval_splits, files["distances"], strict=True)),
            dict(zip(conf.eval_splits, files["attributes"], strict=True)))


def _metrics_record(conf: Config, plan: Plan, wildcards: Mapping[str, str], files: Mapping[str, Any], out: str
                    ) -> MetricsJob:
    """SPLIT=PATH items, the dataset's ground truth (method §§11, 13: a file is an input, cut to each split by the
    stage), the run's matcher, the scorers' settings (method §12), the modes, and the protocol sweep where the
    experiment runs on a dataset with a tolerance or a radius."""
    dataset, (distances, attributes) = wildcards["dataset"], _items(conf, files)
    return MetricsJob(distances, int(wildcards["seq_len"]), plan.datasets[dataset].truth, conf.sequence_matching,
                      predictor=files["predictor"], attributes=attributes, modes=tuple(conf.modes),
                      sweep=_sweeps(conf, plan, dataset), dataset=dataset, method=wildcards["method"],
                      scorers=conf.baselines, allow_split_overlap=conf.allow_split_overlap, out=out)


def _queries_record(conf: Config, plan: Plan, wildcards: Mapping[str, str], files: Mapping[str, Any], out: str
                    ) -> QueriesJob:
    """As the metrics' record, without the modes and the sweep."""
    distances, attributes = _items(conf, files)
    return QueriesJob(distances, int(wildcards["seq_len"]), plan.datasets[wildcards["dataset"]].truth,
                      conf.sequence_matching, predictor=files["predictor"], attributes=attributes,
                      scorers=conf.baselines, allow_split_overlap=conf.allow_split_overlap, out=out)


def _scorers(conf: Config, plan: Plan, wildcards: Mapping[str, str]) -> str:
    """The rule param ``scorers``: the registered scorers, each plugin's with its version (``scorers.registered``).
    These jobs compute every one of them, and no setting names them: installing, upgrading or removing a scorer
    plugin changes this param, so that Snakemake and ``vpr-smr run`` compute these files again (and the report
    after them), where a file written before would lack the new scorer."""
    from vpr_smr.eval.scoring.scorers import registered

    return registered()


SCORERS_PARAM = (("scorers", _scorers),)  # the param of each job that computes every registered scorer


# The training-free scorers against the predictor (method §12), at every predictor seed's budget: every L, so that the
# sequence-length ablation shows the best of them beside the predictor. They read the method's distances and
# attributes of every evaluation split, every seed's predictor and the dataset's ground-truth file (or none); the
# metrics and the per-query table the same with the seed-0 predictor only (the authors' recipe). The per-query table
# is a job of its own: it does not depend on the metric modes, so a change of them reruns the metrics and the report,
# not this table and the match inspector that reads it.
BASELINES_JOB = Job(BASELINES, relative(baselines_path("", "{dataset}", "{method}", "{seq_len}")),
                    rule_files(RuleFiles.baselines), _baselines_record, params=SCORERS_PARAM, rule="baselines")
METRICS_JOB = Job(METRICS, relative(vpr_metrics_path("", "{dataset}", "{method}", "{seq_len}")),
                  rule_files(RuleFiles.metrics), _metrics_record, params=SCORERS_PARAM, rule="vpr_metrics")
QUERIES_JOB = Job(QUERIES, relative(queries_path("", "{dataset}", "{method}", "{seq_len}")),
                  rule_files(RuleFiles.metrics), _queries_record, params=SCORERS_PARAM, rule="queries")

JOBS: tuple[Job, ...] = (BASELINES_JOB, METRICS_JOB, QUERIES_JOB)
