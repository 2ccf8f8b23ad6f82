"""An experiment that is only a plugin runs in the demo workflow: the test package ``recall_gain``
(tests/plugins/vpr_smr_recall_gain), seen through PYTHONPATH alone, turned on by name in the configuration's
``experiments:``. Its jobs (one per dataset and method at table_seq_len) run, its table holds the values worked out
here from the attributes files, and report.html shows its section and sentence, with no edit to vpr_smr."""

from __future__ import annotations

import csv
import re
import subprocess
import sys
from pathlib import Path

import h5py
import pytest
import yaml
from experiment_plugin import plugin_env, recall_gain
from run_configs import FRAMES, RANGES

from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT

DEMO = Path(__file__).resolve().parents[2] / "configs" / "demo.yaml"
OFF = ("trust_levels", "restoration", "attribute_ablation", "leave_one_method_out", "seq_len_ablation", "speed",
       "protocol_sweep", "matchers", "adaptive_seq_len")
METHODS = ("sad", "hog")

pytestmark = pytest.mark.slow


def plugin_config(out: Path) -> dict:
    """configs/demo.yaml on 240 frames of the sample with L 3 and 4, SAD and HOG (not the network), the demo's own
    experiments off and the plugin's on."""
    conf = yaml.safe_load(DEMO.read_text())
    sample = conf["datasets"]["nordland_sample"]
    sample.update(root=str(DEFAULT_ROOT), frames=list(FRAMES), splits=RANGES)
    conf.update(run="plugin_experiment", output=str(out), seq_lens=[3, 4], table_seq_len=4, seeds=1,
                methods={name: conf["methods"][name] for name in METHODS}, predictor={"max_iter": 200},
                experiments={**dict.fromkeys(OFF, False), "recall_gain": True})
    return conf


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("plugin_experiment")
    config = tmp / "plugin.yaml"
    config.write_text(yaml.safe_dump(plugin_config(tmp / "results"), sort_keys=False))
    result = subprocess.run([sys.executable, "-m", "vpr_smr.pipeline", "run", str(config), "--cores", "2"],
                            cwd=tmp, env=plugin_env(), capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    return tmp / "results" / "plugin_experiment"


def test_its_jobs_ran(run):
    assert sorted(p.relative_to(run).as_posix() for p in (run / "recall_gain").rglob("*.json")) == [
        f"recall_gain/nordland_sample/{method}/L4.json" for method in sorted(METHODS)]
    for method in METHODS:
        assert (run / f"logs/recall_gain/nordland_sample/{method}/L4.log").is_file()


def test_its_table_holds_the_gain_of_the_attributes_files(run):
    """Each row: the table split's (test) attributes file at L = 4, its single-frame and sequence correctness per
    evaluated query, the paired difference's mean and interval worked out with a loop."""
    with open(run / "tables/recall_gain.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert [(r["dataset"], r["method"], r["seq_len"]) for r in rows] == [
        ("nordland_sample", method, "4") for method in METHODS]  # the configuration's order
    for row in rows:
        with h5py.File(run / f"attributes/nordland_sample/{row['method']}/L4/test.h5") as f:
            single, sequence = f["single_correct"][()], f["sequence_correct"][()]
        gain, low, high = recall_gain(single, sequence)
        assert int(row["n_queries"]) == len(single) == 70 - 3  # the test split's queries a window of 4 evaluates
        assert float(row["recall_single"]) == pytest.approx(sum(map(int, single)) / len(single), abs=1e-12)
        assert float(row["recall_sequence"]) == pytest.approx(sum(map(int, sequence)) / len(sequence), abs=1e-12)
        assert [float(row[name]) for name in ("gain", "gain_low", "gain_high")] == pytest.approx([gain, low, high],
                                                                                                abs=1e-12)
        assert gain != 0  # sequence matching changes some query's match: the table tells them apart


def test_the_report_shows_its_section_and_sentence(run):
    page = (run / "report.html").read_text()
    found = re.search(r'<section id="recall_gain">(.*?)</section>', page, flags=re.S)
    assert found is not None
    section = found.group(1)
    assert "<h2>Recall gain</h2>" in section and "the whole table, 2 rows (tables/recall_gain.csv" in section
    assert ("<p>Sequence matching&#39;s recall@1 minus single-frame matching&#39;s on the same queries, per dataset "
            "and method, with a 95 % normal interval of the paired difference.</p>") in section
