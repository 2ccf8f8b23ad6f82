"""What a predictor's match removal did, in words: the one place that says each ``curves.outcome`` (a degenerate
predictor named, never shown as a success), for Table I's cells and notes, the findings, the PR figure and the
seed spread.

The one rule for a direction word is ``curves.earned`` (in the scoring layer, so that the console's tables apply
it too): ``curves.outcome`` names improved or worse by the sign of a point estimate; a table, console or sentence
names that direction only where the estimate's interval over queries excludes 0 on the same side. The records
(``records.Reduction``, ``TrustNumbers``: the JSON files) and every row record take their ``outcome`` through
``earned``, so every writer (CSV, Markdown, LaTeX, the page, the console) shows the same word, and ``direction``
reads an outcome and its interval by the same rule. ``UNEARNED`` is the one place that says ``earned``'s codes
in place of a direction (the files keep the codes) in the page's and the tables' words.

The functions of a reduction take its outcome (and its number, or its interval); those of Table I's cells and notes
its record (``rows.Table1Row``: ``outcome``, ``removed``, ``n_queries``, the AOCs and maximum recalls). A
``WORSE_FROM_ZERO`` whose interval of the AOC difference did not earn it (``curves.from_zero``) keeps ``earned``'s
code as its outcome and its reduction undefined: its words say both (``from_zero_words``).
"""

from __future__ import annotations

from collections.abc import Collection, Mapping
from typing import TYPE_CHECKING

from vpr_smr.eval.scoring.curves import (
    AGAINST_SIGN,
    AT_RECALL_ZERO,
    HOLDS_ZERO,
    IMPROVED,
    KEPT_ALL,
    KEPT_NONE_CORRECT,
    LOST_ALL,
    NO_CORRECT_MATCH,
    NO_INTERVAL,
    NOTHING_TO_REDUCE,
    REMOVED_ALL,
    UNDEFINED,
    WORSE,
    WORSE_FROM_ZERO,
    earned,
    is_from_zero,
    reduction_undefined,
)

if TYPE_CHECKING:
    from vpr_smr.eval.report.rows import Table1Row
    from vpr_smr.eval.scoring.intervals import Interval
    from vpr_smr.eval.scoring.records import EvaluationSplit

# A seed's outcome where the spread leaves it out (its reduction undefined), or a table cell's short word for it
SHORT = {
    NO_CORRECT_MATCH: "no correct match",
    REMOVED_ALL: "removed every match",
    KEPT_NONE_CORRECT: "kept no correct match",
    KEPT_ALL: "kept every match",
    NOTHING_TO_REDUCE: "nothing to reduce",
    WORSE_FROM_ZERO: "worse than a perfect baseline",
}
# What a page or table says where ``earned`` names no direction (the files hold the codes)
UNEARNED = {
    HOLDS_ZERO: "holds 0",
    NO_INTERVAL: "no interval",
    AGAINST_SIGN: "no direction",  # the interval excludes 0 on the other side from the estimate
}


def from_zero_words(outcome: str) -> str:
    """A perfect baseline made worse by an AOC whose interval did not earn the word (``outcome``: ``earned``'s code):
    ``perfect baseline, holds 0``."""
    return f"perfect baseline, {UNEARNED[outcome]}"


def undefined_words(outcome: str | None, reduction: float | None, difference: Interval | None = None) -> str | None:
    """Why a reduction (``reduction``, of the outcome ``outcome``) is undefined, in a cell's short words; None where
    it is defined or the outcome says no why. A from-zero outcome names the interval of the AOC difference that
    judged it (``difference``, ``records.Reduction.aoc_difference_ci``) beside its word, where there is one:
    ``worse than a perfect baseline (AOC difference [+0.0004, +0.0021])``."""
    if reduction is not None or outcome is None:
        return None
    if not is_from_zero(outcome, None):
        return SHORT.get(outcome)
    found = SHORT[outcome] if outcome in SHORT else from_zero_words(outcome)
    return found if difference is None else f"{found} ({difference_words(difference)})"


def difference_words(difference: Interval) -> str:
    """The interval of a from-zero outcome's AOC difference (+Pred minus VPR+SM) as a cell names it."""
    return f"AOC difference [{difference.low:+.4f}, {difference.high:+.4f}]"


def said(outcome: str) -> str:
    """An outcome (``earned``'s, or a degenerate one) in the words a page or the console says: ``improved``,
    ``holds 0``, ``removed every match``; any other (``unchanged``) as it is."""
    return UNEARNED.get(outcome) or SHORT.get(outcome) or outcome


def is_degenerate(outcome: str, reduction: float | None) -> bool:
    """The reduction alone would mislead: it is undefined, or 0 because the predictor changed nothing."""
    return outcome in SHORT or is_from_zero(outcome, reduction)


def at_recall_zero(outcome: str) -> bool:
    """Both AOCs are taken at recall 0 (no correct match left, or none to begin with): 0 there says nothing."""
    return outcome in AT_RECALL_ZERO


def lowered_recall(row: Table1Row) -> bool:
    """The predictor's maximum recall is below the baseline's own: the AOCs are taken on part of the curve."""
    return row.max_recall < row.max_recall_vpr_sm


def direction(outcome: str | None, interval: Interval | None) -> int | None:
    """What a reduction of the outcome ``outcome`` with the interval ``interval`` says by ``earned``: +1 (improved,
    its interval above 0), -1 (worse, below 0), 0 (no direction: the interval holds 0 or points against the
    estimate, or the outcome is neither improved nor worse, e.g. ``unchanged``), None (an improved or worse
    estimate without an interval: nothing to tell it by)."""
    found = earned(str(outcome), interval)
    return None if found == NO_INTERVAL else {IMPROVED: 1, WORSE: -1}.get(found, 0)


def own_baseline(row: Table1Row) -> str:
    """The baseline's own AOC at its own maximum recall."""
    return f"VPR+SM's own AOC is {row.aoc_vpr_sm_own:.4f} at its own maximum recall {row.max_recall_vpr_sm:.4f}"


def note(row: Table1Row) -> str:
    """What the seed-0 predictor did to one method, in a clause (empty when its reduction says it all)."""
    outcome, n, removed = row.outcome, row.n_queries, row.removed
    if outcome == NO_CORRECT_MATCH:
        return f"none of its {n} sequence matches is correct: there is nothing to score"
    if outcome == REMOVED_ALL:
        return f"the predictor removed all {n} matches: recall 0; {own_baseline(row)}"
    if outcome == KEPT_NONE_CORRECT:
        return (f"the predictor kept {n - removed} of {n} matches, none of them correct: recall 0; "
                f"{own_baseline(row)}")
    if outcome == KEPT_ALL:
        return f"the predictor kept all {n} matches: nothing changed, a reduction of 0"
    if outcome == NOTHING_TO_REDUCE:
        text = (f"baseline AOC 0 up to the predictor's maximum recall {row.max_recall:.4f}: nothing to reduce, "
                "the reduction is undefined")
        if lowered_recall(row):
            text += (f" (the predictor lowered the maximum recall from {row.max_recall_vpr_sm:.4f}; "
                     f"{own_baseline(row)})")
        return text
    if outcome == WORSE_FROM_ZERO:
        return (f"the predictor made the AOC worse, from 0 to {row.aoc_vpr_sm_pred:.4f} up to its maximum "
                f"recall {row.max_recall:.4f}: worse, by a percentage that is undefined (the baseline's AOC "
                "being 0)")
    if is_from_zero(outcome, row.reduction_pct):
        interval = ("there is no interval of the difference" if outcome == NO_INTERVAL else
                    "the interval over queries of the difference holds 0" if outcome == HOLDS_ZERO else
                    "the interval over queries of the difference lies below 0")
        return (f"the baseline's AOC is 0 up to the predictor's maximum recall {row.max_recall:.4f} and the "
                f"predictor's {row.aoc_vpr_sm_pred:.4f}, but {interval}: no direction, and the reduction is "
                "undefined (the baseline's AOC being 0)")
    return ""


def reduction_cell(row: Table1Row, number: str) -> str:
    """Table I's reduction cell: the number (``number``, formatted), or the outcome's word where it is undefined;
    a 0 of a predictor that removed nothing says so."""
    if row.reduction_pct is None:
        why = undefined_words(row.outcome, None, row.aoc_difference_ci)
        return "n/a" if why is None else f"n/a: {why}"
    return f"{number} ({SHORT[KEPT_ALL]})" if row.outcome == KEPT_ALL else number


def predictor_cell(row: Table1Row, number: str) -> str:
    """Table I's VPR+SM+Pred cell: the AOC, or the removal that left no recall to take it at."""
    return SHORT[row.outcome] if row.outcome in LOST_ALL else number


def baseline_cell(row: Table1Row, number: str) -> str:
    """Table I's VPR+SM cell: the AOC at the predictor's maximum recall, and the baseline's own beside it where
    the predictor was degenerate and lowered the maximum recall (a cut curve alone would hide what was lost)."""
    if reduction_undefined(row.outcome, row.reduction_pct) and lowered_recall(row):
        return f"{number} (own: {row.aoc_vpr_sm_own:.4f})"
    return number


def seeds_left_out(outcomes: Mapping[int, str], undefined: Collection[int] = ()) -> str:
    """The seeds whose reduction is undefined and why, grouped by outcome: ``seed 3: removed every match``,
    ``seeds 1, 4: nothing to reduce``; empty when none. ``undefined``: the seeds whose reduction is None, which names
    those left out for a perfect baseline made worse without an interval to earn the word (``seeds 2, 5: perfect
    baseline, no interval``): their outcome is ``earned``'s code, the same as a defined reduction's without one."""
    groups: dict[str, list[int]] = {}
    for seed, outcome in outcomes.items():
        if outcome in UNDEFINED:
            groups.setdefault(SHORT[outcome], []).append(int(seed))
        elif int(seed) in undefined and is_from_zero(outcome, None):
            groups.setdefault(from_zero_words(outcome), []).append(int(seed))
    parts = []
    for why, seeds in groups.items():
        label = "seed" if len(seeds) == 1 else "seeds"
        parts.append(f"{label} {', '.join(map(str, seeds))}: {why}")
    return "; ".join(parts)


def seeds_left_out_of(split: EvaluationSplit, mode: str) -> str:
    """``seeds_left_out`` of one split's seeds in ``mode``."""
    return seeds_left_out(split.seed_summary[mode].outcomes,
                          [numbers.seed for numbers in split.seeds if numbers.modes[mode].reduction_pct is None])
