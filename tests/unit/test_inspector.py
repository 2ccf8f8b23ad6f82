"""The match inspector (`vpr-smr inspect`): its seeded sample, and figures that show the right frames."""

import csv
import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from helpers import COLOUR_FRAMES, query_colour, reference_colour, write_distance_matrix

from vpr_smr.datasets import load_frames
from vpr_smr.eval.matching.matchers import MatcherSpec
from vpr_smr.eval.matching.sources import TruthSource
from vpr_smr.eval.report import inspector
from vpr_smr.eval.report.inspector import InspectJob
from vpr_smr.pipeline.cli import main as cli

N_FRAMES, LO, HI, L, TOL = COLOUR_FRAMES, 8, 24, 3, 2
HEADER = ["split", "query", "single_match", "single_distance", "single_correct", "sequence_match",
          "sequence_distance", "sequence_correct", "true_reference", "A1", "A2", "A3", "A4", "label",
          "predicted_class", "probability", "kept", "velocities"]
# query: (true label, predicted class, probability), worked by hand below
PREDICTIONS = {
    10: (0, 0, 0.90), 11: (0, 0, 0.80), 12: (0, 1, 0.70), 13: (1, 1, 0.60), 14: (1, 3, 0.95), 15: (1, 1, 0.99),
    16: (2, 0, 0.95), 17: (2, 2, 0.55), 18: (3, 2, 0.97), 19: (3, 3, 0.85), 20: (3, 0, 0.40), 21: (0, 0, 0.99),
    22: (2, 3, 0.99), 23: (0, 2, 0.30),
}
# the mistakes (predicted != true), most confident first; 14 and 16 tie at 0.95: the lower query first
MISTAKES_BY_CONFIDENCE = [22, 18, 14, 16, 12, 20, 23]
MEMBERS = {0: [10, 11, 12, 21, 23], 1: [13, 14, 15], 2: [16, 17, 22], 3: [18, 19, 20]}


@pytest.fixture
def dataset(colour_frames):
    return colour_frames


def _wrong(q):
    return LO + (q - LO + 8) % (HI - LO)


def query_rows(predictor=True, split="test", queries=PREDICTIONS):
    rows = []
    for q, (label, predicted, probability) in queries.items():
        single, sequence = label in (0, 1), label in (0, 2)
        rows.append([split, q, q if single else _wrong(q), 0.1 + q / 100, int(single), q if sequence else _wrong(q),
                     0.5 + q / 100, int(sequence), q, 0.5, 0.6, 0.7, 0.8, label,
                     *((predicted, probability, int(predicted in (0, 2))) if predictor else ("", "", "")), "1"])
    return rows


def write_queries(path, rows):
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(HEADER)
        writer.writerows(rows)
    return path


def matrix_of(rows, seed=0):
    """The test split's distance matrix the rows were made from: each query's single-frame match is its column's
    minimum, at the row's single_distance (0.2 .. 0.33); every other distance is in 0.5 .. 1."""
    matrix = np.random.default_rng(seed).uniform(0.5, 1.0, (HI - LO, HI - LO))
    for row in rows:
        query, match, distance = (row[HEADER.index(name)] for name in ("query", "single_match", "single_distance"))
        matrix[match - LO, query - LO] = distance
    return matrix


@pytest.fixture
def files(tmp_path, dataset):
    """The queries CSV (a val split of other frames too) and the test split's distance matrix."""
    val = {q: PREDICTIONS[q + 8] for q in range(2, 8)}
    queries = write_queries(tmp_path / "queries.csv", query_rows(split="val", queries=val) + query_rows())
    matrix = matrix_of(query_rows())
    distances = tmp_path / "test.h5"
    write_distance_matrix(distances, matrix, {"split": "test", "split_range": [LO, HI], "method": "toy",
                                              "frames_sha256": load_frames("toy", dataset).fingerprint()})
    return queries, distances, matrix


def test_sample_is_stratified_seeded_and_has_the_confident_mistakes(tmp_path):
    rows = inspector.read_queries(write_queries(tmp_path / "q.csv", query_rows()))
    sample = inspector.sample_queries(rows, "test", per_class=2, mistakes=3, seed=0)
    queries = [s.row.query for s in sample]
    assert queries == sorted(queries) and len(set(queries)) == len(queries)
    for label, members in MEMBERS.items():
        chosen = [s.row.query for s in sample if f"class {label} sample" in s.reason]
        assert len(chosen) == 2 and set(chosen) <= set(members)
    mistakes = {s.row.query for s in sample if "confident mistake" in s.reason}
    assert mistakes == {22, 18, 14}  # by hand: 0.99, 0.97, then 14 before 16 (both 0.95)
    assert all(s.reason in ("class 0 sample", "class 1 sample", "class 2 sample", "class 3 sample",
                            "confident mistake") or "; confident mistake" in s.reason for s in sample)
    # the same inputs give the same sample; another seed another one
    assert inspector.sample_queries(rows, "test", 2, 3, seed=0) == sample
    others = [inspector.sample_queries(rows, "test", 2, 3, seed=s) for s in range(1, 6)]
    assert any([s.row.query for s in other] != queries for other in others)
    # more than a class has: all of it; every mistake when asked for more than there are
    every = inspector.sample_queries(rows, "test", per_class=9, mistakes=99)
    assert [s.row.query for s in every] == sorted(PREDICTIONS)
    assert {s.row.query for s in every if "confident mistake" in s.reason} == set(MISTAKES_BY_CONFIDENCE)
    assert inspector.sample_queries(rows, "val") == []


def test_sample_without_a_predictor_has_no_mistakes(tmp_path):
    rows = inspector.read_queries(write_queries(tmp_path / "q.csv", query_rows(predictor=False)))
    assert rows[0].predicted_class is None and rows[0].kept is None and rows[0].right_decision is None
    sample = inspector.sample_queries(rows, "test", per_class=1, mistakes=4)
    assert len(sample) == 4 and not any("mistake" in s.reason for s in sample)


def colours_in(path):
    image = cv2.cvtColor(cv2.imread(str(path), cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)
    packed = image.reshape(-1, 3).astype(np.int64) @ np.array([1 << 16, 1 << 8, 1])
    values, counts = np.unique(packed, return_counts=True)
    return {(v >> 16, (v >> 8) & 255, v & 255): c for v, c in zip(values.tolist(), counts.tolist(), strict=True)}


def test_figures_show_the_frames_and_the_decisions(tmp_path, dataset, files):
    queries, distances, _ = files
    match, matrix = inspector.main(InspectJob(queries=str(queries), distances=str(distances),
                                              match_figure=str(tmp_path / "m.png"),
                                              matrix_figure=str(tmp_path / "d.png"), dataset="toy",
                                              dataset_settings=json.dumps(dataset), seq_len=L, split="test",
                                              truth=TruthSource(tolerance=TOL), per_class=1, mistakes=2))
    for path in (match, matrix):
        data = path.read_bytes()
        assert data.startswith(b"\x89PNG\r\n\x1a\n") and 20_000 < len(data) < 1_500_000
    rows = inspector.read_queries(queries)
    sample = inspector.sample_queries(rows, "test", per_class=1, mistakes=2)
    colours = colours_in(match)
    shown_queries, shown_references = set(), set()
    for s in sample:
        shown_queries |= set(range(s.row.query - L + 1, s.row.query + 1))
        shown_references |= {s.row.single_match, s.row.sequence_match, s.row.true_reference}
    # each thumbnail fills many pixels with its frame's exact colour; frames not shown are absent
    for i in range(N_FRAMES):
        assert (colours.get(query_colour(i), 0) > 200) == (i in shown_queries), f"query frame {i}"
        assert (colours.get(reference_colour(i), 0) > 200) == (i in shown_references), f"reference frame {i}"
    # the grid of thumbnails: a row per sampled query; L query frames, the single-frame match, the sequence match
    # and the true reference; each match framed green when the CSV says it is correct, red when wrong
    image = cv2.cvtColor(cv2.imread(str(match), cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)
    grid = thumbnail_grid(image)
    assert len(grid) == len(sample) and all(len(row) == L + 3 for row in grid)
    frames = {"green": (44, 160, 44), "red": (214, 39, 40)}  # matplotlib's tab:green and tab:red (figures.UP, DOWN)
    verdicts = set()
    for s, row in zip(sample, grid, strict=True):
        r = s.row
        assert [frame for frame, _ in row] == [*(("query", f) for f in range(r.query - L + 1, r.query + 1)),
                                               ("reference", r.single_match), ("reference", r.sequence_match),
                                               ("reference", r.true_reference)]
        for (_, box), correct in ((row[L], r.single_correct), (row[L + 1], r.sequence_correct)):
            expected = frames["green" if correct else "red"]
            assert frame_colour(image, box) == expected, (r.query, correct)
            verdicts.add(correct)
        for _, box in (*row[:L], row[L + 2]):  # the query frames and the true reference: grey or black, never both
            colour = frame_colour(image, box)
            assert colour not in frames.values() and max(colour) - min(colour) < 20, (r.query, colour)
    assert verdicts == {True, False}  # both a correct and a wrong match were checked
    # by hand: query 18 (true class 3) has a wrong single-frame match, reference 10, framed red; query 23 a correct
    # one, framed green
    by_query = {s.row.query: row for s, row in zip(sample, grid, strict=True)}
    assert 18 in by_query and 23 in by_query, sorted(by_query)
    assert by_query[18][L] == (("reference", 10), by_query[18][L][1]) and frame_colour(image, by_query[18][L][1]) == (
        214, 39, 40)
    assert by_query[23][L][0] == ("reference", 23) and frame_colour(image, by_query[23][L][1]) == (44, 160, 44)
    assert not list(tmp_path.glob("*.tmp"))


def thumbnail_grid(image, gap=5):
    """The match figure's thumbnails by row and column: each is a block of one frame's exact colour (larger than
    any caption), given as ((side, frame), (top, left, bottom, right)); rows top to bottom, columns left to right."""
    found = []
    for side, colour in (("query", query_colour), ("reference", reference_colour)):
        for i in range(N_FRAMES):
            mask = np.all(image == colour(i), axis=2).astype(np.uint8)
            n, _, stats, _ = cv2.connectedComponentsWithStats(mask)
            found += [((side, i), (y, x, y + h, x + w)) for x, y, w, h, area in stats[1:n] if area > 1000]
    found.sort(key=lambda item: item[1][0])
    rows = []
    for item in found:
        if rows and abs(item[1][0] - rows[-1][0][1][0]) <= gap:
            rows[-1].append(item)
        else:
            rows.append([item])
    return [sorted(row, key=lambda item: item[1][1]) for row in rows]


def frame_colour(image, box, outside=2):
    """The colour of a thumbnail's frame: the pixels ``outside`` pixels above its top edge and left of its left
    edge, at their middles (they must agree)."""
    top, left, bottom, right = box
    above = tuple(int(v) for v in image[top - outside, (left + right) // 2])
    beside = tuple(int(v) for v in image[(top + bottom) // 2, left - outside])
    assert above == beside, (box, above, beside)
    return above


def test_match_record_and_thumbnail_size(tmp_path, dataset, files):
    queries, distances, matrix = files
    pair = load_frames("toy", dataset)
    rows = [r for r in inspector.read_queries(queries) if r.split == "test"]
    sample = inspector.sample_queries(rows, "test", per_class=0, mistakes=1)
    record = inspector.draw_matches(tmp_path / "m.png", pair, sample, inspector.SplitMatrix(matrix, LO),
                                    MatcherSpec.of().build(L), "title")
    assert record.queries == (22,) and record.reasons == ("confident mistake",)
    assert record.frames == ((20, 21, 22, _wrong(22), 22, 22),)  # L query frames, single (wrong), sequence, true
    assert inspector.thumbnail(np.zeros((300, 600, 3), np.uint8)).shape == (96, 192, 3)
    assert inspector.thumbnail(np.zeros((32, 64, 3), np.uint8)).shape == (32, 64, 3)


def test_matrix_figure_marks_kept_and_removed(tmp_path, files):
    queries, _, matrix = files
    rows = [r for r in inspector.read_queries(queries) if r.split == "test"]
    record = inspector.draw_matrix(tmp_path / "d.png", inspector.SplitMatrix(matrix, LO), rows, TOL, "title")
    kept = [q for q, (_, predicted, _) in PREDICTIONS.items() if predicted in (0, 2)]
    assert record == inspector.MatrixRecord((16, 16), 1, len(kept), len(PREDICTIONS) - len(kept), 0)
    assert (record.kept, record.removed) == (8, 6)  # by hand: predicted 0 or 2 for 10, 11, 16, 17, 18, 20, 21, 23
    colours = colours_in(tmp_path / "d.png")
    assert colours.get((44, 160, 44), 0) > 20 and colours.get((214, 39, 40), 0) > 0  # green dots, red crosses
    unpredicted = inspector.read_queries(write_queries(tmp_path / "q.csv", query_rows(predictor=False)))
    assert inspector.draw_matrix(tmp_path / "d2.png", inspector.SplitMatrix(matrix, LO), unpredicted, TOL,
                                 "t").unpredicted == 14


def test_large_matrices_are_shown_as_block_means(monkeypatch):
    matrix = np.arange(7 * 10, dtype=float).reshape(7, 10)
    monkeypatch.setattr(inspector, "READ_VALUES", 20)  # several column reads
    means = inspector.block_means(matrix, 3)
    assert means.shape == (3, 4)
    assert means[0, 0] == pytest.approx(matrix[:3, :3].mean())
    assert means[2, 3] == pytest.approx(matrix[6:, 9:].mean())  # the last tiles hold what is left
    assert means[1, 3] == pytest.approx(matrix[3:6, 9:].mean())


def test_changed_frames_are_refused(tmp_path, dataset, files):
    queries, distances, _ = files
    out = tmp_path / "m.png", tmp_path / "d.png"
    for side in ("reference", "query"):  # one more frame in both: another frame list than the distances'
        cv2.imwrite(str(Path(dataset[side]) / f"frame{N_FRAMES:03d}.png"), np.zeros((8, 16, 3), dtype=np.uint8))
    with pytest.raises(ValueError, match="dataset 'toy': its frames changed.*run the workflow again"):
        inspector.main(InspectJob(queries=str(queries), distances=str(distances), match_figure=str(out[0]),
                                  matrix_figure=str(out[1]), dataset="toy", dataset_settings=json.dumps(dataset),
                                  seq_len=L, split="test", truth=TruthSource(tolerance=TOL)))
    assert not any(p.exists() for p in out) and not list(tmp_path.glob("*.tmp"))


def test_a_given_fingerprint_must_match(tmp_path, dataset, files):
    queries, distances, _ = files
    fingerprint = load_frames("toy", dataset).fingerprint()
    with pytest.raises(ValueError, match="run the workflow again"):
        inspector.main(InspectJob(queries=str(queries), distances=str(distances), match_figure=str(tmp_path / "m.png"),
                                  matrix_figure=str(tmp_path / "d.png"), dataset="toy",
                                  dataset_settings=json.dumps(dataset), frames_sha256="0" * 64, seq_len=L, split="test",
                                  truth=TruthSource(tolerance=TOL)))
    with pytest.raises(ValueError, match="holds frames 8..23, not the split's 0..15"):
        inspector.main(InspectJob(queries=str(queries), distances=str(distances), match_figure=str(tmp_path / "m.png"),
                                  matrix_figure=str(tmp_path / "d.png"), dataset="toy",
                                  dataset_settings=json.dumps(dataset), frames_sha256=fingerprint, seq_len=L,
                                  split="test", truth=TruthSource(tolerance=TOL), frames=(0, 16)))
    with pytest.raises(ValueError, match="another sequence length"):
        inspector.main(InspectJob(queries=str(queries), distances=str(distances), match_figure=str(tmp_path / "m.png"),
                                  matrix_figure=str(tmp_path / "d.png"), dataset="toy",
                                  dataset_settings=json.dumps(dataset), frames_sha256=fingerprint, seq_len=5,
                                  split="test", truth=TruthSource(tolerance=TOL)))
    assert not list(tmp_path.glob("*.png")) and not list(tmp_path.glob("*.tmp"))


def test_a_csv_of_a_longer_sequence_length_or_a_later_split_is_refused(tmp_path, dataset, files):
    _, distances, _ = files
    out = tmp_path / "m.png", tmp_path / "d.png"
    # made at L = 5: its queries start at frame LO + 4 = 12, not at LO + L - 1 = 10 as --seq-len 3 has them
    longer = write_queries(tmp_path / "L5.csv", query_rows(queries={q: v for q, v in PREDICTIONS.items() if q >= 12}))
    with pytest.raises(ValueError, match=r"L5.csv: split 'test' has queries 12..23, but at L = 3 the distance "
                                         r"matrix of frames 8..23 has the evaluated queries 10..23.*another sequence "
                                         r"length or for another split.*--seq-len 3"):
        inspector.main(InspectJob(queries=str(longer), distances=str(distances), match_figure=str(out[0]),
                                  matrix_figure=str(out[1]), dataset="toy", dataset_settings=json.dumps(dataset),
                                  seq_len=L, split="test", truth=TruthSource(tolerance=TOL)))
    # a gap, or a query twice: not one row per evaluated query
    gap = write_queries(tmp_path / "gap.csv", query_rows(queries={q: v for q, v in PREDICTIONS.items() if q != 15}))
    with pytest.raises(ValueError, match="13 queries 10..23, not one per frame"):
        inspector.main(InspectJob(queries=str(gap), distances=str(distances), match_figure=str(out[0]),
                                  matrix_figure=str(out[1]), dataset="toy", dataset_settings=json.dumps(dataset),
                                  seq_len=L, split="test", truth=TruthSource(tolerance=TOL)))
    twice = write_queries(tmp_path / "twice.csv", query_rows() + query_rows()[:1])
    with pytest.raises(ValueError, match="15 queries 10..23, not one per frame"):
        inspector.main(InspectJob(queries=str(twice), distances=str(distances), match_figure=str(out[0]),
                                  matrix_figure=str(out[1]), dataset="toy", dataset_settings=json.dumps(dataset),
                                  seq_len=L, split="test", truth=TruthSource(tolerance=TOL)))
    assert not any(p.exists() for p in out) and not list(tmp_path.glob("*.tmp"))


def test_a_csv_of_another_distance_matrix_is_refused(tmp_path, dataset, files):
    queries, _, matrix = files
    out = tmp_path / "m.png", tmp_path / "d.png"
    provenance = {"split": "test", "split_range": [LO, HI], "method": "other",
                  "frames_sha256": load_frames("toy", dataset).fingerprint()}
    # another method's matrix, nearer the true reference where the CSV's single-frame match is wrong (classes 2 and
    # 3, sampled) and the same elsewhere
    other = matrix.copy()
    for q in (q for q, (label, *_) in PREDICTIONS.items() if label in (2, 3)):
        other[q - LO, q - LO] = 0.05
    write_distance_matrix(tmp_path / "other.h5", other, provenance)
    with pytest.raises(ValueError, match=r"queries.csv: query \d+'s single-frame match is reference \d+, but the "
                                         r"nearest reference in .*other.h5 is \d+: the CSV was made from another "
                                         r"distance matrix.*vpr-smr queries"):
        inspector.main(InspectJob(queries=str(queries), distances=str(tmp_path / "other.h5"), match_figure=str(out[0]),
                                  matrix_figure=str(out[1]), dataset="toy", dataset_settings=json.dumps(dataset),
                                  seq_len=L, split="test", truth=TruthSource(tolerance=TOL), per_class=1, mistakes=2))
    # the same nearest references at other distances: still another matrix
    write_distance_matrix(tmp_path / "scaled.h5", matrix * 1.5, provenance)
    with pytest.raises(ValueError, match=r"single-frame distance is 0.\d+, but it is 0.\d+ in .*scaled.h5: the CSV "
                                         "was made from another distance matrix"):
        inspector.main(InspectJob(queries=str(queries), distances=str(tmp_path / "scaled.h5"), match_figure=str(out[0]),
                                  matrix_figure=str(out[1]), dataset="toy", dataset_settings=json.dumps(dataset),
                                  seq_len=L, split="test", truth=TruthSource(tolerance=TOL), per_class=1, mistakes=2))
    assert not any(p.exists() for p in out) and not list(tmp_path.glob("*.tmp"))


def test_both_figures_or_none(tmp_path, dataset, files, monkeypatch):
    queries, distances, _ = files

    def broken(*args, **kwargs):
        raise RuntimeError("drawing failed")

    monkeypatch.setattr(inspector, "draw_matrix", broken)
    with pytest.raises(RuntimeError):
        inspector.main(InspectJob(queries=str(queries), distances=str(distances), match_figure=str(tmp_path / "m.png"),
                                  matrix_figure=str(tmp_path / "d.png"), dataset="toy",
                                  dataset_settings=json.dumps(dataset), seq_len=L, split="test",
                                  truth=TruthSource(tolerance=TOL), per_class=0, mistakes=1))
    assert not list(tmp_path.glob("*.png")) and not list(tmp_path.glob("*.tmp"))


def test_cli(tmp_path, dataset, files, capsys):
    import json

    queries, distances, _ = files
    fingerprint = load_frames("toy", dataset).fingerprint()
    args = ["inspect", "--queries", str(queries), "--distances", str(distances), "--dataset", "toy",
            "--dataset-settings", json.dumps({**dataset, "splits": {"test": [LO, HI]}, "tolerance": TOL}),
            "--seq-len", str(L), "--split", "test", "--tolerance", str(TOL), "--frames", str(LO), str(HI),
            "--match-figure", str(tmp_path / "out" / "m.png"), "--matrix-figure", str(tmp_path / "out" / "d.png"),
            "--per-class", "1", "--mistakes", "1", "--seed", "3"]
    assert cli([*args, "--frames-sha256", fingerprint]) == 0
    assert (tmp_path / "out" / "m.png").stat().st_size > 0 and (tmp_path / "out" / "d.png").stat().st_size > 0
    assert cli([*args, "--frames-sha256", "f" * 64]) == 2
    assert "run the workflow again" in capsys.readouterr().err
    bad = [a if a != str(tmp_path / "out" / "m.png") else str(tmp_path / "m.jpg") for a in args]
    assert cli(bad) == 2
    assert "--match-figure" in capsys.readouterr().err and not (tmp_path / "m.jpg").exists()


def test_bad_queries_csv_names_the_problem(tmp_path):
    rows = query_rows()
    rows[0][HEADER.index("label")] = 7
    with pytest.raises(ValueError, match=r"q.csv, line 2: label '7' is not a class 0..3"):
        inspector.read_queries(write_queries(tmp_path / "q.csv", rows))
    (tmp_path / "short.csv").write_text("split,query\ntest,3\n")
    with pytest.raises(ValueError, match="lacks the columns single_match, single_distance"):
        inspector.read_queries(tmp_path / "short.csv")
