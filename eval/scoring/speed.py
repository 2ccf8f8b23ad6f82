"""The ``speed`` experiment (method §11, "Simulated speed profiles"): Table I's numbers when the query traverse is
driven at another speed than the references, with the paper's fixed matcher against SeqSLAM's velocity search.

A profile ``s(t) > 0`` (places advanced per query frame) turns a frame-aligned split ``[lo, hi)`` into a simulated
query: positions ``p_0 = lo``, ``p_{t+1} = p_t + s(t)``, query frame ``t`` is the query traverse's frame
``floor(p_t + 0.5)`` (``simulate``). Its distance matrix is the aligned matrix's columns of those frames (no new
descriptors), and a match ``r`` is correct iff ``|r - (p_t - lo)| <= tolerance`` (split coordinates). A constant
profile ``c`` is a query driven ``c`` times as fast (``0.5x`` .. ``2x``); ``varying`` speeds up and slows down,
``s(t) = 1 + 0.5 sin(2 pi t / 200)``.

The stage (``main``) takes one dataset and one profile. For each matcher (``speed_matchers``: ``fixed``, ``seqslam``
with velocities ``[1.0]``, the paper's; ``velocity``, ``seqslam`` with the experiment's velocity set) it computes the
rank-0 features of every method's simulated train and table split, trains one predictor on the train features of
every method pooled in the configuration's order (the pooled Table I recipe, seed 0) and scores each method's table
split as Table I does (paper mode): recall@1 single and sequence, AOC without and with the predictor and the
reduction.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from vpr_smr.core.constants import DEFAULT_VELOCITIES, N_LABELS
from vpr_smr.core.io import JSON_SUFFIXES, check_suffix, read_provenance
from vpr_smr.core.records import FileRecord, Record, save
from vpr_smr.eval.matching.attributes import QueryFeatures, query_features
from vpr_smr.eval.matching.ground_truth import GroundTruth
from vpr_smr.eval.matching.io import is_user_matrix, open_distance_matrix, stored_positions
from vpr_smr.eval.matching.matchers import MatcherSpec
from vpr_smr.eval.predictor.leakage import FrameRange, check_disjoint, frame_ranges
from vpr_smr.eval.scoring.records import Reduction
from vpr_smr.eval.scoring.study_jobs import (  # the job records, re-exported: they live in a light module
    PROFILE_HELP,
    VARYING,
    VARYING_AMPLITUDE,
    VARYING_PERIOD,
    SpeedExperiment,
    SpeedJob,
    velocities,
)

if TYPE_CHECKING:
    from vpr_smr.eval.predictor.estimator import SMRPredictor

__all__ = [
    "MATCHERS", "MODE", "SEED", "VARYING", "SpeedExperiment", "SpeedJob", "SpeedMatcher", "SpeedProfile", "SpeedResult",
    "SpeedScores", "profile_names", "simulate", "main", "speed_matchers", "velocities",
]

# This module is imported by the workflow (profile_names) each time Snakemake reads the Snakefile: what needs
# scikit-learn (eval.predictor, eval.scoring.evaluate: about 1.5 s to import) is imported inside the functions that
# train and score.

log = logging.getLogger(__name__)

Json = dict[str, Any]

MATCHERS = ("fixed", "velocity")  # the paper's slope-1 matcher, SeqSLAM's velocity search (speed_matchers)
MODE = "paper"  # Table I's numbers, paper mode (method §8)
SEED = 0  # the predictor's seed: the authors' recipe (see main)




def speed_matchers(velocities: Sequence[float]) -> dict[str, MatcherSpec]:
    """The experiment's matchers by their ``MATCHERS`` names: ``fixed``, ``seqslam`` with velocities ``[1.0]`` (the
    paper's), and ``velocity``, ``seqslam`` searching ``velocities`` (ValueError naming ``speed.velocities``)."""
    return {"fixed": MatcherSpec.of("seqslam", {"velocities": list(DEFAULT_VELOCITIES)}),
            "velocity": MatcherSpec.of("seqslam", {"velocities": [float(v) for v in velocities]}, "speed")}


# --- profiles and the simulated query -----------------------------------------------------------------------------


@dataclass(frozen=True)
class SpeedProfile:
    """A speed profile: ``name`` (``0.5x``, ``2x``, ``varying``) and ``speed``, the constant speed (None for
    ``varying``). ``steps(n)`` gives ``s(0) .. s(n-1)``."""

    name: str
    speed: float | None

    @classmethod
    def parse(cls, value: str | float) -> SpeedProfile:
        """A profile from the configuration (a number, or ``"varying"``) or the command line (``"0.5x"``, ``"2"``,
        ``"varying"``); ValueError naming what is wrong otherwise. Constant profiles are named ``f"{c:g}x"``."""
        if isinstance(value, str):
            text = value.strip()
            if text == VARYING:
                return cls(VARYING, None)
            try:
                speed = float(text[:-1] if text.endswith("x") else text)
            except ValueError:
                raise ValueError(f"speed profile {value!r} is not {PROFILE_HELP}") from None
        elif isinstance(value, bool) or not isinstance(value, int | float):
            raise ValueError(f"speed profile {value!r} is not {PROFILE_HELP}")
        else:
            speed = float(value)
        if not (math.isfinite(speed) and speed > 0):
            raise ValueError(f"speed profile {value!r}: a speed must be a finite number > 0 (places per query frame); "
                             f"give {PROFILE_HELP}")
        name = f"{speed:.12g}x"  # the job rebuilds the profile from its name: it must give the same speed back
        if float(name[:-1]) != speed:
            raise ValueError(f"speed profile {value!r}: give it with at most 12 significant digits (it names the "
                             "profile's files and jobs)")
        return cls(name, speed)

    def steps(self, n: int) -> np.ndarray:
        """``s(t)`` for ``t = 0 .. n-1``: places advanced from query frame ``t`` to ``t + 1``."""
        if self.speed is not None:
            return np.full(n, self.speed, dtype=np.float64)
        t = np.arange(n, dtype=np.float64)
        out: np.ndarray = 1.0 + VARYING_AMPLITUDE * np.sin(2 * np.pi * t / VARYING_PERIOD)
        return out


def profile_names(values: Sequence[str | float]) -> list[str]:
    """The profiles' names (the files' names), in the given order; ValueError on a repeat (``1`` and ``1.0x``)."""
    names = [SpeedProfile.parse(value).name for value in values]
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise ValueError(f"speed profiles {list(values)} name {', '.join(repeated)} twice")
    return names


def simulate(profile: SpeedProfile, lo: int, hi: int) -> tuple[np.ndarray, np.ndarray]:
    """The simulated query of the split ``[lo, hi)`` (method §11): ``(frames, positions)``, absolute frame indices of
    the query traverse and positions in places (the references keep ``p = i``).

    ``p_0 = lo`` and ``p_{t+1} = p_t + s(t)``, added in this order in float64; frame ``t`` is ``floor(p_t + 0.5)``.
    The paper does not say where the query stops: here at the last ``t`` whose frame is still inside the split
    (``< hi``), so a query at ``c``x has about ``(hi - lo) / c`` frames, and no frame past the split is read.
    """
    lo, hi = int(lo), int(hi)
    if not 0 <= lo < hi:
        raise ValueError(f"split [{lo}, {hi}) holds no frames: expected 0 <= lo < hi")
    n = hi - lo
    while True:  # the query's length is not known in advance (a varying speed): grow until it leaves the split
        positions = np.add.accumulate(np.concatenate([[float(lo)], profile.steps(n)]))
        frames = np.floor(positions + 0.5).astype(np.int64)
        if frames[-1] >= hi:
            stop = int(np.argmax(frames >= hi))  # positions increase (s > 0): every later frame is outside too
            return frames[:stop], positions[:stop]
        n *= 2


def simulated_split(matrix: Any, lo: int, frames: np.ndarray, positions: np.ndarray, tolerance: int
                    ) -> tuple[np.ndarray, GroundTruth]:
    """The simulated query's distance matrix (the aligned split matrix's columns ``frames - lo``) and its ground
    truth: references at ``0 .. R-1``, queries at ``positions - lo``, within ``tolerance`` (split coordinates)."""
    columns = np.asarray(frames, dtype=np.int64) - lo
    first, last = int(columns.min()), int(columns.max())
    # one read of the columns' range (an HDF5 dataset takes no repeated indices), then the simulated order
    block = np.asarray(matrix[:, first : last + 1])
    simulated = np.ascontiguousarray(block[:, columns - first])
    truth = GroundTruth.positions(np.arange(matrix.shape[0], dtype=np.float64), np.asarray(positions) - lo,
                                  float(tolerance))
    return simulated, truth


# --- the record ---------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SpeedScores(Record):
    """One method's table split under one matcher and its predictor: Table I's numbers (paper mode, seed 0):
    recall@1, the reduction as an evaluation records it (its ``outcome`` says what the removal did: a degenerate
    predictor is named, not hidden), macro F1 and the matches removed."""

    n_queries: int  # simulated queries with a sequence match: every sequence number is over them
    n_queries_single: int  # every simulated query of the split: paper mode's single-frame recall@1 (method §8)
    recall_at_1_single: float
    recall_at_1_sequence: float
    reduction: Reduction
    f1_macro: float
    removed: int


@dataclass(frozen=True)
class SpeedMatcher(Record):
    """One matcher: its velocities, its predictor's training samples (every method's simulated train split) and
    each method's scores, in the configuration's order."""

    velocities: tuple[float, ...]
    n_train: int
    train_class_counts: tuple[int, ...]
    methods: dict[str, SpeedScores]


@dataclass(frozen=True)
class SpeedResult(FileRecord):
    """One dataset under one speed profile (``main``): per matcher (``MATCHERS``), every method's scores.

    ``meta``: dataset, seq_len, profile, tolerance, mode, seed, the train and table splits (name, lo, hi).
    ``speed``: the constant speed (None for ``varying``); ``mean_speed``: the simulated table query's mean step
    ``(p_last - p_0) / (n - 1)``, where the report places a varying profile; ``n_train_queries`` and
    ``n_table_queries``: the simulated queries of each split (one method's).
    """

    meta: Json
    speed: float | None
    mean_speed: float
    n_train_queries: int
    n_table_queries: int
    matchers: dict[str, SpeedMatcher]

    @property
    def profile(self) -> str:
        return str(self.meta["profile"])


# --- the stage ----------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Split:
    """A distance file's split: its name and frames ``[lo, hi)`` (from its provenance, else ``[0, n)``)."""

    name: str
    lo: int
    hi: int


def _split_of(path: Path, shape: tuple[int, ...]) -> _Split:
    if shape[0] != shape[1]:
        raise ValueError(f"{path}: a {shape[0]}x{shape[1]} matrix; the speed experiment simulates from a "
                         "frame-aligned split, whose matrix is square (the split's frames of both traverses)")
    provenance = read_provenance(path) if not is_user_matrix(path) else {}
    if "reference_range" in provenance or stored_positions(path) is not None:
        raise ValueError(f"{path}: a split of a dataset with positions (method §11); the speed experiment simulates "
                         "from a frame-aligned split (the same frames of both traverses, no positions)")
    lo, hi = provenance.get("split_range", (0, shape[0]))
    if int(hi) - int(lo) != shape[0]:
        raise ValueError(f"{path}: split_range [{lo}, {hi}) but {shape[0]} frames in the matrix")
    return _Split(str(provenance.get("split", path.stem)), int(lo), int(hi))


def _method_features(path: Path, profile: SpeedProfile, seq_len: int, tolerance: int,
                     matchers: Mapping[str, MatcherSpec], seconds: dict[str, float]
                     ) -> tuple[_Split, np.ndarray, dict[str, QueryFeatures]]:
    """The features of one distance file's simulated split under each matcher (the time each took added to
    ``seconds``), with its split and the simulated positions."""
    with open_distance_matrix(path) as matrix:
        split = _split_of(path, tuple(matrix.shape))
        frames, positions = simulate(profile, split.lo, split.hi)
        if len(frames) < seq_len:
            raise ValueError(f"{path}: the {profile.name} query of split [{split.lo}, {split.hi}) has "
                             f"{len(frames)} frames, fewer than the sequence length {seq_len}")
        simulated, truth = simulated_split(matrix, split.lo, frames, positions, tolerance)
    out = {}
    for name, matcher in matchers.items():
        start = time.perf_counter()
        try:
            # rank 0 only: the predictor and Table I use it (ranks 1..3 serve restoration, not run here)
            out[name] = query_features(simulated, seq_len, tolerance, n_ranks=1, matcher=matcher, ground_truth=truth)
        except ValueError as error:
            raise ValueError(f"{path}, {profile.name} query, {name} matcher: {error}") from None
        seconds[name] += time.perf_counter() - start
    return split, positions, out


def fit_pooled(train: Sequence[QueryFeatures], params: dict[str, Any] | None, where: str,
               seed: int = SEED) -> SMRPredictor:
    """The pooled predictor of Table I fitted on ``train`` (every method's features, the configuration's order):
    ``train.rank0`` pools them and ``train.seeded_training`` gives seed ``seed`` of the recipe, as
    ``vpr-smr train`` fits it. The cross-validation that ``train.train_seed`` runs beside it changes nothing
    fitted and is left out."""
    from vpr_smr.eval.predictor.estimator import TrainingDataError
    from vpr_smr.eval.predictor.train import check_trainable, predictor_params, rank0, seeded_training

    settings = predictor_params(params)
    x, y = rank0(train)
    try:
        check_trainable(y, settings, [seed], where)
    except TrainingDataError as error:  # a fast profile shortens the train split: say how to leave it out
        raise TrainingDataError(f"{error}; or leave the fastest speed profiles out (speed.profiles), or switch the "
                                "experiment off (experiments.speed: false)") from None
    predictor, x, y = seeded_training(x, y, settings, seed)
    fitted: SMRPredictor = predictor.fit(x, y)
    return fitted


def score(features: QueryFeatures, predictor: SMRPredictor) -> SpeedScores:
    """Table I's numbers of one method's features, as ``evaluate.evaluate_split`` computes them (``removal`` of
    the seed-0 predictor's rank-0 probabilities, paper mode)."""
    from vpr_smr.eval.scoring.evaluate import removal

    probabilities = predictor.predict_proba(features.attributes[:, 0, :])
    result = removal(features, probabilities, predictor.classes_, (MODE,), curves=False)
    numbers = result.modes[MODE]
    return SpeedScores(
        n_queries=len(features.queries), n_queries_single=len(features.all_single_correct),
        recall_at_1_single=numbers.recall_at_1_single, recall_at_1_sequence=numbers.recall_at_1_sequence,
        reduction=numbers.reduction, f1_macro=result.f1_macro, removed=result.removed)


def _frame_ranges(paths: Iterable[Path | str]) -> list[FrameRange]:
    """The splits the distance files cover (``leakage.frame_ranges``); a user's ``.npy`` says nothing of its frames."""
    return frame_ranges([path for path in paths if not is_user_matrix(path)])


def _check_methods(train: Mapping[str, Path | str], test: Mapping[str, Path | str]) -> list[str]:
    if not train:
        raise ValueError("the speed experiment needs every method's train and table distance files (METHOD=PATH)")
    if list(train) != list(test):
        raise ValueError(f"the train files are of methods {list(train)} but the table files of {list(test)}: give "
                         "both for the same methods, in the same (the configuration's) order")
    return list(train)


def main(job: SpeedJob) -> SpeedResult:
    """The speed experiment of one dataset under one profile, written to ``job.out`` (JSON, ``SpeedResult``).

    ``train`` and ``table``: per method (the configuration's order, the pooled training order of method §7) its train
    and table split's distance file (square, frame-aligned; the file's ``split_range`` gives ``lo``).
    ``velocities``: the velocity matcher's search set (``speed_matchers``); the fixed matcher is ``(1.0,)``.
    ``predictor``: the predictor's settings. The meta records both matchers (``MatcherSpec.provenance``).

    One predictor seed (0, the authors' recipe) per matcher, not the run's seeds: the experiment trains two
    predictors per profile and dataset, and the demo's time budget holds that; the spread over seeds is Table I's
    job, this experiment compares matchers and speeds under one recipe.
    """
    dataset, seq_len, tolerance, train, test = job.dataset, job.seq_len, job.tolerance, job.train, job.table
    params = job.predictor.values
    out = check_suffix(job.out, JSON_SUFFIXES, "the speed experiment's result (JSON)")
    profile = SpeedProfile.parse(job.profile)
    matchers = speed_matchers(job.velocities)
    methods = _check_methods(train, test)
    check_disjoint(_frame_ranges(train.values()), _frame_ranges(test.values()), job.allow_split_overlap,
                   "the speed experiment's predictor")
    begin = time.perf_counter()
    seconds = dict.fromkeys(matchers, 0.0)
    features: dict[str, dict[str, list[QueryFeatures]]] = {name: {"train": [], "test": []} for name in matchers}
    splits: dict[str, set[_Split]] = {"train": set(), "test": set()}
    table_positions = np.zeros(0)
    n_queries: dict[str, int] = {}  # simulated queries per split (one method's: every method's are the same)
    for method in methods:
        for role, path in (("train", train[method]), ("test", test[method])):
            split, positions, by_matcher = _method_features(Path(path), profile, seq_len, tolerance, matchers,
                                                            seconds)
            splits[role].add(split)
            n_queries[role] = len(positions)
            if role == "test":
                table_positions = positions
            for name, found in by_matcher.items():
                features[name][role].append(found)
    for role, covered in splits.items():
        if len(covered) != 1:
            raise ValueError(f"the methods' {role} files cover different splits: "
                             f"{', '.join(f'{s.name} [{s.lo}, {s.hi})' for s in covered)}; give one split's files")
    train_split, table_split = splits["train"].pop(), splits["test"].pop()

    results = {}
    for name, matcher in matchers.items():
        start = time.perf_counter()
        where = (f"dataset {dataset!r}, sequence length {seq_len}, {profile.name} query, {name} matcher: train "
                 f"split of {len(methods)} method(s) pooled")
        predictor = fit_pooled(features[name]["train"], params, where)
        labels = np.concatenate([f.labels for f in features[name]["train"]])
        scores = {method: score(found, predictor)
                  for method, found in zip(methods, features[name]["test"], strict=True)}
        class_counts = tuple(np.bincount(labels, minlength=N_LABELS).tolist())
        searched = tuple(float(v) for v in matcher.values["velocities"])
        results[name] = SpeedMatcher(searched, int(len(labels)), class_counts, scores)
        seconds[name] += time.perf_counter() - start
        log.info("%s matcher (%s): %.1f s (attributes, training, scoring)", name, matcher, seconds[name])
    meta = {"dataset": dataset, "seq_len": int(seq_len), "profile": profile.name, "tolerance": int(tolerance),
            "mode": MODE, "seed": SEED, "train_split": [train_split.name, train_split.lo, train_split.hi],
            "table_split": [table_split.name, table_split.lo, table_split.hi],
            "matchers": {name: matcher.provenance() for name, matcher in matchers.items()}}
    mean_speed = float((table_positions[-1] - table_positions[0]) / max(len(table_positions) - 1, 1))
    result = SpeedResult(meta, profile.speed, mean_speed, n_queries["train"], n_queries["test"], results)
    save(out, result)  # the timings stay in the log: two runs give identical files
    log.info("profile %s: %.1f s in all", profile.name, time.perf_counter() - begin)
    return result
