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
from vpr_smr.eval.report.rows import column, extra, interval
from vpr_smr.eval.report.sections import Declared, prose
from vpr_smr.eval.report.table_spec import Figure, Table
from vpr_smr.eval.report.tabulate import Inputs
from vpr_smr.eval.scoring.deployment_records import PREDICTOR_SOURCE, DeploymentResult, DeploymentRow
from vpr_smr.eval.scoring.records import Interval
from vpr_smr.eval.scoring.scorers import ORACLE
from vpr_smr.eval.scoring.thresholds import ABSTAINED, HELD, SAME_FRACTION, VIOLATED

__all__ = ["FIGURES", "NAME", "TABLES", "DeploymentTableRow", "against_target", "deployment_rows", "headline",
           "target_sentences"]

NAME = "deployment"
ABOVE, BELOW, HOLDS, NO_INTERVAL = "interval_above", "interval_below", "interval_holds_target", "no_interval"
PAGE = ("method", "deployment", "source", "rule", "precision_target", "threshold", "precision", "precision_ci_low",
        "precision_ci_high", "recall", "ceiling_recall", "outcome", "against_target", "segments_violated",
        "seeds_violated")


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
    # None: the rule abstains (accepts nothing), or same_fraction, which sets no threshold but a fraction of the
    # deployment (calibration_accepted of n_calibration)
    threshold: float | None = column("threshold t", ".6g")
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
    # what the result says its numbers cannot (a calibration split too small for guaranteed at a target, one
    # without a correct match, an empty deployment): the matcher's notes, said under the sentences
    notes: tuple[str, ...] = extra(default=())

    @classmethod
    def of(cls, result: DeploymentResult, row: DeploymentRow, seeds: Sequence[DeploymentRow]) -> DeploymentTableRow:
        meta, realised = result.meta, row.realised
        violated = sum(1 for r in seeds if r.outcome == VIOLATED)
        return cls(
            str(meta["dataset"]), int(meta["seq_len"]), str(meta["method"]), row.matcher, row.source, row.rule,
            row.precision, row.risk, str(meta["calibration"]), row.calibration.n_queries,
            None if row.rule == SAME_FRACTION else row.calibration.threshold,
            row.calibration.accepted, row.deployment, realised.n_queries, realised.accepted_fraction,
            realised.precision, realised.precision_ci, realised.recall, realised.recall_ci, row.outcome,
            against_target(realised.precision_ci, row.precision), row.ceiling.recall,
            row.recall_lost, f"{row.segments.violated} of {row.segments.with_acceptance}",
            f"{violated} of {len(seeds)}" if row.source == PREDICTOR_SOURCE else "",
            tuple(note for note in result.notes if note.startswith(f"{row.matcher}: ")))


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

SHOWN = 5  # source-rule pairs a sentence names per kind (the rest counted)


def _own(rows: Sequence[DeploymentTableRow]) -> list[DeploymentTableRow]:
    """The rows of the run's matcher (each result lists it first)."""
    return [r for r in rows if r.matcher == rows[0].matcher] if rows else []


def _mean(values: Sequence[float]) -> float:
    return sum(values) / len(values)


def _pairs(rows: Sequence[DeploymentTableRow]) -> dict[tuple[str, str], list[DeploymentTableRow]]:
    """A target's rows per source and rule (the cells: one per method and deployment)."""
    out: dict[tuple[str, str], list[DeploymentTableRow]] = {}
    for r in rows:
        out.setdefault((r.source, r.rule), []).append(r)
    return out


def _held(pairs: dict[tuple[str, str], list[DeploymentTableRow]]) -> list[tuple[str, str]]:
    """The source-rule pairs that held on every one of their cells, the highest mean recall first, the oracle (the
    check, whose recall is the ceiling's) last."""
    kept = [key for key, found in pairs.items() if all(r.outcome == HELD for r in found)]
    return sorted(kept, key=lambda key: (key[0] == ORACLE, -_mean([r.recall for r in pairs[key]])))


def _first(pairs: dict[tuple[str, str], list[DeploymentTableRow]], outcome: str) -> list[tuple[str, str]]:
    """The source-rule pairs with ``outcome`` in any cell: the predictor's first (the method's subject), then the
    most such cells first, ties as the rows come."""
    found = [key for key, rows in pairs.items() if any(r.outcome == outcome for r in rows)]
    return sorted(found, key=lambda key: (key[0] != PREDICTOR_SOURCE,
                                          -sum(1 for r in pairs[key] if r.outcome == outcome)))


def _recall(found: Sequence[DeploymentTableRow]) -> str:
    """The recall against the ceiling's: of the one cell, or the mean over the cells; and where a cell's precision
    held only as a point (its interval includes p, or it has none), how often: held is what the split realised, not
    what the route would give on other queries."""
    mean = "" if len(found) == 1 else "mean "
    holds = sum(1 for r in found if r.outcome == HELD and r.against_target == HOLDS)
    none = sum(1 for r in found if r.outcome == HELD and r.against_target == NO_INTERVAL)
    words = ([f"interval includes p in {holds} of {len(found)}"] if holds else []) + (
        [f"no interval in {none} of {len(found)}"] if none else [])
    return (f"{mean}recall {_mean([r.recall for r in found]):.3f} of the ceiling's "
            f"{_mean([r.ceiling_recall for r in found]):.3f}" + "".join(f"; {w}" for w in words))


def _named(items: Sequence[str]) -> str:
    more = f" and {len(items) - SHOWN} more" if len(items) > SHOWN else ""
    return ", ".join(items[:SHOWN]) + more


def _scope(own: Sequence[DeploymentTableRow]) -> tuple[str, str]:
    """Where the thresholds were deployed, in words, and what holding on all of it is called: one deployment split
    is one stretch of one route, so the words count deployments and claim nothing beyond them."""
    deployments = list(dict.fromkeys(r.deployment for r in own))
    methods = list(dict.fromkeys(r.method for r in own))
    each = f" of each of the {len(methods)} methods" if len(methods) > 1 else ""
    if len(deployments) == 1:
        return (f"the one deployment split {deployments[0]}{each} (one route; not evidence that a threshold holds "
                "elsewhere)", "held on the one deployment split" + (" of every method" if each else ""))
    return (f"{len(deployments)} deployments{each} ({', '.join(deployments)})",
            f"held on {len(deployments)} of {len(deployments)} deployments" + (" of every method" if each else ""))


def _violations(found: Sequence[DeploymentTableRow]) -> str:
    """How often a pair fell below the target, and what the precision's interval says of each time."""
    violated = [r for r in found if r.outcome == VIOLATED]
    beyond = sum(1 for r in violated if r.against_target == BELOW)
    without = sum(1 for r in violated if r.against_target == NO_INTERVAL)
    words = [f"{beyond} below p beyond its interval"] if beyond else []
    if len(violated) - beyond - without:
        words.append(f"{len(violated) - beyond - without} below p, interval includes p")
    if without:
        words.append(f"{without} without an interval")
    return f"in {len(violated)} of {len(found)} ({'; '.join(words)})"


def target_sentences(rows: Sequence[DeploymentTableRow]) -> list[str]:
    """One sentence per target of a block's rows (one dataset and L; the run's matcher): which source-rule pairs
    held (precision at least p) on every deployment of every method, at what recall against the ceiling; which fell
    below p and in how many cells (a cell: a method's deployment), whether the interval lies wholly below p there;
    which abstained (accepted nothing: never a success). Deployments are counted, and one deployment split is said to
    be one route: holding there is no evidence that a threshold holds elsewhere."""
    own = _own(rows)
    if not own:
        return []
    scope, held_words = _scope(own)
    out = []
    for target in dict.fromkeys(r.precision_target for r in own):
        pairs = _pairs([r for r in own if r.precision_target == target])
        held = _held(pairs)
        violated = _first(pairs, VIOLATED)
        abstained = _first(pairs, ABSTAINED)
        parts = [f"{len(held)} of {len(pairs)} source-rule pairs {held_words}"
                 + (f": {_named([f'{s}/{rule} ({_recall(pairs[s, rule])})' for s, rule in held])}" if held else "")]
        if violated:
            parts.append(f"{len(violated)} fell below p: "
                         + _named([f"{s}/{rule} {_violations(pairs[s, rule])}" for s, rule in violated]))
        if abstained:
            parts.append(f"{len(abstained)} abstained (accepted nothing): " + _named(
                [f"{s}/{rule} in {sum(1 for r in pairs[s, rule] if r.outcome == ABSTAINED)} of "
                 f"{len(pairs[s, rule])}" for s, rule in abstained]))
        out.append(f"Precision {target:g} ({own[0].matcher}, thresholds set on {own[0].calibration}, deployed on "
                   f"{scope}): {'; '.join(parts)}.")
    return out + [f"Note: {note}." for note in dict.fromkeys(note for r in own for note in r.notes)]


def headline(rows: Sequence[DeploymentTableRow]) -> str:
    """The first screen's sentence of a block: at the first target, how many source-rule pairs (the oracle, the
    check, aside) held on every deployment, which of them kept the highest recall, and how the predictor's
    thresholds fared in their cells (a rule and a method's deployment each)."""
    own = _own(rows)
    if not own:
        return ""
    target = own[0].precision_target
    pairs = _pairs([r for r in own if r.precision_target == target])
    held = _held(pairs)
    _, held_words = _scope(own)
    checked = {key: found for key, found in pairs.items() if key[0] != ORACLE}  # the oracle is the check
    kept = [key for key in held if key in checked]
    said = "" if not kept else f"; the highest recall: {kept[0][0]}/{kept[0][1]} ({_recall(pairs[kept[0]])})"
    predictor = [r for key, found in checked.items() if key[0] == PREDICTOR_SOURCE for r in found]
    if predictor:
        said += (f"; the predictor's thresholds held in {sum(1 for r in predictor if r.outcome == HELD)}, fell below p "
                 f"in {sum(1 for r in predictor if r.outcome == VIOLATED)} and abstained in "
                 f"{sum(1 for r in predictor if r.outcome == ABSTAINED)} of its {len(predictor)} rule-deployment "
                 f"cell{'s' if len(predictor) > 1 else ''}")
    return (f"On {own[0].dataset} ({own[0].matcher}, L = {own[0].seq_len}), thresholds set on {own[0].calibration} "
            f"for precision {target:g}: {len(kept)} of {len(checked)} source-rule pairs (the oracle aside) "
            f"{held_words}{said}.")


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
        matcher = first.rows[0].matcher if first.rows else ""
        title = (f"{dataset}, L={seq_len}, {matcher}{inputs.correct(dataset)}: thresholds set on "
                 f"{first.meta['calibration']} for each target, realised on {', '.join(first.meta['deployments'])} "
                 "(a rule that accepts nothing is not drawn)")
        path = deployment_figures.deployment_figure(out_dir / figure.file(dataset=dataset, seq_len=seq_len), group,
                                                    title)
        out.append(WrittenFigure(figure.name, f"{figure.title}: {dataset}, L={seq_len}", path, dataset, seq_len))
    return out


FIGURE = Figure(NAME, "Deployment", (NAME,), "deployment_{dataset}_L{seq_len}.png", draw=draw)

TABLE = Table(NAME, "Deployment: thresholds set on the calibration split by each rule for every confidence source, "
                    "and the precision and recall they give on each deployment, against the ceiling (method §16)",
              (NAME,), row=DeploymentTableRow, make=make_deployment, page=PAGE,
              caption="The run's matcher at the first target: per method, deployment, source and rule the threshold, "
                      "the realised precision with its interval, the recall against the ceiling's, and the outcome")


def _page_rows(rows: Sequence[DeploymentTableRow]) -> list[DeploymentTableRow]:
    """What a block's compact table shows: the run's matcher at the first target (the full table has the rest)."""
    own = _own(rows)
    return [r for r in own if r.precision_target == own[0].precision_target] if own else []


SECTION = Declared(NAME, "Thresholds that hold on the next traverse?", (NAME,), prose(NAME), NAME,
                   view=lambda b, f, shown: (b.compact(NAME, b.anchor(NAME, f), _page_rows(shown), TABLE.caption),),
                   sentences=lambda b, shown: target_sentences(shown), headline=headline, after="baselines")

TABLES = (replace(TABLE, section=SECTION),)
FIGURES = (FIGURE,)
