"""The records of the Python API, from one module: ``from vpr_smr.records import QueryFeatures``.

What the functions of ``vpr_smr.api`` return and take (the matcher's spec, a ground truth, a predictor), the records
of the results files that the stages write and the report reads (``vpr_smr.api.run_stage`` returns them), and the
setting groups that several stages share. Each is declared where its stage computes it; this module only gathers
them, so that a notebook needs one import and not the modules' paths. All are frozen dataclasses except
``GroundTruth`` (an abstract class, made by ``vpr_smr.api.read_ground_truth`` or its ``aligned``/``matrix``),
``SMRPredictor`` (a scikit-learn estimator) and ``SplitLeakError`` (an exception).
"""

from __future__ import annotations

from vpr_smr.eval.matching.attributes import QueryFeatures
from vpr_smr.eval.matching.fingerprint import MatrixPrint
from vpr_smr.eval.matching.ground_truth import GroundTruth
from vpr_smr.eval.matching.matchers import MatcherSpec
from vpr_smr.eval.matching.matchers.base import MatchBlock
from vpr_smr.eval.matching.sources import MatrixFormat, TruthSource
from vpr_smr.eval.predictor.estimator import SMRPredictor
from vpr_smr.eval.predictor.leakage import FrameRange, SplitLeakError, Training
from vpr_smr.eval.scoring.calibrate_stage import Deployed, DeployedSplit
from vpr_smr.eval.scoring.queries import Prediction
from vpr_smr.eval.scoring.records import (
    Baselines,
    BudgetRemoval,
    Detection,
    Evaluation,
    EvaluationSplit,
    HeldOut,
    HeldOutPredictors,
    HeldOutScores,
    Interval,
    MatcherMetrics,
    ModeRemoval,
    PRCurve,
    ProtocolSweep,
    Reduction,
    RemovalCurves,
    RestorationMode,
    RestorationNumbers,
    ScorerRemoval,
    SeedNumbers,
    SeedSummary,
    SplitBaselines,
    SplitMetrics,
    SplitTiming,
    SweepPoint,
    Timing,
    TrustNumbers,
    Versus,
    VPRMetrics,
)
from vpr_smr.eval.scoring.threshold_file import ThresholdFile
from vpr_smr.eval.scoring.thresholds import Calibration, Realised, Segments

# by what gives them: the matching, the predictor, the scoring of a split, a results file, the shared settings
__all__ = [
    "QueryFeatures", "MatchBlock", "MatcherSpec", "GroundTruth", "MatrixPrint",
    "SMRPredictor", "Training", "FrameRange", "SplitLeakError", "Prediction",
    "SplitMetrics", "MatcherMetrics", "ProtocolSweep", "SweepPoint",
    "EvaluationSplit", "ModeRemoval", "Reduction", "Interval", "PRCurve", "RemovalCurves", "TrustNumbers",
    "SeedNumbers", "SeedSummary", "RestorationMode", "RestorationNumbers",
    "SplitBaselines", "Detection", "Versus", "BudgetRemoval", "ScorerRemoval",
    "HeldOutScores", "HeldOutPredictors", "SplitTiming",
    "VPRMetrics", "Evaluation", "Baselines", "HeldOut", "Timing",
    "Calibration", "Deployed", "Realised", "Segments", "ThresholdFile", "DeployedSplit",
    "TruthSource", "MatrixFormat",
]
