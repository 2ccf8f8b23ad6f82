"""The commands of the README and the docs pages, run as written in a folder of files made for them, and their output
blocks compared with what the commands print. The numbers each page quotes are checked against a second way of
getting them: the same matrix under a plain tolerance, the hand-worked 6 x 6 matrix of test_vpr_metrics.py."""

from __future__ import annotations

import csv
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.io
from field_files import band
from helpers import REPO, doc_block
from sample_matrix import sample_distances
from worked_matrix import D

from vpr_smr.eval.matching.attributes import read_features

BIN = Path(sys.executable).parent
ENV = {**os.environ, "PATH": f"{BIN}{os.pathsep}{os.environ['PATH']}"}


def bash(block: str, folder: Path) -> subprocess.CompletedProcess[str]:
    """A block run as written by bash in ``folder``, the installed vpr-smr first on the PATH."""
    done = subprocess.run(["bash", "-e", "-c", block], cwd=folder, env=ENV, capture_output=True, text=True)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    return done


def vpr_smr(folder: Path, *words: str) -> subprocess.CompletedProcess[str]:
    done = subprocess.run([str(BIN / "vpr-smr"), *words], cwd=folder, capture_output=True, text=True)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    return done


def words(text: str) -> list[str]:
    """A text as its words: a page wraps a long message that the command prints on one line."""
    return text.split()


@pytest.fixture(scope="module")
def sample(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, np.ndarray]:
    """SAD distances of summer (references) and winter (queries) frames 3301-3420 of the shipped sample, the
    matrix other-tools.md quotes, as D.npy and as similarities max(D) - D in S.npy."""
    folder = tmp_path_factory.mktemp("sample")
    distances = sample_distances(3301, 120)
    np.save(folder / "D.npy", distances)
    np.save(folder / "S.npy", distances.max() - distances)
    return folder, distances


def test_the_two_commands_are_the_makefiles_demo_and_test():
    lines = [line.split("#")[0].split() for line in doc_block("two-commands").splitlines() if line.strip()]
    assert lines == [["make", "demo"], ["make", "test"]]
    # make -n prints each target's recipe without running it: the demo runs the demo configuration, test the suite
    for target, recipe in (("demo", "/vpr-smr run configs/demo.yaml"), ("test", "/python -m pytest -q tests")):
        # as a user types it: not inside the make of `make test` (whose MAKEFLAGS and MAKELEVEL a sub-make inherits)
        env = {key: value for key, value in os.environ.items() if key not in ("MAKEFLAGS", "MAKELEVEL", "MFLAGS")}
        done = subprocess.run(["make", "--no-print-directory", "-n", target], cwd=REPO, capture_output=True,
                              text=True, env=env)
        assert done.returncode == 0, done.stderr
        assert done.stdout.splitlines()[-1].endswith(recipe)


def test_own_matrix_attributes_one_row_per_sequence_match(sample):
    folder, _ = sample
    block = doc_block("own-matrix-attributes")
    bash(block, folder)
    with open(folder / "attributes.csv") as f:
        rows = list(csv.reader(f))
    assert rows[0] == ["query", "A1", "A2", "A3", "A4", "label"]
    assert [int(r[0]) for r in rows[1:]] == list(range(3, 120))  # query >= L - 1, L = 4
    assert {int(r[5]) for r in rows[1:]} <= {0, 1, 2, 3}


def test_the_similarity_warning_is_the_one_printed(sample):
    folder, _ = sample
    printed = vpr_smr(folder, "metrics", "--distances", "S.npy", "--seq-len", "4", "--out", "s.json").stderr
    warning = next(line for line in printed.splitlines() if "WARNING" in line)
    assert words(warning.split("WARNING: ", 1)[1]) == words(doc_block("similarity-warning"))


def test_positions_within_a_radius_label_as_the_same_tolerance(sample):
    folder, _ = sample
    # one position per frame, 10 m apart: within 25 m is within 2 frames, the tolerance's band
    with open(folder / "ref.csv", "w") as f:
        f.write("x\n" + "".join(f"{10 * i}\n" for i in range(120)))
    np.save(folder / "qry.npy", 10.0 * np.arange(120))
    bash(doc_block("own-matrix-positions"), folder)
    vpr_smr(folder, "attributes", "--distances", "D.npy", "--seq-len", "4", "--tolerance", "2", "--velocities",
            "0.5", "0.75", "1", "1.25", "1.5", "2", "--out", "band.h5")
    by_positions, by_tolerance = read_features(folder / "attributes.h5"), read_features(folder / "band.h5")
    assert by_positions.labels.tolist() == by_tolerance.labels.tolist()
    assert by_positions.sequence_match.tolist() == by_tolerance.sequence_match.tolist()


def test_a_matlab_similarity_matrix_with_gthard_scores_as_the_band(sample):
    folder, distances = sample
    scipy.io.savemat(folder / "S.mat", {"S": distances.max() - distances})
    scipy.io.savemat(folder / "GT.mat", {"GThard": band(120, 120, 2)})
    block = doc_block("mat-gthard-command")
    assert block.startswith("vpr-smr metrics --distances S.mat")
    bash(block, folder)
    vpr_smr(folder, "metrics", "--distances", "D.npy", "--tolerance", "2", "--seq-len", "4", "--out", "band.json")
    scored = json.loads((folder / "metrics.json").read_text())
    plain = json.loads((folder / "band.json").read_text())
    assert scored["splits"]["all"]["modes"] == plain["splits"]["all"]["modes"]
    assert scored["meta"]["ground_truth"]["key"] == "GThard"


def test_the_metrics_command_prints_the_pages_table(tmp_path: Path):
    np.save(tmp_path / "D.npy", D)
    printed = bash(doc_block("metrics-command"), tmp_path).stdout
    shown = doc_block("metrics-output")
    assert [line.rstrip() for line in printed.splitlines()] == [line.rstrip() for line in shown.splitlines()]
    # the paper-mode single-frame row, worked out by hand in test_vpr_metrics.py: recall@1 3/6, AUC 11/12, EP 2/3
    assert re.search(r"all +paper +single +6 +0\.5000 .* 0\.3333 +0\.9167 +0\.6667", shown)
    # sequence matching's EP is 0 in both modes: its most confident match (distance 2.5) is wrong, so P_R0 = 0
    assert re.findall(r"sequence +5 .* (\S+)\n", shown) == ["0.0000", "0.0000"]


def test_the_backends_listing_shows_sads_lines():
    printed = vpr_smr(REPO, "backends").stdout.splitlines()
    header, *sad = doc_block("backends-sad-lines").splitlines()
    assert printed[0] == header
    at = printed.index(sad[0])
    assert printed[at : at + len(sad)] == sad


def test_the_readme_is_short_and_reaches_the_two_questions_in_one_click():
    readme = (REPO / "README.md").read_text()
    assert len(readme.splitlines()) <= 250
    # a MATLAB .mat similarity matrix with a GThard ground truth, and adding a matcher: a link each, to a heading
    for page, heading in (("other-tools.md", "### A MATLAB .mat matrix with a GThard ground truth"),
                          ("extending.md", "## A sequence matcher")):
        anchor = re.sub(r"[^\w\- ]", "", heading.lstrip("#").strip().lower()).replace(" ", "-")
        assert f"](docs/{page}#{anchor})" in readme
        assert heading in (REPO / "docs" / page).read_text().splitlines()
