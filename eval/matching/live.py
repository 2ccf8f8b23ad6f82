"""Sequence matching, SMR attributes and the predictor's decision one frame at a time, for a robot.

``LiveMatcher`` keeps the last ``L`` columns of the distance matrix in a ring buffer and runs the batch attributes'
trajectory engine (``features.attribute_engine``: ``SequenceMatcher.block_features``) on that window, so every frame
costs ``O(R x L)`` (times the velocities) and its result is the batch computation's, bit for bit (paper-mode
attributes, method §5's tie rule). Column normalisation needs only the column itself, so nothing else about the past
is kept. Any matcher of the seam (a ``MatcherSpec`` or a built ``Matcher``) gives its match and its native
confidence per frame by its ``block``, one frame at a time, its state (a filter's belief) carried from frame to
frame, so frame by frame equals the batch: it must be causal (no lookahead: a centred window sees frames to come)
and need no pass over the whole split before its first frame (``Matcher.prepare``); the buffer keeps the columns
its window reads. The native confidence is the matcher's own (``MatchBlock.native``) or the §12 scorer it names,
which live must be ``uniqueness`` (``confidence.uniqueness`` with ``r_window``, as the batch scorers compute it).

The descriptors must be compared with the distance their method's batch matrices use (``mad`` for SAD, ``l2`` for
the learned backends, or the method's ``distance`` setting): ``from_descriptors`` takes the reference descriptors
and that distance from a descriptor file of the pipeline, so the live matches are the batch ones.

    matcher = LiveMatcher.from_descriptors("descriptors.h5", seq_len=4, predictor=SMRPredictor.load("L4.h5"))
    for descriptor in camera_descriptors:
        result = matcher.step(descriptor)      # None for the first L - 1 frames
        if result is not None and result.keep:
            use(result.sequence_match)

A threshold file of ``vpr-smr calibrate`` (method §16; ``thresholds=``, read with
``vpr_smr.eval.scoring.threshold_file.read_thresholds``) makes each result say whether the frame's match is accepted
(``LiveResult.accepted``): the frame's confidence of the file's source (the predictor's, the native confidence,
``uniqueness`` where it is the matcher's native scorer, or minus the sequence distance) against its threshold, the
batch ``vpr-smr deploy``'s decision on the same query. A file of another matcher, method or length is refused.

    matcher = LiveMatcher.from_descriptors("descriptors.h5", seq_len=4, thresholds=read_thresholds("thr.json"))
    for descriptor in camera_descriptors:
        result = matcher.step(descriptor)
        if result is not None and result.accepted:
            use(result.sequence_match)

``AdaptiveLiveMatcher`` chooses the sequence length per frame (method §15): every length's window takes every frame,
then the lengths are asked shortest first and the first whose predictor keeps the match is chosen; the longer ones'
attributes and predictions are not computed that frame (a filter's matching is: its belief advances every frame at
every length). The choice is ``adaptive.first_accepted``'s, the batch experiment's rule.

    predictors = [SMRPredictor.load(f"L{length}.h5") for length in (2, 4, 8)]
    matcher = AdaptiveLiveMatcher.from_descriptors("descriptors.h5", lengths=(2, 4, 8), predictors=predictors)
    for descriptor in camera_descriptors:
        result = matcher.step(descriptor)      # None for the first 8 - 1 frames
        if result is not None and result.seq_len is not None:   # None: no length's predictor kept the match
            use(result.result.sequence_match)  # matched over result.seq_len frames; result.computed: lengths asked
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from vpr_smr.core.constants import DEFAULT_R_WINDOW, KEPT_CLASSES, candidates_needed, half_window
from vpr_smr.eval.matching.adaptive import NONE, first_accepted
from vpr_smr.eval.matching.attributes import Matching, built_matcher, check_length, check_matching
from vpr_smr.eval.matching.checks import check_finite
from vpr_smr.eval.matching.confidence import uniqueness
from vpr_smr.eval.matching.distances import distance_columns, prepare_references
from vpr_smr.eval.matching.features import attribute_engine, block_native, smallest_scores
from vpr_smr.eval.matching.matchers import MatcherSpec
from vpr_smr.eval.matching.matchers.base import MatchBlock, Matcher

LIVE_NATIVE_SCORER = "uniqueness"  # the one §12 scorer a frame's own scores give (the others need more than them)


class LiveThresholds(Protocol):
    """What a live matcher needs of a threshold file (``eval.scoring.threshold_file.ThresholdFile``, which the
    scoring layer above this one reads): a check that this matcher gives its source per frame, and its decision on
    a frame from what the frame computes. The file's rule decides; this module only passes the frame's numbers."""

    def check_live(self, matcher: str, native_scorer: str | None, method: str | None, seq_len: int,
                   predictor_sha256: str | None, has_predictor: bool, r_window: int | None = None) -> None: ...

    def frame_accepted(self, native: float | None, sequence_distance: float, probabilities: np.ndarray | None,
                       classes: np.ndarray | None) -> bool: ...


@dataclass(frozen=True)
class LiveResult:
    """The current query's matches, its attributes and, with a predictor, its predicted label."""

    query: int  # index of the current frame (0 for the first frame fed)
    single_match: int  # argmin_r D[r, query]
    sequence_match: int  # the matcher's r*_a (seqslam: the reference at which the best sequence ends)
    sequence_distance: float  # s_a[r*_a] (seqslam: min_i S[i, query - L + 1]; method §11: min_r S[r, query])
    attributes: np.ndarray  # (K, 4): A1..A4 (the paper's names) of ranks 0..K-1
    rank_references: np.ndarray  # (K,): reference matched by the rank-k diagonal (trajectory), where it ends
    label: int | None = None  # predicted class 0..3 (method §6), with a predictor
    keep: bool | None = None  # the predictor keeps the sequence match (label 0 or 2)
    native: float | None = None  # the matcher's native confidence (method §14; higher = more confident)
    accepted: bool | None = None  # the threshold file accepts the sequence match (None: no threshold file)


class LiveMatcher:
    """Feed one frame at a time: ``step(query_descriptor)`` (needs ``references``) or ``step_distances(column)``.

    ``predictor``: any object with ``predict_proba(X)`` (``X`` of shape ``(n, 4)``, A1..A4 of rank 0, as
    ``eval.predictor.SMRPredictor``) and ``classes_``. ``distance`` is the metric of ``eval.distances`` that the
    descriptors' method uses; it is required with ``references`` (``from_descriptors`` reads it from the file).
    ``matcher``: the sequence matcher (default ``seqslam`` with velocities [1.0], the paper's fixed matcher), as the
    batch ``attributes`` stage takes it (a ``MatcherSpec``, or a ``Matcher`` built for ``seq_len``): each step equals
    the batch result of its query. ``r_window``: uniqueness's window, for a matcher whose native confidence it is
    (method §12's ``baselines.r_window``). ``thresholds``: a threshold file (``LiveThresholds``), whose decision
    each result's ``accepted`` holds; it must be of this matcher, length and method (``from_descriptors``' file's).
    """

    def __init__(self, seq_len: int, references: np.ndarray | None = None, predictor: Any = None,
                 distance: str | None = None, n_ranks: int = 4, matcher: MatcherSpec | Matcher | None = None,
                 r_window: int = DEFAULT_R_WINDOW, thresholds: LiveThresholds | None = None) -> None:
        self.matcher = built_matcher(matcher, seq_len)
        # a built matcher's spec is made when a loaded predictor is compared with it (an unregistered one has none)
        self.spec = matcher if isinstance(matcher, MatcherSpec) else MatcherSpec.of() if matcher is None else None
        check_live(self.matcher)
        self.n_native = 0 if self.matcher.native_scorer is None else candidates_needed(r_window, 1)
        self.window = half_window(r_window)
        self.r_window = r_window
        self.engine = attribute_engine(self.matcher)  # the attributes' trajectories
        self._state = self.matcher.initial_state()
        self.references = _prepared_references(references, distance, "LiveMatcher", "path, seq_len")
        self.seq_len = seq_len
        self.distance = distance
        self.predictor = predictor  # checked against the matcher (the property's setter)
        self.n_ranks = n_ranks
        self._buffer: np.ndarray | None = None  # (frames_needed, R) ring of the last columns
        self._own: MatchBlock | None = None  # the last pushed frame's block, for a matcher with its own
        self.frames = 0
        # set by from_descriptors: the file's method and its settings (to build the same backend for new frames)
        self.method: str | None = None
        self.method_settings: dict[str, Any] | None = None
        self.thresholds = thresholds  # checked against the matcher, the length and the predictor (the setter)

    @property
    def thresholds(self) -> LiveThresholds | None:
        return self._thresholds

    @thresholds.setter
    def thresholds(self, thresholds: LiveThresholds | None) -> None:
        if thresholds is not None:
            from vpr_smr.eval.matching.ground_truth_files import file_sha256

            path = getattr(self.predictor, "path_", None)  # a loaded predictor's file
            thresholds.check_live(str(self._spec()), self.matcher.native_scorer, self.method, self.seq_len,
                                  None if path is None or not Path(path).is_file() else file_sha256(path),
                                  self.predictor is not None, self.r_window)
        self._thresholds = thresholds

    def _spec(self) -> MatcherSpec:
        """This matcher's spec (made from a built matcher's name and settings)."""
        if self.spec is None:
            self.spec = MatcherSpec.of(self.matcher.name, dataclasses.asdict(self.matcher.settings),
                                       "LiveMatcher(matcher=)")
        return self.spec

    @property
    def predictor(self) -> Any:
        return self._predictor

    @predictor.setter
    def predictor(self, predictor: Any) -> None:
        if predictor is not None:  # a loaded one's length (SMRPredictor.load), or the Python API's train's
            check_length(predictor, self.seq_len, f"this LiveMatcher matches {self.seq_len} frames",
                         "a LiveMatcher of L =")
        if predictor is not None and hasattr(predictor, "path_"):  # its attributes must be this matcher's (live
            # frames have no ground truth); a predictor fitted in this process records no matcher to compare
            check_matching(predictor, Matching.of(self._spec()), "a LiveMatcher (matcher=)", ground_truth=False)
        before, self._predictor = getattr(self, "_predictor", None), predictor
        if getattr(self, "_thresholds", None) is not None:  # a threshold file set before: checked against this one
            try:
                self.thresholds = self._thresholds
            except ValueError:
                self._predictor = before  # refused: the matcher keeps the predictor it had
                raise

    @classmethod
    def from_descriptors(cls, path: Path | str, seq_len: int, predictor: Any = None, distance: str | None = None,
                         n_ranks: int = 4, frames: tuple[int, int] | None = None,
                         matcher: MatcherSpec | None = None, thresholds: LiveThresholds | None = None
                         ) -> LiveMatcher:
        """A matcher whose references are the ``reference`` descriptors of ``path`` (a ``vpr-smr descriptors``
        file), compared with its backend's distance (the file's ``distance`` attribute), or with ``distance`` when
        given: a run whose method sets ``distance`` computes its matrices with it, while its descriptor file (which
        the setting does not change) keeps the backend's.

        ``frames = (lo, hi)`` keeps reference frames ``lo .. hi-1`` only (a split, as the batch matrix of that split
        has them); match indices then count from ``lo``. ``method`` and ``method_settings`` of the matcher are the
        file's (``descriptors.extract.build_backend(matcher.method, matcher.method_settings)`` describes new frames
        alike). ``thresholds``: as ``LiveMatcher``'s, its method compared with the file's too.
        """
        references, stored, method, settings = _read_references(path, frames)
        live = cls(seq_len, references=references, predictor=predictor, distance=distance or stored,
                   n_ranks=n_ranks, matcher=matcher)
        live.method, live.method_settings = method, settings
        live.thresholds = thresholds  # after the method is known
        return live

    def step(self, query_descriptor: np.ndarray) -> LiveResult | None:
        """Match one query descriptor against the references (the distance of ``eval.distances``)."""
        if self.references is None:
            raise ValueError("LiveMatcher.step needs references=...; or feed distances with step_distances(column)")
        assert self.distance is not None  # given whenever references are (__init__ refuses them without it)
        return self.step_distances(_query_column(self.references, query_descriptor, self.distance))

    def step_distances(self, column: np.ndarray) -> LiveResult | None:
        """Feed one column of D (the current query's distance to every reference, length R): ``push`` then
        ``current``."""
        self.push(column)
        return self.current()

    @property
    def frames_needed(self) -> int:
        """Frames fed before the first result: the attributes' window of ``L`` columns and the matcher's."""
        return max(self.seq_len, self.matcher.lookback + 1)

    def check_column(self, column: np.ndarray) -> np.ndarray:
        """``column`` as an array, or ValueError when ``push`` could not take it (nothing is written)."""
        column = np.asarray(column)
        if column.ndim != 1:
            raise ValueError(f"a distance column must be 1-D (one value per reference), got shape {column.shape}")
        if self._buffer is None:
            if len(column) < self.seq_len:
                raise ValueError(f"{len(column)} references are too few for sequence length {self.seq_len}")
            self.engine.check_references(len(column))
        elif len(column) != self._buffer.shape[1]:
            raise ValueError(f"expected {self._buffer.shape[1]} distances (one per reference), got {len(column)}")
        check_finite(column[:, None], "distance column", first_column=self.frames)  # refused before it is kept
        return column

    def push(self, column: np.ndarray) -> None:
        """Take one column of D into the window; a matcher with its own block (a filter) matches the frame now,
        since its state must advance every frame whether or not ``current`` is asked."""
        self._take(self.check_column(column))

    def _take(self, column: np.ndarray) -> None:
        """``push`` of a column ``check_column`` passed."""
        lookback, kept = self.matcher.lookback, self.frames_needed  # kept: the attributes' window and the matcher's
        if self._buffer is None:
            dtype = column.dtype if column.dtype in (np.float32, np.float64) else np.float64
            self._buffer = np.empty((kept, len(column)), dtype=dtype)
        self._buffer[self.frames % kept] = column
        self.frames += 1
        self._own = None  # a matcher other than seqslam: its match of this frame, its state carried from the last
        if not self.matcher.scores_are_attribute_sums and self.frames > lookback:
            columns = self._buffer[np.arange(self.frames - lookback - 1, self.frames) % kept]
            self._own, self._state = self.matcher.block(columns, self.frames - lookback - 1, self._state)

    def current(self) -> LiveResult | None:
        """The last pushed frame's matches, attributes, native confidence and prediction; None until
        ``frames_needed`` frames were pushed (no window of L columns, or no match yet). It only reads what ``push``
        kept, so asking twice gives the same result."""
        if self._buffer is None or self.frames < self.frames_needed:
            return None
        kept, own = self.frames_needed, self._own
        window = self._buffer[np.arange(self.frames - self.seq_len, self.frames) % kept]
        n_ranks = min(self.n_ranks, self._buffer.shape[1] - self.engine.first_reference)
        first = self.frames - self.seq_len  # the window's first frame: errors name frames, not window rows
        out = self.engine.block_features(window, n_ranks, first, n_candidates=0 if own is not None else self.n_native)
        native = None
        if own is not None:
            match = int(own.match[0])
            scores = np.asarray(own.scores, dtype=np.float64)[:1]
            out["sequence_match"], out["sequence_distance"] = np.array([match]), scores[0, [match]]
            if self.matcher.native_scorer is None:
                native = float(block_native(self.matcher, own)[0])
            else:
                out["sequence_candidates"], out["sequence_candidate_references"] = smallest_scores(scores,
                                                                                                 self.n_native)
        if native is None:  # the scorer it names, on the frame's candidates (the batch scorers' numbers)
            native = float(uniqueness(out["sequence_candidates"], out["sequence_candidate_references"],
                                      self.window)[0])
        attributes = out["attributes"][0]
        label = keep = accepted = None
        probabilities = classes = None
        if self.predictor is not None:
            probabilities = self.predictor.predict_proba(attributes[:1])
            classes = np.asarray(self.predictor.classes_)
            label = int(classes[np.argmax(probabilities[0])])
            keep = label in KEPT_CLASSES
        if self.thresholds is not None:
            accepted = self.thresholds.frame_accepted(native, float(out["sequence_distance"][0]),
                                                      None if probabilities is None else np.asarray(probabilities)[0],
                                                      classes)
        return LiveResult(
            query=self.frames - 1,
            single_match=int(out["single_match"][0]),
            sequence_match=int(out["sequence_match"][0]),
            sequence_distance=float(out["sequence_distance"][0]),
            attributes=attributes,
            rank_references=out["rank_references"][0],
            label=label,
            keep=keep,
            native=native,
            accepted=accepted,
        )


@dataclass(frozen=True)
class AdaptiveLiveResult:
    """The current query's match at the length chosen for it (method §15's rule ``adaptive``)."""

    query: int  # index of the current frame (0 for the first frame fed)
    seq_len: int | None  # the shortest length whose predictor keeps its match; None when no length's does
    result: LiveResult  # the chosen length's result; the longest length's when none kept the match
    computed: tuple[int, ...]  # the lengths whose attributes and prediction were computed, shortest first: up to
    # the chosen one, or every length when none kept


class AdaptiveLiveMatcher:
    """Feed one frame at a time, matched at several sequence lengths: per frame the shortest length whose predictor
    keeps its match (``step(query_descriptor)``, needs ``references``, or ``step_distances(column)``).

    ``lengths``: two or more sequence lengths, strictly increasing; ``predictors[i]``: the predictor of
    ``lengths[i]`` (as ``LiveMatcher`` takes one, checked against the matcher alike). Every length's window takes
    every frame (a filter's state advances every frame), but the attributes and the prediction are computed
    shortest first and stop at the first length that keeps the match: the live cost the rule saves. The choice is
    ``adaptive.first_accepted``'s, the batch experiment's rule. ``matcher``: a ``MatcherSpec`` (built once per
    length), default ``seqslam``; the other arguments as ``LiveMatcher``'s.
    """

    def __init__(self, lengths: tuple[int, ...] | list[int], predictors: tuple[Any, ...] | list[Any],
                 references: np.ndarray | None = None, distance: str | None = None, n_ranks: int = 4,
                 matcher: MatcherSpec | None = None, r_window: int = DEFAULT_R_WINDOW) -> None:
        self.lengths = tuple(int(length) for length in lengths)
        predictors = tuple(predictors)
        if len(self.lengths) < 2 or any(b <= a for a, b in zip(self.lengths, self.lengths[1:], strict=False)):
            raise ValueError(f"lengths={list(self.lengths)}: an AdaptiveLiveMatcher chooses among two or more "
                             "sequence lengths given in strictly increasing order (e.g. lengths=[2, 4, 8]); for "
                             "one length use LiveMatcher")
        if len(predictors) != len(self.lengths):
            raise ValueError(f"predictors= has {len(predictors)} predictor(s) for lengths={list(self.lengths)}: "
                             "give one per length, predictors[i] the one trained at lengths[i]")
        missing = [length for length, p in zip(self.lengths, predictors, strict=True) if p is None]
        if missing:
            raise ValueError(f"predictors= has None for the length(s) {missing}: the length is chosen by each "
                             "length's predictor; give the one trained at each length")
        if isinstance(matcher, Matcher):
            raise ValueError(f"matcher= is the matcher {matcher.name!r} built for sequence length {matcher.seq_len}: "
                             "give its MatcherSpec, which an AdaptiveLiveMatcher builds at each length")
        self.distance = distance
        self.references = _prepared_references(references, distance, "AdaptiveLiveMatcher",
                                               "path, lengths, predictors")
        # one LiveMatcher per length (check_live's refusals are theirs); they take columns, not descriptors
        self.matchers = tuple(LiveMatcher(length, predictor=predictor, n_ranks=n_ranks, matcher=matcher,
                                          r_window=r_window)
                              for length, predictor in zip(self.lengths, predictors, strict=True))
        self.frames_needed = max(live.frames_needed for live in self.matchers)  # before every length has a result
        self.frames = 0
        # set by from_descriptors, as LiveMatcher's
        self.method: str | None = None
        self.method_settings: dict[str, Any] | None = None

    @classmethod
    def from_descriptors(cls, path: Path | str, lengths: tuple[int, ...] | list[int],
                         predictors: tuple[Any, ...] | list[Any], distance: str | None = None, n_ranks: int = 4,
                         frames: tuple[int, int] | None = None,
                         matcher: MatcherSpec | None = None) -> AdaptiveLiveMatcher:
        """References, distance, ``frames`` and ``method`` from a descriptor file, as ``LiveMatcher``'s."""
        references, stored, method, settings = _read_references(path, frames)
        live = cls(lengths, predictors, references=references, distance=distance or stored, n_ranks=n_ranks,
                   matcher=matcher)
        live.method, live.method_settings = method, settings
        return live

    def step(self, query_descriptor: np.ndarray) -> AdaptiveLiveResult | None:
        """Match one query descriptor against the references (the distance of ``eval.distances``)."""
        if self.references is None:
            raise ValueError("AdaptiveLiveMatcher.step needs references=...; or feed distances with "
                             "step_distances(column)")
        assert self.distance is not None  # given whenever references are (__init__ refuses them without it)
        return self.step_distances(_query_column(self.references, query_descriptor, self.distance))

    def step_distances(self, column: np.ndarray) -> AdaptiveLiveResult | None:
        """Feed one column of D; None until every length has a result (the first ``frames_needed - 1`` frames)."""
        for live in self.matchers:  # every length takes the column or none does
            column = live.check_column(column)
        for live in self.matchers:
            live._take(column)  # checked above
        self.frames += 1
        if self.frames < self.frames_needed:
            return None
        accepted = np.zeros((len(self.lengths), 1), dtype=bool)  # lengths not computed stay False: after a kept one
        results: list[LiveResult] = []
        for i, live in enumerate(self.matchers):
            result = live.current()
            assert result is not None and result.keep is not None  # every length is ready; each has a predictor
            results.append(result)
            accepted[i, 0] = result.keep
            if result.keep:
                break
        row = int(first_accepted(accepted)[0])
        return AdaptiveLiveResult(query=results[-1].query, seq_len=None if row == NONE else self.lengths[row],
                                  result=results[-1] if row == NONE else results[row],
                                  computed=self.lengths[: len(results)])


def _prepared_references(references: np.ndarray | None, distance: str | None, who: str, arguments: str
                         ) -> np.ndarray | None:
    """The references prepared for ``distance``; ValueError naming ``who`` when they come without it."""
    if references is None:
        return None
    if distance is None:
        raise ValueError(f"{who} with references needs distance=, the metric of the descriptors' method "
                         "('mad' for sad, 'l2' for the learned backends, or the method's distance setting); "
                         f"{who}.from_descriptors({arguments}) reads both from a descriptor file")
    prepared: np.ndarray = prepare_references(references, distance)
    return prepared


def check_live(matcher: Matcher) -> None:
    """ValueError naming the matcher and the fix when it cannot run one frame at a time as its batch does: it reads
    columns after its query (a centred window: the setting ``alignment: trailing`` where it has one), it prepares
    its state from a pass over the whole split (``Matcher.prepare``), or its native confidence is a §12 scorer
    other than ``uniqueness``, which a frame's scores do not give."""
    # first: a matcher that needs the whole split (openseqslam, either alignment) is told so, not sent to a
    # setting that would not help
    if type(matcher).prepare is not Matcher.prepare:
        raise ValueError(f"the matcher {matcher.name!r} prepares its state from a pass over the whole split before "
                         "its first block (its prepare): a LiveMatcher has no frame to come; match the recorded "
                         "traverse in batch (vpr-smr attributes)")
    if matcher.lookahead > 0:
        fix = ("give it the setting alignment: trailing (its window ends at the query)"
               if hasattr(matcher.settings, "alignment")
               else "give it settings whose window ends at the query, or match the recorded traverse in batch")
        raise ValueError(f"the matcher {matcher.name!r} reads {matcher.lookahead} columns after its query (a "
                         f"centred window): a LiveMatcher has no frame to come; {fix}")
    if matcher.native_scorer not in (None, LIVE_NATIVE_SCORER):
        raise ValueError(f"the matcher {matcher.name!r} names the scorer {matcher.native_scorer!r} as its native "
                         f"confidence, which a frame's own scores do not give: a LiveMatcher gives its own "
                         f"(MatchBlock.native) or {LIVE_NATIVE_SCORER}'s")


def _text(value: Any) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def _query_column(references: np.ndarray, query_descriptor: np.ndarray, distance: str) -> np.ndarray:
    """The query's distance to every (prepared) reference, as the batch matrices compute it."""
    query = np.asarray(query_descriptor, dtype=np.float32).reshape(1, -1)
    column: np.ndarray = distance_columns(references, query, distance)[:, 0]
    return column


def _read_references(path: Path | str, frames: tuple[int, int] | None
                     ) -> tuple[np.ndarray, str, str, dict[str, Any] | None]:
    """The ``reference`` descriptors of a descriptor file (frames ``lo .. hi-1``), its distance, method and the
    method's settings."""
    import json

    from vpr_smr.core.io import open_h5

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"descriptor file not found: {path} (compute it with vpr-smr descriptors)")
    with open_h5(path, "a descriptor file written by vpr-smr descriptors") as f:
        if "reference" not in f or "distance" not in f.attrs:
            raise ValueError(f"{path} lacks the 'reference' descriptors or the 'distance' attribute: give a "
                             "descriptor file written by vpr-smr descriptors (or compute it again)")
        stored = _text(f.attrs["distance"])
        method = _text(f.attrs.get("method", "?"))
        settings = json.loads(_text(f.attrs["method_conf"])) if "method_conf" in f.attrs else None
        n_frames = len(f["reference"])
        lo, hi = (0, n_frames) if frames is None else (int(frames[0]), int(frames[1]))
        if not 0 <= lo < hi <= n_frames:
            raise ValueError(f"{path}: frames {lo}..{hi - 1} are outside its {n_frames} reference frames")
        references = f["reference"][lo:hi]
    return references, stored, method, settings
