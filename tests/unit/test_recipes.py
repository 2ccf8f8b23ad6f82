"""The comparison of what made each output with what the configuration gives now (``pipeline.recipes``), on hand-made
recipes: the sentences are written out here, not taken from the code."""

import json
import os
import time
from pathlib import Path

import pytest

from vpr_smr.core.records import FORMAT
from vpr_smr.pipeline import recipes
from vpr_smr.pipeline.recipes import Job, Recipe, Recipes, differences, portable, record, stale

PREDICTOR = '{"alpha":0.0001,"max_iter":10000,"smote":true}'


def train(predictor=PREDICTOR, **inputs):
    return Recipe("train", {"predictor": predictor, "seeds": "5", "overlap": ""}, dict(inputs))


def test_the_same_recipe_differs_in_nothing():
    assert differences(train(), train()) == []


def test_a_changed_setting_inside_a_json_param_is_named_by_its_key():
    now = train('{"alpha":0.0001,"max_iter":200,"smote":true}')
    assert differences(train(), now) == ["made with predictor.max_iter 10000, the configuration now says 200"]


def test_nested_keys_added_and_removed():
    old = Recipe("report", {"settings": '{"a":{"b":1,"c":[1,2]}}'}, {})
    new = Recipe("report", {"settings": '{"a":{"c":[1,2],"d":"x y"}}'}, {})
    assert differences(old, new) == ["made with settings.a.b 1, the configuration now has none",
                                     "made without settings.a.d, the configuration now says 'x y'"]


def test_plain_params_and_params_that_come_and_go():
    old = Recipe("evaluate", {"modes": "paper standard", "radius": ""}, {})
    new = Recipe("evaluate", {"modes": "paper", "trust": "0.5"}, {})
    assert differences(old, new) == ["made with modes 'paper standard', the configuration now says paper",
                                     "made with radius '', the workflow now has no such setting",
                                     "made without trust, the configuration now says 0.5"]


def test_files_read_from_outside_the_run_folder_by_their_hash():
    old = train(**{"tiny.pt": "a" * 64, "lists/ref.txt": "b" * 64})
    new = train(**{"tiny.pt": "c" * 64, "gt.npy": "d" * 64})
    assert differences(old, new) == ["tiny.pt changed since (SHA-256 aaaaaaaaaaaa..., now cccccccccccc...)",
                                     "made from lists/ref.txt, which it no longer reads",
                                     "made without gt.npy, which it now reads"]


def test_another_rule():
    assert differences(train(), Recipe("speed", {}, {})) == [
        "made by rule train, the workflow now makes it by rule speed"]


def test_paths_are_portable_across_a_moved_project(tmp_path):
    """The same job in the project at two places: the run folder (relative or absolute) and the working folder's
    prefix drop out, so both give one text."""
    texts = []
    for place in ("a", "b"):
        project = tmp_path / place / "proj"
        project.mkdir(parents=True)
        text = (f"train=results/r/attributes/x.h5 ckpt={project}/tiny.pt out={project}/results/r/p.h5 "
                f"other=/data/frames")
        run = project / "results" / "r" if place == "a" else Path("results/r")  # as given: either
        texts.append(portable(text, run, project))
    assert texts[0] == texts[1] == "train={run}/attributes/x.h5 ckpt=tiny.pt out={run}/p.h5 other=/data/frames"


def _job(run, name, recipe):
    return Job((f"{run}/{name}", f"{run}/{name}.json"), recipe)


def test_stale_lists_the_jobs_whose_existing_outputs_differ_or_record_nothing(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    run = Path("results/r")
    run.mkdir(parents=True)
    for name in ("same.h5", "changed.h5", "unrecorded.h5"):
        (run / name).touch()
    now = train('{"alpha":0.0001,"max_iter":200,"smote":true}')
    recorded = {"{run}/same.h5": now, "{run}/changed.h5": train()}
    (run / "recipes.json").write_text(json.dumps(Recipes(recorded).to_json()))
    jobs = [_job(run, name, now) for name in ("same.h5", "changed.h5", "unrecorded.h5", "missing.h5")]
    found = [(item.output, item.reason) for item in stale(jobs, run)]
    assert found == [
        ("results/r/changed.h5", "made with predictor.max_iter 10000, the configuration now says 200"),
        ("results/r/unrecorded.h5", "no record of the settings that made it (results/r/recipes.json has none)"),
    ]


def test_a_record_of_another_results_format_is_no_record(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    run = Path("results/r")
    run.mkdir(parents=True)
    (run / "p.h5").touch()
    (run / "recipes.json").write_text(json.dumps({"format": 3, "outputs": {"{run}/p.h5": train().to_json()}}))
    [item] = stale([_job(run, "p.h5", train())], run)
    assert item.reason == ("no record of the settings that made it that this vpr-smr can read (results/r/recipes.json "
                           f"is in results format 3, this vpr-smr writes results format {FORMAT})")


def test_record_keeps_the_records_of_outputs_this_run_did_not_make(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    run = Path("results/r")
    run.mkdir(parents=True)
    old, new = train(), train('{"max_iter":1}')
    for name in ("kept.h5", "made.h5", "made.h5.json"):
        (run / name).touch()
    os.utime(run / "kept.h5", (1000, 1000))
    (run / "recipes.json").write_text(json.dumps(Recipes({"{run}/kept.h5": old}).to_json()))
    record([_job(run, "kept.h5", new), _job(run, "made.h5", new)], run, since=time.time() - 60)
    outputs = json.loads((run / "recipes.json").read_text())["outputs"]
    assert outputs == {"{run}/kept.h5": old.to_json(), "{run}/made.h5": new.to_json(),
                       "{run}/made.h5.json": new.to_json()}


def test_an_unrecorded_output_that_snakemake_has_a_record_of_is_left_to_snakemake(tmp_path, monkeypatch):
    """Made before vpr-smr recorded recipes: Snakemake's own record judges it; a complete run records it."""
    monkeypatch.chdir(tmp_path)
    run = Path("results/r")
    run.mkdir(parents=True)
    for name in ("old.h5", "old.h5.json"):
        (run / name).touch()
        os.utime(run / name, (1000, 1000))
    job = Job((f"{run}/old.h5", f"{run}/old.h5.json"), train(), snakemake_record=True)
    assert stale([job], run) == []
    record([job], run, since=time.time(), complete=False)
    assert not (run / "recipes.json").exists()
    record([job], run, since=time.time(), complete=True)
    assert json.loads((run / "recipes.json").read_text())["outputs"] == {"{run}/old.h5": train().to_json(),
                                                                          "{run}/old.h5.json": train().to_json()}


def test_a_fault_of_the_comparison_stops_the_run_and_snakemake_s_own_error_is_left_to_it(tmp_path, monkeypatch,
                                                                                        capsys):
    from snakemake.exceptions import WorkflowError

    from vpr_smr.pipeline import workflow

    root = Path(__file__).resolve().parents[2]
    monkeypatch.chdir(root)
    overrides = [f"output={tmp_path}"]

    def broken(*args, **kwargs):
        raise KeyError("a fault of the comparison")

    monkeypatch.setattr(recipes, "workflow_jobs", broken)
    # never a silent "Nothing to be done" with the stale outputs left in place
    with pytest.raises(KeyError, match="a fault of the comparison"):
        workflow.run(root / "configs" / "demo.yaml", dry_run=True, overrides=overrides)

    def snakemake_says(*args, **kwargs):
        raise WorkflowError("no graph of jobs")

    monkeypatch.setattr(recipes, "workflow_jobs", snakemake_says)
    workflow.run(root / "configs" / "demo.yaml", dry_run=True, overrides=overrides)
    assert "warning: the outputs' recorded settings were not compared: no graph of jobs" in capsys.readouterr().err
