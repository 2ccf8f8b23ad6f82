"""The tool's own experiments are declared as a plugin's are (pipeline.experiment): registered by name in the one
registry, their tables at their place in the report, their jobs' wildcards, outputs and records from the
configuration (the workflow's dry run: the same jobs as the .smk rules they replace, checked by hand on the demo)."""

from __future__ import annotations

import argparse
import json
from dataclasses import dataclass
from pathlib import Path

import pytest
from report_runs import build_run, small_png
from run_configs import plan_once_config

from vpr_smr.core.settings import REQUIRED, setting
from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT
from vpr_smr.eval.report import experiments as reported
from vpr_smr.eval.report.results import WrittenFigure
from vpr_smr.eval.report.table_spec import Figure
from vpr_smr.eval.report.tabulate import Inputs
from vpr_smr.pipeline.config import validate
from vpr_smr.pipeline.experiment import Experiment, Job, Wildcard, experiment, plugin_stages, relative, running
from vpr_smr.pipeline.options import add_options, read_options
from vpr_smr.pipeline.plan import preflight
from vpr_smr.pipeline.stage import Stage, job_text
from vpr_smr.pipeline.stages.studies import ADAPTIVE, COMPARE_MATCHERS, SPEED


def test_the_built_in_experiments_are_registered_by_name_and_are_no_plugins():
    built_in = ["speed", "matchers", "adaptive_seq_len", "protocol_sweep", "trust_levels", "restoration",
                "deployment"]
    assert reported.EXPERIMENTS.builtins() == built_in
    assert [one.name for one in reported.builtin()] == built_in
    assert not {"speed", "matchers", "adaptive_seq_len"} & {one.name for one in reported.installed()}
    # their stages are the command line's own (pipeline.stages): not installed a second time as a plugin's
    assert not {SPEED, COMPARE_MATCHERS, ADAPTIVE} & set(plugin_stages())
    assert [(job.stage, experiment(name).rule_name(job)) for name in ("speed", "matchers", "adaptive_seq_len")
            for job in experiment(name).jobs] == [(SPEED, "speed"), (COMPARE_MATCHERS, "matchers"),
                                                  (ADAPTIVE, "adaptive")]


def test_the_report_keeps_its_tables_and_their_order():
    from vpr_smr.eval.report import registry

    # the order of the report before the experiments were modules (speed was in CORE_TABLES after ablation_seq_len)
    assert [entry.name for entry in registry.TABLES] == [
        "table1", "predictor_methods", "predictor_confusion", "trust_levels", "restoration", "timing", "vpr_metrics",
        "baselines", "wrong_match_detection", "ablation_seq_len", "speed", "predictor", "table2",
        "leave_one_method_out", "protocol_sweep", "adaptive_seq_len", "datasets", "deployment", "matchers"]
    assert registry.table("speed") is experiment("speed").tables[0]
    assert registry.table("speed").names()[:4] == ("dataset", "method", "seq_len", "profile")
    # the table-only experiments' tables keep their files' names and are written with Table I only
    assert registry.table("trust_levels") is experiment("trust_levels").tables[0]
    assert registry.table("restoration") is experiment("restoration").tables[0]
    assert registry.table("trust_levels").experiments == ("table1", "trust_levels")
    assert registry.table("restoration").experiments == ("table1", "restoration")


def test_the_report_keeps_its_figures_and_their_order():
    from vpr_smr.eval.report import registry

    # the order of the report before the experiments declared their figures (registry.FIGURES named them all)
    assert [(entry.name, entry.pattern) for entry in registry.FIGURES] == [
        ("pr", "pr_{dataset}_L{seq_len}_{mode}.png"), ("trust", "trust_{dataset}_L{seq_len}_{mode}.png"),
        ("restoration", "restoration_{dataset}_L{seq_len}_{mode}.png"),
        ("restoration_auc", "restoration_auc_{dataset}_L{seq_len}_{mode}.png"),
        ("confusion", "confusion_{dataset}_L{seq_len}.png"), ("seq_len", "seq_len_{dataset}_{mode}.png"),
        ("adaptive_seq_len", "adaptive_{dataset}_{mode}.png"),
        ("baselines", "baselines_{dataset}_L{seq_len}_{mode}.png"), ("detection", "detection_{dataset}_L{seq_len}.png"),
        ("matchers", "matchers_{dataset}_L{seq_len}_{mode}.png"),
        ("deployment", "deployment_{dataset}_L{seq_len}.png"), ("speed", "speed_{dataset}_L{seq_len}.png"),
        ("protocol_sweep", "protocol_sweep_{dataset}_L{seq_len}_{mode}.png")]
    # each experiment's, declared in its module: those with jobs drawn there, the table-only ones' with the PR curves
    owned = {"trust_levels": ["trust"], "restoration": ["restoration", "restoration_auc"],
             "adaptive_seq_len": ["adaptive_seq_len"], "matchers": ["matchers"], "speed": ["speed"],
             "protocol_sweep": ["protocol_sweep"], "deployment": ["deployment"]}
    for name, figures in owned.items():
        assert [entry.name for entry in experiment(name).figures] == figures
        assert all(registry.figure(entry.name) is entry for entry in experiment(name).figures)
    assert [entry.name for entry in registry.FIGURES if entry.draw is not None] == [
        "adaptive_seq_len", "matchers", "deployment", "speed", "protocol_sweep"]
    assert registry.figure("trust").experiments == ("table1", "trust_levels")
    assert registry.figure("restoration_auc").experiments == ("table1", "restoration")


def _glow_draw(figure: Figure, out_dir: Path, inputs: Inputs) -> list[WrittenFigure]:
    """The test plugin's figure: one file per file of its job (a JSON naming the dataset and L)."""
    out = []
    for path in inputs.experiments.get("glow", ()):
        found = json.loads(Path(path).read_text())
        drawn = small_png(out_dir / figure.file(dataset=found["dataset"], seq_len=found["seq_len"]))
        out.append(WrittenFigure(figure.name, f"{figure.title}: {found['dataset']}", drawn, found["dataset"],
                                 found["seq_len"]))
    return out


GLOW = Figure("glow", "Glow", ("glow",), "glow_{dataset}_L{seq_len}.png", draw=_glow_draw)
GLOW_EXPERIMENT = Experiment("glow", "a plugin's figure", (), (), (GLOW,))


def test_an_experiment_declares_its_figures_and_a_plugins_is_listed_and_drawn(tmp_path, monkeypatch):
    from vpr_smr.eval.report import build, registry

    # a plugin of four arguments declares none; a figure is drawn only with its experiment
    assert Experiment("plain", "no figures", (), ()).figures == ()
    with pytest.raises(ValueError, match="its figure 'glow' has experiments=\\('other',\\), without 'glow'"):
        Experiment("glow", "a plugin's figure", (), (), (Figure("glow", "Glow", ("other",), "glow_{dataset}.png"),))
    with monkeypatch.context() as installed:
        installed.setattr(reported, "installed", lambda: (GLOW_EXPERIMENT,))
        assert registry.plugin_figures() == (GLOW,)
    with pytest.raises(ValueError, match="figures declared twice: glow"):
        registry.collected_figures(GLOW, GLOW)
    # the report's figures: the registry collects the installed experiments' when it is imported, here added
    monkeypatch.setattr(registry, "FIGURES", registry.collected_figures(*registry.FIGURES, GLOW))
    assert registry.figure("glow") is GLOW and registry.FIGURES[-1] is GLOW
    on = registry.expected_outputs(["b", "a"], [2, 4], ["paper"], {"table1", "glow"}, table_seq_lens=[4])
    off = registry.expected_outputs(["b", "a"], [2, 4], ["paper"], {"table1"}, table_seq_lens=[4])
    assert [path for path in on if path not in off] == ["figures/glow_a_L4.png", "figures/glow_b_L4.png"]
    assert [path for path in off if path not in on] == []
    # drawn from the files of the experiment when the run's settings turn it on (build.experiment_files), else not
    job_file = tmp_path / "glow_d.json"
    job_file.write_text(json.dumps({"dataset": "d", "seq_len": 4}))
    monkeypatch.setattr(build, "experiment_files", lambda out_dir, config: {"glow": [job_file]})
    run, written = build_run(tmp_path / "on", seq_lens=(4,), baselines=False, inspector=False, restoration=False)
    assert run / "figures" / "glow_d_L4.png" in written and (run / "figures" / "glow_d_L4.png").is_file()
    monkeypatch.setattr(build, "experiment_files", lambda out_dir, config: {})
    run, written = build_run(tmp_path / "off", seq_lens=(4,), baselines=False, inspector=False, restoration=False)
    assert not [path for path in written if "glow" in str(path)] and not (run / "figures" / "glow_d_L4.png").exists()


def test_the_configuration_switches_a_built_in_experiment_by_its_key():
    from vpr_smr.pipeline.config import experiments

    conf = validate(plan_once_config(DEFAULT_ROOT))  # one seq_len: no adaptive_seq_len; matchers off
    assert [one.name for one in running(experiments(conf))] == ["speed", "protocol_sweep", "trust_levels",
                                                                  "restoration", "deployment"]
    conf = validate({**plan_once_config(DEFAULT_ROOT), "seq_lens": [2, 3],
                     "experiments": {"speed": False, "protocol_sweep": False, "restoration": False}})
    assert [one.name for one in running(experiments(conf))] == ["matchers", "adaptive_seq_len", "trust_levels",
                                                                  "deployment"]
    # trust_levels is off by its key, and without levels to score
    conf = validate({**plan_once_config(DEFAULT_ROOT), "experiments": {"trust_levels": False}})
    assert "trust_levels" not in [one.name for one in running(experiments(conf))]
    conf = validate({**plan_once_config(DEFAULT_ROOT), "trust_levels": []})
    assert "trust_levels" not in [one.name for one in running(experiments(conf))]
    # their tables' rows are the core jobs' (VPR metrics, evaluations): no rule of their own
    assert [experiment(name).jobs for name in ("protocol_sweep", "trust_levels", "restoration")] == [(), (), ()]


def test_a_job_record_is_made_from_the_wildcards_alone():
    conf = validate(plan_once_config(DEFAULT_ROOT))
    plan = preflight(conf)
    job = experiment("speed").jobs[0]
    assert job.wildcards == ("dataset", "seq_len", "profile")
    assert job.output == "speed/{dataset}/L{seq_len}/{profile}.json"
    # the configuration's default profiles, by name
    assert job.constraints(conf, plan) == {"profile": r"0\.5x|0\.75x|1x|1\.25x|1\.5x|2x|varying"}
    record = json.loads(job_text(job.job_record("out/r", conf, plan, {"dataset": "sample", "seq_len": "3",
                                                                      "profile": "2x"})))
    assert record["out"] == "out/r/speed/sample/L3/2x.json"
    assert (record["profile"], record["seq_len"], record["tolerance"]) == ("2x", 3, 2)  # the sample's tolerance
    assert record["train"] == {"sad": "out/r/distances/sample/sad/train.h5",
                               "hog": "out/r/distances/sample/hog/train.h5"}
    assert record["table"] == {"sad": "out/r/distances/sample/sad/test.h5", "hog": "out/r/distances/sample/hog/test.h5"}
    assert job.shell_prefix == "OMP_NUM_THREADS={threads} " and job.layout


def test_adaptive_writes_its_timing_beside_its_result_for_each_matcher_tag():
    conf = validate({**plan_once_config(DEFAULT_ROOT), "seq_lens": [2, 3]})
    plan = preflight(conf)
    job = experiment("adaptive_seq_len").jobs[0]
    assert job.patterns == ("adaptive/{dataset}/{tag}/{method}.json", "adaptive/{dataset}/{tag}/{method}.timing.json")
    assert job.constraints(conf, plan) == {"tag": "seqslam"}  # the run's own matcher only: matchers is off
    record = json.loads(job_text(job.job_record("o", conf, plan, {"dataset": "sample", "tag": "seqslam",
                                                                  "method": "hog"})))
    # per split every length's attributes, seed 0's predictor of each length (5 seeds, the default)
    assert record["attributes"] == {split: [f"o/attributes/sample/hog/L{n}/{split}.h5" for n in (2, 3)]
                                    for split in ("test", "val")}
    assert record["predictors"] == ["o/predictors/sample/L2.h5", "o/predictors/sample/L3.h5"]


@dataclass(frozen=True)
class _Toy:
    """A toy stage's record."""

    out: str = setting(REQUIRED, "the output")


def _toy(job: _Toy) -> None:
    return None


def _record(conf, plan, wildcards, files, out):
    return _Toy(out)


def test_an_output_names_only_known_wildcards_and_a_wildcard_without_values_matches_nothing():
    stage = Stage("toy", "a toy", _Toy, _toy)
    with pytest.raises(ValueError, match=r"names \['tag'\]; an output pattern may name dataset, method, seq_len"):
        Experiment("toy", "a toy", (Job(stage, "toy/{dataset}/{tag}.json", lambda *a: {}, _record),), ())
    job = Job(stage, "toy/{dataset}/{tag}.json", lambda *a: {}, _record,
              wildcards_from=(Wildcard("tag", lambda conf, plan: []),))
    assert job.wildcards == ("dataset", "tag") and job.constraints(None, None) == {"tag": "(?!)"}
    with pytest.raises(ValueError, match="take their values from the configuration record"):
        job.outputs({"datasets": {"d": {}}, "methods": {}, "table_seq_len": 4, "seq_lens": [4]})
    assert Experiment("toy", "a toy", (job,), ()).rule_name(job) == "toy"
    assert relative("/speed/{dataset}.json") == "speed/{dataset}.json"
    with pytest.raises(ValueError, match="with the run folder ''"):
        relative("run/speed.json")


def _toy_table(experiments):
    from vpr_smr.eval.report import rows
    from vpr_smr.eval.report.table_spec import Table

    return Table("toy", "a toy", experiments, row=rows.TrustRow, make=lambda inputs: None)


def test_an_experiment_s_table_is_written_only_when_the_experiment_runs():
    with pytest.raises(ValueError, match=r"its table 'toy' has experiments=\('table1',\), without 'toy'; name the "
                                         r"experiment there \(experiments=\('toy',\)"):
        Experiment("toy", "a toy", (), (_toy_table(("table1",)),))
    # its name, then a further condition: written in a run with Table I's evaluations only
    assert Experiment("toy", "a toy", (), (_toy_table(("table1", "toy")),)).tables[0].experiments == ("table1", "toy")


@dataclass(frozen=True)
class _Aliased:
    """A record with an option of two names."""

    table: str = setting(REQUIRED, "the table split", aliases=("test",))


def test_an_alias_is_the_same_option():
    parser = argparse.ArgumentParser()
    add_options(parser, _Aliased, "g")
    for name in ("--table", "--test"):
        assert read_options(parser.parse_args([name, "a.h5"]), _Aliased, "g") == _Aliased("a.h5")
    assert "--table TEXT, --test TEXT" in parser.format_help()
