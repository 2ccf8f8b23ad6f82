"""`vpr-smr run` on two image folders with positions (method §11, issue 20): a query driven 1.5 times as fast as the
reference, so the traverses differ in length and each split gives its reference and query ranges apart.

Checks the files of every stage against values worked out here (matrix shapes, the positions beside them, the
single-frame ground truth within the radius) and which jobs a changed radius, reference range or position reruns.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml

from vpr_smr.core.io import read_provenance
from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT

pytestmark = pytest.mark.slow

NAMES = sorted(p.name for p in (DEFAULT_ROOT / "summer").iterdir())
N_REFERENCE, N_QUERY, SPEED = 240, 160, 1.5  # the query passes 1.5 reference places per frame
SPACING = 10.0  # metres between reference frames
SPLITS = {"train": {"reference": [0, 120], "query": [0, 80]}, "val": {"reference": [120, 180], "query": [80, 120]},
          "test": {"reference": [180, 240], "query": [120, 160]}}
RADIUS = 25.0


def write_route(folder: Path) -> dict:
    """Summer frames as the reference, winter frames of every 1.5th place as the query, with CSVs of positions."""
    reference, query = folder / "route" / "reference", folder / "route" / "query"
    reference.mkdir(parents=True)
    query.mkdir(parents=True)
    ref_rows, query_rows = [], []
    for i in range(N_REFERENCE):
        shutil.copy(DEFAULT_ROOT / "summer" / NAMES[1000 + i], reference / f"r{i:04d}.png")
        ref_rows.append(f"r{i:04d}.png,{SPACING * i},0.0")
    for t in range(N_QUERY):
        place = SPEED * t
        shutil.copy(DEFAULT_ROOT / "winter" / NAMES[1000 + int(place + 0.5)], query / f"q{t:04d}.png")
        query_rows.append(f"q{t:04d}.png,{SPACING * place},2.0")  # the other lane, 2 m across
    (folder / "route" / "reference.csv").write_text("name,x,y\n" + "\n".join(ref_rows) + "\n")
    (folder / "route" / "query.csv").write_text("name,x,y\n" + "\n".join(query_rows) + "\n")
    return {"loader": "folders", "reference": "route/reference", "query": "route/query",
            "reference_positions": "route/reference.csv", "query_positions": "route/query.csv", "radius": RADIUS,
            "splits": SPLITS}


def config(dataset: dict) -> dict:
    conf = {"run": "pos", "output": "results", "seq_lens": [4], "seeds": 1, "trust_levels": [0.5],
            "datasets": {"route": dataset}, "methods": {"sad": {"backend": "sad"}, "hog": {"backend": "hog"}},
            "predictor": {"max_iter": 300}}
    import json

    from vpr_smr.pipeline.config import SCHEMA_PATH

    if "speed" in json.loads(SCHEMA_PATH.read_text())["properties"]["experiments"]["properties"]:
        conf["experiments"] = {"speed": False}  # simulated speeds re-drive frame-aligned pairs: not this one
    conf.setdefault("experiments", {})["matchers"] = False  # tests/workflow/test_plugin_matcher_workflow.py runs it
    return conf


def vpr_smr(folder: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "vpr_smr.pipeline", *args], cwd=folder, capture_output=True,
                          text=True, timeout=900)


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("positions")
    (folder / "c.yaml").write_text(yaml.safe_dump(config(write_route(folder))))
    check = vpr_smr(folder, "dataset", "check", "--config", "c.yaml")
    assert check.returncode == 0, check.stdout + check.stderr
    assert "240 reference and 160 query frames with positions" in check.stdout
    result = vpr_smr(folder, "run", "c.yaml", "--cores", "4")
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    return folder


def test_every_stage_works_on_the_split_ranges(run):
    out = run / "results" / "pos"
    with h5py.File(out / "descriptors" / "route" / "sad.h5") as f:
        assert f["reference"].shape[0] == N_REFERENCE and f["query"].shape[0] == N_QUERY
        positions = f["reference_positions"][()], f["query_positions"][()]
    for split, ranges in SPLITS.items():
        (ref_lo, ref_hi), (lo, hi) = ranges["reference"], ranges["query"]
        distances = out / "distances" / "route" / "sad" / f"{split}.h5"
        with h5py.File(distances) as f:
            matrix = f["distance_matrix"][()]
            np.testing.assert_array_equal(f["reference_positions"][()], positions[0][ref_lo:ref_hi])
            np.testing.assert_array_equal(f["query_positions"][()], positions[1][lo:hi])
        assert matrix.shape == (ref_hi - ref_lo, hi - lo)
        provenance = read_provenance(distances)
        assert provenance["split_range"] == [lo, hi] and provenance["reference_range"] == [ref_lo, ref_hi]
        with h5py.File(out / "attributes" / "route" / "sad" / "L4" / f"{split}.h5") as f:
            queries, single, correct = f["queries"][()], f["single_match"][()], f["single_correct"][()]
        # the single-frame match is right within 25 m of the query's position, worked out here
        np.testing.assert_array_equal(single, matrix.argmin(axis=0)[queries])
        ref_x, query_x = SPACING * np.arange(ref_lo, ref_hi)[single], SPACING * SPEED * np.arange(lo, hi)[queries]
        np.testing.assert_array_equal(correct.astype(bool), np.hypot(ref_x - query_x, 2.0) <= RADIUS)
    assert (out / "report.html").is_file()


def planned(folder: Path) -> set[tuple[str, str]]:
    """``{(rule, first output)}`` of a dry run, relative to the run folder."""
    result = vpr_smr(folder, "run", "c.yaml", "-n", "--verbose")
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    jobs = re.findall(r"^rule (\w+):\n(?:    .*\n)*?    output: ([^,\n]+)", result.stdout, flags=re.MULTILINE)
    return {(rule, output.removeprefix("results/pos/")) for rule, output in jobs if rule != "all"}


def copy_of(run: Path, tmp_path: Path) -> Path:
    folder = tmp_path / "copy"
    shutil.copytree(run, folder, symlinks=True, copy_function=shutil.copy2)  # file times too: nothing is newer
    return folder


def test_what_a_changed_setting_reruns(run, tmp_path):
    folder = copy_of(run, tmp_path)
    # the report only: its dataset cards name the images' folders, and the copy's differ
    assert planned(folder) == {("report", "tables/table1.csv")}
    conf = yaml.safe_load((folder / "c.yaml").read_text())
    # the radius: a split setting, the ground truth of every job after the distances; no descriptors, no distances
    conf["datasets"]["route"]["radius"] = 30.0
    (folder / "c.yaml").write_text(yaml.safe_dump(conf))
    rules = {rule for rule, _ in planned(folder)}
    assert "attributes" in rules and "queries" in rules and "inspect" in rules and "vpr_metrics" in rules
    assert not rules & {"descriptors", "distances"}
    # one split's reference range: that split's distances, no descriptors
    conf["datasets"]["route"]["radius"] = RADIUS
    conf["datasets"]["route"]["splits"]["test"]["reference"] = [190, 240]
    (folder / "c.yaml").write_text(yaml.safe_dump(conf))
    jobs = planned(folder)
    assert {output for rule, output in jobs if rule == "distances"} == {"distances/route/sad/test.h5",
                                                                        "distances/route/hog/test.h5"}
    assert not any(rule == "descriptors" for rule, _ in jobs)
    # a position: the descriptor files hold them, so they are computed again (the CSV is their input)
    conf["datasets"]["route"]["splits"]["test"]["reference"] = [180, 240]
    (folder / "c.yaml").write_text(yaml.safe_dump(conf))
    csv = folder / "route" / "query.csv"
    csv.write_text(csv.read_text().replace("q0000.png,0.0,2.0", "q0000.png,0.0,3.0"))
    assert {output for rule, output in planned(folder) if rule == "descriptors"} == {
        "descriptors/route/sad.h5", "descriptors/route/hog.h5"}
