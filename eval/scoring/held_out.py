"""The ``ablation held-out`` stage: a method's test split under the pooled predictor and under the one trained
without it (leave-one-method-out, ``vpr-smr ablation without``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from vpr_smr.core.constants import MODES
from vpr_smr.core.io import JSON_SUFFIXES, check_suffix
from vpr_smr.core.records import save
from vpr_smr.eval.matching.attributes import Matching, check_matching, read_features, recorded_matching
from vpr_smr.eval.predictor.estimator import SMRPredictor
from vpr_smr.eval.predictor.leakage import check_disjoint, check_scored, frame_ranges, trained_on
from vpr_smr.eval.scoring.evaluate import removal
from vpr_smr.eval.scoring.records import HeldOut, HeldOutPredictors, HeldOutScores


def main(
    features: Path | str,
    pooled_predictor: Path | str,
    held_out_predictor: Path | str,
    out: Path | str,
    modes: tuple[str, ...] = MODES,
    meta: dict[str, Any] | None = None,
    allow_split_overlap: bool = False,
) -> HeldOut:
    """The held-out method's test split (``features``) under the pooled predictor and the ``without_`` one
    (``records.HeldOut``, each reduction with its bootstrap interval over queries), written to ``out``."""
    check_suffix(out, JSON_SUFFIXES, "the leave-one-method-out evaluation (JSON)")
    features_ = read_features(features)
    scores = {}
    for name, path in (("pooled", pooled_predictor), ("without", held_out_predictor)):
        if not Path(path).is_file():
            raise FileNotFoundError(f"predictor file not found: {path} (train it first)")
        check_disjoint(trained_on(path), frame_ranges([features]), allow_split_overlap, f"predictor {path}")
        predictor = SMRPredictor.load(path)
        check_matching(predictor, Matching.stored(features), str(features))
        check_scored(predictor, {str(features): features_}, allow_split_overlap)
        scores[name] = HeldOutScores.of(str(path), removal(
            features_, predictor.predict_proba(features_.attributes[:, 0, :]), predictor.classes_, tuple(modes),
            curves=False, intervals=True))
    result = HeldOut({**recorded_matching([features]), **(meta or {})}, len(features_.queries),
                     HeldOutPredictors(scores["pooled"], scores["without"]))
    save(out, result)
    return result
