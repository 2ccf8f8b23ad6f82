"""The ``ablation held-out`` stage: a method's test split under the pooled predictor and under the one trained
without it (leave-one-method-out, ``vpr-smr ablation without``)."""

from __future__ import annotations

from pathlib import Path

from vpr_smr.core.io import JSON_SUFFIXES, check_suffix
from vpr_smr.core.records import save
from vpr_smr.eval.matching.attributes import Matching, check_matching, check_seq_len, read_features, recorded_matching
from vpr_smr.eval.predictor.estimator import SMRPredictor
from vpr_smr.eval.predictor.jobs import HeldOutJob as HeldOutJob  # the stage's job, named here too
from vpr_smr.eval.predictor.leakage import check_disjoint, check_scored, frame_ranges, trained_on
from vpr_smr.eval.scoring.evaluate import removal
from vpr_smr.eval.scoring.records import HeldOut, HeldOutPredictors, HeldOutScores


def main(job: HeldOutJob) -> HeldOut:
    """The held-out method's test split (``job.attributes``, of ``job.seq_len``) under the pooled predictor and the
    ``without_`` one (``records.HeldOut``, each reduction with its bootstrap interval over queries), written to
    ``job.out``."""
    features, out, allow_split_overlap = job.attributes, job.out, job.allow_split_overlap
    check_suffix(out, JSON_SUFFIXES, "the leave-one-method-out evaluation (JSON)")
    check_seq_len([features], job.seq_len)
    features_ = read_features(features)
    scores = {}
    for name, path in (("pooled", job.pooled), ("without", job.without)):
        if not Path(path).is_file():
            raise FileNotFoundError(f"predictor file not found: {path} (train it first)")
        check_disjoint(trained_on(path), frame_ranges([features]), allow_split_overlap, f"predictor {path}")
        predictor = SMRPredictor.load(path)
        check_matching(predictor, Matching.stored(features), str(features))
        check_scored(predictor, {str(features): features_}, allow_split_overlap)
        scores[name] = HeldOutScores.of(str(path), removal(
            features_, predictor.predict_proba(features_.attributes[:, 0, :]), predictor.classes_, job.modes,
            curves=False, intervals=True))
    meta = {"dataset": job.dataset, "method": job.method, "seq_len": job.seq_len}
    result = HeldOut({**recorded_matching([features]), **meta}, len(features_.queries),
                     HeldOutPredictors(scores["pooled"], scores["without"]))
    save(out, result)
    return result
