"""An experiment declared once, in one module: its jobs, its tables, its figures and its section of the report.

An ``Experiment`` names itself (its key under the configuration's ``experiments:``), its jobs (``Job``: a declared
``Stage``, the output path pattern each job writes, its inputs and its job record from the run's configuration and
plan), its tables (``registry.Table``s made from its jobs' files, each table's ``section`` its part of the page,
with its sentences) and its figures (``registry.Figure``s, each with the function that draws it). An installed
package registers it under its name in the entry point group ``vpr_smr.experiments`` (``eval.report.experiments``);
nothing else is edited:

- the configuration accepts ``experiments: {NAME: true}`` (``pipeline.config``; an unknown name is refused with the
  known ones listed);
- the workflow makes one rule per job (``pipeline/rules/jobs.smk``, as it does of the core workflow's jobs) calling
  ``vpr-smr COMMAND --job JSON``, and the report waits for their files;
- ``vpr-smr COMMAND`` runs a job by hand (``pipeline.cli`` installs the jobs' stages);
- the report reads the files (``eval.report.experiments.files``) and writes the tables, the figures and the section
  (the report rule declares the figures' files, ``registry.expected_outputs``).
"""

from __future__ import annotations

import itertools
import re
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from vpr_smr.eval.report.experiments import builtin, installed
from vpr_smr.pipeline.stage import Stage

if TYPE_CHECKING:
    from vpr_smr.eval.report.table_spec import Figure, Table
    from vpr_smr.pipeline.config import Config
    from vpr_smr.pipeline.plan import Plan

__all__ = ["WILDCARDS", "Experiment", "Job", "Wildcard", "builtin_experiments", "experiment", "plugin_experiments",
           "plugin_stages", "relative", "running"]

# the names a job's output pattern may hold: each ranges over the configuration's datasets, methods, and sequence
# lengths (``Job.every_seq_len``: every L of seq_lens, else table_seq_len only)
WILDCARDS = ("dataset", "method", "seq_len")
NAME = re.compile(r"[a-z][a-z0-9_]*")


@dataclass(frozen=True)
class Wildcard:
    """A wildcard of a job's output beyond ``WILDCARDS``: its ``name`` and its ``values`` from the run's
    configuration and plan (speed's ``profile``: the configured profiles). The workflow's rule matches those values
    only (none: the rule matches nothing)."""

    name: str
    values: Callable[[Config, Plan], Sequence[str]]


@dataclass(frozen=True)
class Job:
    """One kind of job of an experiment: the ``stage`` it runs, the ``output`` it writes (a path relative to the
    run folder with the wildcards of ``WILDCARDS`` it ranges over, e.g. ``recall_gain/{dataset}/{method}/
    L{seq_len}.json``: one job per value of each), its ``inputs`` (the files it reads, by name, from the run folder,
    the configuration, the plan and the job's wildcards) and its ``record`` (the stage's job record, from the
    configuration, the plan, the wildcards, the inputs and the output path: the workflow computes it from those
    alone, so that Snakemake compares it with the last run's and reruns the job when it changed).

    Optional: ``wildcards_from`` (further wildcards of ``output``, their values from the configuration),
    ``also`` (further outputs, e.g. a timing file beside the result), ``named`` (the rule's outputs by name, from
    the run folder and the configuration, in place of ``output`` and ``also``, where the rule names them or their
    number depends on the configuration: ``train``'s every seed's predictor; ``output`` stays its first file, its
    log's and its record's), ``threads`` (the rule's threads, each job's BLAS threads too: ``OMP_NUM_THREADS``),
    ``layout`` (the rule's param ``layout``: the results' layout version, so that a run of an earlier layout
    computes its file again), ``revision`` (the rule's param ``revision`` from the configuration, the plan and the
    wildcards: the revision of the code that computes the file, e.g. a descriptor backend's, so that a new one
    computes it again), ``params`` (further rule params, each a name and its value from the configuration, the
    plan and the wildcards: what else the file depends on that neither its record nor its inputs hold, e.g. the
    baselines' ``scorers``, the registered scorers and their plugins' versions, so that installing one computes
    the file again), ``resources`` (the rule's resources from the configuration), ``speed`` (the stage's
    ``Stage.speed`` options from the rule's threads and resources, after its ``--job``: they change how fast it
    runs, not what it computes, so that changing them reruns nothing; a stage given ``{threads}`` there sets its
    threads itself, without ``OMP_NUM_THREADS``) and ``rule`` (the rule's name, where it is not
    ``Experiment.rule_name``'s; a job of the core workflow, ``pipeline.core_jobs.JOBS``, always names it).

    The workflow makes one rule of each (``pipeline/rules/jobs.smk``), the core workflow's and the experiments'."""

    stage: Stage
    output: str
    inputs: Callable[[str, Config, Plan, Mapping[str, str]], Mapping[str, str | Sequence[str]]]
    record: Callable[[Config, Plan, Mapping[str, str], Mapping[str, Any], str], Any]
    every_seq_len: bool = False
    wildcards_from: tuple[Wildcard, ...] = ()
    also: tuple[str, ...] = ()
    named: Callable[[str, Config], Mapping[str, str | Sequence[str]]] | None = None
    threads: int | None = None
    layout: bool = False
    revision: Callable[[Config, Plan, Mapping[str, str]], int] | None = None
    params: tuple[tuple[str, Callable[[Config, Plan, Mapping[str, str]], str]], ...] = ()
    resources: Callable[[Config], Mapping[str, Any]] | None = None
    speed: str = ""
    rule: str = ""

    @property
    def wildcards(self) -> tuple[str, ...]:
        """The wildcards of ``output``: those of ``WILDCARDS`` in its order, then ``wildcards_from``'s."""
        found = set(re.findall(r"{(\w+)}", self.output))
        own = [wildcard.name for wildcard in self.wildcards_from]
        unknown = sorted(found - set(WILDCARDS) - set(own))
        if unknown:
            raise ValueError(f"job {self.stage.command!r}: its output {self.output!r} names {unknown}; an output "
                             f"pattern may name {', '.join(WILDCARDS)} and the job's wildcards_from")
        return (*(name for name in WILDCARDS if name in found), *(name for name in own if name in found))

    @property
    def patterns(self) -> tuple[str, ...]:
        """Its outputs' patterns, relative to the run folder: ``output``, then ``also``."""
        return (self.output, *self.also)

    def listed_outputs(self, out: str) -> list[str]:
        """The rule's unnamed outputs in the run folder ``out``: ``patterns`` (none where ``named`` names them)."""
        return [] if self.named is not None else [f"{out}/{pattern}" for pattern in self.patterns]

    def named_outputs(self, out: str, conf: Config) -> dict[str, str | Sequence[str]]:
        """The rule's named outputs in the run folder ``out``: ``named``'s (none without it)."""
        return {} if self.named is None else dict(self.named(out, conf))

    def constraints(self, conf: Config, plan: Plan) -> dict[str, str]:
        """The rule's wildcard constraints: each of ``wildcards_from`` matches its values only."""
        return {wildcard.name: "|".join(map(re.escape, wildcard.values(conf, plan))) or "(?!)"
                for wildcard in self.wildcards_from}

    def values(self, settings: Mapping[str, Any]) -> dict[str, list[str]]:
        """Each wildcard's values in a configuration's settings (its validated JSON); ValueError for a job with
        ``wildcards_from`` (their values need the configuration record: ``Experiment.outputs`` lists the files of
        an experiment the report reads itself)."""
        if self.wildcards_from:
            raise ValueError(f"job {self.stage.command!r}: its wildcards "
                             f"{[wildcard.name for wildcard in self.wildcards_from]} take their values from the "
                             "configuration record, not its settings")
        lengths = settings["seq_lens"] if self.every_seq_len else [settings["table_seq_len"]]
        every = {"dataset": list(settings["datasets"]), "method": list(settings["methods"]),
                 "seq_len": [str(n) for n in lengths]}
        return {name: every[name] for name in self.wildcards}

    def outputs(self, settings: Mapping[str, Any]) -> list[str]:
        """Every job's output, relative to the run folder, in the configuration's order."""
        values = self.values(settings)
        return [self.output.format(**dict(zip(values, chosen, strict=True)))
                for chosen in itertools.product(*values.values())]

    def job_record(self, out: str, conf: Config, plan: Plan, wildcards: Mapping[str, str]) -> Any:
        """The job record of the job of ``wildcards`` in the run folder ``out``: ``record`` of its inputs and its
        output (the rule's param, from the wildcards only: Snakemake leaves a param made from a rule's input or
        output out of what it compares with the last run's)."""
        return self.record(conf, plan, wildcards, self.inputs(out, conf, plan, wildcards),
                           f"{out}/{self.output.format(**wildcards)}")

    def rule_params(self, out: str, conf: Config, plan: Plan) -> dict[str, Any]:
        """The rule's params: ``layout`` (with ``layout``), ``job`` (its record as text, from the wildcards:
        ``job_record``), ``revision`` (with ``revision``), then ``params``'; each a function of the wildcards
        alone."""
        from vpr_smr.core.constants import RESULTS_LAYOUT  # here: the results' layout is the workflow's concern
        from vpr_smr.pipeline.stage import job_text

        revision = self.revision
        found: dict[str, Any] = {
            **({"layout": RESULTS_LAYOUT} if self.layout else {}),
            "job": lambda wildcards: job_text(self.job_record(out, conf, plan, dict(wildcards.items()))),
            **({"revision": lambda wildcards: revision(conf, plan, dict(wildcards.items()))}
               if revision is not None else {})}
        for name, value in self.params:
            if name in found:
                raise ValueError(f"job {self.stage.command!r}: its params name {name!r}, a param the rule has "
                                 f"already ({', '.join(found)}); give it another name")
            found[name] = _param(value, conf, plan)
        return found

    def rule_resources(self, conf: Config) -> dict[str, Any]:
        """The rule's resources: ``resources``' (none without it)."""
        return {} if self.resources is None else dict(self.resources(conf))

    @property
    def shell_prefix(self) -> str:
        """What the rule's shell line starts with: the BLAS threads of a job with ``threads`` (OpenBLAS's default,
        a thread per core, makes jobs side by side fight over the cores), unless its ``speed`` options give the
        stage its threads."""
        return "OMP_NUM_THREADS={threads} " if self.threads is not None and "{threads}" not in self.speed else ""


def _param(value: Callable[[Config, Plan, Mapping[str, str]], str], conf: Config, plan: Plan
           ) -> Callable[[Any], str]:
    """A rule's param of ``Job.params``: a function of the wildcards alone (one of its own, not a loop's lambda,
    whose variable would be the loop's last)."""
    return lambda wildcards: value(conf, plan, dict(wildcards.items()))


def relative(path: str) -> str:
    """A ``core.paths`` pattern made with the run folder ``""`` (``speed_path("", "{dataset}", ...)``), relative to
    the run folder: a job's ``output``."""
    if not path.startswith("/"):
        raise ValueError(f"{path!r}: make the pattern with the run folder '' (it starts with '/')")
    return path[1:]


@dataclass(frozen=True)
class Experiment:
    """An experiment: its ``name`` (a key of ``experiments:``, lower case letters, digits and ``_``), ``help`` (one
    line: the configuration reference's), its ``jobs``, its ``tables`` and its ``figures`` (optional). A table's
    ``experiments`` names the experiment (``experiments=(name,)``), so that it is written only when the
    configuration turns the experiment on; further names are further conditions (``("table1", name)``: only in a
    run with Table I's evaluations). Its ``make`` reads ``inputs.experiments[name]``, the jobs' files, or, for a
    table-only experiment (no jobs), the core jobs' files (``trust_levels``: the evaluations'). A figure's
    ``experiments`` names it likewise, and its ``draw`` reads the same inputs."""

    name: str
    help: str
    jobs: tuple[Job, ...]
    tables: tuple[Table, ...]
    figures: tuple[Figure, ...] = ()

    def __post_init__(self) -> None:
        if NAME.fullmatch(self.name) is None:
            raise ValueError(f"experiment {self.name!r}: a name is lower case letters, digits and '_', starting with "
                             "a letter")
        for table in self.tables:
            if self.name not in table.experiments:
                raise ValueError(f"experiment {self.name!r}: its table {table.name!r} has experiments="
                                 f"{table.experiments!r}, without {self.name!r}; name the experiment there "
                                 f"(experiments=({self.name!r},), or with further conditions, e.g. ('table1', "
                                 f"{self.name!r})), so that the table is written only when the experiment runs")
        for figure in self.figures:
            if self.name not in figure.experiments:
                raise ValueError(f"experiment {self.name!r}: its figure {figure.name!r} has experiments="
                                 f"{figure.experiments!r}, without {self.name!r}; name the experiment there, so that "
                                 "the figure is drawn and declared to the workflow only when the experiment runs")
        for job in self.jobs:
            job.wildcards  # noqa: B018 (refuses an unknown wildcard now, not in the workflow)

    def outputs(self, settings: Mapping[str, Any]) -> list[str]:
        """Every job's file, relative to the run folder, for a configuration's settings (its validated JSON)."""
        return [path for job in self.jobs for path in job.outputs(settings)]

    def rule_name(self, job: Job) -> str:
        """The workflow's rule of ``job``: its ``rule``, else its command's words joined by ``_``, after the
        experiment's name where they are not that name (``recall-gain`` of ``recall_gain``: ``recall_gain``)."""
        if job.rule:
            return job.rule
        words = "_".join(re.split(r"[\s-]+", job.stage.command))
        return words if words == self.name else f"{self.name}_{words}"


def _typed(found: Sequence[Any]) -> tuple[Experiment, ...]:
    wrong = [one.name for one in found if not isinstance(one, Experiment)]
    if wrong:
        raise TypeError(f"experiments {wrong}: declare each as a vpr_smr.pipeline.experiment.Experiment")
    return tuple(one for one in found if isinstance(one, Experiment))


def plugin_experiments() -> tuple[Experiment, ...]:
    """The experiments installed packages register (``eval.report.experiments.installed``), by name."""
    return _typed(installed())


def builtin_experiments() -> tuple[Experiment, ...]:
    """The tool's own experiments (``pipeline.experiments``), in their registration's order."""
    return _typed(builtin())


def running(names: Collection[str]) -> tuple[Experiment, ...]:
    """The built-in, then the installed experiments among ``names`` (``pipeline.config.experiments``: those the
    configuration turns on): the workflow makes their jobs' rules (``rules/jobs.smk``)."""
    return tuple(one for one in (*builtin_experiments(), *plugin_experiments()) if one.name in names)


def experiment(name: str) -> Experiment:
    """The experiment ``name``, built in or installed; KeyError listing them."""
    every = (*builtin_experiments(), *plugin_experiments())
    for one in every:
        if one.name == name:
            return one
    known = ", ".join(one.name for one in every) or "none"
    raise KeyError(f"no experiment {name!r}; the experiments: {known}")


def plugin_stages() -> tuple[Stage, ...]:
    """The stages of the installed experiments' jobs: ``vpr-smr COMMAND`` runs one by hand (``pipeline.cli``)."""
    return tuple(job.stage for one in plugin_experiments() for job in one.jobs)
