"""The check every declared stage's test file makes: a command line of the earlier version parses into the job
record written by hand, and that record given as ``--job`` (the rules' form, every setting written out) reads back
as the same record."""

from __future__ import annotations

import dataclasses
import json
from typing import Any

from vpr_smr.pipeline.cli import build_parser
from vpr_smr.pipeline.options import matcher_of
from vpr_smr.pipeline.stage import JOB, Stage, job_of, job_text


def parsed(argv: list[str]) -> tuple[Stage, Any]:
    """The stage a command line names and the job record of its options."""
    args = build_parser(matcher_of(argv)).parse_args(argv)
    return args.stage, job_of(args.stage, args)


def check_old_command(stage: Stage, argv: list[str], expected: Any) -> None:
    """``argv`` is ``stage``'s command giving ``expected``; ``--job job_text(expected)`` gives it back, with every
    setting of the record written out."""
    named, job = parsed(argv)
    assert named is stage and job == expected
    text = job_text(expected)
    again = build_parser(job=True).parse_args([*stage.words, JOB, text])
    assert job_of(stage, again) == expected
    assert set(json.loads(text)) == {item.name for item in dataclasses.fields(stage.job)}
