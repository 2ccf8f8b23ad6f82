"""Split names are the user's: the workflow on real frames of the shipped Nordland sample with the splits named
``fit``, ``check`` and ``final`` (train_split, eval_splits, table_split), against the same run with the names
``train``, ``val`` and ``test``.

The tables of the renamed run name the user's splits (columns, split cells, headings, notes) and none of the
default names, and hold the same numbers as the run with the default names: every table's cells, compared after
renaming the default run's split names (an independent check that no stage, rule or record assumed a name).
"""

from __future__ import annotations

import csv
import re
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from run_configs import RENAMED, split_names_config

# the timing table's seconds differ from run to run; its other cells are compared
TIMES = re.compile(r"seconds|^ms_")


def run(folder: Path, names: dict[str, str]) -> Path:
    folder.mkdir()
    path = folder / "config.yaml"
    path.write_text(yaml.safe_dump(split_names_config(folder / "results", names), sort_keys=False))
    result = subprocess.run([sys.executable, "-m", "vpr_smr.pipeline", "run", str(path), "--cores", "2"],
                            cwd=folder, capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    return folder / "results" / "names" / "tables"


@pytest.fixture(scope="module")
def tables(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("split_names")
    return run(tmp / "default", {role: role for role in RENAMED}), run(tmp / "renamed", RENAMED)


def read(folder: Path, name: str) -> tuple[list[str], list[dict[str, str]]]:
    with open(folder / f"{name}.csv", newline="") as f:
        reader = csv.DictReader(f)
        return list(reader.fieldnames or []), list(reader)


def renamed(text: str) -> str:
    """The default run's split names in a column name or a cell replaced by the user's."""
    return re.sub(r"(?<![A-Za-z0-9])(train|val|test)(?![A-Za-z0-9])", lambda m: RENAMED[m.group(1)], text)


@pytest.mark.slow
def test_every_table_holds_the_same_numbers(tables):
    default, user = tables
    names = sorted(p.stem for p in default.glob("*.csv"))
    assert names == sorted(p.stem for p in user.glob("*.csv"))
    assert {"table1", "predictor", "table2", "leave_one_method_out", "speed", "vpr_metrics", "timing",
            "trust_levels", "restoration", "ablation_seq_len", "datasets"} <= set(names)
    for name in names:
        default_columns, default_rows = read(default, name)
        user_columns, user_rows = read(user, name)
        # columns named by a split: f1_val -> f1_check, n_test -> n_final (n_train and f1_cv are no split's)
        columns = {c: c if c in ("n_train", "f1_cv") or "train_class" in c else renamed(c) for c in default_columns}
        assert [columns[c] for c in default_columns] == user_columns, name
        # cells naming a split (the split column, the datasets' split list) renamed; every number as it was
        # (and the deployment experiment's calibration and deployment splits)
        expected = [{columns[c]: renamed(v) if c in ("split", "splits", "calibration", "deployment") else v
                     for c, v in row.items()
                     if not TIMES.search(c)} for row in default_rows]
        got = [{c: v for c, v in row.items() if not TIMES.search(c)} for row in user_rows]
        key = sorted if name == "timing" else list  # timing rows come in each evaluation file's order of splits
        assert key(map(repr, got)) == key(map(repr, expected)), name


@pytest.mark.slow
def test_the_tables_name_the_users_splits(tables):
    _, user = tables
    columns, rows = read(user, "predictor")
    assert {"f1_check", "f1_final", "n_check", "n_final"} <= set(columns)
    assert not {"f1_val", "f1_test", "n_val", "n_test"} & set(columns)
    # the predictor scored on both evaluation splits: 70 and 70 frames, less L - 1 each, pooled over two methods
    four = next(r for r in rows if r["seq_len"] == "4")
    assert (four["n_check"], four["n_final"], four["n_train"]) == (str(2 * 67), str(2 * 67), str(2 * 97))
    columns, _ = read(user, "table2")
    assert columns == ["dataset", "seq_len", "attributes", "f1_cv", "f1_check", "f1_final", "f1_final_method_mean",
                       "n_train", "n_check", "n_final", "correct_matches"]
    table2 = (user / "table2.md").read_text()
    assert "| F1 cross-validation | F1 check | F1 final | F1 final, mean over methods |" in table2
    assert "F1 over fit 194 samples, check 134 samples, final 134 samples (every method pooled)" in table2
    assert "F1 (check) & F1 (final) & F1 (final, method mean)" in (user / "table2.tex").read_text()
    assert "(final split)" in (user / "table1.md").read_text()
    for name in ("predictor_methods", "vpr_metrics"):
        assert {r["split"] for r in read(user, name)[1]} == {"final"}, name
    assert {r["split"] for r in read(user, "timing")[1]} == {"check", "final"}
    assert read(user, "datasets")[1][0]["splits"].startswith("fit [0, 100): 100 frames; check [100, 170)")
    for path in user.iterdir():  # no table names a default split where the user's are meant
        text = path.read_text()
        assert not re.search(r"f1_val|f1_test|n_val|n_test|\bval\b|validation split|\(test\b", text), path.name
