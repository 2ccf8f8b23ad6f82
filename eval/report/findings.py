"""The report's findings in words: a few sentences per dataset, mode and L that say what Table I shows, what the
speed experiment shows, and how the predictor compares with the training-free scorers (method §12).

Every number in them is one of the tables' (``table1.Table1Block``: the seed-0 predictor's reductions and the seed
summary; ``baselines.Comparison``: the baselines table's), rounded for reading; the table beside them keeps the
exact values.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from vpr_smr.eval.report import bounds
from vpr_smr.eval.report import outcome_words as words
from vpr_smr.eval.report.baselines import Comparison, DetectionComparison
from vpr_smr.eval.report.rows import SpeedRow, SweepRow, Table1Row
from vpr_smr.eval.report.table1 import UNDEFINED, Table1Block
from vpr_smr.eval.scoring.curves import AGAINST_SIGN, HOLDS_ZERO, NO_INTERVAL, NOTHING_TO_REDUCE, UNCHANGED
from vpr_smr.eval.scoring.intervals import Interval
from vpr_smr.eval.scoring.sweep import within

AOC = "area over the PR curve"


def size(value: float) -> str:
    """A reduction's magnitude as a sentence says it: one decimal, two significant digits below 0.05 %."""
    magnitude = abs(value)
    text = f"{magnitude:.1f}" if magnitude >= 0.05 or magnitude == 0 else f"{magnitude:.2g}"
    return f"{text} %"


def signed(value: float) -> str:
    """A reduction with its sign (negative: worse), one decimal."""
    return f"{value:.1f} %"


def methods(n: int) -> str:
    return f"{n} method" + ("" if n == 1 else "s")


def listed(items: Sequence[str]) -> str:
    """``a``, ``a and b``, ``a, b and c``."""
    if len(items) <= 2:
        return " and ".join(items)
    return ", ".join(items[:-1]) + " and " + items[-1]


def _seed_part(row: Table1Row) -> str | None:
    """``method mean ± std %`` over the seeds (and how many, with the seeds left out and why, when only some are
    defined); None when undefined."""
    mean, std = row.reduction_pct_mean, row.reduction_pct_std
    if mean is None:
        return None
    spread = "" if std is None else f" ± {std:.1f}"
    part = f"{row.method} {mean:.1f}{spread} %"
    if row.n_seeds_defined == row.n_seeds:
        return part
    left_out = row.seeds_left_out
    return f"{part} ({row.n_seeds_defined} of {row.n_seeds} seeds{'; ' + left_out if left_out else ''})"


def _seed_sentences(block: Table1Block) -> list[str]:
    rows = block.rows
    n_seeds = rows[0].n_seeds
    if n_seeds == 1:
        return ["One predictor seed was run, so there is no spread over seeds."]
    parts = [(row, _seed_part(row)) for row in rows]
    shown = [part for _, part in parts if part is not None]
    undefined = [row for row, part in parts if part is None]
    if not shown:
        return [f"Over {n_seeds} predictor seeds the reduction is undefined for every method"
                + _why_undefined(undefined) + "."]
    # numbers only: the seeds' spread measures training, not the queries, so no direction is claimed from it
    text = f"Over {n_seeds} predictor seeds (mean ± sample standard deviation) the reduction is {listed(shown)}"
    if undefined:
        text += f"; it is undefined for {listed([r.method for r in undefined])}" + _why_undefined(undefined)
    return [text + "."]


def _why_undefined(rows: Sequence[Table1Row]) -> str:
    """`` (a: seeds 0, 1: removed every match)``: which seeds are left out and why, per method."""
    reasons = [f"{r.method}: {r.seeds_left_out}" for r in rows if r.seeds_left_out]
    return f" ({'; '.join(reasons)})" if reasons else ""


def _verdict(row: Table1Row) -> str:
    """What a method's seed-0 reduction says, by its interval (``outcome_words.direction``): ``better``,
    ``worse``, ``same`` (unchanged), or ``earned``'s code for no direction: ``HOLDS_ZERO``, ``AGAINST_SIGN``
    (the interval points against the estimate) or ``NO_INTERVAL``."""
    found = words.direction(row.outcome, row.reduction_pct_ci)
    if found is None:
        return NO_INTERVAL
    if found:
        return "better" if found > 0 else "worse"
    if row.outcome == UNCHANGED:
        return "same"
    return HOLDS_ZERO if row.reduction_pct_ci is not None and row.reduction_pct_ci.sign() == 0 else AGAINST_SIGN


def _queries(rows: Sequence[Table1Row]) -> str:
    """The queries the rows' numbers are over: ``28``, or ``28-31`` where the methods differ."""
    return _span_of([r.n_queries for r in rows])


def _reduction(row: Table1Row) -> float:
    """The seed-0 reduction of a row that is not degenerate (``outcome_words.is_degenerate``): defined."""
    if row.reduction_pct is None:
        raise ValueError(f"{row.method}: its reduction is undefined ({row.outcome}) but its outcome says not")
    return row.reduction_pct


def no_direction(row: Table1Row, split: str) -> str:
    """The sentence of a method whose reduction's interval earns no direction: the fact (it holds 0, with the
    queries it is over; there is none; it lies against the estimate's sign), never a guess at why."""
    n = _queries([row])
    interval = row.reduction_pct_ci
    of = f"{row.method}'s reduction"
    if interval is None:
        on = f"On the {split} split's {n} queries" if n else f"On the {split} split"
        return f"{on} {of} of {signed(_reduction(row))} has no interval, so it names no direction."
    if interval.sign() == 0:
        return f"On the {split} split, {bounds.holds_zero(interval, of, n)}, so it names no direction."
    return (f"On the {split} split, the {bounds.LEVEL} interval of {of} {bounds.bracket(interval, '.1f')} lies on "
            f"the other side of 0 from its estimate {signed(_reduction(row))}"
            f"{f' ({n} queries)' if n else ''}, so it names no direction.")


def _with_span(row: Table1Row, text: str) -> str:
    interval = row.reduction_pct_ci
    return text if interval is None else f"{text} (interval {bounds.span(interval)})"


def sentences(block: Table1Block, split: str) -> list[str]:
    """What the predictor did to the area over the PR curve of each method of one dataset, mode and L. A direction
    (reduced, made worse) is stated only where the reduction's 95 % interval over queries excludes 0; a method whose
    interval holds 0, or that has none, gets a sentence stating that fact with its queries (``no_direction``). A method
    whose predictor was degenerate (removed every match, kept no correct one, made a perfect baseline worse, kept
    every match) gets its own sentence saying what happened (``outcome_words``) and counts as not improved."""
    rows = block.rows
    where = f"On {block.dataset} ({split} split, L = {block.seq_len}, {block.mode} mode, seed-0 predictor)"
    plain = [r for r in rows if not words.is_degenerate(r.outcome, r.reduction_pct)]
    degenerate = [r for r in rows if words.is_degenerate(r.outcome, r.reduction_pct)]
    verdicts = {r.method: _verdict(r) for r in plain}
    better = sorted((r for r in plain if verdicts[r.method] == "better"), key=lambda r: -_reduction(r))
    worse = sorted((r for r in plain if verdicts[r.method] == "worse"), key=_reduction)
    same = [r.method for r in plain if verdicts[r.method] == "same"]
    untold = [r for r in plain if verdicts[r.method] in words.UNEARNED]
    out = []
    if degenerate and all(r.outcome == NOTHING_TO_REDUCE and not words.lowered_recall(r) for r in rows):
        whose = f"{rows[0].method}'s" if len(rows) == 1 else f"each of the {len(rows)} methods'"
        out.append(f"{where} {whose} {AOC} is already 0 without the predictor: there is nothing to reduce, so the "
                   "reduction is undefined.")
        return out + _seed_sentences(block)
    if len(rows) == 1 and plain:
        row = rows[0]
        method, value = row.method, _reduction(row)
        verdict = verdicts[method]
        if verdict == "better":
            out.append(_with_span(row, f"{where} the predictor reduced {method}'s {AOC} by {size(value)}") + ".")
        elif verdict == "worse":
            out.append(_with_span(row, f"{where} the predictor made {method}'s {AOC} {size(value)} worse (larger)")
                       + ".")
        elif verdict == "same":
            out.append(f"{where} the predictor left {method}'s {AOC} unchanged.")
        else:
            out += [f"{where} {method}'s reduction is {signed(value)}.", no_direction(row, split)]
    elif len(rows) == 1:
        out.append(f"{where}, for {rows[0].method}, {words.note(rows[0])}.")
    else:
        if better:
            clauses = [f"reduced the {AOC} for {len(better)} of {methods(len(rows))}: "
                       + ", ".join(_with_span(r, f"{r.method} by {size(_reduction(r))}") for r in better)]
        else:
            clauses = [f"reduced the {AOC} for none of the {len(rows)} methods"]
        if worse:
            clauses.append("it made " + listed([_with_span(r, f"{r.method}'s {size(_reduction(r))}")
                                                for r in worse]) + " worse")
        if same:
            clauses.append("it left " + listed([f"{m}'s" for m in same]) + " unchanged")
        if untold:
            clauses.append("no direction for " + listed([r.method for r in untold]) + " (below)")
        out.append(f"{where} the predictor " + "; ".join(clauses) + ".")
        out += [no_direction(r, split) for r in untold]
        out += [f"For {r.method}, {words.note(r)}." for r in degenerate]
        defined = [r.reduction_pct for r in rows if r.reduction_pct is not None]
        if len(defined) > 1:
            these = "these" if len(defined) < len(rows) else "the"
            out.append(f"The mean reduction over {these} {len(defined)} methods is {signed(float(np.mean(defined)))} "
                       "(Table I's Mean, seed 0).")
    return out + _seed_sentences(block)


VERDICT = {"better": "it helps", "worse": "it hurts", "same": "unchanged",
           HOLDS_ZERO: f"no direction (interval {words.UNEARNED[HOLDS_ZERO]})",
           AGAINST_SIGN: "no direction (interval against its sign)",
           NO_INTERVAL: f"no direction ({words.UNEARNED[NO_INTERVAL]})"}


def headline(block: Table1Block, split: str) -> str:
    """The first screen's one sentence of a Table I block: per method the seed-0 reduction, its interval and what
    they say (a direction only where the interval excludes 0)."""
    parts = []
    for row in block.rows:
        if words.is_degenerate(row.outcome, row.reduction_pct):
            why = words.undefined_words(row.outcome, row.reduction_pct, row.aoc_difference_ci)
            parts.append(f"{row.method} {UNDEFINED if row.reduction_pct is None else signed(row.reduction_pct)}"
                         f", {why or words.said(row.outcome)}")
            continue
        interval = bounds.bracket(row.reduction_pct_ci, ".1f")
        parts.append(f"{row.method} {signed(_reduction(row))} {interval}, {VERDICT[_verdict(row)]}")
    n = _queries(block.rows)
    queries = f"{n} {split} queries" if n else f"{split} split"
    return (f"{block.dataset} ({queries}, L = {block.seq_len}, {block.mode} mode): the seed-0 predictor's AOC "
            f"reduction with its 95 % interval is " + "; ".join(parts) + ".")


# --- the speed experiment ---------------------------------------------------------------------------------------


def percent(value: float) -> str:
    """A recall or a reduction as a sentence says it: per cent, one decimal."""
    return f"{value:.1f} %"


def recall(value: float | None) -> str:
    """A recall (a fraction) in per cent; ``n/a`` when there is none."""
    return "n/a" if value is None else percent(100 * value)


def ratio(speed: float) -> str:
    return f"{speed:g}x"


def _mean(values: Sequence[float | None]) -> tuple[float | None, int]:
    """The mean of ``values`` where defined, and over how many."""
    defined = [v for v in values if v is not None]
    return (float(np.mean(defined)) if defined else None), len(defined)


def speed_sentences(rows: Sequence[SpeedRow], split: str) -> list[str]:
    """What the speed experiment shows on one dataset at one L (the rows of ``build.speed_rows``: one per method,
    profile and matcher): the fixed matcher's sequence recall@1 at the constant speed farthest from 1 (the faster
    on a tie) against the speed closest to 1, velocity search's there, and the predictor's AOC reduction under
    each matcher. Every number is a mean over the methods, in per cent."""
    if not rows:
        return []
    first = rows[0]
    n_methods = len({r.method for r in rows})
    where = (f"On {first.dataset} ({split} split, L = {first.seq_len}, paper mode, one seed-0 predictor per "
             "matcher and profile)")

    def at(speed: float | None, matcher: str) -> list[SpeedRow]:
        return [r for r in rows if r.matcher == matcher and r.speed == speed]

    def recall_at(speed: float | None, matcher: str) -> float | None:
        """The mean sequence recall@1 over the methods."""
        return _mean([r.recall_at_1_sequence for r in at(speed, matcher)])[0]

    speeds = sorted({r.speed for r in rows if r.speed is not None})
    out = []
    if speeds:
        base = min(speeds, key=lambda s: (abs(np.log(s)), s))
        far = max(speeds, key=lambda s: (abs(np.log(s)), s))
        fixed_base, fixed_far = recall_at(base, "fixed"), recall_at(far, "fixed")
        velocity_base, velocity_far = recall_at(base, "velocity"), recall_at(far, "velocity")
        over = f"mean over {methods(n_methods)}"
        if (far != base and fixed_base is not None and fixed_far is not None and velocity_base is not None
                and velocity_far is not None):
            # numbers, no "falls" or "rises": each speed is scored over its own queries, and no interval of the
            # change is computed
            text = (f"{where}, at {ratio(far)} speed the fixed matcher's sequence recall@1 is "
                    f"{percent(100 * fixed_far)} ({percent(100 * fixed_base)} at {ratio(base)}, over that profile's "
                    f"own queries; {over}); velocity search's is {percent(100 * velocity_far)} there "
                    f"({percent(100 * velocity_base)} at {ratio(base)})")
        else:  # one constant speed only (or a matcher missing): its numbers alone
            text = (f"{where}, at {ratio(far)} speed the fixed matcher's sequence recall@1 is "
                    f"{recall(fixed_far)} and velocity search's {recall(velocity_far)} ({over})")
        parts = []
        for matcher, name in (("fixed", "the fixed matcher"), ("velocity", "velocity search")):
            mean, n = _mean([r.reduction_pct for r in at(far, matcher)])
            if mean is not None:
                undefined = [f"{r.method}: {words.SHORT.get(r.outcome, 'undefined')}"
                             for r in at(far, matcher) if r.reduction_pct is None]
                why = f" ({'; '.join(undefined)})" if undefined else ""
                note = "" if n == n_methods else f" over the {n} methods where it is defined{why}"
                parts.append(f"{signed(mean)} with {name}{note}")
        if parts:
            text += f"; the predictor's AOC reduction at {ratio(far)} is " + " and ".join(parts)
        out.append(text + ".")
    varying = [r for r in rows if r.speed is None]
    if varying:
        fixed, velocity = recall_at(None, "fixed"), recall_at(None, "velocity")
        if fixed is not None and velocity is not None:
            lead = "Under" if out else f"{where}, under"
            out.append(f"{lead} the varying speed (mean {varying[0].mean_speed:.2f}x) the sequence recall@1 is "
                       f"{percent(100 * fixed)} with the fixed matcher and {percent(100 * velocity)} with velocity "
                       "search.")
    return out


def _flip(values: dict[str, list[tuple[float, float | None]]]) -> tuple[str, float, float, float, float] | None:
    """The first name whose values are above 0 at one threshold and below at another: (name, threshold, value,
    threshold, value), the positive first; None when every sign holds (zeros and undefined values decide nothing)."""
    for name, points in values.items():
        above = [(t, v) for t, v in points if v is not None and v > 0]
        below = [(t, v) for t, v in points if v is not None and v < 0]
        if above and below:
            return name, *above[0], *below[0]
    return None


def sweep_sentences(rows: Sequence[SweepRow]) -> list[str]:
    """One sentence on the protocol sweep of one dataset, L and mode (``build.sweep_rows``' rows): every conclusion
    that changes with the ground truth's tolerance or radius (the predictor's reduction changing sign for a method,
    sequence matching's gain over single frames changing sign), or that none does. Which of two methods is ahead by
    recall@1 is not said: the files hold no interval of the difference between two methods."""
    if not rows:
        return []
    first = rows[0]
    changes = _sweep_changes(rows)
    thresholds = sorted({r.threshold for r in rows})
    low, high = thresholds[0], thresholds[-1]
    span = f"{low:g} to {high:g} frames" if first.ground_truth == "frames" else f"a radius of {low:g} to {high:g}"
    where = (f"With matches counted correct within {span} ({first.dataset}, {first.split} split, "
             f"L = {first.seq_len}, {first.mode} mode)")
    untold = _untold(rows)
    if changes:
        return [f"{where}, a conclusion depends on the ground truth: {'; '.join(changes)}.", *untold]
    if not _any_sign(rows):
        n = _span_of([r.n_queries for r in rows])
        return [f"{where}, every {bounds.LEVEL} interval of the predictor's AOC reduction and of sequence matching's "
                f"change of recall@1 holds 0 or is missing{f' ({n} queries)' if n else ''}: no sign is named at any "
                "tolerance, so whether a conclusion depends on the ground truth is not told."]
    return [f"{where}, no conclusion depends on the ground truth: the predictor's AOC reduction keeps its sign for "
            f"every method, so does sequence matching's gain over single frames (each where its interval excludes "
            "0).", *untold]


def sweep_headline(rows: Sequence[SweepRow]) -> str:
    """The first screen's one sentence on the protocol sweep of one dataset, L and mode: whether a conclusion
    depends on the ground truth (``sweep_sentences`` has which)."""
    first = rows[0]
    said = ("a conclusion depends on" if _sweep_changes(rows) else "no conclusion depends on" if _any_sign(rows)
            else "every interval holds 0 or is missing, so nothing tells whether a conclusion depends on")
    return (f"{first.dataset} (L = {first.seq_len}, {first.mode} mode), scored again under other "
            f"{'tolerances' if first.ground_truth == 'frames' else 'radii'}: {said} the ground truth.")


def _sweep_changes(rows: Sequence[SweepRow]) -> list[str]:
    """The conclusions that change across the sweep, in words (a sign only where its interval excludes 0)."""
    kind = rows[0].ground_truth
    methods = list(dict.fromkeys(r.method for r in rows))
    by_method = {name: sorted((r for r in rows if r.method == name), key=lambda r: r.threshold) for name in methods}
    changes = []
    # a sign counts only where the interval earns it (``outcome_words.direction``): elsewhere no sign is named
    flipped = _flip({name: [(r.threshold, r.reduction_pct if _sign(r) else None) for r in mine]
                     for name, mine in by_method.items()})
    if flipped:
        name, t_up, up, t_down, down = flipped
        changes.append(f"the predictor's AOC reduction for {name} changes sign ({signed(up)} "
                       f"{within(kind, t_up)}, {signed(down)} {within(kind, t_down)})")
    flipped = _flip({name: [(r.threshold, _gain(r)) for r in mine] for name, mine in by_method.items()})
    if flipped:
        name, t_up, up, t_down, down = flipped
        changes.append(f"sequence matching changes {name}'s recall@1 over the same queries by {100 * up:+.1f} "
                       f"points {within(kind, t_up)} but {100 * down:+.1f} {within(kind, t_down)}")
    return changes


def _sign(row: SweepRow) -> int | None:
    """The direction a sweep point's reduction says (``outcome_words.direction``)."""
    return words.direction(row.outcome, row.reduction_pct_ci)


def _gain(row: SweepRow) -> float | None:
    """Sequence matching's change of recall@1 over single frames on the same queries (``recall_at_1_single_
    evaluated``), where its paired interval (``recall_change``) excludes 0; None elsewhere: no direction. Never
    the single-frame recall over another denominator."""
    single, interval = row.recall_at_1_single_evaluated, row.recall_change_ci
    if single is None or interval is None or not interval.sign():
        return None
    return row.recall_at_1_sequence - single


def _any_sign(rows: Sequence[SweepRow]) -> bool:
    """Whether some reduction or change of recall@1 of the sweep has a direction (its interval excludes 0)."""
    return any(_sign(r) in (1, -1) or _gain(r) is not None for r in rows)


def _untold(rows: Sequence[SweepRow]) -> list[str]:
    """A sentence naming the thresholds (per method) where the sweep's intervals hold 0 or are missing: there no
    sign of the reduction or of sequence matching's change is named."""
    kind = rows[0].ground_truth
    parts = []
    for name in dict.fromkeys(r.method for r in rows):
        mine = [r for r in rows if r.method == name]
        reduction = [r for r in mine if r.reduction_pct is not None and _sign(r) in (0, None)
                     and r.outcome != UNCHANGED]
        change = [r for r in mine if _gain(r) is None]
        for what, found in (("its AOC reduction", reduction), ("sequence matching's change of recall@1", change)):
            if found:
                where = ", ".join(f"{r.threshold:g}" for r in found)
                parts.append(f"{name}, {what} at {where}{' frames' if kind == 'frames' else ''}")
    if not parts:
        return []
    n = _span_of([r.n_queries for r in rows])
    over = f" ({n} queries)" if n else ""
    return [f"No sign is named where the {bounds.LEVEL} interval holds 0 or is missing{over}: {'; '.join(parts)}."]
# --- the training-free baselines (method §12) -------------------------------------------------------------------


def _difference(interval: Interval | None, ap: bool = False) -> str:
    """The interval of a paired difference: of reductions in points (per cent), of average precisions in AP."""
    if interval is None:
        return words.UNEARNED[NO_INTERVAL]
    return f"interval {bounds.span(interval, unit='', fmt='.3f') if ap else bounds.span(interval, unit=' points')}"


def baseline_sentence(comparison: Comparison, split: str) -> str:
    """Whether the seed-0 predictor's AOC reduction beats the best training-free scorer's at its budget (the scorer
    with the largest mean of its seed-0 reductions over the methods: seed 0 against seed 0), method by method by the
    paired interval of the difference (a direction only where it excludes 0), and what removing only wrong matches
    (the oracle) would do at that budget, mean over the methods."""
    where = (f"On {comparison.dataset} ({split} split, L = {comparison.seq_len}, {comparison.mode} mode), at the "
             "seed-0 predictor's budget")
    n = len(comparison.methods)
    if comparison.best is None:
        text = f"{where} no training-free scorer has a defined AOC reduction for any of the {methods(n)}"
    else:
        best_mean = comparison.best_mean
        mean = "" if best_mean is None else f", mean seed-0 reduction {signed(best_mean)}"
        wins: list[str] = []
        losses: list[str] = []
        untold: list[str] = []
        none: list[str] = []
        same: list[str] = []
        differences = comparison.differences or tuple(None for _ in comparison.methods)
        for method, difference in zip(comparison.methods, differences, strict=True):
            if _identical(difference):
                same.append(method)
                continue
            sign = None if difference is None else difference.sign()
            target = none if sign is None else wins if sign < 0 else losses if sign > 0 else untold
            target.append(f"{method} ({_difference(difference)})" if difference is not None else method)
        text = (f"{where} the predictor beats the best training-free scorer ({comparison.best}{mean}) for "
                f"{len(wins)} of {methods(n)}" + (f": {listed(wins)}" if wins else ""))
        if losses:
            text += f"; {comparison.best} beats the predictor for {listed(losses)}"
        if same:
            text += (f"; for {listed(same)} the two reductions are equal on every draw of the queries (the same "
                     "matches removed)")
        if untold:
            queries = _span_of(comparison.n_queries)
            text += (f"; for {listed(untold)} the {bounds.LEVEL} interval of the difference holds 0"
                     f"{f' ({queries} queries)' if queries else ''}, so no direction is named")
        if none:
            text += f"; no interval of the difference for {listed(none)}"
        if comparison.undefined:
            text += f" (a reduction is undefined for {listed(list(comparison.undefined))})"
    oracle = comparison.oracle_mean
    if oracle is not None:
        text += f"; oracle removal at the same budget would reduce the AOC by {size(oracle)}"
        defined = sum(value is not None for value in comparison.oracle)
        if defined < n:
            text += f" (mean over the {methods(defined)} where it is defined)"
        elif n > 1:
            text += " (mean over the methods)"
    return text + "."


def _by_verdict(verdicts: Sequence[tuple[str, str]], order: Sequence[str]) -> str:
    """``better for a [-5.0, -1.0] and b [...]; interval holds 0 for c [-3.0, 2.0]``: the methods (each with its
    interval, ``_paired_name``) grouped by verdict, in ``order``."""
    groups = {verdict: [method for method, said in verdicts if said == verdict] for verdict in order}
    return "; ".join(f"{verdict} for {listed(names)}" for verdict, names in groups.items() if names)


def _paired_name(method: str, difference: Interval | None, fmt: str) -> str:
    """A method as a headline names it beside a paired verdict: with the interval of the difference."""
    return method if difference is None else f"{method} {bounds.bracket(difference, fmt)}"


def _paired(difference: Interval | None) -> str:
    """A paired difference (a scorer's number minus the predictor's, higher better for both) in words, from the
    predictor's side: better where the difference lies below 0."""
    if difference is None:
        return words.UNEARNED[NO_INTERVAL]
    if _identical(difference):
        return "equal"
    sign = difference.sign()
    if sign == 0:
        return words.UNEARNED[HOLDS_ZERO]
    return "better" if sign < 0 else "worse"


VERDICTS = ("better", "worse", "equal", words.UNEARNED[HOLDS_ZERO], words.UNEARNED[NO_INTERVAL])


def baseline_headline(comparison: Comparison) -> str:
    """The first screen's one sentence of the baselines on one dataset, mode and L: per method whether the seed-0
    predictor's reduction is better than the best training-free scorer's, by the paired interval."""
    where = f"{comparison.dataset} (L = {comparison.seq_len}, {comparison.mode} mode)"
    if comparison.best is None:
        return f"{where}: no training-free scorer has a defined AOC reduction."
    differences = comparison.differences or tuple(None for _ in comparison.methods)
    verdicts = [(_paired_name(method, difference, ".1f"), _paired(difference))
                for method, difference in zip(comparison.methods, differences, strict=True)]
    return (f"{where}, the predictor against the best training-free scorer ({comparison.best}) at its budget "
            f"(the {bounds.LEVEL} interval of its reduction minus the predictor's, in points): "
            f"{_by_verdict(verdicts, VERDICTS)}.")


def detection_headline(found: Sequence[DetectionComparison]) -> str:
    """The first screen's one sentence of wrong-match detection on one dataset and L: per method whether the
    predictor's average precision is better than the best training-free scorer's, by the paired interval."""
    first = found[0]
    verdicts = [(one.method, "no wrong match") if one.best is None or one.average_precision is None
                else (_paired_name(one.method, one.difference, ".3f"), _paired(one.difference)) for one in found]
    return (f"{first.dataset} (L = {first.seq_len}), detecting wrong matches, the predictor against the best "
            f"training-free scorer (the {bounds.LEVEL} interval of its average precision minus the predictor's): "
            f"{_by_verdict(verdicts, (*VERDICTS, 'no wrong match'))}.")


def _identical(difference: Interval | None) -> bool:
    """A paired difference that is 0 on every draw: the two numbers are the same, which is no direction, and says so
    rather than that its interval holds 0."""
    return difference is not None and difference.low == 0 == difference.high


def _span_of(values: Sequence[int | None]) -> str:
    """``28``, or ``28-31`` where the values differ; empty where none is known."""
    known = sorted({int(v) for v in values if v is not None})
    return "" if not known else str(known[0]) if len(known) == 1 else f"{known[0]}-{known[-1]}"


def detection_sentence(found: Sequence[DetectionComparison], split: str) -> str:
    """Wrong-match detection on one dataset and L: per method the training-free scorer with the highest average
    precision (seed 0's, as the predictor's) and whether it beats the predictor, by the paired interval of the
    difference (a direction only where it excludes 0)."""
    first = found[0]
    parts = []
    for one in found:
        if one.best is None or one.average_precision is None:
            parts.append(f"for {one.method} no training-free scorer has an average precision (no wrong match)")
            continue
        against = "" if one.predictor is None else f" against the predictor's {one.predictor:.3f}"
        text = f"for {one.method} {one.best} has the highest, {one.average_precision:.3f}{against}"
        difference = one.difference
        if _identical(difference):
            text += ", the same on every draw of the queries (the same ranking of the wrong matches)"
        elif difference is None:
            text += ", without an interval of the difference, so no direction is named"
        elif difference.sign() > 0:
            text += f", and beats the predictor (difference {_difference(difference, ap=True)})"
        elif difference.sign() < 0:
            text += f", and the predictor beats it (difference {_difference(difference, ap=True)})"
        else:
            held = bounds.holds_zero(difference, "the difference", str(one.n_queries), ".3f")
            text += f"; {held}, so no direction is named"
        parts.append(text)
    return (f"Detecting wrong matches on {first.dataset} ({split} split, L = {first.seq_len}), average precision "
            "among the training-free scorers (seed 0): " + "; ".join(parts) + ".")
