"""The experiment ``restoration`` (method §9): the second filter, a removed match replaced by the next candidate the
predictor trusts, against removal alone.

A table-only experiment: no job of its own, the evaluation jobs compute it (``eval.scoring.restoration``, in the
``evaluate`` rule's files of a run with restoration); its figures ``restoration`` and ``restoration_auc`` are
declared here and drawn by the report beside the PR curves, from the same evaluations (``build``), and its section,
declared on its table here, follows the trust levels' on the page.
"""

from __future__ import annotations

from vpr_smr.eval.report import rows
from vpr_smr.eval.report import tabulate as make
from vpr_smr.eval.report.sections import Declared, prose
from vpr_smr.eval.report.table_spec import Figure, Table
from vpr_smr.pipeline.experiment import Experiment

NAME = "restoration"

SECTION = Declared("restoration", "Match restoration", (NAME,), prose("restoration"), "restoration",
                   view=lambda b, f, shown: (b.compact(NAME, b.anchor("restoration", f), shown),),
                   aside="restoration_auc", after="trust-levels")

TABLE = Table(
    NAME, "Match restoration (second filter): removal against restoration", ("table1", NAME),
    row=rows.RestorationRow, make=make.make_restoration,
    page=("method", "removed", "restored", "wrong_to_right", "right_to_wrong", "auc_difference"), section=SECTION)

# drawn by the report with the PR curves, per dataset, L and mode (``draw`` None: ``build``'s evaluation figures)
FIGURES = (
    Figure("restoration", "Restoration", ("table1", NAME), "restoration_{dataset}_L{seq_len}_{mode}.png"),
    Figure("restoration_auc", "Restoration PR AUC difference", ("table1", NAME),
           "restoration_auc_{dataset}_L{seq_len}_{mode}.png"),
)

EXPERIMENT = Experiment(NAME, "match restoration (method §9)", (), (TABLE,), FIGURES)
