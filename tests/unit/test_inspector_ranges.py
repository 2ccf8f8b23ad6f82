"""The match inspector's distance-matrix figure where the axes are not one range (a split with its own reference
range, traverses with positions), and `vpr-smr inspect` on a user's matrix without a dataset of images."""

import csv
import json

import cv2
import h5py
import numpy as np
import pytest
from helpers import COLOUR_FRAMES, reference_colour, write_distance_matrix
from matplotlib.collections import PathCollection
from matplotlib.contour import ContourSet

from vpr_smr.datasets import load_frames
from vpr_smr.eval.matching.sources import TruthSource
from vpr_smr.eval.report import inspector
from vpr_smr.eval.report.figures import _pyplot
from vpr_smr.eval.report.inspector import InspectJob
from vpr_smr.pipeline.cli import main as cli

N_FRAMES, L = COLOUR_FRAMES, 3
QUERY_LO, QUERY_HI = 8, 20  # the split's queries: frames 8..19
REF_LO, REF_HI = 4, 12  # its references: frames 4..11
SHIFT = 5  # query frame q stands at the place of reference frame q - 5 (positions in metres)
RADIUS = 1.0
HEADER = ["split", "query", "single_match", "single_distance", "single_correct", "sequence_match",
          "sequence_distance", "sequence_correct", "true_reference", "label", "predicted_class", "probability",
          "kept", "velocities"]


@pytest.fixture
def figures(monkeypatch):
    """The figures the inspector draws, kept open (in drawing order) so that their Axes can be read."""
    plt, drawn = _pyplot(), []

    class Keep:
        def __getattr__(self, name):
            return getattr(plt, name)

        def close(self, fig):
            drawn.append(fig)

    monkeypatch.setattr(inspector, "_pyplot", Keep)
    yield drawn
    for fig in drawn:
        plt.close(fig)


def matrix_axes(fig):
    """The distance-matrix figure's main Axes (the other one is the colour bar)."""
    return next(ax for ax in fig.axes if ax.images and ax.get_xlabel().startswith("query frame"))


def scattered(ax):
    return {(float(x), float(y)) for c in ax.collections if isinstance(c, PathCollection)
            and not isinstance(c, ContourSet) for x, y in c.get_offsets()}


def contour_vertices(ax):
    (contour,) = [c for c in ax.collections if isinstance(c, ContourSet)]
    return np.concatenate([p.vertices for p in contour.get_paths() if len(p.vertices)])


@pytest.fixture
def dataset(colour_frames):
    return colour_frames


def ranged_split(tmp_path, dataset):
    """A split with positions whose references (frames 4..11) are not its queries' frames (8..19): the distances
    file (as the distances stage writes it) and the queries CSV of its evaluated queries 10..19."""
    rng = np.random.default_rng(1)
    matrix = rng.uniform(0.5, 1.0, (REF_HI - REF_LO, QUERY_HI - QUERY_LO))
    rows = []
    for q in range(QUERY_LO + L - 1, QUERY_HI):
        true = min(max(q - SHIFT, REF_LO), REF_HI - 1)
        single = true if q % 3 else REF_LO + (q % (REF_HI - REF_LO))  # every third query matched elsewhere
        sequence = true if q % 2 else REF_HI - 1 - (q % 4)
        distance = 0.2 + q / 100
        matrix[single - REF_LO, q - QUERY_LO] = distance
        label = {(True, True): 0, (True, False): 1, (False, True): 2, (False, False): 3}[
            (abs(single - (q - SHIFT)) <= RADIUS, abs(sequence - (q - SHIFT)) <= RADIUS)]
        rows.append(["test", q, single, distance, int(label in (0, 1)), sequence, 0.9, int(label in (0, 2)), true,
                     label, label, 0.8, int(q % 2), "1"])
    queries = tmp_path / "queries.csv"
    with open(queries, "w", newline="") as f:
        csv.writer(f).writerows([HEADER, *rows])
    distances = tmp_path / "test.h5"
    write_distance_matrix(distances, matrix, {
        "split": "test", "split_range": [QUERY_LO, QUERY_HI], "reference_range": [REF_LO, REF_HI], "method": "toy",
        "frames_sha256": load_frames("toy", dataset).fingerprint()})
    with h5py.File(distances, "a") as f:  # positions in metres: reference frame r at r, query frame q at q - 5
        f["reference_positions"] = np.arange(REF_LO, REF_HI, dtype=float)
        f["query_positions"] = np.arange(QUERY_LO, QUERY_HI, dtype=float) - SHIFT
    return queries, distances, rows


def test_each_axis_has_its_own_range(tmp_path, dataset, figures):
    queries, distances, rows = ranged_split(tmp_path, dataset)
    match, matrix = inspector.main(InspectJob(queries=str(queries), distances=str(distances),
                                              match_figure=str(tmp_path / "m.png"),
                                              matrix_figure=str(tmp_path / "d.png"), dataset="toy",
                                              dataset_settings=json.dumps(dataset), seq_len=L, split="test",
                                              truth=TruthSource(tolerance=2, radius=RADIUS), per_class=1, mistakes=1))
    assert match is not None and match.is_file() and matrix.is_file()
    ax = matrix_axes(figures[-1])
    # by hand: queries 8..19 from x = 7.5 to 19.5; references 4..11 from y = 4 - 0.5 (top) to 11 + 0.5 (bottom)
    assert ax.get_xlim() == pytest.approx((7.5, 19.5))
    assert ax.get_ylim() == pytest.approx((11.5, 3.5))
    assert ax.images[0].get_extent() == pytest.approx([7.5, 19.5, 11.5, 3.5])
    ticks = [t for t in ax.get_yticks() if 3.5 <= t <= 11.5]
    assert min(ticks) <= 5 and max(ticks) >= 10  # the reference axis is labelled over all of 4..11
    # every sequence match at (query, reference) in dataset frames, inside the drawn area
    assert scattered(ax) == {(float(r[1]), float(r[5])) for r in rows}
    assert all(7.5 < x < 19.5 and 3.5 < y < 11.5 for x, y in scattered(ax))
    # the ground truth |(q - 5) - r| <= 1 outlined halfway between a correct and a wrong frame: |y - (x - 5)| = 1.5
    vertices = contour_vertices(ax)
    assert len(vertices) > 4 and np.allclose(np.abs(vertices[:, 1] - (vertices[:, 0] - SHIFT)), 1.5)
    # the match figure's thumbnails are the references' own frames (4..11), not frames counted from the queries'
    rows_by_query = {r[1]: r for r in rows}
    sample = inspector.sample_queries(inspector.read_queries(queries), "test", 1, 1)
    shown = {f for s in sample for f in (rows_by_query[s.row.query][i] for i in (2, 5, 8))}
    image = cv2.cvtColor(cv2.imread(str(match), cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)
    present = {i for i in range(N_FRAMES) if np.all(image == reference_colour(i), axis=2).sum() > 200}
    assert present == shown and shown <= set(range(REF_LO, REF_HI))


def test_the_frame_band_follows_each_range(tmp_path, figures):
    """Without positions the band counts frames from each range's first frame, as scoring does."""
    matrix = np.random.default_rng(0).uniform(0.5, 1.0, (8, 12))
    inspector.draw_matrix(tmp_path / "d.png", inspector.SplitMatrix(matrix, 8, reference_lo=4), [], 1, "t")
    ax = matrix_axes(figures[-1])
    assert ax.get_xlim() == pytest.approx((7.5, 19.5)) and ax.get_ylim() == pytest.approx((11.5, 3.5))
    # by hand: correct where |(r - 4) - (q - 8)| <= 1, so the outline lies at |y - x + 4| = 1.5
    vertices = contour_vertices(ax)
    assert len(vertices) > 4 and np.allclose(np.abs(vertices[:, 1] - vertices[:, 0] + 4), 1.5)


def user_matrix(tmp_path, n=12):
    """A user's matrix (.npy): D[r, q] = |r - q| / n + 0.05, so every query's best reference, single-frame and
    sequence, is itself; its queries CSV from `vpr-smr queries` (split ``all``)."""
    r, q = np.mgrid[0:n, 0:n]
    path = tmp_path / "D.npy"
    np.save(path, np.abs(r - q) / n + 0.05)
    queries = tmp_path / "queries.csv"
    assert cli(["queries", "--distances", str(path), "--seq-len", str(L), "--out", str(queries)]) == 0
    return path, queries


def test_a_users_matrix_without_images(tmp_path, figures):
    distances, queries = user_matrix(tmp_path)
    out = tmp_path / "out" / "d.png"
    assert cli(["inspect", "--queries", str(queries), "--distances", str(distances), "--seq-len", str(L),
                "--matrix-figure", str(out)]) == 0
    assert out.read_bytes().startswith(b"\x89PNG\r\n\x1a\n")
    (fig,) = figures  # the distance-matrix figure alone
    ax = matrix_axes(fig)
    assert ax.get_xlim() == pytest.approx((-0.5, 11.5)) and ax.get_ylim() == pytest.approx((11.5, -0.5))
    # by hand: queries 2..11 (L = 3) each matched to itself
    assert scattered(ax) == {(float(q), float(q)) for q in range(2, 12)}


def test_the_match_figure_needs_a_dataset_with_images(tmp_path, capsys):
    distances, queries = user_matrix(tmp_path)
    out = tmp_path / "m.png", tmp_path / "d.png"
    base = ["inspect", "--queries", str(queries), "--seq-len", str(L), "--match-figure", str(out[0]),
            "--matrix-figure", str(out[1])]
    capsys.readouterr()
    # said before any work: even before the distances file is looked for
    assert cli([*base, "--distances", str(tmp_path / "missing.npy")]) == 2
    error = capsys.readouterr().err
    assert "needs a dataset with images" in error and "--dataset NAME and --dataset-settings" in error
    assert "leave out --match-figure" in error and "not found" not in error
    # a dataset entry without a loader (the user's Nordland without its images)
    assert cli([*base, "--distances", str(distances), "--dataset", "nordland", "--dataset-settings", "{}"]) == 2
    error = capsys.readouterr().err
    assert "gives dataset 'nordland' no loader" in error and "leave out --match-figure" in error
    assert "loader is None" not in error
    assert cli([*base, "--distances", str(distances), "--dataset", "nordland"]) == 2
    assert "--dataset-settings JSON together" in capsys.readouterr().err
    assert not any(p.exists() for p in out) and not list(tmp_path.glob("*.tmp"))


def test_the_split_is_the_csvs_only_one_or_named(tmp_path, dataset):
    distances, queries = user_matrix(tmp_path)
    with pytest.raises(ValueError, match=r"has no queries of split 'test' \(its splits: 'all'\).*--split"):
        inspector.main(InspectJob(queries=str(queries), distances=str(distances), matrix_figure=str(tmp_path / "d.png"),
                                  seq_len=L, split="test", truth=TruthSource(tolerance=2)))
    two = tmp_path / "two.csv"
    lines = queries.read_text().splitlines()
    two.write_text("\n".join([*lines, *(line.replace("all,", "val,", 1) for line in lines[1:])]) + "\n")
    with pytest.raises(ValueError, match=r"has the splits 'all', 'val': choose one with --split"):
        inspector.main(InspectJob(queries=str(two), distances=str(distances), matrix_figure=str(tmp_path / "d.png"),
                                  seq_len=L, truth=TruthSource(tolerance=2)))
    assert not (tmp_path / "d.png").exists()
