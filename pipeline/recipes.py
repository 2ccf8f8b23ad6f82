"""What made each output of a run, recorded in the run folder and compared before every run.

A job's recipe is what its rule hands it: the rule's ``params`` (by the Snakefile's design exactly the settings the
job uses), the SHA-256 of every file it reads from outside the run folder (a checkpoint, frame lists, positions, a
ground-truth file) and the results format. ``vpr-smr run`` records the recipe of every output its jobs write
(``core.paths.recipes_path``) and, before the next run, compares each existing output's recorded recipe with the one
the configuration gives now: an output that differs, or records none, is rerun (Snakemake's ``--forcerun``, which
reruns what depends on it too), whatever Snakemake's own state in ``.snakemake`` says or whether it is there. An
output made before vpr-smr recorded recipes is left to Snakemake's own record where one is there, and recorded once
a run has brought every output up to date.

An output made by a version whose params Snakemake did not store (0.16.0: each job's ``job`` param was a function of
its input or output, which Snakemake leaves out of its record) would be rerun by Snakemake's params trigger for the
param it now finds, though nothing changed: where its recorded recipe (of this or an earlier results format) equals
its recipe now, ``carry_over`` records it in this format and clears Snakemake's record of it (see there).

Paths in a recipe are portable: the run folder is written ``{run}`` and the working folder's prefix is dropped, so
that moving the project folder changes no recipe by itself.
"""

from __future__ import annotations

import json
import logging
import os
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vpr_smr.core.paths import recipes_path
from vpr_smr.core.records import FORMAT, FileRecord, FormatError, Record, load, save
from vpr_smr.pipeline.stage import PARAM

RUN = "{run}"  # the run folder in a recorded recipe


@dataclass(frozen=True)
class Recipe(Record):
    """What made one output: its rule, the rule's params as text, the hashes of the files it read from outside the
    run folder (portable path -> SHA-256)."""

    rule: str
    params: dict[str, str]
    inputs: dict[str, str]


@dataclass(frozen=True)
class Recipes(FileRecord):
    """Every recorded output of a run (its path in the run folder -> its recipe); the results format is the file's."""

    outputs: dict[str, Recipe]


@dataclass(frozen=True)
class Job:
    """A job of the workflow as the configuration gives it now: its outputs (paths as the rules write them), its
    recipe, and whether Snakemake holds its own record of them (``.snakemake``: then Snakemake's own checks judge an
    output of ours that records nothing, one made before vpr-smr recorded recipes)."""

    outputs: tuple[str, ...]
    recipe: Recipe
    snakemake_record: bool = False
    # Snakemake's record of every output lacks params that the job has now and holds no other change (the record of
    # a version whose params Snakemake did not store): by itself, Snakemake would run it again
    params_unrecorded: bool = False


@dataclass(frozen=True)
class Stale:
    """A job to run again: its first output and why."""

    output: str
    reason: str


def portable(text: str, run_dir: Path, cwd: Path) -> str:
    """``text`` with the run folder (absolute, or as given from ``cwd``) written ``{run}`` and ``cwd``'s prefix
    dropped."""
    absolute = run_dir if run_dir.is_absolute() else cwd / run_dir
    forms = [str(absolute)]  # absolute first: it holds the relative form
    if absolute.is_relative_to(cwd):
        forms.append(str(absolute.relative_to(cwd)))
    for run in dict.fromkeys(forms):
        text = RUN if text == run else text.replace(run + os.sep, RUN + os.sep)
    return text.replace(str(cwd) + os.sep, "")


@contextmanager
def loaded_workflow(snakefile: Path, configfiles: list[str], forceall: bool = True, forcerun: Iterable[str] = (),
                    forget: Iterable[str] = ()) -> Iterator[Any]:
    """Snakemake's workflow of ``configfiles`` with its graph of jobs built as if every job had to run, without
    looking at any output (``forceall=False``: the jobs Snakemake's own checks find to run, and why, with the outputs
    ``forcerun`` forced as ``--forcerun`` does), taking no lock: its ``dag`` the jobs, its ``rules`` the rules, its
    ``persistence`` its own record in ``.snakemake``. Snakemake's record of each output of ``forget`` is cleared
    first (``carry_over``)."""
    from snakemake.api import SnakemakeApi
    from snakemake.settings.types import ConfigSettings, DAGSettings, OutputSettings, Quietness, ResourceSettings

    # its notes ("Building DAG of jobs...") are not ours to show; no log file of its own either
    settings = OutputSettings(quiet={Quietness.ALL}, log_level_override=logging.WARNING, enable_file_logging=False)
    with SnakemakeApi(settings) as api:
        workflow_api = api.workflow(resource_settings=ResourceSettings(cores=1), snakefile=snakefile,
                                    config_settings=ConfigSettings(configfiles=[Path(f) for f in configfiles]))
        workflow_api.dag(DAGSettings(forcerun=frozenset(forcerun)))
        # Snakemake's API runs or prints a graph of jobs but does not return one: its own two steps build it
        workflow = workflow_api._workflow
        workflow._prepare_dag(forceall=forceall, ignore_incomplete=True, lock_warn_only=True, nolock=True)
        if forget:
            from snakemake.io import IOFile

            for output in forget:  # what `snakemake --cleanup-metadata FILES` does for each file
                workflow.persistence.cleanup_metadata(IOFile(output))
        workflow._build_dag()
        yield workflow


def workflow_jobs(snakefile: Path, configfiles: list[str], run_dir: Path) -> list[Job]:
    """Every job of the workflow of ``configfiles`` with its recipe now, from Snakemake's graph of jobs (built as
    if every job had to run, without looking at any output)."""
    from vpr_smr.eval.matching.ground_truth_files import file_sha256

    cwd = Path.cwd()
    hashes: dict[str, str] = {}
    run = str(run_dir) + "/"
    jobs = []
    with loaded_workflow(snakefile, configfiles) as workflow:
        for job in workflow.dag.jobs:
            outputs = tuple(str(f) for f in job.output)
            if not outputs:  # the target rule
                continue
            params = {name: portable(str(value), run_dir, cwd) for name, value in job.params.items()}
            inputs = {}
            for given in map(str, job.input):
                if not given.startswith(run):
                    if given not in hashes:  # a missing one: Snakemake says so
                        hashes[given] = file_sha256(given) if os.path.isfile(given) else "missing"
                    inputs[portable(given, run_dir, cwd)] = hashes[given]
            persistence = workflow.persistence
            known = persistence.has_metadata(job) and not persistence.has_outdated_metadata(job)
            jobs.append(Job(outputs, Recipe(job.rule.name, params, inputs), bool(known),
                            bool(known) and all(_params_unrecorded(persistence, job, f) for f in job.output)))
    return jobs


def _params_unrecorded(persistence: Any, job: Any, output: Any) -> bool:
    """Whether Snakemake's record of ``output`` lacks params ``job`` has now, holds none it no longer has, and
    records no other change (its code, its set of input files, its software stack) that would rerun it."""
    change = persistence.params_changed(job, file=output)
    return bool(change.only_new and not change.only_old and not persistence.code_changed(job, file=output)
                and not persistence.input_changed(job, file=output)
                and not persistence.software_stack_changed(job, file=output))


def _shown(value: Any) -> str:
    return json.dumps(value) if not isinstance(value, str) else (value if value and " " not in value else repr(value))


def _groups() -> frozenset[str]:
    """The names of the declared stages' option groups (``core.settings.group``): a job record's structure, not
    names of settings."""
    from vpr_smr.core.settings import declared
    from vpr_smr.pipeline.stages import STAGES

    found: set[str] = set()

    def walk(cls: type) -> None:
        for item in declared(cls):
            if item.group is not None:
                found.add(item.name)
                walk(item.group)

    for stage in STAGES:
        walk(stage.job)
    return frozenset(found)


def _changes(name: str, old: Any, new: Any, groups: frozenset[str] = frozenset()) -> list[str]:
    """Each setting that differs between two values of a param (JSON objects key by key), as text; a key of
    ``groups`` is left out of the names (a job record's group: its settings are named as the configuration names
    them, ``predictor.max_iter``)."""
    if isinstance(old, dict) and isinstance(new, dict):
        found = []
        for key in [*old, *(k for k in new if k not in old)]:
            if key in groups and isinstance(old.get(key), dict) and isinstance(new.get(key), dict):
                found += _changes(name, old[key], new[key], groups)
                continue
            where = f"{name}.{key}" if name else key
            if key not in new:
                found.append(f"made with {where} {_shown(old[key])}, the configuration now has none")
            elif key not in old:
                found.append(f"made without {where}, the configuration now says {_shown(new[key])}")
            else:
                found += _changes(where, old[key], new[key], groups)
        return found
    if old == new:
        return []
    return [f"made with {name} {_shown(old)}, the configuration now says {_shown(new)}"]


def _json(text: str) -> Any:
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return text


def differences(recorded: Recipe, now: Recipe) -> list[str]:
    """Why an output recorded as made by ``recorded`` is not what ``now`` would make: one sentence per changed
    setting or file; empty when they agree."""
    if recorded.rule != now.rule:
        return [f"made by rule {recorded.rule}, the workflow now makes it by rule {now.rule}"]
    found = []
    for name in [*recorded.params, *(k for k in now.params if k not in recorded.params)]:
        if name not in now.params:
            found.append(f"made with {name} {_shown(recorded.params[name])}, the workflow now has no such setting")
        elif name not in recorded.params:
            found.append(f"made without {name}, the configuration now says {_shown(now.params[name])}")
        else:
            # a job record's settings by their own names (``predictor.max_iter``), as the configuration says them
            job = name == PARAM
            found += _changes("" if job else name, _json(recorded.params[name]), _json(now.params[name]),
                              _groups() if job else frozenset())
    for path in [*recorded.inputs, *(k for k in now.inputs if k not in recorded.inputs)]:
        if path not in now.inputs:
            found.append(f"made from {path}, which it no longer reads")
        elif path not in recorded.inputs:
            found.append(f"made without {path}, which it now reads")
        elif recorded.inputs[path] != now.inputs[path]:
            found.append(f"{path} changed since (SHA-256 {recorded.inputs[path][:12]}..., now "
                         f"{now.inputs[path][:12]}...)")
    return found


def _relative(output: str, run_dir: Path) -> str:
    return RUN + output[len(str(run_dir)):] if output.startswith(str(run_dir) + "/") else output


def load_recipes(run_dir: Path) -> tuple[dict[str, Recipe], str | None]:
    """The recorded recipes of a run folder, and why none can be used when so (another results format)."""
    path = Path(recipes_path(run_dir))
    if not path.is_file():
        return {}, None
    try:
        return load(path, Recipes).outputs, None
    except FormatError:
        found = json.loads(path.read_text()).get("format")
        return {}, (f"no record of the settings that made it that this vpr-smr can read ({path} is in results format "
                    f"{found}, this vpr-smr writes results format {FORMAT})")
    except ValueError as error:
        return {}, f"its record is unreadable ({error})"


def earlier_recipes(run_dir: Path) -> dict[str, Recipe]:
    """The recorded recipes of a run folder whatever results format its record is in (empty when it has none or it
    cannot be read): to recognise an output that an earlier version made just as this one would."""
    try:
        outputs = json.loads(Path(recipes_path(run_dir)).read_text())["outputs"]
        return {output: Recipe.from_json(recipe) for output, recipe in outputs.items()}
    except (OSError, ValueError, TypeError, KeyError, AttributeError):  # none, or not a record of recipes
        return {}


def carried_over(jobs: list[Job], run_dir: Path) -> list[Job]:
    """The jobs whose every output exists, is lacking params in Snakemake's record (``Job.params_unrecorded``) and
    is recorded as made by the recipe the job has now, in this or an earlier results format: made by an earlier
    version exactly as this one would make it. A results format that changes a job's files changes its recipe (the
    ``layout`` param of the jobs whose files it changes), so those are not among them."""
    recorded = earlier_recipes(run_dir)
    return [job for job in jobs if job.params_unrecorded and all(
        os.path.exists(output) and recorded.get(_relative(output, run_dir)) == job.recipe for output in job.outputs)]


def carry_over(jobs: list[Job], run_dir: Path, snakefile: Path, configfiles: list[str],
               forcerun: Iterable[str] = ()) -> int:
    """Keep the outputs of ``jobs`` (``carried_over``) from being made again for a param that Snakemake did not
    store: record their recipes in this results format, then clear Snakemake's record of them. The number of them
    that the run will not make again (Snakemake, with ``forcerun`` forced, still makes those below a job it runs).

    Clearing it is what Snakemake's own ``--cleanup-metadata FILES`` does, the way Snakemake itself names to ignore a
    provenance change. Snakemake 9 checks its params, code, input and software-stack triggers only for an output
    whose record it holds; an output without one is judged by its file times and existence alone (as one made
    before Snakemake kept records), it is never rerun for lacking it. Touching or rewriting the record instead would
    also need a record of the code and input files that Snakemake writes only when it runs a job, and ``--touch``
    changes the files' times. Until a job runs again, Snakemake's own params, code and input triggers (a bare
    ``snakemake`` call) do not see its outputs; ``vpr-smr run`` judges them by their recipes. The recipes are
    written first: stopped between the two steps, the next run finds the same outputs and does the same.
    """
    recorded, _ = load_recipes(run_dir)
    outputs = [output for job in jobs for output in job.outputs]
    save(recipes_path(run_dir), Recipes({**recorded, **{_relative(output, run_dir): job.recipe
                                                         for job in jobs for output in job.outputs}}))
    with loaded_workflow(snakefile, configfiles, forceall=False, forcerun=forcerun, forget=outputs) as workflow:
        made = {str(output) for job in workflow.dag.needrun_jobs() for output in job.output}
    return sum(output not in made for output in outputs)


def stale(jobs: list[Job], run_dir: Path) -> list[Stale]:
    """Every job with an existing output whose recorded recipe differs from its recipe now (or that records none),
    with why (the first output that says so)."""
    recorded, unusable = load_recipes(run_dir)
    found = []
    for job in jobs:
        for output in job.outputs:
            if not os.path.exists(output):
                continue  # Snakemake makes it anyway
            before = recorded.get(_relative(output, run_dir))
            if before is None and job.snakemake_record:
                continue  # made before recipes were recorded: Snakemake's own record judges it
            if before is None:
                reasons = [unusable or f"no record of the settings that made it ({recipes_path(run_dir)} has none)"]
            else:
                reasons = differences(before, job.recipe)
            if reasons:
                found.append(Stale(output, "; ".join(reasons)))
                break
    return sorted(found, key=lambda item: item.output)


def record(jobs: list[Job], run_dir: Path, since: float, complete: bool = False) -> None:
    """Record the recipe of every output a job wrote at or after ``since`` (the start of the run): the outputs this
    run made, with the recipe it made them by; the others keep their records. ``complete``: the run made every
    output of ``jobs`` up to date, so that those recording nothing that Snakemake's own record vouched for are
    recorded too."""
    recorded, _ = load_recipes(run_dir)
    made = {}
    for job in jobs:
        for output in job.outputs:
            key = _relative(output, run_dir)
            if not os.path.exists(output):
                continue
            if os.stat(output).st_mtime >= since or (complete and job.snakemake_record and key not in recorded):
                made[key] = job.recipe
    if made:
        save(recipes_path(run_dir), Recipes({**recorded, **made}))
