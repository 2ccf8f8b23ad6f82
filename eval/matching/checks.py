"""Checks of a distance matrix before sequence matching (SPEC section 4): its shape and its values.

Matrices are references x queries; a sequence of length ``L`` needs ``L`` references and ``L`` queries.
"""

from __future__ import annotations

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


def check_finite(values: np.ndarray, name: str = "distance matrix", where: str = "") -> None:
    """Raise ValueError when ``values`` (the whole matrix or one block of it, described by ``where``) has NaN/inf."""
    if np.issubdtype(values.dtype, np.inexact) and not np.all(np.isfinite(values)):
        bad = int(np.size(values) - np.count_nonzero(np.isfinite(values)))
        raise ValueError(f"{name} has {bad} non-finite values (NaN or inf){where}; distances must be finite")
