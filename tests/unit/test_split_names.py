"""Split names are the user's: the configuration takes any names but the reserved ones, the rules and commands give
each split by its name (the workflow on real frames with the splits renamed: test_split_names_workflow.py)."""

from __future__ import annotations

import pytest
from run_configs import RENAMED, split_names_config

# --- the pieces, quickly ------------------------------------------------------------------------------------------


def test_the_validation_split_is_the_first_evaluation_split():
    from vpr_smr.eval.predictor.defaults import ablation_splits, validation_split

    assert validation_split(["val", "test"]) == "val" and validation_split(["check", "extra", "final"]) == "check"
    assert validation_split(["final"]) is None
    assert ablation_splits(["check", "extra", "final"]) == ("check", "final") and ablation_splits(["x"]) == ("x",)


def test_the_configuration_takes_any_split_names_but_the_reserved_ones(tmp_path):
    from vpr_smr.pipeline.config import ConfigError, validate

    conf = split_names_config(tmp_path, RENAMED)
    checked = validate(conf)
    assert (checked.train_split, checked.eval_splits, checked.table_split) == ("fit", ("check", "final"), "final")
    assert checked.validation_split == "check" and checked.to_json()["eval_splits"] == ["check", "final"]
    for reserved in ("cv", "train"):
        bad = {**conf, "train_split": "fit", "eval_splits": ["check", reserved], "table_split": "check"}
        with pytest.raises(ConfigError, match=f"eval_splits may not name a split '{reserved}'"):
            validate(bad)
    with pytest.raises(ConfigError, match="non-unique"):
        validate({**conf, "eval_splits": ["check", "check", "final"]})


def test_the_rules_give_each_split_by_its_name():
    from vpr_smr.pipeline.rule_helpers import method_items
    from vpr_smr.pipeline.stages.predictor import split_files

    assert split_files(["check", "final"], ["a c.h5", "b.h5", "c.h5", "d.h5"]) == {
        "check": ("a c.h5", "b.h5"), "final": ("c.h5", "d.h5")}
    assert split_files([], []) == {} and split_files(["check"], []) == {}
    with pytest.raises(ValueError, match="3 files for 2 splits"):
        split_files(["check", "final"], ["a", "b", "c"])
    assert method_items(["sad", "hog", "cnn"], "hog", ["s.h5", "c.h5"]) == ["sad=s.h5", "cnn=c.h5"]


@pytest.mark.parametrize("command", [["train", "--dataset", "d"], ["ablation", "attributes", "--dataset", "d"]])
def test_the_former_val_and_test_options_say_what_replaced_them(command, tmp_path, capsys):
    from vpr_smr.pipeline.cli import main

    status = main([*command, "--seq-len", "4", "--train", "a.h5", "--val", "v.h5", "--test", "t.h5", "--out",
                   str(tmp_path / ("p.h5" if command[0] == "train" else "t2.json"))])
    err = capsys.readouterr().err
    assert status == 2 and "--val and --test: removed" in err and "--evaluate SPLIT FILE..." in err


def test_a_split_given_twice_or_without_files_is_refused(tmp_path, capsys):
    from vpr_smr.pipeline.cli import main

    for evaluate, message in (([["check", "a.h5"], ["check", "b.h5"]], "the split is given twice"),
                              ([["check"]], "give the split's name, then its files")):
        argv = ["train", "--dataset", "d", "--seq-len", "4", "--train", "a.h5", "--out", str(tmp_path / "p.h5")]
        for items in evaluate:
            argv += ["--evaluate", *items]
        assert main(argv) == 2 and message in capsys.readouterr().err
