"""The experiment ``adaptive_seq_len`` (method §15): per dataset, matcher and method, the sequence length chosen per
query by each length's predictor (or uniqueness) against every fixed length, with the live matcher's time.

A matcher of the experiment ``matchers`` other than the run's own reads the attributes and predictors that
experiment's rules compute under ``matchers/<dataset>/<tag>/``, here at every L of seq_lens. The stage is
``pipeline.stages.studies.ADAPTIVE`` (``vpr-smr adaptive``); its table is declared with its rows and sentences in
``eval.report.tables.adaptive`` (the report's page and ``vpr-smr adaptive``'s printout read them too), its figure
``adaptive_seq_len`` is declared and drawn here, and its section, declared here on that table (the experiment's tables
carry it; ``html.declared_sections`` reads it there), follows the sequence-length ablation's on the page.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vpr_smr.core.paths import adaptive_path, distances_path, timing_path
from vpr_smr.eval.predictor.defaults import validation_split
from vpr_smr.eval.report.results import WrittenFigure
from vpr_smr.eval.report.sections import Declared, Rows, prose
from vpr_smr.eval.report.table_spec import Figure
from vpr_smr.eval.report.tables.adaptive import (
    TABLE,
    AdaptiveSeqLenRow,
    adaptive_rows,
    adaptive_sentence,
    adaptive_sentences,
    query_counts,
)
from vpr_smr.eval.report.tabulate import Inputs
from vpr_smr.eval.scoring.study_jobs import AdaptiveJob
from vpr_smr.pipeline.experiment import Experiment, Job, Wildcard, relative
from vpr_smr.pipeline.rule_helpers import adaptive_files, adaptive_matchers, adaptive_predictors, length_files
from vpr_smr.pipeline.stages.studies import ADAPTIVE

if TYPE_CHECKING:
    from vpr_smr.eval.matching.matchers import MatcherSpec
    from vpr_smr.pipeline.config import Config
    from vpr_smr.pipeline.plan import Plan

NAME = "adaptive_seq_len"


def matchers(conf: Config) -> dict[str, MatcherSpec]:
    """Its matchers by tag: the run's own, then each matcher the experiment ``matchers`` compares where it is on."""
    from vpr_smr.pipeline.config import experiments

    return adaptive_matchers(conf, experiments(conf))


def tags(conf: Config, plan: Plan) -> list[str]:
    """The ``tag`` wildcard's values: its matchers' tags, the run's own first."""
    return list(matchers(conf))


def inputs(out: str, conf: Config, plan: Plan, wildcards: Mapping[str, str]) -> dict[str, str | Sequence[str]]:
    """Per split every length's attributes of the job's matcher, each length's predictors (every seed), and the
    table split's matrix (fed frame by frame to the live matcher: its time per query)."""
    dataset, tag, method = wildcards["dataset"], wildcards["tag"], wildcards["method"]
    spec = matchers(conf)[tag]
    validation = validation_split(conf.eval_splits)
    return {"table": adaptive_files(out, conf, spec, tag, dataset, method, conf.table_split),
            "validation": adaptive_files(out, conf, spec, tag, dataset, method, validation) if validation else [],
            "predictors": adaptive_predictors(out, conf, spec, tag, dataset),
            "distances": distances_path(out, dataset, method, conf.table_split)}


def record(conf: Config, plan: Plan, wildcards: Mapping[str, str], files: Mapping[str, Any], out: str
           ) -> AdaptiveJob:
    """Per split every length's attributes, each length's seed-0 predictor (the stage reads the other seeds beside
    it), the table split's matrix (the live timing), the scorers' settings."""
    validation = validation_split(conf.eval_splits)
    return AdaptiveJob(
        length_files([(conf.table_split, files["table"]), (validation, files["validation"])]),
        tuple(files["predictors"][:: conf.seeds]), conf.seeds, conf.table_split, validation, files["distances"],
        wildcards["dataset"], wildcards["method"], wildcards["tag"], conf.baselines, tuple(conf.modes),
        conf.allow_split_overlap, out)


OUTPUT = relative(adaptive_path("", "{dataset}", "{tag}", "{method}"))

JOB = Job(ADAPTIVE, OUTPUT, inputs, record, wildcards_from=(Wildcard("tag", tags),),
          also=(timing_path(OUTPUT),),  # the live timings beside the result (apart, so results repeat exactly)
          layout=True, rule="adaptive")


def _headline(rows: Rows) -> str:
    """The first screen's line of the length rules in one mode, where the mode compares them (``best_fixed``)."""
    return adaptive_sentence(rows) if any(r.best_fixed for r in rows) else ""


SECTION = Declared("adaptive-seq-len", "Choosing the sequence length per query", (NAME,), prose("adaptive-seq-len"),
                   NAME, view=lambda b, f, shown: (b.compact(NAME, b.anchor("adaptive-seq-len", f), shown,
                                                             TABLE.caption),),
                   sentences=lambda b, shown: adaptive_sentences(shown), headline=_headline, after="sequence-length")


def draw(figure: Figure, out_dir: Path, inputs: Inputs) -> list[WrittenFigure]:
    """One figure per dataset and mode: a panel per matcher and method, the AOC at maximum recall against the mean
    length used of every fixed length, with and without its predictor, and of every rule."""
    # the drawing's module (matplotlib): imported when the report draws, not when the workflow imports this one
    from vpr_smr.eval.report import figures as fig

    groups: dict[tuple[str, str], list[AdaptiveSeqLenRow]] = {}
    for row in adaptive_rows(inputs.adaptive, inputs.order):
        groups.setdefault((row.dataset, row.mode), []).append(row)
    out = []
    for (dataset, mode), group in groups.items():
        title = (f"{dataset}, {mode} mode ({inputs.split}{inputs.correct(dataset)}): AOC at maximum recall against "
                 f"the mean sequence length used, on {query_counts(group)} every length "
                 "evaluates")
        path = fig.adaptive_figure(out_dir / figure.file(dataset=dataset, mode=mode), group,
                                   list(dict.fromkeys(r.method for r in group)),
                                   list(dict.fromkeys(r.matcher for r in group)), title)
        out.append(WrittenFigure(figure.name, f"{figure.title}: {dataset}, {mode} mode", path, dataset, mode=mode))
    return out


# every matcher and method of the run in one figure (a panel each): the report's outputs need no matcher tags
FIGURE = Figure(NAME, "Adaptive sequence length", (NAME,), "adaptive_{dataset}_{mode}.png", draw=draw)

EXPERIMENT = Experiment(NAME, "the sequence length chosen per query by each length's predictor (or uniqueness) "
                        "against every fixed length, for every matcher of the run", (JOB,),
                        (replace(TABLE, section=SECTION),), (FIGURE,))
