"""The ground truth of every table's numbers in its CSV (``correct_matches``, each row its dataset's) as under the
Markdown and LaTeX titles: the one table writer adds it, and a plain CSV reader reads it as a column."""

from __future__ import annotations

import csv

from vpr_smr.eval.report.build import _write_table

ROWS = [{"dataset": "corridor", "method": "hog", "recall": 0.5},
        {"dataset": "gardens", "method": "sad", "recall": 0.125},
        {"dataset": "corridor", "method": "sad", "recall": 0.75}]
PROTOCOLS = {"corridor": "within 1 frame", "gardens": "gt_gardens.pkl (per-query lists)", "unused": "within 3 frames"}


def read(path):
    with open(path, newline="") as handle:
        reader = csv.DictReader(handle)
        return list(reader.fieldnames or []), list(reader)


def test_every_row_names_its_datasets_ground_truth(tmp_path):
    csv_path, md, tex = _write_table(tmp_path / "scores", ["dataset", "method", "recall"], ROWS, "Scores",
                                     protocols=PROTOCOLS)
    columns, rows = read(csv_path)
    assert columns == ["dataset", "method", "recall", "correct_matches"]
    assert [(r["dataset"], r["recall"], r["correct_matches"]) for r in rows] == [
        ("corridor", "0.5", "within 1 frame"), ("gardens", "0.125", "gt_gardens.pkl (per-query lists)"),
        ("corridor", "0.75", "within 1 frame")]
    line = "Correct matches: corridor within 1 frame; gardens gt_gardens.pkl (per-query lists)"
    assert md.read_text().splitlines()[:3] == ["# Scores", "", line]
    assert tex.read_text().splitlines()[:2] == ["% Scores", f"% {line}"]


def test_no_known_ground_truth_adds_no_column(tmp_path):
    csv_path = _write_table(tmp_path / "scores", ["dataset", "method", "recall"], ROWS, "Scores", (".csv",),
                            protocols={"elsewhere": "within 2 frames"})[0]
    assert read(csv_path)[0] == ["dataset", "method", "recall"]
