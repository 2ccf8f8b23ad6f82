"""A researcher's own two image folders, end to end: the README's commands, run as written on real images."""

from __future__ import annotations

import shlex
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
from helpers import REPO, doc_block, write_route

from vpr_smr.datasets import load_frames, read_image

EXAMPLE = REPO / "configs" / "own_folders.yaml"


@pytest.mark.slow
def test_readme_example_runs_as_written_on_real_images(tmp_path):
    """The README's commands, run as written from the folder that holds my_route/, with the shipped file."""
    write_route(tmp_path / "my_route", 300)
    commands = [shlex.split(line) for line in doc_block("own-data-commands").splitlines() if line.strip()]
    assert [c[:3] for c in commands] == [["vpr-smr", "dataset", "check"],
                                         ["vpr-smr", "run", "configs/own_folders.yaml"]]
    (tmp_path / "configs").mkdir()
    (tmp_path / "configs" / "own_folders.yaml").symlink_to(EXAMPLE)  # the shipped file itself, not a copy
    vpr_smr = str(Path(sys.executable).with_name("vpr-smr"))
    results = [subprocess.run([vpr_smr, *c[1:]], cwd=tmp_path, capture_output=True, text=True) for c in commands]
    check, run = results
    assert check.returncode == 0, check.stderr
    assert "status: OK" in check.stdout and "paired by file name" in check.stdout
    assert "order: img1.jpg, img2.jpg, img3.jpg ... img298.jpg, img299.jpg, img300.jpg" in check.stdout
    assert "warning" not in check.stdout
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    out = tmp_path / "results" / "my_route"
    table = (out / "tables" / "table1.csv").read_text()
    assert "sad" in table and "hog" in table
    assert (out / "report.html").is_file()
    # frame i of the descriptors is img{i+1}.jpg: natural order, not img1, img10, img100, ...
    descriptors = out / "descriptors" / "my_route" / "sad.h5"
    with h5py.File(descriptors) as f:
        stored = f["reference"][:]
    expected = load_frames("my_route", {"loader": "folders", "reference": str(tmp_path / "my_route/reference"),
                                        "query": str(tmp_path / "my_route/query")})
    assert expected.reference.images[9].name == "img10.jpg"
    from vpr_smr.descriptors.sad import SAD

    assert np.allclose(stored[9], SAD().describe(read_image(expected.reference.images[9])))
