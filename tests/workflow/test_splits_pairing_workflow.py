"""Splits that share frames, allowed by the configuration, through the whole workflow: the overlap is stated next to
every number (every table and the report)."""

from __future__ import annotations

import pytest
import yaml

from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT


@pytest.mark.slow
def test_allowed_overlap_is_stated_next_to_every_number(tmp_path):
    import csv
    import subprocess
    import sys

    conf = {"run": "overlap", "output": str(tmp_path / "results"), "seq_lens": [4], "seeds": 1,
            "allow_split_overlap": True, "trust_levels": [0.0, 0.5], "predictor": {"max_iter": 200},
            "datasets": {"sample": {"loader": "nordland_sample", "root": str(DEFAULT_ROOT), "frames": [1000, 1200],
                                    "splits": {"train": [0, 100], "val": [100, 140], "test": [60, 200]}}},
            "methods": {"sad": {"backend": "sad"}, "hog": {"backend": "hog"}},
            "experiments": {"matchers": False}}  # test_plugin_matcher_workflow.py runs it
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump(conf))
    run = subprocess.run([sys.executable, "-m", "vpr_smr.pipeline", "run", str(path)], cwd=tmp_path,
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    out = tmp_path / "results" / "overlap"
    expected = ("splits share frames (allow_split_overlap: true): 'train' [0, 100) and 'test' [60, 200) share "
                "frames [60, 100); 'val' [100, 140) and 'test' [60, 200) share frames [100, 140)")
    names = sorted(p.stem for p in (out / "tables").glob("*.csv"))
    assert {"table1", "table2", "predictor", "restoration", "trust_levels", "leave_one_method_out"} <= set(names)
    for name in names:
        rows = list(csv.DictReader(open(out / "tables" / f"{name}.csv")))
        assert rows and all(r["split_overlap"] == expected for r in rows), name
        assert f"**Warning, sample: {expected}**" in (out / "tables" / f"{name}.md").read_text(), name
        assert "Warning, sample:" in (out / "tables" / f"{name}.tex").read_text(), name
    page = (out / "report.html").read_text()
    assert page.count("Warning, sample: splits share frames") == 1
    assert "test [60, 200): 140 frames" in page and "by file name (the same names in both folders)" in page
