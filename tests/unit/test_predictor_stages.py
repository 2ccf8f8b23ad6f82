"""The predictor's stages declared once (pipeline.stages.predictor): every command line of the earlier version parses
to the job record written out by hand, ``--job`` gives the same record back, and the workflow's rules build theirs
from the configuration."""

from __future__ import annotations

import json

import pytest
from stage_jobs import check_old_command, parsed

from vpr_smr.core.settings import parse, to_json
from vpr_smr.eval.predictor.defaults import PredictorParams, PredictorTraining
from vpr_smr.eval.predictor.jobs import AttributeAblationJob, EvaluateJob, HeldOutJob, TrainJob, WithoutJob
from vpr_smr.pipeline.cli import main
from vpr_smr.pipeline.stage import job_text
from vpr_smr.pipeline.stages import stage
from vpr_smr.pipeline.stages.predictor import split_files

PREDICTOR = '{"max_iter": 500, "hidden_layer_sizes": [8, 8]}'
GIVEN = PredictorParams('{"hidden_layer_sizes":[8,8],"max_iter":500}')  # canonical: keys sorted

# each stage's command line as the rules of the earlier version wrote it, and its record written out by hand
OLD_COMMANDS = {
    "train": (
        ["train", "--dataset", "nordland", "--seq-len", "4", "--predictor", PREDICTOR, "--seeds", "3", "--train",
         "a.h5", "b.h5", "--evaluate", "val", "a_val.h5", "b_val.h5", "--evaluate", "test", "a_test.h5", "b_test.h5",
         "--validation", "val", "--out", "L4.h5", "--allow-split-overlap"],
        TrainJob("nordland", 4, ("a.h5", "b.h5"), {"val": ("a_val.h5", "b_val.h5"), "test": ("a_test.h5", "b_test.h5")},
                 PredictorTraining(GIVEN, "val", True), 3, "L4.h5")),
    "evaluate": (
        ["evaluate", "--dataset", "nordland", "--method", "sad", "--seq-len", "4", "--attributes", "val=v.h5",
         "test=t.h5", "--predictors", "L4.h5", "L4.seed1.h5", "--modes", "standard", "--trust-levels",
         "--no-restoration", "--out", "e.json"],
        EvaluateJob("nordland", "sad", 4, {"val": "v.h5", "test": "t.h5"}, ("L4.h5", "L4.seed1.h5"), ("standard",), (),
                    False, False, "e.json")),
    "ablation attributes": (
        ["ablation", "attributes", "--dataset", "nordland", "--seq-len", "4", "--predictor", PREDICTOR, "--train",
         "a.h5", "b.h5", "--evaluate", "val", "a_val.h5", "b_val.h5", "--out", "t2.json"],
        AttributeAblationJob("nordland", 4, GIVEN, ("a.h5", "b.h5"), {"val": ("a_val.h5", "b_val.h5")}, False,
                             "t2.json")),
    "ablation without": (
        ["ablation", "without", "--dataset", "nordland", "--seq-len", "4", "--method", "hog", "--predictor", PREDICTOR,
         "--train", "sad=s.h5", "cnn=c.h5", "--evaluate", "val", "sad=s_val.h5", "cnn=c_val.h5", "--out", "w.h5",
         "--allow-split-overlap"],
        WithoutJob("nordland", 4, "hog", {"sad": "s.h5", "cnn": "c.h5"}, {"val": ("sad=s_val.h5", "cnn=c_val.h5")},
                   PredictorTraining(GIVEN, None, True), "w.h5")),
    "ablation held-out": (
        ["ablation", "held-out", "--dataset", "nordland", "--method", "hog", "--seq-len", "4", "--attributes",
         "t.h5", "--pooled", "L4.h5", "--without", "w.h5", "--modes", "paper", "standard", "--out", "h.json"],
        HeldOutJob("nordland", "hog", 4, "t.h5", "L4.h5", "w.h5", ("paper", "standard"), False, "h.json")),
}


_parsed = parsed


@pytest.mark.parametrize("command", list(OLD_COMMANDS))
def test_the_earlier_command_lines_give_their_records_and_job_gives_them_back(command):
    argv, expected = OLD_COMMANDS[command]
    check_old_command(stage(command), argv, expected)


def test_the_defaults_are_the_earlier_commands():
    _, train = _parsed(["train", "--dataset", "d", "--seq-len", "2", "--train", "a.h5", "--out", "p.h5"])
    assert train == TrainJob("d", 2, ("a.h5",), None, PredictorTraining(PredictorParams("{}"), None, False), 1, "p.h5")
    _, evaluation = _parsed(["evaluate", "--dataset", "d", "--method", "m", "--seq-len", "2", "--attributes",
                             "test=t.h5", "--predictors", "p.h5", "--out", "e.json"])
    assert (evaluation.modes, evaluation.trust_levels, evaluation.restoration) == (
        ("paper", "standard"), (0.0, 0.5, 0.7, 0.9, 1.0), True)
    _, held = _parsed(["ablation", "held-out", "--dataset", "d", "--method", "m", "--seq-len", "2", "--attributes",
                       "t.h5", "--pooled", "p.h5", "--without", "w.h5", "--out", "h.json"])
    assert held.modes == ("paper", "standard") and held.allow_split_overlap is False


def test_the_job_json_holds_the_groups_and_the_given_predictor_settings():
    _, expected = OLD_COMMANDS["train"]
    data = json.loads(job_text(expected))
    assert data["training"] == {"predictor": {"hidden_layer_sizes": [8, 8], "max_iter": 500}, "validation": "val",
                                "allow_split_overlap": True}
    assert data["evaluate"] == {"val": ["a_val.h5", "b_val.h5"], "test": ["a_test.h5", "b_test.h5"]}
    assert parse(TrainJob, data, "--job") == expected and to_json(expected) == data


@pytest.mark.parametrize("argv, message", [
    (["train", "--dataset", "d", "--seq-len", "4", "--train", "a.h5", "--predictor", "{\"layers\": [3]}", "--out",
      "p.h5"], "--predictor.layers: unexpected setting 'layers'"),
    (["train", "--dataset", "d", "--seq-len", "4", "--train", "a.h5", "--predictor", "[1]", "--out", "p.h5"],
     "--predictor must be a JSON object, got [1]"),
    (["train", "--dataset", "d", "--seq-len", "4", "--train", "a.h5", "--predictor", "{", "--out", "p.h5"],
     "--predictor is not valid JSON"),
    (["ablation", "without", "--dataset", "d", "--seq-len", "4", "--method", "m", "--train", "a.h5", "--out",
      "w.h5"], "--train takes METHOD=PATH items, got a.h5"),
    (["ablation", "without", "--dataset", "d", "--seq-len", "4", "--method", "m", "--train", "a=a.h5", "--val",
      "v.h5", "--out", "w.h5"], "--val: removed; the splits take the configuration's names now"),
    (["evaluate", "--dataset", "d", "--method", "m", "--seq-len", "4", "--attributes", "t.h5", "--predictors",
      "p.h5", "--out", "e.json"], "--attributes takes SPLIT=PATH items, got t.h5"),
])
def test_a_wrong_option_is_named(argv, message, capsys):
    assert main(argv) == 2
    assert message in capsys.readouterr().err


def test_the_rules_give_each_split_its_files():
    assert split_files(["check", "final"], ["a c.h5", "b.h5", "c.h5", "d.h5"]) == {
        "check": ("a c.h5", "b.h5"), "final": ("c.h5", "d.h5")}
    assert split_files([], []) == {} and split_files(["check"], []) == {}
    with pytest.raises(ValueError, match="3 files for 2 splits"):
        split_files(["check", "final"], ["a", "b", "c"])
