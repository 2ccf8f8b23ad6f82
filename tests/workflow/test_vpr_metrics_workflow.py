"""The workflow rules of the standard VPR metrics and the per-query CSV (``vpr-smr run`` on the shipped sample):
recall@N against a naive loop, and the queries job's table byte for byte the one ``vpr-smr metrics --queries``
writes (slow)."""

import csv
import json
import subprocess
import sys

import pytest
import yaml
from oracles import naive_recalls

from vpr_smr.eval.matching.sources import TruthSource
from vpr_smr.eval.scoring.vpr_metrics import MetricsJob, main


@pytest.mark.slow
def test_workflow_rule(tmp_path):
    from helpers import read_distance_matrix

    from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT

    conf = {
        "run": "r", "output": "results", "seq_lens": [3], "seeds": 2,
        "datasets": {"sample": {"loader": "nordland_sample", "root": str(DEFAULT_ROOT), "frames": [1000, 1120],
                                "splits": {"train": [0, 50], "val": [50, 80], "test": [80, 120]}}},
        "methods": {"sad": {"backend": "sad"}},
        "predictor": {"max_iter": 60},
        "experiments": {"matchers": False},  # test_plugin_matcher_workflow.py runs it
    }
    (tmp_path / "c.yaml").write_text(yaml.safe_dump(conf))
    targets = ["results/r/metrics/sample/sad/L3.json", "results/r/queries/sample/sad/L3.csv"]
    result = subprocess.run([sys.executable, "-m", "vpr_smr.pipeline", "run", "c.yaml", "--cores", "2", "--",
                             *targets], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    run = tmp_path / "results" / "r"
    data = json.loads((run / "metrics/sample/sad/L3.json").read_text())
    assert data["meta"] == {"dataset": "sample", "method": "sad", "seq_len": 3, "tolerance": 2,
                            "ground_truth": {"kind": "frames", "tolerance": 2}, "r_window": 10, "spread_k": 10,
                            "predictor": "results/r/predictors/sample/L3.h5",
                            "matcher": {"name": "seqslam", "settings": {"velocities": [1.0]}}}
    assert set(data["splits"]) == {"val", "test"}  # the default eval_splits (write_json sorts the keys)
    rows = list(csv.DictReader(open(run / "queries/sample/sad/L3.csv")))
    for split, (lo, hi) in (("val", (50, 80)), ("test", (80, 120))):
        d = read_distance_matrix(run / f"distances/sample/sad/{split}.h5")
        single, sequence = naive_recalls(d, 3, 2)
        modes = data["splits"][split]["modes"]
        assert modes["paper"]["single"]["recall_at"] == pytest.approx({str(n): v for n, v in single.items()})
        assert modes["standard"]["sequence"]["recall_at"] == pytest.approx({str(n): v for n, v in sequence.items()})
        assert [int(r["query"]) for r in rows if r["split"] == split] == list(range(lo + 2, hi))
    # the queries job (vpr-smr queries) writes the table `vpr-smr metrics --queries` writes of the same files
    splits = ("val", "test")
    main(MetricsJob(tuple(f"{s}={run}/distances/sample/sad/{s}.h5" for s in splits), 3, TruthSource(tolerance=2),
                    predictor=str(run / "predictors/sample/L3.h5"),
                    attributes={s: str(run / f"attributes/sample/sad/L3/{s}.h5") for s in splits},
                    queries=str(tmp_path / "q.csv"), out=str(tmp_path / "m.json")))
    assert (tmp_path / "q.csv").read_bytes() == (run / "queries/sample/sad/L3.csv").read_bytes()
    logs = sorted(str(p.relative_to(run / "logs")) for p in (run / "logs").rglob("L3.log"))
    assert "metrics/sample/sad/L3.log" in logs and "queries/sample/sad/L3.log" in logs  # two jobs
