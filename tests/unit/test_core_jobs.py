"""The core workflow's jobs are declared as the experiments' are (``pipeline.core_jobs``): each rule's name, outputs,
params and shell line come from its ``Job``, its record from the wildcards alone."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT
from vpr_smr.descriptors import descriptor_revision
from vpr_smr.pipeline.config import validate
from vpr_smr.pipeline.core_jobs import JOBS
from vpr_smr.pipeline.experiments.speed import JOB as SPEED_JOB
from vpr_smr.pipeline.plan import planned
from vpr_smr.pipeline.rule_helpers import method_items
from vpr_smr.pipeline.stages.matching import DESCRIPTORS_JOB, DISTANCES_JOB
from vpr_smr.pipeline.stages.predictor import EVALUATE_JOB, TRAIN_JOB, WITHOUT_JOB
from vpr_smr.pipeline.stages.scoring import BASELINES_JOB


def config(**changes: object):
    """Two methods on 60 frames of the shipped sample at L = 3, three seeds."""
    conf = {"run": "r", "output": "results", "seq_lens": [3], "seeds": 3,
            "datasets": {"sample": {"loader": "nordland_sample", "root": str(DEFAULT_ROOT), "frames": [1000, 1060],
                                    "splits": {"train": [0, 20], "val": [20, 40], "test": [40, 60]}}},
            "methods": {"sad": {"backend": "sad"}, "hog": {"backend": "hog"}}, **changes}
    validated = validate(conf)
    return validated, planned(validated)


def test_the_core_rules_keep_their_names():
    # logs, `vpr-smr run --until`, the tests and rules/matchers.smk (`use rule attributes`, `use rule train`) name them
    names = [job.rule for job in JOBS]
    assert sorted(names) == sorted(["descriptors", "distances", "attributes", "inspect", "train", "evaluate",
                                    "attribute_ablation", "predictor_without", "held_out", "baselines",
                                    "vpr_metrics", "queries"])


def test_a_job_s_outputs_and_record_come_from_its_declaration():
    conf, plan = config()
    assert TRAIN_JOB.listed_outputs("R") == []
    assert TRAIN_JOB.named_outputs("R", conf) == {
        "models": ["R/predictors/{dataset}/L{seq_len}.h5", "R/predictors/{dataset}/L{seq_len}.seed1.h5",
                   "R/predictors/{dataset}/L{seq_len}.seed2.h5"],
        "report": "R/predictors/{dataset}/L{seq_len}.json"}
    record = TRAIN_JOB.job_record("R", conf, plan, {"dataset": "sample", "seq_len": "3"})
    assert record.out == "R/predictors/sample/L3.h5" and record.seeds == 3
    assert record.train == ("R/attributes/sample/sad/L3/train.h5", "R/attributes/sample/hog/L3/train.h5")
    assert record.evaluate == {"val": ("R/attributes/sample/sad/L3/val.h5", "R/attributes/sample/hog/L3/val.h5"),
                               "test": ("R/attributes/sample/sad/L3/test.h5", "R/attributes/sample/hog/L3/test.h5")}
    assert EVALUATE_JOB.named_outputs("R", conf) == {
        "evaluation": "R/evaluation/{dataset}/{method}/L{seq_len}.json",
        "timing": "R/evaluation/{dataset}/{method}/L{seq_len}.timing.json"}
    assert DISTANCES_JOB.listed_outputs("R") == ["R/distances/{dataset}/{method}/{split}.h5"]


def test_the_split_wildcard_matches_the_configured_splits():
    conf, plan = config()
    assert DISTANCES_JOB.constraints(conf, plan) == {"split": "train|val|test"}


def test_the_params_and_shell_line_of_a_rule():
    conf, plan = config()
    assert list(TRAIN_JOB.rule_params("R", conf, plan)) == ["layout", "job"]
    params = DESCRIPTORS_JOB.rule_params("R", conf, plan)
    assert list(params) == ["job", "revision"]
    assert params["revision"]({"dataset": "sample", "method": "sad"}) == descriptor_revision("sad")
    # the descriptors stage takes its threads itself; a job with threads and no such option gets its BLAS threads
    assert DESCRIPTORS_JOB.shell_prefix == "" and DESCRIPTORS_JOB.speed == "--threads {threads} {resources.extraction}"
    assert SPEED_JOB.shell_prefix == "OMP_NUM_THREADS={threads} "
    assert DESCRIPTORS_JOB.rule_resources(conf) == {"gpu": 1, "extraction": ""}
    assert TRAIN_JOB.rule_resources(conf) == {}


def test_the_jobs_that_compute_every_scorer_depend_on_the_registered_scorers(monkeypatch):
    """An installed scorer plugin changes the param ``scorers`` of the baselines, metrics and queries jobs (which
    compute every registered scorer) and of no other job, so that Snakemake and vpr-smr run compute them again."""
    conf, plan = config()
    wildcards = {"dataset": "sample", "method": "sad", "seq_len": "3", "split": "val"}

    def scorer_params():
        return {job.rule: params["scorers"](wildcards) for job in JOBS
                for params in [job.rule_params("R", conf, plan)] if "scorers" in params}

    built_in = "uniqueness,single_uniqueness,spread,distance,native,random,oracle,predictor"
    assert scorer_params() == dict.fromkeys(["baselines", "vpr_metrics", "queries"], built_in)
    assert list(BASELINES_JOB.rule_params("R", conf, plan)) == ["job", "scorers"]
    plugin = SimpleNamespace(name="mine", load=lambda: None, dist=SimpleNamespace(version="1.2"))
    for where in ("vpr_smr.core.registry", "vpr_smr.eval.scoring.scorers"):  # the registry's, and the versions'
        monkeypatch.setattr(f"{where}.entry_points", lambda group: [plugin] if group == "vpr_smr.scorers" else [])
    assert scorer_params() == dict.fromkeys(
        ["baselines", "vpr_metrics", "queries"],
        "uniqueness,single_uniqueness,spread,distance,native,mine==1.2,random,oracle,predictor")


def test_a_job_s_own_param_may_not_take_a_name_the_rule_has():
    from dataclasses import replace

    conf, plan = config()
    clash = replace(BASELINES_JOB, params=(("job", lambda conf, plan, wildcards: "x"),))
    with pytest.raises(ValueError, match="its params name 'job', a param the rule has already \\(job\\)"):
        clash.rule_params("R", conf, plan)


@pytest.mark.parametrize("splits", [["val", "test"], ["test"]])
def test_the_predictor_without_a_method_scores_the_validation_split_where_there_is_one(splits):
    conf, plan = config(eval_splits=splits, table_split="test")
    record = WITHOUT_JOB.job_record("R", conf, plan, {"dataset": "sample", "seq_len": "3", "method": "sad"})
    assert record.train == {"hog": "R/attributes/sample/hog/L3/train.h5"}
    assert record.evaluate == ({"val": ("hog=R/attributes/sample/hog/L3/val.h5",)} if "val" in splits else {})
    assert method_items(["sad", "hog"], "sad", []) == []


def test_each_rule_runs_its_own_shell_line(tmp_path, monkeypatch):
    """Snakemake evaluates a rule's ``shell:`` again when its job runs (its run function calls ``shell(...)``): each
    rule of the declared jobs runs its own stage, not the last declared one's."""
    import inspect

    import yaml

    from vpr_smr.pipeline.recipes import loaded_workflow
    from vpr_smr.pipeline.workflow import SNAKEFILE

    monkeypatch.chdir(tmp_path)
    conf = {"run": "r", "output": "results", "seq_lens": [3, 4], "table_seq_len": 3, "seeds": 1,
            "datasets": {"sample": {"loader": "nordland_sample", "root": str(DEFAULT_ROOT), "frames": [1000, 1060],
                                    "splits": {"train": [0, 20], "val": [20, 40], "test": [40, 60]}}},
            "methods": {"sad": {"backend": "sad"}, "hog": {"backend": "hog"}}}
    (tmp_path / "c.yaml").write_text(yaml.safe_dump(conf))
    with loaded_workflow(SNAKEFILE, [str(tmp_path / "c.yaml")]) as workflow:
        ran: dict[str, str] = {}
        for rule in workflow.rules:
            if not rule.shellcmd:
                continue
            run = rule.run_func
            monkeypatch.setitem(run.__globals__, "shell", lambda cmd, name=rule.name, **_: ran.__setitem__(name, cmd))
            run(**{name: None for name in inspect.signature(run).parameters if not name.startswith("__")})
            assert ran[rule.name] == rule.shellcmd, rule.name
        assert {"descriptors", "train", "speed", "adaptive", "matchers", "report"} <= set(ran)


def test_the_matchers_comparison_depends_on_the_registered_scorers_too():
    # it picks the best training-free scorer among every registered one, as the baselines job does
    from vpr_smr.pipeline.experiments import matchers
    from vpr_smr.pipeline.stages.scoring import SCORERS_PARAM

    assert matchers.JOB.params == SCORERS_PARAM
