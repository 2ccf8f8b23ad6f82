"""Changing a setting reruns exactly the jobs that use it, and the tables change where they should, nowhere else.

One complete run of a tiny workflow (two methods, 120 frames of the shipped sample, L = 3) is copied, with its
Snakemake metadata and file times, for each family of settings; the expected jobs are worked out from the
data flow (descriptors -> distances per split -> attributes per split -> one predictor per dataset and L -> one
evaluation and one baselines file per method; Table II from every method's features; a predictor without each
method from the others' train and val features, tested with the pooled one on the method's table split; per
method at the table's L, the VPR metrics (which also depend on the metric modes) and the per-query CSV (which does
not) from its distances, attributes and the seed-0 predictor, and the match inspector from its per-query CSV and
the table split's distances; the speed experiment per profile at the table's L from every method's train and table
distances, the tolerance and the predictor's settings -> report), not from the workflow's own output.
"""

import base64
import csv
import json
import re
import shutil
import subprocess
import sys
import textwrap

import pytest
import torch
import yaml
from helpers import TINY_NET, tiny_net_model

from vpr_smr.core.records import FORMAT
from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT

pytestmark = pytest.mark.slow

BASE = {
    "run": "r",
    "output": "results",
    "seq_lens": [3],
    "seeds": 2,
    "trust_levels": [0.0, 0.5],
    "datasets": {"sample": {"loader": "nordland_sample", "root": str(DEFAULT_ROOT), "frames": [1000, 1120],
                            "splits": {"train": [0, 50], "val": [50, 80], "test": [80, 120]}}},
    "methods": {"sad": {"backend": "sad"}, "tiny": {"backend": "tinynet:TinyNet", "checkpoint": "tiny.pt"}},
    "predictor": {"max_iter": 60},
    "speed": {"profiles": [0.5, "varying"]},  # two profiles: 2x would leave too few train queries of 50 frames
    "experiments": {"matchers": False},  # test_plugin_matcher_workflow.py runs it
}
METHODS = ("sad", "tiny")
PROFILES = ("0.5x", "varying")
SPLITS = ("train", "val", "test")


def write_config(folder, conf):
    (folder / "c.yaml").write_text(yaml.safe_dump(conf))


def vpr_smr(folder, *args, timeout=600):
    env = {"PYTHONPATH": str(folder), "PATH": "/usr/bin:/bin", "OMP_NUM_THREADS": "1"}
    return subprocess.run([sys.executable, "-m", "vpr_smr.pipeline", *args], cwd=folder, env=env,
                          capture_output=True, text=True, timeout=timeout)


def planned(folder):
    """``{(rule, first output)}`` of a dry run (`--verbose`: Snakemake's list of jobs), relative to the run folder."""
    result = vpr_smr(folder, "run", "c.yaml", "-n", "--verbose")
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    jobs = re.findall(r"^rule (\w+):\n(?:    .*\n)*?    output: ([^,\n]+)", result.stdout, flags=re.MULTILINE)
    return {(rule, output.removeprefix("results/r/")) for rule, output in jobs if rule != "all"}


def descriptors(*methods):
    return {("descriptors", f"descriptors/sample/{m}.h5") for m in methods}


def distances(methods=METHODS, splits=SPLITS):
    return {("distances", f"distances/sample/{m}/{s}.h5") for m in methods for s in splits}


def attributes(methods=METHODS, splits=SPLITS, seq_len=3):
    return {("attributes", f"attributes/sample/{m}/L{seq_len}/{s}.h5") for m in methods for s in splits}


def train(seq_len=3):
    return {("train", f"predictors/sample/L{seq_len}.h5")}


def evaluate(methods=METHODS, seq_len=3):
    return {("evaluate", f"evaluation/sample/{m}/L{seq_len}.json") for m in methods}


def attribute_ablation(seq_len=3):
    return {("attribute_ablation", f"ablation/attributes/sample/L{seq_len}.json")}


def without(methods=METHODS, seq_len=3):
    """The leave-one-method-out predictor trained without each of ``methods``."""
    return {("predictor_without", f"predictors/sample/L{seq_len}/without_{m}.h5") for m in methods}


def held_out(methods=METHODS, seq_len=3):
    return {("held_out", f"ablation/without/sample/L{seq_len}/{m}.json") for m in methods}


def metrics(methods=METHODS, seq_len=3):
    """The standard VPR metrics of each method at the table's L."""
    return {("vpr_metrics", f"metrics/sample/{m}/L{seq_len}.json") for m in methods}


def baselines(methods=METHODS, seq_len=3):
    """The training-free baselines of each method at every L (method §12): its distances and attributes, every
    predictor seed, the scorers' settings and the metric modes."""
    return {("baselines", f"baselines/sample/{m}/L{seq_len}.json") for m in methods}


def queries(methods=METHODS, seq_len=3):
    """The per-query CSV of each method at the table's L (its own job: the metric modes do not change it)."""
    return {("queries", f"queries/sample/{m}/L{seq_len}.csv") for m in methods}


def inspect(methods=METHODS, seq_len=3):
    """The match inspector's figures of each method at the table's L."""
    return {("inspect", f"figures/matches_sample_{m}_L{seq_len}.png") for m in methods}


def speed(profiles=PROFILES, seq_len=3):
    """The speed experiment's profiles at the table's L (each reads every method's train and table distances)."""
    return {("speed", f"speed/sample/L{seq_len}/{p}.json") for p in profiles}


def deployment(methods=METHODS, seq_len=3):
    """The experiment deployment of each method at the table's L (method §16): its attributes and distances of the
    calibration and deployment splits, every predictor seed, the scorers' and its own settings."""
    return {("deployment", f"deployment/sample/{m}/L{seq_len}.json") for m in methods}


def adaptive(methods=METHODS):
    """The experiment adaptive_seq_len of each method (two or more seq_lens; the run's matcher, seqslam)."""
    return {("adaptive", f"adaptive/sample/seqslam/{m}.json") for m in methods}


REPORT = {("report", "tables/table1.csv")}


def other(method):
    return [m for m in METHODS if m != method]


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    folder = tmp_path_factory.mktemp("base")
    (folder / "tinynet.py").write_text(TINY_NET)
    torch.manual_seed(0)
    net = tiny_net_model()
    torch.save(net.state_dict(), folder / "tiny.pt")
    write_config(folder, BASE)
    result = vpr_smr(folder, "run", "c.yaml")
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    assert planned(folder) == set()
    return folder


@pytest.fixture
def copy(base, tmp_path):
    folder = tmp_path / "run"
    shutil.copytree(base, folder, symlinks=True)  # copy2 keeps file times: Snakemake sees the same state
    return folder


def change(folder, edit):
    conf = yaml.safe_load((folder / "c.yaml").read_text())
    edit(conf)
    write_config(folder, conf)


def table1(folder):
    with open(folder / "results" / "r" / "tables" / "table1.csv") as handle:
        return {(r["method"], r["mode"]): r for r in csv.DictReader(handle)}


# Everything downstream of the pooled predictor of L = 3: every method's evaluation, baselines (every seed's budget),
# held-out test, VPR metrics (the seed-0 predictor's matcher), per-query CSV (its decisions) and match inspector
# (which reads that CSV)
PREDICTOR_ON = (train() | evaluate() | baselines() | held_out() | metrics() | queries() | inspect() | deployment()
                | REPORT)
ALL_BUT_DESCRIPTORS = distances() | attributes() | attribute_ablation() | without() | PREDICTOR_ON | speed()


@pytest.mark.parametrize(("edit", "expected"), [
    pytest.param(lambda c: c["datasets"]["sample"].update(tolerance=3),
                 attributes() | attribute_ablation() | without() | PREDICTOR_ON | speed(), id="tolerance"),
    # the test split feeds Table II's test F1 and the held-out scores, not the leave-one-out training
    pytest.param(lambda c: c["datasets"]["sample"]["splits"].update(test=[85, 120]),
                 distances(splits=["test"]) | attributes(splits=["test"]) | attribute_ablation() | PREDICTOR_ON
                 | speed(), id="split-range"),
    pytest.param(lambda c: c["datasets"]["sample"].update(frames=[1000, 1121]),
                 descriptors(*METHODS) | ALL_BUT_DESCRIPTORS, id="frames"),
    # the predictor without tiny never reads tiny's files
    pytest.param(lambda c: c["methods"]["tiny"].update(preprocessing="vpr-methods-evaluation"),
                 descriptors("tiny") | distances(["tiny"]) | attributes(["tiny"]) | attribute_ablation()
                 | without(other("tiny")) | PREDICTOR_ON | speed(), id="backend-setting"),
    # the distance changes the distance matrices, not the descriptors: no extraction reruns
    pytest.param(lambda c: c["methods"]["sad"].update(distance="l2"),
                 distances(["sad"]) | attributes(["sad"]) | attribute_ablation()
                 | without(other("sad")) | PREDICTOR_ON | speed(), id="distance"),
    # Table I moves to L = 4 (table_seq_len: 4 when listed), with its ablations; L = 3 stays as it is; with two
    # lengths the experiment adaptive_seq_len runs
    pytest.param(lambda c: c.update(seq_lens=[3, 4]),
                 attributes(seq_len=4) | train(4) | evaluate(seq_len=4) | baselines(seq_len=4) | attribute_ablation(4)
                 | without(seq_len=4) | held_out(seq_len=4) | metrics(seq_len=4) | queries(seq_len=4)
                 | inspect(seq_len=4) | speed(seq_len=4) | adaptive() | deployment(seq_len=4) | REPORT,
                 id="seq-lens"),
    pytest.param(lambda c: c["predictor"].update(max_iter=61),
                 attribute_ablation() | without() | PREDICTOR_ON | speed(), id="predictor"),
    pytest.param(lambda c: c.update(seeds=3), PREDICTOR_ON, id="seeds"),
    # the per-query CSV does not depend on the modes: it and the match inspector that reads it stay as they are
    pytest.param(lambda c: c.update(modes=["paper"]), evaluate() | baselines() | held_out() | metrics() | REPORT,
                 id="modes"),
    pytest.param(lambda c: c.update(trust_levels=[0.0, 0.6]), evaluate() | REPORT, id="trust-levels"),
    pytest.param(lambda c: c["experiments"].update(restoration=False), evaluate() | REPORT, id="restoration-off"),
    pytest.param(lambda c: c["experiments"].update(attribute_ablation=False), REPORT, id="table2-off"),
    # the inspector draws the table split; the metrics and the per-query CSV cover every evaluated split
    # the deployment experiment calibrates on val and deploys on test either way: it stays as it is
    pytest.param(lambda c: c.update(table_split="val"), held_out() | inspect() | speed() | REPORT, id="table-split"),
    # the deployment experiment's own settings (method §16): its jobs and the report
    pytest.param(lambda c: c.update(deployment={"risk": 0.2}), deployment() | REPORT, id="deployment-risk"),
    pytest.param(lambda c: c["experiments"].update(deployment=False), REPORT, id="deployment-off"),
    # the speed experiment's own settings: its jobs (a new profile: that one's) and the report
    pytest.param(lambda c: c["speed"].update(velocities=[1.0, 2.0]), speed() | REPORT, id="speed-velocities"),
    pytest.param(lambda c: c["speed"].update(profiles=[0.5, 1.5, "varying"]), speed(["1.5x"]) | REPORT,
                 id="speed-profiles"),
    pytest.param(lambda c: c["experiments"].update(speed=False), REPORT, id="speed-off"),
    # the run's sequence matcher (method §11): every attributes job and what reads them; the default written out (as 1,
    # or with its name) is the same matcher to every job and to the report, which lists the validated configuration
    # (the matcher's settings complete and canonical): nothing reruns
    pytest.param(lambda c: c.update(sequence_matching={"velocities": [0.8, 1.0, 1.25]}),
                 attributes() | attribute_ablation() | without() | PREDICTOR_ON, id="velocities"),
    pytest.param(lambda c: c.update(sequence_matching={"velocities": [1]}), set(), id="velocity-1-is-1.0"),
    pytest.param(lambda c: c.update(sequence_matching={"matcher": "seqslam"}), set(), id="matcher-named"),
    pytest.param(lambda c: c.update(extraction={"batch_size": 3}), set(), id="batch-size-reruns-nothing"),
    # the training-free scorers' settings (method §12): the jobs that score them; the attributes (and all below) only
    # when the candidates they keep change in number: spread_k 12 keeps max(2 * 5 + 2, 12) = 12 as before,
    # r_window 14 needs 2 * 7 + 2 = 16
    pytest.param(lambda c: c.update(baselines={"spread_k": 12}), baselines() | metrics() | queries() | inspect()
                 | deployment() | REPORT, id="baselines-spread-k"),
    pytest.param(lambda c: c.update(baselines={"r_window": 14}),
                 attributes() | attribute_ablation() | without() | PREDICTOR_ON, id="baselines-r-window"),
])
def test_a_changed_setting_plans_exactly_its_jobs(copy, edit, expected):
    change(copy, edit)
    assert planned(copy) == expected


def test_dataset_root_reruns_everything(copy, tmp_path):
    # The same frames under another root: the descriptors read other files, so everything reruns.
    shutil.copytree(DEFAULT_ROOT, tmp_path / "sample_copy")
    change(copy, lambda c: c["datasets"]["sample"].update(root=str(tmp_path / "sample_copy")))
    assert planned(copy) == descriptors(*METHODS) | ALL_BUT_DESCRIPTORS


def test_checkpoint_content_reruns_its_method(copy):
    torch.manual_seed(1)
    net = tiny_net_model()
    torch.save(net.state_dict(), copy / "tiny.pt")
    assert planned(copy) == (descriptors("tiny") | distances(["tiny"]) | attributes(["tiny"])
                             | attribute_ablation() | without(other("tiny")) | PREDICTOR_ON | speed())


def test_command_line_override_reaches_the_jobs(copy):
    result = vpr_smr(copy, "run", "c.yaml", "-n", "--verbose", "--config", "predictor.max_iter=61")
    assert result.returncode == 0, result.stderr[-3000:]
    rules = set(re.findall(r"^rule (\w+):", result.stdout, flags=re.MULTILINE)) - {"all"}
    assert rules == {"train", "evaluate", "baselines", "attribute_ablation", "predictor_without", "held_out",
                     "vpr_metrics", "queries", "inspect", "speed", "deployment", "report"}


def test_tables_change_where_they_should(copy):
    before = table1(copy)
    change(copy, lambda c: c["methods"]["sad"].update(distance="l2"))
    result = vpr_smr(copy, "run", "c.yaml")
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    after = table1(copy)
    assert set(before) == set(after)
    single_frame = ("recall_at_1_single", "recall_at_1_sequence", "aoc_vpr_sm", "max_recall")
    for (method, mode), row in after.items():
        if method == "tiny":  # its matrices are untouched; only the (shared) predictor changed
            assert {k: row[k] for k in single_frame[:2]} == {k: before[method, mode][k] for k in single_frame[:2]}
    sad_l2 = [after["sad", m]["recall_at_1_sequence"] != before["sad", m]["recall_at_1_sequence"]
              or after["sad", m]["aoc_vpr_sm"] != before["sad", m]["aoc_vpr_sm"] for m in ("paper", "standard")]
    assert any(sad_l2), "SAD with squared L2 instead of the mean absolute difference left its numbers unchanged"
    assert planned(copy) == set()


def test_table_split_changes_only_the_tables(copy):
    evaluations = sorted((copy / "results" / "r" / "evaluation").rglob("*.json"))
    times = [p.stat().st_mtime_ns for p in evaluations]
    change(copy, lambda c: c.update(table_split="val"))
    result = vpr_smr(copy, "run", "c.yaml")
    assert result.returncode == 0, result.stderr[-3000:]
    assert [p.stat().st_mtime_ns for p in evaluations] == times
    md = (copy / "results" / "r" / "tables" / "table1.md").read_text()
    assert "val split" in md or "(val)" in md, textwrap.shorten(md, 300)


def test_outputs_know_their_settings_without_snakemake_state(copy, tmp_path):
    """Without Snakemake's record (`.snakemake` deleted), a changed predictor setting still reruns exactly what it
    changes: every job that hands that setting to its stage is named with why, Snakemake adds what reads their
    files. The project moved to another folder, unchanged, reruns nothing."""
    shutil.rmtree(copy / ".snakemake")
    change(copy, lambda c: c["predictor"].update(max_iter=61))
    result = vpr_smr(copy, "run", "c.yaml", "-n")
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    why = "made with predictor.max_iter 60, the configuration now says 61"
    named = {"predictors/sample/L3.h5", "ablation/attributes/sample/L3.json", "predictors/sample/L3/without_sad.h5",
             "predictors/sample/L3/without_tiny.h5", "speed/sample/L3/0.5x.json", "speed/sample/L3/varying.json"}
    expected = {f"  results/r/{path}: {why}" for path in named}
    # the report hands its stage the whole configuration, the predictor's settings among it
    expected.add(f"  results/r/tables/table1.csv: {why.replace('predictor.', 'settings.predictor.')}")
    lines = [line for line in result.stdout.splitlines() if line.startswith("  results/")]
    assert sorted(lines) == sorted(expected)
    assert "7 jobs made their outputs with other settings or files than the configuration's now" in result.stdout
    assert planned(copy) == attribute_ablation() | without() | PREDICTOR_ON | speed()

    change(copy, lambda c: c["predictor"].update(max_iter=60))
    moved = tmp_path / "elsewhere" / "project"
    moved.parent.mkdir()
    shutil.move(copy, moved)  # a rename: file times kept
    # every absolute path changes: the checkpoint given as one now names the same file at its new place
    change(moved, lambda c: c["methods"]["tiny"].update(checkpoint=str(moved / "tiny.pt")))
    assert not any((moved / ".snakemake" / "metadata").iterdir())  # dry runs record nothing for Snakemake
    result = vpr_smr(moved, "run", "c.yaml", "-n")
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    assert "Nothing to be done" in result.stdout and "results/" not in result.stdout, result.stdout


def as_0_16_left_it(folder):
    """The run folder as 0.16.0 (results format 6) left it: Snakemake's record of each output holds no ``job`` param
    (a function of the job's input or output then, which Snakemake does not store; a str param is stored as its
    repr, a job record's text starts ``'{``), the recipes are in the earlier results format, and the layout param of
    the jobs that have one (in their recipes and in Snakemake's record) names it."""
    earlier = FORMAT - 1
    path = folder / "results" / "r" / "recipes.json"
    recorded = json.loads(path.read_text())
    recorded["format"] = earlier
    # 0.16.0 had no deployment experiment: its files, recipes and Snakemake records are not there
    for output in [o for o in recorded["outputs"] if o.startswith("{run}/deployment/")]:
        del recorded["outputs"][output]
        made = output.replace("{run}", "results/r")
        (folder / made).unlink()
        for record in (folder / ".snakemake" / "metadata").iterdir():
            if base64.b64decode(record.name).decode() == made:
                record.unlink()
    laid_out = set()
    for output, recipe in recorded["outputs"].items():
        if "layout" in recipe["params"]:
            assert recipe["params"]["layout"] == str(FORMAT)
            recipe["params"]["layout"] = str(earlier)
            laid_out.add(output.replace("{run}", "results/r"))
    path.write_text(json.dumps(recorded))
    for path in (folder / ".snakemake" / "metadata").iterdir():
        record = json.loads(path.read_text())
        assert sum(p.startswith("'{") for p in record["params"]) == 1, record["params"]
        params = [p for p in record["params"] if not p.startswith("'{")]
        if base64.b64decode(path.name).decode() in laid_out:
            params = [str(earlier) if p == str(FORMAT) else p for p in params]
        path.write_text(json.dumps({**record, "params": params}))
    return laid_out


# a new results format: the jobs whose files it changes (their layout param) and all below them; every other output
# of the earlier version is kept (two descriptors, six distance and six attribute files)
NEW_FORMAT = attribute_ablation() | without() | PREDICTOR_ON | speed()


def test_an_upgrade_from_0_16_computes_again_only_what_changed(copy):
    laid_out = as_0_16_left_it(copy)
    assert {path.removeprefix("results/r/") for path in laid_out} == {
        "predictors/sample/L3.h5", "predictors/sample/L3.seed1.h5", "predictors/sample/L3.json",
        "ablation/attributes/sample/L3.json", "predictors/sample/L3/without_sad.h5",
        "predictors/sample/L3/without_tiny.h5", "speed/sample/L3/0.5x.json", "speed/sample/L3/varying.json"}
    result = vpr_smr(copy, "run", "c.yaml", "-n")
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    carried = "14 outputs made by an earlier version of vpr-smr with the settings and files of now: carried over"
    assert carried in result.stdout, result.stdout
    assert planned(copy) == NEW_FORMAT
    kept = sorted((copy / "results" / "r" / "descriptors").rglob("*.h5"))
    times = [p.stat().st_mtime_ns for p in kept]
    result = vpr_smr(copy, "run", "c.yaml")
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    assert "carried over" not in result.stdout  # once only
    assert [p.stat().st_mtime_ns for p in kept] == times
    assert planned(copy) == set()


def test_an_upgrade_from_0_16_still_runs_a_changed_setting(copy):
    as_0_16_left_it(copy)
    change(copy, lambda c: c["methods"]["sad"].update(distance="l2"))
    assert planned(copy) == distances(["sad"]) | attributes(["sad"]) | NEW_FORMAT
