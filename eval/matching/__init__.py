"""Distance matrices, SeqSLAM sequence matching, the four SMR attributes and labels of every query (method §§3-6),
their compiled kernels and the live per-frame API."""

from vpr_smr.eval.matching.live import LiveMatcher

__all__ = ["LiveMatcher"]
