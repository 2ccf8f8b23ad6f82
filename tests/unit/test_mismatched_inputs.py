"""Inputs that cannot be what they claim are refused or warned about: a non-square matrix without positions, a
similarity matrix given as distances, a file that is not what its suffix says, a predictor of another matcher."""

import logging
import pickle
import warnings

import h5py
import numpy as np
import pytest
from helpers import seqslam
from sample_matrix import sample_distances

from vpr_smr.core.io import read_provenance
from vpr_smr.eval.matching.attributes import Matching, query_features, write_features
from vpr_smr.eval.matching.live import LiveMatcher
from vpr_smr.eval.predictor.estimator import SMRPredictor
from vpr_smr.pipeline.cli import main


def failure(capsys, argv):
    assert main(argv) != 0
    err = capsys.readouterr().err
    assert "Traceback" not in err and "allow_pickle" not in err and "weights_only" not in err
    return err


# --- a matrix whose shape cannot be frame-aligned ---------------------------------------------------------------


@pytest.mark.parametrize("command", ["attributes", "metrics", "queries"])
def test_a_non_square_matrix_without_positions_is_refused(tmp_path, capsys, command):
    np.save(tmp_path / "D.npy", np.random.default_rng(0).random((357, 238)))  # a query driven at 1.5x
    out = tmp_path / {"attributes": "a.h5", "metrics": "m.json", "queries": "q.csv"}[command]
    err = failure(capsys, [command, "--distances", str(tmp_path / "D.npy"), "--seq-len", "4", "--out", str(out)])
    assert "D.npy is a 357 x 238 matrix (references x queries) without positions" in err
    assert "--reference-positions and --query-positions" in err and "--radius" in err
    assert not out.exists()


def test_positions_of_another_length_are_refused(tmp_path, capsys):
    np.save(tmp_path / "D.npy", np.random.default_rng(0).random((30, 20)))
    np.save(tmp_path / "ref.npy", np.arange(30.0))
    np.save(tmp_path / "qry.npy", np.arange(25.0))
    err = failure(capsys, ["metrics", "--distances", str(tmp_path / "D.npy"), "--seq-len", "4", "--reference-positions",
                           str(tmp_path / "ref.npy"), "--query-positions", str(tmp_path / "qry.npy"), "--radius", "2",
                           "--out", str(tmp_path / "m.json")])
    assert "distance matrix of shape 30x20 but 30 reference and 25 query positions" in err


# --- similarities given as distances: real frames of the shipped sample, a range no other test reads -------------


@pytest.fixture(scope="module")
def sample_matrices(tmp_path_factory):
    """SAD distances (``sample_matrix.sample_distances``) of summer (references) and winter (queries) frames
    3301-3420 of the sample, and their similarities max(D) - D."""
    folder = tmp_path_factory.mktemp("sample")
    distances = sample_distances(3301, 120)
    np.save(folder / "D.npy", distances)
    np.save(folder / "S.npy", distances.max() - distances)
    return folder, distances


def test_a_similarity_matrix_given_as_distances_gets_a_warning(sample_matrices, tmp_path, caplog):
    folder, distances = sample_matrices
    # single-frame recall@1 within 2 frames, by hand: the distances' and, read the wrong way, the similarities'
    truth = np.abs(np.arange(120)[:, None] - np.arange(120)[None, :]) <= 2
    recall_distances = truth[np.argmin(distances, axis=0), np.arange(120)].mean()
    recall_similarities = truth[np.argmax(distances, axis=0), np.arange(120)].mean()
    assert recall_distances == 21 / 120 and recall_similarities == 3 / 120  # hard winter frames; still 7x apart
    with caplog.at_level(logging.WARNING, logger="vpr_smr"):
        assert main(["metrics", "--distances", str(folder / "S.npy"), "--seq-len", "4", "--modes", "standard",
                     "--out", str(tmp_path / "s.json")]) == 0
    warned = [r.message for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warned) == 1 and f"{folder / 'S.npy'} looks like a similarity matrix" in warned[0]
    assert "give --similarity" in warned[0]
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="vpr_smr"):
        assert main(["metrics", "--distances", str(folder / "D.npy"), "--seq-len", "4", "--modes", "standard",
                     "--out", str(tmp_path / "d.json")]) == 0
        assert main(["metrics", "--distances", str(folder / "S.npy"), "--similarity", "--seq-len", "4", "--modes",
                     "standard", "--out", str(tmp_path / "sd.json")]) == 0
    assert not [r for r in caplog.records if r.levelno == logging.WARNING]
    import json

    plain = json.loads((tmp_path / "d.json").read_text())
    converted = json.loads((tmp_path / "sd.json").read_text())
    assert converted["meta"]["distances_from"] == "similarity: max(M) - M"
    single = converted["splits"]["all"]["modes"]["standard"]["single"]
    # standard mode: over the 117 queries with a sequence match (3 .. 119)
    assert single["recall_at"]["1"] == pytest.approx(truth[np.argmin(distances, axis=0), np.arange(120)][3:].mean())
    assert single == plain["splits"]["all"]["modes"]["standard"]["single"]
    wrong = json.loads((tmp_path / "s.json").read_text())["splits"]["all"]["modes"]["standard"]["single"]
    assert wrong["recall_at"]["1"] == pytest.approx(truth[np.argmin(distances.max() - distances, axis=0),
                                                           np.arange(120)][3:].mean())


def test_attributes_of_similarities_record_the_conversion(sample_matrices, tmp_path, caplog):
    folder, distances = sample_matrices
    with caplog.at_level(logging.WARNING, logger="vpr_smr"):
        assert main(["attributes", "--distances", str(folder / "S.npy"), "--seq-len", "3", "--out",
                     str(tmp_path / "a.csv")]) == 0
    assert any("looks like a similarity matrix" in r.message for r in caplog.records)
    assert main(["attributes", "--distances", str(folder / "S.npy"), "--similarity", "--seq-len", "3", "--out",
                 str(tmp_path / "s.h5")]) == 0
    # S = m - D with m = max(D), so max(S) - S = D - min(D): the distances shifted to start at 0
    np.save(tmp_path / "shifted.npy", distances - distances.min())
    assert main(["attributes", "--distances", str(tmp_path / "shifted.npy"), "--seq-len", "3", "--out",
                 str(tmp_path / "d.h5")]) == 0
    assert read_provenance(tmp_path / "s.h5")["distances_from"] == "similarity: max(M) - M"
    with h5py.File(tmp_path / "s.h5") as s, h5py.File(tmp_path / "d.h5") as d:
        assert np.array_equal(s["labels"][()], d["labels"][()])
        assert np.allclose(s["attributes"][()], d["attributes"][()], rtol=1e-9, atol=1e-12)


# --- files that are not what their suffix says ------------------------------------------------------------------


def _pickled(path):
    path.write_bytes(pickle.dumps({"a": [1, 2]}, protocol=4))


def _objects(path):
    np.save(path, np.array([[0, [1, 2]], [1, [0]]], dtype=object), allow_pickle=True)


def _truncated(path):
    np.save(path, np.ones((40, 40), dtype=np.float32))
    path.write_bytes(path.read_bytes()[:-100])


@pytest.mark.parametrize(("write", "expected"), [
    (lambda p: p.write_text("0,1,2\n1,0,1\n"), "D.npy is text (it starts with '0,1,2'), not a references x queries "
                                              "matrix (a NumPy .npy array): save the numbers with numpy.save"),
    (_pickled, "D.npy is a Python pickle, not a references x queries matrix (a NumPy .npy array), which vpr-smr "
               "never loads (unpickling can run code)"),
    (_objects, "D.npy holds an array of Python objects (dtype object, stored as a pickle), which vpr-smr never "
               "loads"),
    (_truncated, "D.npy is truncated: its header says shape (40, 40) of float32, 6400 bytes of data, but it holds "
                 "6300"),
    (lambda p: p.write_bytes(b""), "D.npy is empty (0 bytes), not a references x queries matrix"),
    (lambda p: h5py.File(p, "w").close(), "D.npy is an HDF5 file, not a references x queries matrix"),
])
def test_a_file_that_is_not_a_npy_array_is_named_for_what_it_is(tmp_path, capsys, write, expected):
    write(tmp_path / "D.npy")
    err = failure(capsys, ["metrics", "--distances", str(tmp_path / "D.npy"), "--seq-len", "2", "--out",
                           str(tmp_path / "m.json")])
    assert expected in err


def test_positions_in_an_object_array_are_refused_without_unpickling(tmp_path, capsys):
    np.save(tmp_path / "D.npy", np.ones((6, 6)))
    _objects(tmp_path / "ref.npy")
    np.save(tmp_path / "qry.npy", np.arange(6.0))
    err = failure(capsys, ["attributes", "--distances", str(tmp_path / "D.npy"), "--seq-len", "2",
                           "--reference-positions", str(tmp_path / "ref.npy"), "--query-positions",
                           str(tmp_path / "qry.npy"), "--radius", "1", "--out", str(tmp_path / "a.csv")])
    assert "ref.npy holds an array of Python objects" in err and "one position per frame" in err


# --- a predictor applied with another matcher ------------------------------------------------------------------


@pytest.fixture
def velocity_predictor(tmp_path):
    """A predictor trained by `vpr-smr train` on attributes of velocity search over 0.8, 1, 1.25."""
    rng = np.random.default_rng(5)
    for split in ("train", "test"):
        matrix = rng.random((60, 60)) + 0.7 * (1 - np.eye(60))
        assert main(["attributes", "--distances", str(_saved(tmp_path / f"{split}.npy", matrix)), "--seq-len", "3",
                     "--velocities", "0.8", "1", "1.25", "--out", str(tmp_path / f"{split}.h5")]) == 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["train", "--dataset", "d", "--seq-len", "3", "--predictor", '{"max_iter": 20}', "--train",
                     str(tmp_path / "train.h5"), "--out", str(tmp_path / "p.h5")]) == 0
    return tmp_path


def _saved(path, matrix):
    np.save(path, matrix)
    return path


def test_the_predictor_file_records_its_matcher(velocity_predictor):
    predictor = SMRPredictor.load(velocity_predictor / "p.h5")
    assert predictor.matching_ == Matching(seqslam(0.8, 1.0, 1.25), "frames")
    # the one record of the matcher every file holds
    expected = {"name": "seqslam", "settings": {"velocities": [0.8, 1.0, 1.25]}}
    assert read_provenance(velocity_predictor / "p.h5")["matcher"] == read_provenance(
        velocity_predictor / "train.h5")["matcher"] == expected


def test_metrics_refuse_a_predictor_of_another_matcher(velocity_predictor, capsys):
    tmp = velocity_predictor
    err = failure(capsys, ["metrics", "--distances", str(tmp / "test.npy"), "--seq-len", "3", "--predictor",
                           str(tmp / "p.h5"), "--out", str(tmp / "m.json")])
    assert (f"{tmp / 'p.h5'} was trained on attributes of the matcher seqslam (velocities [0.8, 1.0, 1.25]), ground "
            "truth from frame indices within a tolerance, but it is applied to these matrices (--matcher, --radius), "
            "of the matcher seqslam (velocities [1.0]), ground truth from frame indices within a tolerance") in err
    # the same velocities in another order are the same matcher
    assert main(["metrics", "--distances", str(tmp / "test.npy"), "--seq-len", "3", "--velocities", "1.25", "0.8",
                 "1", "--predictor", str(tmp / "p.h5"), "--out", str(tmp / "m.json")]) == 0


def test_evaluate_refuses_attributes_of_another_matcher(velocity_predictor, capsys):
    tmp = velocity_predictor
    assert main(["attributes", "--distances", str(tmp / "test.npy"), "--seq-len", "3", "--out",
                 str(tmp / "fixed.h5")]) == 0
    err = failure(capsys, ["evaluate", "--dataset", "d", "--method", "m", "--seq-len", "3", "--attributes",
                           f"test={tmp / 'fixed.h5'}", "--predictors", str(tmp / "p.h5"), "--out",
                           str(tmp / "e.json")])
    assert "was trained on attributes of the matcher seqslam (velocities [0.8, 1.0, 1.25])" in err
    assert f"but it is applied to the attributes {tmp / 'fixed.h5'}, of the matcher seqslam (velocities [1.0])" in err


def test_training_refuses_attributes_of_two_matchers(velocity_predictor, capsys):
    tmp = velocity_predictor
    assert main(["attributes", "--distances", str(tmp / "test.npy"), "--seq-len", "3", "--out",
                 str(tmp / "fixed.h5")]) == 0
    err = failure(capsys, ["train", "--dataset", "d", "--seq-len", "3", "--train", str(tmp / "train.h5"),
                           str(tmp / "fixed.h5"), "--out", str(tmp / "q.h5")])
    assert f"{tmp / 'train.h5'} holds attributes of the matcher seqslam (velocities [0.8, 1.0, 1.25])" in err
    assert f"but {tmp / 'fixed.h5'} of the matcher seqslam (velocities [1.0])" in err


def test_the_live_matcher_refuses_a_predictor_of_other_velocities(velocity_predictor):
    predictor = SMRPredictor.load(velocity_predictor / "p.h5")
    with pytest.raises(ValueError, match=r"trained on attributes of the matcher seqslam \(velocities \[0.8, 1.0, "
                                         r"1.25\]\), but it is applied to a LiveMatcher \(matcher=\), of the "
                                         r"matcher seqslam \(velocities \[1.0\]\): give it the matcher the predictor "
                                         r"was trained with"):
        LiveMatcher(3, predictor=predictor)
    LiveMatcher(3, predictor=predictor, matcher=seqslam(1.25, 0.8, 1.0))  # its own matcher (in any order): accepted


def test_a_predictor_file_without_the_record_is_refused(tmp_path, capsys):
    features = query_features(np.random.default_rng(1).random((30, 30)) + 0.5 * (1 - np.eye(30)), 3)
    write_features(tmp_path / "test.h5", features, {})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        SMRPredictor(hidden_layer_sizes=(4,), max_iter=10).fit(
            np.random.default_rng(0).normal(size=(40, 4)), np.repeat(np.arange(4), 10)).save(tmp_path / "old.h5")
    err = failure(capsys, ["evaluate", "--dataset", "d", "--method", "m", "--seq-len", "3", "--attributes",
                           f"test={tmp_path / 'test.h5'}", "--predictors", str(tmp_path / "old.h5"), "--out",
                           str(tmp_path / "e.json")])
    assert "old.h5 does not record the sequence matcher and ground truth it was trained with" in err
    assert "train it again (vpr-smr train)" in err


def test_the_inspector_refuses_a_queries_csv_of_another_matcher(tmp_path, capsys):
    # the query runs at twice the reference's speed: D is smallest at reference 2q, which velocity 2 follows and the
    # fixed matcher (a diagonal of slope 1) does not
    r, q = np.mgrid[0:40, 0:40]
    np.save(tmp_path / "D.npy", np.abs(r - 2 * q) / 40 + 0.05)
    assert main(["queries", "--distances", str(tmp_path / "D.npy"), "--seq-len", "3", "--velocities", "1", "2",
                 "--out", str(tmp_path / "q.csv")]) == 0
    figure = tmp_path / "d.png"
    base = ["inspect", "--queries", str(tmp_path / "q.csv"), "--distances", str(tmp_path / "D.npy"), "--seq-len", "3",
            "--matrix-figure", str(figure)]
    err = failure(capsys, base)
    assert ("q.csv holds the sequence matches of the matcher seqslam (velocities [1.0, 2.0]), but this stage was "
            "given the matcher seqslam (velocities [1.0])") in err and not figure.exists()
    assert main([*base, "--velocities", "1", "2"]) == 0 and figure.is_file()


def test_a_truncated_hdf5_distance_file_is_named(tmp_path, capsys):
    with h5py.File(tmp_path / "test.h5", "w") as f:
        f["distance_matrix"] = np.random.default_rng(0).random((50, 50))
    (tmp_path / "test.h5").write_bytes((tmp_path / "test.h5").read_bytes()[:5000])  # of 22 KB
    err = failure(capsys, ["metrics", "--distances", str(tmp_path / "test.h5"), "--seq-len", "3", "--out",
                           str(tmp_path / "m.json")])
    assert "test.h5 is a damaged or truncated HDF5 file (" in err
    assert "expected a distance file written by vpr-smr" in err


def test_queries_and_held_out_refuse_a_predictor_of_another_matcher(velocity_predictor, capsys):
    tmp = velocity_predictor
    err = failure(capsys, ["queries", "--distances", str(tmp / "test.npy"), "--seq-len", "3", "--predictor",
                           str(tmp / "p.h5"), "--out", str(tmp / "q.csv")])
    assert ("was trained on attributes of the matcher seqslam (velocities [0.8, 1.0, 1.25])" in err
            and not (tmp / "q.csv").exists())
    assert main(["attributes", "--distances", str(tmp / "test.npy"), "--seq-len", "3", "--out",
                 str(tmp / "fixed.h5")]) == 0
    err = failure(capsys, ["ablation", "held-out", "--dataset", "d", "--method", "m", "--seq-len", "3", "--attributes",
                           str(tmp / "fixed.h5"), "--pooled", str(tmp / "p.h5"), "--without", str(tmp / "p.h5"),
                           "--allow-split-overlap", "--out", str(tmp / "h.json")])
    assert f"but it is applied to {tmp / 'fixed.h5'}, of the matcher seqslam (velocities [1.0])" in err


def test_a_npy_array_under_another_name_is_told_to_be_renamed(tmp_path, capsys):
    np.save(tmp_path / "D.npy", np.ones((6, 6)))
    (tmp_path / "D.npy").rename(tmp_path / "D.dat")
    err = failure(capsys, ["attributes", "--distances", str(tmp_path / "D.dat"), "--seq-len", "2", "--out",
                           str(tmp_path / "a.csv")])
    assert "D.dat is a NumPy .npy array, but its name does not end in .npy: rename it" in err
    (tmp_path / "D.dat").rename(tmp_path / "D.NPY")  # the suffix in capitals is a .npy
    assert main(["attributes", "--distances", str(tmp_path / "D.NPY"), "--seq-len", "2", "--out",
                 str(tmp_path / "a.csv")]) == 0


def test_the_inspector_reads_similarities_and_positions_as_queries_did(sample_matrices, tmp_path):
    folder, distances = sample_matrices
    # the similarities of the 120 references and of every 3rd query (a query driven at 3x), positions in frames
    queries = np.arange(0, 120, 3)
    np.save(tmp_path / "S.npy", (distances.max() - distances)[:, queries])
    np.save(tmp_path / "ref.npy", np.arange(120.0))
    np.save(tmp_path / "qry.npy", queries.astype(float))
    options = ["--reference-positions", str(tmp_path / "ref.npy"), "--query-positions", str(tmp_path / "qry.npy"),
               "--radius", "2", "--velocities", "2", "3", "4", "--similarity"]
    assert main(["queries", "--distances", str(tmp_path / "S.npy"), "--seq-len", "3", *options, "--out",
                 str(tmp_path / "q.csv")]) == 0
    figure = tmp_path / "d.png"
    assert main(["inspect", "--queries", str(tmp_path / "q.csv"), "--distances", str(tmp_path / "S.npy"),
                 "--seq-len", "3", *options, "--matrix-figure", str(figure)]) == 0
    assert figure.read_bytes().startswith(b"\x89PNG")


def test_a_cluster_profile_refuses_an_interpreter_whose_path_holds_a_space():
    from vpr_smr.pipeline.workflow import check_cluster_interpreter, profile_path

    with pytest.raises(ValueError, match=r"submits jobs to slurm, but the Python of this environment is "
                                         r"'/tmp/fresh clone/.venv/bin/python', whose path holds a space"):
        check_cluster_interpreter(profile_path("slurm"), "/tmp/fresh clone/.venv/bin/python")
    check_cluster_interpreter(profile_path("slurm"), "/tmp/clone/.venv/bin/python")  # no space: fine
    check_cluster_interpreter(profile_path("local"), "/tmp/fresh clone/.venv/bin/python")  # local jobs: fine


def test_train_checks_its_predictor_settings_before_reading_a_file(tmp_path, capsys):
    # the training file does not exist: the misspelt setting is what is said, with the setting it means
    err = failure(capsys, ["train", "--dataset", "d", "--seq-len", "3", "--predictor", '{"max_iters": 20}',
                           "--train", str(tmp_path / "missing.h5"), "--out", str(tmp_path / "p.h5")])
    assert "--predictor.max_iters: unexpected setting 'max_iters' (did you mean 'max_iter'?)" in err
    err = failure(capsys, ["train", "--dataset", "d", "--seq-len", "3", "--predictor", '{"alpha": -1}',
                           "--train", str(tmp_path / "missing.h5"), "--out", str(tmp_path / "p.h5")])
    assert "--predictor.alpha: the MLP's L2 penalty" in err and "must be >= 0, got -1.0" in err
    assert not (tmp_path / "p.h5").exists()
