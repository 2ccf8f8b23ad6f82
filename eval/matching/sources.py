"""The option groups that several stages share, each declared once (``core.settings.group``): how a matrix file is
read (``MatrixFormat``) and where the ground truth comes from (``TruthSource``), plus the sequence length
(``seq_len``), each with the one declaration of its field in a job record (``truth``, ``matrix``, ``matcher``,
``seq_len``). A stage's job record holds them as fields; their settings are the stage's options and keys of its
``--job`` object."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from vpr_smr.core.constants import DEFAULT_TOLERANCE
from vpr_smr.core.settings import REQUIRED, group, setting
from vpr_smr.eval.matching.matchers import MatcherSpec

__all__ = ["MatrixFormat", "TruthSource", "matcher", "matrix", "seq_len", "truth"]


def seq_len() -> Any:
    """The field of a job's sequence length L (the one declaration of ``--seq-len``)."""
    return setting(REQUIRED, "the sequence length L of sequence matching (frames per sequence)", minimum=1)


@dataclass(frozen=True)
class MatrixFormat:
    """How a user's matrix file is read (our ``.h5`` files say it themselves)."""

    similarity: bool = setting(False, "the matrix holds similarities (larger = more similar): read as distances "
                                      "max(M) - M, recorded in the outputs")
    key: str | None = setting(None, "the array of an .npz, or the variable of a MATLAB .mat, holding the matrix "
                                    "(default: the file's only 2-D numeric one)", metavar="NAME")
    transpose: bool = setting(False, "the matrix file is queries x references (vpr-smr reads references x queries)")


@dataclass(frozen=True)
class TruthSource:
    """Where a split's ground truth comes from (method §§11, 13): frame indices within ``tolerance`` (a
    frame-aligned pair), positions within ``radius``, or a file."""

    tolerance: int = setting(DEFAULT_TOLERANCE, "frame-aligned pairs: a match within this many frames of the "
                                                "query's own is correct", minimum=0)
    reference_positions: str | None = setting(
        None, "one position per reference frame (.npy, or CSV of numbers: x[,y]); with --query-positions and "
              "--radius, the ground truth of a pair that is not frame-aligned", metavar="PATH")
    query_positions: str | None = setting(None, "one position per query frame (.npy or CSV)", metavar="PATH")
    radius: float | None = setting(None, "with positions: a match within this distance (the positions' unit) is "
                                         "correct", minimum=0)
    ground_truth: str | None = setting(
        None, "the ground truth as a file instead of --tolerance or positions: a boolean references x queries "
              "matrix (.npy, .npz, .mat, e.g. VPR_Tutorial's GThard) or per-query lists of correct references (JSON "
              "{\"query\": [reference, ...]}, CSV query,reference, VPR-Bench's ground_truth_new.npy); a file of a "
              "whole dataset is cut to the split of an .h5 of vpr-smr distances", metavar="FILE")
    ground_truth_key: str | None = setting(None, "the variable of a --ground-truth .npz or .mat holding several "
                                                 "(e.g. GThard)", metavar="NAME")


def truth() -> Any:
    """The field of a job's ground truth (``TruthSource``)."""
    return group(TruthSource, "the ground truth")


def matrix() -> Any:
    """The field of how a job reads a user's matrix file (``MatrixFormat``)."""
    return group(MatrixFormat, "how a user's matrix file is read")


def matcher() -> Any:
    """The field of a job's sequence matcher (``MatcherSpec``, ``seqslam`` by default)."""
    return setting(MatcherSpec.of(), "the sequence matcher and its settings")
