"""The job of the experiment ``deployment`` (method §16), apart from its computation (``eval.scoring.deployment``),
so that the command line builds its options without importing the scoring: its settings record
(``DeploymentSettings``, the configuration's ``deployment:``), its files (``DeploymentInputs``) and the job
(``DeploymentJob``)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from vpr_smr.core.json_objects import json_object
from vpr_smr.core.settings import REQUIRED, parse, setting, to_json
from vpr_smr.eval.matching import sources
from vpr_smr.eval.matching.matchers import MatcherSpec
from vpr_smr.eval.matching.sources import TruthSource
from vpr_smr.eval.predictor.defaults import allow_split_overlap
from vpr_smr.eval.predictor.jobs import dataset_name
from vpr_smr.eval.scoring.scorers import BaselineSettings, baseline_settings
from vpr_smr.eval.scoring.thresholds import (
    DEFAULT_PRECISIONS,
    DEFAULT_RISK,
    DEFAULT_SEGMENT,
    check_precision,
    check_risk,
)

__all__ = ["DatasetFiles", "DeployedMatcher", "DeploymentInputs", "DeploymentJob", "DeploymentSettings"]

Json = dict[str, Any]


def precisions() -> Any:
    """The field of the target precisions (the configuration's ``deployment.precisions``, the stage's
    ``--precisions``)."""
    return setting(DEFAULT_PRECISIONS, "the target precisions p, each in (0, 1]: a threshold is chosen on the "
                                       "calibration split to reach each, and scored on every deployment",
                   schema={"type": "array", "items": {"type": "number", "exclusiveMinimum": 0, "maximum": 1},
                           "minItems": 1, "uniqueItems": True})


def risk() -> Any:
    return setting(DEFAULT_RISK, "the risk delta of the rule guaranteed, in (0, 1): its precision holds with "
                                 "probability at least 1 - delta on exchangeable queries",
                   schema={"type": "number", "exclusiveMinimum": 0, "exclusiveMaximum": 1})


def segment() -> Any:
    return setting(DEFAULT_SEGMENT, "queries per segment of a deployment: the share of segments whose precision is "
                                    "below the target (the shorter last segment joins its neighbour)", minimum=1)


def _checked(found: tuple[float, ...], delta: float, where: str) -> None:
    for value in found:
        check_precision(value, f"{where}precisions")
    check_risk(delta, f"{where}risk")


@dataclass(frozen=True)
class DeploymentSettings:
    """Method §16: thresholds calibrated on one split and deployed on the others (the experiment ``deployment``):
    the targets, the risk of the rule guaranteed, the segment size and the calibration split."""

    precisions: tuple[float, ...] = precisions()
    risk: float = risk()
    segment: int = segment()
    calibration: str | None = setting(None, "the calibration split, one of eval_splits (default: the validation "
                                            "split, the first of eval_splits); every other evaluation split is a "
                                            "deployment", metavar="SPLIT")

    def __post_init__(self) -> None:
        _checked(self.precisions, self.risk, "deployment.")


@dataclass(frozen=True)
class DatasetFiles:
    """A dataset's files the job reads beside the matchers': its ground truth and its splits' distances (the
    positions ``spread`` measures; the shapes the attributes are checked against)."""

    truth: TruthSource
    distances: dict[str, str]  # split -> path


@dataclass(frozen=True)
class DeployedMatcher:
    """One matcher's files: its spec, its tag (the name in the tables), its attributes per dataset and split, its
    predictors (seed 0 first; trained on the job's own dataset)."""

    tag: str
    spec: MatcherSpec
    attributes: dict[str, dict[str, str]]  # dataset -> split -> path
    predictors: tuple[str, ...]


@dataclass(frozen=True)
class DeploymentInputs:
    """The stage's ``inputs`` setting (a value class of ``core.settings``; on the command line its JSON text or
    ``@file``): the calibration split (of the job's dataset), the deployments as (dataset, split) pairs, each
    dataset's files and each matcher's."""

    calibration: str
    deployments: tuple[tuple[str, str], ...]
    datasets: dict[str, DatasetFiles]
    matchers: tuple[DeployedMatcher, ...]

    @classmethod
    def from_setting(cls, value: Any, where: str) -> DeploymentInputs:
        data = json_object(value, where)

        def entry(name: str, kind: type) -> Any:
            found = data.get(name)
            if not isinstance(found, kind) or not found:
                raise ValueError(f"{where}: \"{name}\" must be a non-empty {kind.__name__} (see vpr-smr deployment "
                                 "--help)")
            return found

        calibration = data.get("calibration")
        if not isinstance(calibration, str):
            raise ValueError(f"{where}: \"calibration\" must name the calibration split")
        deployments = tuple((str(pair[0]), str(pair[1])) for pair in entry("deployments", list))
        datasets = {str(name): DatasetFiles(parse(TruthSource, files.get("truth", {}), f"{where} datasets.{name}"),
                                            {str(s): str(p) for s, p in files.get("distances", {}).items()})
                    for name, files in entry("datasets", dict).items()}
        matchers = tuple(DeployedMatcher(str(one["tag"]), MatcherSpec.from_provenance(one.get("matcher"),
                                                                                      f"{where} matchers[{i}]"),
                                         {str(d): {str(s): str(p) for s, p in splits.items()}
                                          for d, splits in one.get("attributes", {}).items()},
                                         tuple(str(p) for p in one.get("predictors", ())))
                         for i, one in enumerate(entry("matchers", list)))
        return cls(calibration, deployments, datasets, matchers)

    def to_setting(self) -> Json:
        return {"calibration": self.calibration, "deployments": [list(pair) for pair in self.deployments],
                "datasets": {name: {"truth": to_json(files.truth), "distances": dict(files.distances)}
                             for name, files in self.datasets.items()},
                "matchers": [{"tag": one.tag, "matcher": one.spec.provenance(),
                              "attributes": {d: dict(splits) for d, splits in one.attributes.items()},
                              "predictors": list(one.predictors)} for one in self.matchers]}


@dataclass(frozen=True)
class DeploymentJob:
    """The ``deployment`` stage's job: the experiment ``deployment`` of one dataset and method at one L
    (``eval.scoring.deployment.main``)."""

    dataset: str = dataset_name()
    method: str = setting(REQUIRED, "the method's name (a key of the configuration's methods)", metavar="NAME")
    seq_len: int = sources.seq_len()
    inputs: DeploymentInputs = setting(
        REQUIRED, "the files as a JSON object (or @file): {\"calibration\": SPLIT, \"deployments\": [[DATASET, "
                  "SPLIT], ...], \"datasets\": {DATASET: {\"truth\": {...ground truth settings}, \"distances\": "
                  "{SPLIT: PATH}}}, \"matchers\": [{\"tag\": TAG, \"matcher\": {\"name\": ..., \"settings\": {...}}, "
                  "\"attributes\": {DATASET: {SPLIT: PATH}}, \"predictors\": [seed 0 first]}, ...]}",
        metavar="JSON")
    precisions: tuple[float, ...] = precisions()
    risk: float = risk()
    segment: int = segment()
    baselines: BaselineSettings = baseline_settings()
    allow_split_overlap: bool = allow_split_overlap()
    out: str = setting(REQUIRED, "the output file: the deployment experiment's result (JSON)", metavar="PATH")

    def __post_init__(self) -> None:
        _checked(self.precisions, self.risk, "--")


def deployments(eval_splits: Sequence[str], calibration: str, table_split: str, dataset: str,
                datasets: Sequence[str]) -> tuple[tuple[str, str], ...]:
    """The deployments of a dataset's job (method §16): every evaluation split but the calibration split, the table
    split first, then every other dataset's table split, in the configuration's order."""
    own = [table_split] if table_split != calibration else []
    own += [split for split in eval_splits if split not in (calibration, table_split)]
    return (*((dataset, split) for split in own), *((other, table_split) for other in datasets if other != dataset))


def deployment_name(job_dataset: str, dataset: str, split: str) -> str:
    """A deployment's name in the tables: its split, or ``<dataset>/<split>`` of another dataset."""
    return split if dataset == job_dataset else f"{dataset}/{split}"


def settings_of(values: Mapping[str, Any]) -> DeploymentSettings:
    """The configuration's ``deployment:`` section as its record."""
    return parse(DeploymentSettings, values, "deployment")
