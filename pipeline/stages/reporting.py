"""The stage of the report: ``report``, the tables, figures and report.html of a run."""

from __future__ import annotations

from pathlib import Path

from vpr_smr.eval.report.job import ReportJob
from vpr_smr.pipeline.stage import Stage

__all__ = ["REPORT", "STAGES"]


def _report(job: ReportJob) -> list[Path]:
    from vpr_smr.eval.report import build  # the tables and figures: imported by the command that draws them

    return build.main(job)


REPORT = Stage("report", "paper-style tables, figures and report.html of a run", ReportJob, _report,
               summary=lambda job, written: f"{len(written)} tables, figures and report files under {job.out}")

STAGES: tuple[Stage, ...] = (REPORT,)
