"""Checks of a distance matrix before sequence matching (method §4): its shape and its values.

Matrices are references x queries; a sequence of length ``L`` needs ``L`` references and ``L`` queries.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

import numpy as np

log = logging.getLogger("vpr_smr")

# The shortest sequence: one of a single frame is single-frame matching, not sequence matching.
SHORTEST_SEQ_LEN = 2


def check_shape(shape: tuple[int, ...], seq_len: int, name: str = "distance matrix") -> None:
    """Raise ValueError with a clear message when a matrix of ``shape`` cannot be sequence-matched."""
    if seq_len < SHORTEST_SEQ_LEN:
        raise ValueError(f"sequence length must be at least {SHORTEST_SEQ_LEN}, got {seq_len}")
    if len(shape) != 2:
        raise ValueError(f"{name} must be 2-D (references x queries), got shape {tuple(shape)}")
    n_ref, n_query = shape
    if n_ref < seq_len or n_query < seq_len:
        raise ValueError(
            f"{name} of shape {n_ref}x{n_query} is too small for sequence length {seq_len}: "
            f"it needs at least {seq_len} references and {seq_len} queries"
        )


def _fits(check: Callable[[int], object], seq_len: int) -> bool:
    try:
        check(seq_len)
    except ValueError:
        return False
    return True


def check_size(check: Callable[[int], object], seq_len: int, option: str = "--seq-len") -> None:
    """Raise ValueError when a matrix cannot be matched at ``seq_len``, with advice that can be followed:
    ``check(L)`` raises ValueError naming the matrix when it does not fit length ``L`` (the stage's own checks at
    ``L``). The advice is the longest length that fits, found by bisection (a matrix that fits ``L`` fits every
    shorter length), or, where none does, that no length fits (``check``'s message at the shortest length, which
    says what the matrix lacks): never a length below the shortest."""
    if seq_len < SHORTEST_SEQ_LEN:
        small = _too_small(check, option)
        raise ValueError(f"{option} must be at least {SHORTEST_SEQ_LEN} (a sequence of one frame is single-frame "
                         f"matching), got {seq_len}" + (f"; besides, {small}" if small else ""))
    try:
        check(seq_len)
    except ValueError as error:
        small = _too_small(check, option)
        if small:
            raise ValueError(small) from None
        lo, hi = SHORTEST_SEQ_LEN, seq_len - 1  # lo fits; seq_len does not, nor (by the rule above) any longer
        while lo < hi:
            mid = (lo + hi + 1) // 2
            lo, hi = (mid, hi) if _fits(check, mid) else (lo, mid - 1)
        raise ValueError(f"{error}; give a {option} of at most {lo}, or a larger matrix") from None


def stage_check(build: Callable[[int], Any], shape: tuple[int, ...], name: str) -> Callable[[int], None]:
    """``check_size``'s ``check`` for a stage that matches a matrix of ``shape`` with the matcher ``build(L)``
    returns and describes the sequences (attributes, recall): ``L`` references and queries, and what the matcher
    needs at ``L``."""
    def check(seq_len: int) -> None:
        check_shape(shape, seq_len, name)
        build(seq_len).check(shape, name)
    return check


def _too_small(check: Callable[[int], object], option: str) -> str:
    """Why no sequence length fits (empty where the shortest does)."""
    try:
        check(SHORTEST_SEQ_LEN)
    except ValueError as error:
        return (f"{error}; {SHORTEST_SEQ_LEN} is the shortest sequence length, so no {option} fits: give a larger "
                "matrix")
    return ""


class NonFiniteError(ValueError):
    """NaN or inf in a distance matrix: the first one (lowest query column, then lowest reference row, in the
    matrix's own indices) and how many there are in ``scope`` (the whole matrix, or the block that was checked)."""

    def __init__(self, name: str, row: int, column: int, value: float, n_nan: int, n_inf: int, scope: str = ""):
        self.name, self.row, self.column, self.value = name, row, column, value
        self.n_nan, self.n_inf, self.scope = n_nan, n_inf, scope
        n_bad = n_nan + n_inf
        kinds = ", ".join(f"{n} {kind}" for n, kind in ((n_nan, "NaN"), (n_inf, "inf")) if n)
        plural = "" if n_bad == 1 else "s"
        super().__init__(f"{name} has {n_bad} non-finite value{plural} ({kinds}){scope}; the first is "
                         f"{_kind(value)} at row {row} (reference), column {column} (query); distances must be finite")

    def __reduce__(self) -> tuple[Any, ...]:  # picklable across worker processes, despite its own arguments
        return (NonFiniteError, (self.name, self.row, self.column, self.value, self.n_nan, self.n_inf, self.scope))

    def counted_in(self, matrix: Any) -> NonFiniteError:
        """The same first value, with the count over the whole references x queries ``matrix`` (an array, memmap
        or HDF5 dataset; read in blocks of columns, as the stages read it): a block's count alone would understate
        a matrix that is NaN throughout. Only called on the error path, so the matrix is read a second time then."""
        n_ref, n_query = (int(n) for n in matrix.shape)
        step = max(1, COUNT_BLOCK_VALUES // max(n_ref, 1))
        n_nan = n_inf = 0
        for lo in range(0, n_query, step):
            block = np.asarray(matrix[:, lo : lo + step])
            if np.issubdtype(block.dtype, np.inexact):
                n_nan += int(np.count_nonzero(np.isnan(block)))
                n_inf += int(np.count_nonzero(np.isinf(block)))
        return NonFiniteError(self.name, self.row, self.column, self.value, n_nan, n_inf)


# Values read at a time when counting a whole matrix's NaN and inf (about 128 MB of float64).
COUNT_BLOCK_VALUES = 1 << 24


def _kind(value: float) -> str:
    return "NaN" if np.isnan(value) else ("inf" if value > 0 else "-inf")


def check_finite(values: np.ndarray, name: str = "distance matrix", *, first_column: int = 0,
                 queries_first: bool = False) -> None:
    """Raise ``NonFiniteError`` when ``values`` has NaN or inf: the whole matrix, or a block of its consecutive
    query columns starting at ``first_column``; ``values`` is references x query columns, or query columns x
    references with ``queries_first`` (the layout of ``matcher.read_columns``)."""
    if not np.issubdtype(values.dtype, np.inexact) or np.all(np.isfinite(values)):
        return
    by_column = values if queries_first else values.T
    bad = ~np.isfinite(by_column)
    column, row = (int(i) for i in np.argwhere(bad)[0])  # row-major over (column, reference): the first column
    n_nan = int(np.count_nonzero(np.isnan(by_column)))
    n_columns = by_column.shape[0]
    scope = f" in query columns {first_column}..{first_column + n_columns - 1}"
    raise NonFiniteError(name, row, first_column + column, float(by_column[column, row]), n_nan,
                         int(np.count_nonzero(bad)) - n_nan, scope)


# Query columns a tie check reads, evenly spaced (every one of a smaller matrix): a constant or all-tied matrix shows
# in any of them, and reading all of a 9000 x 9000 matrix would cost as much as its matching.
TIE_SAMPLE = 256


def tied_columns(matrix: Any, block_queries: int = 64) -> tuple[int, int]:
    """Of the query columns read (every one, or ``TIE_SAMPLE`` evenly spaced ones of a larger matrix): how many
    hold one value in every reference row (every ranking of that query a tie), and how many were read."""
    n_query = int(matrix.shape[1])
    # sorted and without repeats, as np.unique gives them (which imports numpy.ma on first use: 5-15 ms)
    sample = np.array(sorted(set(np.linspace(0, n_query - 1, min(n_query, TIE_SAMPLE)).round()
                                 .astype(np.int64).tolist())), dtype=np.int64)
    tied = 0
    for start in range(0, len(sample), block_queries):
        values = np.asarray(matrix[:, sample[start : start + block_queries]], dtype=np.float64)
        if values.shape[0]:
            tied += int(np.count_nonzero(np.isfinite(values).all(axis=0) & (values.min(axis=0) == values.max(axis=0))))
    return tied, len(sample)


def tie_warning(name: str, matrix: Any) -> str | None:
    """A warning naming ``name`` when query columns of ``matrix`` hold one value throughout (a constant matrix, or
    all-tied columns): their rankings are ties, so recall there is decided by how ties are broken, not by the
    matrix; None where no column read is tied (or the matrix has one reference: nothing to rank)."""
    if int(matrix.shape[0]) < 2 or int(matrix.shape[1]) == 0:
        return None
    tied, read = tied_columns(matrix)
    if tied == 0:
        return None
    n_query = int(matrix.shape[1])
    columns = f"its {read} query columns" if read == n_query else f"{read} of its {n_query} query columns read"
    if tied == read:
        return (f"{name}: every one of {columns} holds a single value (a constant or all-tied matrix): every ranking "
                "is a tie, so recall and the matches are decided by how ties are broken, not by the matrix; check "
                "how the matrix was computed")
    return (f"{name}: {tied} of {columns} hold a single value: those queries' single-frame rankings are ties, "
            "decided by how ties are broken, not by the matrix")


def warn_if_tied(name: str, matrix: Any) -> None:
    """Log ``tie_warning`` of a matrix a stage scores."""
    warning = tie_warning(name, matrix)
    if warning:
        log.warning(warning)
