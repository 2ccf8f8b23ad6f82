"""The experiment ``protocol_sweep`` (method §13): recall@1 and Table I's reduction at table_seq_len over other
ground-truth tolerances (frames) or radii (positions), from the same matches and the same seed-0 predictor.

A table-only experiment: no job of its own, the VPR metrics jobs compute it (``eval.scoring.sweep``, in the
``metrics`` rule's files of a run with the sweep); its figure is ``registry.FIGURES``' ``protocol_sweep``, and its
section, declared on its table here, follows the standard VPR metrics' on the page. Datasets whose ground truth is a
file have none.
"""

from __future__ import annotations

from collections.abc import Sequence

from vpr_smr.eval.report import names, rows
from vpr_smr.eval.report import tabulate as make
from vpr_smr.eval.report.sections import Declared, prose
from vpr_smr.eval.report.table_spec import Pivot, Table
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

EXPERIMENT = Experiment(NAME, "method §13: recall@1 and Table I's reduction at table_seq_len over the tolerances 0, 1, "
                        "2, 5 and 10 frames (radii 5, 10, 25 and 50 with positions)", (), (TABLE,))
