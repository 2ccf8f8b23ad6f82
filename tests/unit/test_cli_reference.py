"""docs/cli.md, the command-line reference, is what the argument parser gives: the committed file is the
generator's, and every option that ``vpr-smr COMMAND --help`` prints (argparse's own text, not the generator's) is in
that command's section, each matcher's too."""

from __future__ import annotations

import contextlib
import io
import re

import pytest

from vpr_smr.eval.matching.matchers import DEFAULT_MATCHER, MATCHERS
from vpr_smr.pipeline.cli import build_parser
from vpr_smr.pipeline.reference import CLI_REFERENCE_PATH, cli_reference, commands

OPTION = re.compile(r"(?<![\w-])--[a-z0-9][a-z0-9-]*")


def help_text(argv: list[str], matcher: str = DEFAULT_MATCHER) -> str:
    out = io.StringIO()
    with contextlib.redirect_stdout(out), pytest.raises(SystemExit):
        build_parser(matcher).parse_args([*argv, "--help"])
    return out.getvalue()


def options_of_help(text: str) -> set[str]:
    """The options argparse lists in a help's option lines (not those its descriptions mention)."""
    found = set()
    for line in text.splitlines():
        if re.match(r"^\s{2}-", line):
            found |= set(OPTION.findall(line.split("  ", 2)[1] if line.startswith("  ") else line))
    return found - {"--help"}


def section(heading: str) -> str:
    text = CLI_REFERENCE_PATH.read_text()
    start = text.index(f"\n{heading}\n")
    level = heading.split(" ")[0]
    following = re.search(rf"\n#{{1,{len(level)}}} ", text[start + 1:])
    return text[start: start + 1 + following.start() if following else len(text)]


def test_the_committed_reference_is_what_the_parser_gives():
    assert CLI_REFERENCE_PATH.read_text() == cli_reference(), "run python -m vpr_smr.pipeline.reference --write"


@pytest.mark.parametrize("words", list(commands(build_parser())))
def test_each_command_lists_every_option_its_help_shows(words):
    shown = options_of_help(help_text(words.split()))
    listed = set(OPTION.findall(section(f"## vpr-smr {words}".rstrip()).split("| option |")[-1]))
    assert shown <= listed, f"vpr-smr {words}: options missing from docs/cli.md: {sorted(shown - listed)}"


@pytest.mark.parametrize("matcher", sorted(set(MATCHERS) - {DEFAULT_MATCHER}))
def test_each_matcher_lists_its_own_options(matcher):
    own = options_of_help(help_text(["attributes", "--matcher", matcher], matcher)) - \
        options_of_help(help_text(["attributes"]))
    assert own, f"--matcher {matcher} adds no option to attributes' help"
    assert own <= set(OPTION.findall(section(f"### `--matcher {matcher}`"))), matcher


def test_the_help_parse_sees_what_a_user_sees():
    """The hand-read options of `vpr-smr metrics --help` (a sample), so the checks above test something."""
    shown = options_of_help(help_text(["metrics"]))
    assert {"--distances", "--seq-len", "--ground-truth", "--ground-truth-key", "--similarity", "--key",
            "--transpose", "--matcher", "--velocities", "--out"} <= shown
