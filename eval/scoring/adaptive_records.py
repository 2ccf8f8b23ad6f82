"""The records of the experiment ``adaptive_seq_len`` (method §15), apart from its computation
(``eval.scoring.adaptive``), so that the report reads them without importing the scoring."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from vpr_smr.core.records import FileRecord, Record
from vpr_smr.eval.scoring.records import Interval, Reduction, SeedSummary

__all__ = [
    "ADAPTIVE", "ADAPTIVE_FALLBACK", "ADAPTIVE_UNIQUENESS", "COMPARED_MODE", "FIXED", "FIXED_PREDICTOR", "KINDS",
    "RULE", "RULES",
    "AdaptiveMode", "AdaptiveResult", "AdaptiveRow", "AdaptiveTiming", "best_key", "fixed_name", "precision_lost",
]

Json = dict[str, Any]

ADAPTIVE, ADAPTIVE_FALLBACK, ADAPTIVE_UNIQUENESS = "adaptive", "adaptive_fallback", "adaptive_uniqueness"
RULES = (ADAPTIVE, ADAPTIVE_FALLBACK, ADAPTIVE_UNIQUENESS)  # the table's and the figure's order
FIXED, FIXED_PREDICTOR, RULE = "fixed", "fixed+predictor", "rule"
# The mode whose numbers compare rows: standard mode's recall divides by the queries, which every row shares; paper
# mode's by each row's own correct matches, which differ from row to row (another length's matches)
COMPARED_MODE = "standard"
KINDS = (FIXED, FIXED_PREDICTOR, RULE)


def precision_lost(aoc: float, max_recall: float) -> float:
    """A row's AOC over its maximum recall: one minus its mean precision over recall 0 .. R_max, what ranks rows that
    reach different maximum recalls (an AOC is at most R_max, so the AOC alone is smaller the more matches a row
    removes); +inf at recall 0."""
    return aoc / max_recall if max_recall > 0 else math.inf


def best_key(aoc: float, max_recall: float, index: int) -> tuple[float, float, int]:
    """How the best of several rows is chosen (the best fixed row, the best rule): the smallest ``precision_lost``,
    then the larger maximum recall, then the first (``index``: its place in the table's order)."""
    return precision_lost(aoc, max_recall), -max_recall, index


def fixed_name(seq_len: int, predictor: bool) -> str:
    """A fixed length's row name: ``L4`` without its predictor, ``L4+pred`` with it."""
    return f"L{seq_len}+pred" if predictor else f"L{seq_len}"


@dataclass(frozen=True)
class AdaptiveMode(Record):
    """One row in one mode, seed 0 (the authors' recipe). ``reduction``: Table I's numbers with VPR+SM the longest
    fixed length without predictor, cut to this row's maximum recall: ``reduction.max_recall`` and
    ``reduction.aoc_vpr_sm_pred`` are the row's own maximum recall and AOC there, ``reduction.reduction_pct`` the
    reduction against the longest length, with the bootstrap intervals over queries (``aoc_vpr_sm_pred_ci``: the
    row's AOC's). ``seeds``: the reduction's spread over every seed (None for a row without predictor). For a rule in
    the mode that compares rows (``AdaptiveResult.best_fixed``'s, standard), ``minus_best_fixed``: its AOC minus the
    best fixed row's, both taken at the smaller of their two maximum recalls, and ``minus_best_fixed_ci`` its paired
    bootstrap interval (None for a fixed row, in paper mode, or with too few defined draws)."""

    reduction: Reduction
    seeds: SeedSummary | None
    minus_best_fixed: float | None = None
    minus_best_fixed_ci: Interval | None = None


@dataclass(frozen=True)
class AdaptiveRow(Record):
    """One fixed length (with or without its predictor) or one rule of method §15 on the shared queries of the table
    split. ``kind``: ``FIXED``, ``FIXED_PREDICTOR`` or ``RULE``; ``seq_len``: a fixed row's length (None for a
    rule). Seed 0: ``removed``, the matches it removes; ``lengths``, how many queries used each length (a rule's
    histogram; the key ``eval.matching.adaptive.NONE`` = -1 counts the queries no length accepted); ``mean_length``,
    the mean length used, a query no length accepted counting the longest (the live matcher computed every length).
    ``mean_length_seeds``: the mean length of every seed, seed 0 first. ``threshold``: ``adaptive_uniqueness``'s
    ``tau`` of seed 0 (None for the other rows)."""

    name: str
    kind: str
    seq_len: int | None
    removed: int
    mean_length: float
    lengths: dict[int, int]
    mean_length_seeds: tuple[float, ...]
    modes: dict[str, AdaptiveMode]
    threshold: float | None = None


@dataclass(frozen=True)
class AdaptiveResult(FileRecord):
    """The experiment ``adaptive_seq_len`` of one dataset, method and matcher (``eval.scoring.adaptive.main``).
    ``meta``: dataset, method, ``tag`` (the matcher's name in tables and files, ``matcher_comparison.matcher_tag``)
    and ``matcher`` (its provenance), the table and validation splits, modes, seeds, the baselines' settings and the
    ground truth. ``lengths``: ``L_1 < .. < L_m``. ``n_queries``: the table split's queries every
    length evaluates (every number is over them); ``n_queries_validation``: the validation split's (None without
    one). ``rows``: the fixed lengths without predictor, then with it (shortest first), then the rules (``RULES``'s
    order; ``adaptive_uniqueness`` only with a validation split). ``best_fixed``: in standard mode only (its recall
    divides by the queries, the same for every row; paper mode's by each row's own correct matches), the fixed row
    that loses the least precision over its recall (``best_key``: seed 0, among those that keep a correct match;
    ``eval.scoring.adaptive.best_fixed``).
    ``notes``: what the result leaves out, in words (e.g. no validation split)."""

    meta: Json
    lengths: tuple[int, ...]
    n_queries: int
    n_queries_validation: int | None
    rows: tuple[AdaptiveRow, ...]
    best_fixed: dict[str, str]
    notes: tuple[str, ...]


@dataclass(frozen=True)
class AdaptiveTiming(FileRecord):
    """The live matcher's time on the table split, in its own file (times change from run to run, the result must
    not): ``seconds_adaptive``, every frame fed to ``AdaptiveLiveMatcher`` (lengths computed shortest first, up to
    the first whose predictor keeps the match, seed 0); ``seconds_longest``, the same frames fed to a
    ``LiveMatcher`` of the longest length with its predictor; ``n_frames`` fed, ``n_queries`` with a match.
    ``refused``: why the live matcher cannot run this matcher (both times None then)."""

    meta: Json
    n_frames: int
    n_queries: int
    seconds_adaptive: float | None
    seconds_longest: float | None
    refused: str | None = None
