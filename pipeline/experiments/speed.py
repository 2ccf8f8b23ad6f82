"""The experiment ``speed`` (method §11): each dataset's train and table splits re-driven at simulated speeds, the
fixed matcher against velocity search, at Table I's sequence length.

One job per dataset and profile, so that the profiles run side by side; each reads the distance matrices only (the
simulated queries are their columns). The stage is ``pipeline.stages.studies.SPEED`` (``vpr-smr speed``); its
figure ``speed``, declared and drawn here, and its section, declared on its table here, follow the adaptive sequence
length's on the page.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vpr_smr.core.paths import distances_path, speed_path
from vpr_smr.eval.predictor.defaults import PredictorParams
from vpr_smr.eval.report import names, rows
from vpr_smr.eval.report import tabulate as make
from vpr_smr.eval.report.results import WrittenFigure, unique
from vpr_smr.eval.report.sections import Declared, Rows
from vpr_smr.eval.report.table_spec import Figure, Pivot, Table
from vpr_smr.eval.report.tabulate import Inputs
from vpr_smr.eval.scoring.study_jobs import SpeedJob
from vpr_smr.pipeline.experiment import Experiment, Job, Wildcard, relative
from vpr_smr.pipeline.stages.studies import SPEED

if TYPE_CHECKING:
    from vpr_smr.eval.report.html import _Builder
    from vpr_smr.eval.report.view import TableView
    from vpr_smr.pipeline.config import Config
    from vpr_smr.pipeline.plan import Plan

NAME = "speed"


def profiles(conf: Config, plan: Plan) -> list[str]:
    """The profiles by name (``eval.scoring.speed``: ``0.5x``, ``varying``), in the configuration's order."""
    from vpr_smr.eval.scoring.speed import profile_names  # the work's module: imported when a run asks

    return profile_names(conf.speed.profiles)


def inputs(out: str, conf: Config, plan: Plan, wildcards: Mapping[str, str]) -> dict[str, Sequence[str]]:
    """Every method's train and table split distances, in the configuration's order (the pooled training order,
    method §7)."""
    return {"train": [distances_path(out, wildcards["dataset"], method, conf.train_split) for method in conf.methods],
            "table": [distances_path(out, wildcards["dataset"], method, conf.table_split) for method in conf.methods]}


def record(conf: Config, plan: Plan, wildcards: Mapping[str, str], files: Mapping[str, Any], out: str) -> SpeedJob:
    """The profile, the velocity search set, the dataset's tolerance, every method's train and table split, the
    predictor's settings."""
    dataset = wildcards["dataset"]
    return SpeedJob(dataset, int(wildcards["seq_len"]), wildcards["profile"], tuple(conf.speed.velocities),
                    plan.datasets[dataset].tolerance, dict(zip(conf.methods, files["train"], strict=True)),
                    dict(zip(conf.methods, files["table"], strict=True)), PredictorParams.of(conf.predictor.to_json()),
                    conf.allow_split_overlap, out)


JOB = Job(SPEED, relative(speed_path("", "{dataset}", "{seq_len}", "{profile}")), inputs, record,
          wildcards_from=(Wildcard("profile", profiles),),
          # one BLAS thread per job: OpenBLAS's default (a thread per core) makes two jobs side by side on 2 cores
          # fight over them, measured 3 to 7 times slower than one thread each; the numbers are the same (the demo)
          threads=1, layout=True)

def _intro(b: _Builder) -> tuple[str, ...]:
    velocities = unique(r.velocities.replace(" ", ", ") for r in b.records(NAME, rows.SpeedRow)
                        if r.matcher == "velocity")
    return (
        "The table split's query re-driven at other speeds (method §11): a constant profile c advances c places "
        "per query frame (the query driven c times as fast; 1x is the aligned pair), the varying one "
        "1 + 0.5 sin(2 pi t / 200) places; the query's frames are the nearest to its positions, its distance "
        "matrix the aligned one's columns, and a match is correct within the tolerance of its position. The "
        "fixed matcher is the paper's (slope 1); velocity search tries the slopes "
        f"{'; '.join(velocities)} reference frames per query frame. Each matcher has its own seed-0 predictor, "
        "trained on its own features of the same profile's train split; the numbers are Table I's, paper mode.",)


def _view(b: _Builder, figure: WrittenFigure, shown: Rows) -> tuple[TableView, ...]:
    from vpr_smr.eval.report.html import speed_table  # the page's module: it imports the registry, which this one

    return (speed_table(b.anchor("speed", figure), shown),)


def _sentences(b: _Builder, shown: Rows) -> list[str]:
    # the findings' module imports the scoring's (scikit-learn); the workflow's parsing imports this one
    from vpr_smr.eval.report.findings import speed_sentences

    return speed_sentences(shown, b.split)


SECTION = Declared(NAME, "Speed profiles", (NAME,), _intro, NAME, view=_view, sentences=_sentences,
                   after="adaptive-seq-len")

TABLE = Table(
    NAME, "Speed profiles: recall@1 and the Table I AOC numbers of the fixed matcher and of velocity search on "
    "simulated queries driven at other speeds (method §11), per dataset, method, profile and matcher", (NAME,),
    row=rows.SpeedRow, make=make.make_speed,
    pivot=Pivot("profile", ("method", "matcher"), (names.RECALL_SEQUENCE, names.REDUCTION)),
    caption="Sequence recall@1, then the predictor's AOC reduction (%), per profile (rows) and method · matcher "
            "(columns); single-frame recall@1 and the AOCs: the whole table below", section=SECTION)


def draw(figure: Figure, out_dir: Path, inputs: Inputs) -> list[WrittenFigure]:
    """One speed figure per dataset and L of the speed experiment's rows."""
    # the drawing's module (matplotlib): imported when the report draws, not when the workflow imports this one
    from vpr_smr.eval.report import figures as fig

    out = []
    groups: dict[tuple[str, int], list[rows.SpeedRow]] = {}
    for row in make.speed_rows(inputs.speed, inputs.order):
        groups.setdefault((row.dataset, row.seq_len), []).append(row)
    for (dataset, seq_len), group in groups.items():
        title = (f"{dataset}, L={seq_len}, paper mode ({inputs.split}{inputs.correct(dataset)}): simulated query "
                 "speeds, fixed matcher against velocity search")
        path = fig.speed_figure(out_dir / figure.file(dataset=dataset, seq_len=seq_len), group,
                                inputs.order.sorted_methods(r.method for r in group), title)
        out.append(WrittenFigure(figure.name, f"{figure.title}: {dataset}, L={seq_len}", path, dataset, seq_len))
    return out


FIGURE = Figure(NAME, "Speed profiles", (NAME,), "speed_{dataset}_L{seq_len}.png", draw=draw)

EXPERIMENT = Experiment(NAME, "simulated speed profiles (method §11) at table_seq_len: the fixed matcher against "
                        "velocity search", (JOB,), (TABLE,), (FIGURE,))
