"""A threshold file in the live matcher (method §16): each frame's accepted equals vpr-smr deploy's decision on the
batch per-query table of the same matrix, and a file the live matcher cannot apply is refused."""

from __future__ import annotations

import csv

import numpy as np
import pytest
from helpers import seqslam

from vpr_smr import api
from vpr_smr.eval.matching.live import LiveMatcher
from vpr_smr.eval.scoring.threshold_file import ThresholdFile
from vpr_smr.eval.scoring.thresholds import Calibration
from vpr_smr.pipeline.cli import main

MATCHER = "seqslam (velocities [1.0])"


class HalfPredictor:
    """A stand-in predictor: class 2 (kept) when A1 is below ``cut``, else class 1 (test only)."""

    classes_ = np.array([0, 1, 2, 3])

    def __init__(self, cut):
        self.cut = cut

    def predict_proba(self, features):
        low = np.asarray(features)[:, 0] < self.cut
        return np.stack([np.zeros(len(low)), (~low) * 1.0, low * 1.0, np.zeros(len(low))], axis=1)


@pytest.fixture(scope="module")
def batch(tmp_path_factory):
    """A matrix whose diagonal is often the best match, and its per-query table of vpr-smr queries (L = 4)."""
    folder = tmp_path_factory.mktemp("live")
    rng = np.random.default_rng(7)
    matrix = rng.random((90, 90)) + 0.5
    matrix[np.arange(90), np.arange(90)] -= 0.45 * (rng.random(90) < 0.6)
    np.save(folder / "D.npy", matrix)
    assert main(["queries", "--distances", str(folder / "D.npy"), "--seq-len", "4", "--out",
                 str(folder / "q.csv")]) == 0
    with open(folder / "q.csv") as handle:
        rows = list(csv.DictReader(handle))
    return matrix, rows


def file_of(rows, source, threshold, rule="empirical", seq_len=4, matcher=MATCHER):
    c = np.array([float(row[f"c_{source}"]) for row in rows])
    y = np.array([row["sequence_correct"] == "1" for row in rows])
    accepted = int((c >= threshold).sum())
    calibration = Calibration(rule, 0.9, None, float(threshold), len(c), accepted, int(((c >= threshold) & ~y).sum()))
    return ThresholdFile.of(calibration, source, matcher, "all", c, y, seq_len=seq_len), c


@pytest.mark.parametrize("source", ["uniqueness", "native", "distance"])
def test_live_accepted_equals_deploy_on_the_batch_table(batch, source):
    matrix, rows = batch
    values = np.array([float(row[f"c_{source}"]) for row in rows])
    file, c = file_of(rows, source, np.median(values))
    mask = api.deploy(c, file.calibration).accepted  # deploy's decision on the batch table
    live = LiveMatcher(4, thresholds=file)
    found = [live.step_distances(matrix[:, a]) for a in range(matrix.shape[1])]
    assert all(result is None for result in found[:3])
    accepted = [result.accepted for result in found[3:]]
    assert [result.query for result in found[3:]] == [int(row["query"]) for row in rows]
    assert accepted == mask.tolist()
    assert True in accepted and False in accepted  # the threshold splits the frames


def test_predictor_source_is_its_probability_of_a_correct_match(batch):
    matrix, rows = batch
    a1 = np.array([float(row["A1"]) for row in rows])
    predictor = HalfPredictor(np.median(a1))
    # the stand-in's 1 - P(class 1) - P(class 3) is 1 when it keeps the match, 0 when not: threshold 0.5
    calibration = Calibration("empirical", 0.9, None, 0.5, 10, 5, 0)
    file = ThresholdFile.of(calibration, "predictor", MATCHER, "val", np.arange(10.0), np.ones(10, bool), seq_len=4)
    live = LiveMatcher(4, predictor=predictor, thresholds=file)
    found = [live.step_distances(matrix[:, a]) for a in range(matrix.shape[1])][3:]
    assert [result.accepted for result in found] == [bool(value < np.median(a1)) for value in a1]
    assert [result.accepted for result in found] == [result.keep for result in found]
    assert LiveMatcher(4).step_distances(matrix[:, 0]) is None
    plain = LiveMatcher(4)
    assert [plain.step_distances(matrix[:, a]) for a in range(4)][-1].accepted is None  # no file: None


def test_files_live_cannot_apply_are_refused(batch):
    _, rows = batch
    file, _ = file_of(rows, "uniqueness", 1.0)
    with pytest.raises(ValueError, match="for the sequence length 4, but the LiveMatcher has the sequence length 5"):
        LiveMatcher(5, thresholds=file)
    with pytest.raises(ValueError, match=r"for the matcher 'seqslam \(velocities \[1.0\]\)', but the LiveMatcher "
                                         r"has the matcher 'seqslam \(velocities \[0.5, 1.0\]\)'"):
        LiveMatcher(4, matcher=seqslam(0.5, 1.0), thresholds=file)
    spread, _ = file_of(rows, "single_uniqueness", 1.0)
    with pytest.raises(ValueError, match="source 'single_uniqueness' is not computed per live frame; a "
                                         "LiveMatcher of the matcher .* gives predictor, native, uniqueness, distance"):
        LiveMatcher(4, thresholds=spread)
    fraction, _ = file_of(rows, "uniqueness", 1.0, rule="same_fraction")
    with pytest.raises(ValueError, match="same_fraction accepts a fraction of a whole split"):
        LiveMatcher(4, thresholds=fraction)
    predictor, _ = file_of(rows, "uniqueness", 1.0)
    predictor = ThresholdFile(**{**predictor.__dict__, "source": "predictor"}).seal()
    with pytest.raises(ValueError, match="give the LiveMatcher its predictor"):
        LiveMatcher(4, thresholds=predictor)

    hashed = ThresholdFile(**{**predictor.__dict__, "predictor_sha256": "a" * 64}).seal()
    with pytest.raises(ValueError, match="calibrated on the predictor file of SHA-256 aaaaaaaaaaaa..., the "
                                         "LiveMatcher's predictor file has bbbbbbbbbbbb..."):
        hashed.check_live(MATCHER, "uniqueness", None, 4, "b" * 64, True)
    hashed.check_live(MATCHER, "uniqueness", None, 4, "a" * 64, True)  # the calibrated predictor: accepted


def test_a_file_of_another_uniqueness_window_is_refused(batch):
    _, rows = batch
    file, _ = file_of(rows, "uniqueness", 1.0)
    assert file.scorers["r_window"] == 10  # the defaults' settings, recorded
    with pytest.raises(ValueError, match="computed with r_window 10, the LiveMatcher's with r_window 4"):
        LiveMatcher(4, r_window=4, thresholds=file)
    LiveMatcher(4, r_window=10, thresholds=file)  # the same window: taken
