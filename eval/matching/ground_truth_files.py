"""Ground truth as the field writes it, read into one ``GroundTruth`` (kind ``matrix``):

- a boolean (or 0/1) ``R x Q`` matrix: a ``.npy``, an ``.npz`` array or a ``.mat`` variable (v5 or v7.3, e.g.
  VPR_Tutorial's ``GThard``, database x queries), reference ``r`` of query ``q`` correct iff ``G[r, q]``;
- per-query lists of correct references: a JSON object ``{"q": [r, ...]}``, a CSV with the header
  ``query,reference`` and one row per correct pair, or VPR-Bench's ``ground_truth_new.npy`` (an array of objects,
  one ``[query, [references]]`` row per query), whose pickle is read by ``core.pickles.ArraysOnlyUnpickler``: it
  builds NumPy arrays, lists, tuples and numbers only, and refuses anything else by name without running it.

Lists name the correct pairs only, not how many frames there are: their matrix is the smallest that holds every
pair, and a query they do not name has no correct reference. Every error names the file and the fix.

Every reader is bounded (method §13.2) by the matrix the file scores, when the caller knows it (the workflow's check
before its first job; a command's matrices, from their headers: ``io.scored_shape``), else by ``MAX_TRUTH_CELLS``:
a matrix's declared shape is checked before its data is read (a compressed one may inflate to that many cells),
lists index by index as they are read (a ``range`` by its length and ends, never expanded), VPR-Bench's rows and
bytes before its pickle is read, and the pickle's arrays and lists by ``core.pickles``' budget (of that matrix's
lists, or of the file's size) as it is read.
"""

from __future__ import annotations

import array
import csv
import hashlib
import json
import math
import numbers
from collections import Counter
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from vpr_smr.core.arrays import Variable, choose, open_array, variables
from vpr_smr.core.files import EMPTY, NPY, TEXT, file_kind, mat_version, npy_header, read_head, what_it_is
from vpr_smr.core.io import CSV_SUFFIXES, JSON_SUFFIXES
from vpr_smr.core.pickles import BUILT_SLACK, REFERENCE_BYTES, PickleTooLarge, RefusedPickle, load_object_npy
from vpr_smr.eval.matching.ground_truth import MAX_TRUTH_CELLS, GroundTruth, MatrixTruth, TruthSource

__all__ = ["GROUND_TRUTH_SUFFIXES", "file_sha256", "read_ground_truth"]

GROUND_TRUTH_SUFFIXES = (".npy", ".npz", ".mat", *JSON_SUFFIXES, *CSV_SUFFIXES)
MATRIX_WHAT = "a boolean ground-truth matrix (references x queries)"
FORMATS = ("a boolean R x Q matrix (.npy, .npz, .mat), per-query lists as a JSON object {\"query\": [reference, "
           "...]}, a CSV with the header query,reference, or VPR-Bench's ground_truth_new.npy")
SAFE_SAVE = ("save it as a boolean matrix (numpy.save('gt.npy', G), G[r, q] true when reference r is correct for "
             "query q) or as per-query lists in JSON")


def file_sha256(path: Path | str) -> str:
    """The SHA-256 of a file's bytes, read in 1 MB pieces."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for piece in iter(lambda: handle.read(1 << 20), b""):
            digest.update(piece)
    return digest.hexdigest()


# The most bytes per-query lists in VPR-Bench's pickled form take per query and per correct reference, however they
# are written (Python 2 or 3, protocol 0 to 5; lists of ints, of NumPy scalars or NumPy arrays: measured at most 140
# bytes per row and 50 per reference), with room to spare: a larger file cannot be the lists of the matrix it scores.
PICKLE_BYTES_PER_QUERY = 1024
PICKLE_BYTES_PER_REFERENCE = 256
PICKLE_BYTES_SLACK = 1 << 16
# The most references listed one by one (not as a range) that a file may name per byte of it, plus LISTED_SLACK: each
# takes at least a byte of a file unless a pickle repeats one list for many queries (through its memo). Bounds the
# time spent on the lists by the file's size.
LISTED_PER_BYTE = 8
LISTED_SLACK = 1 << 20

References = range | list[int] | np.ndarray  # a query's references: a range, indices, or int64 indices (pairs)
# a query, its references as the file holds them, and a label from which ``_Bounds.what`` names them in errors (a
# row's number, a JSON key: not a text per row, which would take more memory than the row)
Listed = tuple[Any, Any, Any]


class _Named(ValueError):
    """An error whose message names the file already."""


class _Bounds:
    """What per-query lists may name: indices within the matrix they score (``shape``, references x queries), or,
    where it is not known, within ``MAX_TRUTH_CELLS`` cells. Each query's references are checked as they are read,
    before anything of their size is built; ``top`` is the largest query and reference named."""

    def __init__(self, path: Path, shape: tuple[int, int] | None) -> None:  # shape: the largest matrix it scores
        self.path, self.shape = path, shape
        self.top = [-1, -1]  # the largest reference, query
        self.pairs = self.listed = 0
        self.what: Callable[[Any, Any], str] = lambda label, query: f"query {query}'s references"  # label, query
        self.most_listed = LISTED_PER_BYTE * path.stat().st_size + LISTED_SLACK

    def most(self, axis: int) -> int:
        """How many references (0) or queries (1) there may be."""
        return MAX_TRUTH_CELLS if self.shape is None else self.shape[axis]

    def limit(self, axis: int) -> str:
        """The limit on ``axis`` in words, for errors."""
        if self.shape is None:
            return (f"the {MAX_TRUTH_CELLS} cells (references x queries) vpr-smr reads from a ground truth when the "
                    "matrix it scores is not known")
        return f"the matrix has {self.shape[axis]} {('references', 'queries')[axis]} (0..{self.shape[axis] - 1})"

    @property
    def fix(self) -> str:
        return ("give the ground truth of the matrix's frames" if self.shape is not None else
                "give the ground truth of the distance matrices' frames (indices from 0)")

    def beyond(self, name: str, value: int, query: Any, reference: Any, axis: int) -> _Named:
        return _Named(f"{self.path} names {name} {value} (the pair query {query}, reference {reference}), but "
                      f"{self.limit(axis)}: {self.fix}")

    def references(self, value: Any, what: str) -> References:
        """A query's correct references: a list, tuple, range or 1-D array of indices, or a single index; a list
        longer than the matrix has references is refused before it is converted, a range is never expanded."""
        if isinstance(value, np.ndarray):
            if value.ndim > 1:
                raise ValueError(f"{what} is an array of shape {value.shape}, not a list of frame indices")
            if value.ndim == 0:
                value = value.item()
        if not isinstance(value, range | list | tuple | np.ndarray):
            return [_index(value, what)]
        if len(value) > self.most(0):
            shown = f" ({value!r})" if isinstance(value, range) else ""
            raise ValueError(f"{what}{shown} number {len(value)}, more than {self.limit(0)}: a query's list names "
                             f"each correct reference once; {self.fix}")
        if isinstance(value, range):
            if len(value) and min(value[0], value[-1]) < 0:
                raise ValueError(f"{what} is {value!r}, whose indices are not all frame indices (integers >= 0)")
            return value
        if isinstance(value, np.ndarray) and value.dtype.kind in "iu" and (not len(value) or value.min() >= 0):
            return value.astype(np.int64)
        items = value.tolist() if isinstance(value, np.ndarray) else value
        if all(type(item) is int and item >= 0 for item in items):  # the usual case, without a text per item
            return list(items)
        return [_index(item, f"{what}, item {i}") for i, item in enumerate(items)]

    def rows(self, listed: Iterable[Listed]) -> Iterator[tuple[Any, References]]:
        """The rows read and checked (``references``, ``add``), each converted again as the matrix is built, so
        that no more than one query's list exists at a time, however often a pickle repeats one; pairs (an array of
        queries, checked line by line) as they are."""
        for query, value, label in listed:
            yield (query, value) if isinstance(query, np.ndarray) else (
                query, self.references(value, self.what(label, query)))

    def add(self, query: int | np.ndarray, references: References) -> None:
        """Count a query's (or an array of queries') references, refusing the first index the matrix cannot hold
        and, where the matrix is not known, a file implying more than ``MAX_TRUTH_CELLS`` cells or pairs."""
        queries, top_query = (None, query) if not isinstance(query, np.ndarray) else (
            query, int(query.max()) if len(query) else -1)
        if top_query >= self.most(1):
            at = 0 if queries is None else int(np.argmax(queries))
            reference = references if isinstance(references, range) else (
                list(references[:1]) or "none" if queries is None else references[at])
            raise self.beyond("query", top_query, top_query, reference, 1)
        if len(references):
            if isinstance(references, range):
                top = max(references[0], references[-1])
            else:
                top = max(references) if isinstance(references, list) else int(references.max())
            if top >= self.most(0):
                at = 0 if queries is None else int(np.argmax(references))
                raise self.beyond("reference", top, query if queries is None else queries[at], top, 0)
            self.top[0] = max(self.top[0], top)
        self.top[1] = max(self.top[1], top_query)
        self.pairs += len(references)
        if not isinstance(references, range):
            self.listed += len(references)
            if self.listed > self.most_listed:
                size = self.path.stat().st_size
                raise _Named(f"{self.path} lists more than {self.most_listed} references one by one, more than its "
                             f"{size} bytes hold ({LISTED_PER_BYTE} per byte, plus {LISTED_SLACK}): a pickle repeating "
                             "one list for many queries is not read; give each query its own list, or a range")
        if self.shape is None and max(self.pairs, (self.top[0] + 1) * (self.top[1] + 1)) > MAX_TRUTH_CELLS:
            raise _Named(f"{self.path} names references up to {self.top[0]} and queries up to {self.top[1]} "
                         f"({self.pairs} pairs so far), more than {self.limit(0)} ({MAX_TRUTH_CELLS // 8 >> 20} MiB "
                         f"as bits): {self.fix}")


def _index(value: Any, what: str) -> int:
    """``value`` as a frame index: an integer (an int, a NumPy integer, or an integral float) >= 0."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        raise ValueError(f"{what} is {value!r}, not a frame index (an integer >= 0)")
    number = float(value)
    if not number.is_integer() or number < 0:
        raise ValueError(f"{what} is {value!r}, not a frame index (an integer >= 0)")
    return int(number)


def _json_lists(path: Path, bounds: _Bounds) -> Callable[[], Iterator[Listed]]:
    def unique(items: list[tuple[str, Any]]) -> dict[str, Any]:
        repeated = sorted(key for key, n in Counter(key for key, _ in items).items() if n > 1)
        if repeated:
            raise ValueError(f"query {repeated[0]!r} is given twice: give each query once, with all its references")
        return dict(items)

    try:
        data = json.loads(path.read_text(encoding="utf-8"), object_pairs_hook=unique)
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise ValueError(f"not valid JSON ({error})") from None
    if not isinstance(data, dict):
        raise ValueError(f"holds a JSON {type(data).__name__}, not an object of per-query lists "
                         '{"query": [reference, ...], ...}')
    bounds.what = lambda key, query: f"query {key!r}'s references"

    def listed() -> Iterator[Listed]:
        for key, value in data.items():
            try:
                query = int(key.strip())
            except ValueError:
                raise ValueError(f"its key {key!r} is not a query index (the keys are query frame indices, e.g. "
                                 '"12")') from None
            yield _index(query, f"query {key!r}"), value, key

    for query, value, key in listed():
        bounds.add(query, bounds.references(value, bounds.what(key, query)))
    return listed


def _csv_pairs(path: Path, bounds: _Bounds) -> Callable[[], Iterator[Listed]]:
    queries, references = array.array("q"), array.array("q")
    with path.open(newline="", encoding="utf-8") as handle:
        reader = csv.reader(handle)
        header = [cell.strip().lower() for cell in next(reader, [])]
        if sorted(header) != ["query", "reference"]:
            raise ValueError(f"its first line is {','.join(header)!r}, not the header query,reference: give one row "
                             "per correct pair under that header")
        query_column, reference_column = header.index("query"), header.index("reference")
        for line, row in enumerate(reader, start=2):
            if not any(cell.strip() for cell in row):
                continue
            if len(row) != 2:
                raise ValueError(f"line {line}: {','.join(row)!r} is not a pair query,reference")
            try:
                query = _index(float(row[query_column]), f"line {line}: the query")
                reference = _index(float(row[reference_column]), f"line {line}: the reference")
            except ValueError as error:
                raise ValueError(str(error) if "frame index" in str(error) else
                                 f"line {line}: {','.join(row)!r} is not a pair of frame indices") from None
            bounds.add(query, [reference])
            queries.append(query)
            references.append(reference)
    pairs = (np.array(queries, dtype=np.int64), np.array(references, dtype=np.int64), None)
    return lambda: iter([pairs])


def _once(queries: np.ndarray) -> None:
    """Refuse rows giving a query twice, naming the first repetition (in 8 bytes per row, not a dict of rows)."""
    order = np.argsort(queries, kind="stable")
    repeated = np.flatnonzero(queries[order][1:] == queries[order][:-1])
    if len(repeated):
        at = repeated[np.argmin(order[repeated + 1])]  # the earliest second row of a query, after its first
        first, second = int(order[at]), int(order[at + 1])
        raise ValueError(f"rows {first} and {second} both give query {queries[second]}: give each query once")


def _vpr_bench_lists(path: Path, bounds: _Bounds) -> Callable[[], Iterator[Listed]]:
    """VPR-Bench's rows ``[query, references]`` (its own code reads ``row[1]`` as the list of correct references;
    the query is ``row[0]``). A file with more rows than the matrix has queries, or larger than such lists can be,
    is refused before its pickle is read."""
    n_rows = npy_header(path, MATRIX_WHAT).shape[:1] or (1,)
    if n_rows[0] > bounds.most(1):
        raise ValueError(f"its header says {n_rows[0]} rows, but {bounds.limit(1)}: one row per query; {bounds.fix}")
    if bounds.shape is not None:
        n_reference, n_query = bounds.shape
        most = PICKLE_BYTES_SLACK + n_query * (PICKLE_BYTES_PER_QUERY + n_reference * PICKLE_BYTES_PER_REFERENCE)
        size = path.stat().st_size
        if size > most:
            raise ValueError(f"it is {size} bytes, more than per-query lists of the {n_reference} x {n_query} matrix "
                             f"it scores can take ({most} bytes: {PICKLE_BYTES_PER_QUERY} per query and "
                             f"{PICKLE_BYTES_PER_REFERENCE} per reference, every reference correct for every query): "
                             "give the ground truth of the matrix's frames")
    # the lists of an R x Q matrix hold at most Q rows of R references (and a query index) each
    limit = None if bounds.shape is None else (
        REFERENCE_BYTES * bounds.shape[1] * (bounds.shape[0] + 4) + BUILT_SLACK,
        f"per-query lists of the {bounds.shape[0]} x {bounds.shape[1]} matrix it scores can take ({REFERENCE_BYTES} "
        f"per reference of every query, plus {BUILT_SLACK})")
    try:
        rows = load_object_npy(path, "VPR-Bench's ground truth (rows of [query, [references]])", limit=limit)
    except RefusedPickle as refused:
        raise ValueError(f"its pickle names {refused.args[0]}, which vpr-smr refuses to build: a ground truth holds "
                         "NumPy arrays, lists, tuples and numbers only, and nothing of this file was run; "
                         f"{SAFE_SAVE}") from None
    except PickleTooLarge as large:
        raise ValueError(f"its pickle {large.args[0]}: it is not a ground truth, and it was refused before being "
                         f"built; {SAFE_SAVE}") from None
    if not (rows.ndim == 1 or (rows.ndim == 2 and rows.shape[1] == 2)):
        raise ValueError(f"holds an array of objects of shape {rows.shape}, not VPR-Bench's rows of "
                         "[query, [references]]")
    bounds.what = lambda number, query: f"row {number} (query {query}): the references"

    def listed() -> Iterator[Listed]:
        for number, row in enumerate(rows):  # a 1-D array holds [query, references] items, a 2-D one rows of two
            if not (isinstance(row, np.ndarray | list | tuple) and len(row) == 2):
                raise ValueError(f"row {number} is {row!r}, not [query, [references]]")
            yield _index(row[0], f"row {number}: the query"), row[1], number

    queries = array.array("q")
    for query, value, number in listed():
        bounds.add(query, bounds.references(value, bounds.what(number, query)))
        queries.append(query)
    _once(np.array(queries, dtype=np.int64))
    return listed


def _lists(path: Path, head: bytes, bounds: _Bounds) -> tuple[Callable[[], Iterator[Listed]], str]:
    """The rows of a lists file as it holds them (read again by each call: nothing per row is kept), each checked
    against ``bounds`` as it is read, and its form."""
    suffix = path.suffix.lower()
    if suffix == ".npy":
        return _vpr_bench_lists(path, bounds), "vpr-bench lists"
    if file_kind(head) != TEXT:
        raise ValueError(f"is {what_it_is(head)}, not a {suffix[1:].upper()} text file")
    if suffix in JSON_SUFFIXES:
        return _json_lists(path, bounds), "json lists"
    return _csv_pairs(path, bounds), "csv pairs"


def _check_declared(path: Path, key: str | None, shape: tuple[int, int] | None, key_option: str) -> None:
    """Refuse a matrix whose shape, as its file declares it (a header, without reading the data), has more cells than
    the matrix it scores (``shape``), or than ``MAX_TRUTH_CELLS`` where that is not known."""
    try:
        declared = (Variable("", npy_header(path, MATRIX_WHAT).shape, "", True) if path.suffix.lower() == ".npy"
                    else choose(path, variables(path), key, MATRIX_WHAT, key_option))
    except ValueError:
        return  # open_array says what is wrong, with the same words
    cells = math.prod(declared.shape)
    most = MAX_TRUTH_CELLS if shape is None else shape[0] * shape[1]
    if len(declared.shape) != 2 or cells <= most:
        return
    name = f" {declared.name!r}" if declared.name else ""
    dims = " x ".join(map(str, declared.shape))
    if shape is not None:
        raise ValueError(f"{path}: its matrix{name} is {dims} ({cells} cells, as the file declares it), more than the "
                         f"{shape[0]} x {shape[1]} matrix it scores: give the ground truth of the matrix's frames "
                         "(references x queries); nothing of it was read")
    raise ValueError(f"{path}: its matrix{name} is {dims} ({cells} cells, as the file declares it), more than the "
                     f"{MAX_TRUTH_CELLS} cells (references x queries) vpr-smr reads from a ground truth when the "
                     "matrix it scores is not known: give the ground truth of the distance matrices' frames; nothing "
                     "of it was read")


def read_ground_truth(path: Path | str, key: str | None = None, shape: tuple[int, int] | None = None,
                      key_option: str = "--ground-truth-key", within: tuple[int, int] | None = None) -> GroundTruth:
    """The ground truth in ``path`` (see the module's docstring), its provenance the file's name, SHA-256, form and
    ``key``. ``key``: the variable of an ``.npz`` or ``.mat`` (default: its only 2-D numeric array). ``shape``
    (references, queries): the matrix it must score, checked here (a matrix's own shape must be it; lists are
    sized to it and every index must lie in it); None: a matrix keeps its shape, lists get the smallest that holds
    them and may be sliced past it, each within ``within`` (the largest matrix it may score, when known without
    sizing it to it: ``io.scored_shape``) or ``MAX_TRUTH_CELLS`` cells. A matrix declaring more cells, or lists
    naming an index beyond it, are refused before anything of that size is built (method §13.2); a compressed matrix
    within it is inflated whatever its ratio. Raises
    FileNotFoundError or ValueError naming the file, what was found, the limit and the fix; never runs anything a
    file holds."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"ground truth not found: {path}")
    suffix = path.suffix.lower()
    if suffix not in GROUND_TRUTH_SUFFIXES:
        raise ValueError(f"{path}: a ground truth is {FORMATS}, not {suffix or 'a file without a suffix'}")
    head = read_head(path)
    if file_kind(head) == EMPTY:
        raise ValueError(f"{path} is empty (0 bytes): write it again ({FORMATS})")
    lists = suffix in JSON_SUFFIXES + CSV_SUFFIXES or (
        suffix == ".npy" and file_kind(head) == NPY and npy_header(path, MATRIX_WHAT).dtype.hasobject)
    if lists and key is not None:
        raise ValueError(f"{key_option} {key}: {path} holds per-query lists, not variables; leave {key_option} out")
    bound = shape or within
    sha256 = file_sha256(path)
    if not lists:
        form = {".npy": "npy matrix", ".npz": "npz matrix"}.get(suffix) or (
            "mat v7.3 matrix" if mat_version(head) == "7.3" else "mat v5 matrix")
        _check_declared(path, key, bound, key_option)
        # a compressed matrix may inflate to the matrix it scores, or, not known, to what a dataset's ground truth
        # may be (a boolean matrix: Nordland's compressed GThard inflates 300-fold, past open_array's ratio)
        known = MAX_TRUTH_CELLS if bound is None else bound[0] * bound[1]
        with open_array(path, key, what=MATRIX_WHAT, key_option=key_option, known_values=known) as matrix:
            try:
                truth = GroundTruth.matrix(matrix, TruthSource(str(path), sha256, form, key))
            except ValueError as error:
                raise ValueError(f"{path}: {error}: {SAFE_SAVE}") from None
        if shape is not None:
            try:
                truth.check_shape(shape)
            except ValueError as error:
                raise ValueError(f"{path}: {error}") from None
        return truth
    bounds = _Bounds(path, bound)
    try:
        rows, form = _lists(path, head, bounds)
    except _Named:
        raise
    except ValueError as error:
        raise ValueError(f"{path}: {error}") from None
    if not bounds.pairs:
        raise ValueError(f"{path} names no correct pair (query, reference): every query would be wrong; give each "
                         "query's correct references")
    source = TruthSource(str(path), sha256, form)
    if shape is not None:
        return MatrixTruth.of_rows(bounds.rows(rows()), shape, source)
    return MatrixTruth.of_rows(bounds.rows(rows()), (bounds.top[0] + 1, bounds.top[1] + 1), source, open_ended=True)
