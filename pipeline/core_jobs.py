"""The core workflow's jobs, each declared once beside its stage (``pipeline.stages``' ``matching``, ``predictor``
and ``scoring``: a ``pipeline.experiment.Job`` of the stage, its output path, its inputs and its record from the
wildcards): ``pipeline/rules/jobs.smk`` makes one rule of each, named by its ``rule``, as it does of the
experiments' jobs. Two rule files are written by hand: ``rules/report.smk`` (the report: no wildcards, every file of
the run its input, the registry's files its outputs) and ``rules/matchers.smk`` (the experiment ``matchers`` takes
the rules ``attributes`` and ``train`` as they are, with its own paths and records: ``use rule``)."""

from __future__ import annotations

from vpr_smr.pipeline.experiment import Job
from vpr_smr.pipeline.stages import matching, predictor, scoring

__all__ = ["JOBS"]

JOBS: tuple[Job, ...] = (*matching.JOBS, *predictor.JOBS, *scoring.JOBS)
