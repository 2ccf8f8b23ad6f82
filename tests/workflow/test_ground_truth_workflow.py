"""A dataset whose ground truth is a file (method §13), end to end on real frames of the shipped Nordland sample: the
run with ``ground_truth: {matrix: gt.npy}`` holding the band |r - q| <= 2 (written out, a path relative to the
configuration's folder) gives every table the numbers of the same run with ``tolerance: 2``, says the file under
every table's title, and has no protocol sweep; the tolerance run has one."""

from __future__ import annotations

import csv
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from field_files import band

from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT

TIMES = re.compile(r"seconds|^ms_")  # the timing table's seconds differ from run to run


def run(folder: Path, entry: dict) -> Path:
    folder.mkdir()
    config = {
        "run": "gt", "output": str(folder / "results"), "seq_lens": [3], "seeds": 1,
        "datasets": {"sample": {"loader": "nordland_sample", "root": str(DEFAULT_ROOT), "frames": [1000, 1240],
                                "splits": {"train": [0, 100], "val": [100, 170], "test": [170, 240]}, **entry}},
        "methods": {"sad": {"backend": "sad"}, "hog": {"backend": "hog"}},
        "predictor": {"max_iter": 200},
        "experiments": {"speed": False, "leave_one_method_out": False, "trust_levels": False, "matchers": False},
    }
    (folder / "config.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    np.save(folder / "gt.npy", band(240, 240, 2))
    # run from another folder: the ground truth's relative path is the configuration's
    result = subprocess.run([sys.executable, "-m", "vpr_smr.pipeline", "run", str(folder / "config.yaml"),
                             "--cores", "2"], cwd=folder.parent, capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    return folder / "results" / "gt" / "tables"


@pytest.fixture(scope="module")
def tables(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("ground_truth")
    return run(tmp / "tolerance", {"tolerance": 2}), run(tmp / "file", {"ground_truth": {"matrix": "gt.npy"}})


def read(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.mark.slow
def test_a_band_file_gives_the_numbers_of_the_tolerance(tables):
    tolerance, file = tables
    names = sorted(p.stem for p in file.glob("*.csv"))
    assert sorted(p.stem for p in tolerance.glob("*.csv")) == sorted([*names, "protocol_sweep"])
    assert {"table1", "predictor", "table2", "vpr_metrics", "restoration", "timing"} <= set(names)
    for name in names:
        if name == "datasets":
            continue
        expected, found = read(tolerance / f"{name}.csv"), read(file / f"{name}.csv")
        assert len(found) == len(expected) > 0, name
        for a, b in zip(expected, found, strict=True):
            # the same numbers; each CSV row names the ground truth it was scored with (correct_matches)
            assert {k: v for k, v in a.items() if not TIMES.search(k) and k != "correct_matches"} == \
                {k: v for k, v in b.items() if not TIMES.search(k) and k != "correct_matches"}, name
            if "dataset" in a:
                assert (a["correct_matches"], b["correct_matches"]) == ("within 2 frames", "gt.npy (a matrix)"), name
        assert "Correct matches: sample gt.npy (a matrix)" in (file / f"{name}.md").read_text(), name
        assert "Correct matches: sample within 2 frames" in (tolerance / f"{name}.md").read_text(), name
    # the scoring jobs read the file: their outputs record it
    for kind in ("metrics", "baselines"):
        for path in (file.parent / kind).rglob("*.json"):
            assert json.loads(path.read_text())["meta"]["ground_truth"]["kind"] == "matrix", path
    (card,) = read(file / "datasets.csv")
    assert card["tolerance"] == "gt.npy (a matrix)"
    sweep = read(tolerance / "protocol_sweep.csv")
    at_two = [r for r in sweep if float(r["threshold"]) == 2 and r["mode"] == "paper"]
    table1 = {r["method"]: r for r in read(tolerance / "table1.csv") if r["mode"] == "paper"}
    # the sweep's point at the run's own tolerance is Table I
    assert {r["method"]: r["reduction_pct"] for r in at_two} == {m: r["reduction_pct"] for m, r in table1.items()}
