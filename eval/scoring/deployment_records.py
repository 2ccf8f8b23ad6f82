"""The records of the experiment ``deployment`` (method §16), apart from its computation
(``eval.scoring.deployment``), so that the report reads them without importing the scoring."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from vpr_smr.core.records import FileRecord, Record
from vpr_smr.eval.scoring.thresholds import Calibration, Realised, Segments

__all__ = ["PREDICTOR_SOURCE", "Chosen", "DeploymentResult", "DeploymentRow", "RiskCoverage"]

PREDICTOR_SOURCE = "predictor"  # the source scored per seed (seed 0 the table's and the figure's)


@dataclass(frozen=True)
class DeploymentRow(Record):
    """One matcher's source (the predictor: of one seed), rule and target precision, calibrated on the calibration
    split and scored on one deployment (a split name, or ``<dataset>/<split>`` of another dataset): the calibration
    (``Calibration``), what it does there (``realised``, with intervals for every source but the predictor's seeds
    after the first), the ceiling (``oracle_threshold`` on the deployment itself), the recall lost against it, the
    segments and the outcome (``thresholds.HELD``, ``VIOLATED``, ``ABSTAINED``)."""

    matcher: str
    source: str
    seed: int | None
    rule: str
    precision: float
    risk: float | None
    calibration: Calibration
    deployment: str
    realised: Realised
    ceiling: Realised
    recall_lost: float
    segments: Segments
    outcome: str


@dataclass(frozen=True)
class Chosen(Record):
    """A threshold a rule chose on the calibration split for a target (None: it abstains)."""

    rule: str
    precision: float
    threshold: float | None


@dataclass(frozen=True)
class RiskCoverage(Record):
    """One matcher's source on the calibration split: the coverage and the risk (one minus the precision) of
    accepting from each distinct confidence down (thinned to at most ``deployment.CURVE_POINTS``, the ends kept), and
    the thresholds the rules chose there (``same_fraction`` sets none on the calibration split: left out)."""

    matcher: str
    source: str
    coverage: tuple[float, ...]
    risk: tuple[float, ...]
    thresholds: tuple[float, ...]
    chosen: tuple[Chosen, ...]


@dataclass(frozen=True)
class DeploymentResult(FileRecord):
    """The experiment ``deployment`` of one dataset and method at one L (``eval.scoring.deployment.main``).
    ``meta``: dataset, method, seq_len, the calibration split and its size per matcher, the deployments, the
    targets, the risk, the segment size, the matchers (tag -> provenance), the seeds, the scorers' settings and
    the predictor files. ``rows``: per matcher (the run's first), source, seed, target, rule and deployment.
    ``curves``: per matcher and source (seed 0), the calibration split's risk-coverage curve. ``notes``: what
    the result cannot say, in words (a calibration split too small for a target, one without a correct match)."""

    meta: dict[str, Any]
    rows: tuple[DeploymentRow, ...]
    curves: tuple[RiskCoverage, ...]
    notes: tuple[str, ...]
