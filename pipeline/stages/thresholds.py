"""The stages of method §16's thresholds: ``calibrate`` (a rule's threshold on a calibration split, written as a
threshold file) and ``deploy`` (that file applied to another split). Their job records and work are
``eval.scoring.calibrate_stage``'s, imported when a stage runs (the queries' scoring imports scikit-learn)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from vpr_smr.eval.scoring.calibrate_stage import CalibrateJob, DeployJob
from vpr_smr.pipeline.stage import Stage, wrote

if TYPE_CHECKING:
    from vpr_smr.eval.scoring.calibrate_stage import Calibrated, DeployedSplit

__all__ = ["CALIBRATE", "DEPLOY", "STAGES"]


def _calibrate(job: CalibrateJob) -> Calibrated:
    from vpr_smr.eval.scoring import calibrate_stage

    return calibrate_stage.calibrate_main(job)


def _calibrate_text(job: CalibrateJob, result: Calibrated) -> str:
    from vpr_smr.eval.scoring import calibrate_stage

    return calibrate_stage.calibrate_text(job, result)


def _calibrate_summary(job: CalibrateJob, result: Calibrated) -> str:
    return wrote("the threshold file", job.out, result.file.described())


def _deploy(job: DeployJob) -> DeployedSplit:
    from vpr_smr.eval.scoring import calibrate_stage

    return calibrate_stage.deploy_main(job)


def _deploy_text(job: DeployJob, result: DeployedSplit) -> str:
    from vpr_smr.eval.scoring import calibrate_stage

    return calibrate_stage.deploy_text(job, result)


def _deploy_summary(job: DeployJob, result: DeployedSplit) -> str:
    headline = f"{result.accepted} of {result.n_queries} accepted" + ("" if result.outcome is None
                                                                      else f", {result.outcome}")
    return wrote(f"the threshold on split {result.split}", job.out, headline)


CALIBRATE = Stage(
    "calibrate", "a threshold on a calibration split's confidences, for a target precision (method §16): the "
                 "threshold file", CalibrateJob, _calibrate, summary=_calibrate_summary, show=_calibrate_text,
    epilog="e.g. vpr-smr calibrate --queries queries.csv --split val --source uniqueness --precision 0.9 --rule "
           "guaranteed --risk 0.1 --out thr.json")

DEPLOY = Stage(
    "deploy", "a threshold file applied to another split: the accepted queries and, with labels, the realised "
              "precision and recall (method §16)", DeployJob, _deploy, summary=_deploy_summary, show=_deploy_text,
    epilog="e.g. vpr-smr deploy --thresholds thr.json --queries queries.csv --split test --accepted accepted.csv "
           "--out deployed.json")

STAGES: tuple[Stage, ...] = (CALIBRATE, DEPLOY)
