"""The README's "Scoring a matrix from another tool" commands, run as written on files written the way VPR_Tutorial,
VPR-Bench and OpenSeqSLAM write them, from 120 real frames of the shipped Nordland sample. Each ground truth below is
the band |r - q| <= 2 in another form, so every number must equal the tolerance-2 scoring of the same matrix."""

from __future__ import annotations

import csv
import hashlib
import json
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.io
from field_files import band, lists_of, write_vpr_bench
from helpers import doc_block
from sample_matrix import sample_distances

VPR_SMR = str(Path(sys.executable).with_name("vpr-smr"))


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The files of the README's examples: S.npy (similarities), GT.npz (GThard: the band of 2 frames, GTsoft: of 5),
    D.npy (distances), ground_truth_new.npy (VPR-Bench's lists of the band) and results.mat (D, queries x
    references, as OpenSeqSLAM's MATLAB code writes its difference matrix)."""
    out = tmp_path_factory.mktemp("field")
    distances = sample_distances(3301, 120)
    np.save(out / "D.npy", distances)
    np.save(out / "S.npy", distances.max() - distances)  # larger = more similar
    np.savez(out / "GT.npz", GThard=band(120, 120, 2), GTsoft=band(120, 120, 5))
    write_vpr_bench(out / "ground_truth_new.npy", lists_of(band(120, 120, 2)))
    scipy.io.savemat(out / "results.mat", {"D": distances.T})
    return out


def run(folder: Path, *words: str) -> subprocess.CompletedProcess[str]:
    done = subprocess.run([VPR_SMR, *words], cwd=folder, capture_output=True, text=True)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    return done


def splits(path: Path) -> dict[str, object]:
    data = json.loads(path.read_text())
    return {name: split["modes"] for name, split in data["splits"].items()}


def test_readme_commands_run_as_written_and_give_the_band_numbers(folder):
    commands = [shlex.split(line) for line in doc_block("field-matrix-commands").splitlines() if line.strip()]
    assert [c[:2] for c in commands] == [["vpr-smr", "metrics"], ["vpr-smr", "metrics"], ["vpr-smr", "attributes"],
                                         ["vpr-smr", "metrics"]]
    for command in commands:
        run(folder, *command[1:])
    # the same matrices scored within 2 frames: GThard and VPR-Bench's lists are that band
    run(folder, "metrics", "--distances", "S.npy", "--similarity", "--tolerance", "2", "--seq-len", "4", "--out",
        "s_band.json")
    run(folder, "metrics", "--distances", "D.npy", "--tolerance", "2", "--seq-len", "4", "--out", "d_band.json")
    run(folder, "attributes", "--distances", "D.npy", "--tolerance", "2", "--seq-len", "4", "--out", "d_band.csv")
    assert splits(folder / "tutorial.json") == splits(folder / "s_band.json")
    assert splits(folder / "vpr_bench.json") == splits(folder / "d_band.json")
    # the MATLAB file holds D transposed: the same attributes and labels as the .npy
    with open(folder / "openseqslam.csv") as a, open(folder / "d_band.csv") as b:
        assert list(csv.reader(a)) == list(csv.reader(b))
    recorded = json.loads((folder / "tutorial.json").read_text())["meta"]["ground_truth"]
    assert recorded["kind"] == "matrix" and recorded["key"] == "GThard"
    assert recorded["sha256"] == hashlib.sha256((folder / "GT.npz").read_bytes()).hexdigest()


def test_the_sweep_scores_the_same_matches_under_each_tolerance(folder):
    run(folder, "metrics", "--distances", "D.npy", "--seq-len", "4", "--sweep", "--out", "swept.json")
    sweep = json.loads((folder / "swept.json").read_text())["splits"]["all"]["sweep"]
    assert sweep["kind"] == "frames"
    assert [p["threshold"] for p in sweep["modes"]["paper"]] == [0, 1, 2, 5, 10]
    for index, tolerance in enumerate((0, 1, 2, 5, 10)):  # each point equals a plain run at that tolerance
        run(folder, "metrics", "--distances", "D.npy", "--tolerance", str(tolerance), "--seq-len", "4", "--out",
            f"t{tolerance}.json")
        plain = json.loads((folder / f"t{tolerance}.json").read_text())["splits"]["all"]["modes"]
        for mode in ("paper", "standard"):
            point = sweep["modes"][mode][index]
            assert "reduction" not in point  # no predictor, no removal
            assert point["recall_at_1_single"] == pytest.approx(plain[mode]["single"]["recall_at"]["1"], abs=1e-12)
            assert point["recall_at_1_sequence"] == pytest.approx(plain[mode]["sequence"]["recall_at"]["1"],
                                                                  abs=1e-12)
    recall = [p["recall_at_1_sequence"] for p in sweep["modes"]["paper"]]
    assert recall == sorted(recall)  # a looser ground truth never makes a match wrong
