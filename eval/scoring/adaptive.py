"""The experiment ``adaptive_seq_len`` (method §15): does choosing the sequence length per query reach the best fixed
length's AOC with a shorter mean length, or a better AOC at the same mean length?

For one dataset, method and matcher, with the lengths ``L_1 < .. < L_m`` of the run and each length's predictors
(every seed), on the queries of the table split that every length evaluates (``matcher_comparison.shared_queries``;
SeqSLAM's ``a >= L_m - 1``):

- every fixed length without its predictor and with it;
- ``adaptive``: the shortest length whose predictor keeps the query's match gives the match; none keeps it, the match
  is removed; ``adaptive_fallback``: the same, but the longest length's match is kept; ``adaptive_uniqueness``
  (training-free): the shortest length whose ``uniqueness`` (method §12) reaches ``tau``, ``tau`` chosen on the
  validation split so that it removes as many matches there as ``adaptive`` does (``uniqueness_threshold``).

Each is scored as Table I scores a removal (method §8), its matches' distances per frame (``Matcher.score_frames``:
a query's match may come from any length, and a sum over more frames is larger), against the longest fixed length
without predictor (``AdaptiveMode``). The live matcher's time per query (``live.AdaptiveLiveMatcher``, lengths
computed shortest first up to the first kept) against the longest length's goes to a file of its own
(``AdaptiveTiming``), and the run checks that its choices are the batch rule's, query by query.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vpr_smr.core.io import JSON_SUFFIXES, check_suffix
from vpr_smr.core.paths import timing_path
from vpr_smr.core.records import save
from vpr_smr.eval.matching.adaptive import NONE, first_accepted, used_lengths
from vpr_smr.eval.matching.attributes import QueryFeatures
from vpr_smr.eval.scoring.adaptive_records import (
    ADAPTIVE,
    ADAPTIVE_FALLBACK,
    ADAPTIVE_UNIQUENESS,
    COMPARED_MODE,
    FIXED,
    FIXED_PREDICTOR,
    RULE,
    AdaptiveMode,
    AdaptiveResult,
    AdaptiveRow,
    AdaptiveTiming,
    best_key,
    fixed_name,
)
from vpr_smr.eval.scoring.curves import AT_RECALL_ZERO
from vpr_smr.eval.scoring.records import Reduction
from vpr_smr.eval.scoring.scorers import BaselineSettings
from vpr_smr.eval.scoring.study_jobs import AdaptiveJob  # the job record, re-exported: a light module's

__all__ = ["AdaptiveJob", "Length", "choose", "compute", "main", "uniqueness_threshold"]

log = logging.getLogger(__name__)

UNIQUENESS = "uniqueness"  # the §12 scorer adaptive_uniqueness reads


@dataclass(frozen=True)
class Length:
    """One sequence length's numbers on the shared queries of a split: its matches' per-frame distances (the
    matcher's score over ``Matcher.score_frames``) and correctness, the paper grid's range per frame (the whole
    split's), every seed's keep-mask (seed 0 first) and the uniqueness of its matches."""

    seq_len: int
    distances: np.ndarray
    correct: np.ndarray
    sequence_min: float
    sequence_max: float
    keeps: tuple[np.ndarray, ...]
    uniqueness: np.ndarray

    @classmethod
    def of(cls, features: QueryFeatures, queries: np.ndarray, seq_len: int, score_frames: int,
           predictors: Sequence[Any], settings: BaselineSettings) -> Length:
        """``features`` of one length cut to ``queries``; each predictor's keep-mask (its rank-0 class, method §8)."""
        from vpr_smr.eval.scoring.curves import keep_mask
        from vpr_smr.eval.scoring.matcher_comparison import restricted
        from vpr_smr.eval.scoring.scorers import scorer

        cut = restricted(features, queries)
        keeps = []
        for predictor in predictors:
            probabilities = predictor.predict_proba(cut.attributes[:, 0, :])
            keeps.append(keep_mask(np.asarray(predictor.classes_)[np.argmax(probabilities, axis=1)]))
        confidence = scorer(UNIQUENESS).confidence
        assert confidence is not None  # a training-free scorer
        # NaN (an infinite best score over an infinite second) never reaches a threshold; +inf (a best score of 0)
        # the largest float, so that the threshold +inf (every query to go) removes it too
        found = np.nan_to_num(confidence(cut, settings, np.zeros(0), 0), nan=-np.inf, posinf=np.finfo(float).max,
                              neginf=-np.inf)
        return cls(seq_len, cut.sequence_distance / score_frames, np.asarray(cut.sequence_correct, dtype=bool),
                   features.sequence_min / score_frames, features.sequence_max / score_frames, tuple(keeps), found)


def uniqueness_threshold(uniqueness: np.ndarray, removed: int) -> float:
    """``tau`` of ``adaptive_uniqueness`` (``uniqueness``: ``(m, N)`` of the validation split's queries, ``removed``:
    the matches ``adaptive`` removes there): a query is removed when no length's uniqueness reaches ``tau``, i.e. its
    largest is below it; ``tau`` is the ``removed``-th smallest largest (0-based; +inf when every query is to go), so
    that exactly ``removed`` go unless equal values straddle the cut (then fewer)."""
    largest = np.sort(np.max(uniqueness, axis=0)) if uniqueness.size else np.zeros(0)
    return float(largest[removed]) if removed < len(largest) else float("inf")


def choose(lengths: Sequence[Length], rule: str, seed: int = 0, tau: float | None = None
           ) -> tuple[np.ndarray, np.ndarray]:
    """The row of each query's chosen length (``adaptive.NONE`` where none accepts) and whether its match is kept,
    by ``rule`` with the seed-``seed`` predictors (``adaptive_uniqueness``: with the threshold ``tau``)."""
    if rule == ADAPTIVE_UNIQUENESS:
        if tau is None:
            raise ValueError("adaptive_uniqueness needs its threshold tau (uniqueness_threshold)")
        chosen = first_accepted(np.stack([length.uniqueness >= tau for length in lengths]))
    elif rule in (ADAPTIVE, ADAPTIVE_FALLBACK):
        chosen = first_accepted(np.stack([length.keeps[seed] for length in lengths]))
    else:
        raise ValueError(f"unknown rule {rule!r}")
    keep = np.ones(len(chosen), dtype=bool) if rule == ADAPTIVE_FALLBACK else chosen != NONE
    return chosen, keep


@dataclass(frozen=True)
class _Removal:
    """One row of one seed: the chosen row per query (NONE: none accepted), the keep-mask."""

    chosen: np.ndarray
    keep: np.ndarray


def _scored(lengths: Sequence[Length], removal: _Removal, own_range: bool) -> Any:
    """The row's matches as a curve takes them: each query's chosen length's (the longest's where none accepted);
    the paper grid over the one length's range (``own_range``: a fixed row) or over every length's (a rule)."""
    from vpr_smr.eval.scoring.intervals import Scored

    index = np.where(removal.chosen == NONE, len(lengths) - 1, removal.chosen)
    columns = np.arange(len(index))
    distances = np.stack([length.distances for length in lengths])[index, columns]
    correct = np.stack([length.correct for length in lengths])[index, columns]
    if own_range:
        first = lengths[int(index[0])] if len(index) else lengths[-1]
        low, high = first.sequence_min, first.sequence_max
    else:
        low = min(length.sequence_min for length in lengths)
        high = max(length.sequence_max for length in lengths)
    return Scored(distances, correct, removal.keep, low, high)


def _curve(mode: str, scored: Any) -> Any:
    """``curves.curve`` of one row's matches (``_scored``)."""
    from vpr_smr.eval.scoring.curves import curve

    return curve(mode, scored.distances, scored.correct, scored.keep, scored.sequence_min, scored.sequence_max)


def _reduction(mode: str, baseline: Any, scored: Any) -> Reduction:
    from vpr_smr.eval.scoring.curves import compare_curves
    from vpr_smr.eval.scoring.evaluate import reduction_of

    same = bool(np.array_equal(scored.distances, baseline.distances) and np.array_equal(scored.correct,
                                                                                         baseline.correct))
    return reduction_of(compare_curves(_curve(mode, baseline), _curve(mode, scored)), len(scored.keep),
                        int((~scored.keep).sum()), same)


@dataclass(frozen=True)
class _Row:
    name: str
    kind: str
    seq_len: int | None
    removals: tuple[_Removal, ...]  # every seed's (one for a row without predictor)
    thresholds: tuple[float, ...] = ()


def _rows(lengths: Sequence[Length], validation: Sequence[Length] | None, n_seeds: int) -> list[_Row]:
    n = len(lengths[0].distances)
    rows = [_Row(fixed_name(length.seq_len, False), FIXED, length.seq_len,
                 (_Removal(np.full(n, i), np.ones(n, dtype=bool)),)) for i, length in enumerate(lengths)]
    rows += [_Row(fixed_name(length.seq_len, True), FIXED_PREDICTOR, length.seq_len,
                  tuple(_Removal(np.full(n, i), length.keeps[seed]) for seed in range(n_seeds)))
             for i, length in enumerate(lengths)]
    for rule in (ADAPTIVE, ADAPTIVE_FALLBACK):
        rows.append(_Row(rule, RULE, None, tuple(_Removal(*choose(lengths, rule, seed)) for seed in range(n_seeds))))
    if validation is not None:
        stacked = np.stack([length.uniqueness for length in validation])
        taus = tuple(uniqueness_threshold(stacked, int((~choose(validation, ADAPTIVE, seed)[1]).sum()))
                     for seed in range(n_seeds))
        rows.append(_Row(ADAPTIVE_UNIQUENESS, RULE, None,
                         tuple(_Removal(*choose(lengths, ADAPTIVE_UNIQUENESS, tau=tau)) for tau in taus), taus))
    return rows


def best_fixed(rows: Sequence[tuple[str, str, int | None, Reduction]]) -> str | None:
    """The best fixed row of ``rows`` (name, kind, length, seed-0 numbers, in the table's order): among the fixed
    rows that keep a correct match, the one that loses the least precision over its recall (``best_key``: AOC over
    maximum recall, then the larger maximum recall, then the earlier row). None when no fixed row keeps a correct
    match."""
    found = [best_key(numbers.aoc_vpr_sm_pred, numbers.max_recall, i) for i, (_, kind, _, numbers) in enumerate(rows)
             if kind != RULE and numbers.outcome not in AT_RECALL_ZERO]
    return rows[min(found)[2]][0] if found else None


def _common_recall(mode: str, first: Any, second: Any) -> float:
    """``first``'s AOC minus ``second``'s at the smaller of their maximum recalls (as
    ``intervals.common_recall_difference`` on every draw)."""
    from vpr_smr.eval.scoring.curves import area, cut_curve

    found = [_curve(mode, s) for s in (first, second)]
    common = min(float(c.recall[-1]) for c in found)
    aoc = [max(0.0, common - area(cut_curve(c, common))) for c in found]
    return aoc[0] - aoc[1]


def compute(lengths: Sequence[Length], validation: Sequence[Length] | None, modes: Sequence[str]
            ) -> tuple[list[AdaptiveRow], dict[str, str]]:
    """Every row of the experiment on the shared queries (``lengths``: the table split's, shortest first;
    ``validation``: the validation split's, None leaves ``adaptive_uniqueness`` out) and the best fixed row's name
    (``best_fixed``) in ``COMPARED_MODE``, against which each rule's AOC is compared at the recall both reach."""
    from vpr_smr.eval.scoring.evaluate import summarise_seeds, with_intervals
    from vpr_smr.eval.scoring.intervals import common_recall_difference, paired_draws, percentile_interval

    n_seeds = len(lengths[0].keeps)
    table = tuple(length.seq_len for length in lengths)
    rows = _rows(lengths, validation, n_seeds)
    longest = len(lengths) - 1
    n = len(lengths[0].distances)
    baseline = _scored(lengths, _Removal(np.full(n, longest), np.ones(n, dtype=bool)), own_range=True)
    # every row's matches of every seed, once: the modes score the same matches
    scored = [[_scored(lengths, removal, row.kind != RULE) for removal in row.removals] for row in rows]
    numbers: dict[str, list[dict[int, Reduction]]] = {}
    draws: dict[str, list[Any]] = {}
    for mode in modes:
        numbers[mode] = [{seed: _reduction(mode, baseline, found) for seed, found in enumerate(seeds)}
                         for seeds in scored]
        draws[mode] = paired_draws(mode, baseline, [seeds[0] for seeds in scored])
    best: dict[str, str] = {}
    if COMPARED_MODE in modes:
        found = best_fixed([(row.name, row.kind, row.seq_len, numbers[COMPARED_MODE][i][0])
                            for i, row in enumerate(rows)])
        if found is not None:
            best[COMPARED_MODE] = found
    out = []
    for i, row in enumerate(rows):
        first = row.removals[0]
        used = [used_lengths(removal.chosen, table) for removal in row.removals]
        histogram = {int(length): int(count) for length, count in zip(*np.unique(
            np.where(first.chosen == NONE, NONE, np.asarray(table)[np.maximum(first.chosen, 0)]), return_counts=True),
            strict=True)}
        spread = summarise_seeds({seed: {mode: numbers[mode][i][seed] for mode in modes}
                                  for seed in range(len(row.removals))}) if row.kind != FIXED else None
        modes_out = {}
        for mode in modes:
            reduction = with_intervals(numbers[mode][i][0], draws[mode][i])
            versus = versus_ci = None
            if row.kind == RULE and mode in best:
                pair = (scored[i][0], scored[[r.name for r in rows].index(best[mode])][0])
                versus = _common_recall(mode, *pair)
                versus_ci = percentile_interval(common_recall_difference(mode, *pair))
            modes_out[mode] = AdaptiveMode(reduction, None if spread is None else spread[mode], versus, versus_ci)
        out.append(AdaptiveRow(row.name, row.kind, row.seq_len, int((~first.keep).sum()),
                               float(np.mean(used[0])) if n else float("nan"), histogram,
                               tuple(float(np.mean(u)) if n else float("nan") for u in used), modes_out,
                               row.thresholds[0] if row.thresholds else None))
    return out, best


# --- the stage --------------------------------------------------------------------------------------------------


def _recorded(path: Path | str, key: str) -> Any:
    from vpr_smr.core.io import read_provenance

    if not Path(path).is_file():
        raise FileNotFoundError(f"{path} not found")
    return read_provenance(path).get(key)


def predictor_length(predictor: Any) -> int:
    """The sequence length a loaded predictor was trained at (``SMRPredictor.load``'s ``seq_len_``); ValueError
    naming its file when it records none."""
    length = getattr(predictor, "seq_len_", None)
    if length is None:
        raise ValueError(f"{getattr(predictor, 'path_', 'the predictor')} records no sequence length: give a "
                         "predictor file written by vpr-smr train")
    return int(length)


def seed_files(first: Path | str, seeds: int | None) -> list[str]:
    """The predictor files of seeds ``0 .. seeds - 1`` beside the seed-0 file ``first`` (``core.paths``'s names);
    ``seeds`` None: the seeds its training wrote (its report's ``seeds``), not whatever files lie beside it.
    ValueError naming a missing file and the fix."""
    from vpr_smr.core.paths import seed_predictor_path

    if seeds is None:
        report = _recorded(first, "report")
        trained = report.get("seeds") if isinstance(report, Mapping) else None
        seeds = len(trained) if isinstance(trained, list | Mapping) and trained else 1
    if seeds < 1:
        raise ValueError(f"--seeds {seeds}: give one or more seeds (seed 0 is the authors' recipe)")
    files = [str(first)] + [seed_predictor_path(first, seed) for seed in range(1, seeds)]
    for path in files[1:]:
        if not Path(path).is_file():
            raise FileNotFoundError(f"{path} not found: {first} needs its seeds 0..{seeds - 1}; train them with "
                                    f"vpr-smr train --seeds {seeds}, or give fewer (--seeds)")
    return files


def _grouped(paths: Sequence[Path | str], split: str) -> dict[int, str]:
    """The attributes files of one split by their recorded sequence length; ValueError for two of one length."""
    out: dict[int, str] = {}
    for path in paths:
        length = _recorded(path, "seq_len")
        if length is None:
            raise ValueError(f"{path} records no sequence length: give an attributes file written by "
                             "vpr-smr attributes")
        if int(length) in out:
            raise ValueError(f"--attributes gives two {split} files of L = {int(length)}: {out[int(length)]} and "
                             f"{path}; give one per length")
        out[int(length)] = str(path)
    return dict(sorted(out.items()))


def live_timing(matrix: Any, lengths: Sequence[int], predictors: Sequence[Any], matcher: Any,
                batch_chosen: np.ndarray, queries: np.ndarray, meta: Mapping[str, Any]) -> AdaptiveTiming:
    """The live matcher fed every column of the table split ``matrix`` (R x Q): ``AdaptiveLiveMatcher`` with the
    seed-0 ``predictors`` of ``lengths``, then a ``LiveMatcher`` of the longest length with its predictor, each
    timed; the adaptive matcher's chosen lengths must be ``batch_chosen`` (rows of ``lengths``, ``adaptive.NONE``
    where none kept) at the shared ``queries``: RuntimeError naming the first query where they are not."""
    from vpr_smr.eval.matching.live import AdaptiveLiveMatcher, LiveMatcher
    from vpr_smr.eval.matching.matcher import read_columns

    n_query = int(matrix.shape[1])
    try:
        adaptive = AdaptiveLiveMatcher(tuple(lengths), list(predictors), matcher=matcher)
        longest = LiveMatcher(lengths[-1], predictor=predictors[-1], matcher=matcher)
    except ValueError as error:
        log.info("no live timing: %s", error)
        return AdaptiveTiming(dict(meta), n_query, 0, None, None, str(error))
    columns = read_columns(matrix, 0, n_query)
    # a first pass over a few frames, untimed: the first calls' costs (imports, caches) are neither matcher's
    warm = columns[: 2 * lengths[-1]]
    for matcher_ in (AdaptiveLiveMatcher(tuple(lengths), list(predictors), matcher=matcher),
                     LiveMatcher(lengths[-1], predictor=predictors[-1], matcher=matcher)):
        for column in warm:
            matcher_.step_distances(column)
    chosen: dict[int, int] = {}
    start = time.perf_counter()
    for column in columns:
        found = adaptive.step_distances(column)
        if found is not None:
            chosen[found.query] = NONE if found.seq_len is None else lengths.index(found.seq_len)
    seconds_adaptive = time.perf_counter() - start
    start = time.perf_counter()
    for column in columns:
        longest.step_distances(column)
    seconds_longest = time.perf_counter() - start
    def named(row: int | None) -> str:
        return "no frame" if row is None else "none" if row == NONE else f"L = {lengths[row]}"

    for query, batch in zip(queries.tolist(), batch_chosen.tolist(), strict=True):
        if chosen.get(query) != batch:
            raise RuntimeError(f"{meta.get('tag')} on {meta.get('method')}: at query {query} the live matcher chose "
                               f"{named(chosen.get(query))}, the batch rule {named(batch)}: please report this")
    return AdaptiveTiming(dict(meta), n_query, len(chosen), seconds_adaptive, seconds_longest)




def main(job: AdaptiveJob) -> AdaptiveResult:
    """The experiment ``adaptive_seq_len`` of one dataset, ``job.method`` and matcher, written to ``job.out`` (JSON,
    ``AdaptiveResult``) and the live timing beside it (``core.paths.timing_path``).

    ``attributes``: per split (the table split, and the validation split for ``adaptive_uniqueness``) one attributes
    file per sequence length (each records its length), all of one matcher and ground truth; ``predictors``: the
    seed-0 predictor file of each length (``vpr-smr train``'s), the other seeds beside each (``seed_files``:
    ``seeds`` of them, or every one found); ``distances``: the table split's distance file, fed to the live matcher
    (None: no timing). Every input is checked before any scoring."""
    from vpr_smr.eval.matching.attributes import check_matching, common_matching, read_features
    from vpr_smr.eval.matching.io import open_distance_matrix
    from vpr_smr.eval.predictor.estimator import SMRPredictor
    from vpr_smr.eval.predictor.leakage import check_disjoint, check_scored, frame_ranges, trained_on
    from vpr_smr.eval.scoring.baselines import check_candidates
    from vpr_smr.eval.scoring.matcher_comparison import shared_queries

    dataset, method, attributes, predictors, seeds = job.dataset, job.method, job.attributes, job.predictors, job.seeds
    table_split, validation_split, distances = job.split, job.validation, job.distances
    settings, modes = job.baselines, job.modes
    matcher_tag, allow_split_overlap = job.matcher_tag, job.allow_split_overlap
    out = check_suffix(job.out, JSON_SUFFIXES,
                       "the adaptive sequence length's result (JSON; its timing goes beside it)")
    if table_split not in attributes:
        raise ValueError(f"no attributes of the table split {table_split!r}: give --attributes {table_split} PATH... "
                         "(one file per sequence length)")
    splits = [table_split] + ([validation_split] if validation_split else [])
    files = {split: _grouped(attributes.get(split, ()), split) for split in splits}
    lengths = list(files[table_split])
    if len(lengths) < 2:
        raise ValueError(f"the adaptive sequence length needs two or more lengths; the {table_split} attributes give "
                         f"{', '.join(f'L = {n}' for n in lengths) or 'none'}: give one file per length")
    for split in splits[1:]:
        if list(files[split]) != lengths:
            raise ValueError(f"the {split} attributes are of the lengths {list(files[split])}, the {table_split} "
                             f"ones of {lengths}: give both splits' files of every length")
    by_length: dict[int, list[str]] = {}
    models: dict[int, list[SMRPredictor]] = {}
    for first in predictors:
        loaded = [SMRPredictor.load(path) for path in seed_files(first, seeds)]
        length = predictor_length(loaded[0])
        if length in by_length:
            raise ValueError(f"two predictors of L = {length}: {by_length[length][0]} and {first}; give one seed-0 "
                             "file per length")
        for model in loaded[1:]:
            if predictor_length(model) != length:
                raise ValueError(f"{model.path_} was trained at L = {predictor_length(model)}, its seed 0 {first} at "
                                 f"L = {length}: train the seeds together (vpr-smr train --seeds N)")
        by_length[length], models[length] = [str(model.path_) for model in loaded], loaded
    if sorted(by_length) != lengths:
        raise ValueError(f"the predictors are of the lengths {sorted(by_length)}, the attributes of {lengths}: give "
                         "one predictor (its seed-0 file) per length")
    counts = {len(found) for found in by_length.values()}
    if len(counts) != 1:
        raise ValueError(f"the lengths' predictors have different numbers of seeds ({sorted(counts)}): give every "
                         "length's seed files (vpr-smr train --seeds N)")
    paths = [path for split in splits for path in files[split].values()]
    matching = common_matching(paths)
    for length in lengths:
        for path, model in zip(by_length[length], models[length], strict=True):
            check_disjoint(trained_on(path), frame_ranges(paths), allow_split_overlap, f"predictor {path}")
            check_matching(model, matching, "the attributes " + ", ".join(paths))
    features: dict[str, dict[int, QueryFeatures]] = {}
    for split in splits:
        features[split] = {}
        for length, path in files[split].items():
            features[split][length] = read_features(path)
            check_candidates(features[split][length], settings, path)
            for model in models[length]:  # no matrix that shares entries with its training ones
                check_scored(model, {path: features[split][length]}, allow_split_overlap)
    frames = {length: matching.matcher.build(length).score_frames for length in lengths}

    def cut(split: str) -> tuple[np.ndarray, list[Length]]:
        queries = shared_queries(list(features[split].values()))
        if not len(queries):
            raise ValueError(f"the lengths {lengths} evaluate no query in common on the {split} split: shorten the "
                             "longest or give a longer split")
        return queries, [Length.of(features[split][n], queries, n, frames[n], models[n], settings) for n in lengths]

    queries, table = cut(table_split)
    validation = cut(validation_split)[1] if validation_split else None
    rows, best = compute(table, validation, modes)
    spec = matching.matcher
    tag = matcher_tag or spec.name
    notes = () if validation_split else (
        "no validation split: adaptive_uniqueness (its threshold is chosen there) is left out",)
    meta = {"dataset": dataset, "method": method, "tag": tag, "matcher": spec.provenance(),
            "split": table_split, "validation_split": validation_split, "modes": list(modes),
            "seeds": len(models[lengths[0]]), **settings.meta(),
            "ground_truth": matching.ground_truth}
    result = AdaptiveResult(meta, tuple(lengths), len(queries), None if validation is None else
                            len(validation[0].distances), tuple(rows), best, notes)
    timing = None
    if distances is not None:
        with open_distance_matrix(distances) as matrix:
            batch = choose(table, ADAPTIVE, 0)[0]
            timing = live_timing(matrix, lengths, [models[n][0] for n in lengths], spec, batch, queries, meta)
    else:
        timing = AdaptiveTiming(dict(meta), 0, 0, None, None, "no distance file given (--distances): not timed")
    save(timing_path(out), timing)
    save(out, result)
    log.info("%s on %s: %d lengths, %d shared queries", tag, method, len(lengths), len(queries))
    return result


def read_timing(result: Path | str) -> AdaptiveTiming | None:
    """The live timing beside a result file (None where there is none)."""
    from vpr_smr.core.records import load

    path = Path(timing_path(result))
    return load(path, AdaptiveTiming) if path.is_file() else None
