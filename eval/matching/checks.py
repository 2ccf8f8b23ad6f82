"""Checks of a distance matrix before sequence matching (method §4): its shape and its values.

Matrices are references x queries; a sequence of length ``L`` needs ``L`` references and ``L`` queries.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

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
