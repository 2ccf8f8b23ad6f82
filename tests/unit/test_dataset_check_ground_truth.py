"""``vpr-smr dataset check`` on a configuration whose dataset's ground truth is a file (method §13): the file is read
and checked as ``vpr-smr run`` checks it before its first job, and the report names the file in place of a
tolerance."""

from __future__ import annotations

import json

import yaml

from vpr_smr.pipeline.cli import main as cli


def write_run(folder, lists):
    """A configuration of the shipped sample's 12 frames 1000-1011 with per-query lists in ``gt.json`` beside it."""
    (folder / "gt.json").write_text(json.dumps({str(q): refs for q, refs in lists.items()}))
    path = folder / "check.yaml"
    path.write_text(yaml.safe_dump({
        "run": "r", "output": str(folder / "out"), "seq_lens": [3],
        "datasets": {"mine": {"loader": "nordland_sample", "frames": [1000, 1012],
                              "splits": {"train": [0, 4], "val": [4, 8], "test": [8, 12]},
                              "ground_truth": {"lists": "gt.json"}}},
        "methods": {"sad": {"backend": "sad"}}}))
    return path


def test_an_index_out_of_range_fails_naming_the_file_and_the_index(tmp_path, capsys):
    lists = {q: [q] for q in range(12)}
    lists[7] = [7, 15]  # 12 references: 0 .. 11
    config = write_run(tmp_path, lists)
    assert cli(["dataset", "check", "--config", str(config), "--no-decode"]) == 1
    out = capsys.readouterr().out
    assert out.splitlines()[0] == (f"dataset 'mine': 12 aligned frames, correct matches from the ground-truth file "
                                   f"{tmp_path / 'gt.json'} (lists)")
    assert "tolerance" not in out
    problem = next(line for line in out.splitlines() if line.startswith("  ground truth: "))
    assert problem.startswith("  ground truth: datasets.mine.ground_truth.lists: ")
    assert (f"{tmp_path / 'gt.json'} names reference 15 (the pair query 7, reference 15), but the matrix has 12 "
            "references (0..11)") in problem
    assert out.splitlines()[-1] == ("status: PROBLEMS (0 missing files, 0 unreadable files, the ground-truth file "
                                    "refused)")


def test_a_good_file_is_named_and_passes(tmp_path, capsys):
    lists = {q: [q - 1, q] if q else [0] for q in range(12)}
    lists[9] = []  # a query without a correct reference is a note, as in `run`
    config = write_run(tmp_path, lists)
    assert cli(["dataset", "check", "--config", str(config), "--no-decode"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == (f"dataset 'mine': 12 aligned frames, correct matches from the ground-truth file "
                        f"{tmp_path / 'gt.json'} (lists)")
    assert ("  note: datasets.mine: 1 of the 4 queries of split 'test' have no correct reference in gt.json: they "
            "count in every recall and precision, never as correct (method §13)") in lines
    assert lines[-1] == "status: OK"
