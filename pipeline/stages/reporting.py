"""The stages of reporting (``pipeline.stage.Stage``)."""

from __future__ import annotations

from vpr_smr.pipeline.stage import Stage

STAGES: tuple[Stage, ...] = ()
