"""The experiment ``deployment``'s table, sentences, figure and section (method §16): thresholds set on the
calibration split by each rule, for every confidence source, and what they do on each deployment.

One row per dataset, L, method, matcher, source (the predictor: seed 0, its other seeds counted in
``seeds_violated``), target, rule and deployment. ``outcome`` is the method's: held (precision at least the
target), violated (below it) or abstained (nothing accepted, never a success); ``against_target`` says what the
precision's interval over the deployment's queries supports: ``interval_above`` the target, ``interval_below``, or
``interval_holds_target`` (the interval holds it: the outcome could be the other on other queries of the route),
``no_interval``. The sentences count deployments and never call a rule safe: one deployment split is one stretch of
one route.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from vpr_smr.eval.report.results import Order, WrittenFigure
from vpr_smr.eval.report.rows import column, interval
from vpr_smr.eval.report.sections import Declared, prose
from vpr_smr.eval.report.table_spec import Figure, Table
from vpr_smr.eval.report.tabulate import Inputs
from vpr_smr.eval.scoring.deployment_records import PREDICTOR_SOURCE, DeploymentResult, DeploymentRow
from vpr_smr.eval.scoring.records import Interval
from vpr_smr.eval.scoring.scorers import ORACLE
from vpr_smr.eval.scoring.thresholds import ABSTAINED, HELD, RULES, VIOLATED

__all__ = ["FIGURES", "NAME", "TABLES", "DeploymentTableRow", "against_target", "deployment_rows", "headline",
           "target_sentences"]

NAME = "deployment"
ABOVE, BELOW, HOLDS, NO_INTERVAL = "interval_above", "interval_below", "interval_holds_target", "no_interval"
PAGE = ("method", "source", "rule", "precision_target", "threshold", "precision", "precision_ci_low",
        "precision_ci_high", "recall",
        "ceiling_recall", "outcome", "against_target", "segments_violated", "seeds_violated")


def against_target(found: Interval | None, target: float) -> str:
    """What the precision's interval says of the target: wholly above it (or at it), wholly below, holding it, or
    no interval (nothing accepted, or too few draws that accept anything)."""
    if found is None:
        return NO_INTERVAL
    if found.low >= target:
        return ABOVE
    return BELOW if found.high < target else HOLDS


@dataclass(frozen=True)
class DeploymentTableRow:
    """``deployment``: one source, rule and target of one matcher and method, calibrated on ``calibration`` and
    scored on ``deployment``."""

    dataset: str = column()
    seq_len: int = column()
    method: str = column()
    matcher: str = column()
    source: str = column()
    rule: str = column()
    precision_target: float = column("target p", ".2f")
    risk: float | None = column("risk delta", ".2f")
    calibration: str = column()
    n_calibration: int = column("calibration queries")
    threshold: float | None = column("threshold t", ".6g")  # None: the rule abstains (accepts nothing)
    calibration_accepted: int = column("accepted on calibration")
    deployment: str = column()
    n_deployment: int = column("deployment queries")
    accepted_fraction: float = column("accepted fraction")
    precision: float | None = column("precision")  # None: nothing accepted (never 0 or 1)
    precision_ci: Interval | None = interval("precision")
    recall: float = column("recall")
    recall_ci: Interval | None = interval("recall")
    outcome: str = column()
    against_target: str = column("interval vs target")
    ceiling_recall: float = column("ceiling recall")
    recall_lost: float = column("recall lost")
    segments_violated: str = column("segments below p")
    seeds_violated: str = column("seeds violated", if_any=True)

    @classmethod
    def of(cls, result: DeploymentResult, row: DeploymentRow, seeds: Sequence[DeploymentRow]) -> DeploymentTableRow:
        meta, realised = result.meta, row.realised
        violated = sum(1 for r in seeds if r.outcome == VIOLATED)
        return cls(
            str(meta["dataset"]), int(meta["seq_len"]), str(meta["method"]), row.matcher, row.source, row.rule,
            row.precision, row.risk, str(meta["calibration"]), row.calibration.n_queries, row.calibration.threshold,
            row.calibration.accepted, row.deployment, realised.n_queries, realised.accepted_fraction,
            realised.precision, realised.precision_ci, realised.recall, realised.recall_ci, row.outcome,
            against_target(realised.precision_ci, row.precision), row.ceiling.recall,
            row.recall_lost, f"{row.segments.violated} of {row.segments.with_acceptance}",
            f"{violated} of {len(seeds)}" if row.source == PREDICTOR_SOURCE else "")


def deployment_rows(results: Sequence[DeploymentResult], order: Order | None = None) -> list[DeploymentTableRow]:
    """One row per dataset, L, method, matcher, source (seed 0), target, rule and deployment: datasets and methods in
    the configuration's order, the rest as the files list them."""
    if order is not None:
        results = sorted(results, key=lambda r: (order.dataset(str(r.meta["dataset"])), int(r.meta["seq_len"]),
                                                 order.method(str(r.meta["method"]))))
    out = []
    for result in results:
        seeds: dict[tuple[str, str, str, float, str], list[DeploymentRow]] = {}
        for row in result.rows:
            if row.source == PREDICTOR_SOURCE:
                seeds.setdefault((row.matcher, row.deployment, row.rule, row.precision, row.source), []).append(row)
        for row in result.rows:
            if row.seed in (None, 0):
                out.append(DeploymentTableRow.of(result, row, seeds.get(
                    (row.matcher, row.deployment, row.rule, row.precision, row.source), [])))
    return out


def make_deployment(inputs: Inputs) -> list[DeploymentTableRow] | None:
    return deployment_rows(inputs.deployment, inputs.order) if inputs.deployment else None


# --- the sentences ---------------------------------------------------------------------------------------------


def _own(rows: Sequence[DeploymentTableRow]) -> list[DeploymentTableRow]:
    """The rows of the run's matcher (each result lists it first)."""
    return [r for r in rows if r.matcher == rows[0].matcher] if rows else []


def _sources(rows: Sequence[DeploymentTableRow]) -> list[DeploymentTableRow]:
    """The rows of real confidence sources: the oracle is a check (its calibrated precision is 1), said apart."""
    return [r for r in rows if r.source != ORACLE]


def _oracle_note(rows: Sequence[DeploymentTableRow]) -> str:
    """The check: the oracle held wherever it accepted; a word where it did not (it cannot, unless the labels of
    the two splits disagree in kind)."""
    missed = [r for r in rows if r.source == ORACLE and r.outcome == VIOLATED]
    return f" The oracle (a check) fell below p in {len(missed)} cells." if missed else ""


def target_sentences(rows: Sequence[DeploymentTableRow]) -> list[str]:
    """One sentence per target of a block's rows (the run's matcher): per rule, in how many of its cells (source,
    method, deployment) the threshold held, was violated (and how many of those with the interval wholly below the
    target) or abstained; the source-rule pairs that held in every cell, with their mean recall against the
    ceiling's. It counts deployments and says that one deployment is no evidence beyond its route."""
    own = _own(rows)
    if not own:
        return []
    deployments = sorted({r.deployment for r in own})
    methods = list(dict.fromkeys(r.method for r in own))
    n_cells = len(deployments) * len(methods)
    out = []
    for target in dict.fromkeys(r.precision_target for r in own):
        checks = [r for r in own if r.precision_target == target]
        at = _sources(checks)
        parts = []
        for rule in RULES:
            found = [r for r in at if r.rule == rule]
            if not found:
                continue
            held = sum(1 for r in found if r.outcome == HELD)
            violated = [r for r in found if r.outcome == VIOLATED]
            beyond = sum(1 for r in violated if r.against_target == BELOW)
            abstained = sum(1 for r in found if r.outcome == ABSTAINED)
            parts.append(f"{rule} held in {held}, fell below p in {len(violated)} ({beyond} with the interval wholly "
                         f"below p) and abstained in {abstained} of {len(found)}")
        pairs: dict[tuple[str, str], list[DeploymentTableRow]] = {}
        for r in at:
            pairs.setdefault((r.source, r.rule), []).append(r)
        kept = [(key, found) for key, found in pairs.items()
                if len(found) == n_cells and all(r.outcome == HELD for r in found)]
        kept.sort(key=lambda item: -sum(r.recall for r in item[1]))
        if kept:
            shown = "; ".join(
                f"{source}/{rule} (recall {_mean([r.recall for r in found]):.3f} against the ceiling's "
                f"{_mean([r.ceiling_recall for r in found]):.3f})" for (source, rule), found in kept[:4])
            more = f" and {len(kept) - 4} more" if len(kept) > 4 else ""
            every = (f"Held in every cell: {shown}{more}" if n_cells > 1 else f"Held on it: {shown}{more}")
        else:
            every = "No source-rule pair held in every cell"
        where = ("on the one deployment split of each method (one stretch of one route: holding there does not show "
                 "that a rule holds on another)" if len(deployments) == 1 else
                 f"on {len(deployments)} deployments ({', '.join(deployments)}) of each method")
        out.append(f"Precision {target:g} ({own[0].matcher}, calibrated on {own[0].calibration}, {where}): of the "
                   f"cells of a source (the oracle apart), method and deployment, {'; '.join(parts)}. {every}."
                   + _oracle_note(checks))
    return out


def _mean(values: Sequence[float]) -> float:
    return sum(values) / len(values)


def headline(rows: Sequence[DeploymentTableRow]) -> str:
    """The first screen's sentence of a block: at the first target, how many cells each rule held in."""
    own = _own(rows)
    if not own:
        return ""
    target = own[0].precision_target
    at = _sources([r for r in own if r.precision_target == target])
    counts = ", ".join(f"{rule} {sum(1 for r in at if r.rule == rule and r.outcome == HELD)} of "
                       f"{sum(1 for r in at if r.rule == rule)}" for rule in RULES if any(r.rule == rule for r in at))
    deployments = sorted({r.deployment for r in at})
    return (f"On {own[0].dataset} ({own[0].matcher}, L = {own[0].seq_len}), thresholds set on {own[0].calibration} "
            f"for precision {target:g} held on {', '.join(deployments)} in {counts} source-method cells (the oracle "
            "apart) "
            "(held: the realised precision at least the target; one route, so no rule is shown to hold elsewhere).")


# --- the figure ------------------------------------------------------------------------------------------------


def draw(figure: Figure, out_dir: Path, inputs: Inputs) -> list[WrittenFigure]:
    """One figure per dataset and L: per method, realised precision against recall of each source and rule on the
    deployments at each target (the target drawn), and the calibration split's risk-coverage curve of each source
    with the chosen thresholds marked; the run's matcher."""
    from vpr_smr.eval.report import deployment_figures  # matplotlib: imported when the report draws

    groups: dict[tuple[str, int], list[DeploymentResult]] = {}
    results = inputs.deployment
    if inputs.order is not None:
        results = sorted(results, key=lambda r: (inputs.order.dataset(str(r.meta["dataset"])),
                                                 inputs.order.method(str(r.meta["method"]))))
    for result in results:
        groups.setdefault((str(result.meta["dataset"]), int(result.meta["seq_len"])), []).append(result)
    out = []
    for (dataset, seq_len), group in groups.items():
        first = group[0]
        title = (f"{dataset}, L={seq_len}{inputs.correct(dataset)}: thresholds set on {first.meta['calibration']} "
                 f"for each target, realised on {', '.join(first.meta['deployments'])}")
        path = deployment_figures.deployment_figure(out_dir / figure.file(dataset=dataset, seq_len=seq_len), group,
                                                    title)
        out.append(WrittenFigure(figure.name, f"{figure.title}: {dataset}, L={seq_len}", path, dataset, seq_len))
    return out


FIGURE = Figure(NAME, "Deployment", (NAME,), "deployment_{dataset}_L{seq_len}.png", draw=draw)

TABLE = Table(NAME, "Deployment: thresholds set on the calibration split by each rule for every confidence source, "
                    "and the precision and recall they give on each deployment, against the ceiling (method §16)",
              (NAME,), row=DeploymentTableRow, make=make_deployment, page=PAGE,
              caption="The run's matcher at the first target: per method, source and rule the threshold, the "
                      "realised precision with its interval, the recall against the ceiling's, and the outcome")


def _page_rows(rows: Sequence[DeploymentTableRow]) -> list[DeploymentTableRow]:
    """What a block's compact table shows: the run's matcher at the first target (the full table has the rest)."""
    own = _own(rows)
    return [r for r in own if r.precision_target == own[0].precision_target] if own else []


SECTION = Declared(NAME, "Thresholds that hold on the next traverse?", (NAME,), prose(NAME), NAME,
                   view=lambda b, f, shown: (b.compact(NAME, b.anchor(NAME, f), _page_rows(shown), TABLE.caption),),
                   sentences=lambda b, shown: target_sentences(shown), headline=headline, after="baselines")

TABLES = (replace(TABLE, section=SECTION),)
FIGURES = (FIGURE,)
