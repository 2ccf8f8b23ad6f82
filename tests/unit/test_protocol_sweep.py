"""The protocol sweep (method §13): the same matches and keep-mask scored under other tolerances or radii equal a
fresh scoring at each; the sentence that names what changes across the sweep, on hand-made rows."""

from __future__ import annotations

import numpy as np
import pytest

from vpr_smr.eval.matching.attributes import query_features
from vpr_smr.eval.matching.ground_truth import GroundTruth
from vpr_smr.eval.report.build import sweep_rows
from vpr_smr.eval.report.findings import sweep_sentences
from vpr_smr.eval.scoring.evaluate import compare_removal, recall_at_1
from vpr_smr.eval.scoring.records import SplitMetrics, VPRMetrics
from vpr_smr.eval.scoring.sweep import FRAME_TOLERANCES, RADII, protocol_sweep, sweep_thresholds


def _matrix(n: int = 90, seed: int = 3) -> np.ndarray:
    """Distances with a noisy diagonal: matches land at various offsets, so the tolerance matters."""
    rng = np.random.default_rng(seed)
    offset = np.abs(np.arange(n)[:, None] - np.arange(n)[None, :])
    return (np.minimum(offset, 12) / 12 + 0.9 * rng.random((n, n))).astype(np.float64)


@pytest.mark.parametrize("mode", ["paper", "standard"])
def test_each_point_equals_a_fresh_scoring_at_its_tolerance(mode):
    matrix = _matrix()
    features = query_features(matrix, 4, 2)
    kept = np.random.default_rng(0).random(len(features.queries)) > 0.3  # any keep-mask: the predictor's decisions
    single = np.argmin(matrix, axis=0)
    swept = protocol_sweep(features, single, GroundTruth.aligned(90, 90, 2), (mode,), kept)
    assert swept.kind == "frames" and [p.threshold for p in swept.modes[mode]] == list(FRAME_TOLERANCES)
    for point in swept.modes[mode]:
        fresh = query_features(matrix, 4, int(point.threshold))  # matched again, labelled at this tolerance
        recall = recall_at_1(fresh, mode)
        assert point.recall_at_1_single == recall["recall_at_1_single"]
        assert point.recall_at_1_sequence == recall["recall_at_1_sequence"]
        assert point.reduction == compare_removal(fresh, mode, kept, intervals=True)[2]


def test_positions_sweep_radii_and_a_matrix_has_nothing_to_sweep():
    positions = GroundTruth.positions(np.arange(10.0) * 3, np.arange(10.0) * 3, 25.0)
    assert sweep_thresholds(positions) == ("positions", RADII)
    with pytest.raises(ValueError, match="no tolerance or radius to vary"):
        sweep_thresholds(GroundTruth.matrix(np.eye(10, dtype=bool)))


def _rows(reductions: dict[str, list[float | None]], recalls: dict[str, list[float]], single: float = 0.1):
    out = []
    for method in reductions:
        for threshold, reduction, recall in zip((0, 2, 10), reductions[method], recalls[method], strict=True):
            out.append({"dataset": "d", "method": method, "seq_len": 4, "split": "test", "mode": "paper",
                        "ground_truth": "frames", "threshold": float(threshold), "recall_at_1_single": single,
                        "recall_at_1_sequence": recall, "reduction_pct": reduction})
    return out


def test_the_sentence_names_a_sign_change_and_a_swap():
    rows = _rows({"a": [12.5, 3.0, -4.25], "b": [20.0, 30.0, None]}, {"a": [0.2, 0.5, 0.9], "b": [0.3, 0.4, 0.8]})
    (sentence,) = sweep_sentences(rows)
    assert sentence.startswith("With matches counted correct within 0 to 10 frames (d, test split, L = 4, paper mode), "
                               "a conclusion depends on the ground truth:")
    assert "the predictor's AOC reduction for a changes sign (12.5 % within 0 frames, -4.2 % within 10 frames)" \
        in sentence
    assert "a and b swap places by sequence recall@1 (a ahead within 2 frames, b within 0 frames)" in sentence


def test_the_sentence_says_when_nothing_changes():
    rows = _rows({"a": [1.0, 2.0, 3.0], "b": [None, 0.0, 5.0]}, {"a": [0.2, 0.5, 0.9], "b": [0.1, 0.4, 0.8]})
    (sentence,) = sweep_sentences(rows)
    assert "no conclusion depends on the ground truth" in sentence


def test_rows_from_metrics_in_the_configurations_order():
    features = query_features(_matrix(), 4, 2)
    swept = protocol_sweep(features, np.argmin(_matrix(), axis=0), GroundTruth.aligned(90, 90, 2), ("paper",))
    records = [VPRMetrics({"dataset": "d", "method": m, "seq_len": 4}, {"test": SplitMetrics({}, sweep=swept)})
               for m in ("zeta", "alpha")]
    rows = sweep_rows(records, "test")
    assert [(r["method"], r["threshold"]) for r in rows][:2] == [("zeta", 0.0), ("zeta", 1.0)]
    assert len(rows) == 10 and all("reduction_pct" not in r for r in rows)
