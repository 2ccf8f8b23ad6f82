"""What a predictor was trained on, and the checks that it never scores its own training data.

``Training`` is a predictor file's record of its training data: the sequence length, the methods, the frame ranges
of the files it learnt from (a dataset's splits) and the identity of each training matrix
(``fingerprint.MatrixPrint``: its SHA-256 and content fingerprint, which catches a user's matrix or a block cut
from it). ``write_training`` writes it and ``read_training`` reads it, the one place of its keys. A stage that
applies a predictor checks the length (``attributes.check_length``), the frames (``check_disjoint``) and the matrices
(``check_matrices``) of what it scores.

The workflow cannot produce an overlapping pair unless the configuration allows overlapping splits; the stages check
anyway, so that a hand-run stage or a file from another run cannot leak either.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from vpr_smr.core.io import read_provenance
from vpr_smr.core.records import FORMAT, Record, decode
from vpr_smr.eval.matching.attributes import QueryFeatures, check_length
from vpr_smr.eval.matching.fingerprint import MatrixPrint, found_anchors, read_print, write_print

log = logging.getLogger("vpr_smr")

# the predictor file's attributes (and group, of the matrices): the frames, length, methods and matrices it learnt
TRAINED_ON = "trained_on_frames"
SEQ_LEN = "seq_len"
METHODS = "methods"
MATRICES = "trained_on_matrices"
# shared anchors that mean shared entries: one alone may be two equal patches by chance (a matrix of few distinct
# values, e.g. clipped distances), while a shared region of a entries shares about a / modulus
MIN_SHARED = 3
OVERLAP_FIX = ("score it on data it was not trained on (blocks cut from one matrix must not overlap), or allow it "
               "for a deliberate experiment (allow_split_overlap: true, --allow-split-overlap, or the Python API's "
               "allow_split_overlap=True)")


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


@dataclass(frozen=True)
class Training(Record):
    """What a predictor was trained on: its sequence length (None: a file that records none, written before
    0.15.0 by the Python API), the methods (a dataset's, or the attributes files' names), the frame ranges and the
    training matrices."""

    seq_len: int | None = None
    methods: tuple[str, ...] = ()
    frames: tuple[FrameRange, ...] = ()
    matrices: tuple[MatrixPrint, ...] = ()

    @classmethod
    def of(cls, features: Sequence[QueryFeatures], methods: Sequence[str] = (),
           frames: Sequence[FrameRange] = ()) -> Training:
        """The training record of features pooled in memory or read from files: their one sequence length
        (ValueError naming both when two differ) and their matrices' prints (those recorded)."""
        lengths = sorted({f.seq_len for f in features if f.seq_len is not None})
        if len(lengths) > 1:
            raise ValueError(f"the training features are of the sequence lengths {lengths}: a predictor learns the "
                             "matches of one length; give features computed at one seq_len")
        prints = tuple(dict.fromkeys(f.matrix for f in features if f.matrix is not None))
        return cls(lengths[0] if lengths else None, tuple(methods), tuple(frames), prints)


def write_training(f: Any, training: Training) -> None:
    """``training`` into an open predictor file (``read_training`` reads it back): the length, methods and frames
    as attributes, each matrix's print as a dataset of the group ``MATRICES`` (``fingerprint.write_print``)."""
    f.attrs[TRAINED_ON] = json.dumps([r.to_json() for r in training.frames], sort_keys=True)
    f.attrs[METHODS] = json.dumps(list(training.methods))
    if training.seq_len is not None:
        f.attrs[SEQ_LEN] = int(training.seq_len)
    group = f.create_group(MATRICES)
    for i, found in enumerate(training.matrices):
        write_print(group, str(i), found)


def read_training(f: Any, where: str) -> Training:
    """The ``Training`` of an open predictor file; a file from before it recorded its length gives the length its
    training report's meta holds (``vpr-smr train``), else None; one without matrices none."""
    def value(key: str, default: Any) -> Any:
        found = f.attrs.get(key)
        if found is None:
            return default
        return json.loads(found) if isinstance(found, str | bytes) else found

    def records(key: str, kind: Any) -> tuple[Any, ...]:
        try:
            return tuple(decode(list[kind], value(key, []), key))
        except (KeyError, TypeError, ValueError) as error:
            raise ValueError(f"{where}: its {key} are not in results format {FORMAT} ({error}): the predictor was "
                             "trained by another vpr-smr; train it again with this version") from None

    length = value(SEQ_LEN, None)
    if length is None:
        report = value("report", {})
        meta = report.get("meta") if isinstance(report, dict) else None
        length = meta.get("seq_len") if isinstance(meta, dict) else None
    group = f.get(MATRICES)
    matrices = () if group is None else tuple(read_print(group[str(i)]) for i in range(len(group)))
    return Training(None if length is None else int(length), tuple(str(m) for m in value(METHODS, [])),
                    records(TRAINED_ON, FrameRange), matrices)


def matrix_overlaps(training: Training, name: str, scored: MatrixPrint | None = None, matrix: Any = None,
                    predictor: str = "the predictor", ranged: bool = False) -> list[str]:
    """How the matrix ``name`` shares entries with a training matrix of ``training`` (empty: none): the same
    matrix, or shared fingerprint anchors (overlapping blocks). ``matrix``: the scored values, every patch looked up
    (``found_anchors``); else ``scored``, its print (the same SHA-256, or anchors at the coarser of the two rates).
    Where no print can tell (the predictor records no matrix, or ``name`` has none) logs one warning naming
    ``name``, unless the frame ranges tell instead (``ranged``: ``name`` records its split, ``has_frames``, and the
    predictor its own: ``check_disjoint``)."""
    if not training.matrices or (matrix is None and scored is None):
        if not (ranged and training.frames):
            _warn_unchecked(name, predictor, bool(training.matrices))
        return []
    found = []
    for trained in training.matrices:
        anchors = np.asarray(trained.anchors, np.uint64)
        if matrix is not None:
            shared = len(found_anchors(matrix, anchors))
            same = shared == len(anchors) > 0 and tuple(matrix.shape) in (trained.shape, trained.shape[::-1])
        else:
            assert scored is not None  # the early return above
            shared, same = trained.shared(scored), scored.sha256 == trained.sha256
        if same:
            found.append(f"{predictor} was trained on {trained}, and {name} is that matrix")
        elif shared >= MIN_SHARED:
            found.append(f"{predictor} was trained on {trained}, which shares entries with {name} ({shared} of the "
                         f"{len(anchors)} fingerprint anchors of its training matrix): overlapping blocks")
    return found


def _warn_unchecked(name: str, predictor: str, trained_prints: bool) -> None:
    """The warning of a matrix whose overlap with the predictor's training matrices nothing can check."""
    if trained_prints:
        why, fix = "it records no print of its matrix", "compute its attributes again with this version"
    else:
        why, fix = f"{predictor} records no print of them", "train the predictor again with this version"
    log.warning("%s: whether it shares entries with the matrices %s was trained on cannot be checked (%s, and no "
                "split frame ranges tell); fix: %s", name, predictor, why, fix)


def has_frames(path: Path | str) -> bool:
    """Whether ``path`` is a file of vpr-smr that records the frames of its split (``frame_range``), which
    ``check_disjoint`` compares with a predictor's; a name that is no file (``"features"``) records none."""
    return Path(path).is_file() and h5py.is_hdf5(path) and frame_range(path) is not None


def check_scored(predictor: Any, features: Mapping[str, QueryFeatures | None], allow_overlap: bool,
                 seq_len: int | None = None, fix: str = "give attributes computed at L =") -> list[str]:
    """Every check of a loaded or API-trained predictor (``training_``) against what a stage scores: the length
    (``seq_len``, else each features' own; ``check_length``) and the matrices (``check_matrices``) of ``features``
    (a name, e.g. its file, to the features, None where only ``seq_len`` is known). Returns the overlaps allowed."""
    training: Training | None = getattr(predictor, "training_", None)
    name = str(getattr(predictor, "path_", "the predictor"))
    found: list[str] = []
    for where, scored in features.items():
        length = seq_len if seq_len is not None else None if scored is None else scored.seq_len
        if length is not None:
            check_length(predictor, length, where, fix)
        if training is not None and scored is not None:
            found += matrix_overlaps(training, where, scored.matrix, predictor=name, ranged=has_frames(where))
    return check_matrices(found, allow_overlap)


def check_matrices(found: Sequence[str], allow_overlap: bool) -> list[str]:
    """Raise ``SplitLeakError`` with the first of ``found`` (``matrix_overlaps``) unless ``allow_overlap``, else
    log each as a warning; return them."""
    if found and not allow_overlap:
        raise SplitLeakError(f"{found[0]}: its scores there would be measured on its own training data. Fix: "
                             f"{OVERLAP_FIX}")
    for overlap in found:
        log.warning("%s: its scores there are measured on its own training data (allowed: allow_split_overlap)",
                    overlap)
    return list(found)


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
    with h5py.File(predictor, "r") as f:
        return list(read_training(f, str(predictor)).frames)


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
