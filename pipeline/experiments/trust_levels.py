"""The experiment ``trust_levels``: PR curves and AUC at every trust level of the configuration's ``trust_levels``
(a match the predictor marks wrong is removed only when its confidence is at least the level).

A table-only experiment: no job of its own, the evaluation jobs compute it (``eval.scoring.evaluate``, in the
``evaluate`` rule's files of a run with trust levels); its figure ``trust`` is declared here and drawn by the report
beside the PR curves, from the same panels (``build``), and its section, declared on its table here, follows the PR
curves' on the page.
"""

from __future__ import annotations

from vpr_smr.eval.report import names, rows
from vpr_smr.eval.report import tabulate as make
from vpr_smr.eval.report.sections import Declared, prose
from vpr_smr.eval.report.table_spec import Figure, Pivot, Table
from vpr_smr.pipeline.experiment import Experiment

NAME = "trust_levels"

SECTION = Declared("trust-levels", "Trust levels", (NAME,), prose("trust-levels"), "trust",
                   view=lambda b, f, shown: (b.pivot(NAME, b.anchor("trust", f), shown),), after="pr-curves")

TABLE = Table(
    NAME, "Trust-level ablation: PR AUC per trust level", ("table1", NAME),
    row=rows.TrustRow, make=make.make_trust, pivot=Pivot("trust", ("method",), (names.REDUCTION,)),
    caption="AOC reduction (%) per trust level (columns: methods)", section=SECTION)

# drawn by the report with the PR curves, per dataset, L and mode (``draw`` None: ``build``'s evaluation figures)
FIGURE = Figure("trust", "Trust levels", ("table1", NAME), "trust_{dataset}_L{seq_len}_{mode}.png")

EXPERIMENT = Experiment(NAME, "PR curves and AUC at every trust level", (), (TABLE,), (FIGURE,))
