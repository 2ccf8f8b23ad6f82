"""Distance matrices, SeqSLAM sequence matching, the four SMR attributes and labels of every query (method §§3-6),
their compiled kernels and the live per-frame API."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from vpr_smr.eval.matching.live import LiveMatcher

__all__ = ["LiveMatcher"]


def __getattr__(name: str) -> Any:
    """``LiveMatcher`` imported on first use: importing any of this package's modules (every CLI command does) then
    no longer imports the live API and its distances (PEP 562)."""
    if name == "LiveMatcher":
        from vpr_smr.eval.matching.live import LiveMatcher

        return LiveMatcher
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
