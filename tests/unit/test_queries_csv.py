"""The per-query CSV of ``vpr-smr queries`` and ``vpr-smr metrics --queries`` (one implementation): its columns,
the dataset's frame indices, the attributes under the paper's names (A3 block, A4 group: checked against method §5's
formulas), the predictor's decision, and the metrics and the table written both or neither."""

import csv

import numpy as np
import pytest
from helpers import read_distance_matrix, seqslam, write_distance_matrix
from worked_matrix import DECISION, SEQ_LEN, TOLERANCE, D, FixedPredictor

from vpr_smr.core.constants import EPS, GROUP_HALF_WIDTH, KEPT_CLASSES
from vpr_smr.eval.matching.attributes import AttributesJob
from vpr_smr.eval.matching.attributes import main as attributes_main
from vpr_smr.eval.matching.sources import TruthSource
from vpr_smr.eval.predictor.estimator import SMRPredictor
from vpr_smr.eval.scoring.baselines import BaselineSettings
from vpr_smr.eval.scoring.queries import QUERY_COLUMNS, SCORE_COLUMNS, write_queries
from vpr_smr.eval.scoring.vpr_metrics import MetricsJob, main, score_split

COLUMNS = ["split", "query", "single_match", "single_distance", "single_correct", "sequence_match",
           "sequence_distance", "sequence_correct", "true_reference", "A1", "A2", "A3", "A4", "label",
           "predicted_class", "probability", "kept", "matcher"]
SCORES = ["c_uniqueness", "c_single_uniqueness", "c_spread", "c_distance", "c_native", "c_random", "c_oracle",
          "c_predictor"]


def read(path):
    with open(path, newline="") as handle:
        reader = csv.reader(handle)
        header = next(reader)
        return header, [dict(zip(header, row, strict=True)) for row in reader]


def spec_attributes(d, seq_len, a):
    """Rank-0 A1..A4 of query ``a``, written from method §5 one value at a time (ties: the lowest diagonal)."""
    d = np.asarray(d, dtype=np.float64)
    col_max = d.max(axis=0)
    col_max[col_max == 0] = 1
    w = (d / col_max)[:, a - seq_len + 1 : a + 1]
    n_diag = d.shape[0] - seq_len + 1
    diagonals = [[w[i + c, c] for c in range(seq_len)] for i in range(n_diag)]
    full = [sum(x) for x in diagonals]
    past = [sum(x[:-1]) for x in diagonals]
    row_past = [sum(w[r, : seq_len - 1]) for r in range(d.shape[0])]
    best = min(range(n_diag), key=lambda i: (full[i], i))
    lo = seq_len * (best // seq_len)
    block = np.mean([full[m] for m in range(lo, min(n_diag - 1, lo + seq_len - 1) + 1)])
    group = np.mean([full[m] for m in range(max(0, best - GROUP_HALF_WIDTH),
                                             min(n_diag - 1, best + GROUP_HALF_WIDTH) + 1)])
    return {"A1": min(past) / (min(row_past) + EPS), "A2": min(w[:, -1]) / (diagonals[best][-1] + EPS),
            "A3": past[best] / (block + EPS), "A4": past[best] / (group + EPS)}


def test_columns_and_values_by_hand(tmp_path):
    # the 6 x 6 matrix of worked_matrix.py (L = 2, tolerance 0), worked out there by hand
    assert list(QUERY_COLUMNS) == COLUMNS and list(SCORE_COLUMNS) == SCORES
    scored = score_split(D, SEQ_LEN, TOLERANCE, FixedPredictor(DECISION, confidence=0.7))
    write_queries(tmp_path / "q.csv", [scored.queries])
    header, rows = read(tmp_path / "q.csv")
    assert header == COLUMNS + SCORES and all(r[name] == "" for r in rows for name in SCORES)  # not asked for
    column = {name: [r[name] for r in rows] for name in COLUMNS}
    assert column["split"] == ["all"] * 5
    assert column["query"] == column["true_reference"] == ["1", "2", "3", "4", "5"]
    assert column["single_match"] == ["2", "2", "4", "0", "5"]
    assert [float(v) for v in column["single_distance"]] == [2, 1, 1, 2, 0]
    assert column["single_correct"] == ["0", "1", "0", "0", "1"]
    assert column["sequence_match"] == ["1", "2", "3", "5", "1"]
    assert [float(v) for v in column["sequence_distance"]] == [4, 4, 5, 6, 2.5]
    assert column["sequence_correct"] == ["1", "1", "1", "0", "0"]
    assert column["label"] == ["2", "0", "2", "3", "1"]
    assert column["predicted_class"] == [str(c) for c in DECISION]
    assert [float(v) for v in column["probability"]] == pytest.approx([0.7] * 5)
    assert column["kept"] == ["0", "1", "1", "0", "1"]
    assert column["matcher"] == ["seqslam (velocities [1.0])"] * 5  # the fixed matcher


def test_scorer_columns_by_hand(tmp_path):
    # the worked matrix with r_window 2 (uniqueness looks past |r - r*| <= 1) and spread_k 3 (method §12)
    scored = score_split(D, SEQ_LEN, TOLERANCE, FixedPredictor(DECISION, confidence=0.7),
                         baselines=BaselineSettings(r_window=2, spread_k=3))
    write_queries(tmp_path / "q.csv", [scored.queries])
    header, rows = read(tmp_path / "q.csv")
    assert header == COLUMNS + SCORES
    column = {name: [float(r[name]) for r in rows] for name in SCORES}
    # S of a1..a5 by end reference 1..5 (worked_matrix.py): the best outside the window over the best
    #   a1 [4, 7, 10, 10, 10] r* 1: 10 / 4;  a2 [10, 4, 7, 10, 10] r* 2: 10 / 4;  a3 [10, 10, 5, 6, 7] r* 3: 7 / 5
    #   a4 [10, 10, 10, 7, 6] r* 5: 10 / 6;  a5 [2.5, 10, 10, 10, 3] r* 1: 3 / 2.5
    assert column["c_uniqueness"] == pytest.approx([2.5, 2.5, 1.4, 10 / 6, 1.2])
    # D[:, a] of a1..a5 around the single-frame match: q1 r 2 (2): 5 / 2; q2 r 2 (1): 5; q3 r 4 (1): 5;
    # q4 r 0 (2): D[4, 4] = 3 / 2; q5 r 5 (0): 0.5 outside over 0: +inf
    assert column["c_single_uniqueness"] == pytest.approx([2.5, 5, 5, 1.5, np.inf])
    # the 3 best end references (ties to the lowest): a1 1, 2, 3; a2 2, 3, 1; a3 3, 4, 5; a4 5, 4, 1; a5 1, 5, 2
    assert column["c_spread"] == pytest.approx([-np.std([1, 2, 3]), -np.std([2, 3, 1]), -np.std([3, 4, 5]),
                                                -np.std([5, 4, 1]), -np.std([1, 5, 2])])
    assert column["c_distance"] == [-4, -4, -5, -6, -2.5]
    assert column["c_native"] == pytest.approx([2.5, 2.5, 1.4, 10 / 6, 1.2])  # seqslam's own: its uniqueness
    assert column["c_random"] == np.random.default_rng(0).permutation(5).tolist()
    assert column["c_oracle"] == [1, 1, 1, 0, 0]
    # 1 - P(class 1) - P(class 3): the decided class has 0.7, the others 0.1 (DECISION 1, 0, 2, 3, 0)
    assert column["c_predictor"] == pytest.approx([0.2, 0.8, 0.8, 0.2, 0.8])


def test_the_matcher_column_names_the_matcher_and_its_settings(tmp_path):
    scored = score_split(D, SEQ_LEN, TOLERANCE, matcher=seqslam(2.0, 0.5, 1.0))
    write_queries(tmp_path / "q.csv", [scored.queries])
    _, rows = read(tmp_path / "q.csv")
    # the velocities sorted: the same set in another order is the same matcher
    assert {r["matcher"] for r in rows} == {"seqslam (velocities [0.5, 1.0, 2.0])"}


def test_without_a_predictor_its_columns_are_empty(tmp_path):
    scored = score_split(D, SEQ_LEN, TOLERANCE)
    write_queries(tmp_path / "q.csv", [scored.queries])
    _, rows = read(tmp_path / "q.csv")
    assert all(r["predicted_class"] == r["probability"] == r["kept"] == "" for r in rows)
    assert [r["label"] for r in rows] == ["2", "0", "2", "3", "1"]


def _items(paths):
    """A metrics job's ``distances``: SPLIT=PATH items of split -> path, in order."""
    return tuple(f"{split}={path}" for split, path in paths.items())


def _named(paths):
    """A job's split -> path as text."""
    return {split: str(path) for split, path in paths.items()}


@pytest.fixture
def splits(tmp_path):
    """Two splits of dataset "d" in our HDF5 layout, frames 100..111 (test) and 60..71 (val), with attributes
    files of L = 3 for the test split only."""
    rng = np.random.default_rng(11)
    paths = {}
    for split, lo in (("test", 100), ("val", 60)):
        d = rng.random((12, 12)) + 2 * (1 - np.eye(12)) * rng.random((12, 12))
        path = tmp_path / f"{split}.h5"
        write_distance_matrix(path, d, {"dataset": "d", "method": "m", "split": split, "split_range": [lo, lo + 12]})
        paths[split] = path
    attributes_main(AttributesJob(str(paths["test"]), 3, TruthSource(tolerance=2), out=str(tmp_path / "test_L3.h5")))
    return paths, {"test": tmp_path / "test_L3.h5"}


def test_frames_attributes_and_prediction(splits, predictor_file, tmp_path):
    distances, attributes = splits
    main(MetricsJob(_items(distances), 3, TruthSource(tolerance=2), predictor=str(predictor_file),
                    attributes=_named(attributes), queries=str(tmp_path / "q.csv"), out=str(tmp_path / "m.json")))
    header, rows = read(tmp_path / "q.csv")
    assert header == COLUMNS + SCORES
    # splits in the given order (test, then val); frames: the split's first frame plus the index in the split,
    # from the attributes file (test) or the distances file (val)
    assert [r["split"] for r in rows] == ["test"] * 10 + ["val"] * 10
    assert [int(r["query"]) for r in rows] == list(range(102, 112)) + list(range(62, 72))
    assert all(r["true_reference"] == r["query"] for r in rows)
    predictor = SMRPredictor.load(predictor_file)
    differ = 0
    for split, lo in (("test", 100), ("val", 60)):
        d = read_distance_matrix(distances[split])  # the float32 values the stages read
        split_rows = [r for r in rows if r["split"] == split]
        for r in split_rows:
            a = int(r["query"]) - lo
            assert int(r["single_match"]) - lo == int(np.argmin(d[:, a]))
            assert float(r["single_distance"]) == float(d[:, a].min())
            assert r["single_correct"] == str(int(abs(int(r["single_match"]) - int(r["query"])) <= 2))
            assert r["sequence_correct"] == str(int(abs(int(r["sequence_match"]) - int(r["query"])) <= 2))
            expected = spec_attributes(d, 3, a)
            for name in ("A1", "A2", "A3", "A4"):
                assert float(r[name]) == pytest.approx(expected[name], rel=1e-9), (split, a, name)
            differ += not np.isclose(expected["A3"], expected["A4"])
            # kept follows the predicted class, and the class and probability are the predictor's on A1..A4
            assert r["kept"] == str(int(int(r["predicted_class"]) in KEPT_CLASSES))
        x = np.array([[float(r[name]) for name in ("A1", "A2", "A3", "A4")] for r in split_rows])
        probabilities = predictor.predict_proba(x)
        assert [int(r["predicted_class"]) for r in split_rows] == predictor.classes_[probabilities.argmax(1)].tolist()
        assert [float(r["probability"]) for r in split_rows] == pytest.approx(probabilities.max(1).tolist())
    assert differ > 5  # the block and group rates differ on most queries: the names are tested, not a coincidence


def test_a_users_npy_starts_at_frame_zero(tmp_path):
    np.save(tmp_path / "D.npy", D)
    main(MetricsJob((str(tmp_path / "D.npy"),), SEQ_LEN, TruthSource(tolerance=TOLERANCE),
                    queries=str(tmp_path / "q.csv"), out=str(tmp_path / "m.json")))
    _, rows = read(tmp_path / "q.csv")
    assert [r["query"] for r in rows] == ["1", "2", "3", "4", "5"] and {r["split"] for r in rows} == {"all"}


def test_the_queries_command_writes_the_metrics_commands_table(splits, predictor_file, tmp_path, capsys):
    from vpr_smr.pipeline.cli import main as cli

    distances, attributes = splits
    main(MetricsJob(_items(distances), 3, TruthSource(tolerance=2), predictor=str(predictor_file),
                    attributes=_named(attributes), modes=("standard",), queries=str(tmp_path / "from_metrics.csv"),
                    out=str(tmp_path / "m.json")))
    pairs = [f"{split}={path}" for split, path in distances.items()]
    assert cli(["queries", "--distances", *pairs, "--attributes", f"test={attributes['test']}", "--seq-len", "3",
                "--tolerance", "2", "--predictor", str(predictor_file), "--out", str(tmp_path / "q.csv")]) == 0
    # one implementation: the same bytes, whatever modes the metrics were computed in
    assert (tmp_path / "q.csv").read_bytes() == (tmp_path / "from_metrics.csv").read_bytes()
    header, rows = read(tmp_path / "q.csv")
    assert header == COLUMNS + SCORES and len(rows) == 20 and all(r["kept"] in ("0", "1") for r in rows)
    assert all(r["c_predictor"] and r["c_uniqueness"] for r in rows)  # the scorers, by default
    # without a predictor: its columns are empty; a user's single .npy is split "all"
    np.save(tmp_path / "D.npy", D)
    assert cli(["queries", "--distances", str(tmp_path / "D.npy"), "--seq-len", str(SEQ_LEN), "--tolerance",
                str(TOLERANCE), "--out", str(tmp_path / "d.csv")]) == 0
    _, rows = read(tmp_path / "d.csv")
    assert [r["query"] for r in rows] == ["1", "2", "3", "4", "5"] and {r["split"] for r in rows} == {"all"}
    assert all(r["predicted_class"] == r["kept"] == "" for r in rows)
    # checked before any work, named
    assert cli(["queries", "--distances", str(tmp_path / "D.npy"), "--seq-len", "3", "--out",
                str(tmp_path / "q.txt")]) == 2
    assert "--out " in capsys.readouterr().err and not (tmp_path / "q.txt").exists()
    assert cli(["queries", "--distances", f"test={distances['test']}", "--seq-len", "3", "--predictor",
                str(predictor_file), "--out", str(tmp_path / "e.csv"), "--tolerance", "1", "--attributes",
                f"test={attributes['test']}"]) == 2
    assert "at tolerance 2, but --tolerance is 1" in capsys.readouterr().err and not (tmp_path / "e.csv").exists()
    assert not list(tmp_path.glob("*.tmp"))


def test_metrics_and_queries_are_written_both_or_neither(tmp_path, monkeypatch):
    from vpr_smr.eval.scoring import vpr_metrics

    np.save(tmp_path / "D.npy", D)
    out, queries = tmp_path / "m.json", tmp_path / "q.csv"
    matrix = (str(tmp_path / "D.npy"),)
    main(MetricsJob(matrix, SEQ_LEN, TruthSource(tolerance=TOLERANCE), queries=str(queries), out=str(out)))
    before = out.read_bytes(), queries.read_bytes()

    def broken(*args, **kwargs):
        raise OSError("disk full")

    # at tolerance 1 both files would change; the JSON cannot be written: neither changes
    monkeypatch.setattr(vpr_metrics, "write_json", broken)
    with pytest.raises(OSError, match="disk full"):
        main(MetricsJob(matrix, SEQ_LEN, TruthSource(tolerance=1), queries=str(queries), out=str(out)))
    assert (out.read_bytes(), queries.read_bytes()) == before
    with pytest.raises(OSError, match="disk full"):  # a first run: neither file appears
        main(MetricsJob(matrix, SEQ_LEN, TruthSource(tolerance=1), queries=str(tmp_path / "new.csv"),
                        out=str(tmp_path / "new.json")))
    assert not (tmp_path / "new.json").exists() and not (tmp_path / "new.csv").exists()
    # the table cannot be written: the JSON is not replaced either
    monkeypatch.undo()
    monkeypatch.setattr(vpr_metrics, "write_queries", broken)
    with pytest.raises(OSError, match="disk full"):
        main(MetricsJob(matrix, SEQ_LEN, TruthSource(tolerance=1), queries=str(queries), out=str(out)))
    assert (out.read_bytes(), queries.read_bytes()) == before
    assert not list(tmp_path.glob("*.tmp"))
