"""The configuration check runs once per `vpr-smr run`: Snakemake, and every cluster job that parses the workflow,
read the plan it wrote instead of checking (and hashing every checkpoint) again (Snakemake given the plan:
test_plan_once_workflow.py)."""

from __future__ import annotations

import json

import pytest
from run_configs import plan_once_config

from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT
from vpr_smr.pipeline import plan as plan_module
from vpr_smr.pipeline.config import validate
from vpr_smr.pipeline.plan import PLAN_ENV, plan_from_json, plan_to_json, planned, preflight, save_plan


def test_a_saved_plan_is_read_back_for_its_configuration_only(tmp_path, monkeypatch):
    conf = validate(plan_once_config(DEFAULT_ROOT))
    made = preflight(conf)
    assert made.metrics == {"sad": "mad", "hog": "cosine"}  # the backend's default, or the method's setting
    path = save_plan(made, conf, tmp_path)
    assert plan_from_json(json.loads(path.read_text()), conf) == made
    monkeypatch.setenv(PLAN_ENV, str(path))

    def fail(conf: dict) -> None:
        raise AssertionError("checked again")

    monkeypatch.setattr(plan_module, "preflight", fail)
    assert planned(conf) == made
    other = validate({**plan_once_config(DEFAULT_ROOT), "seeds": 2})
    assert plan_from_json(json.loads(path.read_text()), other) is None  # made for another configuration
    with pytest.raises(AssertionError, match="checked again"):
        planned(other)
    assert plan_to_json(made, conf)["config_sha256"] != plan_to_json(made, other)["config_sha256"]


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
