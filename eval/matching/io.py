"""Reading a distance matrix, ours (HDF5) or a user's (``.npy``, ``.npz``, MATLAB ``.mat``), lazily and checked, and
the ground truth that scores it."""

from __future__ import annotations

import logging
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from vpr_smr.core.arrays import ARRAY_SUFFIXES, choose, open_array, variables
from vpr_smr.core.files import KINDS, MAT, NPY, ZIP, file_kind, read_head, what_it_is
from vpr_smr.core.io import open_h5, read_provenance
from vpr_smr.eval.matching.ground_truth import GroundTruth, MatrixTruth, read_positions

log = logging.getLogger("vpr_smr")

# A column block of a chunked distance matrix touches every chunk row; cache them so that the L-1 columns that
# consecutive blocks share are not read twice (64 MB holds one chunk column of a 27592-reference matrix).
CHUNK_CACHE_BYTES = 64 << 20
CHUNK_CACHE_SLOTS = 10007
NEGATIVE_ROUNDING = 1e-5  # negatives down to this fraction of the largest |distance| are float rounding
SCAN_VALUES = 1 << 24  # values per block of the scan for negative distances (64 MB of float32)

USER_MATRIX = "a references x queries matrix"  # what a user's matrix file should hold, as errors say it
OUR_DISTANCES = "a distance file written by vpr-smr distances (or a user's .npy, .npz or .mat matrix)"


def is_user_matrix(path: Path | str) -> bool:
    """A user's matrix (``.npy``, ``.npz`` or ``.mat``, any case), as opposed to the HDF5 files the stages write."""
    return Path(path).suffix.lower() in ARRAY_SUFFIXES


def reading_provenance(similarity: bool = False, key: str | None = None, transpose: bool = False) -> dict[str, Any]:
    """What an output records of how a user's matrix was read: ``--similarity``, ``--key``, ``--transpose``
    (nothing for a matrix read as it is)."""
    out: dict[str, Any] = {"distances_from": "similarity: max(M) - M"} if similarity else {}
    if key is not None:
        out["distances_key"] = key
    if transpose:
        out["distances_transposed"] = True
    return out


class SimilarityAsDistance:
    """A similarity matrix (larger = more similar) read as the distances ``max(M) - M``, lazily: slicing it reads
    the similarities' block and converts it in float64. ``maximum`` is the largest finite value of the matrix."""

    def __init__(self, similarity: Any) -> None:
        self.similarity = similarity
        self.chunks = getattr(similarity, "chunks", None)
        self.column_major = _by_columns(similarity)  # read it in its source's storage order (``_blocks``)
        self.shape: tuple[int, ...] = tuple(similarity.shape)
        self.ndim = 2
        self.dtype = np.dtype(np.float64)
        self.maximum = 0.0 if not similarity.size else -np.inf
        for rows, cols in _blocks(similarity):
            block = np.asarray(similarity[rows, cols], dtype=np.float64)
            finite = block[np.isfinite(block)]
            if finite.size:
                self.maximum = max(self.maximum, float(finite.max()))
        self.size = int(similarity.size)

    def __getitem__(self, key: Any) -> np.ndarray:
        return self.maximum - np.asarray(self.similarity[key], dtype=np.float64)


@contextmanager
def open_distance_matrix(path: Path | str, similarity: bool = False, key: str | None = None,
                         transpose: bool = False, key_option: str = "--key") -> Iterator[Any]:
    """The references x queries matrix of ``path``, lazily where the format allows: a read-only memory map of a
    ``.npy``, the array ``key`` of an ``.npz``, the variable ``key`` of a MATLAB ``.mat`` (v5 in memory; v7.3 read by
    column blocks as MATLAB shows it), or the ``distance_matrix`` dataset of our HDF5 file (read by column blocks, see
    ``eval.matching.matcher.read_columns``). ``key``: default, the file's only 2-D numeric array. ``transpose``: the
    user's file is queries x references. ``similarity``: the file holds similarities (larger = more similar), read as
    distances ``max(M) - M`` (``SimilarityAsDistance``). ``key_option``: how errors name ``key`` (the Python API's
    argument ``key``, the CLI's ``--key``).

    Raises ``FileNotFoundError``/``ValueError`` naming the file, what it holds and the fix when it is missing, of
    another format, has no such variable (or several and no ``key``), has no ``distance_matrix`` dataset, or does
    not hold a 2-D numeric matrix with values.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"distance matrix not found: {path}")
    if is_user_matrix(path):
        with open_array(path, key, transpose, USER_MATRIX, key_option) as array:
            _check_matrix(path, array)
            matrix: Any = SimilarityAsDistance(array) if similarity else array
            check_non_negative(path, matrix)
            try:
                yield matrix
            finally:
                del matrix, array  # a memory map closes when its last reference goes
        return
    if not h5py.is_hdf5(path):
        head = read_head(path)
        suffix = {NPY: ".npy", ZIP: ".npz", MAT: ".mat"}.get(file_kind(head))
        if suffix is not None:
            raise ValueError(f"{path} is {what_it_is(head)}, but its name does not end in {suffix}: rename it (the "
                             "suffix says how the file is read)")
        raise ValueError(f"{path} is {KINDS[file_kind(head)]}, neither a NumPy .npy/.npz array, a MATLAB .mat file nor "
                         "HDF5 of vpr-smr distances: give a references x queries matrix as one of them, its name "
                         "ending in its format (numpy.save(path, matrix) writes a .npy)")
    if key is not None or transpose:
        option = "--key" if key is not None else "--transpose"
        raise ValueError(f"{option}: {path} is a distance file of vpr-smr (its dataset distance_matrix, references x "
                         f"queries): leave {option} out")
    with open_h5(path, OUR_DISTANCES, rdcc_nbytes=CHUNK_CACHE_BYTES, rdcc_nslots=CHUNK_CACHE_SLOTS) as f:
        if "distance_matrix" not in f:
            found = ", ".join(f) or "nothing"
            raise ValueError(f"{path} has no 'distance_matrix' dataset (it holds {found}): give a distance file of "
                             "vpr-smr distances; a MATLAB v7.3 file must end in .mat")
        matrix = f["distance_matrix"]
        _check_matrix(path, matrix)
        if similarity:
            raise ValueError(f"{path} is a distance file of vpr-smr (smaller = more similar): leave --similarity out")
        check_non_negative(path, matrix)
        yield matrix


def scored_shape(paths: Iterable[Path | str], key: str | None = None, transpose: bool = False
                 ) -> tuple[int, int] | None:
    """The largest references and queries of the matrices in ``paths``, from their headers alone (a ``.npy`` or
    ``.npz`` header, ``scipy.io.whosmat``, an HDF5 dataset's shape), nothing read: what a ground-truth file scoring
    them may name (``ground_truth_files.read_ground_truth``'s ``within``). None when one of them does not say: a
    distance file of a dataset's split (whose ground truth may be the whole dataset's), a file that cannot be read
    (``open_distance_matrix`` says why), a matrix that is not 2-D."""
    largest = (0, 0)
    for path in map(Path, paths):
        try:
            if is_user_matrix(path):
                shape = choose(path, variables(path), key, USER_MATRIX, "--key").shape
            else:
                if split_ranges(path) is not None:
                    return None
                with open_h5(path, OUR_DISTANCES) as f:
                    shape = tuple(f["distance_matrix"].shape) if "distance_matrix" in f else ()
        except (OSError, ValueError):
            return None
        if len(shape) != 2:
            return None
        rows, cols = (shape[1], shape[0]) if transpose else (shape[0], shape[1])
        largest = (max(largest[0], int(rows)), max(largest[1], int(cols)))
    return largest if largest != (0, 0) else None


def _check_matrix(path: Path, matrix: Any) -> None:
    if not np.issubdtype(matrix.dtype, np.number) or matrix.dtype.kind == "c":
        raise ValueError(f"{path}: expected a numeric matrix (references x queries), got {matrix.dtype}")
    if matrix.ndim != 2:
        raise ValueError(f"{path}: distance matrix must be 2-D (references x queries), got shape {matrix.shape}")
    if 0 in matrix.shape:
        raise ValueError(f"{path}: the distance matrix is {matrix.shape[0]} x {matrix.shape[1]} (references x "
                         "queries): it holds no values; write it again")


def _by_columns(matrix: Any) -> bool:
    """Whether ``matrix`` is stored by columns: a chunked HDF5 dataset, a Fortran-ordered array (a transposed
    ``.npy``), or a lazily transposed one (``core.arrays.Transposed``, a MATLAB v7.3 variable)."""
    return (getattr(matrix, "chunks", None) is not None
            or bool(getattr(getattr(matrix, "flags", None), "f_contiguous", False))
            or bool(getattr(matrix, "column_major", False)))


def _blocks(matrix: Any) -> Iterator[tuple[slice, slice]]:
    """Blocks of about ``SCAN_VALUES`` values in the matrix's storage order (``_by_columns``): whole chunk columns of
    a chunked HDF5 dataset, column blocks of a matrix stored by columns, row blocks otherwise."""
    n_rows, n_cols = matrix.shape
    chunks = getattr(matrix, "chunks", None)
    if _by_columns(matrix) and n_rows:
        unit = chunks[1] if chunks is not None else 1
        step = max(unit, SCAN_VALUES // n_rows // unit * unit)
        for start in range(0, n_cols, step):
            yield slice(None), slice(start, start + step)
    else:
        step = max(1, SCAN_VALUES // max(n_cols, 1))
        for start in range(0, n_rows, step):
            yield slice(start, start + step), slice(None)


def check_non_negative(path: Path | str, matrix: Any) -> None:
    """Raise ValueError naming ``path``, the count and minimum of the negative values and the fix, when the matrix
    has any beyond float rounding: method §5 divides each query column by its maximum, which presumes distances >= 0.
    Squared L2 and cosine distances of (nearly) identical descriptors come out about -1e-6 in float32 (faiss, as
    in the authors' code): values down to ``-NEGATIVE_ROUNDING`` times the largest magnitude pass unchanged.
    One pass in blocks; NaN passes here (the attributes stage names it)."""
    if matrix.dtype.kind == "u" or matrix.size == 0:
        return
    # The blocks' minima alone decide the common case, no value below 0, in one reduction per block; the magnitudes
    # that bound float rounding are read only when a minimum is negative or NaN (NaN fails the comparison).
    if all(float(np.asarray(matrix[rows, cols]).min()) >= 0 for rows, cols in _blocks(matrix)):
        return
    count, minimum, largest = 0, 0.0, 0.0
    for rows, cols in _blocks(matrix):
        block = np.asarray(matrix[rows, cols])
        # two reductions decide a block; a mask of the finite values is built only where NaN or inf make them
        # non-finite (a mask and a copy per block took longer than sequence matching a 9000 x 9000 matrix)
        low, high = float(block.min()), float(block.max())
        if not (np.isfinite(low) and np.isfinite(high)):
            block = block[np.isfinite(block)]
            if not block.size:
                continue
            low, high = float(block.min()), float(block.max())
        largest = max(largest, abs(low), abs(high))
        if low < 0:
            count += int(np.count_nonzero(block < 0))
            minimum = min(minimum, low)
    if count == 0 or minimum >= -NEGATIVE_ROUNDING * largest:
        return
    option = "give --similarity (read as distances max(M) - M), or " if is_user_matrix(path) else ""
    raise ValueError(
        f"{path}: {count} negative values in the distance matrix (minimum {minimum:.6g}); distances must be >= 0 "
        "(smaller = more similar; the attributes divide each query column by its maximum). If these are "
        f"similarities (larger = more similar), {option}turn them into distances first, e.g. D = 1 - S for the "
        "cosine similarity of L2-normalised descriptors, or D = S.max() - S")


def stored_positions(path: Path | str) -> tuple[np.ndarray, np.ndarray] | None:
    """The split's ``reference_positions`` and ``query_positions`` that a distance file of a dataset with positions
    holds (the distances stage copies them), or None (a frame-aligned split, or a user's matrix)."""
    path = Path(path)
    if is_user_matrix(path) or not h5py.is_hdf5(path):
        return None
    with open_h5(path, OUR_DISTANCES) as f:
        if "reference_positions" not in f and "query_positions" not in f:
            return None
        if "reference_positions" not in f or "query_positions" not in f:
            raise ValueError(f"{path} holds the positions of one traverse only: compute it again (vpr-smr distances)")
        return np.asarray(f["reference_positions"][()]), np.asarray(f["query_positions"][()])


def split_ranges(path: Path | str) -> tuple[tuple[int, int], tuple[int, int]] | None:
    """The dataset frames a distance file of vpr-smr covers: (its references' range, its queries' range), from its
    ``split_range`` (and ``reference_range`` when the distances stage was given one apart); None for a user's
    matrix."""
    path = Path(path)
    if is_user_matrix(path) or not h5py.is_hdf5(path):
        return None
    stored = read_provenance(path)
    if stored.get("split_range") is None:
        return None
    queries = (int(stored["split_range"][0]), int(stored["split_range"][1]))
    reference = stored.get("reference_range")
    return (queries if reference is None else (int(reference[0]), int(reference[1]))), queries


def fit_ground_truth(path: Path | str, shape: tuple[int, ...], truth: GroundTruth) -> GroundTruth:
    """The ground truth of a file (``truth``) for the matrix in ``path``: a matrix as it is when it has the matrix's
    shape (a matrix of the whole dataset would have at least the split's last frame); else sliced to the frames a
    distance file of vpr-smr covers (a split of the dataset whose frames the file's indices count), which per-query
    lists always are (they name frames, and their shape is only the largest index they name); per-query lists of a
    user's matrix sized to it when every pair lies in it. Errors name both files, both shapes and the fix."""
    shape = (int(shape[0]), int(shape[1]))
    lists = isinstance(truth, MatrixTruth) and truth.open_ended
    if truth.shape == shape and not lists:
        return truth
    ranges = split_ranges(path)
    if ranges is not None:
        (r_lo, r_hi), (q_lo, q_hi) = ranges
        if (r_hi - r_lo, q_hi - q_lo) != shape:
            raise ValueError(f"{path} is {shape[0]} x {shape[1]}, but it records references [{r_lo}, {r_hi}) and "
                             f"queries [{q_lo}, {q_hi}): compute it again (vpr-smr distances)")
        try:
            return truth.sliced((r_lo, r_hi), (q_lo, q_hi))
        except ValueError as error:
            raise ValueError(f"{path} covers references [{r_lo}, {r_hi}) and queries [{q_lo}, {q_hi}) of its "
                             f"dataset, but the ground truth {truth.describe()} is {truth.shape[0]} x {truth.shape[1]} "
                             f"(references x queries; {error}): give the ground truth of every frame of the "
                             "dataset, or of this split's") from None
    if isinstance(truth, MatrixTruth) and truth.open_ended:
        if truth.shape[0] <= shape[0] and truth.shape[1] <= shape[1]:
            return truth.sized(shape)
        raise ValueError(f"{path} is {shape[0]} x {shape[1]} (references x queries), but the ground truth "
                         f"{truth.describe()} names references up to {truth.shape[0] - 1} and queries up to "
                         f"{truth.shape[1] - 1}: give the ground truth of this matrix's frames (indices from 0), or "
                         "the matrix of the frames it names")
    try:
        truth.check_shape(shape)
    except ValueError as error:
        raise ValueError(f"{path}: {error}") from None
    return truth


def split_ground_truth(path: Path | str, shape: tuple[int, ...], tolerance: int, radius: float | None = None,
                       reference_positions: Path | str | None = None,
                       query_positions: Path | str | None = None, ground_truth: GroundTruth | None = None
                       ) -> GroundTruth:
    """The ground truth of the matrix in ``path`` (method §§1 and 11): a ground-truth file's (``ground_truth``, read
    by ``ground_truth_files.read_ground_truth``; ``fit_ground_truth``); else the positions files given (``.npy`` or
    CSV, one position per frame), else the positions the distance file holds, each within ``radius``; else frame
    indices within ``tolerance``. Errors name the option or file and the fix."""
    if ground_truth is not None:
        if radius is not None or reference_positions is not None or query_positions is not None:
            raise ValueError(f"--ground-truth {ground_truth.describe()} and positions (--reference-positions, "
                             "--query-positions, --radius) are two ground truths: give one of them")
        return fit_ground_truth(path, shape, ground_truth)
    if (reference_positions is None) != (query_positions is None):
        raise ValueError("give both --reference-positions and --query-positions (one position per frame of each "
                         "traverse), or neither")
    where = "the positions"
    if reference_positions is not None and query_positions is not None:
        positions: tuple[np.ndarray, np.ndarray] | None = (read_positions(reference_positions),
                                                            read_positions(query_positions))
        where = f"{reference_positions} and {query_positions}"
    else:
        positions = stored_positions(path)
        where = f"the positions stored in {path}"
    if positions is None:
        if radius is not None:
            raise ValueError(f"--radius {radius} needs positions (--reference-positions and --query-positions, or a "
                             f"distance file of a dataset with positions); {path} is frame-aligned: its ground "
                             "truth is --tolerance frames")
        if shape[0] != shape[1]:  # |r - q| <= tolerance means nothing for traverses of different lengths
            raise ValueError(f"{path} is a {shape[0]} x {shape[1]} matrix (references x queries) without positions: "
                             "a frame-aligned ground truth (a match r of query q is correct when |r - q| <= "
                             "tolerance) needs as many references as queries. Give the positions of both traverses "
                             "(--reference-positions and --query-positions, one per frame) and --radius (for "
                             "traverses of different lengths whose frame i shows the same place, positions 0, 1, 2, "
                             "... and --radius equal to the tolerance)")
        return GroundTruth.aligned(shape[0], shape[1], tolerance)
    if radius is None:
        raise ValueError(f"{where}: a ground truth from positions needs --radius (in the positions' unit, e.g. "
                         "metres): a match is correct within that distance of the query's position")
    truth = GroundTruth.positions(positions[0], positions[1], radius)
    try:
        truth.check_shape(shape)
    except ValueError as error:
        raise ValueError(f"{path} and {where}: {error}") from None
    return truth


# A matrix reads as similarities when, for at least this share of the queries, the correct references' values are
# larger on average than the others'. Measured on the Nordland sample's SAD, HOG and EfficientNet matrices (every
# split): 4-20 % of the queries as distances, 80-96 % as their similarities max(D) - D, even where recall@1 is 2.5 %;
# a matrix of noise sits near 50 %.
SIMILARITY_SHARE = 2 / 3
# The test reads at most this many queries, evenly spaced: a share needs no more (its standard error over 256
# queries is at most 3 points, against shares of 4-20 % and 80-96 %), and reading every column of a 9000 x 9000
# matrix took longer than its sequence matching (512 columns: 45-60 ms, reading them dominates).
SIMILARITY_SAMPLE = 256


def similarity_evidence(matrix: Any, truth: GroundTruth, block_queries: int = 256) -> tuple[int, int, int, int]:
    """Over the queries with correct and wrong references (every query, or ``SIMILARITY_SAMPLE`` evenly spaced
    ones of a larger matrix): how many there are, for how many the correct references' mean value is larger than the
    wrong ones', and for how many the column's largest and its smallest value is a correct reference (first index on
    ties). Read in blocks of ``block_queries`` columns."""
    n_ref, n_query = (int(n) for n in matrix.shape)
    # sorted and without repeats, as np.unique gives them (which imports numpy.ma on first use: 5-15 ms)
    sample = np.array(sorted(set(np.linspace(0, n_query - 1, min(n_query, SIMILARITY_SAMPLE)).round()
                                 .astype(np.int64).tolist())), dtype=np.int64)
    counted = larger = at_max = at_min = 0
    for start in range(0, len(sample), block_queries):
        queries = sample[start : start + block_queries]
        values = np.asarray(matrix[:, queries], dtype=np.float64)
        correct = truth.columns(queries)
        n_correct = correct.sum(axis=0)
        both = (n_correct > 0) & (n_correct < n_ref) & np.isfinite(values).all(axis=0)
        if not both.any():
            continue
        if not both.all():  # a copy of the block only where some of its queries do not count
            values, correct, n_correct = values[:, both], correct[:, both], n_correct[both]
        mean_correct = np.where(correct, values, 0.0).sum(axis=0) / n_correct
        mean_wrong = np.where(correct, 0.0, values).sum(axis=0) / (n_ref - n_correct)
        columns = np.arange(values.shape[1])
        counted += int(both.sum())
        larger += int(np.count_nonzero(mean_correct > mean_wrong))
        at_max += int(np.count_nonzero(correct[np.argmax(values, axis=0), columns]))
        at_min += int(np.count_nonzero(correct[np.argmin(values, axis=0), columns]))
    return counted, larger, at_max, at_min


def warn_if_similar(path: Path | str, matrix: Any, truth: GroundTruth, similarity: bool) -> None:
    """Log ``similarity_warning`` for a user's matrix read as distances (the stages' own files are distances)."""
    if not similarity and is_user_matrix(path):
        warning = similarity_warning(path, matrix, truth)
        if warning:
            log.warning(warning)


def similarity_warning(path: Path | str, matrix: Any, truth: GroundTruth) -> str | None:
    """A warning naming ``path`` and ``--similarity`` when the matrix reads as similarities (``SIMILARITY_SHARE``
    of the queries with larger values on their correct references than on the others), else None."""
    counted, larger, at_max, at_min = similarity_evidence(matrix, truth)
    if counted == 0 or larger < SIMILARITY_SHARE * counted:
        return None
    sampled = "" if matrix.shape[1] <= SIMILARITY_SAMPLE else f" (an even sample of its {matrix.shape[1]})"
    return (f"{path} looks like a similarity matrix (larger = more similar), not distances: for {larger} of its "
            f"{counted} queries{sampled} ({100 * larger / counted:.0f} %) the correct references' values are larger on "
            f"average than the others' (distances are smaller there), and a column's largest value is a correct "
            f"reference for {at_max} queries, its smallest for {at_min}. If it holds similarities, give --similarity "
            "(read as distances max(M) - M); it is scored as distances here")
