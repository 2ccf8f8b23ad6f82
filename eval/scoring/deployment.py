"""The experiment ``deployment`` (method §16): for one dataset and method at one L, every matcher's confidence
sources calibrated on the calibration split by each rule (``thresholds``) and scored on every deployment.

Each matcher's attributes of every split give the sequence matches, their labels (``sequence_correct``: a query
without a correct reference is wrong) and the candidates the training-free scorers read; the sources are those
scorers (``baselines.query_scores``: all but ``random``), ``oracle`` and the predictor of every seed (its
confidence ``1 - P(class 1) - P(class 3)``; on another dataset's split the job's own dataset's predictor: a robot
carries one model). Inputs are read and checked as the baselines stage reads them (``baselines_stage``); nothing
is written before every input is checked.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vpr_smr.core.records import save
from vpr_smr.eval.matching.attributes import Matching, QueryFeatures, check_matching, read_features
from vpr_smr.eval.matching.ground_truth_files import read_ground_truth
from vpr_smr.eval.matching.io import open_distance_matrix, scored_shape, split_ground_truth
from vpr_smr.eval.predictor.leakage import check_disjoint, check_scored, frame_ranges, trained_on
from vpr_smr.eval.scoring import scorers, thresholds
from vpr_smr.eval.scoring.baselines import check_candidates, query_scores, spread_positions
from vpr_smr.eval.scoring.deployment_jobs import DeploymentJob, deployment_name
from vpr_smr.eval.scoring.deployment_records import (
    PREDICTOR_SOURCE,
    Chosen,
    DeploymentResult,
    DeploymentRow,
    RiskCoverage,
)
from vpr_smr.eval.scoring.thresholds import GUARANTEED, ORACLE_THRESHOLD, RULES, SAME_FRACTION
from vpr_smr.eval.scoring.vpr_metrics import check_inputs, load_predictor, truth_kind

__all__ = ["CURVE_POINTS", "Sources", "deploy_sources", "main", "sources_of", "thin"]

CURVE_POINTS = 200  # the most points a risk-coverage curve keeps for the figure

Key = tuple[str, int | None]  # a source and its seed (the predictor's), None for the others


@dataclass(frozen=True)
class Sources:
    """One matcher's split: its name (a deployment's, or the calibration split's), each source's confidence per
    query (in the split's query order) and the labels."""

    name: str
    confidence: dict[Key, np.ndarray]
    correct: np.ndarray


def sources_of(name: str, features: QueryFeatures, settings: scorers.BaselineSettings, positions: np.ndarray,
               predictions: Sequence[tuple[np.ndarray, np.ndarray]]) -> Sources:
    """The sources of method §16 on one split: every registered scorer's confidence but ``random`` and the
    predictor's (``baselines.query_scores``, seed 0), then each predictor seed's from its class probabilities and
    classes (``predictions``, seed 0 first)."""
    found: dict[Key, np.ndarray] = {(source, None): value
                                    for source, value in query_scores(features, settings, positions).items()
                                    if source not in (scorers.RANDOM, scorers.PREDICTOR)}
    for seed, (probabilities, classes) in enumerate(predictions):
        found[(PREDICTOR_SOURCE, seed)] = scorers.predictor_confidence(probabilities, classes)
    return Sources(name, found, np.asarray(features.sequence_correct, dtype=bool))


def thin(coverage: np.ndarray, risk: np.ndarray, points: int = CURVE_POINTS) -> np.ndarray:
    """The indices a drawn curve keeps: every one when there are at most ``points``, else ``points`` evenly spaced
    in coverage from the first to the last (both kept), each the first point at or past its coverage."""
    n = len(coverage)
    if n <= points:
        return np.arange(n)
    wanted = np.linspace(coverage[0], coverage[-1], points)
    chosen = np.minimum(np.searchsorted(coverage, wanted, side="left"), n - 1)
    return np.unique(np.concatenate([[0], chosen, [n - 1]]))


def deploy_sources(tag: str, calibration: Sources, deployments: Sequence[Sources], precisions: Sequence[float],
                   risk: float, segment: int) -> tuple[list[DeploymentRow], list[RiskCoverage]]:
    """Every source of one matcher calibrated on ``calibration`` by every rule at every target and scored on each
    deployment (intervals for every source but the predictor's seeds after the first: their spread is the seeds'),
    with the ceiling ``oracle_threshold`` of each deployment; and the calibration split's risk-coverage curve of
    each source (seed 0 of the predictor's)."""
    weights = {d.name: thresholds.bootstrap_weights(len(d.correct)) for d in deployments if len(d.correct)}
    rows, curves = [], []
    for key, confidence in calibration.confidence.items():
        source, seed = key
        intervals = seed in (None, 0)
        chosen = []
        for precision in precisions:
            calibrated = {rule: thresholds.calibrate(confidence, calibration.correct, precision, rule, risk)
                          for rule in RULES}
            chosen += [Chosen(rule, precision, found.threshold) for rule, found in calibrated.items()
                       if rule != SAME_FRACTION]
            for deployed in deployments:
                if not len(deployed.correct):
                    continue
                values = deployed.confidence[key]
                ceiling_at = thresholds.calibrate(values, deployed.correct, precision, ORACLE_THRESHOLD)
                ceiling = thresholds.realise(thresholds.accept(values, ceiling_at), deployed.correct, intervals,
                                             weights[deployed.name])
                for rule, found in calibrated.items():
                    accepted = thresholds.accept(values, found)
                    realised = thresholds.realise(accepted, deployed.correct, intervals, weights[deployed.name])
                    rows.append(DeploymentRow(
                        tag, source, seed, rule, precision, found.risk, found, deployed.name, realised, ceiling,
                        ceiling.recall - realised.recall,
                        thresholds.segments(accepted, deployed.correct, precision, segment),
                        thresholds.outcome(realised, precision)))
        if seed in (None, 0):
            coverage, risks, cuts = thresholds.risk_coverage(confidence, calibration.correct)
            kept = thin(coverage, risks)
            curves.append(RiskCoverage(tag, source, tuple(map(float, coverage[kept])), tuple(map(float, risks[kept])),
                                       tuple(map(float, cuts[kept])), tuple(chosen)))
    return rows, curves


def notes_of(tag: str, calibration: Sources, precisions: Sequence[float], risk: float) -> list[str]:
    """What the calibration split cannot give, in words: no correct match (every rule abstains), or, at a target
    where ``guaranteed`` abstains for a source (seed 0 of the predictor's), a split smaller than the rule needs with
    distinct confidences (tied ones may need fewer: the note counts the sources that did abstain)."""
    n = len(calibration.correct)
    if not calibration.correct.any():
        return [f"{tag}: the calibration split {calibration.name} holds no correct sequence match among its {n} "
                "queries: every rule abstains"]
    found = []
    keys = [key for key in calibration.confidence if key[1] in (None, 0)]
    for precision in precisions:
        if precision >= 1:
            found.append(f"{tag}: guaranteed cannot reach precision 1 from a finite calibration split: it abstains")
            continue
        needed = thresholds.smallest_calibration(precision, risk)
        if n >= needed:
            continue
        abstained = [key[0] for key in keys if thresholds.calibrate(
            calibration.confidence[key], calibration.correct, precision, GUARANTEED, risk).abstains]
        if abstained:
            found.append(f"{tag}: guaranteed needs at least {needed} calibration queries for precision {precision:g} "
                         f"at risk {risk:g} (with distinct confidences); the calibration split {calibration.name} has "
                         f"{n}: it abstains there for {len(abstained)} of {len(keys)} sources")
    return found


@dataclass(frozen=True)
class _Split:
    features: QueryFeatures
    positions: np.ndarray


def _read_splits(job: DeploymentJob) -> dict[str, dict[tuple[str, str], _Split]]:
    """Per matcher tag, per (dataset, split) the job needs, the features and the reference positions, every file
    checked as the baselines stage checks it (the attributes against their matrix, the ground truth, the
    matcher, the candidates the scorers need)."""
    inputs = job.inputs
    needed = [(job.dataset, inputs.calibration), *inputs.deployments]
    out: dict[str, dict[tuple[str, str], _Split]] = {one.tag: {} for one in inputs.matchers}
    for dataset in dict.fromkeys(d for d, _ in needed):
        if dataset not in inputs.datasets:
            raise ValueError(f"--inputs: no \"datasets\" entry for {dataset!r} (its ground truth and distances)")
        files = inputs.datasets[dataset]
        splits = [s for d, s in needed if d == dataset]
        distances = {}
        for split in splits:
            if split not in files.distances:
                raise ValueError(f"--inputs: datasets.{dataset} has no distances of split {split!r} (it has "
                                 f"{', '.join(files.distances) or 'none'})")
            distances[split] = Path(files.distances[split])
        file_truth = (None if files.truth.ground_truth is None
                      else read_ground_truth(files.truth.ground_truth, files.truth.ground_truth_key,
                                             within=scored_shape(distances.values())))
        for one in inputs.matchers:
            paths = one.attributes.get(dataset, {})
            missing = [split for split in splits if split not in paths]
            if missing:
                raise ValueError(f"--inputs: matcher {one.tag} has no attributes of {dataset} split(s) "
                                 f"{', '.join(missing)}")
            attributes = {split: Path(paths[split]) for split in splits}
            check_inputs(distances, attributes, job.seq_len, files.truth, one.spec, file_truth)
            built = one.spec.build(job.seq_len)
            for split in splits:
                features = read_features(attributes[split])
                check_candidates(features, job.baselines, str(attributes[split]))
                with open_distance_matrix(distances[split]) as matrix:
                    shape = tuple(int(n) for n in matrix.shape)
                    truth = split_ground_truth(distances[split], shape, files.truth.tolerance, files.truth.radius,
                                               files.truth.reference_positions, files.truth.query_positions,
                                               file_truth)
                first, stop = built.evaluated(shape[1])
                expected = max(stop - max(first, job.seq_len - 1), 0)
                if len(features.queries) != expected:
                    raise ValueError(f"{attributes[split]} holds {len(features.queries)} queries, but "
                                     f"{distances[split]} is a {shape[0]} x {shape[1]} matrix ({expected} queries at "
                                     f"L = {job.seq_len}): give the attributes computed from it")
                out[one.tag][(dataset, split)] = _Split(features, spread_positions(truth))
    return out


def _scored(found: _Split, name: str, models: Sequence[Any], job: DeploymentJob) -> Sources:
    """The sources of one split: the scorers' on its features, each predictor's on its rank-0 attributes."""
    ranked = found.features.attributes[:, 0, :]
    return sources_of(name, found.features, job.baselines, found.positions,
                      [(np.asarray(m.predict_proba(ranked)), np.asarray(m.classes_)) for m in models])


def main(job: DeploymentJob) -> DeploymentResult:
    """The ``deployment`` stage (method §16): every matcher's sources calibrated on the job's dataset's
    calibration split and scored on every deployment, written to ``job.out`` (JSON, ``DeploymentResult``).
    Every input is checked before any work: the attributes, distances and ground truths as the baselines stage
    checks them, each predictor (trained at ``seq_len`` with the matcher's matching, and on none of the job's own
    dataset's scored frames)."""
    from vpr_smr.core.io import JSON_SUFFIXES, check_suffix

    out = check_suffix(job.out, JSON_SUFFIXES, "the deployment experiment's result (JSON)")
    inputs = job.inputs
    if not inputs.deployments:
        raise ValueError("--inputs: no deployment: give at least one (dataset, split) other than the calibration "
                         "split")
    pairs = list(inputs.deployments)
    if (job.dataset, inputs.calibration) in pairs or len(set(pairs)) != len(pairs):
        raise ValueError(f"--inputs: the deployments {pairs} repeat one or hold the calibration split "
                         f"({job.dataset}, {inputs.calibration}): give each other split once")
    splits = _read_splits(job)
    own_truth = inputs.datasets[job.dataset].truth
    rows: list[DeploymentRow] = []
    curves: list[RiskCoverage] = []
    notes: list[str] = []
    for one in inputs.matchers:
        if not one.predictors:
            raise ValueError(f"--inputs: matcher {one.tag} has no predictors (one per seed, seed 0 first)")
        own = {split: str(one.attributes[job.dataset][split]) for d, split in splits[one.tag] if d == job.dataset}
        models = []
        for path in map(Path, one.predictors):
            model = load_predictor(path, job.seq_len)
            check_disjoint(trained_on(path), frame_ranges(own.values()), job.allow_split_overlap,
                           f"predictor {path}")
            check_scored(model, {own[split]: splits[one.tag][(job.dataset, split)].features for split in own},
                         job.allow_split_overlap, job.seq_len, "--seq-len")
            check_matching(model, Matching.of(one.spec, truth_kind(own_truth)), f"matcher {one.tag}'s attributes")
            models.append(model)

        calibration = _scored(splits[one.tag][(job.dataset, inputs.calibration)], inputs.calibration, models, job)
        deployed = [_scored(splits[one.tag][(d, s)], deployment_name(job.dataset, d, s), models, job)
                    for d, s in inputs.deployments]
        notes += notes_of(one.tag, calibration, job.precisions, job.risk)
        notes += [f"{one.tag}: the deployment {d.name} holds no evaluated query" for d in deployed
                  if not len(d.correct)]
        found_rows, found_curves = deploy_sources(one.tag, calibration, deployed, job.precisions, job.risk,
                                                  job.segment)
        rows += found_rows
        curves += found_curves
    sizes = {one.tag: len(splits[one.tag][(job.dataset, inputs.calibration)].features.queries)
             for one in inputs.matchers}
    meta = {"dataset": job.dataset, "method": job.method, "seq_len": int(job.seq_len),
            "calibration": inputs.calibration, "n_calibration": sizes,
            "deployments": [deployment_name(job.dataset, d, s) for d, s in inputs.deployments],
            "precisions": [float(p) for p in job.precisions], "risk": float(job.risk), "segment": int(job.segment),
            "matchers": {one.tag: one.spec.provenance() for one in inputs.matchers},
            "seeds": len(inputs.matchers[0].predictors), **job.baselines.meta(),
            "predictors": {one.tag: list(one.predictors) for one in inputs.matchers}}
    result = DeploymentResult(meta, tuple(rows), tuple(curves), tuple(notes))
    save(out, result)
    return result

