"""The configuration check runs once per `vpr-smr run`: Snakemake, and every cluster job that parses the workflow,
read the plan it wrote instead of checking (and hashing every checkpoint) again."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT
from vpr_smr.pipeline import plan as plan_module
from vpr_smr.pipeline.config import validate
from vpr_smr.pipeline.plan import PLAN_ENV, plan_from_json, plan_to_json, planned, preflight, save_plan


def config(root: Path) -> dict:
    return {"run": "r", "seq_lens": [3], "datasets": {"sample": {
        "loader": "nordland_sample", "root": str(root), "frames": [1000, 1060],
        "splits": {"train": [0, 30], "val": [30, 40], "test": [40, 60]}}},
        "methods": {"sad": {"backend": "sad"}, "hog": {"backend": "hog", "distance": "cosine"}}}


def test_a_saved_plan_is_read_back_for_its_configuration_only(tmp_path, monkeypatch):
    conf = validate(config(DEFAULT_ROOT))
    made = preflight(conf)
    assert made.metrics == {"sad": "mad", "hog": "cosine"}  # the backend's default, or the method's setting
    path = save_plan(made, conf, tmp_path)
    assert plan_from_json(json.loads(path.read_text()), conf) == made
    monkeypatch.setenv(PLAN_ENV, str(path))

    def fail(conf: dict) -> None:
        raise AssertionError("checked again")

    monkeypatch.setattr(plan_module, "preflight", fail)
    assert planned(conf) == made
    other = validate({**config(DEFAULT_ROOT), "seeds": 2})
    assert plan_from_json(json.loads(path.read_text()), other) is None  # made for another configuration
    with pytest.raises(AssertionError, match="checked again"):
        planned(other)
    assert plan_to_json(made, conf)["config_sha256"] != plan_to_json(made, other)["config_sha256"]


@pytest.mark.slow
def test_snakemake_reads_the_plan_of_the_run(tmp_path):
    """After `vpr-smr run`, the dataset's folder is gone: Snakemake, given the run's plan, still plans every job
    (it did not check the dataset again); without the plan it stops at the missing folder."""
    root = tmp_path / "sample copy"
    (root / "summer").mkdir(parents=True)
    (root / "winter").mkdir()
    names = sorted(p.name for p in (DEFAULT_ROOT / "summer").iterdir())
    for season in ("summer", "winter"):
        for name in names[1000:1060]:
            shutil.copy(DEFAULT_ROOT / season / name, root / season / name)
    conf = config(root)
    conf["datasets"]["sample"]["frames"] = [0, 60]
    (tmp_path / "c.yaml").write_text(yaml.safe_dump(conf))
    run = subprocess.run([sys.executable, "-m", "vpr_smr.pipeline", "run", "c.yaml", "-n"], cwd=tmp_path,
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    plans = list((tmp_path / ".snakemake" / "vpr-smr").glob("plan-*.json"))
    assert len(plans) == 1
    shutil.rmtree(root)
    from vpr_smr.pipeline.workflow import SNAKEFILE

    command = [sys.executable, "-m", "snakemake", "--snakefile", str(SNAKEFILE), "--configfile", "c.yaml", "-n",
               "--cores", "1"]
    with_plan = subprocess.run(command, cwd=tmp_path, capture_output=True, text=True, timeout=300,
                               env={**os.environ, PLAN_ENV: str(plans[0])})
    assert with_plan.returncode == 0, with_plan.stdout[-2000:] + with_plan.stderr[-2000:]
    assert "descriptors" in with_plan.stdout
    without = subprocess.run(command, cwd=tmp_path, capture_output=True, text=True, timeout=300,
                             env={k: v for k, v in os.environ.items() if k != PLAN_ENV})
    assert without.returncode != 0 and "sample copy" in without.stdout + without.stderr


def test_the_methods_check_reruns_when_a_shared_backend_module_changes():
    # MegaLoc and BoQ build on dinov2.py (and MegaLoc on salad.py's aggregation): a change there must not let the
    # check before the first job reuse an earlier verdict for them.
    import os

    import vpr_smr.descriptors.dinov2 as dinov2
    from vpr_smr.pipeline.plan import _method_key

    path = dinov2.__file__
    before = os.stat(path)
    keys = {name: _method_key({"backend": name}) for name in ("megaloc", "boq", "salad")}
    try:
        os.utime(path, ns=(before.st_atime_ns, before.st_mtime_ns + 1_000_000_000))
        assert all(_method_key({"backend": name}) != key for name, key in keys.items())
    finally:
        os.utime(path, ns=(before.st_atime_ns, before.st_mtime_ns))
    assert all(_method_key({"backend": name}) == key for name, key in keys.items())
