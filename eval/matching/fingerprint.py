"""What identifies a distance matrix, so that a predictor never scores the entries it was trained on: the SHA-256 of
its values and a content fingerprint that blocks cut from it share.

The fingerprint hashes every ``PATCH x PATCH`` patch of the values (float64 bit patterns, so equal values hash
equally wherever they sit) and keeps the hashes that are 0 modulo ``modulus``: anchors chosen by content, not by
position, so a block cut from the matrix keeps exactly the anchors of the patches it holds. A patch hash is the same
for the patch and its transpose (a matrix read with ``--transpose``), and constant patches are skipped (an all-zero
corner of one matrix says nothing about another's). ``modulus`` is the smallest power of two that keeps about
``MAX_ANCHORS`` anchors, so a file records at most about 130 kB whatever the matrix's size (a dataset: an HDF5
attribute of HDF5 1.x holds at most 64 kB); two matrices sharing a
region of ``a`` entries share about ``a / modulus`` anchors, and disjoint regions share none (but by a 64-bit hash
collision). A similarity matrix is fingerprinted as stored (``max(M) - M`` of a block differs from the whole's).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vpr_smr.core.records import Record
from vpr_smr.eval.matching.matcher import as_matrix, read_columns

PATCH = 4  # rows and columns of a hashed patch
MAX_ANCHORS = 16384  # anchors a matrix keeps, about: its modulus grows with its size
BLOCK_VALUES = 1 << 22  # values per block read (32 MB of float64)
# splitmix64's finaliser (hashes each value's bits) and odd weights of a patch's rows and columns (the format's)
_M1, _M2 = np.uint64(0xBF58476D1CE4E5B9), np.uint64(0x94D049BB133111EB)
_WEIGHTS = np.random.default_rng(20260407).integers(0, 2**63, size=PATCH, dtype=np.uint64) * np.uint64(2) + np.uint64(1)
with np.errstate(over="ignore"):  # arithmetic modulo 2**64
    _TOTAL = np.uint64(_WEIGHTS.sum() * _WEIGHTS.sum())


@dataclass(frozen=True)
class MatrixPrint(Record):
    """A matrix's identity: ``sha256`` of its float64 values (column by column, after its shape), its ``shape`` and
    its fingerprint, the sorted ``anchors`` (patch hashes that are 0 modulo ``modulus``)."""

    sha256: str
    shape: tuple[int, int]
    modulus: int
    anchors: tuple[int, ...] = field(repr=False)  # thousands of numbers: never in a message

    def shared(self, other: MatrixPrint) -> int:
        """How many anchors both hold (each counted once): > 0 when the matrices share entries."""
        return len(_among(np.asarray(self.anchors, np.uint64), np.asarray(other.anchors, np.uint64)))

    def __str__(self) -> str:
        return f"a {self.shape[0]} x {self.shape[1]} matrix (SHA-256 {self.sha256[:12]}...)"


def _distinct(values: np.ndarray) -> np.ndarray:
    """The distinct values, sorted (``np.unique`` without its first use's import of ``numpy.ma``, which the
    attributes stage spares its process)."""
    ordered = np.sort(values)
    kept: np.ndarray = ordered[np.concatenate(([True], ordered[1:] != ordered[:-1]))] if ordered.size else ordered
    return kept


def _among(values: np.ndarray, anchors: np.ndarray) -> np.ndarray:
    """The distinct ``values`` that are among ``anchors`` (sorted, distinct)."""
    if not anchors.size:
        return anchors
    at = np.minimum(np.searchsorted(anchors, values), anchors.size - 1)
    return _distinct(values[anchors[at] == values])


def write_print(group: Any, name: str, found: MatrixPrint) -> None:
    """``found`` as the dataset ``name`` of an HDF5 group: its anchors, the rest as the dataset's attributes."""
    data = group.create_dataset(name, data=np.asarray(found.anchors, np.uint64))
    data.attrs["sha256"], data.attrs["shape"], data.attrs["modulus"] = found.sha256, list(found.shape), found.modulus


def read_print(data: Any) -> MatrixPrint:
    """The ``MatrixPrint`` that ``write_print`` wrote as the HDF5 dataset ``data``."""
    return MatrixPrint(str(data.attrs["sha256"]), (int(data.attrs["shape"][0]), int(data.attrs["shape"][1])),
                       int(data.attrs["modulus"]), tuple(int(a) for a in data[()]))


def _mix(bits: np.ndarray) -> np.ndarray:
    """splitmix64's finaliser of every value (in place: ``bits`` is a fresh array)."""
    for shift, factor in ((30, _M1), (27, _M2)):
        bits ^= bits >> np.uint64(shift)
        bits *= factor
    bits ^= bits >> np.uint64(31)
    return bits


def _window_sums(mixed: np.ndarray, weights: np.ndarray, axis: int) -> np.ndarray:
    """``sum_k weights[k] * mixed`` shifted by ``k`` along ``axis``, over the ``PATCH`` positions of a window."""
    n = mixed.shape[axis] - PATCH + 1
    out = np.zeros(mixed.shape[:axis] + (n,) + mixed.shape[axis + 1:], np.uint64)
    for k in range(PATCH):
        out += weights[k] * (mixed[k:k + n] if axis == 0 else mixed[:, k:k + n])
    return out


def patch_hashes(block: np.ndarray) -> np.ndarray:
    """The hash of every non-constant ``PATCH x PATCH`` patch of ``block`` (float64), a flat uint64 array (empty
    for a block smaller than a patch). Position ``(a, b)`` of a patch weighs its value's hash by ``w[a] w[b]``:
    the same for a patch and its transpose, and two passes of ``PATCH`` terms (rows, then columns)."""
    values = np.ascontiguousarray(block, dtype=np.float64) + 0.0  # -0.0 as 0.0: equal values, equal bits
    mixed = _mix(values.view(np.uint64))
    if mixed.shape[0] < PATCH or mixed.shape[1] < PATCH:
        return np.zeros(0, np.uint64)
    hashes = _window_sums(_window_sums(mixed, _WEIGHTS, 1), _WEIGHTS, 0)
    # a constant patch's hash is its value's times the weights' total (anything else: a 64-bit coincidence)
    corner = mixed[:hashes.shape[0], :hashes.shape[1]]
    kept: np.ndarray = hashes[hashes != corner * _TOTAL]
    return kept


def _column_blocks(matrix: Any) -> Any:
    """``(lo, hi, block)``: column blocks of about ``BLOCK_VALUES`` values, float64 and transposed (a row per column,
    ``read_columns``), each with the ``PATCH - 1`` columns after it (the patches that straddle two blocks), ``hi``
    the first of those."""
    n_rows, n_cols = matrix.shape
    step = max(PATCH, BLOCK_VALUES // max(n_rows, 1))
    for lo in range(0, n_cols, step):
        hi = min(n_cols, lo + step)
        yield lo, hi, np.asarray(read_columns(matrix, lo, min(n_cols, hi + PATCH - 1)), dtype=np.float64)


def stored(matrix: Any) -> Any:
    """The values a file stores: a similarity matrix's own (``io.SimilarityAsDistance``), any other as it is."""
    return getattr(matrix, "similarity", matrix)


def matrix_print(matrix: Any, max_anchors: int = MAX_ANCHORS) -> MatrixPrint:
    """The ``MatrixPrint`` of a 2-D matrix (an array, memory map, HDF5 dataset or similarity read as distances),
    read in column blocks."""
    matrix = as_matrix(stored(matrix))
    n_rows, n_cols = (int(n) for n in matrix.shape)
    patches = max(1, (n_rows - PATCH + 1) * (n_cols - PATCH + 1))
    modulus = 1 << max(0, int(np.ceil(np.log2(patches / max_anchors))))
    digest = hashlib.sha256(f"{n_rows}x{n_cols}:".encode())
    kept = []
    for lo, hi, block in _column_blocks(matrix):
        digest.update(block[:hi - lo].tobytes())  # a row per column: the values column by column
        hashes = patch_hashes(block)
        kept.append(hashes[hashes % np.uint64(modulus) == 0])
    anchors = _distinct(np.concatenate(kept)) if kept else np.zeros(0, np.uint64)
    return MatrixPrint(digest.hexdigest(), (n_rows, n_cols), modulus, tuple(int(a) for a in anchors))


def found_anchors(matrix: Any, anchors: np.ndarray) -> np.ndarray:
    """Which of ``anchors`` (sorted uint64) are hashes of patches of ``matrix`` (read in column blocks): every
    patch is looked up, so a region shared with a fingerprinted matrix is found at that matrix's own rate."""
    matrix = as_matrix(stored(matrix))
    anchors = np.asarray(anchors, np.uint64)
    if not anchors.size:
        return anchors
    found = [_among(patch_hashes(block), anchors) for _, _, block in _column_blocks(matrix)]
    return _distinct(np.concatenate(found)) if found else anchors[:0]
