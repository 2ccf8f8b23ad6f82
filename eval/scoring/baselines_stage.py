"""The ``baselines`` stage (``vpr-smr baselines``, method §12): every training-free scorer's detection of wrong
matches and its removal at the budget of each predictor seed, per split (``baselines.split_baselines``), the inputs
checked as ``vpr-smr metrics`` checks them (``vpr_metrics.check_inputs``, ``vpr_metrics.load_predictor``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from vpr_smr.core.constants import MODES
from vpr_smr.core.io import JSON_SUFFIXES, check_suffix
from vpr_smr.core.records import save
from vpr_smr.eval.matching.attributes import Matching, check_matching, read_features
from vpr_smr.eval.matching.ground_truth_files import read_ground_truth
from vpr_smr.eval.matching.io import open_distance_matrix, scored_shape, split_ground_truth
from vpr_smr.eval.predictor.leakage import check_disjoint, check_scored, frame_ranges, trained_on
from vpr_smr.eval.scoring.baselines import (
    Prediction,
    check_candidates,
    split_baselines,
    spread_positions,
)
from vpr_smr.eval.scoring.matrix_jobs import BaselinesJob
from vpr_smr.eval.scoring.records import Baselines
from vpr_smr.eval.scoring.vpr_metrics import check_inputs, load_predictor, truth_kind

__all__ = ["BaselinesJob", "main"]


def main(job: BaselinesJob) -> Baselines:
    """The ``baselines`` stage (method §12): per split, every scorer's detection of wrong matches and its removal
    at the budget of each predictor seed (``job.predictors``: seed 0 first), written to ``job.out`` (JSON,
    ``records.Baselines``).

    ``attributes`` (split -> our features ``.h5``, holding the candidates the ``scorers`` settings need) give the
    matches and their verdicts; ``distances`` (the same splits' matrices, read for their shape and the positions
    they hold) the ground truth, as ``vpr_metrics.main`` builds it (``matcher``, ``truth``), whose reference
    positions ``spread`` measures. The meta holds ``dataset``, ``method``, ``seq_len``, the settings, the ground
    truth, the matcher (``MatcherSpec.provenance``) and the predictor files. Every input is checked before any
    work."""
    out = check_suffix(job.out, JSON_SUFFIXES, "the training-free baselines (JSON)")
    seq_len, truth_source, matcher, matrix_format = job.seq_len, job.truth, job.matcher, job.matrix
    settings, predictors, modes = job.scorers, job.predictors, job.modes
    built = matcher.build(seq_len)
    distance_paths = {str(name): Path(path) for name, path in job.distances.items()}
    attribute_paths = {str(name): Path(path) for name, path in job.attributes.items()}
    if not attribute_paths or set(distance_paths) != set(attribute_paths):
        raise ValueError(f"give every split's attributes and distances (--attributes names "
                         f"{', '.join(attribute_paths) or 'none'}, --distances {', '.join(distance_paths) or 'none'})")
    if not predictors:
        raise ValueError("the baselines need the predictor files (one per seed, seed 0 first): their budgets")
    unknown = [mode for mode in modes if mode not in MODES]
    if unknown:
        raise ValueError(f"unknown metric modes {unknown}; choose from {', '.join(MODES)}")
    file_truth = (None if truth_source.ground_truth is None
                  else read_ground_truth(truth_source.ground_truth, truth_source.ground_truth_key,
                                         within=scored_shape(distance_paths.values(), matrix_format.key,
                                                             matrix_format.transpose)))
    check_inputs(distance_paths, attribute_paths, seq_len, truth_source, matcher, file_truth)
    models = []
    for path in map(Path, predictors):
        model = load_predictor(path, seq_len)
        check_disjoint(trained_on(path), frame_ranges(attribute_paths.values()), job.allow_split_overlap,
                       f"predictor {path}")
        models.append(model)
        check_matching(model, Matching.of(matcher, truth_kind(truth_source)),
                       "the attributes " + ", ".join(map(str, attribute_paths.values())))
    features = {split: read_features(path) for split, path in attribute_paths.items()}
    for model in models:  # neither the attributes' matrices may share entries with its training ones
        check_scored(model, {str(attribute_paths[split]): found for split, found in features.items()},
                     job.allow_split_overlap, seq_len, "--seq-len")
    for split, path in attribute_paths.items():
        check_candidates(features[split], settings, str(path))
    splits = {}
    recorded: dict[str, Any] | None = None if file_truth is None else file_truth.provenance()
    for split in attribute_paths:
        path = distance_paths[split]
        with open_distance_matrix(path, matrix_format.similarity, matrix_format.key,
                                  matrix_format.transpose) as matrix:
            shape = tuple(int(n) for n in matrix.shape)
            truth = split_ground_truth(path, shape, truth_source.tolerance, truth_source.radius,
                                       truth_source.reference_positions, truth_source.query_positions, file_truth)
        first, stop = built.evaluated(shape[1])
        expected = max(stop - max(first, seq_len - 1), 0)  # the evaluated queries with a window (QueryFeatures)
        if len(features[split].queries) != expected:
            raise ValueError(f"{attribute_paths[split]} holds {len(features[split].queries)} queries, but {path} is "
                             f"a {shape[0]} x {shape[1]} matrix ({expected} queries at L = {seq_len}): "
                             "give the attributes computed from it")
        recorded = truth.provenance() if recorded is None else recorded
        attributes_0 = features[split].attributes[:, 0, :]
        predictions = [Prediction(seed, np.asarray(model.predict_proba(attributes_0)),
                                          np.asarray(model.classes_)) for seed, model in enumerate(models)]
        splits[split] = split_baselines(features[split], settings, spread_positions(truth), predictions, modes)
    info = {"dataset": job.dataset, "method": job.method, "seq_len": int(seq_len), **settings.meta(),
            "ground_truth": recorded, "matcher": matcher.provenance(),
            "predictors": [str(path) for path in predictors]}
    result = Baselines(info, splits)
    save(out, result)
    return result
