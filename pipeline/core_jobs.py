"""The core workflow's jobs, each declared once beside its stage (``pipeline.stages``' ``matching``, ``predictor``
and ``scoring``: a ``pipeline.experiment.Job`` of the stage, its output path, its inputs and its record from the
wildcards): ``pipeline/rules/jobs.smk`` makes one rule of each, named by its ``rule``, as it does of the
experiments' jobs. The rules not made so are written in ``pipeline/rules/``: ``descriptors`` (a GPU resource and the
speed options given as a resource), ``report`` (the gathering rule: every file of the run as its input) and the
experiment ``matchers``' ``use rule`` of ``attributes`` and ``train``."""

from __future__ import annotations

from vpr_smr.pipeline.experiment import Job
from vpr_smr.pipeline.stages import matching, predictor, scoring

__all__ = ["JOBS"]

JOBS: tuple[Job, ...] = (*matching.JOBS, *predictor.JOBS, *scoring.JOBS)
