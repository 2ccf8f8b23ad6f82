"""The ``baselines`` stage (``vpr-smr baselines``, method §12): every training-free scorer's detection of wrong
matches and its removal at the budget of each predictor seed, per split (``baselines.split_baselines``), the inputs
checked as ``vpr-smr metrics`` checks them (``vpr_metrics.check_inputs``)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from vpr_smr.core.constants import MODES
from vpr_smr.core.io import JSON_SUFFIXES, check_suffix
from vpr_smr.core.records import save
from vpr_smr.eval.matching.attributes import Matching, check_matching, read_features
from vpr_smr.eval.matching.ground_truth_files import read_ground_truth
from vpr_smr.eval.matching.io import open_distance_matrix, scored_shape, split_ground_truth
from vpr_smr.eval.predictor.estimator import SMRPredictor
from vpr_smr.eval.predictor.leakage import check_disjoint, check_scored, frame_ranges, trained_on
from vpr_smr.eval.scoring.baselines import (
    DEFAULT_SETTINGS,
    BaselineSettings,
    Prediction,
    check_candidates,
    split_baselines,
    spread_positions,
)
from vpr_smr.eval.scoring.records import Baselines
from vpr_smr.eval.scoring.vpr_metrics import MatcherSettings, check_inputs

__all__ = ["main"]


def main(
    distances: Mapping[str, Path | str],
    attributes: Mapping[str, Path | str],
    predictors: Sequence[Path | str],
    seq_len: int,
    tolerance: int,
    out: Path | str,
    settings: BaselineSettings = DEFAULT_SETTINGS,
    modes: Sequence[str] = MODES,
    meta: Mapping[str, Any] | None = None,
    allow_split_overlap: bool = False,
    matcher: MatcherSettings | None = None,
    similarity: bool = False,
    key: str | None = None,
    transpose: bool = False,
) -> Baselines:
    """The ``baselines`` stage (method §12): per split, every scorer's detection of wrong matches and its removal
    at the budget of each predictor seed (``predictors``: seed 0 first), written to ``out`` (JSON,
    ``records.Baselines``).

    ``attributes`` (split -> our features ``.h5``, holding the candidates ``settings`` need) give the matches and
    their verdicts; ``distances`` (the same splits' matrices, read for their shape and the positions they hold) the
    ground truth, as ``vpr_metrics.main`` builds it (``matcher``, ``tolerance``), whose reference positions
    ``spread`` measures. ``meta`` (dataset, method) is written with ``seq_len``, the settings, the ground truth, the
    matcher (``MatcherSpec.provenance``) and the predictor files.
    Every input is checked before any work."""
    out = check_suffix(out, JSON_SUFFIXES, "the training-free baselines (JSON)")
    matcher = matcher or MatcherSettings()
    built = matcher.spec.build(seq_len)
    distance_paths = {str(name): Path(path) for name, path in distances.items()}
    attribute_paths = {str(name): Path(path) for name, path in attributes.items()}
    if not attribute_paths or set(distance_paths) != set(attribute_paths):
        raise ValueError(f"give every split's attributes and distances (--attributes names "
                         f"{', '.join(attribute_paths) or 'none'}, --distances {', '.join(distance_paths) or 'none'})")
    if not predictors:
        raise ValueError("the baselines need the predictor files (one per seed, seed 0 first): their budgets")
    unknown = [mode for mode in modes if mode not in MODES]
    if unknown:
        raise ValueError(f"unknown metric modes {unknown}; choose from {', '.join(MODES)}")
    file_truth = (None if matcher.ground_truth is None
                  else read_ground_truth(matcher.ground_truth, matcher.ground_truth_key,
                                         within=scored_shape(distance_paths.values(), key, transpose)))
    check_inputs(distance_paths, attribute_paths, None, seq_len, tolerance, matcher, file_truth)
    models = []
    for path in map(Path, predictors):
        check_inputs({}, {}, path, seq_len, tolerance, matcher)
        check_disjoint(trained_on(path), frame_ranges(attribute_paths.values()), allow_split_overlap,
                       f"predictor {path}")
        models.append(SMRPredictor.load(path))
        check_matching(models[-1], Matching.of(matcher.spec, matcher.kind),
                       "the attributes " + ", ".join(map(str, attribute_paths.values())))
    features = {split: read_features(path) for split, path in attribute_paths.items()}
    for model in models:  # neither the attributes' matrices may share entries with its training ones
        check_scored(model, {str(attribute_paths[split]): found for split, found in features.items()},
                     allow_split_overlap, seq_len, "--seq-len")
    for split, path in attribute_paths.items():
        check_candidates(features[split], settings, str(path))
    splits = {}
    recorded: dict[str, Any] | None = None if file_truth is None else file_truth.provenance()
    for split in attribute_paths:
        path = distance_paths[split]
        with open_distance_matrix(path, similarity, key, transpose) as matrix:
            shape = tuple(int(n) for n in matrix.shape)
            truth = split_ground_truth(path, shape, tolerance, matcher.radius, matcher.reference_positions,
                                       matcher.query_positions, file_truth)
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
    info = {**dict(meta or {}), "seq_len": int(seq_len), **settings.meta(), "ground_truth": recorded,
            "matcher": matcher.spec.provenance(),
            "predictors": [str(path) for path in predictors]}
    result = Baselines(info, splits)
    save(out, result)
    return result
