"""Figures of the report (method §10), one PNG each, named predictably from the configuration.

Names (``<d>`` dataset, ``<L>`` sequence length, ``<mode>`` paper or standard):

- ``pr_<d>_L<L>_<mode>.png``: PR curves VPR+SM and VPR+SM+Pred, one panel per method.
- ``confusion_<d>_L<L>.png``: the seed-0 predictor's confusion matrix on the table split, all methods summed.
- ``trust_<d>_L<L>_<mode>.png``: PR curves at the configured trust levels, one panel per method.
- ``seq_len_<d>_<mode>.png``: PR AUC per method and sequence length, a bar from VPR+SM to VPR+SM+Pred.
- ``restoration_<d>_L<L>_<mode>.png``: PR curves of VPR+SM, removal and restoration, one panel per method.
- ``restoration_auc_<d>_L<L>_<mode>.png``: PR AUC of restoration minus removal per method (the paper's bars).
- ``speed_<d>_L<L>.png``: the speed experiment: sequence recall@1 and the AOC reduction against the query's speed.
- ``adaptive_<d>_<mode>.png``: the adaptive sequence length: AOC against the mean length used, a panel per matcher
  and method.
"""

from __future__ import annotations

import textwrap
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from vpr_smr.core.io import atomic_path
from vpr_smr.eval.report import names
from vpr_smr.eval.report.baselines import Comparison, headline
from vpr_smr.eval.report.outcome_words import SHORT, at_recall_zero
from vpr_smr.eval.report.rows import BaselineRow, SpeedRow, SweepRow
from vpr_smr.eval.report.tables.adaptive import AdaptiveSeqLenRow
from vpr_smr.eval.report.tables.matchers import MatchersRow
from vpr_smr.eval.scoring import scorers
from vpr_smr.eval.scoring.adaptive_records import FIXED, FIXED_PREDICTOR, RULE, RULES
from vpr_smr.eval.scoring.curves import LOST_ALL, REMOVED_ALL

UP, DOWN = "tab:green", "tab:red"
TITLE_POINTS = 14.4  # matplotlib's default figure and axes title size ("large": 1.2 x 12 pt)
CHAR_WIDTH = 0.62  # a character's mean width in DejaVu Sans, in units of the font size (a little generous)


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


NOTE_LINE = 7 * 1.4 / 72  # inches per line of a 7-point note under a figure's axes


def wrapped(title: str, width_inches: float, points: float = TITLE_POINTS) -> str:
    """``title`` broken into lines that fit ``width_inches`` at ``points`` (its own line breaks kept), so that no
    title runs past its figure's edge."""
    chars = max(16, int(width_inches * 72 / (CHAR_WIDTH * points)))
    return "\n".join(textwrap.fill(line, chars) for line in title.split("\n"))


def save(fig: Any, path: Path) -> Path:
    """Write the figure as PNG; ``bbox_inches="tight"`` grows the canvas to whatever was drawn, titles and legends
    included, so nothing is cut off."""
    plt = _pyplot()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png", bbox_inches="tight", pad_inches=0.1)
    plt.close(fig)
    return path


def _panels(n: int) -> tuple[Any, Any]:
    plt = _pyplot()
    fig, axes = plt.subplots(1, n, figsize=(3.2 * n, 3.3), squeeze=False)
    return fig, axes[0]


def _finish(fig: Any, axes: Any, title: str, legend_size: int = 8) -> None:
    axes[0].set_ylabel("precision")
    # the legend goes below the panels so that it never hides a curve
    handles, labels = axes[-1].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 6), fontsize=legend_size)
    fig.suptitle(wrapped(title, fig.get_figwidth()))
    fig.tight_layout(rect=(0, 0.1, 1, 1))


def pr_title(method: str, numbers: dict[str, Any]) -> str:
    """A PR panel's title: the AOCs at the predictor's maximum recall, or, where the predictor left no correct
    match (``outcome_words``), what it did and the baseline's own AOC at its own maximum recall."""
    outcome = numbers.get("outcome")
    if outcome in LOST_ALL:
        n, removed = int(numbers["n_queries"]), int(numbers["removed"])
        what = (f"removed all {n} matches" if outcome == REMOVED_ALL else
                f"kept {n - removed} of {n} matches, none correct")
        return (f"{method}\n{what}: recall 0\nVPR+SM AOC {numbers['aoc_vpr_sm_own']:.3f} at R "
                f"{numbers['max_recall_vpr_sm']:.2f}")
    text = f"{method}\nAOC {numbers[names.AOC_VPR_SM]:.3f} -> {numbers[names.AOC_VPR_SM_PRED]:.3f}"
    return f"{text} ({SHORT[outcome]})" if outcome in SHORT else text


def pr_figure(path: Path, panels: Sequence[tuple[str, dict[str, Any]]], title: str) -> Path:
    """``panels``: (method, that method's numbers of one mode) with ``curve_vpr_sm`` and ``curve_vpr_sm_pred``,
    ``outcome``, ``n_queries`` and ``removed``."""
    fig, axes = _panels(len(panels))
    for ax, (method, numbers) in zip(axes, panels, strict=True):
        for key, label in (("curve_vpr_sm", "VPR+SM"), ("curve_vpr_sm_pred", "VPR+SM+Pred")):
            ax.plot(numbers[key]["recall"], numbers[key]["precision"], label=label)
        ax.axvline(numbers["max_recall"], color="grey", lw=0.5, ls=":")
        ax.set(title=wrapped(pr_title(method, numbers), 3.0), xlabel="recall", ylim=(0, 1.02), xlim=(0, 1))
    _finish(fig, axes, title)
    return save(fig, path)


def trust_figure(path: Path, panels: Sequence[tuple[str, dict[str, Any]]], title: str) -> Path:
    """``panels``: (method, numbers of one mode) with ``trust`` (level -> curve) and ``curve_vpr_sm``."""
    fig, axes = _panels(len(panels))
    for ax, (method, numbers) in zip(axes, panels, strict=True):
        ax.plot(numbers["curve_vpr_sm"]["recall"], numbers["curve_vpr_sm"]["precision"], color="black", lw=0.8,
                ls="--", label="VPR+SM")
        for level, trust_curve in numbers["trust"].items():
            ax.plot(trust_curve["recall"], trust_curve["precision"], label=f"trust >= {level}")
        ax.set(title=wrapped(method, 3.0), xlabel="recall", ylim=(0, 1.02), xlim=(0, 1))
    _finish(fig, axes, title, legend_size=7)
    return save(fig, path)


def confusion_figure(path: Path, matrix: np.ndarray, title: str) -> Path:
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(3.8, 3.4))
    ax.imshow(matrix, cmap="Blues")
    for (i, j), value in np.ndenumerate(matrix):
        ax.text(j, i, str(value), ha="center", va="center", fontsize=8)
    ax.set(xlabel="predicted", ylabel="true", xticks=range(4), yticks=range(4), title=wrapped(title, 3.4))
    fig.tight_layout()
    return save(fig, path)


def change_bars(path: Path, methods: Sequence[str], groups: Sequence[str], bottoms: np.ndarray, tops: np.ndarray,
                title: str, ylabel: str = "PR AUC", markers: np.ndarray | None = None,
                marker_label: str = "") -> Path:
    """One bar per method and group (e.g. sequence length) from ``bottoms[m, g]`` to ``tops[m, g]``: green when
    the top is higher, red when lower (the paper's sequence-length figure); ``markers[m, g]`` (NaN: none), e.g. the
    best training-free scorer's value, a black cross on its bar (``marker_label`` in a legend)."""
    plt = _pyplot()
    n_methods, n_groups = len(methods), len(groups)
    fig, ax = plt.subplots(figsize=(max(4.0, min(12.0, 0.3 * n_methods * n_groups + 2)), 3.8))
    width = 0.8 / max(n_groups, 1)
    for g, group in enumerate(groups):
        x = np.arange(n_methods) - 0.4 + width * (g + 0.5)
        height = tops[:, g] - bottoms[:, g]
        colours = [UP if h >= 0 else DOWN for h in height]
        ax.bar(x, height, width=width * 0.9, bottom=bottoms[:, g], color=colours, edgecolor="black", lw=0.4)
        if markers is not None:
            ax.plot(x, markers[:, g], "x", color="black", ms=5, mew=1.2, label=marker_label if g == 0 else None)
        if n_groups > 1:
            for xi, top in zip(x, np.maximum(tops[:, g], bottoms[:, g]), strict=True):
                ax.text(xi, top, str(group), ha="center", va="bottom", fontsize=6)
    ax.set_xticks(np.arange(n_methods), list(methods), rotation=30, ha="right")
    shown = [bottoms, tops] + ([markers[~np.isnan(markers)]] if markers is not None else [])
    low, high = min(float(np.min(a)) for a in shown if a.size), max(float(np.max(a)) for a in shown if a.size)
    pad = max(0.02, 0.1 * (high - low))
    ax.set(ylabel=ylabel, title=wrapped(title, fig.get_figwidth() - 0.6),
           ylim=(max(0.0, low - pad), min(1.05, high + pad)))
    if markers is not None and marker_label:
        ax.legend(loc="best", fontsize=7)
    fig.tight_layout()
    return save(fig, path)


def difference_bars(path: Path, methods: Sequence[str], differences: Sequence[float], title: str,
                    ylabel: str = "PR AUC difference") -> Path:
    """One bar per method from 0: green above, red below (the paper's second-filter figure)."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(max(4.0, 0.7 * len(methods) + 2), 3.4))
    values = np.asarray(differences, dtype=float)
    ax.bar(np.arange(len(methods)), values, color=[UP if v >= 0 else DOWN for v in values], edgecolor="black", lw=0.4)
    ax.axhline(0, color="black", lw=0.6)
    ax.set_xticks(np.arange(len(methods)), list(methods), rotation=30, ha="right")
    ax.set(ylabel=ylabel, title=wrapped(title, fig.get_figwidth() - 0.6))
    fig.tight_layout()
    return save(fig, path)


def restoration_figure(path: Path, panels: Sequence[tuple[str, dict[str, Any]]], title: str) -> Path:
    """``panels``: (method, restoration numbers of one mode) with the three curves."""
    fig, axes = _panels(len(panels))
    for ax, (method, numbers) in zip(axes, panels, strict=True):
        for key, label in (("curve_vpr_sm", "VPR+SM"), ("curve_removal", "removal (VPR+SM+Pred)"),
                           ("curve_restoration", "restoration")):
            ax.plot(numbers[key]["recall"], numbers[key]["precision"], label=label)
        ax.set(title=wrapped(f"{method}\nAUC {numbers['auc_removal']:.3f} -> {numbers['auc_restoration']:.3f}",
                             3.0), xlabel="recall", ylim=(0, 1.02), xlim=(0, 1))
    _finish(fig, axes, title)
    return save(fig, path)


def sweep_figure(path: Path, rows: Sequence[SweepRow], methods: Sequence[str], title: str) -> Path:
    """The protocol sweep of one dataset, L and mode (``build.sweep_rows``' rows): recall@1 (left; sequence solid,
    single frame dotted) and the predictor's AOC reduction (right) against the ground truth's tolerance (frames) or
    radius (positions); one colour per method. An undefined reduction is a gap."""
    from matplotlib.lines import Line2D

    plt = _pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(9.6, 3.8))
    colours = {method: f"C{i % 10}" for i, method in enumerate(methods)}
    kind = rows[0].ground_truth if rows else "frames"
    xlabel = "tolerance (frames)" if kind == "frames" else "radius (the positions' unit)"
    thresholds = sorted({r.threshold for r in rows})
    for method in methods:
        mine = sorted((r for r in rows if r.method == method), key=lambda r: r.threshold)
        x = [r.threshold for r in mine]
        axes[0].plot(x, [r.recall_at_1_sequence for r in mine], "-", marker="o", ms=3, color=colours[method])
        axes[0].plot(x, [r.recall_at_1_single for r in mine], ":", lw=0.9, color=colours[method])
        reductions = [np.nan if r.reduction_pct is None else r.reduction_pct for r in mine]
        axes[1].plot(x, reductions, "-", marker="o", ms=3, color=colours[method])
    axes[0].set(xlabel=xlabel, ylabel="recall@1", ylim=(0, 1.02))
    axes[1].axhline(0, color="black", lw=0.6)
    axes[1].set(xlabel=xlabel, ylabel="AOC reduction by the predictor (%)")
    for ax in axes:
        ax.set_xticks(thresholds, [f"{t:g}" for t in thresholds])
    handles = [Line2D([], [], color=colours[m], lw=2, label=m) for m in methods]
    handles += [Line2D([], [], color="black", ls="-", label="after sequence matching"),
                Line2D([], [], color="black", ls=":", lw=0.9, label="single frame")]
    fig.legend(handles=handles, loc="lower center", ncol=min(len(handles), 5), fontsize=8)
    fig.suptitle(wrapped(title, fig.get_figwidth()))
    fig.tight_layout(rect=(0, 0.12, 1, 1))
    return save(fig, path)


def speed_figure(path: Path, rows: Sequence[SpeedRow], methods: Sequence[str], title: str) -> Path:
    """The speed experiment of one dataset (``build.speed_rows``' rows): sequence recall@1 (left) and the
    predictor's AOC reduction (right) against the query's speed ratio, log scale. One colour per method; the fixed
    matcher dashed, velocity search solid; single-frame recall@1 a thin dotted line (it does not depend on the
    matcher). The varying profile is a marker at its mean speed (hollow: fixed, filled: velocity search)."""
    from matplotlib.lines import Line2D

    plt = _pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(9.6, 3.8))
    colours = {method: f"C{i % 10}" for i, method in enumerate(methods)}
    styles = {"fixed": "--", "velocity": "-"}
    constant = [r for r in rows if r.speed is not None]
    speeds = sorted({r.speed for r in constant if r.speed is not None})
    varying = [r for r in rows if r.speed is None]
    panels: tuple[tuple[Any, Callable[[SpeedRow], float | None], str], ...] = (
        (axes[0], lambda r: r.recall_at_1_sequence, "sequence recall@1"),
        (axes[1], lambda r: r.reduction_pct, "AOC reduction by the predictor (%)"))
    for i, (ax, of, ylabel) in enumerate(panels):
        for method in methods:
            for matcher, style in styles.items():
                line = sorted((r.speed, of(r)) for r in constant
                              if r.speed is not None and r.method == method and r.matcher == matcher)
                if line:
                    ax.plot([x for x, _ in line], [np.nan if y is None else y for _, y in line], style,
                            color=colours[method], marker="o", ms=3)
            for r in (r for r in varying if r.method == method):
                value = of(r)
                ax.plot([r.mean_speed], [np.nan if value is None else value], "D", ms=6, color=colours[method],
                        mfc=colours[method] if r.matcher == "velocity" else "none")
            if i == 0:
                single = sorted({(r.speed, r.recall_at_1_single) for r in constant
                                 if r.speed is not None and r.method == method})
                ax.plot([x for x, _ in single], [y for _, y in single], ":", lw=0.8, color=colours[method])
        if varying:  # name the markers once, above the highest
            values = [v for v in map(of, varying) if v is not None]
            if values:
                ax.annotate("varying", (varying[0].mean_speed, max(values)), textcoords="offset points",
                            xytext=(6, 6), ha="left", fontsize=7)
        if i == 1:
            ax.axhline(0, color="black", lw=0.6)
        ax.set_xscale("log")
        if speeds:
            ax.set_xticks(speeds, [f"{s:g}x" for s in speeds])
            ax.minorticks_off()
        ax.set(xlabel="query speed / reference speed", ylabel=ylabel)
        if i == 0:
            ax.set_ylim(0, 1.02)
    handles = [Line2D([], [], color=colours[m], lw=2, label=m) for m in methods]
    handles += [Line2D([], [], color="black", ls="--", label="fixed matcher"),
                Line2D([], [], color="black", ls="-", label="velocity search"),
                Line2D([], [], color="black", ls=":", lw=0.8, label="single frame")]
    if varying:
        handles += [Line2D([], [], color="black", marker="D", ls="", mfc="none", label="varying, fixed"),
                    Line2D([], [], color="black", marker="D", ls="", label="varying, velocity")]
    fig.legend(handles=handles, loc="lower center", ncol=min(len(handles), 5), fontsize=8)
    fig.suptitle(wrapped(title, fig.get_figwidth()))
    fig.tight_layout(rect=(0, 0.12, 1, 1))
    return save(fig, path)


# --- the training-free baselines (method §12) -------------------------------------------------------------------

def baselines_figure(path: Path, rows: Sequence[BaselineRow], comparison: Comparison, title: str) -> Path:
    """Each scorer's AOC reduction per method at the seed-0 predictor's budget (``report.baselines.baseline_rows``
    of one dataset, mode and L): a group of bars per method, the training-free scorers first, the best of them
    (``comparison.best``, edged) just before the predictor's bar, each with its 95 % interval over the queries as an
    error bar; random as its mean over the seeds with the sample standard deviation as its error bar; the oracle's
    reduction a dashed line over the group (the ceiling at that budget). An undefined reduction has no bar and is
    named under the axis."""
    plt = _pyplot()
    methods = list(comparison.methods)
    best = comparison.best
    order = [name for name in scorers.names() if name not in ("oracle", "predictor", best)]
    order += ([best] if best is not None else []) + ["predictor"]
    by = {(r.method, r.scorer): r for r in rows}
    fig, ax = plt.subplots(figsize=(max(5.0, min(14.0, 0.55 * len(order) * len(methods) + 2.5)), 4.2))
    width = 0.8 / len(order)
    missing = []
    for s, scorer in enumerate(order):
        x = np.arange(len(methods)) - 0.4 + width * (s + 0.5)
        values, below, above = [], [], []
        for method in methods:
            row = by.get((method, scorer))
            value = None if row is None else headline(row)
            values.append(np.nan if value is None else value)
            low, high = (0.0, 0.0) if row is None or value is None else _whisker(row, value)
            below.append(low)
            above.append(high)
            if value is None and row is not None:
                missing.append(f"{method}: {scorer} ({SHORT.get(row.outcome, 'undefined')})")
        label = scorer + (" (best training-free)" if scorer == best else "")
        ax.bar(x, values, width=width * 0.92, color=scorers.colour(scorer), label=label,
               edgecolor="black", lw=1.2 if scorer in (best, "predictor") else 0.3,
               yerr=np.array([below, above]), capsize=2)
    for m, method in enumerate(methods):
        oracle = by.get((method, "oracle"))
        ceiling = None if oracle is None else oracle.reduction_pct
        if ceiling is not None:
            ax.hlines(ceiling, m - 0.42, m + 0.42, colors="black", linestyles="--", lw=1.0,
                      label="oracle (ceiling)" if m == 0 else None)
    ax.axhline(0, color="black", lw=0.6)
    ax.set_xticks(np.arange(len(methods)), methods, rotation=20, ha="right")
    ax.set(ylabel="AOC reduction at the predictor's budget (%)", title=wrapped(title, fig.get_figwidth() - 0.6))
    # the legend right of the axes, the note under them: neither covers the other or a bar
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0, fontsize=7)
    bottom = 0.0
    if missing:
        note = wrapped("undefined: " + "; ".join(missing), fig.get_figwidth(), 7)
        fig.text(0.01, 0.005, note, fontsize=7, va="bottom")
        bottom = min(0.5, 0.02 + NOTE_LINE * (note.count("\n") + 1) / fig.get_figheight())
    fig.tight_layout(rect=(0, bottom, 1, 1))
    return save(fig, path)


def _whisker(row: BaselineRow, value: float) -> tuple[float, float]:
    """How far the error bar of ``value`` reaches below and above its bar: random's seed standard deviation each
    way, any other scorer's 95 % interval over the queries (a percentile interval may leave out its own point, then
    the bar's side is 0); none without an interval."""
    if row.scorer == "random":
        spread = row.reduction_pct_std or 0.0
        return spread, spread
    interval = row.reduction_pct_ci
    if interval is None:
        return 0.0, 0.0
    return max(0.0, value - interval.low), max(0.0, interval.high - value)


def detection_figure(path: Path, panels: Sequence[tuple[str, Any]], title: str) -> Path:
    """Precision-recall curves of detecting the wrong sequence matches, one panel per method (``panels``: method
    and its ``records.SplitBaselines``): each scorer's curve as the steps its average precision sums (random's first
    seed), the fraction of wrong matches (a random ranking's expected precision) dotted."""
    fig, axes = _panels(len(panels))
    for ax, (method, found) in zip(axes, panels, strict=True):
        for scorer in (name for name in scorers.names() if name in found.detection):
            numbers = found.detection[scorer]
            if numbers.curve is None or not numbers.curve.recall:
                continue
            recall = [0.0, *numbers.curve.recall]
            precision = [numbers.curve.precision[0], *numbers.curve.precision]
            ax.plot(recall, precision, drawstyle="steps-pre", color=scorers.colour(scorer), label=scorer,
                    lw=1.6 if scorer == "predictor" else 1.0, ls="--" if scorer == "oracle" else "-")
        ax.axhline(found.wrong_fraction, color="grey", lw=0.8, ls=":", label="fraction of wrong matches")
        ax.set(title=wrapped(f"{method}\n{found.n_wrong} of {found.n_queries} matches wrong", 3.0),
               xlabel="recall of wrong matches", ylim=(0, 1.02), xlim=(0, 1))
    _finish(fig, axes, title, legend_size=7)
    return save(fig, path)


def matchers_figure(path: Path, rows: Sequence[MatchersRow], methods: Sequence[str], matchers: Sequence[str],
                    title: str) -> Path:
    """The experiment matchers of one dataset, L and mode (``tables.matchers``' rows): one panel per method, per
    matcher the seed-0 predictor's AOC reduction (its 95 % interval as a whisker) and the native confidence's at the
    same budget beside it (hatched). An undefined reduction is a bar of height 0 (nothing drawn). A reduction is at
    most 100 %, but below 0 it has no bound (a baseline AOC near 0): bars and whiskers are cut at -100 %, a cut bar
    labelled with its value."""
    floor = -100.0
    fig, axes = _panels(len(methods))
    width = 0.38
    x = np.arange(len(matchers))
    series: tuple[tuple[float, Callable[[MatchersRow], float | None], str, str, str], ...] = (
        (-width / 2, lambda r: r.reduction_pct, "predictor (seed 0)", "tab:blue", ""),
        (width / 2, lambda r: r.native_reduction_pct, "native confidence, same budget", "tab:orange", "//"))
    for ax, method in zip(axes, methods, strict=True):
        by = {r.matcher: r for r in rows if r.method == method}
        for offset, of, label, colour, hatch in series:
            values = np.array([(of(by[m]) if m in by else None) or 0.0 for m in matchers], dtype=float)
            ax.bar(x + offset, np.maximum(values, floor), width, color=colour, hatch=hatch, edgecolor="black", lw=0.4,
                   label=label)
            for cut in np.flatnonzero(values < floor):
                ax.annotate(f"{values[cut]:.0f}", (x[cut] + offset, floor), xytext=(0, 2), textcoords="offset points",
                            ha="center", va="bottom", fontsize=7, rotation=90)
        for i, matcher in enumerate(matchers):
            interval = by[matcher].reduction_pct_ci if matcher in by else None
            if interval is not None:
                ax.plot([x[i] - width / 2] * 2, [max(interval.low, floor), max(interval.high, floor)], color="black",
                        lw=0.8)
        ax.axhline(0, color="black", lw=0.6)
        ax.set_xticks(x, list(matchers), rotation=30, ha="right")
        ax.set(title=method)
    _finish(fig, axes, title)
    axes[0].set_ylabel("AOC reduction (%)")
    return save(fig, path)


RULE_STYLE = dict(zip(RULES, (("^", "tab:red"), ("v", "tab:purple"), ("D", "tab:green")), strict=True))


def adaptive_figure(path: Path, rows: Sequence[AdaptiveSeqLenRow], methods: Sequence[str], matchers: Sequence[str],
                    title: str) -> Path:
    """The experiment adaptive_seq_len of one dataset and mode (``tables.adaptive``' rows): a panel per matcher
    (rows of panels) and method (columns), the seed-0 AOC at each row's own maximum recall (y, its 95 % interval as
    a whisker) against the mean sequence length used (x): the fixed lengths without their predictor (circles,
    joined), with it (squares, joined), each rule its own marker; the best fixed row ringed. A row that keeps no
    correct match has no AOC to compare: it is left out of its panel, which names it."""
    plt = _pyplot()
    fig, grid = plt.subplots(len(matchers), len(methods), figsize=(3.4 * len(methods), 3.2 * len(matchers) + 0.5),
                             squeeze=False)
    series = ((FIXED, "o", "-", "tab:blue", "fixed length"),
              (FIXED_PREDICTOR, "s", "--", "tab:orange", "fixed length + its predictor"))
    for i, matcher in enumerate(matchers):
        for j, method in enumerate(methods):
            ax = grid[i][j]
            found = [r for r in rows if r.matcher == matcher and r.method == method]
            shown = [r for r in found if not at_recall_zero(r.outcome)]
            for kind, marker, style, colour, label in series:
                line = sorted((r for r in shown if r.kind == kind), key=lambda r: r.mean_length)
                ax.plot([r.mean_length for r in line], [r.aoc for r in line], marker=marker, ls=style,
                        color=colour, label=label)
                for r in line:
                    ax.annotate(f"L{r.seq_len}", (r.mean_length, r.aoc), xytext=(3, 3),
                                textcoords="offset points", fontsize=7, color=colour)
            for r in (r for r in shown if r.kind == RULE):
                marker, colour = RULE_STYLE.get(r.name, ("*", "black"))
                ax.plot([r.mean_length], [r.aoc], marker=marker, ls="", ms=8, color=colour, label=r.name)
            for r in shown:
                if r.aoc_ci is not None:
                    ax.plot([r.mean_length] * 2, [r.aoc_ci.low, r.aoc_ci.high], color="grey", lw=0.7)
            best = [r for r in shown if r.name == r.best_fixed]
            ax.plot([r.mean_length for r in best], [r.aoc for r in best], marker="o", ms=15, ls="",
                    mfc="none", mec="black", label="best fixed row (least precision lost: AOC / max recall)")
            left = [r.name for r in found if r not in shown]
            note = f"\nno correct match kept: {', '.join(left)}" if left else ""
            ax.margins(x=0.15)  # room for the lengths' labels at the ends
            ax.set(title=wrapped(f"{method} · {matcher}{note}", 3.2, 9), xlabel="mean sequence length used")
            ax.title.set_fontsize(9)
        grid[i][0].set_ylabel("AOC at max recall")
    labels: dict[str, Any] = {}
    for ax in grid.flat:  # each label once, whichever panel has it
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            labels.setdefault(label, handle)
    fig.legend(list(labels.values()), list(labels), loc="lower center", ncol=min(len(labels), 6), fontsize=8)
    fig.suptitle(wrapped(title, fig.get_figwidth()))
    fig.tight_layout(rect=(0, 0.4 / fig.get_figheight(), 1, 1))  # the legend's line below the panels
    return save(fig, path)
