"""The experiment ``protocol_sweep`` (method §13): recall@1 and Table I's reduction at table_seq_len over other
ground-truth tolerances (frames) or radii (positions), from the same matches and the same seed-0 predictor.

A table-only experiment: no job of its own, the VPR metrics jobs compute it (``eval.scoring.sweep``, in the
``metrics`` rule's files of a run with the sweep); its figure ``protocol_sweep``, declared and drawn here, and its
section, declared on its table here, follows the standard VPR metrics' on the page. Datasets whose ground truth is a
file have none.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from vpr_smr.eval.report import names, rows
from vpr_smr.eval.report import tabulate as make
from vpr_smr.eval.report.results import WrittenFigure
from vpr_smr.eval.report.sections import Declared, prose
from vpr_smr.eval.report.table_spec import Figure, Pivot, Table
from vpr_smr.eval.report.tabulate import Inputs
from vpr_smr.pipeline.experiment import Experiment

NAME = "protocol_sweep"


def _sentences(shown: Sequence[rows.SweepRow]) -> list[str]:
    # the findings' module imports the scoring's (scikit-learn); the workflow's parsing imports this one
    from vpr_smr.eval.report.findings import sweep_sentences

    return sweep_sentences(shown)


def _headline(shown: Sequence[rows.SweepRow]) -> str:
    from vpr_smr.eval.report.findings import sweep_headline

    return sweep_headline(shown)


SECTION = Declared("protocol-sweep", "Protocol sweep", (NAME,), prose("protocol-sweep"), "protocol_sweep",
                   view=lambda b, f, shown: (b.pivot(NAME, b.anchor("protocol-sweep", f), shown),),
                   sentences=lambda b, shown: _sentences(shown), headline=_headline, after="vpr-metrics")

TABLE = Table(
    NAME, "Protocol sweep: recall@1 and the AOC reduction of the predictor under other ground-truth tolerances "
    "(frames) or radii (positions), from the same matches and the same seed-0 predictor (method §13)", (NAME,),
    row=rows.SweepRow, make=make.make_sweep, pivot=Pivot("threshold", ("method",), (names.REDUCTION,)),
    caption="AOC reduction (%) per tolerance or radius (rows) and method (columns); recall@1: the figure and the "
            "whole table below", section=SECTION)


def draw(figure: Figure, out_dir: Path, inputs: Inputs) -> list[WrittenFigure]:
    """One protocol-sweep figure per dataset, L and mode of the sweep's rows."""
    # the drawing's module (matplotlib): imported when the report draws, not when the workflow imports this one
    from vpr_smr.eval.report import figures as fig

    out = []
    groups: dict[tuple[str, int, str], list[rows.SweepRow]] = {}
    for row in make.sweep_rows(inputs.metrics, inputs.split, inputs.order):
        groups.setdefault((row.dataset, row.seq_len, row.mode), []).append(row)
    for (dataset, seq_len, mode), group in groups.items():
        title = f"{dataset}, L={seq_len}, {mode} mode ({inputs.split}): the same matches under other ground truths"
        path = fig.sweep_figure(out_dir / figure.file(dataset=dataset, seq_len=seq_len, mode=mode), group,
                                inputs.order.sorted_methods(r.method for r in group), title)
        out.append(WrittenFigure(figure.name, f"{figure.title}: {dataset}, L={seq_len}, {mode} mode", path,
                                 dataset, seq_len, mode))
    return out


FIGURE = Figure(NAME, "Protocol sweep", (NAME,), "protocol_sweep_{dataset}_L{seq_len}_{mode}.png", draw=draw)

EXPERIMENT = Experiment(NAME, "method §13: recall@1 and Table I's reduction at table_seq_len over the tolerances 0, 1, "
                        "2, 5 and 10 frames (radii 5, 10, 25 and 50 with positions)", (), (TABLE,),
                        (FIGURE,))
