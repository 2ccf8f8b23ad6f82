"""The four SMR attributes of every query and its label (method §5 and §6, paper mode), and the ``attributes`` stage.

``query_features`` runs a sequence matcher (a ``MatcherSpec``, default ``seqslam`` with velocities [1.0]: the
paper's fixed matcher) and the attributes (``features.split_features``: computed once, for any matcher) over one
split's distance matrix, read in blocks of query columns (any 2-D array-like that slices by columns: ``np.ndarray``,
``np.memmap``, ``h5py.Dataset``), so no full-size float64 copy of it ever exists, and labels its matches with the
split's ground truth. Every reported number is the float64 value of the definition, bit for bit, whatever the block
size or the implementation the matcher picks.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from vpr_smr.core import environment
from vpr_smr.core.constants import DEFAULT_TOLERANCE, candidates_needed
from vpr_smr.core.io import (
    CSV_SUFFIXES,
    HDF5_SUFFIXES,
    atomic_h5,
    atomic_path,
    check_suffix,
    open_h5,
    read_provenance,
)
from vpr_smr.core.records import Record
from vpr_smr.core.settings import REQUIRED, setting
from vpr_smr.eval.matching import sources
from vpr_smr.eval.matching.checks import check_size, stage_check, warn_if_tied
from vpr_smr.eval.matching.features import split_features
from vpr_smr.eval.matching.fingerprint import MatrixPrint, matrix_print, read_print, write_print
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
from vpr_smr.eval.matching.matchers import DEFAULT_MATCHER, MatcherSpec, matcher_class
from vpr_smr.eval.matching.matchers.base import Matcher
from vpr_smr.eval.matching.sources import MatrixFormat, TruthSource

__all__ = [
    "ATTRIBUTE_NAMES", "CANDIDATE_FIELDS", "DEFAULT_CANDIDATES", "OPTIONAL_FIELDS", "QueryFeatures",
    "labels_from_correctness", "query_features", "recorded_matcher",
]

ATTRIBUTE_NAMES = ("A1", "A2", "A3", "A4")  # minimum sum, minimum value, block sum, group sum rates


DEFAULT_CANDIDATES = candidates_needed()  # 12: r_window 10, K 10
# QueryFeatures' candidate arrays: written when computed, absent from files computed without them
CANDIDATE_FIELDS = ("sequence_candidates", "sequence_candidate_references", "single_candidates",
                    "single_candidate_references")
# every array a file may lack: the candidates, and the native confidence (absent where the matcher names a scorer)
OPTIONAL_FIELDS = (*CANDIDATE_FIELDS, "sequence_native")
NATIVE_SCORER = "native_scorer"  # QueryFeatures' one field that no file stores (the recorded matcher's)
MATRIX_PRINT = "distances_print"  # the dataset of a features file holding its matrix's ``MatrixPrint``
NOT_DATASETS = (NATIVE_SCORER, "seq_len", "matrix")  # QueryFeatures' fields that are no dataset of its file


@dataclass(frozen=True)
class QueryFeatures:
    """What the predictor and the evaluation need of one split, for the queries its matcher evaluates with a window
    of ``L`` columns (``seqslam``: ``a = L-1 .. Q-1``).

    ``attributes[n, k]`` holds ``[A1_k, A2_k, A3_k, A4_k]`` of query ``queries[n]``;
    ``rank_references[n, k]`` is the reference that the rank-``k`` diagonal (with velocity search, method §11: the
    rank-``k`` best trajectory) matches to that query, i.e. where it ends. The sequence match, its distance and
    the sequence candidates are the matcher's (``r*_a``, ``s_a[r*_a]``, the smallest ``s_a``; ``seqslam``: ``S``).
    """

    queries: np.ndarray  # (N,) query index within the split
    attributes: np.ndarray  # (N, K, 4)
    rank_references: np.ndarray  # (N, K)
    single_match: np.ndarray  # (N,) argmin_r D[r, a]
    sequence_match: np.ndarray  # (N,) the matcher's r*_a (seqslam: argmin_i S[i, a-L+1] + L - 1)
    sequence_distance: np.ndarray  # (N,) s_a[r*_a] (seqslam: min_i S[i, a-L+1]; method §11: min_r S[r, a])
    labels: np.ndarray  # (N,) 0..3, method §6
    single_correct: np.ndarray  # (N,) bool
    sequence_correct: np.ndarray  # (N,) bool
    rank_correct: np.ndarray  # (N, K) bool
    sequence_min: float  # S.min() of the whole split (the smallest s_a[r*_a])
    sequence_max: float  # S.max() of the whole split (the largest finite s_a[r])
    all_single_correct: np.ndarray  # (Q,) bool: single-frame correctness of every query, the first L-1 included
    # The training-free scorers' candidates (method §12), None when not computed: the n smallest S[r, a] ascending
    # (equal values lowest r first; the first is the sequence match) and their end references, and the n smallest
    # D[r, a] of the query's own column and their references; +inf and -1 where a split has fewer than n.
    sequence_candidates: np.ndarray | None = None  # (N, n) float64
    sequence_candidate_references: np.ndarray | None = None  # (N, n) int64
    single_candidates: np.ndarray | None = None  # (N, n) float64
    single_candidate_references: np.ndarray | None = None  # (N, n) int64
    # The matcher's native confidence (method §14, higher = more confident): its own numbers where it computes them
    # (``sequence_native``, stored in the file), else ``native_scorer``, the §12 scorer it names (``uniqueness``
    # for seqslam), computed with the other scorers. The name is the matcher's, never stored: a file gives it from
    # the matcher it records; features built without a matcher are the default matcher's.
    sequence_native: np.ndarray | None = None  # (N,) float64
    native_scorer: str | None = field(default_factory=lambda: matcher_class(DEFAULT_MATCHER).native_scorer)
    # What they were computed from, for a predictor trained on them (``leakage.Training``): the sequence length and
    # the matrix's identity (``fingerprint.matrix_print``; None unless asked for: a pass over the matrix)
    seq_len: int | None = None
    matrix: MatrixPrint | None = None

    @property
    def n_candidates(self) -> int:
        """How many candidates per query this holds (0: none)."""
        return 0 if self.sequence_candidates is None else int(self.sequence_candidates.shape[1])


def labels_from_correctness(single_correct: np.ndarray, sequence_correct: np.ndarray) -> np.ndarray:
    """0 correct before and after, 1 correct before only, 2 correct after only, 3 wrong both."""
    single_correct = np.asarray(single_correct, dtype=bool)
    sequence_correct = np.asarray(sequence_correct, dtype=bool)
    return np.where(single_correct, np.where(sequence_correct, 0, 1), np.where(sequence_correct, 2, 3))


# --- whole split ------------------------------------------------------------------------------------------------


def query_features(
    distance_matrix: Any, seq_len: int, tolerance: int = DEFAULT_TOLERANCE, n_ranks: int = 4,
    block_queries: int | None = None,
    screen_dtype: Any = np.float32,
    *,
    matcher: MatcherSpec | Matcher | None = None,
    ground_truth: GroundTruth | None = None,
    n_candidates: int = 0,
    fingerprint: bool = False,
) -> QueryFeatures:
    """Sequence matching, attributes and labels of one split's ``R x Q`` distance matrix.

    ``distance_matrix`` is any 2-D numeric array-like that supports column slicing (``np.ndarray``, a memory-mapped
    ``.npy``, an ``h5py.Dataset``); it is read ``block_queries`` columns at a time. ``screen_dtype`` only decides
    which candidates are recomputed in float64: the results are the same for float32 and float64.
    ``matcher``: the sequence matcher (a ``MatcherSpec``, built at ``seq_len``, or a ``Matcher`` of that length;
    default ``seqslam`` with velocities [1.0], the fixed matcher of method §4).
    ``ground_truth``: which matches are correct (default: frame-aligned within ``tolerance``, method §1).
    ``n_candidates``: also the training-free scorers' candidates (``core.constants.candidates_needed``; 0: none).
    ``fingerprint``: also the matrix's identity (``fingerprint.matrix_print``), which a predictor trained on these
    features records.
    """
    built = built_matcher(matcher, seq_len)
    matrix = as_matrix(distance_matrix)
    built.check(tuple(matrix.shape))  # before the ground truth's check: the matrix's own errors first
    if ground_truth is None:
        ground_truth = GroundTruth.aligned(matrix.shape[0], matrix.shape[1], tolerance)
    ground_truth.check_shape(tuple(matrix.shape))
    if n_candidates < 0:
        raise ValueError(f"n_candidates must be >= 0, got {n_candidates}")
    result = split_features(built, matrix, n_ranks, block_queries, screen_dtype, n_candidates)
    queries = result["queries"]
    rank_refs = result["rank_references"]
    single = result["single_match"]
    seq_match = result["sequence_match"]
    return QueryFeatures(
        queries=queries,
        attributes=result["attributes"],
        rank_references=rank_refs,
        single_match=single,
        sequence_match=seq_match,
        sequence_distance=result["sequence_distance"],
        sequence_min=float(result["sequence_distance"].min()),
        sequence_max=float(result["sequence_max"].max()),
        **verdicts(ground_truth, queries, single, seq_match, rank_refs,
                   np.concatenate([np.argmin(read_columns(matrix, 0, seq_len - 1), axis=1),
                                   result["window_single_match"]])),
        **{name: result[name] for name in OPTIONAL_FIELDS if name in result},
        native_scorer=built.native_scorer,
        seq_len=seq_len,
        matrix=matrix_print(matrix) if fingerprint else None,
    )


def built_matcher(matcher: MatcherSpec | Matcher | None, seq_len: int) -> Matcher:
    """The matcher of a spec (built at ``seq_len``; None: the default spec), or a built one of that length."""
    if isinstance(matcher, Matcher):
        if matcher.seq_len != seq_len:
            raise ValueError(f"the matcher {matcher.name!r} was built for sequence length {matcher.seq_len}, "
                             f"not {seq_len}")
        return matcher
    return (matcher or MatcherSpec.of()).build(seq_len)


def verdicts(truth: GroundTruth, queries: np.ndarray, single_match: np.ndarray, sequence_match: np.ndarray,
             rank_references: np.ndarray, all_single: np.ndarray) -> dict[str, np.ndarray]:
    """The fields of ``QueryFeatures`` that the ground truth decides: each match's correctness under ``truth`` and
    the labels (method §6). ``all_single``: the single-frame matches of every query of the split, the first
    ``L - 1`` (which have no sequence match) included; paper mode's single-frame recall@1 counts every query of the
    split (method §8)."""
    single = truth.correct(single_match, queries)
    sequence = truth.correct(sequence_match, queries)
    return {"labels": labels_from_correctness(single, sequence), "single_correct": single,
            "sequence_correct": sequence, "rank_correct": truth.correct(rank_references, queries[:, None]),
            "all_single_correct": truth.correct(all_single, np.arange(len(all_single)))}


def write_features(path: Path | str, features: QueryFeatures, provenance: dict[str, Any]) -> None:
    """Every array of ``features`` as a dataset of its name; the candidates and the native confidence only when
    computed (``native_scorer`` is the recorded matcher's, ``provenance["matcher"]``); the length as an attribute
    and the matrix's identity as the dataset ``MATRIX_PRINT`` (``fingerprint.write_print``)."""
    own = {} if features.seq_len is None else {"seq_len": features.seq_len}
    with atomic_h5(path, {**provenance, **own}) as f:
        for item in fields(QueryFeatures):
            value = getattr(features, item.name)
            if value is not None and item.name not in NOT_DATASETS:
                f[item.name] = value
        if features.matrix is not None:
            write_print(f, MATRIX_PRINT, features.matrix)


def read_features(path: Path | str) -> QueryFeatures:
    """The features ``write_features`` wrote; a file without the candidates (computed without them, or before
    they existed) reads with them None, one without ``sequence_native`` (a matcher that names its native scorer,
    or a file written before it was stored) with it None. ``native_scorer``: that of the matcher the file records
    (``recorded_matcher``); ``seq_len`` and ``matrix`` those the file records (None where it records none)."""
    with open_h5(path, "attributes written by vpr-smr attributes (.h5)") as f:
        values: dict[str, Any] = {
            item.name: f[item.name][()] for item in fields(QueryFeatures)
            if item.name not in NOT_DATASETS and (item.name in f or item.name not in OPTIONAL_FIELDS)}
        values["matrix"] = read_print(f[MATRIX_PRINT]) if MATRIX_PRINT in f else None
    values["sequence_min"] = float(values["sequence_min"])
    values["sequence_max"] = float(values["sequence_max"])
    provenance = read_provenance(path)
    values["seq_len"] = None if provenance.get("seq_len") is None else int(provenance["seq_len"])
    if "sequence_native" in values:  # the matcher's own numbers: it names no scorer
        return QueryFeatures(**values, native_scorer=None)
    spec = recorded_matcher(provenance, str(path))
    return QueryFeatures(**values, native_scorer=matcher_class(spec.name).native_scorer)


# --- the `attributes` stage: sequence matching, attributes and labels of one distance matrix, to .csv or .h5

OUT_SUFFIXES = CSV_SUFFIXES + HDF5_SUFFIXES

log = logging.getLogger("vpr_smr")


def write_csv(path: Path | str, features: QueryFeatures) -> None:
    """One row per query: its index, the rank-0 attributes A1..A4 (the paper's names) and its label."""
    table = np.column_stack([features.queries, features.attributes[:, 0, :], features.labels])
    header = ",".join(("query", *ATTRIBUTE_NAMES, "label"))
    with atomic_path(path) as tmp:
        np.savetxt(tmp, table, delimiter=",", header=header, comments="", fmt=["%d", *["%.9g"] * 4, "%d"])


@dataclass(frozen=True)
class AttributesJob:
    """The ``attributes`` stage's job: the four attributes of every query of one distance matrix."""

    distances: str = setting(REQUIRED, "the distance matrix: our .h5, or a references x queries .npy, .npz or .mat",
                             metavar="PATH")
    seq_len: int = sources.seq_len()
    truth: TruthSource = sources.truth()
    matcher: MatcherSpec = sources.matcher()
    matrix: MatrixFormat = sources.matrix()
    candidates: int = setting(DEFAULT_CANDIDATES, "the smallest S and D values per query kept for the training-free "
                                                  "scorers (method §12); 0 keeps none", minimum=0)
    out: str = setting(REQUIRED, "the output file: the attributes (.csv table or HDF5)", metavar="PATH")


def main(job: AttributesJob) -> QueryFeatures:
    """Features of the matrix in ``job.distances`` (``.npy``, ``.npz``, ``.mat`` or our ``.h5``) written to ``out``.

    ``out`` ending in ``.csv`` gets the rank-0 table (``write_csv``); ``.h5``/``.hdf5`` every field of
    ``QueryFeatures`` as HDF5, with the distance file's provenance, ``seq_len``, ``tolerance``,
    ``attributes_seconds`` (the time of the computation, reading included), the ground truth (``ground_truth``:
    ``GroundTruth.provenance``) and its ``queries_without_correct`` (of every query of the matrix) and
    ``evaluated_without_correct`` (of the queries with a sequence match), the matcher (``matcher``:
    ``MatcherSpec.provenance``; default ``seqslam`` with velocities [1.0]) and ``radius`` with positions; another
    suffix is an error, before anything is read. ``key``,
    ``transpose``, ``similarity``: how a user's matrix is read (``io.open_distance_matrix``). The ground truth:
    ``ground_truth`` (a file, ``ground_truth_files.read_ground_truth``, its variable ``ground_truth_key``), else
    ``io.split_ground_truth`` (positions within ``radius``, or frame indices within ``tolerance``). Errors name the
    distance file (negative distances included: ``io.check_non_negative``). ``n_candidates``: how many of the
    smallest ``S`` and ``D`` values per query the HDF5 file keeps for the training-free scorers (method §12;
    ``core.constants.candidates_needed``), recorded as ``n_candidates``; 0 keeps none.
    """
    distances, seq_len, truth_source, matrix_format = Path(job.distances), job.seq_len, job.truth, job.matrix
    tolerance, radius = truth_source.tolerance, truth_source.radius
    similarity, key, transpose = matrix_format.similarity, matrix_format.key, matrix_format.transpose
    matcher, n_candidates = job.matcher, job.candidates
    out = check_suffix(job.out, OUT_SUFFIXES, "the attributes (.csv table or HDF5)")
    start = time.perf_counter()
    truth_file = None if truth_source.ground_truth is None else read_ground_truth(
        truth_source.ground_truth, truth_source.ground_truth_key, within=scored_shape([distances], key, transpose))
    with open_distance_matrix(distances, similarity, key, transpose) as matrix:
        check_size(stage_check(matcher.build, tuple(matrix.shape), str(distances)), seq_len)
        built = matcher.build(seq_len)
        truth = split_ground_truth(distances, tuple(matrix.shape), tolerance, radius,
                                   truth_source.reference_positions, truth_source.query_positions, truth_file)
        warn_if_similar(distances, matrix, truth, similarity)
        warn_if_tied(str(distances), matrix)
        try:
            hdf5 = out.suffix.lower() not in CSV_SUFFIXES
            features = query_features(matrix, seq_len, tolerance, matcher=built, ground_truth=truth,
                                      n_candidates=n_candidates if hdf5 else 0, fingerprint=hdf5)
        except ValueError as error:
            raise ValueError(f"{distances}: {error}") from None
    seconds = time.perf_counter() - start
    without = truth.without_correct()
    if without.any():
        log.info("%s: %d of its %d queries have no correct reference under %s (never correct, still counted)",
                 distances, int(without.sum()), len(without), truth.describe())
    if out.suffix.lower() in CSV_SUFFIXES:
        write_csv(out, features)
    else:
        provenance = read_provenance(distances) if not is_user_matrix(distances) else {}
        provenance = {k: v for k, v in provenance.items() if k != "vpr_smr_version"}
        provenance.update({**matcher_provenance(matcher, radius), **reading_provenance(similarity, key, transpose)})
        if n_candidates:  # recorded only when kept, so that a file without them reads as it always did
            provenance["n_candidates"] = int(n_candidates)
        # this stage's own numeric environment replaces the one its distances file recorded (information only)
        write_features(out, features, {**provenance, "seq_len": seq_len, "tolerance": tolerance,
                                       "attributes_seconds": seconds, **truth_provenance(truth, seq_len, without),
                                       **environment.recorded()})
    log.info("%d queries, %.1f µs per query", len(features.queries), 1e6 * seconds / max(len(features.queries), 1))
    return features


def recorded_matching(paths: Sequence[Path | str]) -> dict[str, Any]:
    """``{"ground_truth": ..., "matcher": ...}``: the ground truth (``truth_provenance``) and the matcher
    (``recorded_matcher``: ``seqslam`` with its velocities for a file of 0.10 and before) the first of several
    attributes files records, for the meta of what is computed from them; no ``ground_truth`` when it records none
    (a file written before it did)."""
    if not paths:
        return {}
    stored = read_provenance(paths[0])
    recorded = stored.get("ground_truth")
    truth = {"ground_truth": recorded} if isinstance(recorded, dict) else {}
    return {**truth, "matcher": recorded_matcher(stored, str(paths[0])).provenance()}


def truth_provenance(truth: GroundTruth, seq_len: int, without: np.ndarray | None = None) -> dict[str, Any]:
    """What an attributes file records of its ground truth: ``GroundTruth.provenance`` as ``ground_truth``, and how
    many queries have no correct reference (``without``: ``truth.without_correct()``, computed when None), of all
    (``queries_without_correct``) and of those with a sequence match (``evaluated_without_correct``, queries
    ``L - 1`` on)."""
    without = truth.without_correct() if without is None else without
    return {"ground_truth": truth.provenance(), "queries_without_correct": int(without.sum()),
            "evaluated_without_correct": int(without[seq_len - 1 :].sum())}


def matcher_provenance(matcher: MatcherSpec, radius: float | None) -> dict[str, Any]:
    """What a file records of its matcher and ground truth beyond ``seq_len`` and ``tolerance``: the matcher
    (``MatcherSpec.provenance``) and, with positions, the radius."""
    out: dict[str, Any] = {"matcher": matcher.provenance()}
    if radius is not None:
        out["radius"] = float(radius)
    return out


def recorded_matcher(provenance: Mapping[str, Any], where: str) -> MatcherSpec:
    """The matcher a file's provenance records (``matcher_provenance``); a file of vpr-smr 0.9 or before (no
    ``matcher``) was made by ``seqslam`` with its recorded ``velocities`` (the fixed matcher's [1.0] when it records
    none). ValueError naming ``where`` for a record that is no matcher's."""
    if "matcher" in provenance:
        return MatcherSpec.from_provenance(provenance["matcher"], where)
    old = provenance.get("velocities")
    return MatcherSpec.of(DEFAULT_MATCHER, {} if old is None else {"velocities": list(old)}, where)


@dataclass(frozen=True)
class Matching(Record):
    """What made the matches and labels of an attributes file, beyond ``L``: the sequence matcher (its name and
    settings) and the kind of ground truth (``FRAMES``, ``POSITIONS`` or ``MATRIX``). A predictor learns from such
    labels, so its file records the ``Matching`` it was trained with and every stage that applies it compares
    (``applies_to``)."""

    matcher: MatcherSpec = field(default_factory=MatcherSpec.of)
    ground_truth: str = FRAMES

    @classmethod
    def of(cls, matcher: MatcherSpec | None = None, kind: str = FRAMES) -> Matching:
        """A stage's matcher (None: the default) and the kind of its ground truth (``GroundTruth.kind``)."""
        if kind not in (FRAMES, POSITIONS, MATRIX):
            raise ValueError(f"unknown kind of ground truth {kind!r}; one of {FRAMES}, {POSITIONS}, {MATRIX}")
        return cls(matcher or MatcherSpec.of(), kind)

    def to_json(self) -> dict[str, Any]:
        return {"matcher": self.matcher.provenance(), "ground_truth": self.ground_truth}

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> Matching:
        """The record ``to_json`` wrote; one of vpr-smr 0.9 or before (``velocities``, no ``matcher``) is
        ``seqslam``'s with those velocities (``recorded_matcher``)."""
        return cls.of(recorded_matcher(data, "a predictor's recorded matching"), str(data.get("ground_truth", FRAMES)))

    @classmethod
    def stored(cls, path: Path | str) -> Matching:
        """The matching an attributes file was computed with (``matcher_provenance``, ``truth_provenance``); a file
        that does not record its ``ground_truth`` (written before it did) is of positions when it records a radius,
        else of frames."""
        stored = read_provenance(path)
        truth = stored.get("ground_truth")
        kind = truth.get("kind") if isinstance(truth, dict) else None
        if kind is None:
            kind = FRAMES if stored.get("radius") is None else POSITIONS
        return cls.of(recorded_matcher(stored, str(path)), str(kind))

    def applies_to(self, other: Matching) -> bool:
        """Whether a predictor trained on attributes of this matching may score where ``other`` is used: the same
        matcher and settings (its matches are that matcher's), and the same kind of ground truth or a matrix on
        either side. Frames and positions tell a frame-aligned pair from one driven at other speeds, whose
        attributes differ; a matrix (or lists) says which frames are correct, not how the traverses were driven,
        and the field's matrices exist for both, so scoring with one is another protocol (an experiment, as another
        tolerance or radius is), not a sign of the wrong predictor."""
        return self.matcher == other.matcher and (
            self.ground_truth == other.ground_truth or MATRIX in (self.ground_truth, other.ground_truth))

    def __str__(self) -> str:
        truth = {FRAMES: "frame indices within a tolerance", POSITIONS: "positions within a radius",
                 MATRIX: "a matrix (or lists) of correct references"}[self.ground_truth]
        return f"the matcher {self.matcher}, ground truth from {truth}"


def common_matching(paths: Sequence[Path | str]) -> Matching:
    """The one ``Matching`` of several attributes files (a predictor's training files); ValueError naming two files
    that differ."""
    if not paths:
        return Matching.of()
    first = Matching.stored(paths[0])
    for path in paths[1:]:
        other = Matching.stored(path)
        if other != first:
            raise ValueError(f"{paths[0]} holds attributes of {first}, but {path} of {other}: give attributes files "
                             "computed with one matcher and one kind of ground truth")
    return first


def check_matching(predictor: Any, matching: Matching, where: str, ground_truth: bool = True) -> None:
    """Raise ValueError naming both when ``predictor`` was trained on attributes of another matcher (or, with
    ``ground_truth``, a kind of ground truth it does not apply to: ``Matching.applies_to``) than ``matching``, what
    ``where`` scores with: its classes would describe other matches and other labels. The record is the
    ``matching_`` that ``SMRPredictor.load`` reads from the file (``path_``); a predictor fitted in this process
    (never loaded) has none and passes; one loaded from a file without the record is refused, with the fix."""
    if not hasattr(predictor, "path_"):
        return
    trained: Matching | None = predictor.matching_
    if trained is None:
        raise ValueError(f"{predictor.path_} does not record the sequence matcher and ground truth it was trained "
                         f"with (it was written before vpr-smr 0.5.0), so it cannot be checked against {where}, of "
                         f"{matching}: train it again (vpr-smr train)")
    if ground_truth and not trained.applies_to(matching):
        raise ValueError(f"{predictor.path_} was trained on attributes of {trained}, but it is applied to {where}, "
                         f"of {matching}: give the predictor trained with this matcher (the same matcher and "
                         "settings, and positions with a radius or not), or train one for it")
    if trained.matcher != matching.matcher:
        raise ValueError(f"{predictor.path_} was trained on attributes of the matcher {trained.matcher}, but it is "
                         f"applied to {where}, of the matcher {matching.matcher}: give it the matcher the predictor "
                         f"was trained with ({trained.matcher}), or train one for this one")


def check_length(predictor: Any, seq_len: int, where: str, fix: str) -> None:
    """Raise ValueError when a predictor was trained at another sequence length (``seq_len_``: a loaded file's, or
    the Python API's ``train``'s) than ``seq_len``, at which ``where`` applies it; ``fix``: how to give its length
    instead. A file that records none (saved by the Python API of 0.14 or before) is applied with a warning that
    says so, naming the fix (its classes describe matches of one length); a predictor fitted by hand passes."""
    trained = getattr(predictor, "seq_len_", None)
    name = getattr(predictor, "path_", "the predictor")
    if trained is None:
        if hasattr(predictor, "path_"):
            log.warning("%s records no sequence length (saved by the Python API of vpr-smr 0.14 or before), so it "
                        "cannot be checked against L = %d (%s): if it was trained at another length its decisions "
                        "mean nothing; save it again with save_predictor(..., seq_len=L), L the length of its "
                        "training attributes, or train it again", name, seq_len, where)
        return
    if int(trained) != seq_len:
        raise ValueError(f"{name} was trained at sequence length {trained}, but it is applied at L = {seq_len} "
                         f"({where}): give the predictor trained at L = {seq_len}, or {fix} {trained}")


def check_matcher(paths: Sequence[Path | str], matcher: MatcherSpec, radius: float | None,
                  ground_truth: GroundTruth | None = None) -> None:
    """Raise ValueError when an attributes file was computed with another matcher (or other settings), another
    kind of ground truth, another radius, or another ground-truth file (its SHA-256 and variable; ``ground_truth``:
    the stage's file) than a stage is given: its labels and matches would not be this matcher's."""
    kind = ground_truth.kind if ground_truth is not None else (FRAMES if radius is None else POSITIONS)
    expected = Matching.of(matcher, kind)
    given_file = None if ground_truth is None else _file_identity(ground_truth.provenance())
    for path in paths:
        stored_provenance = read_provenance(path)
        found, stored = Matching.stored(path), stored_provenance.get("radius")
        if found != expected or (radius is not None and (stored is None or float(stored) != float(radius))):
            given = "" if radius is None else f" within {float(radius):g}"
            held = "" if stored is None else f" within {float(stored):g}"
            raise ValueError(f"{path} holds attributes of {found}{held}, but this stage was given {expected}{given}: "
                             "give the same matcher and settings, --radius and --ground-truth, or recompute them")
        stored_truth = stored_provenance.get("ground_truth")
        held_file = _file_identity(stored_truth) if isinstance(stored_truth, dict) else None
        if given_file is not None and held_file != given_file:
            raise ValueError(f"{path} holds attributes labelled with the ground truth {_file_text(held_file)}, but "
                             f"this stage was given {_file_text(given_file)}: give the same --ground-truth (and "
                             "--ground-truth-key), or recompute the attributes with it")


def _file_identity(provenance: dict[str, Any]) -> tuple[str, str, str | None] | None:
    """(file name, SHA-256, variable) of a ground truth's provenance, None for one not from a file."""
    if provenance.get("sha256") is None:
        return None
    return str(provenance.get("file")), str(provenance["sha256"]), provenance.get("key")


def _file_text(identity: tuple[str, str, str | None] | None) -> str:
    if identity is None:
        return "not from a file"
    name, sha256, key = identity
    return f"{name}{'' if key is None else ':' + key} (SHA-256 {sha256[:12]}...)"


def check_seq_len(paths: Sequence[Path | str], seq_len: int, option: str = "--seq-len") -> None:
    """Raise ValueError when an attributes file was computed at another sequence length than ``seq_len`` (a stage
    given ``--seq-len 4`` and files of L = 3 would label its outputs wrongly); files without the attribute (made
    elsewhere) pass."""
    for path in paths:
        stored = read_provenance(path).get("seq_len")
        if stored is not None and int(stored) != int(seq_len):
            raise ValueError(f"{path} holds attributes of sequence length {int(stored)}, but {option} is {seq_len}: "
                             f"give the attributes files of L = {seq_len}, or {option} {int(stored)}")
