"""The experiment ``deployment`` (method §16): per dataset and method at Table I's sequence length, every matcher's
confidence sources (the training-free scorers, the oracle, the predictor of every seed) calibrated on the
calibration split by each rule and scored on every other evaluation split and every other dataset's table split.

The matchers are the run's own (``sequence_matching``) and, when the experiment ``matchers`` is on, each of its
matchers, whose attributes and predictors that experiment computes. The stage is
``pipeline.stages.studies.DEPLOYMENT`` (``vpr-smr deployment``); its table, sentences, figure and section are
declared in ``eval.report.tables.deployment``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

from vpr_smr.core.paths import (
    attributes_path,
    deployment_path,
    distances_path,
    matcher_attributes_path,
    matcher_predictor_paths,
    predictor_paths,
)
from vpr_smr.core.settings import to_json
from vpr_smr.eval.report.tables.deployment import FIGURES, TABLES
from vpr_smr.eval.scoring.deployment_jobs import DeploymentInputs, DeploymentJob, deployments
from vpr_smr.pipeline.experiment import Experiment, Job, relative
from vpr_smr.pipeline.rule_helpers import ground_truth_input
from vpr_smr.pipeline.stages.scoring import SCORERS_PARAM
from vpr_smr.pipeline.stages.studies import DEPLOYMENT

if TYPE_CHECKING:
    from vpr_smr.eval.matching.matchers import MatcherSpec
    from vpr_smr.pipeline.config import Config
    from vpr_smr.pipeline.plan import Plan

NAME = "deployment"


def matchers(conf: Config) -> dict[str, MatcherSpec]:
    """The matchers by tag: the run's own first, then each of the experiment ``matchers``' when it is on."""
    from vpr_smr.eval.scoring.matcher_comparison import matcher_tag
    from vpr_smr.pipeline.config import experiments

    found = {matcher_tag(conf.sequence_matching): conf.sequence_matching}
    if "matchers" in experiments(conf):
        found.update((matcher_tag(spec), spec) for spec in conf.matchers if spec != conf.sequence_matching)
    return found


def _files(out: str, conf: Config, plan: Plan, dataset: str, method: str, seq_len: str) -> dict[str, Any]:
    """The stage's ``--inputs`` (``DeploymentInputs``' JSON): the calibration split, the deployments, each dataset's
    ground truth and distances, each matcher's attributes (the run's own files for the run's matcher) and
    predictors (of the job's dataset)."""
    calibration = conf.calibration_split
    pairs = deployments(conf.eval_splits, calibration, conf.table_split, dataset, list(conf.datasets))
    needed = [(dataset, calibration), *pairs]
    datasets = {name: {"truth": to_json(plan.datasets[name].truth),
                       "distances": {split: distances_path(out, name, method, split)
                                     for d, split in needed if d == name}}
                for name in dict.fromkeys(d for d, _ in needed)}
    entries = []
    for tag, spec in matchers(conf).items():
        own = spec == conf.sequence_matching
        attributes = {name: {split: (attributes_path(out, name, method, seq_len, split) if own else
                                     matcher_attributes_path(out, name, tag, method, seq_len, split))
                             for d, split in needed if d == name} for name in datasets}
        predictors = (predictor_paths(out, dataset, seq_len, conf.seeds) if own
                      else matcher_predictor_paths(out, dataset, tag, seq_len, conf.seeds))
        entries.append({"tag": tag, "matcher": spec.provenance(), "attributes": attributes,
                        "predictors": predictors})
    return {"calibration": calibration, "deployments": [list(pair) for pair in pairs], "datasets": datasets,
            "matchers": entries}


def inputs(out: str, conf: Config, plan: Plan, wildcards: Mapping[str, str]) -> dict[str, str | Sequence[str]]:
    """Every file of ``_files``, and each dataset's ground-truth file (method §13)."""
    found = _files(out, conf, plan, wildcards["dataset"], wildcards["method"], wildcards["seq_len"])
    paths = [path for files in found["datasets"].values() for path in files["distances"].values()]
    paths += [path for entry in found["matchers"] for splits in entry["attributes"].values()
              for path in splits.values()]
    paths += [path for entry in found["matchers"] for path in entry["predictors"]]
    truths = [path for name in found["datasets"] for path in ground_truth_input(plan, name)]
    return {"files": list(dict.fromkeys(paths)), "truth": truths}


def record(conf: Config, plan: Plan, wildcards: Mapping[str, str], files: Mapping[str, Any], out: str
           ) -> DeploymentJob:
    """The files (``_files``, in the run folder), the targets, the risk, the segment size, the scorers' settings."""
    dataset, method, seq_len = wildcards["dataset"], wildcards["method"], wildcards["seq_len"]
    settings = conf.deployment
    return DeploymentJob(dataset, method, int(seq_len), DeploymentInputs.from_setting(
        _files(str(conf.run_dir), conf, plan, dataset, method, seq_len), "inputs"), tuple(settings.precisions),
        settings.risk, settings.segment, conf.baselines, conf.allow_split_overlap, out)


# it computes every registered scorer's confidence: a scorer plugin installed reruns it
JOB = Job(DEPLOYMENT, relative(deployment_path("", "{dataset}", "{method}", "{seq_len}")), inputs, record,
          layout=True, params=SCORERS_PARAM, rule="deployment")

EXPERIMENT = Experiment(NAME, "thresholds calibrated on one split by each rule, for every confidence source and "
                        "matcher, scored on the other evaluation splits and datasets at table_seq_len (method §16)",
                        (JOB,), TABLES, FIGURES)
