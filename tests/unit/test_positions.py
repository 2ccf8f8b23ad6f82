"""Traverses with positions (method §11, issue 20): CSVs and @UTM@ names, lat/lon in metres, different lengths,
separate reference and query ranges, the dataset check, the descriptor and distance files, and the split checks."""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path

import cv2
import h5py
import numpy as np
import pytest
from street_dataset import (
    QUERY_XY,
    REFERENCE_XY,
    csv_dataset,
    image,
    plain_names,
    plan_config,
    utm_dataset,
    write_csv,
    write_folder,
)

from vpr_smr.core.io import atomic_h5, read_provenance
from vpr_smr.datasets import DatasetError, load_dataset
from vpr_smr.datasets import check as check_module
from vpr_smr.datasets.base import Traverse, TraversePair
from vpr_smr.datasets.positions import median_spacing, positions_from_csv, positions_from_names
from vpr_smr.eval.matching import distances
from vpr_smr.eval.matching.distances import DistancesJob, distance_matrix
from vpr_smr.eval.matching.ground_truth import GroundTruth
from vpr_smr.eval.predictor.leakage import FrameRange, SplitLeakError, check_disjoint, frame_range
from vpr_smr.pipeline.plan import dataset_cards, plan_from_json, plan_to_json, split_overlaps

# --- positions from names and CSVs ---


def test_utm_names_and_csv_give_the_same_positions_and_ground_truth(tmp_path):
    by_names = load_dataset("street", utm_dataset(tmp_path))
    by_csv = load_dataset("street", csv_dataset(tmp_path))
    for pair in (by_names, by_csv):
        assert pair.has_positions and pair.radius == 5.0
        assert (len(pair.reference), len(pair.query)) == (8, 5)  # different lengths: not frame-aligned
    np.testing.assert_array_equal(by_names.reference.positions, REFERENCE_XY)
    np.testing.assert_array_equal(by_names.query.positions, QUERY_XY)
    np.testing.assert_array_equal(by_csv.reference.positions, by_names.reference.positions)
    np.testing.assert_array_equal(by_csv.query.positions, by_names.query.positions)
    r, q = np.meshgrid(np.arange(8), np.arange(5), indexing="ij")
    truths = [GroundTruth.positions(p.reference.positions, p.query.positions, p.radius).correct(r, q)
              for p in (by_names, by_csv)]
    np.testing.assert_array_equal(truths[0], truths[1])
    # by hand: query t at east 2 + 15 t, 3 m across; reference i at east 10 i: within 5 m iff |10 i - 2 - 15 t| <= 4
    expected = np.abs(10 * r - 2 - 15 * q) <= 4
    np.testing.assert_array_equal(truths[0], expected)
    assert truths[0].sum() == 5  # one reference per query here
    assert by_names.pairing.startswith("by positions within 5 m (the UTM easting and northing in the @UTM_east")
    assert by_csv.pairing.startswith("by positions within 5 (units of the CSVs' x, y) (the CSV files ")
    # the @UTM@ names sort by easting: the pair says so, for a route not driven due east
    assert "order of the eastings" in (by_names.reference.order_note or "")


def test_positions_are_read_only_and_left_out_of_equality(tmp_path):
    pair = load_dataset("street", csv_dataset(tmp_path))
    positions = pair.reference.positions
    assert positions is not None and positions.dtype == np.float64 and positions.shape == (8, 2)
    with pytest.raises(ValueError):
        positions[0, 0] = 1.0
    assert pair.reference == Traverse(pair.reference.name, pair.reference.images, pair.reference.order_note)
    hash(pair.reference)


# Points ~100 m apart on the central meridian of UTM zone 30 (3 degrees west), near Oxford. There the projection
# scales every distance by k0 = 0.9996; a step of d metres north is d / rho radians of latitude, a step of d
# metres east d / (N cos(lat)) radians of longitude (WGS84 radii of curvature), so both project to k0 * d.
A, F, K0 = 6378137.0, 1 / 298.257223563, 0.9996
E2 = F * (2 - F)


def radii(lat: float) -> tuple[float, float]:
    """(meridian radius rho, prime-vertical radius N) of WGS84 at ``lat`` degrees."""
    s = math.sin(math.radians(lat)) ** 2
    return A * (1 - E2) / (1 - E2 * s) ** 1.5, A / math.sqrt(1 - E2 * s)


def test_lat_lon_become_metres_within_centimetres(tmp_path):
    lat0, lon0 = 51.75, -3.0
    rho, n = radii(lat0)
    north = math.degrees(100.0 / rho)
    east = math.degrees(100.0 / (n * math.cos(math.radians(lat0))))
    points = [(lat0, lon0), (lat0 + north, lon0), (lat0, lon0 + east), (lat0 + north, lon0 + east)]
    names = plain_names(4)
    images = write_folder(tmp_path / "ref", names)
    csv = write_csv(tmp_path / "ll.csv", "name,lat,lon", [(nm, a, b) for nm, (a, b) in zip(names, points, strict=True)])
    xy = positions_from_csv(csv, images, tmp_path / "ref")
    step = lambda i, j: float(np.hypot(*(xy[i] - xy[j])))  # noqa: E731
    assert step(0, 1) == pytest.approx(K0 * 100.0, abs=0.01)  # north
    assert step(0, 2) == pytest.approx(K0 * 100.0, abs=0.01)  # east
    assert step(0, 3) == pytest.approx(K0 * 100.0 * math.sqrt(2), abs=0.01)
    assert xy[0, 0] == pytest.approx(500000.0, abs=0.01)  # the central meridian's false easting


def test_both_traverses_share_the_reference_zone(tmp_path):
    """A query just across a zone border is projected into the reference's zone, not its own: the distance
    between the traverses stays the ground distance (about 1.58 km here, 1.0004 times at 3 degrees from the
    zone's centre), not hundreds of kilometres."""
    from pyproj import Geod

    ref_images = write_folder(tmp_path / "ref", ["a.png"])
    qry_images = write_folder(tmp_path / "qry", ["b.png"])
    ref_csv = write_csv(tmp_path / "r.csv", "name,lat,lon", [("a.png", 45.0, 5.99)])  # zone 31
    qry_csv = write_csv(tmp_path / "q.csv", "name,lat,lon", [("b.png", 45.0, 6.01)])  # zone 32 on its own
    from vpr_smr.datasets.positions import csv_pair_positions

    ref, qry, unit, how = csv_pair_positions(ref_csv, ref_images, tmp_path / "ref", qry_csv, qry_images,
                                             tmp_path / "qry")
    ground = Geod(ellps="WGS84").inv(5.99, 45.0, 6.01, 45.0)[2]
    assert float(np.hypot(*(ref[0] - qry[0]))) == pytest.approx(ground, rel=1e-3)
    assert "UTM zone 31N" in how and unit == "metres"


def test_relative_names_and_bare_names_in_a_list(tmp_path):
    """Images named by a frame list may lie in sub-folders: a row names one by its path in the folder, or by its
    bare file name when no other image has it."""
    folder = tmp_path / "ref"
    images = [*write_folder(folder / "a", ["x.png", "y.png"]), *write_folder(folder / "b", ["x.png"], seed=5)]
    csv = write_csv(tmp_path / "p.csv", "name,x,y", [("a/x.png", 1, 0), ("y.png", 2, 0), ("b/x.png", 3, 0)])
    np.testing.assert_array_equal(positions_from_csv(csv, images, folder), [(1, 0), (2, 0), (3, 0)])
    ambiguous = write_csv(tmp_path / "q.csv", "name,x,y", [("x.png", 1, 0), ("y.png", 2, 0)])
    with pytest.raises(DatasetError, match=r"no position for 2 of the 3 images of .*: a/x.png, b/x.png"):
        positions_from_csv(ambiguous, images, folder)


# --- errors name the file, the line and the fix ---


@pytest.mark.parametrize(("text", "message"), [
    ("name,x,y\n0000.png,1,2\n0001.png,abc,2\n", r"q.csv, line 3: x is 'abc', not a number"),
    ("name,x,y\n0000.png,1,2\n0000.png,3,4\n", r"q.csv, line 3: '0000.png' has a position already \(line 2\)"),
    ("file,east,north\n0000.png,1,2\n", r"q.csv, line 1: the header is 'file,east,north'; a positions CSV starts "
                                        r"with the header 'name,x,y' .* or 'name,lat,lon'"),
    ("name,x,y\n0000.png,1\n", r"q.csv, line 2: 2 fields .* each row is name,x,y"),
    ("name,lat,lon\n0000.png,95,2\n", r"q.csv, line 2: lat 95.0, lon 2.0 are not WGS84 degrees"),
    ("name,x,y\n0000.png,1,2\n", r"q.csv: no position for 1 of the 2 images of .*qry: 0001.png; add a row"),
])
def test_csv_errors_name_file_and_line(tmp_path, text, message):
    write_folder(tmp_path / "qry", plain_names(2))
    (tmp_path / "q.csv").write_text(text)
    with pytest.raises(DatasetError, match=message):
        positions_from_csv(tmp_path / "q.csv", [tmp_path / "qry" / n for n in plain_names(2)], tmp_path / "qry")


def test_loader_errors(tmp_path):
    conf = csv_dataset(tmp_path)
    with pytest.raises(DatasetError, match=r"positions file not found: .*absent.csv"):
        load_dataset("street", {**conf, "query_positions": str(tmp_path / "absent.csv")})
    with pytest.raises(DatasetError, match="reference_positions is set but query_positions is not"):
        load_dataset("street", {k: v for k, v in conf.items() if k != "query_positions"})
    with pytest.raises(DatasetError, match=r"datasets.street.radius is not set: the frames have positions in units "
                                           r"of the CSVs' x, y"):
        load_dataset("street", {k: v for k, v in conf.items() if k != "radius"})
    with pytest.raises(DatasetError, match=r"datasets.street.tolerance is set, but the frames have positions"):
        load_dataset("street", {**conf, "tolerance": 2})
    with pytest.raises(DatasetError, match=r"datasets.street.radius is -1.0: give a distance > 0"):
        load_dataset("street", {**conf, "radius": -1})
    with pytest.raises(DatasetError, match="positions: file_names and reference_positions / query_positions are both"):
        load_dataset("street", {**conf, "positions": "file_names"})
    (tmp_path / "other.csv").write_text("name,lat,lon\n0000.png,51,0\n")
    with pytest.raises(DatasetError, match=r"ref.csv holds x,y but .*other.csv holds lat,lon"):
        load_dataset("street", {**conf, "query_positions": str(tmp_path / "other.csv")})


def test_a_name_outside_the_utm_convention_is_named(tmp_path):
    conf = utm_dataset(tmp_path)
    cv2.imwrite(str(tmp_path / "utm_qry" / "frame7.png"), image(7))
    with pytest.raises(DatasetError, match=r"1 of 6 images have names outside the @UTM_east@UTM_north@ convention "
                                           r".*: .*utm_qry/frame7.png; rename them, or give positions in CSV files"):
        load_dataset("street", conf)
    with pytest.raises(DatasetError, match=r"@abc@1@.png"):
        positions_from_names([tmp_path / "@abc@1@.png"])


def test_radius_without_positions_is_refused(tmp_path):
    names = plain_names(4)
    write_folder(tmp_path / "a", names)
    write_folder(tmp_path / "b", names)
    conf = {"loader": "folders", "reference": str(tmp_path / "a"), "query": str(tmp_path / "b")}
    with pytest.raises(DatasetError, match=r"datasets.x.radius is set, but the frames have no positions"):
        load_dataset("x", {**conf, "radius": 5})


# --- lengths and splits ---


def test_different_lengths_load_with_positions_and_are_refused_without(tmp_path):
    conf = csv_dataset(tmp_path)
    assert (len(load_dataset("street", conf).reference), len(load_dataset("street", conf).query)) == (8, 5)
    aligned = {k: conf[k] for k in ("loader", "reference", "query")}
    with pytest.raises(DatasetError, match=r"ref has 8 images but .*qry has 5.*only in .*ref: 0005.png"):
        load_dataset("street", aligned)
    with pytest.raises(DatasetError, match="the reference traverse has positions but the query traverse has none"):
        TraversePair("x", Traverse("r", (Path("a.png"),), positions=np.zeros((1, 2))), Traverse("q", (Path("b"),)))


def test_splits_with_separate_ranges(tmp_path):
    conf = csv_dataset(tmp_path, splits={"train": {"reference": [0, 4], "query": [0, 2]}, "test": [2, 5],
                                         "same": {"reference": [5, 8], "query": [5, 8]}})
    with pytest.raises(DatasetError, match=r"split 'same' query range = \[5, 8\) is outside the 5 frames of the "
                                           r"query traverse \(qry\)"):
        load_dataset("street", conf)
    conf["splits"]["same"] = {"reference": [5, 8], "query": [2, 5]}
    pair = load_dataset("street", conf)
    assert pair.splits == {"train": (0, 2), "test": (2, 5), "same": (2, 5)}
    assert pair.reference_splits == {"train": (0, 4), "same": (5, 8)}  # only the ranges that differ
    assert [pair.reference_range(s) for s in pair.splits] == [(0, 4), (2, 5), (5, 8)]
    conf["splits"]["train"] = {"reference": [0, 9], "query": [0, 2]}
    with pytest.raises(DatasetError, match=r"split 'train' reference range = \[0, 9\) is outside the 8 frames of "
                                           r"the reference traverse \(ref\)"):
        load_dataset("street", conf)
    conf["splits"]["train"] = {"reference": [0, 4]}
    with pytest.raises(DatasetError, match=r"datasets.street.splits.train has keys reference; give \[lo, hi\]"):
        load_dataset("street", conf)


def test_separate_ranges_need_positions(tmp_path):
    names = plain_names(6)
    write_folder(tmp_path / "a", names)
    write_folder(tmp_path / "b", names)
    conf = {"loader": "folders", "reference": str(tmp_path / "a"), "query": str(tmp_path / "b"),
            "splits": {"train": {"reference": [0, 3], "query": [0, 2]}}}
    with pytest.raises(DatasetError, match="split 'train' gives its reference range apart from its query range, "
                                           "which needs positions"):
        load_dataset("x", conf)
    conf["splits"] = {"train": {"reference": [0, 3], "query": [0, 3]}}  # the same range twice: the short form
    assert load_dataset("x", conf).reference_splits == {}


def test_frames_setting_slices_positions(tmp_path):
    pair = load_dataset("street", csv_dataset(tmp_path, frames=[1, 4]))
    np.testing.assert_array_equal(pair.reference.positions, REFERENCE_XY[1:4])
    np.testing.assert_array_equal(pair.query.positions, QUERY_XY[1:4])
    assert pair.splits == {"all": (0, 3)}
    with pytest.raises(DatasetError, match=r"frames = \[0, 6\] is outside the 5 frames of the shorter traverse"):
        load_dataset("street", csv_dataset(tmp_path / "b", frames=[0, 6]))


def test_fingerprint_unchanged_without_positions_and_covers_positions(tmp_path):
    names = plain_names(3)
    write_folder(tmp_path / "a", names)
    write_folder(tmp_path / "b", names)
    pair = load_dataset("x", {"loader": "folders", "reference": str(tmp_path / "a"), "query": str(tmp_path / "b")})
    by_hand = hashlib.sha256("".join(f"{t}/{n}\n" for t in ("a", "b") for n in names).encode()).hexdigest()
    assert pair.fingerprint() == by_hand
    conf = csv_dataset(tmp_path / "p")
    before = load_dataset("street", conf).fingerprint()
    Path(conf["query_positions"]).write_text(Path(conf["query_positions"]).read_text().replace(",500002.0,", ",1.0,"))
    assert load_dataset("street", conf).fingerprint() != before  # a moved position: other descriptor files


def test_median_spacing():
    assert median_spacing(np.array(REFERENCE_XY)) == 10.0
    assert median_spacing(np.array([[0, 0], [3, 4], [3, 4], [np.nan, 0], [9, 12]])) == 2.5  # NaN steps left out
    assert math.isnan(median_spacing(np.zeros((1, 2))))


# --- dataset check ---


def test_dataset_check_reports_positions(tmp_path, capsys):
    conf = csv_dataset(tmp_path, splits={"train": {"reference": [0, 4], "query": [0, 2]}, "test": [2, 5]})
    Path(conf["query_positions"]).write_text("name,x,y\n0000.png,500002,4178909.5\n0001.png,500017,4178909.5\n"
                                             "0002.png,500032,4178909.5\n0003.png,500047,4178909.5\n")
    assert check_module.main(conf, name="street") == 1
    out = capsys.readouterr().out
    assert "dataset 'street': 8 reference and 5 query frames with positions, a match correct within 5 " in out
    assert "    positions: 8 of 8 frames, median spacing 10 (units of the CSVs' x, y) between consecutive frames" in out
    assert "    positions: 4 of 5 frames, median spacing 15 (units of the CSVs' x, y) between consecutive frames; " \
           "1 without a position: 0004.png" in out
    assert "  split train: references [0, 4) 4 frames (4 usable), queries [0, 2) 2 frames (2 usable)" in out
    assert "  split test: references [2, 5) 3 frames (3 usable), queries [2, 5) 3 frames (2 usable)" in out
    assert "status: PROBLEMS (0 missing files, 0 unreadable files, 1 frames without a position)" in out
    # the command line: the positions options and a split's two ranges
    from vpr_smr.pipeline.cli import main as cli

    status = cli(["dataset", "check", "folders", "--reference", conf["reference"], "--query", conf["query"],
                  "--positions", "file_names", "--radius", "25", "--splits", "train=0:4/0:2"])
    out = capsys.readouterr().out  # names outside the @UTM@ convention: frames without a position
    assert status == 1 and "positions: 0 of 5 frames, median spacing n/a" in out and "warning" not in out
    utm = utm_dataset(tmp_path)
    status = cli(["dataset", "check", "folders", "--reference", utm["reference"], "--query", utm["query"],
                  "--positions", "file_names", "--radius", "25", "--splits", "train=0:4/0:2"])
    out = capsys.readouterr().out
    assert status == 0 and "a match correct within 25 m" in out and "median spacing 15 m" in out
    assert "split train: references [0, 4) 4 frames (4 usable), queries [0, 2) 2 frames (2 usable)" in out


# --- the descriptor and distance files ---


def descriptor_file(path: Path, reference: np.ndarray, query: np.ndarray, positions: bool = True) -> Path:
    provenance = {"dataset": "street", "method": "m", "checkpoint_sha256": "", "frames_sha256": "f" * 64}
    with atomic_h5(path, provenance) as f:
        f.attrs["distance"] = "l2"
        f.create_dataset("reference", data=reference)
        f.create_dataset("query", data=query)
        if positions:
            f.create_dataset("reference_positions", data=np.arange(2 * len(reference), dtype=float).reshape(-1, 2))
            f.create_dataset("query_positions", data=-np.arange(2 * len(query), dtype=float).reshape(-1, 2))
    return path


def test_distances_with_separate_ranges(tmp_path):
    rng = np.random.default_rng(0)
    reference, query = rng.normal(size=(30, 16)).astype(np.float32), rng.normal(size=(20, 16)).astype(np.float32)
    source = descriptor_file(tmp_path / "d.h5", reference, query)
    out = distances.main(DistancesJob(str(source), "test", (5, 12), (3, 25), out=str(tmp_path / "test.h5")),
                         block_queries=64)
    with h5py.File(out) as f:
        matrix = f["distance_matrix"][()]
        np.testing.assert_array_equal(f["reference_positions"][()], np.arange(60.0).reshape(-1, 2)[3:25])
        np.testing.assert_array_equal(f["query_positions"][()], -np.arange(40.0).reshape(-1, 2)[5:12])
    assert matrix.shape == (22, 7)
    np.testing.assert_allclose(matrix, distance_matrix(reference[3:25], query[5:12]), atol=1e-6)
    provenance = read_provenance(out)
    assert provenance["split_range"] == [5, 12] and provenance["reference_range"] == [3, 25]
    assert frame_range(out) == FrameRange("street", "test", 5, 12, (3, 25))
    # the short form: one range, no reference_range attribute (as every file before the features of method §11)
    out = distances.main(DistancesJob(str(source), "test", (5, 12), out=str(tmp_path / "short.h5")))
    assert "reference_range" not in read_provenance(out) and frame_range(out) == FrameRange("street", "test", 5, 12)
    with pytest.raises(ValueError, match=r"split 'test' covers frames 3..30, but 'reference' has 30 frames"):
        distances.main(DistancesJob(str(source), "test", (5, 12), (3, 31), out=str(tmp_path / "bad.h5")))
    # a frame-aligned descriptor file: a matrix and nothing else
    plain = descriptor_file(tmp_path / "plain.h5", reference[:20], query, positions=False)
    with h5py.File(distances.main(DistancesJob(str(plain), "test", (0, 20), out=str(tmp_path / "p.h5")))) as f:
        assert set(f) == {"distance_matrix"}
    # and without positions the ranges may not differ: frame indices would be scored against other references
    with pytest.raises(ValueError, match=r"plain.h5 has no positions, so split 'test' must cover the same frames"):
        distances.main(DistancesJob(str(plain), "test", (5, 12), (3, 20), out=str(tmp_path / "q.h5")))
    assert not (tmp_path / "q.h5").exists()


def test_distances_cli_takes_the_reference_frames(tmp_path):
    from vpr_smr.pipeline.cli import main as cli

    rng = np.random.default_rng(1)
    source = descriptor_file(tmp_path / "d.h5", rng.normal(size=(12, 8)).astype(np.float32),
                             rng.normal(size=(9, 8)).astype(np.float32))
    cli(["distances", "--descriptors", str(source), "--split", "val", "--frames", "2", "6", "--reference-frames",
         "0", "12", "--out", str(tmp_path / "val.h5")])
    with h5py.File(tmp_path / "val.h5") as f:
        assert f["distance_matrix"].shape == (12, 4) and f["query_positions"].shape == (4, 2)


def test_descriptors_of_a_pair_with_positions(tmp_path):
    from vpr_smr.descriptors import extract

    pair = load_dataset("street", csv_dataset(tmp_path))
    out = extract.main(pair, "sad", {"backend": "sad"}, tmp_path / "sad.h5", batch_size=4, num_workers=0)
    with h5py.File(out) as f:
        assert f["reference"].shape[0] == 8 and f["query"].shape[0] == 5
        np.testing.assert_array_equal(f["reference_positions"][()], REFERENCE_XY)
        np.testing.assert_array_equal(f["query_positions"][()], QUERY_XY)
        assert f.attrs["frames_sha256"] == pair.fingerprint()


# --- the plan and the split checks ---


def test_split_overlaps_with_separate_ranges():
    splits = {"train": (0, 40), "test": (40, 80)}
    assert split_overlaps(splits) == []
    assert split_overlaps(splits, {"train": (0, 50), "test": (45, 90)}) == [
        "'train' reference range [0, 50) and 'test' reference range [45, 90) share reference frames [45, 50)"]
    assert split_overlaps({"train": (0, 40), "test": (30, 80)}, {"test": (60, 90)}) == [
        "'train' query range [0, 40) and 'test' query range [30, 80) share query frames [30, 40)"]


def test_leakage_checks_references_and_queries():
    train = FrameRange("d", "train", 0, 40, (0, 50))
    test = FrameRange("d", "test", 40, 80, (45, 90))
    assert FrameRange.from_json(train.to_json()) == train
    assert FrameRange("d", "t", 0, 4).to_json() == {"dataset": "d", "split": "t", "lo": 0, "hi": 4}  # no references
    with pytest.raises(SplitLeakError, match=r"trained on 'd' split 'train' \(queries \[0, 40\), references "
                                             r"\[0, 50\)\), which shares reference frames \[45, 50\) with 'd' split "
                                             r"'test' \(queries \[40, 80\), references \[45, 90\)\)"):
        check_disjoint([train], [test], False, "the predictor")
    assert check_disjoint([train], [FrameRange("d", "test", 40, 80, (50, 90))], False, "p") == []


def test_plan_of_a_dataset_with_positions(tmp_path):
    from vpr_smr.pipeline import plan as plan_module

    splits = {"train": {"reference": [0, 4], "query": [0, 2]}, "val": {"reference": [4, 5], "query": [2, 4]},
              "test": {"reference": [5, 8], "query": [4, 5]}}
    conf = plan_config(tmp_path, splits)
    datasets = plan_module._check_datasets(conf, problems := [])
    # each range of a split needs L frames (and the train split enough to train: too short here, as ever)
    assert "datasets.street: split 'val' reference range has 1 frames, fewer than the sequence length 2 " \
           "(seq_lens): lengthen the split or shorten the sequences" in problems
    assert "datasets.street: split 'test' has 1 frames, fewer than the sequence length 2 (seq_lens): lengthen " \
           "the split or shorten the sequences" in problems
    assert len(problems) == 3 and "lengthen split 'train'" in problems[2]
    d = datasets["street"]
    assert d.radius == 5.0 and d.splits["test"] == (4, 5) and d.reference_splits["test"] == (5, 8)
    assert d.reference_range("test") == (5, 8)
    street = conf.datasets["street"].to_json()
    assert d.positions_files == (street["query_positions"], street["reference_positions"])
    assert "radius" not in d.frames_settings  # a split setting: a new radius reruns no descriptors
    plan = plan_module.Plan(datasets, {"sad": None}, (), {"sad": "mad"})
    assert plan_from_json(json.loads(json.dumps(plan_to_json(plan, conf))), conf) == plan  # as saved
    card = dataset_cards(plan)["street"]
    assert card["radius"] == 5.0 and card["reference_splits"]["train"] == [0, 4]


def test_overlapping_reference_ranges_are_refused(tmp_path):
    splits = {"train": {"reference": [0, 5], "query": [0, 2]}, "val": {"reference": [4, 6], "query": [2, 3]},
              "test": {"reference": [6, 8], "query": [3, 5]}}
    from vpr_smr.pipeline import plan as plan_module

    plan_module._check_datasets(plan_config(tmp_path, splits), problems := [])
    assert any("splits 'train' reference range [0, 5) and 'val' reference range [4, 6) share reference frames "
               "[4, 5)" in p for p in problems), problems
