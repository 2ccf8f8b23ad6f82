"""Bad input: a clear message naming the file or setting, a non-zero exit, no traceback, nothing half-written.

Configuration problems are caught by `vpr-smr run` before any job (a dry run is enough to show it); problems
that only show when data are read are caught by the stage that reads them.
"""

import argparse
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
import torch
import yaml
from helpers import REPO, TINY_NET, tiny_net_model

from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT
from vpr_smr.pipeline.cli import main

SAMPLE = sorted((DEFAULT_ROOT / "summer").iterdir())[:12]

def image_folders(tmp_path, n_reference=12, n_query=12):
    for name, count in (("ref", n_reference), ("qry", n_query)):
        (tmp_path / name).mkdir()
        for path in SAMPLE[:count]:
            (tmp_path / name / path.name).write_bytes(path.read_bytes())
    return tmp_path / "ref", tmp_path / "qry"


def config(tmp_path, **changes):
    conf = {
        "run": "bad", "output": str(tmp_path / "results"), "seq_lens": [3],
        "datasets": {"d": {"loader": "folders", "reference": str(tmp_path / "ref"), "query": str(tmp_path / "qry"),
                           "splits": {"train": [0, 4], "val": [4, 8], "test": [8, 12]}}},
        "methods": {"sad": {"backend": "sad"}},
    }
    for key, value in changes.items():
        node = conf
        *parents, last = key.split(".")
        for part in parents:
            node = node[part]
        node[last] = value
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump(conf))
    return path


def fails(capsys, argv, *fragments):
    assert main(argv) != 0
    err = capsys.readouterr().err
    assert "Traceback" not in err
    for fragment in fragments:
        assert fragment in err, err
    return err


def nothing_written(folder):
    assert not list(Path(folder).rglob("*.tmp")) and not list(Path(folder).rglob("*.h5"))


@pytest.fixture
def folders(tmp_path):
    return image_folders(tmp_path)


def test_missing_dataset_root(tmp_path, capsys, folders):
    path = config(tmp_path, **{"datasets.d.reference": str(tmp_path / "nowhere")})
    fails(capsys, ["run", str(path), "-n"], f"image folder not found: {tmp_path / 'nowhere'}")
    assert not (tmp_path / "results").exists()


def test_relative_dataset_root_says_where_it_was_looked_for(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    path = config(tmp_path, **{"datasets.d": {"loader": "nordland_sample", "root": "data/sample"}})
    fails(capsys, ["run", str(path), "-n"], "data/sample/summer", f"looked for from the working folder {tmp_path}")


def test_unequal_frame_counts(tmp_path, capsys):
    image_folders(tmp_path, 12, 11)
    fails(capsys, ["run", str(config(tmp_path)), "-n"], f"{tmp_path / 'ref'} has 12 images but", "has 11",
          SAMPLE[11].name)


def test_non_image_files_mixed_in(tmp_path, capsys, folders):
    (folders[1] / "notes.txt").write_text("taken on a rainy day")
    fails(capsys, ["run", str(config(tmp_path)), "-n"], "notes.txt", "not images", "frame list")


def test_corrupt_image_names_the_file(tmp_path, capsys, folders):
    broken = folders[1] / SAMPLE[5].name
    broken.write_bytes(b"\x89PNG not really")
    out = tmp_path / "d.h5"
    fails(capsys, ["descriptors", "--config", str(config(tmp_path)), "--dataset", "d", "--method", "sad",
                   "--out", str(out)], f"cannot decode image {broken}")
    nothing_written(tmp_path)


def test_images_of_different_sizes(tmp_path, capsys, folders, monkeypatch):
    (tmp_path / "tinynet.py").write_text(TINY_NET)
    monkeypatch.syspath_prepend(str(tmp_path))
    torch.save(tiny_net_model().state_dict(), tmp_path / "tiny.pt")
    big = folders[1] / SAMPLE[3].name
    cv2.imwrite(str(big), cv2.resize(cv2.imread(str(big)), (80, 40)))
    path = config(tmp_path, methods={"tiny": {"backend": "tinynet:TinyNet", "checkpoint": str(tmp_path / "tiny.pt")}})
    fails(capsys, ["descriptors", "--config", str(path), "--dataset", "d", "--method", "tiny",
                   "--out", str(tmp_path / "d.h5")], "different sizes", big.name)
    nothing_written(tmp_path)


@pytest.mark.parametrize(("splits", "message"), [
    ({"train": [0, 4], "val": [4, 8], "test": [8, 8]}, "split 'test' = [8, 8) is empty"),
    ({"train": [0, 4], "val": [4, 8], "test": [8, 20]}, "split 'test' = [8, 20) is outside the 12 frames"),
    ({"train": [0, 4], "val": [4, 8], "test": [8, 10]}, "split 'test' has 2 frames, fewer than the sequence length 3"),
    ({"train": [0, 4], "test": [8, 12]}, "split 'val' (named in train_split, eval_splits or table_split) is not"),
])
def test_bad_splits(tmp_path, capsys, folders, splits, message):
    fails(capsys, ["run", str(config(tmp_path, **{"datasets.d.splits": splits})), "-n"], message)


def test_wrong_checkpoint_keys_fail_before_any_job(tmp_path, capsys, folders, monkeypatch):
    (tmp_path / "tinynet.py").write_text(TINY_NET)
    monkeypatch.syspath_prepend(str(tmp_path))
    torch.save({"backbone.weight": torch.zeros(8, 3, 3, 3)}, tmp_path / "other.pt")
    path = config(tmp_path, methods={"tiny": {"backend": "tinynet:TinyNet", "checkpoint": str(tmp_path / "other.pt")}})
    fails(capsys, ["run", str(path)], "methods.tiny", "other.pt", "missing keys", "0.weight", "unexpected keys",
          "backbone.weight")
    assert not (tmp_path / "results" / "bad" / "descriptors").exists()


def test_pickled_checkpoint_names_the_python_objects(tmp_path, capsys, folders, monkeypatch):
    (tmp_path / "tinynet.py").write_text(TINY_NET)
    monkeypatch.syspath_prepend(str(tmp_path))
    torch.save({"args": argparse.Namespace(lr=0.1)}, tmp_path / "pickle.pt")
    path = config(tmp_path, methods={"tiny": {"backend": "tinynet:TinyNet",
                                              "checkpoint": str(tmp_path / "pickle.pt")}})
    err = fails(capsys, ["run", str(path)], "methods.tiny", "pickle.pt", "stores Python objects",
                "weights_only=True refuses argparse.Namespace", "torch.save(model.state_dict(), PATH)")
    assert "convert-checkpoint" not in err  # only backends with a converter (apgem) get that hint


def test_unknown_backend_and_unknown_backend_setting(tmp_path, capsys, folders):
    path = config(tmp_path, methods={"a": {"backend": "no_such_net"}, "b": {"backend": "sad", "colour": "red"}})
    fails(capsys, ["run", str(path)], "methods.a.backend: unknown descriptor backend 'no_such_net'",
          "methods.b", "no setting colour")


@pytest.mark.parametrize(("change", "message"), [
    ({"seq_lens": "four"}, "seq_lens: 'four' is not of type 'array'"),
    ({"colour": "blue"}, "colour: unexpected key 'colour'; the top level allows: run, output, seq_lens"),
    ({"seq_len": 4}, "seq_len: unexpected key 'seq_len' (did you mean 'seq_lens'?)"),
    ({"run": "corridor ü"}, "run: 'corridor ü' is not allowed: it has a space (character 9) and 'ü' (character 10);"
                            " use only letters A-Z a-z, digits 0-9, '_', '.' and '-'"),
])
def test_schema_failures(tmp_path, capsys, folders, change, message):
    fails(capsys, ["run", str(config(tmp_path, **change)), "-n"], "c.yaml is invalid", message)


@pytest.mark.parametrize("command", ["attributes", "metrics"])
def test_non_finite_distances_are_named_by_row_and_column(tmp_path, capsys, command):
    matrix = np.ones((400, 400))
    matrix[10, 20] = np.nan  # the first, in column order: query column 20, reference row 10
    matrix[3, 399] = np.nan
    matrix[390, 200] = -np.inf
    np.save(tmp_path / "D.npy", matrix)
    out = tmp_path / ("a.csv" if command == "attributes" else "m.json")
    fails(capsys, [command, "--distances", str(tmp_path / "D.npy"), "--seq-len", "4", "--out", str(out)],
          "D.npy", "distance matrix has 3 non-finite values (2 NaN, 1 inf); the first is NaN at row 10 (reference), "
                   "column 20 (query); distances must be finite")
    assert not out.exists()


@pytest.mark.parametrize(("name", "content", "message"), [
    ("nan.npy", np.array([[0.0, np.nan, 1.0], [1.0, 0.5, 0.0], [0.5, 0.5, 0.5]]), "non-finite"),
    ("flat.npy", np.arange(9.0), "must be 2-D"),
    ("matrix.txt", None, "is text, neither a NumPy .npy/.npz array, a MATLAB .mat file nor HDF5"),
    ("missing.npy", "absent", "not found"),
])
def test_bad_distance_matrices(tmp_path, capsys, name, content, message):
    path = tmp_path / name
    if isinstance(content, np.ndarray):
        np.save(path, content)
    elif content is None:
        path.write_text("0 1\n1 0\n")
    out = tmp_path / "attributes.csv"
    fails(capsys, ["attributes", "--distances", str(path), "--seq-len", "2", "--out", str(out)], name, message)
    assert not out.exists() and not list(tmp_path.glob("*.tmp"))


def test_output_folder_that_cannot_be_written(tmp_path, capsys, folders):
    (tmp_path / "a_file").write_text("")
    path = config(tmp_path, output=str(tmp_path / "a_file" / "results"))
    fails(capsys, ["run", str(path)], "output: cannot write the run folder", "a_file")


def test_snakemake_without_a_configuration(tmp_path):
    result = subprocess.run([sys.executable, "-m", "snakemake", "-n", "--snakefile", str(REPO / "Snakefile")],
                            cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert result.returncode != 0
    assert "no configuration: run `vpr-smr run <config.yaml>`" in result.stdout + result.stderr


def test_debug_shows_the_traceback(tmp_path, folders):
    path = config(tmp_path, **{"datasets.d.reference": str(tmp_path / "nowhere")})
    with pytest.raises(ValueError, match="image folder not found"):
        main(["--debug", "run", str(path), "-n"])
