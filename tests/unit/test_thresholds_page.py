"""docs/thresholds.md: its commands run as written on the shipped sample, in order, and what they print is the page's
output blocks; the live matcher accepts the frames deploy accepts (counted here from deploy's accepted table)."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from helpers import doc_block

BIN = Path(sys.executable).parent
ENV = {**os.environ, "PATH": f"{BIN}{os.pathsep}{os.environ['PATH']}"}


def bash(block: str, folder: Path) -> str:
    done = subprocess.run(["bash", "-e", "-c", block], cwd=folder, env=ENV, capture_output=True, text=True)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    return done.stdout


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    here = tmp_path_factory.mktemp("thresholds")
    bash(doc_block("thresholds-inputs"), here)
    return here


def test_calibrate_then_deploy_print_the_pages_numbers(folder):
    assert bash(doc_block("thresholds-calibrate"), folder).split() == doc_block("thresholds-calibrate-output").split()
    assert bash(doc_block("thresholds-deploy"), folder).split() == doc_block("thresholds-deploy-output").split()
    # the printed numbers, worked out again from the accepted table and the threshold file
    with open(folder / "accepted.csv") as handle:
        rows = list(csv.DictReader(handle))
    with open(folder / "queries.csv") as handle:
        labels = [r["sequence_correct"] == "1" for r in csv.DictReader(handle) if r["split"] == "test"]
    threshold = json.loads((folder / "thr.json").read_text())["threshold"]
    taken = [float(r["confidence"]) >= threshold for r in rows]
    assert [int(r["accepted"]) for r in rows] == [int(a) for a in taken]
    n, right = sum(taken), sum(a and ok for a, ok in zip(taken, labels, strict=True))
    assert (n, n - right, len(rows)) == (119, 1, 197)
    assert f"precision {right / n:.4f}" in doc_block("thresholds-deploy-output")
    assert f"recall {right / len(rows):.4f}" in doc_block("thresholds-deploy-output")


def test_the_reverse_deployment_misses_its_target(folder):
    assert bash(doc_block("thresholds-reverse"), folder).split() == doc_block("thresholds-reverse-output").split()
    found = json.loads((folder / "reverse-deployed.json").read_text())
    assert found["outcome"] == "violated" and found["realised"]["precision"] < 0.9


def test_the_live_matcher_accepts_what_deploy_accepts(folder):
    if not (folder / "thr.json").is_file():
        bash(doc_block("thresholds-calibrate"), folder)
    done = subprocess.run([sys.executable, "-c", doc_block("thresholds-live")], cwd=folder, capture_output=True,
                          text=True)
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.split() == doc_block("thresholds-live-output").split()
    if (folder / "accepted.csv").is_file():
        with open(folder / "accepted.csv") as handle:
            accepted = sum(int(r["accepted"]) for r in csv.DictReader(handle))
        assert f"accepted {accepted} of" in done.stdout
