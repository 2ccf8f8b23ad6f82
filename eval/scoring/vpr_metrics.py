"""The standard VPR metrics of a distance matrix per split (``vpr-smr metrics``), per mode and matcher, and the
scoring that the per-query table (``metrics --queries``; the ``queries`` stage, ``eval.scoring.queries_stage``)
and the training-free baselines (the ``baselines`` stage, ``eval.scoring.baselines_stage``: method §12's scorers,
at the budget of every predictor seed) share with it. ``metrics`` and ``queries`` compute the scorers too (their
detection of wrong matches, with a predictor their removal at its budget; their confidences in the per-query
table).

One split's ``R x Q`` matrix ``D``: a match ``r`` of query ``q`` is correct iff ``|r - q| <= tolerance`` for a
frame-aligned pair, iff its position is within the radius of the query's with positions (method §11), iff
``G[r, q]`` for a ground-truth file (a boolean matrix or per-query lists): one ``GroundTruth``. A query without any
correct reference is never correct and counts in every denominator; each split records how many there are.
Rankings are stable (equal distances: the lower reference or diagonal index first). With velocity search (method
§11) the sequence candidates are the end references ``r_min .. R-1`` of ``S[r, a] = min_v S_v[r, a]``.
Evaluated queries: ``a = L-1 .. Q-1``, those with a sequence match (method §4). One item per metric, its denominator
last:

- single recall@N: queries whose N nearest references (``D[:, q]`` ascending) hold a correct one / all Q queries
  of the split in paper mode (the authors' rule, method §8), the evaluated queries in standard mode.
- sequence recall@N: evaluated queries ``a`` whose first N candidates hold a correct reference / the evaluated
  queries. The candidates (method §14): the matcher's match ``r*_a`` first, then the other references by the
  matcher's score ``s_a`` ascending (``seqslam``: the diagonals ``S[i, j] = sum_k D[i+k, j+k]``, ``j = a-L+1``, as
  end references ``i + L - 1``, whose lowest is the match; a filter's match need not be its lowest score).
- sequence_predictor recall@N: as sequence, a query whose match the seed-0 predictor removes (rank-0 predicted
  class not in KEPT_CLASSES, trust level 0) counting as not retrieved / the evaluated queries.
- recall_at_100p: the highest recall of a point of precision 1 on the mode's PR curve / the curve's recall
  denominator (method §8: paper the curve's queries whose match is correct, standard all the curve's queries).
- pr_auc: the trapezoid area under the mode's whole PR curve (``curves.area``; not cut to a maximum recall).
- extended_precision: ``(P_R0 + recall_at_100p) / 2`` (VPR-Bench), ``P_R0`` the precision at the strictest
  threshold that accepts a match: the share correct of the curve's kept matches at the smallest distance (ties
  together; 0 when none is kept), as VPR-Bench's ``precision[-2]`` of scikit-learn's curve.

The PR curves (``curves.curve``): the sequence matchers' as ``evaluate`` builds them (``sequence_distance``,
``sequence_correct``, the split's ``S`` range; with the predictor its keep mask), over the evaluated queries; the
single matcher's from ``D[single_match, q]`` and its correctness over the same queries as its recall (paper all Q,
standard the evaluated ones), thresholds over ``(D.min(), D.max())`` of the split.

The matrix is read in blocks of query columns: ``S`` exists a block at a time, never whole. Recall@N uses, per
query, the stable rank (0 = best) of its best-ranked correct candidate, ``#{values < v} + #{values == v before
it}``: exact with ties, a hit at N iff below N.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from contextlib import ExitStack
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any, TypedDict, Unpack

import h5py
import numpy as np

from vpr_smr.core.arrays import ARRAY_SUFFIXES
from vpr_smr.core.constants import MODES, RECALL_AT
from vpr_smr.core.io import (
    CSV_SUFFIXES,
    HDF5_SUFFIXES,
    JSON_SUFFIXES,
    atomic_path,
    check_suffix,
    read_provenance,
    write_json,
)
from vpr_smr.eval.matching.attributes import (
    Matching,
    QueryFeatures,
    built_matcher,
    check_length,
    check_matcher,
    check_matching,
    check_seq_len,
    matcher_provenance,
    query_features,
    read_features,
)
from vpr_smr.eval.matching.checks import check_size, stage_check, warn_if_tied
from vpr_smr.eval.matching.features import match_blocks
from vpr_smr.eval.matching.ground_truth import FRAMES, MATRIX, POSITIONS, GroundTruth
from vpr_smr.eval.matching.ground_truth_files import read_ground_truth
from vpr_smr.eval.matching.io import (
    is_user_matrix,
    open_distance_matrix,
    reading_provenance,
    scored_shape,
    split_ground_truth,
    warn_if_similar,
)
from vpr_smr.eval.matching.matcher import as_matrix, read_columns
from vpr_smr.eval.matching.matchers import MatcherSpec
from vpr_smr.eval.matching.matchers.base import Matcher
from vpr_smr.eval.matching.sources import MatrixFormat, TruthSource
from vpr_smr.eval.predictor.estimator import SMRPredictor
from vpr_smr.eval.predictor.leakage import (
    check_disjoint,
    check_matrices,
    frame_range,
    frame_ranges,
    has_frames,
    matrix_overlaps,
)
from vpr_smr.eval.scoring import baselines as scorers
from vpr_smr.eval.scoring.baselines import (
    BaselineSettings,
    check_candidates,
    split_baselines,
    spread_positions,
)
from vpr_smr.eval.scoring.curves import Curve, area, curve, earned, keep_mask, recall_at_full_precision
from vpr_smr.eval.scoring.matrix_jobs import ALL_SPLIT, MetricsJob, QueriesJob, distance_splits
from vpr_smr.eval.scoring.queries import Prediction, SplitQueries, write_queries
from vpr_smr.eval.scoring.records import Interval, MatcherMetrics, Reduction, SplitMetrics, VPRMetrics
from vpr_smr.eval.scoring.sweep import protocol_sweep, within

__all__ = [
    "ALL_SPLIT", "MetricsJob", "Retrieval", "ScoredSplit", "check_inputs", "extended_precision", "format_baselines",
    "format_metrics", "load_predictor", "main", "matcher_metrics", "precision_at_strictest", "recall_at",
    "retrieval", "score", "score_all", "score_split", "SplitInputs", "SplitSettings", "truth_kind",
]

log = logging.getLogger("vpr_smr")

NOT_RETRIEVED = np.iinfo(np.int64).max  # the rank of a query without any correct candidate
DISTANCE_SUFFIXES = (*ARRAY_SUFFIXES, *HDF5_SUFFIXES)


def truth_kind(truth: TruthSource) -> str:
    """The kind of ground truth ``truth`` gives (``GroundTruth.kind``): a file, else positions within a radius, else
    frames within the tolerance (method §11)."""
    return MATRIX if truth.ground_truth is not None else FRAMES if truth.radius is None else POSITIONS


@dataclass(frozen=True)
class Retrieval:
    """What recall@N and the single-frame curve need of one split, from the matrix itself.

    ``single_rank[q]``: the stable rank of query ``q``'s best-ranked correct reference in ``D[:, q]`` (every query,
    the first ``L-1`` too); ``sequence_rank[n]``: that of the best-ranked correct reference of query
    ``a = queries[n]``, the matcher's match ranked first and the others by its scores ``s_a`` (``seqslam``: the
    best-ranked correct diagonal in ``S[:, n]``, query ``a = n + L - 1``), a reference of score ``+inf`` other than
    the match never ranked; ``NOT_RETRIEVED`` when no candidate is correct.
    """

    single_rank: np.ndarray  # (Q,)
    single_match: np.ndarray  # (Q,) argmin_r D[r, q], first index on ties
    single_distance: np.ndarray  # (Q,) D[single_match, q]
    sequence_rank: np.ndarray  # (N,)
    sequence_match: np.ndarray  # (N,) r*_a (seqslam: argmin_i S[i, j] + L - 1)
    sequence_distance: np.ndarray  # (N,) s_a[r*_a] (seqslam: min_i S[i, j])
    distance_min: float  # D.min() of the split
    distance_max: float  # D.max() of the split
    queries: np.ndarray  # (N,) the evaluated queries a >= L - 1 (seqslam: L-1 .. Q-1)


def _best_correct_rank(values: np.ndarray, correct: np.ndarray, first: np.ndarray | None = None) -> np.ndarray:
    """Per column of ``values`` (candidates x queries), the stable rank of its best-ranked correct candidate (the
    lowest (value, row) among the rows ``correct`` marks); ``NOT_RETRIEVED`` where no candidate is correct. A row of
    value ``+inf`` (a reference no path of the matcher reaches) is no candidate. ``first``: per column, the
    matcher's match, ranked first whatever its value (method §14: a filter's match need not be its lowest score),
    the other rows after it by value."""
    reached = correct & np.isfinite(values)
    if first is not None:
        cols = np.arange(values.shape[1])
        reached[first, cols] = correct[first, cols]  # the match is the matcher's answer, whatever its score
        values = values.copy()
        values[first, cols] = -np.inf  # below every score: rank 0, every other row one further down
    correct = reached
    n_rows, n_cols = values.shape
    best = np.argmin(np.where(correct, values, np.inf), axis=0)  # first row on ties: the best-ranked of them
    cols = np.arange(n_cols)
    value = values[best, cols]
    rank = (np.count_nonzero(values < value, axis=0)
            + np.count_nonzero((values == value) & (np.arange(n_rows)[:, None] < best), axis=0))
    return np.where(correct.any(axis=0), rank, NOT_RETRIEVED).astype(np.int64)



def retrieval(distance_matrix: Any, seq_len: int, tolerance: int, block_queries: int | None = None,
              matcher: MatcherSpec | Matcher | None = None, ground_truth: GroundTruth | None = None
              ) -> Retrieval:
    """Rankings of single-frame and sequence matching of one split's ``R x Q`` matrix (any 2-D array-like that
    slices by columns: ``np.ndarray``, memmap, ``h5py.Dataset``), read by the matcher's blocks of query columns
    (``features.match_blocks``). ``matcher`` and ``ground_truth`` as ``query_features`` takes them (default: the
    fixed matcher and frames within ``tolerance``)."""
    matrix = as_matrix(distance_matrix)
    built = built_matcher(matcher, seq_len)
    built.check(tuple(matrix.shape))
    if tolerance < 0:
        raise ValueError(f"the tolerance is a number of frames >= 0, got {tolerance}")
    n_ref, n_query = (int(n) for n in matrix.shape)
    truth = GroundTruth.aligned(n_ref, n_query, tolerance) if ground_truth is None else ground_truth
    truth.check_shape((n_ref, n_query))
    references = np.arange(n_ref)[:, None]

    def single(start: int, own: np.ndarray) -> dict[str, Any]:
        """The single-frame numbers of the query columns ``own`` (as rows), the first of them column ``start``."""
        own = own.astype(np.float64, copy=False).T
        queries = np.arange(start, start + own.shape[1])
        match = np.argmin(own, axis=0)
        return {"single_rank": _best_correct_rank(own, truth.correct(references, queries)), "single_match": match,
                "single_distance": own[match, np.arange(len(queries))], "range": (float(own.min()), float(own.max()))}

    singles, sequences = [], []
    seen = 0  # the query columns whose single-frame numbers are done: blocks of a window overlap
    for found, lo, columns in match_blocks(built, matrix, block_queries):
        if lo + len(columns) > seen:
            singles.append(single(seen, columns[seen - lo :]))
            seen = lo + len(columns)
        s = found.scores.T  # (references, queries)
        rows = np.arange(len(found.queries))
        sequences.append({"queries": found.queries, "sequence_match": found.match,
                          "sequence_rank": _best_correct_rank(s, truth.correct(references, found.queries),
                                                              found.match),
                          "sequence_distance": s[found.match, rows]})
    if seen < n_query:  # columns after the last evaluated query's window (none for a trailing window)
        singles.append(single(seen, read_columns(matrix, seen, n_query)))
    joined = {key: np.concatenate([p[key] for p in (*singles, *sequences) if key in p])
              for key in ("single_rank", "single_match", "single_distance", "queries", "sequence_match",
                          "sequence_rank", "sequence_distance")}
    windowed = joined["queries"] >= seq_len - 1  # those with attributes (QueryFeatures' queries)
    return Retrieval(joined["single_rank"], joined["single_match"], joined["single_distance"],
                     joined["sequence_rank"][windowed], joined["sequence_match"][windowed].astype(np.int64),
                     joined["sequence_distance"][windowed], min(p["range"][0] for p in singles),
                     max(p["range"][1] for p in singles), joined["queries"][windowed].astype(np.int64))


def recall_at(ranks: np.ndarray, ns: Sequence[int] = RECALL_AT, retrieved: np.ndarray | None = None
              ) -> dict[int, float]:
    """Recall@N for each N: the share of queries whose best-ranked correct candidate ranks below N (and, with
    ``retrieved``, whose match was not removed); the denominator is ``len(ranks)``."""
    ranks = np.asarray(ranks)
    hits = ranks[:, None] < np.asarray(ns, dtype=np.int64)[None, :]
    if retrieved is not None:
        hits &= np.asarray(retrieved, dtype=bool)[:, None]
    return {int(n): float(hits[:, i].mean()) for i, n in enumerate(ns)}


def precision_at_strictest(distances: np.ndarray, correct: np.ndarray, keep: np.ndarray) -> float:
    """``P_R0``: the precision at the strictest threshold that accepts a match, the share correct of the kept
    matches at the smallest distance (all of them when tied); 0 when none is kept. VPR-Bench's ``precision[-2]`` of
    scikit-learn's curve: a wrong most-confident match gives 0, whatever follows (not the precision at the first
    non-zero recall)."""
    kept = np.asarray(distances, dtype=np.float64)[keep]
    if len(kept) == 0:
        return 0.0
    best = kept == kept.min()
    return float(np.asarray(correct, dtype=bool)[keep][best].mean())


def extended_precision(p_r0: float, curve_: Curve) -> float:
    """VPR-Bench's extended precision ``(P_R0 + R_P100) / 2`` (``P_R0``: ``precision_at_strictest``)."""
    return (p_r0 + recall_at_full_precision(curve_)) / 2


def matcher_metrics(ranks: np.ndarray, mode: str, distances: np.ndarray, correct: np.ndarray, keep: np.ndarray,
                    distance_range: tuple[float, float], retrieved: np.ndarray | None = None) -> MatcherMetrics:
    """One matcher in one mode: recall@N over ``ranks``' queries and the numbers of its PR curve (``curves.curve``
    of ``distances``, ``correct``, ``keep`` and the split's ``distance_range``)."""
    curve_ = curve(mode, distances, correct, keep, *distance_range)
    return MatcherMetrics(len(ranks), recall_at(ranks, RECALL_AT, retrieved), recall_at_full_precision(curve_),
                          area(curve_), extended_precision(precision_at_strictest(distances, correct, keep), curve_))


def _mode_metrics(mode: str, found: Retrieval, features: QueryFeatures, seq_len: int, ground_truth: GroundTruth,
                  prediction: Prediction | None) -> dict[str, MatcherMetrics]:
    n_query = len(found.single_rank)
    # paper mode: every query of the split (the authors' rule, method §8); standard: the evaluated ones
    single = np.arange(n_query) if mode == "paper" else found.queries
    single_correct = ground_truth.correct(found.single_match[single], single)
    single_keep = keep_mask(n=len(single_correct))
    n = len(features.queries)
    s_range = (features.sequence_min, features.sequence_max)
    out = {
        "single": matcher_metrics(found.single_rank[single], mode, found.single_distance[single], single_correct,
                                  single_keep, (found.distance_min, found.distance_max)),
        "sequence": matcher_metrics(found.sequence_rank, mode, features.sequence_distance, features.sequence_correct,
                                    keep_mask(n=n), s_range),
    }
    if prediction is not None:
        kept = prediction.kept
        out["sequence_predictor"] = matcher_metrics(found.sequence_rank, mode, features.sequence_distance,
                                                    features.sequence_correct, kept, s_range, kept)
    return out


def _check_agree(found: Retrieval, features: QueryFeatures, seq_len: int, where: str) -> None:
    """The features (read from an attributes file) belong to this matrix: same queries and matches."""
    same = (np.array_equal(features.queries, found.queries)
            and np.array_equal(features.single_match, found.single_match[found.queries])
            and np.array_equal(features.sequence_match, found.sequence_match)
            and np.allclose(features.sequence_distance, found.sequence_distance, rtol=1e-12, atol=0))
    if not same:
        raise ValueError(f"{where}: the attributes do not belong to this distance matrix (their queries, matches or "
                         "sequence distances differ); recompute them from it (vpr-smr attributes) or leave "
                         "--attributes out")


@dataclass(frozen=True)
class ScoredSplit:
    """One split's metrics and what its rows of the queries table need."""

    metrics: SplitMetrics
    queries: SplitQueries


@dataclass(frozen=True)
class SplitSettings:
    """What every split of a job is scored with (``score``): the sequence length; the tolerance in frames (of the
    aligned ground truth, where a split gives none); the metric modes; the matcher (None: ``MatcherSpec.of()``);
    ``sweep``: also recall@1 and the predictor's reduction over the tolerances or radii of ``sweep.protocol_sweep``
    (a ground truth of frames or positions only); ``baselines``: also the training-free scorers of method §12 with
    these settings (their detection of wrong matches, and with a predictor their removal at its budget;
    ``SplitMetrics.baselines``) and their confidences in the per-query table (None: left out); the queries
    retrieved per block (None: ``retrieval``'s)."""

    seq_len: int
    tolerance: int
    modes: tuple[str, ...] = MODES
    matcher: MatcherSpec | None = None
    sweep: bool = False
    baselines: BaselineSettings | None = None
    block_queries: int | None = None


@dataclass(frozen=True)
class SplitInputs:
    """One split's inputs beside its matrix (``score``): its attributes (``query_features`` of the same matrix;
    None: computed from it; read from a file they must hold the candidates ``SplitSettings.baselines`` needs), its
    ground truth (None: the aligned band of the tolerance), its name and the first query and reference frames of its
    matrix (the per-query table's frame numbers)."""

    features: QueryFeatures | None = None
    ground_truth: GroundTruth | None = None
    split: str = ALL_SPLIT
    first_frame: int = 0
    reference_first_frame: int | None = None


class SplitOptions(TypedDict, total=False):
    """``score_split``'s keywords: the fields of ``SplitSettings`` and ``SplitInputs`` it does not take by place."""

    features: QueryFeatures | None
    ground_truth: GroundTruth | None
    split: str
    first_frame: int
    reference_first_frame: int | None
    matcher: MatcherSpec | None
    sweep: bool
    baselines: BaselineSettings | None
    block_queries: int | None


def score_split(distance_matrix: Any, seq_len: int, tolerance: int, predictor: Any | None = None,
                modes: Sequence[str] = MODES, **options: Unpack[SplitOptions]) -> ScoredSplit:
    """``score`` with its settings and inputs by name (the Python API's form): ``score_split(D, 4, 2, predictor,
    matcher=spec, ground_truth=truth)``."""
    names = {field.name for field in fields(SplitSettings)}
    # each value typed by SplitOptions; a name of neither record is the records' TypeError
    settings: dict[str, Any] = {name: value for name, value in options.items() if name in names}
    inputs: dict[str, Any] = {name: value for name, value in options.items() if name not in names}
    return score(distance_matrix, SplitSettings(seq_len, tolerance, tuple(modes), **settings), SplitInputs(**inputs),
                 predictor)


def score(distance_matrix: Any, settings: SplitSettings, inputs: SplitInputs = SplitInputs(),
          predictor: Any | None = None) -> ScoredSplit:
    """The metrics of one split's matrix per mode and matcher (``sequence_predictor`` only with ``predictor``: an
    object with ``predict_proba`` and ``classes_``, e.g. ``SMRPredictor``), and the rows of its per-query table."""
    seq_len, tolerance, modes, baselines = settings.seq_len, settings.tolerance, settings.modes, settings.baselines
    features, split = inputs.features, inputs.split
    unknown = [mode for mode in modes if mode not in MODES]
    if unknown:
        raise ValueError(f"unknown metric modes {unknown}; choose from {', '.join(MODES)}")
    shape = tuple(int(n) for n in distance_matrix.shape)
    truth = (GroundTruth.aligned(shape[0], shape[1], tolerance) if inputs.ground_truth is None
             else inputs.ground_truth)
    matcher = settings.matcher or MatcherSpec.of()
    built = matcher.build(seq_len)
    found = retrieval(distance_matrix, seq_len, tolerance, settings.block_queries, built, truth)
    if features is None:
        features = query_features(distance_matrix, seq_len, tolerance, matcher=built, ground_truth=truth,
                                  n_candidates=baselines.candidates if baselines is not None else 0)
    _check_agree(found, features, seq_len, f"split {split!r}")
    prediction = Prediction.of(predictor, features) if predictor is not None else None
    without = truth.without_correct()
    swept = protocol_sweep(features, found.single_match, truth, modes,
                           prediction.kept if prediction is not None else None) if settings.sweep else None
    found_baselines, scores = None, None
    if baselines is not None:
        check_candidates(features, baselines, "the attributes")
        positions = spread_positions(truth)
        scored = [] if prediction is None or prediction.probabilities is None or prediction.classes is None else [
            scorers.Prediction(0, prediction.probabilities, prediction.classes)]
        found_baselines = split_baselines(features, baselines, positions, scored, modes)
        scores = scorers.query_scores(features, baselines, positions, 0, scored[0] if scored else None)
    metrics = SplitMetrics({mode: _mode_metrics(mode, found, features, seq_len, truth, prediction)
                            for mode in modes}, int(without.sum()), int(without[features.queries].sum()), swept,
                           found_baselines)
    true_reference = None if truth.is_aligned_band() else truth.true_references(features.queries)
    queries = SplitQueries(split, inputs.first_frame, features, found.single_distance[features.queries], prediction,
                           inputs.reference_first_frame, true_reference, matcher, scores)
    return ScoredSplit(metrics, queries)


# --- the `metrics` stage ----------------------------------------------------------------------------------------


def _ours(path: Path | str) -> bool:
    """An HDF5 file of vpr-smr (a MATLAB v7.3 ``.mat`` is HDF5 too, and a user's)."""
    return not is_user_matrix(path) and h5py.is_hdf5(path)


def _first_frame(*paths: Path | str | None) -> int:
    """The split's first frame in the dataset: the frame range of the first HDF5 file of ``paths`` that records
    one (attributes, then distances), else 0 (a user's matrix)."""
    for path in paths:
        if path is not None and _ours(path):
            found = frame_range(path)
            if found is not None:
                return found.lo
    return 0


def _reference_first_frame(*paths: Path | str | None) -> int | None:
    """The split's first reference frame when its reference range differs from its query range (the distances
    stage records ``reference_range`` then, method §11), else None."""
    for path in paths:
        if path is not None and h5py.is_hdf5(path):
            stored = read_provenance(path).get("reference_range")
            if stored is not None:
                return int(stored[0])
    return None


def check_inputs(distances: Mapping[str, Path], attributes: Mapping[str, Path], seq_len: int, truth: TruthSource,
                 matcher: MatcherSpec, file_truth: GroundTruth | None = None) -> None:
    """Check every matrix and attributes file before any work: their suffixes, that they exist, that the attributes
    name only these splits and were computed at ``seq_len`` with this ground truth (``truth``; ``file_truth``, a
    ground-truth file read) and ``matcher``."""
    if truth.reference_positions is not None and len(distances) > 1:
        raise ValueError("--reference-positions and --query-positions give the positions of one matrix: give one "
                         "--distances file with them (the distance files of a dataset with positions hold their own)")
    for split, path in distances.items():
        check_suffix(path, DISTANCE_SUFFIXES, f"split {split!r}'s distance matrix (.npy, .npz, .mat or HDF5)",
                     "--distances")
        if not path.is_file():
            raise FileNotFoundError(f"distance matrix of split {split!r} not found: {path} (run vpr-smr distances, "
                                    "or give a references x queries .npy, .npz or .mat)")
    extra = sorted(set(attributes) - set(distances))
    if extra:
        raise ValueError(f"--attributes names splits {extra} that --distances does not give; splits: "
                         f"{', '.join(distances)}")
    tolerance = truth.tolerance
    for split, path in attributes.items():
        check_suffix(path, HDF5_SUFFIXES, f"split {split!r}'s attributes (HDF5)", "--attributes")
        if not path.is_file():
            raise FileNotFoundError(f"attributes of split {split!r} not found: {path} (run vpr-smr attributes, "
                                    "or leave --attributes out to compute them)")
        stored = read_provenance(path).get("tolerance")
        # with positions or a ground-truth file, the tolerance plays no part (check_matcher compares them)
        if truth_kind(truth) == FRAMES and stored is not None and int(stored) != int(tolerance):
            raise ValueError(f"{path} holds attributes at tolerance {int(stored)}, but --tolerance is {tolerance}: "
                             f"give --tolerance {int(stored)}, or attributes computed at {tolerance}")
    check_seq_len(list(attributes.values()), seq_len)
    check_matcher(list(attributes.values()), matcher, truth.radius, file_truth)


def load_predictor(predictor: Path, seq_len: int) -> SMRPredictor:
    """The predictor file ``predictor``, checked (an HDF5 file that exists, trained at ``seq_len``) and loaded."""
    check_suffix(predictor, HDF5_SUFFIXES, "the predictor (HDF5)", "--predictor")
    if not predictor.is_file():
        raise FileNotFoundError(f"predictor file not found: {predictor} (train it first: vpr-smr train)")
    model = SMRPredictor.load(predictor)
    check_length(model, seq_len, f"--seq-len {seq_len}", "--seq-len")
    return model


def _check_matrices(model: SMRPredictor, splits: Mapping[str, Path], allow_split_overlap: bool,
                    matrix_format: MatrixFormat) -> None:
    """Refuse to score a matrix that shares entries with one the predictor was trained on (``check_matrices``:
    every patch of each matrix looked up among its training matrices' fingerprints), unless allowed; a warning
    where the predictor records none and the frame ranges cannot tell either (``matrix_overlaps``)."""
    found = []
    name = f"predictor {model.path_}"
    for path in splits.values():
        if not model.training_.matrices:  # nothing to look the patches up in: the matrix need not be read
            matrix_overlaps(model.training_, str(path), predictor=name, ranged=_ours(path) and has_frames(path))
            continue
        with _open(path, matrix_format) as matrix:
            found += matrix_overlaps(model.training_, str(path), matrix=matrix, predictor=name)
    check_matrices(found, allow_split_overlap)


def _open(path: Path | str, matrix_format: MatrixFormat) -> Any:
    """The matrix file ``path`` opened as ``matrix_format`` says (``io.open_distance_matrix``)."""
    return open_distance_matrix(path, matrix_format.similarity, matrix_format.key, matrix_format.transpose)


@dataclass(frozen=True)
class Scored:
    """Every split scored, the predictor file (None without one) and the ground truth's provenance (of the file,
    whole, when one was given; else of the first split's: frames or positions are the same for every split)."""

    splits: dict[str, ScoredSplit]
    predictor: Path | None
    ground_truth: dict[str, Any]


def score_all(job: MetricsJob | QueriesJob) -> Scored:
    """Every split of ``job.distances`` scored (``score_split``) in the given order, after every input is checked:
    what ``main`` and the ``queries`` stage share (one implementation of the per-query table; a ``QueriesJob``
    scores no metric mode and no sweep)."""
    modes, sweep = (job.modes, job.sweep) if isinstance(job, MetricsJob) else ((), False)
    seq_len, truth_source, matcher, matrix_format = job.seq_len, job.truth, job.matcher, job.matrix
    baselines = job.scorer_settings
    splits = {name: Path(path) for name, path in distance_splits(job.distances).items()}
    if not splits:
        raise ValueError("no distance matrix given (--distances PATH, or SPLIT=PATH items)")
    attribute_paths = {str(name): Path(path) for name, path in (job.attributes or {}).items()}
    unknown = [mode for mode in modes if mode not in MODES]
    if unknown:
        raise ValueError(f"unknown metric modes {unknown}; choose from {', '.join(MODES)}")
    predictor_file = Path(job.predictor) if job.predictor is not None else None
    if sweep and truth_source.ground_truth is not None:  # before any file is read
        raise ValueError(f"--sweep varies a tolerance (frames) or a radius (positions), but --ground-truth "
                         f"{truth_source.ground_truth} says which references are correct, with nothing to vary: "
                         "leave out --sweep, or score with --tolerance (or positions and --radius) instead")
    file_truth = (None if truth_source.ground_truth is None
                  else read_ground_truth(truth_source.ground_truth, truth_source.ground_truth_key,
                                         within=scored_shape(splits.values(), matrix_format.key,
                                                             matrix_format.transpose)))
    check_inputs(splits, attribute_paths, seq_len, truth_source, matcher, file_truth)
    model = None if predictor_file is None else load_predictor(predictor_file, seq_len)
    if model is not None:
        scored = [p for p in (*splits.values(), *attribute_paths.values()) if _ours(p)]
        check_disjoint(model.training_.frames, frame_ranges(scored), job.allow_split_overlap,
                       f"predictor {predictor_file}")
        check_matching(model, Matching.of(matcher, truth_kind(truth_source)), "these matrices (--matcher, --radius)")
        _check_matrices(model, splits, job.allow_split_overlap, matrix_format)
    settings = SplitSettings(seq_len, truth_source.tolerance, tuple(modes), matcher, sweep, baselines)
    results: dict[str, ScoredSplit] = {}
    recorded: dict[str, Any] | None = None if file_truth is None else file_truth.provenance()
    for split, path in splits.items():
        attributes_file = attribute_paths.get(split)
        with _open(path, matrix_format) as matrix:
            check_size(stage_check(matcher.build, tuple(matrix.shape), str(path)), seq_len)
            features = read_features(attributes_file) if attributes_file is not None else None
            if features is not None and baselines is not None:
                check_candidates(features, baselines, str(attributes_file),
                                 "leave --attributes out (they are computed here), or give --no-baselines")
            truth = split_ground_truth(path, tuple(matrix.shape), truth_source.tolerance, truth_source.radius,
                                       truth_source.reference_positions, truth_source.query_positions, file_truth)
            recorded = truth.provenance() if recorded is None else recorded
            warn_if_similar(path, matrix, truth, matrix_format.similarity)
            warn_if_tied(str(path), matrix)
            try:
                results[split] = score(matrix, settings, SplitInputs(
                    features, truth, split, _first_frame(attributes_file, path),
                    _reference_first_frame(attributes_file, path)), model)
            except ValueError as error:
                given = f" and {attributes_file}" if attributes_file is not None else ""
                raise ValueError(f"{path}{given}: {error}") from None
        split_metrics = results[split].metrics
        if split_metrics.queries_without_correct:
            log.info("%s: %d of its queries have no correct reference under %s (never correct, counted in every "
                     "denominator)", split, split_metrics.queries_without_correct, truth.describe())
        first_mode = split_metrics.modes[modes[0]] if modes else {}
        if first_mode:
            log.info("%s: recall@1 single %.4f, sequence %.4f (%s mode)", split,
                     first_mode["single"].recall_at[1], first_mode["sequence"].recall_at[1], modes[0])
    assert recorded is not None  # splits is not empty
    return Scored(results, predictor_file, recorded)


def main(job: MetricsJob) -> VPRMetrics:
    """The standard VPR metrics of every split of ``job.distances`` (one ``.npy``, ``.npz``, ``.mat`` or our HDF5:
    one split named ``"all"``; or ``SPLIT=PATH`` items), written to ``job.out`` (JSON, ``records.VPRMetrics``) and,
    with ``job.queries``, the per-query table (``queries.QUERY_COLUMNS``) of every split in the given order, as the
    ``queries`` stage writes it. Both files are written to temporary names and renamed into place only when both
    are written.

    ``attributes`` (split -> our features ``.h5``) spares recomputing a split's attributes; they must come from the
    same matrix, ``seq_len`` and ground truth. ``predictor``: the seed-0 predictor file; it may not score frames it
    was trained on (``allow_split_overlap``: a deliberate experiment). ``matrix``: how a user's matrix is read
    (``io.open_distance_matrix``). The meta holds ``dataset`` and ``method`` (those given), ``seq_len``,
    ``tolerance``, the ground truth (``ground_truth``: ``GroundTruth.provenance``), how the matrices were read and
    the predictor's path; each split records its queries without a correct reference. ``sweep``: each split
    also records recall@1 and the predictor's reduction over the tolerances or radii of ``sweep.protocol_sweep``
    (``records.ProtocolSweep``). ``baselines`` (default on; ``scorers`` their settings): each split also records
    the training-free scorers of method §12 (``records.SplitBaselines``: their detection of wrong matches and, with
    ``predictor``, their removal at its budget), the per-query table their confidences, and the meta the settings
    (``r_window``, ``spread_k``). Every input is checked before any work.
    """
    out = check_suffix(job.out, JSON_SUFFIXES, "the VPR metrics (JSON)")
    queries = check_suffix(job.queries, CSV_SUFFIXES, "the per-query table (CSV)", "--queries") if job.queries else None
    scored = score_all(job)
    baselines, matrix_format = job.scorer_settings, job.matrix
    meta = {key: value for key, value in (("dataset", job.dataset), ("method", job.method)) if value is not None}
    info = {**meta, "seq_len": int(job.seq_len), "tolerance": int(job.truth.tolerance),
            **matcher_provenance(job.matcher, job.truth.radius),
            **reading_provenance(matrix_format.similarity, matrix_format.key, matrix_format.transpose),
            "ground_truth": scored.ground_truth, **(baselines.meta() if baselines is not None else {})}
    if scored.predictor is not None:
        info["predictor"] = str(scored.predictor)
    result = VPRMetrics(info, {split: scored_split.metrics for split, scored_split in scored.splits.items()})
    with ExitStack() as stack:  # both files are renamed into place only when both are written
        out_tmp = stack.enter_context(atomic_path(out))
        if queries is not None:
            write_queries(stack.enter_context(atomic_path(queries)),
                          [scored_split.queries for scored_split in scored.splits.values()])
        write_json(out_tmp, result.to_json())
    return result


def format_metrics(result: VPRMetrics) -> str:
    """Every metric of ``result`` as a plain-text table, one row per split, mode and matcher (what ``vpr-smr
    metrics`` prints; the JSON holds the same numbers unrounded). Recalls and areas are fractions, 4 decimals."""
    ns = sorted({n for split in result.splits.values() for matchers in split.modes.values()
                 for metrics in matchers.values() for n in metrics.recall_at})
    header = ["split", "mode", "matcher", "queries", *(f"R@{n}" for n in ns), "R@100P", "PR-AUC", "EP"]
    rows = [header]
    for split, scored in result.splits.items():
        for mode, matchers in scored.modes.items():
            for matcher, metrics in matchers.items():
                recalls = [f"{metrics.recall_at[n]:.4f}" if n in metrics.recall_at else "-" for n in ns]
                rows.append([split, mode, matcher, str(metrics.n_queries), *recalls, f"{metrics.recall_at_100p:.4f}",
                             f"{metrics.pr_auc:.4f}", f"{metrics.extended_precision:.4f}"])
    text = _aligned(rows, 3)
    sweep = [["split", "mode", "ground truth", "R@1 single", "R@1 sequence", "AOC reduction (%)"]]
    for split, scored in result.splits.items():
        if scored.sweep is None:
            continue
        for mode, points in scored.sweep.modes.items():
            for point in points:
                reduction = point.reduction.reduction_pct if point.reduction is not None else None
                sweep.append([split, mode, within(scored.sweep.kind, point.threshold),
                              f"{point.recall_at_1_single:.4f}", f"{point.recall_at_1_sequence:.4f}",
                              "-" if reduction is None else f"{reduction:.2f}"])
    if all(row[-1] == "-" for row in sweep[1:]):  # no predictor: no reduction to show
        sweep = [row[:-1] for row in sweep]
    return text if len(sweep) == 1 else f"{text}\n\nprotocol sweep (method §13):\n{_aligned(sweep, 3)}"


def _aligned(rows: Sequence[Sequence[str]], names: int) -> str:
    """Rows of cells as plain-text columns: the first ``names`` left-aligned, numbers right-aligned, as a reader
    compares them down a column."""
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    return "\n".join("  ".join(cell.ljust(width) if i < names else cell.rjust(width)
                               for i, (cell, width) in enumerate(zip(row, widths, strict=True))).rstrip()
                     for row in rows)


def _fraction(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.4f}"


def _bracket(interval: Interval | None) -> str:
    """A reduction's interval as the console prints it beside the number: ``[-7.47, 91.65]``, ``[n/a]``."""
    return "[n/a]" if interval is None else f"[{interval.low:.2f}, {interval.high:.2f}]"


def _interval_of(numbers: Reduction) -> str:
    """The interval a removal's row prints: its reduction's, or for a from-zero outcome (no reduction) that of the
    AOC difference which judged it, named: ``AOC difference [+0.0004, +0.0021]``."""
    difference = numbers.aoc_difference_ci
    if numbers.reduction_pct is None and difference is not None:
        return f"AOC difference [{difference.low:+.4f}, {difference.high:+.4f}]"
    return _bracket(numbers.reduction_pct_ci)


def format_baselines(result: VPRMetrics) -> str:
    """The training-free scorers of every split (method §12) as plain text: each scorer's average precision and ROC
    AUC of detecting wrong matches (with the fraction of wrong matches, a random ranking's average precision), and
    with a predictor each scorer's AOC reduction at its budget per mode, its interval, and its outcome (a direction
    only where the interval earns it, ``curves.earned``); empty when none were computed."""
    parts = []
    for split, scored in result.splits.items():
        found = scored.baselines
        if found is None:
            continue
        parts.append(f"{split}: detecting the {found.n_wrong} wrong sequence matches of {found.n_queries} queries "
                     f"(fraction {found.wrong_fraction:.4f}: a random ranking's average precision)")
        rows = [["scorer", "AP", "ROC AUC"]]
        rows += [[name, _fraction(numbers.average_precision), _fraction(numbers.roc_auc)]
                 for name, numbers in found.detection.items()]
        parts.append(_aligned(rows, 1))
        for budget in found.removal or ():
            parts.append(f"{split}: removal at the seed-{budget.seed} predictor's budget of {budget.budget} matches")
            rows = [["mode", "scorer", "removed", "max recall", "AOC VPR+SM", "AOC", "reduction %",
                     "interval", "outcome"]]
            modes = list(dict.fromkeys(mode for removal in budget.scorers.values() for mode in removal.modes))
            for mode in modes:  # one mode's scorers together, as a reader compares them
                for name, removal in budget.scorers.items():
                    numbers = removal.modes[mode]
                    rows.append([mode, name, str(removal.removed), f"{numbers.max_recall:.4f}",
                                 f"{numbers.aoc_vpr_sm:.4f}", f"{numbers.aoc_vpr_sm_pred:.4f}",
                                 "n/a" if numbers.reduction_pct is None else f"{numbers.reduction_pct:.2f}",
                                 _interval_of(numbers),
                                 earned(numbers.outcome, numbers.reduction_pct_ci)])
            parts.append(_aligned(rows, 2))
    return "\n\n".join(parts)
