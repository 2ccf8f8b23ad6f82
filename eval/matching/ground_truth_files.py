"""Ground truth as the field writes it, read into one ``GroundTruth`` (kind ``matrix``):

- a boolean (or 0/1) ``R x Q`` matrix: a ``.npy``, an ``.npz`` array or a ``.mat`` variable (v5 or v7.3, e.g.
  VPR_Tutorial's ``GThard``, database x queries), reference ``r`` of query ``q`` correct iff ``G[r, q]``;
- per-query lists of correct references: a JSON object ``{"q": [r, ...]}``, a CSV with the header
  ``query,reference`` and one row per correct pair, or VPR-Bench's ``ground_truth_new.npy`` (an array of objects,
  one ``[query, [references]]`` row per query), whose pickle is read by ``core.pickles.ArraysOnlyUnpickler``: it
  builds NumPy arrays, lists, tuples and numbers only, and refuses anything else by name without running it.

Lists name the correct pairs only, not how many frames there are: their matrix is the smallest that holds every
pair, and a query they do not name has no correct reference. Every error names the file and the fix.
"""

from __future__ import annotations

import csv
import hashlib
import json
import numbers
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from vpr_smr.core.arrays import open_array
from vpr_smr.core.files import EMPTY, NPY, TEXT, file_kind, mat_version, npy_header, read_head, what_it_is
from vpr_smr.core.io import CSV_SUFFIXES, JSON_SUFFIXES
from vpr_smr.core.pickles import RefusedPickle, load_object_npy
from vpr_smr.eval.matching.ground_truth import GroundTruth, TruthSource

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


def _index(value: Any, what: str) -> int:
    """``value`` as a frame index: an integer (an int, a NumPy integer, or an integral float) >= 0."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        raise ValueError(f"{what} is {value!r}, not a frame index (an integer >= 0)")
    number = float(value)
    if not number.is_integer() or number < 0:
        raise ValueError(f"{what} is {value!r}, not a frame index (an integer >= 0)")
    return int(number)


def _references(value: Any, what: str) -> list[int]:
    """A query's correct references: a list, tuple, range or 1-D array of indices, or a single index."""
    if isinstance(value, np.ndarray):
        if value.ndim > 1:
            raise ValueError(f"{what} is an array of shape {value.shape}, not a list of frame indices")
        value = value.tolist() if value.ndim == 1 else value.item()
    if isinstance(value, list | tuple | range):
        return [_index(item, f"{what}, item {i}") for i, item in enumerate(value)]
    return [_index(value, what)]


def _pairs(rows: Iterable[tuple[int, list[int]]]) -> tuple[np.ndarray, np.ndarray]:
    queries: list[int] = []
    references: list[int] = []
    for query, correct in rows:
        queries.extend([query] * len(correct))
        references.extend(correct)
    return np.array(queries, dtype=np.int64), np.array(references, dtype=np.int64)


def _json_lists(path: Path) -> tuple[np.ndarray, np.ndarray, int]:
    def unique(items: list[tuple[str, Any]]) -> dict[str, Any]:
        keys = [key for key, _ in items]
        repeated = sorted({key for key in keys if keys.count(key) > 1})
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
    rows = []
    for key, value in data.items():
        try:
            query = int(key.strip())
        except ValueError:
            raise ValueError(f"its key {key!r} is not a query index (the keys are query frame indices, e.g. "
                             '"12")') from None
        rows.append((_index(query, f"query {key!r}"), _references(value, f"query {key!r}'s references")))
    queries, references = _pairs(rows)
    return queries, references, max((query for query, _ in rows), default=-1) + 1


def _csv_pairs(path: Path) -> tuple[np.ndarray, np.ndarray, int]:
    with path.open(newline="", encoding="utf-8") as handle:
        reader = csv.reader(handle)
        header = [cell.strip().lower() for cell in next(reader, [])]
        if sorted(header) != ["query", "reference"]:
            raise ValueError(f"its first line is {','.join(header)!r}, not the header query,reference: give one row "
                             "per correct pair under that header")
        query_column, reference_column = header.index("query"), header.index("reference")
        queries, references = [], []
        for line, row in enumerate(reader, start=2):
            if not any(cell.strip() for cell in row):
                continue
            if len(row) != 2:
                raise ValueError(f"line {line}: {','.join(row)!r} is not a pair query,reference")
            try:
                queries.append(_index(float(row[query_column]), f"line {line}: the query"))
                references.append(_index(float(row[reference_column]), f"line {line}: the reference"))
            except ValueError as error:
                raise ValueError(str(error) if "frame index" in str(error) else
                                 f"line {line}: {','.join(row)!r} is not a pair of frame indices") from None
    return (np.array(queries, dtype=np.int64), np.array(references, dtype=np.int64),
            max(queries, default=-1) + 1)


def _vpr_bench_lists(path: Path) -> tuple[np.ndarray, np.ndarray, int]:
    """VPR-Bench's rows ``[query, references]`` (its own code reads ``row[1]`` as the list of correct references;
    the query is ``row[0]``)."""
    try:
        array = load_object_npy(path, "VPR-Bench's ground truth (rows of [query, [references]])")
    except RefusedPickle as refused:
        raise ValueError(f"its pickle names {refused.args[0]}, which vpr-smr refuses to build: a ground truth holds "
                         "NumPy arrays, lists, tuples and numbers only, and nothing of this file was run; "
                         f"{SAFE_SAVE}") from None
    if not (array.ndim == 1 or (array.ndim == 2 and array.shape[1] == 2)):
        raise ValueError(f"holds an array of objects of shape {array.shape}, not VPR-Bench's rows of "
                         "[query, [references]]")
    read: list[tuple[int, list[int]]] = []
    seen: dict[int, int] = {}
    for number, row in enumerate(array):  # a 1-D array holds [query, references] items, a 2-D one rows of two
        if not (isinstance(row, np.ndarray | list | tuple) and len(row) == 2):
            raise ValueError(f"row {number} is {row!r}, not [query, [references]]")
        query = _index(row[0], f"row {number}: the query")
        if query in seen:
            raise ValueError(f"rows {seen[query]} and {number} both give query {query}: give each query once")
        seen[query] = number
        read.append((query, _references(row[1], f"row {number} (query {query}): the references")))
    queries, references = _pairs(read)
    return queries, references, max(seen, default=-1) + 1


def _lists(path: Path, head: bytes) -> tuple[np.ndarray, np.ndarray, int, str]:
    """The correct pairs of a lists file, the number of queries it names (one past the largest), and its form."""
    suffix = path.suffix.lower()
    if suffix == ".npy":
        return (*_vpr_bench_lists(path), "vpr-bench lists")
    if file_kind(head) != TEXT:
        raise ValueError(f"is {what_it_is(head)}, not a {suffix[1:].upper()} text file")
    if suffix in JSON_SUFFIXES:
        return (*_json_lists(path), "json lists")
    return (*_csv_pairs(path), "csv pairs")


def _within(path: Path, queries: np.ndarray, references: np.ndarray, shape: tuple[int, int]) -> None:
    for name, values, size in (("query", queries, shape[1]), ("reference", references, shape[0])):
        if len(values) and values.max() >= size:
            i = int(np.argmax(values))
            raise ValueError(f"{path} names {name} {values[i]} (the pair query {queries[i]}, reference "
                             f"{references[i]}), but the matrix has {size} {name}s (0..{size - 1}): give the ground "
                             "truth of the matrix's frames")


def read_ground_truth(path: Path | str, key: str | None = None, shape: tuple[int, int] | None = None,
                      key_option: str = "--ground-truth-key") -> GroundTruth:
    """The ground truth in ``path`` (see the module's docstring), its provenance the file's name, SHA-256, form and
    ``key``. ``key``: the variable of an ``.npz`` or ``.mat`` (default: its only 2-D numeric array). ``shape``
    (references, queries): the matrix it must score, checked here (a matrix's own shape must be it; lists are
    sized to it and every index must lie in it); None: a matrix keeps its shape, lists get the smallest that holds
    them and may be sliced past it. Raises FileNotFoundError or ValueError naming the file, what was found and the
    fix; never runs anything a file holds."""
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
    sha256 = file_sha256(path)
    if not lists:
        form = {".npy": "npy matrix", ".npz": "npz matrix"}.get(suffix) or (
            "mat v7.3 matrix" if mat_version(head) == "7.3" else "mat v5 matrix")
        with open_array(path, key, what=MATRIX_WHAT, key_option=key_option) as array:
            try:
                truth = GroundTruth.matrix(array, TruthSource(str(path), sha256, form, key))
            except ValueError as error:
                raise ValueError(f"{path}: {error}: {SAFE_SAVE}") from None
        if shape is not None:
            try:
                truth.check_shape(shape)
            except ValueError as error:
                raise ValueError(f"{path}: {error}") from None
        return truth
    try:
        queries, references, n_query, form = _lists(path, head)
    except ValueError as error:
        raise ValueError(f"{path}: {error}") from None
    if not len(queries):
        raise ValueError(f"{path} names no correct pair (query, reference): every query would be wrong; give each "
                         "query's correct references")
    if shape is not None:
        _within(path, queries, references, shape)
        return GroundTruth.pairs(queries, references, shape, TruthSource(str(path), sha256, form))
    smallest = (int(references.max()) + 1 if len(references) else 0, n_query)
    return GroundTruth.pairs(queries, references, smallest, TruthSource(str(path), sha256, form), open_ended=True)

