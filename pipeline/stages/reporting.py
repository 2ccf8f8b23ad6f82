"""The stage of the report: ``report``, the tables, figures and report.html of a run."""

from __future__ import annotations

import argparse
from pathlib import Path

from vpr_smr.core.settings import declared
from vpr_smr.eval.report.job import ReportJob, RunFiles
from vpr_smr.pipeline.options import option
from vpr_smr.pipeline.stage import Stage

__all__ = ["REPORT", "STAGES"]


def _report(job: ReportJob) -> list[Path]:
    from vpr_smr.eval.report import build  # the tables and figures: imported by the command that draws them

    return build.main(job)


def _empty_lists(parser: argparse.ArgumentParser) -> None:
    """The file lists of ``RunFiles`` may be given empty (``--speed`` with no file), as in earlier versions: the
    workflow gave each list whether or not its experiment ran."""
    for item in declared(RunFiles):
        parser._option_string_actions[option(item.name)].nargs = "*"


REPORT = Stage("report", "paper-style tables, figures and report.html of a run", ReportJob, _report,
               summary=lambda job, written: f"{len(written)} tables, figures and report files under {job.out}",
               legacy=_empty_lists)

STAGES: tuple[Stage, ...] = (REPORT,)
