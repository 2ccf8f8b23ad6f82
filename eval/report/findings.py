"""The report's findings in words: a few sentences per dataset, mode and L that say what Table I shows, what the
speed experiment shows, and how the predictor compares with the training-free scorers (method §12).

Every number in them is one of the tables' (``table1.Table1Block``: the seed-0 predictor's reductions and the seed
summary; ``baselines.Comparison``: the baselines table's), rounded for reading; the table beside them keeps the
exact values.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from vpr_smr.eval.report import outcome_words as words
from vpr_smr.eval.report.baselines import Comparison
from vpr_smr.eval.report.table1 import Table1Block
from vpr_smr.eval.scoring.curves import NOTHING_TO_REDUCE
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


def _seed_part(row: dict[str, Any]) -> str | None:
    """``method mean ± std %`` over the seeds (and how many, with the seeds left out and why, when only some are
    defined); None when undefined."""
    mean, std = row.get("reduction_pct_mean"), row.get("reduction_pct_std")
    if mean is None:
        return None
    n_seeds = row["n_seeds"]
    defined = row.get("n_seeds_defined", n_seeds)
    spread = "" if std is None else f" ± {std:.1f}"
    part = f"{row['method']} {mean:.1f}{spread} %"
    if defined == n_seeds:
        return part
    left_out = row.get("seeds_left_out", "")
    return f"{part} ({defined} of {n_seeds} seeds{'; ' + left_out if left_out else ''})"


def _seed_sentences(block: Table1Block) -> list[str]:
    if not block.has_seeds:
        return []
    rows = block.rows
    n_seeds = int(rows[0]["n_seeds"])
    if n_seeds == 1:
        return ["One predictor seed was run, so there is no spread over seeds."]
    parts = [(row, _seed_part(row)) for row in rows]
    shown = [part for _, part in parts if part is not None]
    undefined = [row for row, part in parts if part is None]
    if not shown:
        return [f"Over {n_seeds} predictor seeds the reduction is undefined for every method"
                + _why_undefined(undefined) + "."]
    improved = sum(words.improved_on_average(row) for row in rows)
    text = f"Over {n_seeds} predictor seeds (mean ± sample standard deviation) the reduction is {listed(shown)}"
    if len(rows) > 1:
        text += f"; on average it helps {improved} of {methods(len(rows))}"
    if undefined:
        text += f"; it is undefined for {listed([str(r['method']) for r in undefined])}" + _why_undefined(undefined)
    return [text + "."]


def _why_undefined(rows: Sequence[dict[str, Any]]) -> str:
    """`` (a: seeds 0, 1: removed every match)``: which seeds are left out and why, per method."""
    reasons = [f"{r['method']}: {r['seeds_left_out']}" for r in rows if r.get("seeds_left_out")]
    return f" ({'; '.join(reasons)})" if reasons else ""


def sentences(block: Table1Block, split: str) -> list[str]:
    """What the predictor did to the area over the PR curve of each method of one dataset, mode and L. A method
    whose predictor was degenerate (removed every match, kept no correct one, made a perfect baseline worse, kept
    every match) gets its own sentence saying what happened (``outcome_words``) and counts as not improved."""
    rows = block.rows
    where = f"On {block.dataset} ({split} split, L = {block.seq_len}, {block.mode} mode, seed-0 predictor)"
    plain = [r for r in rows if not words.is_degenerate(r)]
    degenerate = [r for r in rows if words.is_degenerate(r)]
    better = sorted(((str(r["method"]), float(r["reduction_pct"])) for r in plain if r["reduction_pct"] > 0),
                    key=lambda item: -item[1])
    worse = sorted(((str(r["method"]), float(r["reduction_pct"])) for r in plain if r["reduction_pct"] < 0),
                   key=lambda item: item[1])
    same = [str(r["method"]) for r in plain if r["reduction_pct"] == 0]
    out = []
    if degenerate and all(r.get("outcome") == NOTHING_TO_REDUCE and not words.lowered_recall(r) for r in rows):
        whose = f"{rows[0]['method']}'s" if len(rows) == 1 else f"each of the {len(rows)} methods'"
        out.append(f"{where} {whose} {AOC} is already 0 without the predictor: there is nothing to reduce, so the "
                   "reduction is undefined.")
        return out + _seed_sentences(block)
    if len(rows) == 1 and plain:
        method, value = str(rows[0]["method"]), float(rows[0]["reduction_pct"])
        if value > 0:
            out.append(f"{where} the predictor reduced {method}'s {AOC} by {size(value)}.")
        elif value < 0:
            out.append(f"{where} the predictor made {method}'s {AOC} {size(value)} worse (larger).")
        else:
            out.append(f"{where} the predictor left {method}'s {AOC} unchanged.")
    elif len(rows) == 1:
        out.append(f"{where}, for {rows[0]['method']}, {words.note(rows[0])}.")
    else:
        if better:
            clauses = [f"reduced the {AOC} for {len(better)} of {methods(len(rows))}: "
                       + ", ".join(f"{m} by {size(v)}" for m, v in better)]
        else:
            clauses = [f"reduced the {AOC} for none of the {len(rows)} methods"]
        if worse:
            clauses.append("it made " + listed([f"{m}'s {size(v)}" for m, v in worse]) + " worse")
        if same:
            clauses.append("it left " + listed([f"{m}'s" for m in same]) + " unchanged")
        out.append(f"{where} the predictor " + "; ".join(clauses) + ".")
        out += [f"For {r['method']}, {words.note(r)}." for r in degenerate]
        defined = [float(r["reduction_pct"]) for r in rows if r["reduction_pct"] is not None]
        if len(defined) > 1:
            these = "these" if len(defined) < len(rows) else "the"
            out.append(f"The mean reduction over {these} {len(defined)} methods is {signed(float(np.mean(defined)))} "
                       "(Table I's Mean).")
    return out + _seed_sentences(block)


# --- the speed experiment ---------------------------------------------------------------------------------------


def percent(value: float) -> str:
    """A recall or a reduction as a sentence says it: per cent, one decimal."""
    return f"{value:.1f} %"


def recall(value: float | None) -> str:
    """A recall (a fraction) in per cent; ``n/a`` when there is none."""
    return "n/a" if value is None else percent(100 * value)


def ratio(speed: float) -> str:
    return f"{speed:g}x"


def _mean(rows: Sequence[dict[str, Any]], key: str) -> tuple[float | None, int]:
    """The mean of ``key`` over ``rows`` where it is defined, and over how many."""
    values = [float(r[key]) for r in rows if r.get(key) is not None]
    return (float(np.mean(values)) if values else None), len(values)


def speed_sentences(rows: Sequence[dict[str, Any]], split: str) -> list[str]:
    """What the speed experiment shows on one dataset at one L (the rows of ``build.speed_rows``: one per method,
    profile and matcher): the fixed matcher's sequence recall@1 at the constant speed farthest from 1 (the faster
    on a tie) against the speed closest to 1, velocity search's there, and the predictor's AOC reduction under
    each matcher. Every number is a mean over the methods, in per cent."""
    if not rows:
        return []
    first = rows[0]
    n_methods = len({r["method"] for r in rows})
    where = (f"On {first['dataset']} ({split} split, L = {first['seq_len']}, paper mode, one seed-0 predictor per "
             "matcher and profile)")

    def at(speed: float | None, matcher: str) -> list[dict[str, Any]]:
        return [r for r in rows if r["matcher"] == matcher and r["speed"] == speed]

    speeds = sorted({float(r["speed"]) for r in rows if r["speed"] is not None})
    out = []
    if speeds:
        base = min(speeds, key=lambda s: (abs(np.log(s)), s))
        far = max(speeds, key=lambda s: (abs(np.log(s)), s))
        fixed_base, _ = _mean(at(base, "fixed"), "recall_at_1_sequence")
        fixed_far, _ = _mean(at(far, "fixed"), "recall_at_1_sequence")
        velocity_base, _ = _mean(at(base, "velocity"), "recall_at_1_sequence")
        velocity_far, _ = _mean(at(far, "velocity"), "recall_at_1_sequence")
        over = f"mean over {methods(n_methods)}"
        if (far != base and fixed_base is not None and fixed_far is not None and velocity_base is not None
                and velocity_far is not None):
            verb = "falls" if fixed_far < fixed_base else "rises" if fixed_far > fixed_base else "stays"
            text = (f"{where}, at {ratio(far)} speed the fixed matcher's sequence recall@1 {verb} from "
                    f"{percent(100 * fixed_base)} at {ratio(base)} to {percent(100 * fixed_far)} ({over}); velocity "
                    f"search gets {percent(100 * velocity_far)} there ({percent(100 * velocity_base)} at "
                    f"{ratio(base)})")
        else:  # one constant speed only (or a matcher missing): its numbers alone
            text = (f"{where}, at {ratio(far)} speed the fixed matcher's sequence recall@1 is "
                    f"{recall(fixed_far)} and velocity search's {recall(velocity_far)} ({over})")
        parts = []
        for matcher, name in (("fixed", "the fixed matcher"), ("velocity", "velocity search")):
            mean, n = _mean(at(far, matcher), "reduction_pct")
            if mean is not None:
                undefined = [f"{r['method']}: {words.SHORT.get(str(r.get('outcome')), 'undefined')}"
                             for r in at(far, matcher) if r.get("reduction_pct") is None]
                why = f" ({'; '.join(undefined)})" if undefined else ""
                note = "" if n == n_methods else f" over the {n} methods where it is defined{why}"
                parts.append(f"{signed(mean)} with {name}{note}")
        if parts:
            text += f"; the predictor's AOC reduction at {ratio(far)} is " + " and ".join(parts)
        out.append(text + ".")
    varying = [r for r in rows if r["speed"] is None]
    if varying:
        fixed, _ = _mean([r for r in varying if r["matcher"] == "fixed"], "recall_at_1_sequence")
        velocity, _ = _mean([r for r in varying if r["matcher"] == "velocity"], "recall_at_1_sequence")
        if fixed is not None and velocity is not None:
            lead = "Under" if out else f"{where}, under"
            out.append(f"{lead} the varying speed (mean {varying[0]['mean_speed']:.2f}x) the sequence recall@1 is "
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


def sweep_sentences(rows: Sequence[dict[str, Any]]) -> list[str]:
    """One sentence on the protocol sweep of one dataset, L and mode (``build.sweep_rows``' rows): every conclusion
    that changes with the ground truth's tolerance or radius (the predictor's reduction changing sign for a method,
    sequence matching's gain over single frames changing sign, two methods swapping places by sequence recall@1),
    or that none does."""
    if not rows:
        return []
    first = rows[0]
    kind = str(first["ground_truth"])
    thresholds = sorted({float(r["threshold"]) for r in rows})
    names = list(dict.fromkeys(str(r["method"]) for r in rows))
    by_method = {name: sorted((r for r in rows if r["method"] == name), key=lambda r: r["threshold"])
                 for name in names}
    changes = []
    flipped = _flip({name: [(r["threshold"], r.get("reduction_pct")) for r in mine]
                     for name, mine in by_method.items()})
    if flipped:
        name, t_up, up, t_down, down = flipped
        changes.append(f"the predictor's AOC reduction for {name} changes sign ({signed(up)} "
                       f"{within(kind, t_up)}, {signed(down)} {within(kind, t_down)})")
    gains = {name: [(r["threshold"], r["recall_at_1_sequence"] - r["recall_at_1_single"]) for r in mine]
             for name, mine in by_method.items()}
    flipped = _flip(gains)
    if flipped:
        name, t_up, up, t_down, down = flipped
        changes.append(f"sequence matching changes {name}'s recall@1 by {100 * up:+.1f} points "
                       f"{within(kind, t_up)} but {100 * down:+.1f} {within(kind, t_down)}")
    recall = {(str(r["method"]), float(r["threshold"])): float(r["recall_at_1_sequence"]) for r in rows}
    for i, a in enumerate(names):
        swap = next(((b, t1, t2) for b in names[i + 1:] for t1 in thresholds for t2 in thresholds
                     if recall.get((a, t1), 0) > recall.get((b, t1), 0)
                     and recall.get((a, t2), 0) < recall.get((b, t2), 0)), None)
        if swap:
            b, t1, t2 = swap
            changes.append(f"{a} and {b} swap places by sequence recall@1 ({a} ahead "
                           f"{within(kind, t1)}, {b} {within(kind, t2)})")
            break
    low, high = thresholds[0], thresholds[-1]
    span = f"{low:g} to {high:g} frames" if kind == "frames" else f"a radius of {low:g} to {high:g}"
    where = (f"With matches counted correct within {span} ({first['dataset']}, {first['split']} split, "
             f"L = {first['seq_len']}, {first['mode']} mode)")
    if changes:
        return [f"{where}, a conclusion depends on the ground truth: {'; '.join(changes)}."]
    return [f"{where}, no conclusion depends on the ground truth: the predictor's AOC reduction keeps its sign for "
            f"every method, so does sequence matching's gain over single frames, and no two methods swap places by "
            "sequence recall@1."]
# --- the training-free baselines (method §12) -------------------------------------------------------------------


def baseline_sentence(comparison: Comparison, split: str) -> str:
    """For how many methods the seed-0 predictor's AOC reduction beats the best training-free scorer's at its budget
    (the scorer with the largest mean reduction over the methods; random's is its mean over the seeds), and what
    removing only wrong matches (the oracle) would do at that budget, mean over the methods."""
    where = (f"On {comparison.dataset} ({split} split, L = {comparison.seq_len}, {comparison.mode} mode), at the "
             "seed-0 predictor's budget")
    n = len(comparison.methods)
    if comparison.best is None:
        text = f"{where} no training-free scorer has a defined AOC reduction for any of the {methods(n)}"
    else:
        best_mean = comparison.best_mean
        mean = "" if best_mean is None else f", mean reduction {signed(best_mean)}"
        text = (f"{where} the predictor beats the best training-free scorer ({comparison.best}{mean}) for "
                f"{comparison.beaten} of {methods(n)}")
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
