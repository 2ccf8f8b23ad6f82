"""The real workflow (Snakemake calling our CLI) on a slice of the shipped Nordland sample."""

import csv
import json
import subprocess
import sys

import cv2
import numpy as np
import pytest

from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT

pytestmark = pytest.mark.slow

FRAMES = (1000, 1360)  # 360 frames: train 0-150, val 150-250, test 250-360 of the slice
CONFIG = f"""
run: e2e
output: {{out}}
seq_lens: [3, 4]
datasets:
  sample:
    loader: nordland_sample
    root: {DEFAULT_ROOT}
    frames: [{FRAMES[0]}, {FRAMES[1]}]
    splits: {{train: [0, 150], val: [150, 250], test: [250, 360]}}
methods:
  sad: {{backend: sad}}
  hog: {{backend: hog}}
  effnet: {{backend: efficientnet_lite0_gem, checkpoint: package, image_size: [64, 128]}}
predictor: {{max_iter: 300}}
"""


def naive_sad_recall(lo, hi, seq_len):
    """Single-frame R@1 of SAD on frames lo..hi-1 of the sample, computed from scratch (tolerance 2)."""
    def descriptor(path):
        grey = cv2.cvtColor(cv2.imread(str(path)), cv2.COLOR_BGR2GRAY).astype(np.float64)
        out = np.zeros_like(grey)
        for y in range(0, 32, 8):
            for x in range(0, 64, 8):
                patch = grey[y:y + 8, x:x + 8]
                out[y:y + 8, x:x + 8] = 0 if patch.std() == 0 else (patch - patch.mean()) / patch.std()
        return out.ravel()

    names = sorted(p.name for p in (DEFAULT_ROOT / "summer").iterdir())[lo:hi]
    ref = np.array([descriptor(DEFAULT_ROOT / "summer" / n) for n in names])
    qry = np.array([descriptor(DEFAULT_ROOT / "winter" / n) for n in names])
    hits = [abs(int(np.argmin(np.abs(ref - qry[q]).mean(axis=1))) - q) <= 2 for q in range(seq_len - 1, len(names))]
    return float(np.mean(hits))


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("e2e")
    config = tmp / "e2e.yaml"
    config.write_text(CONFIG.replace("{out}", str(tmp / "results")))
    result = subprocess.run([sys.executable, "-m", "vpr_smr.pipeline", "run", str(config), "--cores", "2"],
                            cwd=tmp, capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    return tmp / "results" / "e2e", result.stdout


def test_tables_have_every_row(run):
    out, stdout = run
    assert f"tables:  {out / 'tables'}" in stdout
    rows = list(csv.DictReader(open(out / "tables" / "table1.csv")))
    assert list(rows[0]) == ["dataset", "method", "seq_len", "mode", "recall_at_1_single", "recall_at_1_sequence",
                             "max_recall", "aoc_vpr_sm", "aoc_vpr_sm_pred", "reduction_pct"]
    keys = {(r["method"], r["seq_len"], r["mode"]) for r in rows}
    assert keys == {(m, s, mode) for m in ("sad", "hog", "effnet") for s in ("3", "4")
                    for mode in ("paper", "standard")}
    for r in rows:
        aoc_base, aoc_pred, max_recall = float(r["aoc_vpr_sm"]), float(r["aoc_vpr_sm_pred"]), float(r["max_recall"])
        assert 0 <= aoc_base <= max_recall <= 1 and 0 <= aoc_pred <= max_recall
        if aoc_base > 0:
            assert float(r["reduction_pct"]) == pytest.approx(100 * (aoc_base - aoc_pred) / aoc_base)
    md = (out / "tables" / "table1.md").read_text()
    assert "| sample | VPR+SM |" in md and "Improved" in md
    assert r"\begin{tabular}" in (out / "tables" / "table1.tex").read_text()
    predictor = list(csv.DictReader(open(out / "tables" / "predictor.csv")))
    assert [(p["dataset"], p["seq_len"]) for p in predictor] == [("sample", "3"), ("sample", "4")]
    assert all(0 < float(p[k]) <= 1 for p in predictor for k in ("f1_cv", "f1_val", "f1_test"))
    assert sorted(p.name for p in (out / "figures").iterdir()) == sorted(
        [f"pr_sample_L{s}_{m}.png" for s in (3, 4) for m in ("paper", "standard")]
        + [f"trust_sample_L{s}.png" for s in (3, 4)] + [f"confusion_sample_L{s}.png" for s in (3, 4)])


def test_sad_recall_matches_an_independent_computation(run):
    out, _ = run
    rows = list(csv.DictReader(open(out / "tables" / "table1.csv")))
    sad = next(r for r in rows if r["method"] == "sad" and r["seq_len"] == "4" and r["mode"] == "paper")
    lo = FRAMES[0] + 250
    assert float(sad["recall_at_1_single"]) == pytest.approx(naive_sad_recall(lo, FRAMES[1], 4), abs=1e-9)


def test_outputs_carry_provenance_and_a_rerun_does_nothing(run, tmp_path):
    import h5py

    out, _ = run
    with h5py.File(out / "descriptors" / "sample" / "effnet.h5", "r") as f:
        assert f["reference"].shape == (360, 1280) and f.attrs["method"] == "effnet"
        assert len(f.attrs["frames_sha256"]) == 64
    evaluation = json.loads((out / "evaluation" / "sample" / "hog" / "L4.json").read_text())
    assert set(evaluation["splits"]) == {"val", "test"}
    config = out.parent.parent / "e2e.yaml"
    again = subprocess.run([sys.executable, "-m", "vpr_smr.pipeline", "run", str(config)], cwd=out.parent.parent,
                           capture_output=True, text=True, timeout=300)
    assert again.returncode == 0 and "Nothing to be done" in again.stdout + again.stderr
