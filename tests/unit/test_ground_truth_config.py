"""A dataset whose ground truth is a file (method §13) in a run's configuration: found from the configuration's
folder, checked before the first job (form, shape, indices, queries without a correct reference), shown on the cards
and passed to the scoring jobs; no speed experiment and no protocol sweep for it."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml
from field_files import band, lists_of, write_json_lists, write_vpr_bench

from vpr_smr.eval.matching.sources import TruthSource
from vpr_smr.pipeline import plan as plan_module
from vpr_smr.pipeline.config import ConfigError, load_config
from vpr_smr.pipeline.plan import dataset_cards, plan_from_json, plan_to_json, preflight
from vpr_smr.pipeline.rule_helpers import ground_truth_input

SPLITS = {"train": [0, 40], "val": [40, 60], "test": [60, 100]}


def write_config(folder, ground_truth, **entry):
    """A configuration file in ``folder``: the shipped sample's 100 frames 1000-1099 (no images written), SAD."""
    path = folder / "run.yaml"
    path.write_text(yaml.safe_dump({
        "run": "r", "output": str(folder / "out"), "seq_lens": [3],
        "datasets": {"sample": {"loader": "nordland_sample", "frames": [1000, 1100], "splits": SPLITS,
                                "ground_truth": ground_truth, **entry}},
        "methods": {"sad": {"backend": "sad"}}}))
    return path


def test_a_relative_file_is_found_from_the_configurations_folder_and_reaches_the_jobs(tmp_path, monkeypatch):
    (tmp_path / "cfg").mkdir()
    np.savez(tmp_path / "cfg" / "GT.npz", GThard=band(100, 100, 1), GTsoft=band(100, 100, 4))
    conf = load_config(write_config(tmp_path / "cfg", {"matrix": "GT.npz", "key": "GThard"}))
    monkeypatch.chdir(tmp_path)  # vpr-smr runs elsewhere: the file is still the configuration's
    plan = preflight(conf)
    given = plan.datasets["sample"].ground_truth
    assert given is not None and given.path == str(tmp_path / "cfg" / "GT.npz") and given.key == "GThard"
    assert plan.datasets["sample"].ground_truth_text == "GT.npz:GThard (a matrix)"
    assert not plan.datasets["sample"].has_tolerance
    assert dataset_cards(plan)["sample"]["ground_truth"] == "GT.npz:GThard (a matrix)"
    assert ground_truth_input(plan, "sample") == [str(tmp_path / "cfg" / "GT.npz")]
    # the jobs' ground truth group: the file and its variable (the tolerance beside them is not used then)
    assert plan.datasets["sample"].truth == TruthSource(tolerance=plan.datasets["sample"].tolerance,
                                                        ground_truth=str(tmp_path / "cfg" / "GT.npz"),
                                                        ground_truth_key="GThard")
    # the plan handed to Snakemake and its jobs reads back the same
    assert plan_from_json(json.loads(json.dumps(plan_to_json(plan, conf))), conf) == plan
    assert plan.warnings == ()  # every query of every split has a correct reference in the band


def test_lists_and_queries_without_a_correct_reference_are_warned_about(tmp_path):
    lists = lists_of(band(100, 100, 2))
    for query in (45, 46, 70):
        lists[query] = []
    write_vpr_bench(tmp_path / "ground_truth_new.npy", lists)
    plan = preflight(load_config(write_config(tmp_path, {"lists": "ground_truth_new.npy"})))
    assert plan.datasets["sample"].ground_truth_text == "ground_truth_new.npy (per-query lists)"
    assert plan.warnings == (
        "datasets.sample: 2 of the 20 queries of split 'val' have no correct reference in ground_truth_new.npy: "
        "they count in every recall and precision, never as correct (method §13)",
        "datasets.sample: 1 of the 40 queries of split 'test' have no correct reference in ground_truth_new.npy: "
        "they count in every recall and precision, never as correct (method §13)")


@pytest.mark.parametrize("ground_truth, write, message", [
    ({"matrix": "missing.npy"}, None, "datasets.sample.ground_truth.matrix: file not found: .*missing.npy"),
    ({"matrix": "gt.json"}, "lists", r"gt.json holds per-query lists: write it as ground_truth: \{lists: \.\.\.\}"),
    ({"lists": "small.npy"}, "small", "ground_truth.lists: .*small.npy.*100 reference and 100 query frames"),
])
def test_bad_files_stop_the_run_before_any_job(tmp_path, ground_truth, write, message):
    if write == "lists":
        write_json_lists(tmp_path / "gt.json", lists_of(band(100, 100, 2)))
    if write == "small":
        np.save(tmp_path / "small.npy", band(90, 100, 2))
    with pytest.raises(ConfigError, match=message):
        preflight(load_config(write_config(tmp_path, ground_truth)))


def test_a_file_and_a_tolerance_together_are_refused(tmp_path):
    np.save(tmp_path / "gt.npy", band(100, 100, 2))
    problems: list[str] = []
    plan_module._check_datasets(load_config(write_config(tmp_path, {"matrix": "gt.npy"}, tolerance=3)), problems)
    assert problems == ["datasets.sample: both ground_truth and tolerance are set; the file says which references "
                        "are correct, so tolerance would be ignored: remove one of them"]


def test_the_schema_takes_one_form(tmp_path):
    with pytest.raises(ConfigError, match="ground_truth"):
        load_config(write_config(tmp_path, {"matrix": "a.npy", "lists": "b.json"}))
    with pytest.raises(ConfigError, match="ground_truth"):
        load_config(write_config(tmp_path, {"key": "GThard"}))
