"""The stages speed, compare-matchers, adaptive and report declared once (``pipeline.stages.studies``,
``reporting``): each earlier command line parses to the job record written out by hand, and ``--job`` (the rules'
form) reads ``job_text`` of it back to the same record."""

from __future__ import annotations

import json
from types import SimpleNamespace

import pytest

from vpr_smr.core.json_objects import JsonObject
from vpr_smr.eval.matching.matchers import MatcherSpec
from vpr_smr.eval.matching.sources import TruthSource
from vpr_smr.eval.predictor.defaults import PredictorParams
from vpr_smr.eval.report.job import ReportJob, RunFiles
from vpr_smr.eval.scoring.adaptive import AdaptiveJob
from vpr_smr.eval.scoring.matcher_comparison import ComparedInputs, MatcherInputs, MatchersJob
from vpr_smr.eval.scoring.scorers import BaselineSettings
from vpr_smr.eval.scoring.speed import SpeedJob
from vpr_smr.pipeline.cli import build_parser
from vpr_smr.pipeline.rule_helpers import length_files, report_files
from vpr_smr.pipeline.stage import JOB, job_of, job_text
from vpr_smr.pipeline.stages import reporting, studies


def parsed(argv: list[str]):
    """The job of a command line, as ``vpr-smr`` reads it (the stage's check first, then its options or --job)."""
    args = build_parser(job=JOB in argv).parse_args(argv)
    if args.stage.check is not None:
        args.stage.check(args)
    return job_of(args.stage, args)


def round_trip(command: str, job):
    return parsed([command, JOB, job_text(job)])


# --- speed -------------------------------------------------------------------------------------------------------

SPEED_ARGV = ["speed", "--dataset", "d", "--seq-len", "4", "--profile", "2x", "--velocities", "0.5", "1", "2",
              "--tolerance", "3", "--train", "sad=tr_sad.h5", "netvlad=tr_nv.h5", "--table", "sad=te_sad.h5",
              "netvlad=te_nv.h5", "--predictor", '{"max_iter": 50, "hidden_layer_sizes": [8]}', "--out", "s.json",
              "--allow-split-overlap"]
SPEED_JOB = SpeedJob("d", 4, "2x", (0.5, 1.0, 2.0), 3, {"sad": "tr_sad.h5", "netvlad": "tr_nv.h5"},
                     {"sad": "te_sad.h5", "netvlad": "te_nv.h5"},
                     PredictorParams.of({"max_iter": 50, "hidden_layer_sizes": [8]}), True, "s.json")


def test_speeds_command_line_is_its_job():
    job = parsed(SPEED_ARGV)
    assert job == SPEED_JOB
    assert list(job.train) == ["sad", "netvlad"]  # the pooled training order is kept
    assert job.predictor.values == {"hidden_layer_sizes": [8], "max_iter": 50}
    assert round_trip("speed", SPEED_JOB) == SPEED_JOB


def test_speeds_test_option_is_its_table_option():
    argv = [("--test" if word == "--table" else word) for word in SPEED_ARGV]
    assert argv != SPEED_ARGV and parsed(argv) == SPEED_JOB


def test_speeds_defaults():
    job = parsed(["speed", "--dataset", "d", "--seq-len", "4", "--profile", "varying", "--train", "a=t.h5",
                  "--table", "a=u.h5", "--out", "s.json"])
    assert job.velocities == (0.5, 0.595, 0.707, 0.841, 1.0, 1.189, 1.414, 1.682, 2.0)
    assert (job.tolerance, job.predictor.values, job.allow_split_overlap) == (2, {}, False)


# --- compare-matchers --------------------------------------------------------------------------------------------

INPUTS = {"matchers": [{"matcher": {"name": "seqslam", "settings": {"velocities": [1.0]}},
                        "attributes": {"test": {"sad": "a_test.h5"}, "val": {"sad": "a_val.h5"}},
                        "predictors": ["p0.h5", "p1.h5"]},
                       {"matcher": {"name": "seqslam", "settings": {"velocities": [0.5, 1.0]}},
                        "attributes": {"test": {"sad": "b_test.h5"}, "val": {"sad": "b_val.h5"}},
                        "predictors": ["q0.h5", "q1.h5"]}],
          "fixed": {"matcher": {"name": "seqslam", "settings": {"velocities": [1.0]}},
                    "attributes": {"val": {"sad": "a_val.h5"}}}}


def test_compare_matchers_command_line_is_its_job(tmp_path):
    (tmp_path / "inputs.json").write_text(json.dumps(INPUTS))
    argv = ["compare-matchers", "--dataset", "d", "--method", "sad", "--seq-len", "4", "--inputs",
            f"@{tmp_path / 'inputs.json'}", "--distances", "sad=test.h5", "--split", "test", "--validation", "val",
            "--tolerance", "1", "--radius", "5", "--ground-truth", "gt.npz", "--ground-truth-key", "GThard",
            "--r-window", "6", "--spread-k", "4", "--modes", "paper", "--out", "m.json"]
    fixed = MatcherInputs(MatcherSpec.of("seqslam", {"velocities": [1.0]}), {"val": {"sad": "a_val.h5"}}, ())
    compared = (MatcherInputs(MatcherSpec.of("seqslam", {"velocities": [1.0]}),
                              {"test": {"sad": "a_test.h5"}, "val": {"sad": "a_val.h5"}}, ("p0.h5", "p1.h5")),
                MatcherInputs(MatcherSpec.of("seqslam", {"velocities": [0.5, 1.0]}),
                              {"test": {"sad": "b_test.h5"}, "val": {"sad": "b_val.h5"}}, ("q0.h5", "q1.h5")))
    expected = MatchersJob("d", "sad", 4, ComparedInputs(compared, fixed), {"sad": "test.h5"}, "test", "val",
                           TruthSource(tolerance=1, radius=5.0, ground_truth="gt.npz", ground_truth_key="GThard"),
                           BaselineSettings(r_window=6, spread_k=4), ("paper",), False, "m.json")
    job = parsed(argv)
    assert job == expected
    assert argv[7:9] == ["--inputs", f"@{tmp_path / 'inputs.json'}"]
    assert parsed([*argv[:8], json.dumps(INPUTS), *argv[9:]]) == job  # the JSON text itself
    assert job.inputs.to_setting() == INPUTS  # what the rule gives is what the job holds
    assert round_trip("compare-matchers", expected) == expected


def test_compare_matchers_refuses_inputs_without_matchers():
    with pytest.raises(ValueError, match='"matchers" must be a non-empty list'):
        parsed(["compare-matchers", "--dataset", "d", "--method", "sad", "--seq-len", "4", "--inputs", "{}",
                "--distances", "sad=t.h5", "--split", "test", "--out", "m.json"])


# --- adaptive ----------------------------------------------------------------------------------------------------

ADAPTIVE_JOB = AdaptiveJob({"test": ("L2/test.h5", "L4/test.h5"), "val": ("L2/val.h5", "L4/val.h5")},
                           ("L2.h5", "L4.h5"), 3, "test", "val", "test_d.h5", "d", "sad", "seqslam",
                           BaselineSettings(), ("paper", "standard"), True, "adaptive.json")
ADAPTIVE_REST = ["--predictors", "L2.h5", "L4.h5", "--seeds", "3", "--split", "test", "--validation", "val",
                 "--distances", "test_d.h5", "--dataset", "d", "--method", "sad", "--matcher-tag", "seqslam",
                 "--allow-split-overlap", "--out", "adaptive.json"]


def test_adaptives_command_line_in_either_form_is_its_job():
    old = ["adaptive", "--attributes", "test=L2/test.h5", "test=L4/test.h5", "val=L2/val.h5", "val=L4/val.h5",
           *ADAPTIVE_REST]
    new = ["adaptive", "--attributes", "test", "L2/test.h5", "L4/test.h5", "--attributes", "val", "L2/val.h5",
           "L4/val.h5", *ADAPTIVE_REST]
    assert parsed(old) == parsed(new) == ADAPTIVE_JOB
    assert round_trip("adaptive", ADAPTIVE_JOB) == ADAPTIVE_JOB


def test_adaptive_refuses_a_split_given_in_both_forms():
    with pytest.raises(ValueError, match="given twice"):
        parsed(["adaptive", "--attributes", "test", "a.h5", "--attributes", "test=b.h5", "--predictors", "p.h5",
                "--split", "test", "--out", "a.json"])


# --- report ------------------------------------------------------------------------------------------------------


def test_reports_command_line_is_its_job(tmp_path):
    (tmp_path / "datasets.json").write_text(json.dumps({"d": {"frames": 10}}))
    argv = ["report", "--evaluations", "e1.json", "e2.json", "--predictors", "p.json", "--baselines", "b.json",
            "--timings", "t.json", "--attribute-ablations", "--leave-one-out", "--metrics", "m.json", "--speed",
            "--matchers", "--adaptive", "a.json", "--descriptors", "x.h5", "--match-figures", "--matrix-figures",
            "--split", "test", "--eval-splits", "val", "test", "--train-split", "train", "--table-seq-lens", "4",
            "--seq-len-ablation", "--settings", '{"run": "r", "seq_lens": [2, 4]}', "--datasets",
            f"@{tmp_path / 'datasets.json'}", "--out", "run"]
    files = RunFiles(evaluations=("e1.json", "e2.json"), predictors=("p.json",), timings=("t.json",),
                     metrics=("m.json",), baselines=("b.json",), descriptors=("x.h5",), adaptive=("a.json",))
    expected = ReportJob(files, "test", ("val", "test"), "train", (4,), True,
                         JsonObject({"run": "r", "seq_lens": [2, 4]}), JsonObject({"d": {"frames": 10}}), "run")
    assert parsed(argv) == expected
    assert round_trip("report", expected) == expected


def test_reports_settings_not_given_are_none():
    job = parsed(["report", "--evaluations", "e.json", "--predictors", "p.json", "--out", "run"])
    assert (job.settings.to_dict(), job.datasets.to_dict(), job.table_seq_lens, job.split) == (None, None, None, None)


# --- the rules' helpers and the stages' lines ---------------------------------------------------------------------


def test_length_files_keep_each_splits_files_in_order():
    assert length_files([("test", ["a", "b"]), (None, []), ("val", [])]) == {"test": ("a", "b")}
    assert length_files([("test", ["a"]), ("val", ["c"]), ("test", ["b"])]) == {"test": ("a", "b"), "val": ("c",)}


def test_report_files_take_the_rules_named_inputs():
    given = SimpleNamespace(**{name: [] for name in RunFiles.__dataclass_fields__})
    given.evaluations, given.speed = ["e.json"], ["s1.json", "s2.json"]
    assert report_files(given) == RunFiles(evaluations=("e.json",), speed=("s1.json", "s2.json"))


def test_the_stages_keep_their_commands():
    assert [stage.command for stage in studies.STAGES + reporting.STAGES] == [
        "speed", "compare-matchers", "adaptive", "deployment", "report"]
    summary = studies.SPEED.summary
    assert summary is not None
    result = SimpleNamespace(matchers={"fixed": SimpleNamespace(methods={"a": SimpleNamespace(
        recall_at_1_sequence=0.25)}), "velocity": SimpleNamespace(methods={"a": SimpleNamespace(
            recall_at_1_sequence=0.5)})}, meta={"mode": "paper"})
    assert summary(SPEED_JOB, result) == ("the speed profile 2x to s.json: sequence recall@1 0.2500 to 0.5000 over 2 "
                                          "matchers x 1 methods (paper mode, seed 0)")
    report = reporting.REPORT.summary
    assert report is not None
    assert report(parsed(["report", "--out", "run"]), ["a", "b", "c"]) == "3 tables, figures and report files under run"
