"""A predictor never scores the frames it was trained on: the frame ranges of the files it learnt from (kept in
its own file) against those of every file it scores, read from the files' provenance.

The workflow cannot produce such a pair unless the configuration allows overlapping splits; the stages check
anyway, so that a hand-run stage or a file from another run cannot leak either.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from vpr_smr.core.io import read_provenance
from vpr_smr.core.records import FORMAT, Record, decode

TRAINED_ON = "trained_on_frames"  # the predictor file's attribute: the frame ranges it was trained on


class SplitLeakError(ValueError):
    """A predictor would score frames of its own training data."""


@dataclass(frozen=True)
class FrameRange(Record):
    """Frames ``lo .. hi-1`` of both traverses of a dataset: one split of a features file. A split of traverses
    with positions (method §11) may give its references apart: ``reference = (lo, hi)``; ``lo .. hi-1`` are then
    its queries."""

    dataset: str
    split: str
    lo: int
    hi: int
    reference: tuple[int, int] | None = None  # the reference frames, when they differ from lo .. hi-1

    @property
    def references(self) -> tuple[int, int]:
        return self.reference if self.reference is not None else (self.lo, self.hi)

    def shared(self, other: FrameRange) -> tuple[int, int] | None:
        """The frames both ranges hold, as ``(lo, hi)``, or None: the shared queries, else the shared references."""
        found = self.shared_frames(other)
        return found[1] if found is not None else None

    def shared_frames(self, other: FrameRange) -> tuple[str, tuple[int, int]] | None:
        """Which frames both ranges hold, ``("", (lo, hi))`` for both traverses' frames of frame-aligned splits,
        ``("query ", ...)`` or ``("reference ", ...)`` when a split gives its references apart; or None."""
        if self.dataset != other.dataset:
            return None
        apart = self.reference is not None or other.reference is not None
        for role, mine, theirs in (("query " if apart else "", (self.lo, self.hi), (other.lo, other.hi)),
                                   ("reference ", self.references, other.references)):
            lo, hi = max(mine[0], theirs[0]), min(mine[1], theirs[1])
            if lo < hi:
                return role, (lo, hi)
            if not apart:
                break  # one range for both traverses: the first test was the only one
        return None

    def __str__(self) -> str:
        if self.reference is None:
            return f"{self.dataset!r} split {self.split!r} [{self.lo}, {self.hi})"
        return (f"{self.dataset!r} split {self.split!r} (queries [{self.lo}, {self.hi}), references "
                f"[{self.reference[0]}, {self.reference[1]}))")


def frame_range(features: Path | str) -> FrameRange | None:
    """The split a features file covers, from its provenance (``split_range``: its queries, or its frames of both
    traverses; ``reference_range``: its references, when the distances stage was given them apart); None for a
    file without one (a user's matrix)."""
    provenance = read_provenance(features)
    if not {"dataset", "split", "split_range"} <= provenance.keys():
        return None
    lo, hi = provenance["split_range"]
    reference = provenance.get("reference_range")
    own = (int(reference[0]), int(reference[1])) if reference is not None else None
    return FrameRange(str(provenance["dataset"]), str(provenance["split"]), int(lo), int(hi), own)


def frame_ranges(paths: Iterable[Path | str]) -> list[FrameRange]:
    """The distinct splits of ``paths`` (every method of a split covers the same frames), in first-seen order."""
    return list(dict.fromkeys(r for r in map(frame_range, paths) if r is not None))


def trained_on(predictor: Path | str) -> list[FrameRange]:
    """The frame ranges a predictor file was trained on (none recorded: an empty list); a file of another results
    format (an earlier layout of its ranges) raises a ValueError saying to train it again."""
    try:
        return decode(list[FrameRange], read_provenance(predictor).get(TRAINED_ON, []), TRAINED_ON)
    except (KeyError, TypeError, ValueError) as error:
        raise ValueError(f"{predictor}: its {TRAINED_ON} are not in results format {FORMAT} ({error}): the predictor "
                         "was trained by another vpr-smr; train it again with this version") from None


def check_disjoint(trained: Sequence[FrameRange], scored: Sequence[FrameRange], allow_overlap: bool,
                   predictor: str) -> list[str]:
    """Raise ``SplitLeakError`` when a scored range shares frames with a trained one, unless ``allow_overlap``;
    return the overlaps found (empty when the splits are disjoint)."""
    found = [f"{predictor} was trained on {t}, which shares {s[0]}frames [{s[1][0]}, {s[1][1]}) with {r}"
             for r in scored for t in trained if (s := t.shared_frames(r)) is not None]
    if found and not allow_overlap:
        raise SplitLeakError(f"{found[0]}: its scores there would be measured on its own training data. Make the "
                             "split ranges disjoint, or allow it for a deliberate experiment "
                             "(allow_split_overlap: true, or --allow-split-overlap)")
    return found
