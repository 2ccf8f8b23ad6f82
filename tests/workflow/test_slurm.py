"""The workflow on a real (one-node) SLURM cluster gives the tables of a local run.

`tests/slurm_cluster.py` starts slurmctld, slurmd and munged for this test only (Debian's packages, installed when
missing). `vpr-smr run --profile slurm` submits every job with sbatch through snakemake-executor-plugin-slurm;
the jobs' SLURM ids must appear in the log, and Table I must equal the local run's byte for byte.
"""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from slurm_cluster import start_cluster

from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT

pytestmark = pytest.mark.slow

# Small, and few levels in the job graph: the plugin checks job states every few seconds per level.
CONFIG = {
    "run": "s",
    "seq_lens": [3],
    "seeds": 2,
    "trust_levels": [0.0],
    "experiments": {"restoration": False, "attribute_ablation": False, "leave_one_method_out": False, "speed": False,
                    "matchers": False},
    "datasets": {"sample": {"loader": "nordland_sample", "root": str(DEFAULT_ROOT), "frames": [2000, 2090],
                            "splits": {"train": [0, 40], "val": [40, 60], "test": [60, 90]}}},
    "methods": {"sad": {"backend": "sad"}, "hog": {"backend": "hog"}},
    "predictor": {"max_iter": 100},
}


def vpr_smr_run(folder: Path, *args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    (folder / "c.yaml").write_text(yaml.safe_dump(CONFIG))
    return subprocess.run([sys.executable, "-m", "vpr_smr.pipeline", "run", "c.yaml", *args], cwd=folder, env=env,
                          capture_output=True, text=True, timeout=1200)


def test_slurm_run_equals_local_run(tmp_path):
    local = tmp_path / "local"
    local.mkdir()
    result = vpr_smr_run(local)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]

    cluster_folder = tmp_path / "cluster"
    cluster_folder.mkdir()
    with start_cluster(tmp_path) as cluster:
        # jobs run `vpr-smr` and `python -m snakemake` from this interpreter's environment
        env = cluster.env({**os.environ, "PATH": f"{Path(sys.executable).parent}:{os.environ['PATH']}"})
        result = vpr_smr_run(cluster_folder, "--profile", "slurm", "--", "--max-threads", str(cluster.cpus),
                             "--slurm-init-seconds-before-status-checks", "2", env=env)
        output = result.stdout + result.stderr
        assert result.returncode == 0, output[-4000:] + cluster.log_tails()
    # Snakemake's own output, which names the SLURM jobs, goes to the run's log (vpr-smr run shows a summary)
    output = "".join(p.read_text() for p in (cluster_folder / "results" / "s" / "logs").glob("snakemake-*.log"))
    job_ids = set(re.findall(r"submitted with SLURM jobid (\d+)", output))
    # descriptors 2, distances 6, attributes 6, train 1, evaluate 2, baselines 2, vpr_metrics 2, queries 2, inspect 2,
    # deployment 2, report 1: every job went through sbatch
    assert len(job_ids) == 28, output[-4000:]
    for name in ("table1.csv", "predictor.csv", "trust_levels.csv"):
        assert (cluster_folder / "results" / "s" / "tables" / name).read_bytes() == \
            (local / "results" / "s" / "tables" / name).read_bytes(), name
