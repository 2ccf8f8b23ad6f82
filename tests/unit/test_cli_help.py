"""The command line's help: every option of every command explained, the top-level help in the order a new user
runs the commands; and ``vpr-smr backends``, which lists the descriptor backends from their classes."""

import argparse

import pytest

from vpr_smr.descriptors import BACKENDS, available_backends
from vpr_smr.pipeline.cli import build_parser, main


def commands(parser: argparse.ArgumentParser, name: str = "vpr-smr"):
    """Every (sub)command's parser with its full name, walking argparse's subparser actions."""
    yield name, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub_name, sub in action.choices.items():
                yield from commands(sub, f"{name} {sub_name}")


def test_every_option_and_positional_has_help():
    missing = [f"{name} {'/'.join(action.option_strings) or action.dest}"
               for name, parser in commands(build_parser()) for action in parser._actions
               if not isinstance(action, argparse._HelpAction | argparse._SubParsersAction)
               and not (action.help or "").strip()]
    assert missing == []
    names = [name for name, _ in commands(build_parser())]
    assert "vpr-smr backends" in names and "vpr-smr dataset check" in names and "vpr-smr ablation held-out" in names


def test_top_level_help_is_plain_text_in_the_order_to_run(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    text = capsys.readouterr().out
    assert "`" not in text
    first_check, first_run = text.index("dataset check"), text.index("vpr-smr run")
    assert first_check < first_run
    # the line breaks of the examples survive (RawDescriptionHelpFormatter): one command per line
    assert "\n       vpr-smr run my.yaml\n" in text
    for stage in ("vpr-smr attributes --distances D.npy", "vpr-smr metrics --distances D.npy",
                  "vpr-smr queries --distances D.npy"):
        assert text.index(stage) > first_run
    assert "vpr-smr backends" in text


def backend_rows(capsys) -> dict[str, list[str]]:
    assert main(["backends"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split()[:3] == ["backend", "checkpoint", "distance"]
    rows = {}
    for line, below in zip(lines[1:], lines[2:], strict=False):
        if line and not line.startswith(" ") and below.startswith("    settings: "):
            rows[line.split()[0]] = [*line.split()[1:3], below.removeprefix("    settings: ")]
    return rows


def test_backends_lists_every_backend_with_its_checkpoint_and_defaults(capsys):
    rows = backend_rows(capsys)
    assert sorted(rows) == available_backends() and set(BACKENDS) <= set(rows)
    # the weight-free SAD: no checkpoint, mean absolute difference, grey 64 x 32 in 8 x 8 patches
    assert rows["sad"] == ["none", "mad", "width=64, height=32, patch=8"]
    assert rows["hog"][:2] == ["none", "l2"]
    assert rows["netvlad"] == ["needed", "l2", "image_size=auto, num_clusters=64, num_pcs=4096"]
    assert rows["efficientnet_lite0_gem"] == ["needed", "l2", "image_size=[112, 224], gem_p=3.0"]


def test_backends_input_sizes(capsys):
    assert main(["backends"]) == 0
    lines = {line.split()[0]: line for line in capsys.readouterr().out.splitlines() if line and line[0] != " "}
    assert lines["sad"].endswith("any; grey, resized to 64x32 (W x H)")
    assert lines["mixvpr"].endswith("320x320 (H x W, image_size)")
    assert lines["salad"].endswith("322x322 (H x W)")
    assert lines["boq"].endswith("384x384 (resnet50), 322x322 (dinov2)")
    assert lines["netvlad"].endswith("480x640 (H x W) with a Patch-NetVLAD file, full size with Nanne's")


def test_unknown_backend_points_to_the_listing():
    from vpr_smr.descriptors import backend_class

    with pytest.raises(ValueError, match=r"unknown descriptor backend 'nope'; available: .*\(`vpr-smr backends` "
                                         r"lists each with its settings\)"):
        backend_class("nope")
