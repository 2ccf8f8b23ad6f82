"""Checks of a distance matrix before sequence matching (method §4): its shape and its values.

Matrices are references x queries; a sequence of length ``L`` needs ``L`` references and ``L`` queries.
"""

from __future__ import annotations

from typing import Any

import numpy as np


def check_shape(shape: tuple[int, ...], seq_len: int, name: str = "distance matrix") -> None:
    """Raise ValueError with a clear message when a matrix of ``shape`` cannot be sequence-matched."""
    if seq_len < 2:
        raise ValueError(f"sequence length must be at least 2, got {seq_len}")
    if len(shape) != 2:
        raise ValueError(f"{name} must be 2-D (references x queries), got shape {tuple(shape)}")
    n_ref, n_query = shape
    if n_ref < seq_len or n_query < seq_len:
        raise ValueError(
            f"{name} of shape {n_ref}x{n_query} is too small for sequence length {seq_len}: "
            f"it needs at least {seq_len} references and {seq_len} queries"
        )


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
