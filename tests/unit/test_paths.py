"""Every output path of a run (core/paths.py) against its file name written out by hand, and the report's registry
of tables and figures (eval/report/registry.py) against what a small report run writes."""

import html
from pathlib import Path

import pytest

from vpr_smr.core import paths
from vpr_smr.eval.report import registry
from vpr_smr.eval.report.registry import expected_outputs

RUN = "results/demo run"  # a space, as a user's output folder may hold

ALL_EXPERIMENTS = {"table1", "predictor", "trust_levels", "restoration", "seq_len", "attributes",
                   "leave_one_method_out", "speed", "protocol_sweep", "matchers", "adaptive_seq_len", "deployment"}


def test_each_output_kind_has_its_file_name():
    assert paths.descriptors_path(RUN, "nordland", "sad") == "results/demo run/descriptors/nordland/sad.h5"
    assert paths.distances_path(RUN, "nordland", "sad", "test") == "results/demo run/distances/nordland/sad/test.h5"
    assert (paths.attributes_path(RUN, "nordland", "sad", 4, "val")
            == "results/demo run/attributes/nordland/sad/L4/val.h5")
    assert paths.predictor_path(RUN, "nordland", 4) == "results/demo run/predictors/nordland/L4.h5"
    assert (paths.without_predictor_path(RUN, "nordland", 4, "sad")
            == "results/demo run/predictors/nordland/L4/without_sad.h5")
    assert paths.evaluation_path(RUN, "nordland", "sad", 4) == "results/demo run/evaluation/nordland/sad/L4.json"
    assert (paths.attribute_ablation_path(RUN, "nordland", 4)
            == "results/demo run/ablation/attributes/nordland/L4.json")
    assert paths.held_out_path(RUN, "nordland", 4, "sad") == "results/demo run/ablation/without/nordland/L4/sad.json"
    assert (paths.matcher_attributes_path(RUN, "nordland", "bayes_filter", "sad", 4, "val")
            == "results/demo run/matchers/nordland/bayes_filter/attributes/sad/L4/val.h5")
    assert (paths.matcher_predictor_path(RUN, "nordland", "monotone-0123abcd", 4)
            == "results/demo run/matchers/nordland/monotone-0123abcd/predictors/L4.h5")
    assert paths.matchers_path(RUN, "nordland", "sad", 4) == "results/demo run/matchers/nordland/sad/L4.json"
    assert paths.speed_path(RUN, "nordland", 4, "0.5x") == "results/demo run/speed/nordland/L4/0.5x.json"
    assert paths.report_log_path(RUN) == "results/demo run/logs/report.log"


def test_files_beside_another_are_named_from_it():
    assert paths.predictor_paths(RUN, "nordland", 4, 1) == ["results/demo run/predictors/nordland/L4.h5"]
    assert paths.predictor_paths(RUN, "nordland", 4, 3) == [
        "results/demo run/predictors/nordland/L4.h5", "results/demo run/predictors/nordland/L4.seed1.h5",
        "results/demo run/predictors/nordland/L4.seed2.h5"]
    # a stage given its --out as a Path (any HDF5 or JSON suffix) derives the same names
    assert paths.seed_predictor_path(Path("out/L4.h5"), 2) == "out/L4.seed2.h5"
    assert paths.seed_predictor_path("out/L4.HDF5", 2) == "out/L4.seed2.h5"
    assert paths.predictor_report_path(Path("out/L4.h5")) == "out/L4.json"
    assert paths.predictor_report_path("results/demo run/predictors/d/L4/without_sad.h5") == (
        "results/demo run/predictors/d/L4/without_sad.json")
    assert paths.timing_path(Path("out/L4.json")) == "out/L4.timing.json"
    assert paths.timing_path(RUN + "/evaluation/d/sad/L4.json") == "results/demo run/evaluation/d/sad/L4.timing.json"


def test_a_jobs_log_mirrors_its_output():
    cases = {
        paths.descriptors_path(RUN, "d", "sad"): "logs/descriptors/d/sad.log",
        paths.distances_path(RUN, "d", "sad", "test"): "logs/distances/d/sad/test.log",
        paths.attributes_path(RUN, "d", "sad", 3, "test"): "logs/attributes/d/sad/L3/test.log",
        paths.predictor_path(RUN, "d", 3): "logs/predictors/d/L3.log",
        paths.without_predictor_path(RUN, "d", 3, "sad"): "logs/predictors/d/L3/without_sad.log",
        paths.evaluation_path(RUN, "d", "sad", 3): "logs/evaluation/d/sad/L3.log",
        paths.attribute_ablation_path(RUN, "d", 3): "logs/ablation/attributes/d/L3.log",
        paths.held_out_path(RUN, "d", 3, "sad"): "logs/ablation/without/d/L3/sad.log",
        paths.speed_path(RUN, "d", 3, "varying"): "logs/speed/d/L3/varying.log",
    }
    for output, log in cases.items():
        assert paths.log_path(RUN, output) == f"{RUN}/{log}"
    with pytest.raises(ValueError, match="not under the run folder"):
        paths.log_path(RUN, "elsewhere/descriptors/d/sad.h5")


def test_rules_pass_wildcards_through():
    """The Snakemake rules call the functions with wildcard strings: they come back in place, braces single."""
    assert (paths.attributes_path("out", "{dataset}", "{method}", "{seq_len}", "{split}")
            == "out/attributes/{dataset}/{method}/L{seq_len}/{split}.h5")
    assert paths.predictor_paths("out", "{dataset}", "{seq_len}", 2) == [
        "out/predictors/{dataset}/L{seq_len}.h5", "out/predictors/{dataset}/L{seq_len}.seed1.h5"]
    assert (paths.timing_path(paths.evaluation_path("out", "{dataset}", "{method}", "{seq_len}"))
            == "out/evaluation/{dataset}/{method}/L{seq_len}.timing.json")
    assert (paths.log_path("out", paths.held_out_path("out", "{dataset}", "{seq_len}", "{method}"))
            == "out/logs/ablation/without/{dataset}/L{seq_len}/{method}.log")


def test_expected_outputs_of_one_experiment_in_order():
    assert expected_outputs(["d"], [2, 4], ["paper"], {"table1"}, table_seq_lens=[4]) == [
        *[f"tables/{name}.{ext}" for name in ("table1", "predictor_methods", "predictor_confusion", "timing")
          for ext in ("csv", "md", "tex")],
        "figures/pr_d_L4_paper.png", "figures/confusion_d_L4.png", "report.html"]
    assert expected_outputs(["d"], [4], ["paper"], {"predictor", "attributes"}, html=False) == [
        "tables/predictor.csv", "tables/predictor.md", "tables/predictor.tex",
        "tables/table2.csv", "tables/table2.md", "tables/table2.tex"]


def test_a_report_run_writes_exactly_the_registry(full_report_run):
    # every experiment: dataset d, L 2 and 4 (tables and figures at L 4)
    run, written = full_report_run
    written = sorted(str(p.relative_to(run)) for p in written)
    tables = ("table1", "predictor_methods", "predictor_confusion", "trust_levels", "restoration", "timing",
              "vpr_metrics", "baselines", "wrong_match_detection", "ablation_seq_len", "speed", "predictor", "table2",
              "leave_one_method_out", "protocol_sweep", "adaptive_seq_len", "datasets", "deployment", "matchers")
    by_hand = (
        [f"tables/{name}.{ext}" for name in tables for ext in ("csv", "md", "tex")]
        + [f"figures/{kind}_d_L4_{mode}.png" for kind in ("pr", "trust", "restoration", "restoration_auc", "baselines",
                                                            "protocol_sweep", "matchers")
           for mode in ("paper", "standard")]
        + ["figures/confusion_d_L4.png", "figures/seq_len_d_paper.png", "figures/seq_len_d_standard.png",
           "figures/adaptive_d_paper.png", "figures/adaptive_d_standard.png",
           "figures/speed_d_L4.png", "figures/detection_d_L4.png", "figures/deployment_d_L4.png", "report.html"]
    )
    assert written == sorted(by_hand)
    assert written == sorted(expected_outputs(["d"], [2, 4], ["paper", "standard"],
                                              ALL_EXPERIMENTS | {"metrics", "datasets", "baselines"},
                                              table_seq_lens=[4]))
    assert [spec.name for spec in registry.TABLES] == list(tables)
    for spec in registry.FIGURES:  # each registered figure was written at least once
        prefix = spec.pattern.split("{")[0]
        assert any(Path(p).name.startswith(prefix) for p in written if p.startswith("figures/")), spec.name
    page = (run / "report.html").read_text()
    for spec in registry.TABLES:  # the page folds each whole table under its registered title
        assert f"<summary>{html.escape(spec.title)}: the whole table" in page


def test_an_unregistered_table_or_figure_is_refused():
    with pytest.raises(KeyError, match="not in eval/report/registry.py"):
        registry.table("table3")
    with pytest.raises(KeyError, match="not in eval/report/registry.py"):
        registry.figure("roc")
