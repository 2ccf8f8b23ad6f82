"""Ground truth from positions within a radius (method §11) and the commands that take it for a user's matrix:
``GroundTruth`` by hand, frame indices within the tolerance as its special case, recall@N with velocity search and
positions against a naive loop that builds every trajectory, and the options' errors."""

import json

import numpy as np
import pytest
from helpers import seqslam
from oracles import stable_top

from vpr_smr.core.constants import RECALL_AT
from vpr_smr.eval.matching.attributes import query_features, read_features
from vpr_smr.eval.matching.ground_truth import GroundTruth, read_positions
from vpr_smr.eval.matching.io import split_ground_truth
from vpr_smr.eval.scoring.vpr_metrics import retrieval, score_split
from vpr_smr.pipeline.cli import main as cli


def test_positions_within_a_radius_by_hand():
    # references at x = 0, 10, 20, 30; queries at 4, 16 and 30.5; radius 5: |0-4| = 4 yes, |10-4| = 6 no, ...
    truth = GroundTruth.positions(np.array([0.0, 10, 20, 30]), np.array([4.0, 16, 30.5]), 5.0)
    expected = np.array([[True, False, False], [False, False, False], [False, True, False], [False, False, True]])
    assert np.array_equal(truth.correct(np.arange(4)[:, None], np.arange(3)[None, :]), expected)
    assert np.array_equal(truth.correct_references(1), [False, False, True, False])
    # 2-D: Euclidean. (3, 4) is 5 from the origin: inside a radius of 5, outside 4.9
    planar = GroundTruth.positions(np.array([[0.0, 0.0], [10.0, 0.0]]), np.array([[3.0, 4.0]]), 5.0)
    assert planar.correct(np.array([0, 1]), np.array([0, 0])).tolist() == [True, False]
    assert not GroundTruth.positions(planar.reference_positions, planar.query_positions, 4.9).correct(0, 0)


@pytest.mark.parametrize("tolerance", [0, 1, 2, 5])
def test_frame_indices_are_the_aligned_special_case(tolerance):
    r, q = np.meshgrid(np.arange(30), np.arange(25), indexing="ij")
    truth = GroundTruth.aligned(30, 25, tolerance)
    assert np.array_equal(truth.correct(r, q), np.abs(r - q) <= tolerance)
    assert truth.is_aligned_band()
    assert not GroundTruth.positions(np.arange(30.0), np.arange(25.0) + 0.5, tolerance).is_aligned_band()


def test_bad_positions_are_named(tmp_path):
    with pytest.raises(ValueError, match="different dimensions"):
        GroundTruth.positions(np.zeros((3, 2)), np.zeros(4), 1.0)
    with pytest.raises(ValueError, match="radius must be a number >= 0"):
        GroundTruth.positions(np.zeros(3), np.zeros(4), -1.0)
    with pytest.raises(ValueError, match="frames 1"):
        GroundTruth.positions(np.array([0.0, np.nan]), np.zeros(4), 1.0)
    bad = tmp_path / "query.csv"
    bad.write_text("x,y\n1,2\n3,four\n")
    with pytest.raises(ValueError, match=r"query.csv, line 3: '3,four'"):
        read_positions(bad)
    ragged = tmp_path / "ragged.csv"
    ragged.write_text("1,2\n3\n")
    with pytest.raises(ValueError, match="ragged.csv: rows have different numbers of columns"):
        read_positions(ragged)
    with pytest.raises(FileNotFoundError, match="positions file not found: .*nowhere.npy"):
        read_positions(tmp_path / "nowhere.npy")


def test_ground_truth_options_are_checked(tmp_path):
    matrix = tmp_path / "D.npy"
    np.save(matrix, np.ones((5, 6), dtype=np.float32))
    ref, qry = tmp_path / "ref.npy", tmp_path / "qry.npy"
    np.save(ref, np.arange(5.0))
    np.save(qry, np.arange(6.0))
    assert split_ground_truth(matrix, (6, 6), 2).is_aligned_band()
    # 5 references and 6 queries: frame indices within a tolerance mean nothing there
    with pytest.raises(ValueError, match="is a 5 x 6 matrix .references x queries. without positions"):
        split_ground_truth(matrix, (5, 6), 2)
    with pytest.raises(ValueError, match="--radius 3.0 needs positions"):
        split_ground_truth(matrix, (5, 6), 2, radius=3.0)
    with pytest.raises(ValueError, match="needs --radius"):
        split_ground_truth(matrix, (5, 6), 2, reference_positions=ref, query_positions=qry)
    with pytest.raises(ValueError, match="give both --reference-positions and --query-positions"):
        split_ground_truth(matrix, (5, 6), 2, radius=1.0, reference_positions=ref)
    with pytest.raises(ValueError, match="5 reference and 6 query positions"):
        split_ground_truth(matrix, (5, 7), 2, radius=1.0, reference_positions=ref, query_positions=qry)


def trajectory_sequences(d, seq_len, velocities):
    """``S[r, a] = min_v`` of the sum of ``D`` along method §11's trajectory ``T_v(r)``, written out literally; +inf
    where no trajectory is valid. Rows: every reference ``r``; columns: queries ``a = L-1 .. Q-1``."""
    n_ref, n_query = d.shape
    s = np.full((n_ref, n_query - seq_len + 1), np.inf)
    for a in range(seq_len - 1, n_query):
        for r in range(n_ref):
            for v in velocities:
                cells = [(r - int(np.floor(v * (seq_len - 1 - k) + 0.5)), a - seq_len + 1 + k) for k in range(seq_len)]
                if cells[0][0] < 0:
                    continue
                total = 0.0
                for row, col in cells:
                    total += float(d[row, col])
                s[r, a - seq_len + 1] = min(s[r, a - seq_len + 1], total)
    return s


@pytest.mark.parametrize("velocities", [(1.0,), (0.5, 1.0, 2.0), (0.75, 1.25, 1.5), (2.0, 3.0)])
def test_recall_at_n_with_velocities_and_positions_matches_a_naive_loop(velocities):
    rng = np.random.default_rng(len(velocities))
    d = rng.integers(0, 4, size=(36, 30)).astype(float)  # few distinct values: many ties
    seq_len = 4
    truth = GroundTruth.positions(np.cumsum(rng.uniform(0.5, 2.0, 36)), np.cumsum(rng.uniform(0.5, 2.5, 30)), 2.0)
    correct = truth.correct(np.arange(36)[:, None], np.arange(30)[None, :])
    single = {n: np.mean([any(correct[r, q] for r in stable_top(list(d[:, q]), n)) for q in range(30)])
              for n in RECALL_AT}
    s = trajectory_sequences(d, seq_len, velocities)
    valid = np.isfinite(s).any(axis=1)
    rows = np.flatnonzero(valid)  # the end references with a valid trajectory: r_min .. R-1
    assert np.array_equal(rows, np.arange(rows[0], 36))
    sequence = {n: np.mean([any(correct[rows[i], a + seq_len - 1] for i in stable_top(list(s[rows, a]), n))
                            for a in range(s.shape[1])]) for n in RECALL_AT}
    modes = score_split(d, seq_len, 99, matcher=seqslam(*velocities), ground_truth=truth).metrics.modes
    assert modes["paper"]["single"].recall_at == pytest.approx(single)
    assert modes["paper"]["sequence"].recall_at == pytest.approx(sequence)
    found = retrieval(d, seq_len, 99, matcher=seqslam(*velocities), ground_truth=truth)
    best = rows[np.argmin(s[rows], axis=0)]
    assert np.array_equal(found.sequence_match, best)
    assert np.array_equal(found.sequence_distance, s[best, np.arange(s.shape[1])])
    features = query_features(d, seq_len, matcher=seqslam(*velocities), ground_truth=truth)
    assert np.array_equal(features.sequence_match, best)
    assert np.array_equal(features.sequence_correct, correct[best, np.arange(seq_len - 1, 30)])


@pytest.mark.parametrize("seq_len, tolerance", [(2, 0), (3, 2), (5, 1)])
def test_retrieval_ranks_the_band_as_a_literal_count(seq_len, tolerance):
    # ties everywhere (values 0..2): the stable rank of the best correct candidate, counted literally per query
    rng = np.random.default_rng(seq_len)
    d = rng.integers(0, 3, size=(40, 37)).astype(np.float32)
    found = retrieval(d, seq_len, tolerance, block_queries=9)

    def stable_rank(values, rows):
        order = sorted(range(len(values)), key=lambda r: (values[r], r))
        return min(order.index(r) for r in rows)

    for q in range(37):
        rows = [r for r in range(40) if abs(r - q) <= tolerance]
        assert found.single_rank[q] == stable_rank(list(d[:, q]), rows)
    for n, a in enumerate(range(seq_len - 1, 37)):
        sums = [sum(float(d[i + k, a - seq_len + 1 + k]) for k in range(seq_len)) for i in range(40 - seq_len + 1)]
        ends = [i for i in range(len(sums)) if abs(i + seq_len - 1 - a) <= tolerance]
        assert found.sequence_rank[n] == stable_rank(sums, ends)
    whole = retrieval(d, seq_len, tolerance)
    for field in whole.__dataclass_fields__:
        assert np.array_equal(getattr(whole, field), getattr(found, field)), field


def test_attributes_and_metrics_commands_take_positions(tmp_path):
    rng = np.random.default_rng(5)
    d = rng.uniform(0, 1, size=(20, 24)).astype(np.float32)
    np.save(tmp_path / "D.npy", d)
    ref, qry = np.arange(20.0) * 3.0, np.arange(24.0) * 2.5  # metres: the query drives slower
    np.savetxt(tmp_path / "ref.csv", ref[:, None], delimiter=",", header="x", comments="")
    np.save(tmp_path / "qry.npy", qry)
    options = ["--reference-positions", str(tmp_path / "ref.csv"), "--query-positions", str(tmp_path / "qry.npy"),
               "--radius", "4", "--velocities", "0.5", "0.8", "1"]
    assert cli(["attributes", "--distances", str(tmp_path / "D.npy"), "--seq-len", "3", *options,
                "--out", str(tmp_path / "A.h5")]) == 0
    features = read_features(tmp_path / "A.h5")
    single = np.argmin(d, axis=0)[2:]
    assert np.array_equal(features.single_correct, np.abs(ref[single] - qry[2:]) <= 4)
    assert cli(["metrics", "--distances", str(tmp_path / "D.npy"), "--seq-len", "3", *options,
                "--attributes", f"all={tmp_path / 'A.h5'}", "--out", str(tmp_path / "m.json")]) == 0
    info = json.loads((tmp_path / "m.json").read_text())["meta"]
    assert info["matcher"] == {"name": "seqslam", "settings": {"velocities": [0.5, 0.8, 1.0]}} and info["radius"] == 4.0
    # attributes of another matcher are refused, naming both
    assert cli(["metrics", "--distances", str(tmp_path / "D.npy"), "--seq-len", "3", *options[:-4],
                "--attributes", f"all={tmp_path / 'A.h5'}", "--out", str(tmp_path / "m2.json")]) != 0
    assert not (tmp_path / "m2.json").exists()


def test_attributes_of_the_same_velocities_in_another_order_are_accepted(tmp_path):
    from vpr_smr.eval.matching.attributes import check_matcher

    rng = np.random.default_rng(2)
    np.save(tmp_path / "D.npy", rng.uniform(0, 1, size=(24, 24)).astype(np.float32))
    assert cli(["attributes", "--distances", str(tmp_path / "D.npy"), "--seq-len", "3", "--velocities", "1", "0.5",
                "--out", str(tmp_path / "A.h5")]) == 0
    check_matcher([tmp_path / "A.h5"], seqslam(0.5, 1.0), None)  # the same matcher
    with pytest.raises(ValueError, match=r"seqslam \(velocities \[0.5, 1.0\]\).*given the matcher seqslam "
                                         r"\(velocities \[0.5, 2.0\]\)"):
        check_matcher([tmp_path / "A.h5"], seqslam(2.0, 0.5), None)
