"""The protocol sweep (method §13): the same matches and keep-mask scored under other tolerances or radii equal a
fresh scoring at each; the sentence that names what changes across the sweep, on hand-made rows."""

from __future__ import annotations

import numpy as np
import pytest
from row_records import records

from vpr_smr.eval.matching.attributes import query_features
from vpr_smr.eval.matching.ground_truth import GroundTruth
from vpr_smr.eval.report.findings import sweep_headline, sweep_sentences
from vpr_smr.eval.report.rows import SweepRow
from vpr_smr.eval.report.tabulate import sweep_rows
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
        assert (point.recall_at_1_single, point.recall_at_1_sequence) == recall_at_1(fresh, mode)
        assert point.reduction == compare_removal(fresh, mode, kept, intervals=True)[2]


def test_positions_sweep_radii_and_a_matrix_has_nothing_to_sweep():
    positions = GroundTruth.positions(np.arange(10.0) * 3, np.arange(10.0) * 3, 25.0)
    assert sweep_thresholds(positions) == ("positions", RADII)
    with pytest.raises(ValueError, match="no tolerance or radius to vary"):
        sweep_thresholds(GroundTruth.matrix(np.eye(10, dtype=bool)))


def _rows(reductions: dict[str, list[float | None]], recalls: dict[str, list[float]], single: float = 0.1):
    """Sweep rows by hand; each reduction's interval its value +- 1 (a direction), single-frame recall@1 ``single``
    over all queries and over the evaluated ones, sequence matching's change with an interval +- 0.05 about it."""
    out = []
    for method in reductions:
        for threshold, reduction, recall in zip((0, 2, 10), reductions[method], recalls[method], strict=True):
            row = {"dataset": "d", "method": method, "seq_len": 4, "split": "test", "mode": "paper",
                   "ground_truth": "frames", "threshold": float(threshold), "recall_at_1_single": single,
                   "recall_at_1_sequence": recall, "reduction_pct": reduction, "recall_at_1_single_evaluated": single,
                   "recall_change_ci_low": recall - single - 0.05, "recall_change_ci_high": recall - single + 0.05,
                   "n_queries": 28}
            if reduction is not None:
                row.update(outcome="improved" if reduction > 0 else "worse" if reduction < 0 else "unchanged",
                           reduction_pct_ci_low=reduction - 1, reduction_pct_ci_high=reduction + 1)
            out.append(row)
    return out


def test_the_sentence_names_a_sign_change_and_never_a_swap_without_an_interval():
    rows = _rows({"a": [12.5, 3.0, -4.25], "b": [20.0, 30.0, None]}, {"a": [0.2, 0.5, 0.9], "b": [0.3, 0.4, 0.8]})
    (sentence,) = sweep_sentences(records(SweepRow, rows))
    assert sentence.startswith("With matches counted correct within 0 to 10 frames (d, test split, L = 4, paper mode), "
                               "a conclusion depends on the ground truth:")
    assert "the predictor's AOC reduction for a changes sign (12.5 % within 0 frames, -4.2 % within 10 frames)" \
        in sentence
    # a is behind b within 0 frames and ahead within 2, but no interval of their difference says so
    assert "swap" not in sentence
    assert sweep_headline(records(SweepRow, rows)) == (
        "d (L = 4, paper mode), scored again under other tolerances: a conclusion depends on the ground truth.")
    # the same numbers with a's interval at 10 frames containing 0: no sign change, and a sentence says why
    rows[2].update(reduction_pct_ci_low=-9.0, reduction_pct_ci_high=1.0)
    first, untold = sweep_sentences(records(SweepRow, rows))
    assert "changes sign" not in first
    assert untold == ("No sign is named where the 95 % interval holds 0 or is missing (28 queries): a, its AOC "
                      "reduction at 10 frames.")


def test_sequence_matching_is_compared_over_the_same_queries():
    # the paper-mode case: single-frame recall@1 over all 31 queries against sequence recall@1 over the 28
    # evaluated ones is a change of denominator; over the same 28 queries the change is what counts
    rows = _rows({"hog": [None, None, None]}, {"hog": [0.6, 0.6429, 0.6]})
    changes = {0.0: (0.45, 0.4452, 0.3, 0.6), 2.0: (0.6452, 0.6071, -0.1, 0.18), 10.0: (0.5, 0.75, -0.25, -0.05)}
    for row in rows:
        single, evaluated, low, high = changes[row["threshold"]]
        row.update(recall_at_1_single=single, recall_at_1_single_evaluated=evaluated, recall_change_ci_low=low,
                   recall_change_ci_high=high)
    # over all queries the gain is +15.0, -0.2, +10.0 points (no sign change, though -0.2 at 2 frames is one of
    # denominators); over the same queries +15.5 (interval above 0), +3.6 (contains 0), -15.0 (below 0)
    first, untold = sweep_sentences(records(SweepRow, rows))
    assert ("sequence matching changes hog's recall@1 over the same queries by +15.5 points within 0 frames but "
            "-15.0 within 10 frames") in first
    assert untold == ("No sign is named where the 95 % interval holds 0 or is missing (28 queries): hog, sequence "
                      "matching's change of recall@1 at 2 frames.")
    # without intervals: no direction at all, so nothing is said to keep its sign either
    bare = [{k: v for k, v in row.items() if not k.startswith("recall_change")} for row in rows]
    (first,) = sweep_sentences(records(SweepRow, bare))
    assert "no conclusion depends" not in first and first.endswith(
        "whether a conclusion depends on the ground truth is not told.")


def test_the_sentence_says_when_nothing_changes():
    rows = _rows({"a": [1.0, 2.0, 3.0], "b": [None, 0.0, 5.0]}, {"a": [0.2, 0.5, 0.9], "b": [0.1, 0.4, 0.8]})
    sentence, untold = sweep_sentences(records(SweepRow, rows))
    assert "no conclusion depends on the ground truth" in sentence
    # a's 1.0 [0.0, 2.0] and b's change of recall 0.1 - 0.1 = 0 [-0.05, 0.05] at 0 frames contain 0
    assert untold == ("No sign is named where the 95 % interval holds 0 or is missing (28 queries): a, its AOC "
                      "reduction at 0 frames; b, sequence matching's change of recall@1 at 0 frames.")


def test_rows_from_metrics_in_the_configurations_order():
    features = query_features(_matrix(), 4, 2)
    swept = protocol_sweep(features, np.argmin(_matrix(), axis=0), GroundTruth.aligned(90, 90, 2), ("paper",))
    records = [VPRMetrics({"dataset": "d", "method": m, "seq_len": 4}, {"test": SplitMetrics({}, sweep=swept)})
               for m in ("zeta", "alpha")]
    rows = sweep_rows(records, "test")
    assert [(r.method, r.threshold) for r in rows][:2] == [("zeta", 0.0), ("zeta", 1.0)]
    assert len(rows) == 10 and all(r.reduction_pct is None and r.outcome is None for r in rows)


def test_a_sweep_where_no_interval_excludes_0_says_nothing_can_be_told():
    # every reduction's interval and every change's contain 0: "no conclusion depends" would claim kept signs
    rows = _rows({"a": [2.0, 1.0, -0.5]}, {"a": [0.12, 0.11, 0.09]})
    for row in rows:
        row.update(reduction_pct_ci_low=-5.0, reduction_pct_ci_high=5.0)
    assert sweep_sentences(records(SweepRow, rows)) == [
        "With matches counted correct within 0 to 10 frames (d, test split, L = 4, paper mode), every 95 % interval "
        "of the predictor's AOC reduction and of sequence matching's change of recall@1 holds 0 or is missing (28 "
        "queries): no sign is named at any tolerance, so whether a conclusion depends on the ground truth is not "
        "told."]
    assert sweep_headline(records(SweepRow, rows)) == (
        "d (L = 4, paper mode), scored again under other tolerances: every interval holds 0 or is missing, so "
        "nothing tells whether a conclusion depends on the ground truth.")
