"""The experiment ``matchers`` (method §14): per dataset, L, mode, method and matcher, Table I's numbers with the
matcher's own predictor, the best training-free scorer and the matcher's native confidence at the predictor's
budget, and the wrong-match average precision of both, on the queries every matcher evaluates
(``scoring.matcher_comparison``). Its section, declared on this table by the experiment's module
(``pipeline/experiments/matchers.py``), follows the baselines' on the page."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from vpr_smr.eval.report import bounds, names
from vpr_smr.eval.report import outcome_words as words
from vpr_smr.eval.report.registry import Table
from vpr_smr.eval.report.rows import AOC_DIFFERENCE, column, interval
from vpr_smr.eval.report.tabulate import Inputs
from vpr_smr.eval.scoring.curves import earned
from vpr_smr.eval.scoring.matcher_comparison import FAR_BELOW, MatcherComparison, MatcherScores, validation_warning
from vpr_smr.eval.scoring.records import Interval

if TYPE_CHECKING:
    from vpr_smr.eval.report.results import Order

__all__ = ["FAR_BELOW", "TABLE", "MatchersRow", "comparison_sentence", "make_matchers", "matcher_rows",
           "matcher_sentences"]

PAGE = ("method", "matcher", "n_evaluated", names.RECALL_SEQUENCE, names.AOC_VPR_SM, names.AOC_VPR_SM_PRED,
        names.REDUCTION, "outcome", names.REDUCTION_MEAN, "reduction_pct_std", "best_scorer", "native_reduction_pct",
        "ap_predictor", "ap_native", "warning")


@dataclass(frozen=True)
class MatchersRow:
    """``matchers``: one matcher on one method's table split in one mode, on the ``n_queries`` queries every
    compared matcher evaluates (``n_evaluated``: those it evaluates itself)."""

    dataset: str = column()
    seq_len: int = column()
    mode: str = column()
    method: str = column()
    matcher: str = column()
    n_queries: int = column("shared queries")
    n_evaluated: int = column("its queries")
    recall_at_1_single: float = column()
    recall_at_1_sequence: float = column()
    aoc_vpr_sm: float = column()
    aoc_vpr_sm_pred: float = column()
    reduction_pct: float | None = column()  # the seed-0 predictor's; None where VPR+SM's AOC is 0
    reduction_pct_ci: Interval | None = interval()
    aoc_difference_ci: Interval | None = interval(AOC_DIFFERENCE, ".4f")  # as Table I's: a from-zero outcome's
    # what the seed-0 removal did, in a word (``curves.outcome``): a degenerate one named, e.g. an AOC near 0; a
    # direction only where the interval earns it (``curves.earned``)
    outcome: str = column()
    reduction_pct_mean: float | None = column("mean over seeds (%)", ".2f")
    reduction_pct_std: float | None = column("std over seeds", ".2f")
    n_seeds: int = column()
    removed: int = column()
    best_scorer: str | None = column("best training-free scorer")
    best_scorer_reduction_pct: float | None = column("its reduction (%)", ".2f")
    native_reduction_pct: float | None = column("native reduction (%)", ".2f")
    # the native confidence's reduction minus the predictor's at the seed-0 budget, paired over the same draws
    native_minus_predictor_ci: Interval | None = interval("native - predictor reduction (%)", ".2f")
    ap_predictor: float | None = column("AP predictor")  # None without a wrong match
    ap_native: float | None = column("AP native")
    ap_native_minus_predictor_ci: Interval | None = interval("AP native - predictor")
    n_wrong: int = column("wrong matches")
    validation_recall_at_1: float | None = column("validation R@1")
    fixed_validation_recall_at_1: float | None = column("fixed matcher's validation R@1")
    warning: str = column(if_any=True)

    @classmethod
    def of(cls, result: MatcherComparison, tag: str, method: str, mode: str, scores: MatcherScores) -> MatchersRow:
        numbers = scores.modes[mode]
        fixed = (None if result.fixed_validation_recall_at_1 is None
                 else result.fixed_validation_recall_at_1.get(method))
        warned = validation_warning(tag, method, scores.validation_recall_at_1, fixed)
        return cls(
            str(result.meta["dataset"]), int(result.meta["seq_len"]), mode, method, tag, result.n_queries,
            scores.n_evaluated, numbers.recall_at_1_single, numbers.recall_at_1_sequence,
            numbers.reduction.aoc_vpr_sm, numbers.reduction.aoc_vpr_sm_pred, numbers.reduction.reduction_pct,
            numbers.reduction.reduction_pct_ci, numbers.reduction.aoc_difference_ci,
            earned(numbers.reduction.outcome, numbers.reduction.reduction_pct_ci),
            numbers.seeds.reduction_pct_mean, numbers.seeds.reduction_pct_std, numbers.seeds.n_seeds,
            scores.removed, numbers.best_scorer,
            None if numbers.best_scorer_reduction is None else numbers.best_scorer_reduction.reduction_pct,
            numbers.native_reduction.reduction_pct, numbers.native_minus_predictor_ci,
            scores.detection_predictor.average_precision, scores.detection_native.average_precision,
            scores.native_minus_predictor_ap_ci, scores.n_wrong, scores.validation_recall_at_1, fixed,
            "" if warned is None else f"validation R@1 under {FAR_BELOW:g} of the fixed matcher's")


def matcher_rows(results: Sequence[MatcherComparison], order: Order | None = None) -> list[MatchersRow]:
    """One row per dataset, L, mode, method and matcher: datasets and methods in the configuration's order
    (``order``; else as the files come), the matchers in the experiment's, the modes as the files list them."""
    groups: dict[tuple[str, int], list[tuple[str, MatcherComparison]]] = {}
    for result in results:
        key = (str(result.meta["dataset"]), int(result.meta["seq_len"]))
        groups.setdefault(key, []).extend((method, result) for method in next(iter(result.matchers.values())))
    keys = sorted(groups, key=lambda key: (order.dataset(key[0]), key[1])) if order else list(groups)
    rows = []
    for key in keys:
        found = groups[key]
        if order is not None:
            found = sorted(found, key=lambda item: order.method(item[0]))
        for mode in found[0][1].meta["modes"]:
            for method, result in found:
                for tag in result.tags:
                    rows.append(MatchersRow.of(result, tag, method, mode, result.matchers[tag][method]))
    return rows


def make_matchers(inputs: Inputs) -> list[MatchersRow] | None:
    return matcher_rows(inputs.matchers, inputs.order) if inputs.matchers else None


def comparison_sentence(rows: Sequence[MatchersRow]) -> str:
    """The experiment's one sentence of one dataset, L and mode (its rows): for how many matcher-method
    pairs SMR reduces the AOC (the seed-0 reduction's 95 % interval above 0), and for how many it beats the
    matcher's own confidence (the paired interval of the native confidence's reduction minus the predictor's, at
    the same budget, below 0). A pair whose interval is undefined or holds 0, or whose removal is degenerate (every
    match removed, no correct one kept: ``outcome_words.direction``), is counted in neither."""
    if not rows:
        return ""
    first = rows[0]
    directions = [words.direction(r.outcome, r.reduction_pct_ci) for r in rows]
    reduced, hurts = directions.count(1), directions.count(-1)
    beats = sum(1 for r in rows if bounds.sign(r.native_minus_predictor_ci) == -1)
    harm = f"; it raises it for {hurts} (the interval below 0)" if hurts else ""
    return (f"On {first.dataset} (L = {first.seq_len}, {first.mode} mode, the {first.n_queries} queries "
            f"every matcher evaluates), SMR reduces the AOC for {reduced} of {len(rows)} matcher-method pairs (the "
            f"seed-0 predictor's reduction, its 95 % interval above 0){harm}; it beats the matcher's own "
            f"confidence for {beats} (the paired 95 % interval of the native confidence's reduction minus the "
            "predictor's, removing as many matches, below 0).")


TABLE = Table("matchers", "Matchers: the Table I numbers of each sequence matcher with its own predictor, the best "
              "training-free scorer and the native confidence of the matcher at the budget of the predictor, and the "
              "wrong-match average precision, on the queries every matcher evaluates (method §14)", ("matchers",),
              row=MatchersRow, make=make_matchers, page=PAGE,
              caption="Per method and matcher: sequence recall@1, the seed-0 predictor's AOCs and reduction, its "
                      "mean and std over the seeds, the best training-free scorer and the native confidence at the "
                      "same budget, and the average precision of detecting the wrong matches")


def matcher_sentences(rows: Sequence[MatchersRow]) -> list[str]:
    """What the section says under a figure: the comparison's sentence, then each pair flagged by the validation
    warning."""
    warned = [f"Warning: {r.matcher} on {r.method} has a validation recall@1 of "
              f"{r.validation_recall_at_1:.3f}, under {FAR_BELOW:g} of the fixed matcher's "
              f"({r.fixed_validation_recall_at_1:.3f}): its settings may not fit the traverses (a filter's "
              "transition window must fit their speed ratio)." for r in rows if r.warning]
    return [comparison_sentence(rows), *warned] if rows else []
