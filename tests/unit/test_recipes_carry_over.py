"""Which outputs of an earlier version are carried over (``pipeline.recipes.carried_over``): those whose Snakemake
record lacks params the job has now and whose recorded recipe, in this or an earlier results format, is the job's
recipe now; on hand-made recipes."""

import json
from pathlib import Path

from vpr_smr.core.records import FORMAT
from vpr_smr.pipeline.recipes import Job, Recipe, carried_over, earlier_recipes

DESCRIPTORS = Recipe("descriptors", {"job": '{"dataset":"sample","method":"sad"}'}, {"lists/ref.txt": "a" * 64})
TRAIN = Recipe("train", {"layout": str(FORMAT), "job": '{"max_iter":60}'}, {})


def _setup(tmp_path, monkeypatch, recorded, fmt):
    monkeypatch.chdir(tmp_path)
    run = Path("results/r")
    run.mkdir(parents=True)
    for name in ("d.h5", "d2.h5", "t.h5", "gone.h5"):
        (run / name).touch()
    (run / "gone.h5").unlink()
    (run / "recipes.json").write_text(json.dumps(
        {"format": fmt, "outputs": {f"{{run}}/{name}": recipe.to_json() for name, recipe in recorded.items()}}))
    return run


def test_an_earlier_format_s_equal_recipe_is_carried_over_a_changed_one_is_not(tmp_path, monkeypatch):
    earlier_train = Recipe("train", {**TRAIN.params, "layout": str(FORMAT - 1)}, {})
    run = _setup(tmp_path, monkeypatch, {"d.h5": DESCRIPTORS, "d2.h5": DESCRIPTORS, "t.h5": earlier_train,
                                         "gone.h5": DESCRIPTORS}, FORMAT - 1)
    same = Job((f"{run}/d.h5",), DESCRIPTORS, snakemake_record=True, params_unrecorded=True)
    recorded_by_snakemake = Job((f"{run}/d2.h5",), DESCRIPTORS, snakemake_record=True, params_unrecorded=False)
    new_layout = Job((f"{run}/t.h5",), TRAIN, snakemake_record=True, params_unrecorded=True)
    missing = Job((f"{run}/gone.h5",), DESCRIPTORS, snakemake_record=True, params_unrecorded=True)
    assert carried_over([same, recorded_by_snakemake, new_layout, missing], run) == [same]


def test_every_output_of_a_job_must_be_recorded_with_its_recipe(tmp_path, monkeypatch):
    run = _setup(tmp_path, monkeypatch, {"d.h5": DESCRIPTORS}, FORMAT)
    job = Job((f"{run}/d.h5", f"{run}/d2.h5"), DESCRIPTORS, snakemake_record=True, params_unrecorded=True)
    assert carried_over([job], run) == []


def test_a_changed_file_read_from_outside_is_a_changed_recipe(tmp_path, monkeypatch):
    run = _setup(tmp_path, monkeypatch, {"d.h5": DESCRIPTORS}, FORMAT - 1)
    now = Recipe("descriptors", DESCRIPTORS.params, {"lists/ref.txt": "b" * 64})
    assert carried_over([Job((f"{run}/d.h5",), now, snakemake_record=True, params_unrecorded=True)], run) == []


def test_no_record_or_an_unreadable_one_carries_nothing_over(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    run = Path("results/r")
    run.mkdir(parents=True)
    (run / "d.h5").touch()
    job = Job((f"{run}/d.h5",), DESCRIPTORS, snakemake_record=True, params_unrecorded=True)
    assert earlier_recipes(run) == {} and carried_over([job], run) == []
    for text in ("not json", "[]", '{"format": 6}', '{"format": 6, "outputs": {"{run}/d.h5": {"rule": 1}}}'):
        (run / "recipes.json").write_text(text)
        assert earlier_recipes(run) == {}, text
        assert carried_over([job], run) == []


def test_the_jobs_that_write_a_reduction_rerun_for_a_new_results_format(tmp_path, monkeypatch):
    # results format 8 added the interval of the AOC difference to a from-zero Reduction: a file of 7 lacks it, so the
    # jobs that write Reductions (beside train's, whose evaluations and baselines depend on it) carry the layout, and
    # one recorded in format 7 with a recipe otherwise equal is not carried over
    from vpr_smr.pipeline.experiment import experiment

    assert FORMAT == 8
    assert all(job.layout for name in ("adaptive_seq_len", "matchers", "speed") for job in experiment(name).jobs)
    job = '{"method":"sad"}'
    before = Recipe("adaptive", {"layout": str(FORMAT - 1), "job": job}, {})
    run = _setup(tmp_path, monkeypatch, {"t.h5": before}, FORMAT - 1)
    now = Job((f"{run}/t.h5",), Recipe("adaptive", {"layout": str(FORMAT), "job": job}, {}), snakemake_record=True,
              params_unrecorded=True)
    assert carried_over([now], run) == []
    same = Job((f"{run}/t.h5",), before, snakemake_record=True, params_unrecorded=True)
    assert carried_over([same], run) == [same]  # the same recipe would be: only the layout keeps it out
