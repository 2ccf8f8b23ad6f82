"""Snakemake's own rerun check sees every job record: each rule's params are computed from the wildcards alone.

Snakemake leaves a param made by a function that takes the job's ``input`` or ``output`` (a "deriving function",
``Rule._is_deriving_function``) out of what it compares with its record in ``.snakemake``: a job record made so would
change unseen by a bare ``snakemake`` call, which would keep a stale result.
"""

from __future__ import annotations

import logging
from pathlib import Path
from types import SimpleNamespace

import yaml
from snakemake.api import SnakemakeApi
from snakemake.rules import Rule
from snakemake.settings.types import (
    ConfigSettings,
    DAGSettings,
    ExecutionSettings,
    OutputSettings,
    Quietness,
    ResourceSettings,
)

from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT
from vpr_smr.pipeline.recipes import loaded_workflow
from vpr_smr.pipeline.workflow import SNAKEFILE


def tiny(max_iter: int = 60) -> dict[str, object]:
    """One method on 60 frames of the shipped sample at L = 3, the speed and matchers experiments off."""
    return {"run": "r", "output": "results", "seq_lens": [3], "seeds": 1,
            "datasets": {"sample": {"loader": "nordland_sample", "root": str(DEFAULT_ROOT), "frames": [1000, 1060],
                                    "splits": {"train": [0, 20], "val": [20, 40], "test": [40, 60]}}},
            "methods": {"sad": {"backend": "sad"}}, "predictor": {"max_iter": max_iter},
            "experiments": {"speed": False, "matchers": False}}


def write(folder: Path, conf: dict[str, object]) -> list[str]:
    (folder / "c.yaml").write_text(yaml.safe_dump(conf))
    return [str(folder / "c.yaml")]


def test_no_rule_has_a_param_derived_from_its_input_or_output(tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    with loaded_workflow(SNAKEFILE, write(tmp_path, tiny())) as workflow:
        rules = list(workflow.rules)
        derived = [f"{rule.name}.{name}" for rule in rules for name, item in rule.params._allitems()
                   if Rule._is_deriving_function(item)]
    # every rule of every rule file, those of `use rule` included
    assert {"descriptors", "train", "report", "matcher_train", "matcher_attributes"} <= {rule.name for rule in rules}
    assert derived == [], f"params made from the job's input or output, which Snakemake does not compare: {derived}"


def snakemake_sees(folder: Path, conf: dict[str, object]) -> tuple[set[str], set[str]]:
    """The jobs a dry run of ``conf`` plans, and those whose params differ from Snakemake's record (its params
    trigger, ``persistence.params_changed``), each by its first output relative to the run folder."""
    with loaded_workflow(SNAKEFILE, write(folder, conf), forceall=False) as workflow:
        first = {job: str(job.output[0]).removeprefix("results/r/") for job in workflow.dag.jobs if job.output}
        return ({first[job] for job in workflow.dag.needrun_jobs() if job in first},
                {first[job] for job in first if workflow.persistence.params_changed(job)})


def test_a_setting_that_reaches_a_job_only_through_its_record_reruns_it_under_snakemake(tmp_path,
                                                                                       monkeypatch) -> None:
    """Snakemake's record of every job, as after a run (its `touch` executor records the params of each job it
    marks up to date), then the configuration's predictor.max_iter changed: Snakemake itself names the jobs that
    hand it to their stage (the two that train a predictor, and the report, which shows the configuration),
    and plans them."""
    recorded(tmp_path, monkeypatch)
    assert snakemake_sees(tmp_path, tiny()) == (set(), set())  # up to date: nothing to do

    planned, changed = snakemake_sees(tmp_path, tiny(max_iter=61))
    assert changed == {"predictors/sample/L3.h5", "ablation/attributes/sample/L3.json", "tables/table1.csv"}
    assert changed <= planned


def recorded(tmp_path: Path, monkeypatch) -> None:
    """Every job of ``tiny()`` in ``tmp_path`` recorded by Snakemake as after a run."""
    monkeypatch.chdir(tmp_path)
    with loaded_workflow(SNAKEFILE, write(tmp_path, tiny())) as workflow:
        outputs = [Path(str(f)) for job in workflow.dag.jobs for f in job.output]
    for path in outputs:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.touch()
    quiet = OutputSettings(quiet={Quietness.ALL}, log_level_override=logging.WARNING, enable_file_logging=False)
    with SnakemakeApi(quiet) as api:
        api.workflow(resource_settings=ResourceSettings(cores=1), snakefile=SNAKEFILE,
                     config_settings=ConfigSettings(configfiles=[Path("c.yaml")])).dag(
            DAGSettings(forceall=True)).execute_workflow(executor="touch", execution_settings=ExecutionSettings())


def test_an_installed_scorer_plugin_reruns_the_jobs_that_compute_every_scorer(tmp_path, monkeypatch) -> None:
    """The baselines, metrics, queries and deployment jobs compute every registered scorer: installing a scorer
    plugin changes their param ``scorers`` and no other job's; Snakemake plans them and what reads their files."""
    recorded(tmp_path, monkeypatch)
    plugin = SimpleNamespace(name="mine", load=lambda: None, dist=SimpleNamespace(version="1.2"))
    for where in ("vpr_smr.core.registry", "vpr_smr.eval.scoring.scorers"):  # the registry's, and the versions'
        monkeypatch.setattr(f"{where}.entry_points", lambda group: [plugin] if group == "vpr_smr.scorers" else [])
    planned, changed = snakemake_sees(tmp_path, tiny())
    assert changed == {"baselines/sample/sad/L3.json", "metrics/sample/sad/L3.json",
                       "queries/sample/sad/L3.csv", "deployment/sample/sad/L3.json"}
    # what reads their files: the match inspector (the per-query table) and the report
    assert planned == changed | {"figures/matches_sample_sad_L3.png", "tables/table1.csv"}
