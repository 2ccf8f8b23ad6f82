"""Every stage of the workflow, each declared once (``pipeline.stage.Stage``), by the part of the data flow it
belongs to. The command line, the workflow's rules and the Python API take them from ``STAGES``."""

from __future__ import annotations

from vpr_smr.pipeline.stage import Stage
from vpr_smr.pipeline.stages import matching, predictor, reporting, scoring, studies, thresholds

__all__ = ["COMMAND_GROUPS", "STAGES", "stage"]

STAGES: tuple[Stage, ...] = (*matching.STAGES, *predictor.STAGES, *scoring.STAGES, *thresholds.STAGES,
                             *studies.STAGES, *reporting.STAGES)

# the help of a command whose stages are its subcommands (``ablation attributes``, ...)
COMMAND_GROUPS = {"ablation": "the predictor's ablations"}


def stage(command: str) -> Stage:
    """The stage of ``command`` (its words, e.g. ``ablation held-out``); KeyError naming the known ones."""
    for one in STAGES:
        if one.command == command:
            return one
    raise KeyError(f"no stage {command!r}; the stages: {', '.join(one.command for one in STAGES)}")
