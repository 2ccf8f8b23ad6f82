"""The configuration check runs once per `vpr-smr run`: Snakemake, given the plan the run wrote, plans every job
without checking the dataset again."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys

import pytest
import yaml
from run_configs import plan_once_config

from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT
from vpr_smr.pipeline.plan import PLAN_ENV


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
    conf = plan_once_config(root)
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
