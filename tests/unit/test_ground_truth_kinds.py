"""The three kinds of ground truth on one hand-made 6 x 6 matrix: frames within a tolerance, positions within a radius,
a boolean matrix (and the same matrix as per-query lists in every format the field writes). Every value below is
worked out by hand from the rankings ``ORDER``; the code only has to agree."""

import json

import numpy as np
import pytest
from field_files import write_csv_pairs, write_json_lists, write_mat73, write_vpr_bench

from vpr_smr.eval.matching.ground_truth import NO_REFERENCE, GroundTruth
from vpr_smr.eval.matching.ground_truth_files import file_sha256, read_ground_truth
from vpr_smr.eval.scoring.vpr_metrics import NOT_RETRIEVED, recall_at, retrieval
from vpr_smr.pipeline.cli import main as cli

# Each query's references from best to worst; D[r, q] is r's place in q's order (0 = the nearest).
ORDER = [[0, 1, 2, 3, 4, 5], [3, 1, 0, 2, 4, 5], [2, 5, 1, 0, 3, 4], [5, 3, 4, 0, 1, 2], [4, 0, 5, 3, 2, 1],
         [0, 5, 4, 1, 2, 3]]
D = np.array([[order.index(r) for order in ORDER] for r in range(6)], dtype=np.float64)
SINGLE = [0, 3, 2, 5, 4, 0]  # argmin of each column: the first of each order

# The matrix kind: G[r, q], queries 2 and 5 without any correct reference.
CORRECT = {0: [1], 1: [3], 2: [], 3: [3, 5], 4: [0, 1], 5: []}
G = np.zeros((6, 6), dtype=bool)
for query, references in CORRECT.items():
    G[references, query] = True

# Positions: references every 10 m, queries at 0, 14, 20, 33, 47, 51 m, radius 5 m:
# q0 {0}, q1 |10 - 14| = 4 {1}, q2 {2}, q3 |30 - 33| = 3 {3}, q4 |50 - 47| = 3 (|40 - 47| = 7) {5}, q5 {5}
REFERENCE_POSITIONS = np.arange(6) * 10.0
QUERY_POSITIONS = np.array([0.0, 14, 20, 33, 47, 51])


def all_cells(truth):
    r, q = np.meshgrid(np.arange(6), np.arange(6), indexing="ij")
    return truth.correct(r, q)


def test_frames_within_one_by_hand():
    truth = GroundTruth.aligned(6, 6, 1)
    assert truth.kind == "frames" and truth.describe() == "within 1 frame"
    assert truth.provenance() == {"kind": "frames", "tolerance": 1}
    assert GroundTruth.aligned(6, 6, 2).describe() == "within 2 frames"
    assert np.array_equal(all_cells(truth), np.abs(np.arange(6)[:, None] - np.arange(6)) <= 1)
    assert not truth.without_correct().any()
    # ranks of the best-ranked correct reference: q0 0 (r0); q1: 3 is 2 away, 1 is next (rank 1); q2 0; q3: 5 is
    # wrong, 3 next (rank 1); q4 0; q5: 0 is wrong, 5 next (rank 1)
    found = retrieval(D, 2, 1)
    assert found.single_rank.tolist() == [0, 1, 0, 1, 0, 1]
    assert recall_at(found.single_rank, (1, 2)) == {1: 0.5, 2: 1.0}


def test_positions_within_five_metres_by_hand():
    truth = GroundTruth.positions(REFERENCE_POSITIONS, QUERY_POSITIONS, 5.0)
    assert truth.kind == "positions" and truth.describe() == "positions within 5"
    assert truth.provenance() == {"kind": "positions", "radius": 5.0}
    assert [np.flatnonzero(all_cells(truth)[:, q]).tolist() for q in range(6)] == [[0], [1], [2], [3], [5], [5]]
    # q4's only correct reference, 5, is third in its order (4, 0, 5); q5's, 5, second (0, 5)
    found = retrieval(D, 2, 0, ground_truth=truth)
    assert found.single_rank.tolist() == [0, 1, 0, 1, 2, 1]
    assert recall_at(found.single_rank, (1, 2, 3)) == {1: 2 / 6, 2: 5 / 6, 3: 1.0}
    # the nearest reference of each query, within the radius or not: 33 -> 30, 47 -> 50
    assert truth.true_references(np.arange(6)).tolist() == [0, 1, 2, 3, 5, 5]


def test_a_matrix_by_hand():
    truth = GroundTruth.matrix(G)
    assert truth.kind == "matrix" and truth.shape == (6, 6) and truth.describe() == "a boolean matrix"
    assert truth.provenance() == {"kind": "matrix"}
    assert np.array_equal(all_cells(truth), G)
    assert truth.correct(3, 3) and truth.correct(5, 3) and not truth.correct(4, 3)  # scalars too
    assert truth.correct_references(4).tolist() == [True, True, False, False, False, False]
    assert truth.without_correct().tolist() == [False, False, True, False, False, True]
    # q0's 1 is second (0, 1); q1's 3 first; q3's 5 first; q4's 0 second (4, 0); q2 and q5 never
    found = retrieval(D, 2, 0, ground_truth=truth)
    assert found.single_rank.tolist() == [1, 0, NOT_RETRIEVED, 0, 1, NOT_RETRIEVED]
    assert recall_at(found.single_rank, (1, 2, 5)) == {1: 2 / 6, 2: 4 / 6, 5: 4 / 6}
    # the correct reference nearest to the query's own frame: q3 {3, 5} -> 3, q4 {0, 1} -> 1
    assert truth.true_references(np.arange(6)).tolist() == [1, 3, NO_REFERENCE, 3, 1, NO_REFERENCE]


def test_slicing_keeps_the_frames_each_index_names():
    matrix = GroundTruth.matrix(G)
    part = matrix.sliced((1, 5), (2, 6))  # references 1..4, queries 2..5
    assert part.shape == (4, 4) and np.array_equal(part.correct(np.arange(4)[:, None], np.arange(4)), G[1:5, 2:6])
    assert part.provenance() == {"kind": "matrix", "references": [1, 5], "queries": [2, 6]}
    assert part.sliced((0, 2), (1, 3)).provenance()["references"] == [1, 3]  # counted in the file's frames
    # query 3 of the file is local 1 here; its correct references 3 and 5: 5 is outside, 3 is local 2
    assert part.true_references(np.array([1])).tolist() == [2]
    frames = GroundTruth.aligned(6, 6, 1).sliced((1, 5), (2, 6))
    assert np.array_equal(frames.correct(np.arange(4)[:, None], np.arange(4)),
                          (np.abs(np.arange(1, 5)[:, None] - np.arange(2, 6)) <= 1))
    assert GroundTruth.aligned(6, 6, 1).sliced((2, 5), (2, 5)).is_aligned_band()
    assert not frames.is_aligned_band() and not matrix.is_aligned_band()
    with pytest.raises(ValueError, match=r"the reference range \[1, 7\) is not a range of 0..6"):
        matrix.sliced((1, 7), (0, 6))


def test_per_query_lists_are_the_matrix_in_every_format(tmp_path):
    expected = GroundTruth.matrix(G)
    files = {
        "json lists": write_json_lists(tmp_path / "gt.json", CORRECT),
        "csv pairs": write_csv_pairs(tmp_path / "gt.csv", CORRECT),
        "vpr-bench lists": write_vpr_bench(tmp_path / "ground_truth_new.npy", CORRECT),
    }
    for form, path in files.items():
        truth = read_ground_truth(path, shape=(6, 6))
        assert np.array_equal(all_cells(truth), all_cells(expected)), form
        assert truth.describe() == f"{path.name} (per-query lists)"
        assert truth.provenance() == {"kind": "matrix", "file": path.name, "sha256": file_sha256(path),
                                      "form": form}
        # without the matrix's shape, lists name what they hold only: reference 5, and queries up to 4 (the CSV
        # has no row of the last queries, which have none)
        unsized = read_ground_truth(path)
        assert unsized.shape[0] == 6 and unsized.sliced((0, 6), (0, 6)).without_correct().sum() == 2


def test_a_matrix_in_every_format(tmp_path):
    np.save(tmp_path / "g.npy", G)
    np.save(tmp_path / "g01.npy", G.astype(np.uint8))
    np.savez(tmp_path / "g.npz", GThard=G, GTsoft=np.ones((6, 6), dtype=bool))
    import scipy.io

    scipy.io.savemat(tmp_path / "g.mat", {"GThard": G})
    write_mat73(tmp_path / "g73.mat", {"GThard": G})
    for name, key, form in (("g.npy", None, "npy matrix"), ("g01.npy", None, "npy matrix"),
                            ("g.npz", "GThard", "npz matrix"), ("g.mat", None, "mat v5 matrix"),
                            ("g73.mat", "GThard", "mat v7.3 matrix")):
        truth = read_ground_truth(tmp_path / name, key)
        assert np.array_equal(all_cells(truth), G), name
        assert truth.provenance()["form"] == form and truth.provenance().get("key") == key


def test_metrics_of_each_kind_by_hand(tmp_path):
    np.save(tmp_path / "D.npy", D)
    write_json_lists(tmp_path / "gt.json", {q: refs for q, refs in CORRECT.items() if refs})
    out = tmp_path / "m.json"
    assert cli(["metrics", "--distances", str(tmp_path / "D.npy"), "--seq-len", "2", "--ground-truth",
                str(tmp_path / "gt.json"), "--out", str(out)]) == 0
    data = json.loads(out.read_text())
    split = data["splits"]["all"]
    # paper mode's single-frame recall counts all 6 queries, standard mode's the 5 with a sequence match (1..5):
    # correct at rank 0 are q1 and q3 only; q2 and q5 have no correct reference and count all the same
    assert split["modes"]["paper"]["single"]["n_queries"] == 6
    assert split["modes"]["paper"]["single"]["recall_at"]["1"] == 2 / 6
    assert split["modes"]["standard"]["single"]["n_queries"] == 5
    assert split["modes"]["standard"]["single"]["recall_at"]["1"] == 2 / 5
    assert split["modes"]["standard"]["single"]["recall_at"]["5"] == 3 / 5  # q4 at rank 1; q0 is not evaluated
    assert split["queries_without_correct"] == 2 and split["evaluated_without_correct"] == 2
    assert data["meta"]["ground_truth"] == {"kind": "matrix", "file": "gt.json", "sha256": file_sha256(
        tmp_path / "gt.json"), "form": "json lists"}
    # the frame tolerance of the same matrix: q0, q2 and q4 right at rank 0
    assert cli(["metrics", "--distances", str(tmp_path / "D.npy"), "--seq-len", "2", "--tolerance", "1",
                "--out", str(out)]) == 0
    frames = json.loads(out.read_text())
    assert frames["splits"]["all"]["modes"]["paper"]["single"]["recall_at"]["1"] == 3 / 6
    assert frames["meta"]["ground_truth"] == {"kind": "frames", "tolerance": 1}
    assert frames["splits"]["all"]["queries_without_correct"] == 0
