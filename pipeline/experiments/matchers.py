"""The experiment ``matchers`` (method §14): each compared matcher with its own attributes and its own predictor (the
authors' recipe, every seed) at Table I's sequence length, then one job per dataset and method scoring them all on
the queries every matcher evaluates (per method: the jobs of a dataset's methods run side by side).

The run's own matcher (``sequence_matching``) reuses the run's files; every other one gets its attributes and
predictors under ``matchers/<dataset>/<tag>/`` from the same stages as the run's: the rules ``matcher_attributes``
and ``matcher_train`` of ``rules/matchers.smk``, which take the core rules ``attributes`` and ``train`` as they are
(``use rule``) with this module's paths and records. The stage is ``pipeline.stages.studies.COMPARE_MATCHERS``
(``vpr-smr compare-matchers``); its table is declared with its rows and sentences in ``eval.report.tables.matchers``,
its figure ``matchers`` is declared and drawn here, and its section, declared here on that table (the experiment's
tables carry it; ``html.declared_sections`` reads it there), follows the baselines' on the page.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vpr_smr.core.paths import distances_path, matcher_attributes_path, matcher_predictor_paths, matchers_path
from vpr_smr.eval.matching.attributes import AttributesJob
from vpr_smr.eval.predictor.defaults import validation_split
from vpr_smr.eval.predictor.jobs import TrainJob
from vpr_smr.eval.report.results import WrittenFigure
from vpr_smr.eval.report.sections import Declared, prose
from vpr_smr.eval.report.table_spec import Figure
from vpr_smr.eval.report.tables.matchers import (
    FAR_BELOW,
    TABLE,
    MatchersRow,
    comparison_sentence,
    matcher_rows,
    matcher_sentences,
)
from vpr_smr.eval.report.tabulate import Inputs
from vpr_smr.eval.scoring.study_jobs import ComparedInputs, MatchersJob
from vpr_smr.pipeline.experiment import Experiment, Job, relative
from vpr_smr.pipeline.rule_helpers import compared_matchers, experiment_files, experiment_inputs, ground_truth_input
from vpr_smr.pipeline.stages.predictor import split_files, training
from vpr_smr.pipeline.stages.scoring import SCORERS_PARAM
from vpr_smr.pipeline.stages.studies import COMPARE_MATCHERS

if TYPE_CHECKING:
    from vpr_smr.pipeline.config import Config
    from vpr_smr.pipeline.plan import Plan

NAME = "matchers"


def inputs(out: str, conf: Config, plan: Plan, wildcards: Mapping[str, str]) -> dict[str, str | Sequence[str]]:
    """Every compared matcher's attributes and predictors of the job's method, the table split's distances (the
    ground truth's reference positions: the scorer spread) and the dataset's ground-truth file (method §13)."""
    dataset, method = wildcards["dataset"], wildcards["method"]
    return {"files": experiment_files(experiment_inputs(out, conf, dataset, method, wildcards["seq_len"])),
            "distances": distances_path(out, dataset, method, conf.table_split),
            "truth": ground_truth_input(plan, dataset)}


def record(conf: Config, plan: Plan, wildcards: Mapping[str, str], files: Mapping[str, Any], out: str
           ) -> MatchersJob:
    """The compared matchers' files, the table split's distances, the dataset's ground truth (method §§11, 13), the
    scorers' settings, the modes."""
    dataset, method, seq_len = wildcards["dataset"], wildcards["method"], wildcards["seq_len"]
    run = str(conf.run_dir)
    return MatchersJob(dataset, method, int(seq_len), ComparedInputs.from_setting(
        experiment_inputs(run, conf, dataset, method, seq_len), "inputs"), {method: str(files["distances"])},
        conf.table_split, validation_split(conf.eval_splits), plan.datasets[dataset].truth, conf.baselines,
        tuple(conf.modes), conf.allow_split_overlap, out)


# its comparison picks the best training-free scorer of every registered one: a scorer plugin installed reruns it
JOB = Job(COMPARE_MATCHERS, relative(matchers_path("", "{dataset}", "{method}", "{seq_len}")), inputs, record,
          layout=True, params=SCORERS_PARAM, rule="matchers")

SECTION = Declared(NAME, "Does SMR help each sequence matcher?", (NAME,), prose(NAME, far_below=f"{FAR_BELOW:g}"),
                   NAME, view=lambda b, f, shown: (b.compact(NAME, b.anchor(NAME, f), shown, TABLE.caption),),
                   sentences=lambda b, shown: matcher_sentences(shown), headline=comparison_sentence,
                   after="baselines")


def draw(figure: Figure, out_dir: Path, inputs: Inputs) -> list[WrittenFigure]:
    """One figure per dataset, L and mode of the experiment: each matcher's reduction per method, the native
    confidence's beside it."""
    # the drawing's module (matplotlib): imported when the report draws, not when the workflow imports this one
    from vpr_smr.eval.report import figures as fig

    groups: dict[tuple[str, int, str], list[MatchersRow]] = {}
    for row in matcher_rows(inputs.matchers, inputs.order):
        groups.setdefault((row.dataset, row.seq_len, row.mode), []).append(row)
    out = []
    for (dataset, seq_len, mode), group in groups.items():
        title = (f"{dataset}, L={seq_len}, {mode} mode ({inputs.split}{inputs.correct(dataset)}): AOC reduction of "
                 f"each matcher's predictor and, hatched, of its native confidence at the same budget, on the "
                 f"{group[0].n_queries} queries every matcher evaluates")
        path = fig.matchers_figure(out_dir / figure.file(dataset=dataset, seq_len=seq_len, mode=mode), group,
                                   list(dict.fromkeys(r.method for r in group)),
                                   list(dict.fromkeys(r.matcher for r in group)), title)
        out.append(WrittenFigure(figure.name, f"{figure.title}: {dataset}, L={seq_len}, {mode} mode", path,
                                 dataset, seq_len, mode))
    return out


FIGURE = Figure(NAME, "Matchers", (NAME,), "matchers_{dataset}_L{seq_len}_{mode}.png", draw=draw)

EXPERIMENT = Experiment(NAME, "each matcher of `matchers` with its own predictor at table_seq_len: Table I's "
                        "numbers, the best training-free scorer and the matcher's own confidence, on the queries "
                        "every matcher evaluates", (JOB,), (replace(TABLE, section=SECTION),), (FIGURE,))


# --- the compared matchers' own attributes and predictors (rules/matchers.smk) -------------------------------------


def attributes_record(out: str, conf: Config, plan: Plan, wildcards: Mapping[str, str]) -> AttributesJob:
    """The attributes stage's job with the compared matcher of the ``tag`` instead of the run's own."""
    dataset, seq_len, split = wildcards["dataset"], wildcards["seq_len"], wildcards["split"]
    return AttributesJob(distances_path(out, dataset, wildcards["method"], split), int(seq_len),
                         plan.datasets[dataset].truth, compared_matchers(conf)[wildcards["tag"]],
                         candidates=conf.baselines.candidates,
                         out=matcher_attributes_path(out, dataset, wildcards["tag"], wildcards["method"], seq_len,
                                                     split))


def train_inputs(out: str, conf: Config, wildcards: Mapping[str, str]) -> dict[str, list[str]]:
    """The compared matcher's attributes the train stage reads: every method's of the train split (the pooled
    training order), then of each evaluation split."""
    dataset, tag, seq_len = wildcards["dataset"], wildcards["tag"], wildcards["seq_len"]
    return {"train": [matcher_attributes_path(out, dataset, tag, method, seq_len, conf.train_split)
                      for method in conf.methods],
            "evaluate": [matcher_attributes_path(out, dataset, tag, method, seq_len, split)
                         for split in conf.eval_splits for method in conf.methods]}


def train_record(out: str, conf: Config, wildcards: Mapping[str, str]) -> TrainJob:
    """The train stage's job of the compared matcher of the ``tag``: its attributes, its predictors' folder."""
    files = train_inputs(out, conf, wildcards)
    dataset, seq_len = wildcards["dataset"], wildcards["seq_len"]
    models = matcher_predictor_paths(out, dataset, wildcards["tag"], seq_len, conf.seeds)
    return TrainJob(dataset, int(seq_len), tuple(files["train"]), split_files(conf.eval_splits, files["evaluate"]),
                    training(conf), conf.seeds, models[0])
