"""A backend whose numbers change in a release computes its descriptors again: its revision is a param of its
descriptors jobs (and of no other backend's)."""

from __future__ import annotations

from pathlib import Path

from vpr_smr.descriptors import BACKENDS, descriptor_revision
from vpr_smr.pipeline.recipes import differences, workflow_jobs

ROOT = Path(__file__).resolve().parents[2]


def test_sad_and_hog_are_at_their_second_revision_every_other_backend_at_its_first() -> None:
    # 0.10.0 computes SAD and HOG by exact rules (the same bytes on every CPU): their numbers moved, nobody else's
    assert {name: descriptor_revision(name) for name in BACKENDS} == {
        name: 2 if name in ("sad", "hog") else 1 for name in BACKENDS}
    assert descriptor_revision("my_plugin") == 1


def test_the_descriptors_jobs_carry_their_backends_revision(monkeypatch) -> None:
    monkeypatch.chdir(ROOT)
    jobs = [job for job in workflow_jobs(ROOT / "pipeline" / "Snakefile", ["configs/demo.yaml"], Path("results/demo"))
            if job.recipe.rule == "descriptors"]
    revisions = {Path(job.outputs[0]).stem: job.recipe.params["revision"] for job in jobs}
    assert revisions == {"sad": "2", "hog": "2", "efficientnet_lite0_gem": "1"}
    # a descriptors file made by the revision before is named stale, with the setting and both values
    hog = next(job for job in jobs if Path(job.outputs[0]).stem == "hog")
    before = type(hog.recipe)(hog.recipe.rule, {**hog.recipe.params, "revision": "1"}, hog.recipe.inputs)
    assert differences(before, hog.recipe) == ["made with revision 1, the configuration now says 2"]
