"""The threshold file of method §16: a threshold set on a calibration split (``vpr-smr calibrate``), read where it is
deployed (``vpr-smr deploy``, the live matcher).

The file says what the threshold is a threshold of, so that it is never applied to another confidence: the source
(a scorer of method §12, ``c_<source>`` of the per-query table), the method, the sequence matcher (its name and
settings, as the per-query table's ``matcher`` column writes them), the sequence length ``L``, and the predictor
file's SHA-256 when the source is the predictor. Then the rule and its targets (``precision``, ``risk``), the
threshold (None: the rule abstains, nothing is accepted), the calibration split's size, counts and the SHA-256 of
its confidences and labels, and the version of the tool. Its last entry, ``sha256``, is the SHA-256 of every other
entry as canonical JSON (keys sorted, no spaces), so that a file edited by hand is refused when read: a threshold
chosen by hand has none of the promises a rule gives.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vpr_smr.core.io import atomic_path, package_version
from vpr_smr.core.records import MissingEntry, Record, decode, encode
from vpr_smr.eval.scoring import thresholds
from vpr_smr.eval.scoring.scorers import NATIVE, PREDICTOR, RANDOM, predictor_confidence
from vpr_smr.eval.scoring.thresholds import SAME_FRACTION, Calibration

__all__ = ["LIVE_SOURCES", "REFUSED_SOURCES", "ThresholdFile", "calibration_sha256", "check_same", "read_thresholds",
           "write_thresholds"]

HASH_KEY = "sha256"
# the sources a live frame gives (LiveResult): the predictor's, the matcher's native confidence, uniqueness where it
# is the matcher's native scorer (seqslam's), and minus the sequence distance
LIVE_SOURCES = (PREDICTOR, NATIVE, "uniqueness", "distance")
REFUSED_SOURCES = (RANDOM,)  # a random order has nothing to calibrate (``oracle``, the labels, is kept as a check)


def calibration_sha256(confidence: np.ndarray, correct: np.ndarray) -> str:
    """The SHA-256 of a split's confidences (float64, little-endian) and labels (one byte each), in query order:
    which calibration split a threshold came from."""
    digest = hashlib.sha256(f"{len(confidence)}:".encode())
    digest.update(np.asarray(confidence, dtype="<f8").tobytes())
    digest.update(np.asarray(correct, dtype=bool).astype(np.uint8).tobytes())
    return digest.hexdigest()


def _canonical_sha256(data: Mapping[str, Any]) -> str:
    text = json.dumps(data, sort_keys=True, separators=(",", ":"), allow_nan=True)
    return hashlib.sha256(text.encode()).hexdigest()


@dataclass(frozen=True)
class ThresholdFile(Record):
    """A threshold set by ``vpr-smr calibrate`` and what it is a threshold of (the module's docstring). ``method``
    and ``seq_len`` are None where the calibration's input did not say them; ``predictor_sha256`` is the predictor
    file's when the source is the predictor and the file was given."""

    source: str
    method: str | None
    matcher: str  # str(MatcherSpec), as the per-query table's matcher column
    seq_len: int | None
    predictor_sha256: str | None
    rule: str
    precision: float
    risk: float | None
    threshold: float | None
    split: str  # the calibration split's name
    n_queries: int
    accepted: int
    wrong: int
    calibration_sha256: str
    version: str
    scorers: dict[str, int]  # the training-free scorers' settings the confidences were computed with (r_window, ...)
    sha256: str = ""  # of every other entry (``seal``); "" only before it is sealed

    @classmethod
    def of(cls, calibration: Calibration, source: str, matcher: str, split: str, confidence: np.ndarray,
           correct: np.ndarray, method: str | None = None, seq_len: int | None = None,
           predictor_sha256: str | None = None, scorers: Mapping[str, int] | None = None) -> ThresholdFile:
        """The sealed file of ``calibration`` set on ``confidence`` and ``correct`` (the calibration split);
        ``scorers``: the scorers' settings (``BaselineSettings.meta``, the defaults' when not given)."""
        from vpr_smr.eval.scoring.scorers import DEFAULT_SETTINGS

        return cls(source, method, matcher, seq_len, predictor_sha256, calibration.rule, calibration.precision,
                   calibration.risk, calibration.threshold, split, calibration.n_queries, calibration.accepted,
                   calibration.wrong, calibration_sha256(confidence, correct), package_version(),
                   dict(scorers if scorers is not None else DEFAULT_SETTINGS.meta())).seal()

    @property
    def calibration(self) -> Calibration:
        """The rule's record (``thresholds.Calibration``), as ``thresholds.accept`` takes it."""
        return Calibration(self.rule, self.precision, self.risk, self.threshold, self.n_queries, self.accepted,
                           self.wrong)

    def content(self) -> dict[str, Any]:
        """Every entry but the hash, as JSON data (None entries kept: the hash covers them)."""
        data = encode(self)
        data.pop(HASH_KEY, None)
        return {name: data.get(name) for name in self.__dataclass_fields__ if name != HASH_KEY}

    def seal(self) -> ThresholdFile:
        """The same file with its ``sha256`` computed from its other entries."""
        return ThresholdFile(**{**self.__dict__, HASH_KEY: _canonical_sha256(self.content())})

    def accepts(self, confidence: np.ndarray) -> np.ndarray:
        """The queries of a split this threshold accepts (``thresholds.accept``)."""
        return thresholds.accept(confidence, self.calibration)

    def described(self) -> str:
        """One line: the source, what it was set for and the threshold."""
        shown = "abstains (accepts nothing)" if self.threshold is None else f"t = {self.threshold!r}"
        if self.rule == SAME_FRACTION and self.threshold is not None:
            shown = f"the same fraction as {self.accepted} of {self.n_queries} (empirical's {shown})"
        risk = "" if self.risk is None else f", risk {self.risk:g}"
        return f"{self.source} {self.rule} at precision {self.precision:g}{risk}: {shown}"

    # --- live (``eval.matching.live.LiveMatcher``): the frame's confidence of this file's source ----------------

    def check_live(self, matcher: str, native_scorer: str | None, method: str | None, seq_len: int,
                   predictor_sha256: str | None, has_predictor: bool, r_window: int | None = None) -> None:
        """ValueError unless a live matcher of ``matcher`` (its ``str(MatcherSpec)``), ``method`` and ``seq_len``
        gives this file's source per frame: a source of ``LIVE_SOURCES`` (``uniqueness`` only where it is the
        matcher's native scorer; ``predictor`` with a predictor, whose file must be the calibrated one), a rule
        that sets a threshold (``same_fraction`` needs a whole split), and the same matcher, method and length."""
        if self.rule == SAME_FRACTION:
            raise ValueError("the threshold file's rule same_fraction accepts a fraction of a whole split, which a "
                             "live frame does not know: calibrate with --rule empirical or guaranteed for live use")
        usable = [name for name in LIVE_SOURCES if name != "uniqueness" or native_scorer == "uniqueness"]
        if self.source not in usable:
            raise ValueError(f"the threshold file's source {self.source!r} is not computed per live frame; a "
                             f"LiveMatcher of the matcher {matcher!r} gives {', '.join(usable)}: calibrate on one "
                             "of them")
        check_same(self, "the LiveMatcher", matcher=matcher, method=method, seq_len=seq_len)
        window = self.scorers.get("r_window")
        if self.source in ("uniqueness", NATIVE) and r_window is not None and window is not None and window != r_window:
            raise ValueError(f"the threshold file's {self.source} was computed with r_window {window}, the "
                             f"LiveMatcher's with r_window {r_window}: give LiveMatcher(r_window={window}) or "
                             "calibrate again")
        if self.source == PREDICTOR:
            if not has_predictor:
                raise ValueError("the threshold file's source is the predictor: give the LiveMatcher its predictor "
                                 "(predictor=SMRPredictor.load(...)), the one the threshold was calibrated with")
            mine = self.predictor_sha256
            if mine is not None and predictor_sha256 is not None and mine != predictor_sha256:
                raise ValueError(f"the threshold file was calibrated on the predictor file of SHA-256 {mine[:12]}..., "
                                 f"the LiveMatcher's predictor file has {predictor_sha256[:12]}...: calibrate again "
                                 "with this predictor, or give the calibrated one")

    def frame_accepted(self, native: float | None, sequence_distance: float, probabilities: np.ndarray | None,
                       classes: np.ndarray | None) -> bool:
        """Whether this threshold accepts a live frame: its source's confidence (the predictor's
        ``1 - P(class 1) - P(class 3)``, the native confidence, which is uniqueness's where that is the matcher's
        scorer, or minus the sequence distance) through ``thresholds.accept``."""
        if self.source == PREDICTOR:
            assert probabilities is not None and classes is not None  # check_live: a predictor is given
            value = float(predictor_confidence(np.asarray(probabilities).reshape(1, -1), classes)[0])
        elif self.source == "distance":
            value = -float(sequence_distance)
        else:
            assert native is not None  # every live frame has its native confidence
            value = float(native)
        return bool(self.accepts(np.array([value]))[0])


def check_same(file: ThresholdFile, where: str, *, source: str | None = None, matcher: str | None = None,
               method: str | None = None, seq_len: int | None = None, scorers: Mapping[str, int] | None = None,
               name: str = "the threshold file") -> None:
    """ValueError naming both when ``where`` (the input a threshold file is applied to) has another source,
    matcher, method, sequence length or scorers' settings than the file (``name``: how messages call it); what
    either side does not say is not compared."""
    settings = [(f"scorers' {key}", value, None if scorers is None else scorers.get(key))
                for key, value in file.scorers.items()]
    for what, mine, theirs in (("source", file.source, source), ("matcher", file.matcher, matcher),
                               ("method", file.method, method), ("sequence length", file.seq_len, seq_len),
                               *settings):
        if mine is not None and theirs is not None and mine != theirs:
            raise ValueError(f"{name} is for the {what} {mine!r}, but {where} has the {what} {theirs!r}: a "
                             f"threshold holds for the confidence it was calibrated on only; calibrate again on a "
                             f"split of {theirs!r}")


def write_thresholds(path: Path | str, file: ThresholdFile) -> None:
    """``file`` as JSON (sorted keys, its hash last), written atomically (``core.io.atomic_path``)."""
    data = {**file.content(), HASH_KEY: file.sha256}
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(data, indent=1, sort_keys=True, allow_nan=True) + "\n")


def read_thresholds(path: Path | str) -> ThresholdFile:
    """The threshold file ``path``; ValueError naming it when it is missing, not one, or was edited after ``vpr-smr
    calibrate`` wrote it (its hash does not match)."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"--thresholds {path}: no such file; write one with vpr-smr calibrate")
    try:
        data = json.loads(path.read_text())
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise ValueError(f"{path}: not a threshold file (not JSON: {error}); write one with vpr-smr "
                         "calibrate") from None
    if not isinstance(data, dict) or HASH_KEY not in data:
        raise ValueError(f"{path}: not a threshold file (no {HASH_KEY!r} entry); write one with vpr-smr calibrate")
    try:
        found = decode(ThresholdFile, data, str(path))
    except MissingEntry as error:
        raise ValueError(f"{path}: not a threshold file: it has no {error.args[0]!r} entry; write one with vpr-smr "
                         "calibrate") from None
    except (TypeError, ValueError) as error:
        raise ValueError(f"{path}: not a threshold file: {error}; write one with vpr-smr calibrate") from None
    if _canonical_sha256({key: value for key, value in data.items() if key != HASH_KEY}) != data[HASH_KEY]:
        raise ValueError(f"{path} was edited after vpr-smr calibrate wrote it (its hash does not match): calibrate "
                         "again")
    if found.source in REFUSED_SOURCES or (found.threshold is not None and math.isnan(found.threshold)):
        raise ValueError(f"{path}: not a threshold file vpr-smr calibrate writes (source {found.source!r}): "
                         "calibrate again")
    return found

