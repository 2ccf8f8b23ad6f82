"""Hand-built records of the experiment deployment (method §16) for the report's tests: its own
(``unit/test_deployment_report.py``) and a whole report run's (``deployment_files``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from vpr_smr.core.records import save
from vpr_smr.eval.scoring.deployment_records import DeploymentResult, DeploymentRow
from vpr_smr.eval.scoring.records import Interval
from vpr_smr.eval.scoring.thresholds import (
    ABSTAINED,
    EMPIRICAL,
    GUARANTEED,
    HELD,
    VIOLATED,
    Calibration,
    Realised,
    Segments,
)

OWN, OTHER = "seqslam", "seqslam_v2"
NONE_BELOW = Segments(100, 2, 2, 0)  # two segments with acceptance, none below the target


def realised(n: int, accepted: int, wrong: int, ci: Interval | None = None) -> Realised:
    """A realised record from its counts (precision None when nothing is accepted, as the method says)."""
    precision = None if accepted == 0 else (accepted - wrong) / accepted
    return Realised(n, accepted, wrong, precision, (accepted - wrong) / n, accepted / n, ci, None)


def row(source: str, rule: str, p: float, threshold: float | None, deployed: Realised, ceiling: Realised,
        outcome: str, seed: int | None = None, matcher: str = OWN, deployment: str = "test",
        segments: Segments = NONE_BELOW) -> DeploymentRow:
    """A row calibrated on 100 queries (40 accepted, 4 wrong; none when it abstains)."""
    risk = 0.1 if rule == GUARANTEED else None
    calibration = Calibration(rule, p, risk, threshold, 100, 0 if threshold is None else 40, 0 if threshold is None
                              else 4)
    return DeploymentRow(matcher, source, seed, rule, p, risk, calibration, deployment, deployed, ceiling,
                         ceiling.recall - deployed.recall, segments, outcome)


def meta(method: str = "netvlad", deployments: tuple[str, ...] = ("test",), dataset: str = "nordland"
         ) -> dict[str, Any]:
    """A result's meta as the stage writes it, with what the report reads."""
    return {"dataset": dataset, "method": method, "seq_len": 4, "calibration": "val",
            "deployments": list(deployments), "precisions": [0.9, 0.95]}


def several(dataset: str = "nordland", methods: tuple[str, str] = ("netvlad", "cosplace")) -> list[DeploymentResult]:
    """Two methods, each deployed on two splits (``test`` and another dataset's, ``oxford/test``), the outcomes
    varying over the cells: predictor/empirical held in all four, distance/empirical fell below 0.9 in three (once
    with its interval wholly below, once holding 0.9, once without one), spread/guaranteed abstained in two."""
    deployments = ("test", "oxford/test")
    results = []
    plan = {  # (method, deployment) -> per (source, rule): (accepted, wrong, outcome, interval)
        (0, "test"): {("predictor", EMPIRICAL): (50, 4, HELD, None), ("distance", EMPIRICAL): (
            40, 8, VIOLATED, Interval(0.7, 0.85)), ("spread", GUARANTEED): (0, 0, ABSTAINED, None)},
        (0, "oxford/test"): {("predictor", EMPIRICAL): (60, 3, HELD, None), ("distance", EMPIRICAL): (
            40, 5, VIOLATED, Interval(0.8, 0.95)), ("spread", GUARANTEED): (10, 0, HELD, None)},
        (1, "test"): {("predictor", EMPIRICAL): (70, 7, HELD, None), ("distance", EMPIRICAL): (40, 2, HELD, None),
                      ("spread", GUARANTEED): (0, 0, ABSTAINED, None)},
        (1, "oxford/test"): {("predictor", EMPIRICAL): (30, 0, HELD, None), ("distance", EMPIRICAL): (
            40, 10, VIOLATED, None), ("spread", GUARANTEED): (20, 1, HELD, None)},
    }
    for i, method in enumerate(methods):
        rows = []
        for deployment in deployments:
            for (source, rule), (accepted, wrong, outcome, ci) in plan[i, deployment].items():
                rows.append(row(source, rule, 0.9, None if accepted == 0 else 0.5, realised(100, accepted, wrong, ci),
                                realised(100, 80, 8), outcome, 0 if source == "predictor" else None,
                                deployment=deployment))
        results.append(DeploymentResult(meta(method, deployments, dataset) | {"precisions": [0.9]}, tuple(rows), (),
                                        ()))
    return results


def deployment_files(folder: Path, dataset: str = "d", methods: tuple[str, str] = ("m1", "m2")) -> list[str]:
    """``several``'s results of ``dataset`` and ``methods`` written as the stage writes them (one file per method),
    with a note: what ``RunFiles.deployment`` lists."""
    out = []
    for result in several(dataset, methods):
        path = folder / f"deployment_{dataset}_{result.meta['method']}.json"
        save(path, DeploymentResult(result.meta, result.rows, result.curves, (f"{OWN}: a note",)))
        out.append(str(path))
    return out
