"""A stage declared once: its command, its options, the workflow's call of it and its Python function.

A ``Stage`` names a command (``attributes``, or two words such as ``ablation held-out``), the job record its work
takes (a settings record of ``core.settings``: its settings, groups of settings shared with other stages, its input
and output paths), the function that does the work (``run(job)``) and the line it says when done. Everything else
follows from it:

- the command and its options (``install``): every setting of the job record is an option (``pipeline.options``);
  ``--job`` gives the whole record as one JSON object instead;
- the workflow's rules call ``vpr-smr COMMAND --job JSON`` (``job_text``, ``shell_command``): the record itself, every
  setting written out, so that a job reruns exactly when one of its settings changes;
- the Python function: ``stage(**settings)`` or ``stage(job)`` runs the work in the calling process.
"""

from __future__ import annotations

import argparse
import json
import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from vpr_smr.core.json_objects import json_object
from vpr_smr.core.settings import parse, to_json
from vpr_smr.eval.matching.matchers import DEFAULT_MATCHER
from vpr_smr.pipeline.options import add_options, given_options, read_options

__all__ = ["JOB", "Stage", "install", "job_of", "job_text", "shell_command", "wrote"]

log = logging.getLogger("vpr_smr")

JOB = "--job"
PARAM = "job"  # the rules' param holding a job record (``job_text``), which ``shell_command`` passes
GROUP = "job"  # the options' group name (``pipeline.options``): the job record's settings


@dataclass(frozen=True)
class Stage:
    """One stage of the workflow: ``command`` (its words on the command line), ``help`` (one line), ``job`` (its
    settings record), ``run`` (the work: ``run(job)`` returns the result), ``summary`` (the line after "wrote"
    from the job and the result: what, where, the headline number), ``show`` (text it prints to the terminal from
    the job and the result, e.g. a table), ``description`` and ``epilog`` (its ``--help``), ``legacy`` (options of
    an earlier version that fail naming what replaced them: adds them to the parser) and ``check`` (refuses those
    given, from the parsed options), ``speed`` (the names of the job's settings or groups that change how fast it
    runs, not what it computes: options read beside ``--job`` too, so that a rule gives them from its threads and
    resources, not its params, and changing them reruns nothing)."""

    command: str
    help: str
    job: type
    run: Callable[[Any], Any]
    summary: Callable[[Any, Any], str] | None = None
    show: Callable[[Any, Any], str] | None = None
    description: str = ""
    epilog: str = ""
    legacy: Callable[[argparse.ArgumentParser], None] | None = None
    check: Callable[[argparse.Namespace], None] | None = None
    speed: tuple[str, ...] = ()

    @property
    def words(self) -> tuple[str, ...]:
        return tuple(self.command.split())

    def __call__(self, job: Any = None, /, **settings: Any) -> Any:
        """The stage's work in this process: ``job`` (its record), or its settings as keywords (JSON values,
        records of groups, a ``MatcherSpec``; the others at their defaults)."""
        if job is None:
            job = parse(self.job, settings, self.command)
        elif settings:
            raise TypeError(f"{self.command}: give the job record or its settings, not both")
        return self.run(job)

    def execute(self, args: argparse.Namespace) -> int:
        """The command: the job of ``args`` run, its summary logged and its text printed."""
        if self.check is not None:
            self.check(args)
        job = job_of(self, args)
        result = self.run(job)
        if self.show is not None:
            print(self.show(job, result))
        if self.summary is not None:
            log.info("wrote %s", self.summary(job, result))
        return 0


def wrote(what: str, out: str, headline: str = "") -> str:
    """A stage's summary after "wrote": what, where, and its headline number (``Stage.summary``)."""
    return f"{what} to {out}{f': {headline}' if headline else ''}"


def job_of(stage: Stage, args: argparse.Namespace) -> Any:
    """The job record of a stage's parsed options: ``--job``'s JSON object (``@file``: a file holding it), its
    ``speed`` settings replaced by those given as options; or the options (those not given at their defaults);
    ValueError naming the option or the setting that is wrong."""
    text = getattr(args, "job", None)
    if text is None:
        return read_options(args, stage.job, GROUP)
    data = json_object(text, JOB)
    given = given_options(args, stage.job, GROUP) if stage.speed else {}
    for name in stage.speed:  # a group's options replace its settings one by one
        value = given.get(name)
        if isinstance(value, Mapping) and value:
            data = {**data, name: {**data.get(name, {}), **value}}
        elif name in given and not isinstance(value, Mapping):
            data = {**data, name: value}
    return parse(stage.job, data, JOB)


def job_text(job: Any) -> str:
    """A job record as the JSON text ``--job`` reads back into an equal record (every setting written out, in the
    declaration's order): a rule's param, so that the job reruns exactly when a setting changes."""
    return json.dumps(to_json(job), separators=(",", ":"), allow_nan=False)


def shell_command(stage: Stage, speed: str = "") -> str:
    """A rule's shell command calling ``stage`` with its ``job`` param, its output to the rule's log; ``speed``: the
    options of its ``speed`` settings (from the rule's threads and resources, e.g. ``--threads {threads}``)."""
    beside = f" {speed}" if speed else ""
    return f"vpr-smr {stage.command} {JOB} {{params.{PARAM}:q}}{beside} > {{log:q}} 2>&1"


def _subparsers(parser: argparse.ArgumentParser) -> Any:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return action
    return parser.add_subparsers(dest=f"{parser.prog.split()[-1]}_command", required=True, metavar="COMMAND")


def install(sub: Any, stage: Stage, matcher: str = DEFAULT_MATCHER, job: bool = False,
            groups: Mapping[str, str] | None = None) -> argparse.ArgumentParser:
    """``stage``'s command under the subcommands ``sub`` (a two-word command under its first word's, made if
    missing with its help from ``groups``), replacing one of the same name: its job record's settings as options,
    ``--job``, and the function that runs it. ``job``: the command line gives ``--job`` (then no other option is
    required)."""
    *outer, name = stage.words
    for word in outer:
        parent = sub.choices.get(word) or sub.add_parser(word, help=(groups or {}).get(word, f"{word} commands"))
        sub = _subparsers(parent)
    names = list(sub.choices)
    place = names.index(name) if name in names else len(names)  # a command of the same name: replaced in its place
    sub.choices.pop(name, None)
    helps = [action for action in sub._choices_actions if action.dest != name]
    parser: argparse.ArgumentParser = sub.add_parser(name, help=stage.help, description=stage.description or None,
                                                     epilog=stage.epilog or None)
    sub._choices_actions[:] = [*helps[:place], sub._choices_actions[-1], *helps[place:]]
    parsers = dict(sub.choices)
    sub.choices.clear()  # the same mapping as argparse's own (``choices`` is it): refilled in the commands' order
    sub.choices.update({key: parsers[key] for key in [*names[:place], name, *names[place + 1:]]})
    add_options(parser, stage.job, GROUP, matcher, required=not job)
    parser.add_argument(JOB, metavar="JSON", help="the whole job as one JSON object of its settings (or @file "
                        "holding it), as the workflow's rules give it; the other options are not read then")
    if stage.legacy is not None:
        stage.legacy(parser)
    parser.set_defaults(func=stage.execute, stage=stage)
    return parser

