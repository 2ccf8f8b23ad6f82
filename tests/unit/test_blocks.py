"""The distances and attributes stages as plain functions: block-wise distances to chunked HDF5, lazy matrices."""

import csv

import h5py
import numpy as np
import pytest

from vpr_smr.core.constants import EPS
from vpr_smr.core.io import read_provenance
from vpr_smr.eval.matching import attributes as features
from vpr_smr.eval.matching import distances
from vpr_smr.eval.matching.attributes import AttributesJob, query_features, read_features
from vpr_smr.eval.matching.distances import DistancesJob
from vpr_smr.eval.matching.io import open_distance_matrix
from vpr_smr.eval.matching.sources import TruthSource

PROVENANCE = {"dataset": "toy", "method": "hog", "checkpoint_sha256": "none", "frames_sha256": "abc"}


def descriptor_file(path, metric, n=150, dim=24, seed=0):
    rng = np.random.default_rng(seed)
    reference, query = rng.normal(size=(n, dim)).astype(np.float32), rng.normal(size=(n, dim)).astype(np.float32)
    with h5py.File(path, "w") as f:
        f["reference"], f["query"] = reference, query
        f.attrs["distance"] = metric
        for key, value in PROVENANCE.items():
            f.attrs[key] = value
    return reference, query


@pytest.mark.parametrize("metric", ["l2", "cosine", "mad"])
def test_distances_stage_block_by_block(tmp_path, metric):
    reference, query = descriptor_file(tmp_path / "d.h5", metric)
    out = distances.main(DistancesJob(str(tmp_path / "d.h5"), "test", (20, 130), out=str(tmp_path / "D.h5")),
                         block_queries=64)
    # naive: every pair by its definition
    r, q = reference[20:130].astype(float), query[20:130].astype(float)
    if metric != "mad":
        r, q = r / np.linalg.norm(r, axis=1, keepdims=True), q / np.linalg.norm(q, axis=1, keepdims=True)
    naive = {"l2": lambda a, b: np.sum((a - b) ** 2), "cosine": lambda a, b: 1 - a @ b,
             "mad": lambda a, b: np.mean(np.abs(a - b))}[metric]
    expected = np.array([[naive(r[i], q[j]) for j in range(110)] for i in range(110)])
    with h5py.File(out, "r") as f:
        stored = f["distance_matrix"]
        assert stored.dtype == np.float32 and stored.shape == (110, 110)
        assert stored.chunks == (110, 64)  # whole chunk columns: what the attributes stage reads
        np.testing.assert_allclose(stored[()], expected, rtol=1e-5, atol=1e-5)
    provenance = read_provenance(out)
    assert provenance["split"] == "test" and provenance["split_range"] == [20, 130]
    assert provenance["metric"] == metric and provenance["method"] == "hog" and provenance["frames_sha256"] == "abc"
    assert not list(tmp_path.glob("*.tmp"))


def test_distances_stage_errors(tmp_path):
    descriptor_file(tmp_path / "d.h5", "l2", n=30)
    with pytest.raises(ValueError, match="d.h5: split 'test' covers frames 10..39"):
        distances.main(DistancesJob(str(tmp_path / "d.h5"), "test", (10, 40), out=str(tmp_path / "D.h5")))
    with h5py.File(tmp_path / "e.h5", "w") as f:
        f["reference"] = np.zeros((3, 2))
    with pytest.raises(ValueError, match="e.h5 lacks query"):
        distances.main(DistancesJob(str(tmp_path / "e.h5"), "test", (0, 3), out=str(tmp_path / "D.h5")))
    assert not (tmp_path / "D.h5").exists()


def test_features_stage_h5_and_csv(tmp_path):
    descriptor_file(tmp_path / "d.h5", "l2", n=120)
    distances.main(DistancesJob(str(tmp_path / "d.h5"), "val", (0, 120), out=str(tmp_path / "D.h5")))
    result = features.main(AttributesJob(str(tmp_path / "D.h5"), 4, TruthSource(2), out=str(tmp_path / "f.h5")))
    with h5py.File(tmp_path / "D.h5", "r") as f:
        expected = query_features(f["distance_matrix"][()].astype(np.float64), 4, 2)
    stored = read_features(tmp_path / "f.h5")
    for got in (result, stored):
        np.testing.assert_array_equal(got.attributes, expected.attributes)
        np.testing.assert_array_equal(got.labels, expected.labels)
    provenance = read_provenance(tmp_path / "f.h5")
    assert provenance["seq_len"] == 4 and provenance["tolerance"] == 2 and provenance["attributes_seconds"] > 0
    assert provenance["split"] == "val" and provenance["method"] == "hog"


def test_features_stage_csv_by_hand(tmp_path):
    matrix = np.array([[1, 2, 4], [2, 1, 2], [4, 4, 1], [4, 2, 2]], dtype=np.float32)
    np.save(tmp_path / "D.npy", matrix)
    # 4 references, 3 queries, frame i of both one place: positions are the frame indices, the radius 2 frames
    np.save(tmp_path / "ref.npy", np.arange(4.0))
    np.save(tmp_path / "qry.npy", np.arange(3.0))
    features.main(AttributesJob(str(tmp_path / "D.npy"), 2, TruthSource(2, str(tmp_path / "ref.npy"),
                                                            str(tmp_path / "qry.npy"), radius=2),
                               out=str(tmp_path / "a.csv")))
    rows = list(csv.DictReader(open(tmp_path / "a.csv")))
    assert [r["query"] for r in rows] == ["1", "2"] and [r["label"] for r in rows] == ["0", "0"]
    # rank 0 of query 1, worked by hand in test_attributes.py
    expected = [.25 / (.25 + EPS), .25 / (.25 + EPS), .25 / (1 + EPS), .25 / (3.5 / 3 + EPS)]
    np.testing.assert_allclose([float(rows[0][k]) for k in ("A1", "A2", "A3", "A4")], expected, rtol=1e-8)


@pytest.mark.parametrize("content, message", [
    (None, "distance matrix not found"),
    (b"not a matrix", "is text, neither a NumPy .npy/.npz array, a MATLAB .mat file nor HDF5"),
    ("h5-empty", "has no 'distance_matrix' dataset"),
    (np.zeros((3, 3, 2)), "must be 2-D"),
    (np.array(["a", "b"]), "expected a numeric matrix"),
])
def test_open_distance_matrix_errors(tmp_path, content, message):
    path = tmp_path / ("D.npy" if isinstance(content, np.ndarray) else "D.h5")
    if isinstance(content, np.ndarray):
        np.save(path, content)
    elif content == "h5-empty":
        h5py.File(path, "w").close()
    elif content is not None:
        path.write_bytes(content)
    with pytest.raises((ValueError, FileNotFoundError), match=message) as error:
        with open_distance_matrix(path):
            pass
    assert "D." in str(error.value)


def test_features_stage_names_the_file(tmp_path):
    matrix = np.ones((10, 10), dtype=np.float32)
    matrix[4, 7] = np.inf
    np.save(tmp_path / "D.npy", matrix)
    with pytest.raises(ValueError, match="D.npy: distance matrix has 1 non-finite"):
        features.main(AttributesJob(str(tmp_path / "D.npy"), 3, TruthSource(2), out=str(tmp_path / "a.csv")))
    assert not (tmp_path / "a.csv").exists()
