"""Experiments, the tool's own and those an installed package adds (entry point group ``vpr_smr.experiments``), as
the report sees them.

An experiment is one module: a ``pipeline.experiment.Experiment`` declaring its jobs, its tables (each a
``registry.Table`` whose ``section`` is its part of the page), its figures (each a ``registry.Figure`` with how it
is drawn) and where its jobs write. The workflow runs its jobs (``pipeline/rules/jobs.smk``) when the configuration
turns it on (``experiments: {NAME: true}``); the report reads its jobs' files (``files``), and its tables make their
rows from them, its figures are drawn from them (``tabulate.Inputs.experiments``).

This module sees only what the report needs of an experiment (``Reported``): the report is below the workflow, and
an experiment's jobs are the workflow's. The tool's own experiments register here too, one line each, by the name of
the module that declares them (``add_lazy``: imported when first asked for, never by this module's import); the
configuration switches each by its own key (``pipeline.config.Experiments``), and the report reads their files
through its job's own inputs (``ReportJob``), not ``files``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

from vpr_smr.core.registry import Registry

if TYPE_CHECKING:
    from vpr_smr.eval.report.table_spec import Figure, Table

__all__ = ["ENTRY_POINT_GROUP", "EXPERIMENTS", "Reported", "builtin", "chosen", "files", "installed"]

ENTRY_POINT_GROUP = "vpr_smr.experiments"


@runtime_checkable
class Reported(Protocol):
    """What the report reads of an experiment: its ``name`` (its key under ``experiments:``), its ``tables``, its
    ``figures`` and ``outputs(settings)``: its jobs' files, relative to the run folder, for a configuration's
    settings (its validated JSON, as ``vpr-smr report --settings`` gives it)."""

    @property
    def name(self) -> str: ...

    @property
    def tables(self) -> tuple[Table, ...]: ...

    @property
    def figures(self) -> tuple[Figure, ...]: ...

    def outputs(self, settings: Mapping[str, Any]) -> list[str]: ...


def _experiment(name: str, item: Any) -> Reported:
    """An installed experiment checked: an experiment, under its own name."""
    if not isinstance(item, Reported):
        raise ValueError(f"the entry point {name} (group {ENTRY_POINT_GROUP}) is not an experiment: declare a "
                         "vpr_smr.pipeline.experiment.Experiment")
    if item.name != name:
        raise ValueError(f"the entry point {name} (group {ENTRY_POINT_GROUP}) names the experiment {item.name!r}: "
                         "register it under its own name")
    return item


EXPERIMENTS: Registry[Reported] = Registry("experiment", ENTRY_POINT_GROUP, check=_experiment)
# the tool's own experiments, each declared in its module as a plugin's is
EXPERIMENTS.add_lazy("speed", "vpr_smr.pipeline.experiments.speed:EXPERIMENT")
EXPERIMENTS.add_lazy("matchers", "vpr_smr.pipeline.experiments.matchers:EXPERIMENT")
EXPERIMENTS.add_lazy("adaptive_seq_len", "vpr_smr.pipeline.experiments.adaptive_seq_len:EXPERIMENT")
EXPERIMENTS.add_lazy("protocol_sweep", "vpr_smr.pipeline.experiments.protocol_sweep:EXPERIMENT")
EXPERIMENTS.add_lazy("trust_levels", "vpr_smr.pipeline.experiments.trust_levels:EXPERIMENT")
EXPERIMENTS.add_lazy("restoration", "vpr_smr.pipeline.experiments.restoration:EXPERIMENT")
EXPERIMENTS.add_lazy("deployment", "vpr_smr.pipeline.experiments.deployment:EXPERIMENT")


def builtin() -> tuple[Reported, ...]:
    """The tool's own experiments, in their registration's order (each module imported on first call)."""
    from vpr_smr.eval.report import registry  # noqa: F401 (first: an experiment's module imports its ``Table``)

    return tuple(EXPERIMENTS.get(name) for name in EXPERIMENTS.builtins())


def installed() -> tuple[Reported, ...]:
    """The experiments installed packages register, by name; ValueError naming an entry point whose object is not
    an experiment or names another."""
    names = [name for name in EXPERIMENTS.names() if name not in EXPERIMENTS.builtins()]
    if not names:  # none installed: the report's registry (about 70 ms of imports) is not needed by every command
        return ()
    # the registry first: an experiment's module imports it (its ``Table``), and it collects the experiments' tables
    from vpr_smr.eval.report import registry  # noqa: F401

    return tuple(EXPERIMENTS.get(name) for name in names)


def chosen(settings: Mapping[str, Any]) -> list[Reported]:
    """The installed experiments the settings (a configuration's validated JSON) turn on: ``experiments: {NAME:
    true}``."""
    on = settings.get("experiments", {})
    return [experiment for experiment in installed() if isinstance(on, Mapping) and on.get(experiment.name) is True]


def files(run_dir: Path | str, settings: Mapping[str, Any] | None) -> dict[str, Sequence[Path]]:
    """Per experiment the settings turn on, its jobs' files under the run folder ``run_dir`` (the report reads them
    where the workflow wrote them)."""
    if not settings:
        return {}
    return {experiment.name: [Path(run_dir) / path for path in experiment.outputs(settings)]
            for experiment in chosen(settings)}
