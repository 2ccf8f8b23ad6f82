"""The stages of the studies beyond Table I: ``speed`` (method §11), ``compare-matchers`` (method §14),
``adaptive`` (method §15) and ``deployment`` (method §16), with the summary lines and the text they print. Their job
records are ``eval.scoring.study_jobs``' and ``deployment_jobs``'; the work's modules are imported when a stage runs
(the command line declares every stage when it starts, and a command that runs no study must not import them)."""

from __future__ import annotations

import argparse
from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

from vpr_smr.eval.scoring.deployment_jobs import DeploymentJob
from vpr_smr.eval.scoring.study_jobs import AdaptiveJob, MatchersJob, SpeedJob
from vpr_smr.pipeline.options import _dest
from vpr_smr.pipeline.stage import GROUP, Stage, wrote

if TYPE_CHECKING:
    from vpr_smr.eval.scoring.adaptive_records import AdaptiveResult
    from vpr_smr.eval.scoring.matcher_comparison import MatcherComparison
    from vpr_smr.eval.scoring.speed import SpeedResult

__all__ = ["ADAPTIVE", "COMPARE_MATCHERS", "DEPLOYMENT", "SPEED", "STAGES", "adaptive_text", "deployment_headline",
           "lowest_rule", "matchers_headline", "speed_headline"]



# --- speed ---------------------------------------------------------------------------------------------------------


def speed_headline(result: Any) -> str:
    """The speed headline (``speed.SpeedResult``): the range of sequence recall@1 over its matchers and methods."""
    recalls = [scores.recall_at_1_sequence for matcher in result.matchers.values()
               for scores in matcher.methods.values()]
    n_methods = len(recalls) // len(result.matchers)
    return (f"sequence recall@1 {min(recalls):.4f} to {max(recalls):.4f} over {len(result.matchers)} matchers x "
            f"{n_methods} methods ({result.meta['mode']} mode, seed 0)")


def _speed(job: SpeedJob) -> SpeedResult:
    from vpr_smr.eval.scoring import speed

    return speed.main(job)


SPEED = Stage("speed", "one simulated speed profile: Table I's numbers of the fixed matcher and of velocity search, "
              "each with its own seed-0 predictor", SpeedJob, _speed,
              summary=lambda job, result: wrote(f"the speed profile {job.profile}", job.out, speed_headline(result)),
              epilog="e.g. vpr-smr speed --dataset d --seq-len 4 --profile 2x --velocities 0.5 1 2 --train "
                     "sad=train.h5 --table sad=test.h5 --out speed/2x.json")


# --- compare-matchers ----------------------------------------------------------------------------------------------


def matchers_headline(result: Any, modes: Iterable[str]) -> str:
    """The compare-matchers headline (``MatcherComparison``): per mode, how many matcher-method pairs the seed-0
    predictor reduces the AOC for by ``curves.earned`` (its interval above 0)."""
    from vpr_smr.eval.scoring.curves import IMPROVED, earned

    counts = []
    for mode in modes:
        reductions = [scores.modes[mode].reduction for methods in result.matchers.values()
                      for scores in methods.values() if mode in scores.modes]
        reduced = sum(earned(r.outcome, r.reduction_pct_ci) == IMPROVED for r in reductions)
        counts.append(f"{reduced} of {len(reductions)} matcher-method pairs ({mode} mode)")
    return "the seed-0 predictor reduces the AOC, its interval above 0, for " + ", ".join(counts)


def _compare_matchers(job: MatchersJob) -> MatcherComparison:
    from vpr_smr.eval.scoring import matcher_comparison

    return matcher_comparison.main(job)


COMPARE_MATCHERS = Stage(
    "compare-matchers", "the experiment matchers (method §14): each matcher with its own predictor, on the queries "
    "every matcher evaluates", MatchersJob, _compare_matchers,
    summary=lambda job, result: wrote(f"the matchers compared on {job.method}", job.out,
                                       matchers_headline(result, job.modes)),
    epilog="e.g. vpr-smr compare-matchers --dataset d --method sad --seq-len 4 --inputs @inputs.json --distances "
           "sad=test.h5 --split test --validation val --out matchers/d/sad/L4.json")


# --- adaptive ------------------------------------------------------------------------------------------------------


def lowest_rule(result: Any) -> str:
    """The length rule of the lowest AOC (seed 0) in the mode that compares rows (else the first), with its
    interval and its difference from the best fixed length's; no direction word (the table above has them)."""
    from vpr_smr.eval.report.bounds import bracket
    from vpr_smr.eval.scoring.adaptive_records import COMPARED_MODE, RULE

    rules = [row for row in result.rows if row.kind == RULE]
    if not rules:
        return "no length rule"
    modes = list(rules[0].modes)
    mode = COMPARED_MODE if COMPARED_MODE in modes else modes[0]
    best = min(rules, key=lambda row: row.modes[mode].reduction.aoc_vpr_sm_pred)
    numbers = best.modes[mode]
    text = (f"lowest AOC of the length rules ({mode} mode, seed 0): {best.name} "
            f"{numbers.reduction.aoc_vpr_sm_pred:.4f} {bracket(numbers.reduction.aoc_vpr_sm_pred_ci, '.4f')}")
    fixed = result.best_fixed.get(mode)
    if fixed is not None and numbers.minus_best_fixed is not None:
        text += (f", minus the best fixed length's ({fixed}) {numbers.minus_best_fixed:+.4f} "
                 f"{bracket(numbers.minus_best_fixed_ci, '.4f')}")
    return text


def adaptive_text(result: Any, timing: Any) -> str:
    """The report's table ``adaptive_seq_len`` of one result, its page columns, per mode, as Markdown."""
    from vpr_smr.eval.report.build import markdown_table
    from vpr_smr.eval.report.rows import cells
    from vpr_smr.eval.report.tables.adaptive import TABLE, adaptive_rows, adaptive_sentence

    rows = adaptive_rows([(result, timing)])
    out = []
    for mode in dict.fromkeys(row.mode for row in rows):
        shown = [row for row in rows if row.mode == mode]
        out += [markdown_table(TABLE.page, [cells(row) for row in shown],
                               f"{mode} mode, {result.n_queries} queries every length evaluates"),
                adaptive_sentence(shown), ""]
    return "\n".join([*out, *(f"Note: {note}" for note in result.notes)]).rstrip()


def _split_items(args: argparse.Namespace) -> None:
    """``--attributes SPLIT=PATH ...`` (the form of earlier versions, one item per file) as the option's groups
    ``SPLIT PATH ...``: the files of a split in the order given."""
    dest = _dest(GROUP, "attributes")  # where pipeline.options keeps the option
    groups = getattr(args, dest, None)
    if not groups:
        return
    kept: list[list[str]] = []
    items: list[list[str]] = []
    for words in groups:
        (items if "=" in words[0] else kept).append(words)
    by_split: dict[str, list[str]] = {}
    for word in (word for words in items for word in words):
        split, sep, path = word.partition("=")
        if not (split and sep and path):
            raise ValueError(f"--attributes takes SPLIT=PATH items (or SPLIT PATH...), got {word}")
        by_split.setdefault(split, []).append(path)
    setattr(args, dest, [*kept, *([split, *paths] for split, paths in by_split.items())])


def _adaptive(job: AdaptiveJob) -> AdaptiveResult:
    from vpr_smr.eval.scoring import adaptive

    return adaptive.main(job)


def _adaptive_show(job: AdaptiveJob, result: AdaptiveResult) -> str:
    """The table of ``adaptive_text``, with the live timing written beside the result."""
    from vpr_smr.eval.scoring.adaptive import read_timing

    return adaptive_text(result, read_timing(job.out))


ADAPTIVE = Stage(
    "adaptive", "the sequence length chosen per query (method §15): each rule against every fixed length with and "
    "without its predictor; prints the table", AdaptiveJob, _adaptive,
    summary=lambda job, result: wrote(f"the adaptive sequence length of {job.method}", job.out, lowest_rule(result)),
    show=_adaptive_show,
    epilog="e.g. vpr-smr adaptive --attributes test=L2/test.h5 test=L4/test.h5 val=L2/val.h5 val=L4/val.h5 "
           "--predictors L2.h5 L4.h5 --split test --validation val --distances test.h5 --out adaptive.json",
    check=_split_items)

# --- deployment (method §16) ------------------------------------------------------------------------------------


def deployment_headline(result: Any) -> str:
    """How many of the result's seed-0 rows held their target, per target (the first matcher's)."""
    first = result.rows[0].matcher if result.rows else None
    rows = [r for r in result.rows if r.seed in (None, 0) and r.matcher == first]
    parts = []
    for precision in result.meta["precisions"]:
        at = [r for r in rows if r.precision == precision]
        held = sum(1 for r in at if r.outcome == "held")
        parts.append(f"p = {precision:g}: {held} of {len(at)} source-rule-deployment rows held")
    return f"{rows[0].matcher}: " + "; ".join(parts) if rows else "no rows"


def _deployment(job: DeploymentJob) -> Any:
    from vpr_smr.eval.scoring import deployment

    return deployment.main(job)


DEPLOYMENT = Stage(
    "deployment", "the experiment deployment (method §16): thresholds calibrated on one split by each rule, for "
    "every confidence source, scored on the other splits and datasets", DeploymentJob, _deployment,
    summary=lambda job, result: wrote(f"the deployment of {job.method}'s thresholds", job.out,
                                       deployment_headline(result)),
    epilog="e.g. vpr-smr deployment --dataset d --method sad --seq-len 4 --inputs @inputs.json --out "
           "deployment/d/sad/L4.json (vpr-smr calibrate and vpr-smr deploy do the same for one source and rule)")

STAGES: tuple[Stage, ...] = (SPEED, COMPARE_MATCHERS, ADAPTIVE, DEPLOYMENT)
