"""Users' matrices and ground truths as the field writes them, on a real matrix (SAD of the shipped Nordland sample):
the band |r - q| <= 2 as a boolean matrix or as per-query lists gives exactly the numbers of tolerance 2; a matrix
read from .npz, MATLAB v5 and v7.3, transposed, or as similarities gives exactly the numbers of its .npy; a dataset's
ground truth is cut to a split's frames; every output records its ground truth; and bad input is named."""

import csv
import json
import re
from dataclasses import fields

import numpy as np
import pytest
import scipy.io
from field_files import band, lists_of, write_csv_pairs, write_json_lists, write_mat73, write_vpr_bench
from helpers import write_distance_matrix
from sample_matrix import sample_distances

from vpr_smr.core.io import read_provenance
from vpr_smr.datasets import load_frames
from vpr_smr.eval.matching.attributes import Matching, QueryFeatures, read_features
from vpr_smr.eval.matching.ground_truth_files import file_sha256
from vpr_smr.eval.matching.io import open_distance_matrix
from vpr_smr.eval.matching.matchers import MatcherSpec
from vpr_smr.eval.report import inspector
from vpr_smr.pipeline.cli import main as cli

N, L = 160, 3  # frames of the sample (2001 .. 2160: a range no other test reads) and the sequence length


@pytest.fixture(scope="module")
def real(tmp_path_factory):
    """The SAD matrix of frames 2001..2160 as D.npy, and the band |r - q| <= 2 in every ground-truth format."""
    folder = tmp_path_factory.mktemp("real")
    d = sample_distances(2001, N)
    np.save(folder / "D.npy", d)
    truth = band(N, N, 2)
    np.save(folder / "band.npy", truth)
    lists = lists_of(truth)
    write_json_lists(folder / "band.json", lists)
    write_csv_pairs(folder / "band.csv", lists)
    write_vpr_bench(folder / "ground_truth_new.npy", lists)
    scipy.io.savemat(folder / "band.mat", {"GThard": truth})
    return folder, d


def run(folder, name, *options, predictor=None, attributes=True):
    """Metrics (both modes, the queries CSV) and attributes of ``options``, written under ``name``: their JSON, the
    CSV's text and the attributes file's arrays."""
    extra = ["--predictor", str(predictor)] if predictor is not None else []
    metrics, queries = folder / f"{name}.json", folder / f"{name}.csv"
    assert cli(["metrics", *options, "--seq-len", str(L), *extra, "--queries", str(queries), "--out",
                str(metrics)]) == 0
    out = {"metrics": json.loads(metrics.read_text()), "queries": queries.read_text()}
    if attributes:
        h5 = folder / f"{name}.h5"
        assert cli(["attributes", *options, "--seq-len", str(L), "--out", str(h5)]) == 0
        out["features"], out["provenance"] = read_features(h5), read_provenance(h5)
    return out


def assert_same_numbers(mine, theirs):
    assert mine["metrics"]["splits"] == theirs["metrics"]["splits"]
    assert mine["queries"] == theirs["queries"]
    if "features" in mine:
        for field in fields(QueryFeatures):
            if field.name == "matrix":  # the identity of the file's own values (a similarity's differ)
                continue
            np.testing.assert_array_equal(getattr(mine["features"], field.name),
                                          getattr(theirs["features"], field.name), err_msg=field.name)


FORMS = {"band.npy": "npy matrix", "band.json": "json lists", "band.csv": "csv pairs",
         "ground_truth_new.npy": "vpr-bench lists", "band.mat": "mat v5 matrix"}


@pytest.mark.parametrize("name", FORMS)
def test_the_band_as_a_ground_truth_file_gives_the_numbers_of_tolerance_2(real, tmp_path, predictor_file, name):
    folder, _ = real
    tolerance = run(tmp_path, "tolerance", "--distances", str(folder / "D.npy"), "--tolerance", "2",
                    predictor=predictor_file)
    given = run(tmp_path, "file", "--distances", str(folder / "D.npy"), "--ground-truth", str(folder / name),
                predictor=predictor_file)
    assert_same_numbers(given, tolerance)
    # both modes and the predictor's matcher were compared; the numbers are not trivial
    modes = given["metrics"]["splits"]["all"]["modes"]
    assert set(modes) == {"paper", "standard"} and set(modes["paper"]) == {"single", "sequence", "sequence_predictor"}
    assert 0 < modes["standard"]["single"]["recall_at"]["1"] < modes["standard"]["sequence"]["recall_at"]["1"] < 1
    recorded = {"kind": "matrix", "file": name, "sha256": file_sha256(folder / name), "form": FORMS[name]}
    assert given["metrics"]["meta"]["ground_truth"] == recorded
    assert given["provenance"]["ground_truth"] == recorded
    assert given["provenance"]["queries_without_correct"] == 0 and given["provenance"]["evaluated_without_correct"] == 0
    assert tolerance["provenance"]["ground_truth"] == {"kind": "frames", "tolerance": 2}
    assert Matching.stored(tmp_path / "file.h5").ground_truth == "matrix"


def test_a_matrix_in_every_file_format_gives_the_numbers_of_its_npy(real, tmp_path):
    folder, d = real
    np.savez(tmp_path / "one.npz", d)
    np.savez(tmp_path / "two.npz", D=d, positions=np.arange(N * 2.0).reshape(N, 2))
    scipy.io.savemat(tmp_path / "D5.mat", {"D": d, "name": "sad"})
    write_mat73(tmp_path / "D73.mat", {"D": d, "other": np.ones((2, 2))})
    np.save(tmp_path / "DT.npy", d.T)  # queries x references
    write_mat73(tmp_path / "DT73.mat", {"DT": d.T})
    expected = run(tmp_path, "npy", "--distances", str(folder / "D.npy"))
    for name, options in (("one.npz", ()), ("two.npz", ("--key", "D")), ("D5.mat", ()),
                          ("D73.mat", ("--key", "D")), ("DT.npy", ("--transpose",)), ("DT73.mat", ("--transpose",))):
        given = run(tmp_path, name, "--distances", str(tmp_path / name), *options)
        assert_same_numbers(given, expected)
    # the outputs record how the matrix was read
    assert given["metrics"]["meta"]["distances_transposed"] is True
    assert run(tmp_path, "key", "--distances", str(tmp_path / "two.npz"), "--key", "D")["metrics"]["meta"][
        "distances_key"] == "D"
    # a MATLAB v7.3 matrix is read back as MATLAB shows it, lazily, by column blocks
    with open_distance_matrix(tmp_path / "D73.mat", key="D") as matrix:
        assert matrix.shape == (N, N) and not isinstance(matrix, np.ndarray)
        np.testing.assert_array_equal(matrix[:, 5:9], d[:, 5:9])
        np.testing.assert_array_equal(matrix[7, 3], d[7, 3])


def test_similarities_and_their_distances_give_the_same_numbers(real, tmp_path):
    folder, d = real
    similarity = np.exp(-d)  # larger = more similar
    np.save(tmp_path / "S.npy", similarity)
    np.save(tmp_path / "M.npy", similarity.max() - similarity)
    given = run(tmp_path, "similarity", "--distances", str(tmp_path / "S.npy"), "--similarity")
    assert_same_numbers(given, run(tmp_path, "distances", "--distances", str(tmp_path / "M.npy")))
    assert given["metrics"]["meta"]["distances_from"] == "similarity: max(M) - M"
    # and as a MATLAB variable with a ground-truth matrix beside it, as VPR_Tutorial keeps them
    write_mat73(tmp_path / "S.mat", {"S": similarity})
    write_mat73(tmp_path / "GT.mat", {"GThard": band(N, N, 2), "GTsoft": band(N, N, 8)})
    assert_same_numbers(run(tmp_path, "mat", "--distances", str(tmp_path / "S.mat"), "--similarity",
                            "--ground-truth", str(tmp_path / "GT.mat"), "--ground-truth-key", "GThard"), given)


def test_a_dataset_ground_truth_is_cut_to_each_split(real, tmp_path):
    folder, d = real
    for split, (lo, hi) in {"val": (20, 60), "test": (60, 160)}.items():
        write_distance_matrix(tmp_path / f"{split}.h5", d[lo:hi, lo:hi],
                              {"dataset": "sample", "split": split, "split_range": [lo, hi], "method": "sad"})
    distances = ["--distances", f"val={tmp_path / 'val.h5'}", f"test={tmp_path / 'test.h5'}"]
    expected = run(tmp_path, "tolerance", *distances, attributes=False)
    for name in ("band.npy", "band.json"):
        given = run(tmp_path, name, *distances, "--ground-truth", str(folder / name), attributes=False)
        assert_same_numbers(given, expected)
    # lists name the dataset's frames whatever their largest index: lists of frames 0..39 hold no pair of the
    # 40 frames 60..99, though their shape is the split's
    write_distance_matrix(tmp_path / "late.h5", d[60:100, 60:100], {"dataset": "sample", "split": "test",
                                                                      "split_range": [60, 100]})
    write_json_lists(tmp_path / "early.json", lists_of(band(40, 40, 2)))
    early = run(tmp_path, "early", "--distances", str(tmp_path / "late.h5"), "--ground-truth",
                str(tmp_path / "early.json"), attributes=False)["metrics"]["splits"]["all"]
    assert early["queries_without_correct"] == 40 and early["modes"]["paper"]["single"]["recall_at"]["20"] == 0
    # a split's references apart from its queries (method §11): frames 40..99 against queries 60..99
    write_distance_matrix(tmp_path / "apart.h5", d[40:100, 60:100], {"dataset": "sample", "split": "test",
                                                                       "split_range": [60, 100],
                                                                       "reference_range": [40, 100]})
    positions = tmp_path / "ref.npy", tmp_path / "qry.npy"
    np.save(positions[0], np.arange(40.0, 100.0))
    np.save(positions[1], np.arange(60.0, 100.0))
    expected = run(tmp_path, "positions", "--distances", str(tmp_path / "apart.h5"), "--reference-positions",
                   str(positions[0]), "--query-positions", str(positions[1]), "--radius", "2", attributes=False)
    given = run(tmp_path, "apart", "--distances", str(tmp_path / "apart.h5"), "--ground-truth",
                str(folder / "band.json"), attributes=False)
    assert given["metrics"]["splits"] == expected["metrics"]["splits"]
    # the per-query table names the same true references (the positions' nearest, the matrix's nearest correct)
    assert given["queries"] == expected["queries"]


def test_queries_without_a_correct_reference_are_counted_and_never_correct(tmp_path, colour_frames):
    rng = np.random.default_rng(4)
    d = rng.uniform(0.2, 1.0, (24, 24))
    d[np.arange(24), np.arange(24)] = 0.05  # every single-frame match is right by the band
    np.save(tmp_path / "D.npy", d)
    truth = band(24, 24, 1)
    truth[:, [5, 6, 20]] = False  # three queries (all with a sequence match) without a correct reference
    np.save(tmp_path / "G.npy", truth)
    result = run(tmp_path, "g", "--distances", str(tmp_path / "D.npy"), "--ground-truth", str(tmp_path / "G.npy"))
    split = result["metrics"]["splits"]["all"]
    assert split["queries_without_correct"] == split["evaluated_without_correct"] == 3
    # standard single recall@N: 22 evaluated queries (2 .. 23), all right but the three
    assert split["modes"]["standard"]["single"]["recall_at"] == {str(n): 19 / 22 for n in (1, 5, 10, 20)}
    assert split["modes"]["paper"]["single"]["recall_at"]["1"] == 21 / 24
    assert result["provenance"]["queries_without_correct"] == 3
    # vpr-smr queries writes the table metrics --queries wrote
    assert cli(["queries", "--distances", str(tmp_path / "D.npy"), "--seq-len", str(L), "--ground-truth",
                str(tmp_path / "G.npy"), "--out", str(tmp_path / "alone.csv")]) == 0
    assert (tmp_path / "alone.csv").read_text() == result["queries"]
    rows = list(csv.DictReader(result["queries"].splitlines()))
    assert [r["query"] for r in rows if r["true_reference"] == ""] == ["5", "6", "20"]
    assert all(r["true_reference"] == r["query"] for r in rows if r["query"] not in ("5", "6", "20"))
    # the inspector reads the empty cell as "no correct reference" and outlines the matrix's correct cells
    queries = tmp_path / "g.csv"
    rows = [r for r in inspector.read_queries(queries) if r.query in (5, 7)]
    assert [r.true_reference for r in rows] == [None, 7]
    samples = [inspector.Sampled(row, "chosen") for row in rows]
    record = inspector.draw_matches(tmp_path / "m.png", load_frames("toy", colour_frames), samples,
                                    inspector.SplitMatrix(d, 0), MatcherSpec.of().build(L), "t")
    assert [frames[-1] for frames in record.frames] == [None, 7]
    assert cli(["inspect", "--queries", str(queries), "--distances", str(tmp_path / "D.npy"), "--seq-len", str(L),
                "--ground-truth", str(tmp_path / "G.npy"), "--matrix-figure", str(tmp_path / "d.png")]) == 0
    assert (tmp_path / "d.png").stat().st_size > 0


def test_attributes_of_another_ground_truth_are_refused(real, tmp_path, capsys):
    folder, _ = real
    h5 = tmp_path / "a.h5"
    assert cli(["attributes", "--distances", str(folder / "D.npy"), "--seq-len", str(L), "--ground-truth",
                str(folder / "band.npy"), "--out", str(h5)]) == 0
    metrics = ["metrics", "--distances", str(folder / "D.npy"), "--seq-len", str(L), "--attributes", f"all={h5}",
               "--out", str(tmp_path / "m.json")]
    assert cli([*metrics, "--ground-truth", str(folder / "band.npy")]) == 0
    assert cli([*metrics, "--ground-truth", str(folder / "band.json")]) == 2
    err = capsys.readouterr().err
    assert (f"{h5} holds attributes labelled with the ground truth band.npy (SHA-256 "
            f"{file_sha256(folder / 'band.npy')[:12]}...), but this stage was given band.json") in err
    assert cli(metrics) == 2  # frames within the tolerance
    assert "holds attributes of the matcher seqslam (velocities [1.0]), ground truth from a matrix" in \
        capsys.readouterr().err


def test_which_predictor_applies_to_which_ground_truth():
    # a matrix says which frames are correct, not how the traverses were driven: it scores with either kind's
    # predictor; frames and positions stay apart, and the velocities must always agree
    kinds = ("frames", "positions", "matrix")
    allowed = {(a, b) for a in kinds for b in kinds if Matching.of((1.0,), a).applies_to(Matching.of((1.0,), b))}
    assert allowed == {(k, k) for k in kinds} | {("matrix", "frames"), ("frames", "matrix"),
                                                  ("matrix", "positions"), ("positions", "matrix")}
    assert not Matching.of((1.0,), "matrix").applies_to(Matching.of((0.5, 1.0), "matrix"))
    with pytest.raises(ValueError, match="unknown kind of ground truth 'lists'"):
        Matching.of((1.0,), "lists")


@pytest.mark.parametrize(("write", "options", "message"), [
    (lambda p: np.savez(p / "M.npz", a=np.ones((4, 4)), b=np.ones((4, 4))), ("--distances", "M.npz"),
     r"M.npz holds 2 2-D arrays of numbers \(a \(4 x 4 float64\), b \(4 x 4 float64\)\): choose a references x "
     "queries matrix with --key NAME"),
    (lambda p: np.savez(p / "M.npz", a=np.ones((4, 4))), ("--distances", "M.npz", "--key", "D"),
     r"M.npz has no variable 'D'; it holds a \(4 x 4 float64\): give one of them with --key"),
    (lambda p: np.savez(p / "M.npz", a=np.ones((0, 4))), ("--distances", "M.npz"),
     "M.npz: the distance matrix is 0 x 4 .references x queries.: it holds no values"),
    (lambda p: np.save(p / "M.npy", np.ones((4, 4))), ("--distances", "M.npy", "--key", "D"),
     "--key D: .*M.npy is a .npy, which holds one array; leave --key out"),
    (lambda p: write_distance_matrix(p / "M.h5", np.ones((4, 4)), {}), ("--distances", "M.h5", "--transpose"),
     "--transpose: .*M.h5 is a distance file of vpr-smr .* leave --transpose out"),
    (lambda p: scipy.io.savemat(p / "M.mat", {"D": np.where(np.eye(4) > 0, np.nan, 1.0)}), ("--distances", "M.mat"),
     "M.mat: distance matrix has 4 non-finite values .4 NaN.; the first is NaN at row 0 .reference., "
     "column 0 .query."),
    (lambda p: write_mat73(p / "M.mat", {"D": np.ones((4, 4))}) and (p / "M.mat").write_bytes(b""),
     ("--distances", "M.mat"), "M.mat is empty .0 bytes., not a MATLAB .mat file"),
    (lambda p: (p / "M.mat").write_text("1 2\n3 4\n"), ("--distances", "M.mat"),
     r"M.mat is text \(it starts with '1 2'\), not a MATLAB .mat file of version 5 or 7.3"),
    (lambda p: np.save(p / "M.zip", np.ones((4, 4))), ("--distances", "M.zip"),
     "must end in .npy, .npz, .mat, .h5 or .hdf5"),
    (lambda p: (np.save(p / "M.npy", np.ones((4, 4))), np.save(p / "G.npy", np.eye(4, 5, dtype=bool))),
     ("--distances", "M.npy", "--ground-truth", "G.npy"),
     # bounded by M.npy's header before G.npy is read
     r"G.npy: its matrix is 4 x 5 \(20 cells, as the file declares it\), more than the 4 x 4 matrix it scores: give "
     "the ground truth of the matrix's frames"),
    (lambda p: (np.save(p / "M.npy", np.ones((4, 4))), np.save(p / "G.npy", np.eye(4, dtype=bool))),
     ("--distances", "M.npy", "--ground-truth", "G.npy", "--radius", "2"),
     "--ground-truth G.npy .a matrix. and positions .* are two ground truths: give one of them"),
])
def test_bad_matrices_and_options_are_named(tmp_path, capsys, write, options, message):
    write(tmp_path)
    argv = [str(tmp_path / item) if "." in item and not item.startswith("--") else item for item in options]
    assert cli(["metrics", *argv, "--seq-len", "2", "--out", str(tmp_path / "m.json")]) == 2
    err = capsys.readouterr().err
    assert re.search(message, err), err
    assert "allow_pickle" not in err and "Traceback" not in err and not (tmp_path / "m.json").exists()
