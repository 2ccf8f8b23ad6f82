"""The experiment ``deployment``'s figure (method §16): one row of panels per method, the run's matcher (the first
of each result).

Per target one panel: each source and rule's realised precision (its 95 % interval as a whisker) against its
recall on the deployments, the source by colour (``scorers.colour``), the rule by marker, filled on the dataset's own
splits and hollow on another dataset's (``<dataset>/<split>``: the larger shift), the target dashed; a rule that
accepts nothing is left out (it has no precision). Last, the calibration split's risk-coverage curve of each
source (seed 0 of the predictor's), the thresholds the rules chose marked on it.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from vpr_smr.eval.report.figures import _pyplot, save, wrapped
from vpr_smr.eval.scoring import scorers
from vpr_smr.eval.scoring.deployment_records import DeploymentResult
from vpr_smr.eval.scoring.thresholds import RULES

__all__ = ["deployment_figure"]

MARKERS = dict(zip(RULES, ("o", "s", "^"), strict=True))


def _colour(source: str) -> str:
    try:
        return scorers.colour(source)
    except (KeyError, ValueError):  # a source whose scorer is no longer registered
        return "grey"


def deployment_figure(path: Path, results: Sequence[DeploymentResult], title: str) -> Path:
    """The figure of one dataset and L (``results``: one per method, in the table's order)."""
    plt = _pyplot()
    targets = list(results[0].meta["precisions"])
    columns = len(targets) + 1
    fig, axes = plt.subplots(len(results), columns, figsize=(3.3 * columns, 3.2 * len(results)), squeeze=False)
    for row, result in zip(axes, results, strict=True):
        own = result.rows[0].matcher if result.rows else ""
        rows = [r for r in result.rows if r.matcher == own and r.seed in (None, 0)]
        for ax, target in zip(row, targets, strict=False):
            drawn = 0
            for r in rows:
                if r.precision != target or r.realised.precision is None:
                    continue
                found = r.realised.precision_ci
                point = r.realised.precision
                yerr = None if found is None else [[point - found.low], [found.high - point]]
                colour = _colour(r.source)
                ax.errorbar(r.realised.recall, point, yerr=yerr, fmt=MARKERS.get(r.rule, "x"), color=colour,
                            mfc="none" if "/" in r.deployment else colour, ms=5, lw=0.7, alpha=0.85)
                drawn += 1
            if not drawn:  # every rule abstained (or no row at this target): say so rather than an empty frame
                ax.text(0.5, 0.5, "nothing accepted", ha="center", va="center", transform=ax.transAxes)
            ax.axhline(target, color="black", ls="--", lw=0.8)
            ax.set(title=f"{result.meta['method']}: p = {target:g}", xlabel="recall on the deployments",
                   ylabel="realised precision")
        ax = row[-1]
        for curve in result.curves:
            if curve.matcher != own:
                continue
            ax.plot(curve.coverage, curve.risk, color=_colour(curve.source), lw=1.0, label=curve.source)
            coverage, risk, cuts = (np.asarray(curve.coverage), np.asarray(curve.risk), np.asarray(curve.thresholds))
            for chosen in curve.chosen:
                if chosen.threshold is None or not len(cuts):
                    continue
                at = int(np.argmin(np.abs(cuts - chosen.threshold))) if np.isfinite(chosen.threshold) else 0
                ax.plot(coverage[at], risk[at], MARKERS.get(chosen.rule, "x"), color=_colour(curve.source), ms=5,
                        mfc="none")
        ax.set(title=f"{result.meta['method']}: risk-coverage on {result.meta['calibration']}",
               xlabel="coverage (accepted fraction)", ylabel="risk (1 - precision)")
    own = results[0].rows[0].matcher if results[0].rows else ""
    sources = dict.fromkeys([*(r.source for result in results for r in result.rows if r.matcher == own),
                             *(c.source for result in results for c in result.curves if c.matcher == own)])
    handles = [plt.Line2D([], [], color=_colour(source), lw=1.5, label=source) for source in sources]
    handles += [plt.Line2D([], [], color="black", marker=MARKERS[rule], ls="none", label=rule) for rule in RULES]
    if any("/" in name for result in results for name in result.meta["deployments"]):
        handles.append(plt.Line2D([], [], color="black", marker="o", mfc="none", ls="none",
                                  label="hollow: another dataset"))
    ncol = min(len(handles), 6)
    fig.legend(handles=handles, loc="lower center", ncol=ncol, fontsize=8)
    legend = 0.3 * -(-len(handles) // ncol) / fig.get_figheight()  # its rows' height, as a fraction of the figure
    fig.suptitle(wrapped(title, fig.get_figwidth()))
    fig.tight_layout(rect=(0, legend, 1, 1))
    return save(fig, path)
