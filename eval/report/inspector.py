"""The match inspector: see where sequence matching and the predictor go wrong, query by query.

Two PNG figures of one method, dataset, sequence length ``L`` and split (the workflow: the table split):

- the match figure: a fixed, seeded sample of queries (``sample_queries``: a few per true class and the
  predictor's most confident mistakes), one row each: the ``L`` query frames of the sequence, the single-frame
  match, the sequence match and the true reference as thumbnails, framed green (correct) or red (wrong) and
  captioned with their distances, and what the predictor decided (kept or removed, right or wrong);
  A matcher other than ``seqslam`` gets one more panel per row, its own scores ``s_a`` around the match (the strip
  ``STRIP_HALF`` references either side, from one pass of the matcher over the split: a filter's belief included),
  where SeqSLAM's sequence distance ``S`` would be read off its path;
- the distance-matrix figure: the split's ``D`` (references x queries, block means when large), the ground truth
  (the band ``|r - q| <= tolerance``, or the outline of the correct matches of positions or a ground-truth matrix)
  and every sequence match, kept or removed by the predictor.

The match figure needs the dataset's images; without them (a user's matrix and its queries CSV) the distance-matrix
figure is drawn alone.

The queries come from the queries CSV (``eval.scoring``'s, one row per evaluated query), read by column name; its
frame indices are the dataset's, the distance matrix's are the split's (``D[r - ref_lo, q - lo]``; ``ref_lo``
is ``lo`` unless the split has its own reference range).
"""

from __future__ import annotations

import csv
import math
import textwrap
from collections.abc import Sequence
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import h5py
import numpy as np

from vpr_smr.core.io import atomic_path, check_suffix, read_provenance
from vpr_smr.core.json_objects import json_object
from vpr_smr.eval.matching.attributes import ATTRIBUTE_NAMES
from vpr_smr.eval.matching.features import match_blocks
from vpr_smr.eval.matching.ground_truth import POSITIONS, GroundTruth
from vpr_smr.eval.matching.ground_truth_files import read_ground_truth
from vpr_smr.eval.matching.io import is_user_matrix, open_distance_matrix, scored_shape, split_ground_truth
from vpr_smr.eval.matching.matchers import MatcherSpec
from vpr_smr.eval.matching.matchers.base import Matcher
from vpr_smr.eval.report.figures import DOWN, UP, _pyplot
from vpr_smr.eval.report.job import InspectJob as InspectJob  # the job record, re-exported: a light module's
from vpr_smr.eval.scoring.queries import MATCHER_COLUMN, OLD_MATCHER_COLUMN, QUERY_COLUMNS, row_matcher

if TYPE_CHECKING:  # the datasets (OpenCV) are imported when the stage runs, not when its command line is built
    from vpr_smr.datasets import TraversePair

# The columns of the queries CSV the inspector reads (by name; the attributes are not shown); a table of vpr-smr 0.9
# names its matcher in OLD_MATCHER_COLUMN instead (queries.row_matcher).
COLUMNS = tuple(c for c in QUERY_COLUMNS if c not in ATTRIBUTE_NAMES)
CLASS_TEXT = {0: "correct before and after SM", 1: "correct before SM only", 2: "correct after SM only",
              3: "wrong before and after SM"}
THUMB_HEIGHT = 96  # pixels: larger images are downscaled to this height (INTER_AREA)
MATCH_DPI = 80  # the match figure has many thumbnails: a moderate resolution keeps the PNG small
MATRIX_DPI = 110
MAX_DISPLAY = 800  # the distance matrix is shown as block means of at most this many rows and columns
READ_VALUES = 1 << 24  # values of the distance matrix read at a time (64 MB of float32)
NEUTRAL = "0.55"  # frame of a query thumbnail (neither correct nor wrong)
STRIP_HALF = 10  # references either side of the match in a matcher's score strip


@dataclass(frozen=True)
class QueryRow:
    """One evaluated query of the queries CSV; frame indices are the dataset's. Without a predictor,
    ``predicted_class``, ``probability`` and ``kept`` are None."""

    split: str
    query: int
    single_match: int
    single_distance: float
    single_correct: bool
    sequence_match: int
    sequence_distance: float
    sequence_correct: bool
    true_reference: int | None  # None: the query has no correct reference
    label: int
    predicted_class: int | None
    probability: float | None
    kept: bool | None
    matcher: str  # the sequence matcher, as the CSV writes it (``str(MatcherSpec)``; ``queries.row_matcher``)

    @property
    def mistake(self) -> bool:
        """The predictor's class is not the true one."""
        return self.predicted_class is not None and self.predicted_class != self.label

    @property
    def right_decision(self) -> bool | None:
        """Kept and correct after sequence matching, or removed and wrong: the predictor decided right."""
        return None if self.kept is None else self.kept == self.sequence_correct


@dataclass(frozen=True)
class Sampled:
    """A sampled query and why it was chosen (``class 1 sample``, ``confident mistake``, or both)."""

    row: QueryRow
    reason: str


@dataclass(frozen=True)
class SplitMatrix:
    """A split's distance matrix as the figures place it: ``matrix`` (references x queries, split-local), its query
    frame ``f`` in column ``f - lo``, its reference frame ``f`` in row ``f - reference_lo`` (None: ``lo``, one range
    of frames for both traverses; method §11 gives a split a reference range of its own)."""

    matrix: Any
    lo: int
    reference_lo: int | None = None

    @property
    def ref_lo(self) -> int:
        """The dataset frame of the matrix's first row."""
        return self.lo if self.reference_lo is None else self.reference_lo


@dataclass(frozen=True)
class MatchRecord:
    """What the match figure shows: per row, the query and the dataset frames of its thumbnails in order
    (``L`` query frames, then the single-frame match, the sequence match and the true reference)."""

    queries: tuple[int, ...]
    frames: tuple[tuple[int | None, ...], ...]  # None: a query without a correct reference has no true one
    reasons: tuple[str, ...]
    # a matcher other than seqslam: per row, the first reference frame of its score strip and s_a there (+inf
    # where nothing of the matcher reaches a reference); None for seqslam, whose S the captions give
    strips: tuple[tuple[int, tuple[float, ...]], ...] | None = None


@dataclass(frozen=True)
class MatrixRecord:
    """What the distance-matrix figure shows: the matrix's shape, the block size of the display (1: every
    value), and how many sequence matches were drawn as kept, removed, or without a prediction."""

    shape: tuple[int, int]
    block: int
    kept: int
    removed: int
    unpredicted: int


def _optional(value: str, kind: type) -> Any:
    return None if value.strip() == "" else kind(value)


def _flag(value: str) -> bool:
    return bool(int(float(value)))


def _row(record: dict[str, str], where: str) -> QueryRow:
    if int(record["label"]) not in CLASS_TEXT:
        raise ValueError(f"label {record['label']!r} is not a class 0..3 (method §6)")
    kept = _optional(record["kept"], float)
    return QueryRow(
        split=record["split"], query=int(record["query"]), single_match=int(record["single_match"]),
        single_distance=float(record["single_distance"]), single_correct=_flag(record["single_correct"]),
        sequence_match=int(record["sequence_match"]), sequence_distance=float(record["sequence_distance"]),
        sequence_correct=_flag(record["sequence_correct"]), true_reference=_optional(record["true_reference"], int),
        label=int(record["label"]), predicted_class=_optional(record["predicted_class"], int),
        probability=_optional(record["probability"], float), kept=None if kept is None else bool(kept),
        matcher=row_matcher(record, where),
    )


def read_queries(path: Path | str) -> list[QueryRow]:
    """The rows of a queries CSV, by column name; a missing file or column, or a bad value, raises naming it."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"queries CSV not found: {path}")
    with path.open(newline="") as f:
        reader = csv.DictReader(f)
        names = reader.fieldnames or ()
        old = OLD_MATCHER_COLUMN in names  # a table of vpr-smr 0.9
        missing = [c for c in COLUMNS if c not in names and not (old and c == MATCHER_COLUMN)]
        if missing:
            raise ValueError(f"{path} lacks the columns {', '.join(missing)}: is it a queries CSV of the workflow "
                             "(`vpr-smr queries`)? Run the workflow again")
        rows = []
        for line, record in enumerate(reader, start=2):
            try:
                rows.append(_row(record, f"{path}, line {line}"))
            except (TypeError, ValueError) as error:
                raise ValueError(f"{path}, line {line}: {error}") from None
    return rows


def sample_queries(rows: Sequence[QueryRow], split: str, per_class: int = 2, mistakes: int = 4,
                   seed: int = 0) -> list[Sampled]:
    """A stratified, seeded sample of ``split``'s queries, sorted by query index.

    Up to ``per_class`` queries of each true class 0..3, drawn with ``numpy.random.default_rng(seed)`` (classes in
    order, each class's queries in index order), plus the predictor's ``mistakes`` most confident mistakes
    (predicted class != true class, highest probability first, ties by query index). A query chosen both ways
    appears once, with both reasons. The same rows, split and seed give the same sample.
    """
    if per_class < 0 or mistakes < 0:
        raise ValueError(f"per_class ({per_class}) and mistakes ({mistakes}) must be >= 0")
    in_split = sorted((r for r in rows if r.split == split), key=lambda r: r.query)
    rng = np.random.default_rng(seed)
    reasons: dict[int, list[str]] = {}
    by_query = {r.query: r for r in in_split}
    for label in sorted(CLASS_TEXT):
        members = [r.query for r in in_split if r.label == label]
        if not members:
            continue
        chosen = rng.choice(len(members), size=min(per_class, len(members)), replace=False)
        for index in sorted(int(i) for i in chosen):
            reasons.setdefault(members[index], []).append(f"class {label} sample")
    wrong = sorted((r for r in in_split if r.mistake), key=lambda r: (-(r.probability or 0.0), r.query))
    for r in wrong[:mistakes]:
        reasons.setdefault(r.query, []).append("confident mistake")
    return [Sampled(by_query[q], "; ".join(reasons[q])) for q in sorted(reasons)]


def thumbnail(image: np.ndarray, height: int = THUMB_HEIGHT) -> np.ndarray:
    """``image`` downscaled (INTER_AREA) to ``height`` rows when taller, the aspect ratio kept; else unchanged."""
    import cv2  # here: the stage's command line is built without OpenCV (about 0.15 s to import)

    if image.shape[0] <= height:
        return image
    width = max(1, round(image.shape[1] * height / image.shape[0]))
    return np.asarray(cv2.resize(image, (width, height), interpolation=cv2.INTER_AREA))


def _frame(ax: Any, colour: str, width: float) -> None:
    ax.set_xticks([])
    ax.set_yticks([])
    for spine in ax.spines.values():
        spine.set_edgecolor(colour)
        spine.set_linewidth(width)


def _verdict(correct: bool) -> tuple[str, str]:
    return ("correct", UP) if correct else ("wrong", DOWN)


def matcher_scores(matcher: Matcher, matrix: Any, queries: Sequence[int]) -> dict[int, np.ndarray]:
    """``s_a`` (float64, one per reference) of the split-local ``queries`` the matcher evaluates, from one pass of
    the matcher over the whole split (``features.match_blocks``: its state carried, as the queries CSV's matches
    were made)."""
    wanted, out = set(queries), {}
    for found, _, _ in match_blocks(matcher, matrix):
        for n, query in enumerate(np.asarray(found.queries).tolist()):
            if query in wanted:
                out[int(query)] = np.asarray(found.scores[n], dtype=np.float64)
    return out


def _true_score(window: np.ndarray, reference: int, matcher: Matcher, scores: np.ndarray | None) -> float | None:
    """``s_a[reference]`` of the run's matcher: from its pass over the split (``scores``, ``matcher_scores``), or
    for seqslam from ``window`` (split-local rows x the columns its match reads); None when nothing of the matcher
    reaches it."""
    if not 0 <= reference < window.shape[0]:
        return None
    if scores is None:
        found, _ = matcher.block(window.T, 0, matcher.initial_state())
        scores = found.scores[0]
    score = float(scores[reference])
    return score if np.isfinite(score) else None


def score_strip(scores: np.ndarray, match: int, half: int = STRIP_HALF) -> tuple[int, np.ndarray]:
    """The strip of ``scores`` around ``match``: references ``max(0, match - half) .. match + half`` (those that
    exist), as (its first reference, its values)."""
    first = max(0, match - half)
    return first, scores[first : match + half + 1]


def _decision_lines(row: QueryRow) -> list[tuple[str, str]]:
    lines = [(f"query {row.query}", "black"), (f"true class {row.label}: {CLASS_TEXT[row.label]}", "black")]
    if row.predicted_class is None:
        return [*lines, ("no predictor: every match kept", "0.4")]
    probability = "" if row.probability is None else f" (p = {row.probability:.2f})"
    lines.append((f"predicted class {row.predicted_class}{probability}",
                  "black" if row.predicted_class == row.label else DOWN))
    if row.kept is not None:
        right = row.right_decision
        lines.append((f"{'kept' if row.kept else 'removed'}: {'right' if right else 'wrong'} decision",
                      UP if right else DOWN))
    return lines


def draw_matches(path: Path | str, pair: TraversePair, samples: Sequence[Sampled], split: SplitMatrix,
                 matcher: Matcher, title: str) -> MatchRecord:
    """The match figure of ``samples`` (see the module's docstring) to ``path`` (PNG, written as given).

    ``split`` is the split's distance matrix, read for the true reference's distances (``S``: ``s_a`` of the run's
    ``matcher``, built at the sequence length ``L``: ``MatcherSpec.of().build(L)`` is the paper's); the thumbnails
    are ``pair``'s images.
    """
    matrix, lo, reference_lo = split.matrix, split.lo, split.ref_lo
    built, seq_len = matcher, matcher.seq_len
    if not samples:
        raise ValueError("no queries to show: the sample is empty")
    # a matcher other than seqslam: its own scores, from one pass over the split (a filter's state included)
    own = (None if built.scores_are_attribute_sums
           else matcher_scores(built, matrix, [s.row.query - lo for s in samples]))
    symbol = "S" if own is None else "s"
    plt = _pyplot()
    cache: dict[tuple[str, int], np.ndarray] = {}

    def image(side: str, index: int) -> np.ndarray:
        if (side, index) not in cache:
            traverse = pair.query if side == "query" else pair.reference
            cache[side, index] = thumbnail(traverse.read(index))
        return cache[side, index]

    first = image("query", samples[0].row.query)
    aspect = first.shape[1] / first.shape[0]
    thumb_h = 0.95
    thumb_w = min(2.4, max(0.7, thumb_h * aspect))
    n_thumbs = seq_len + 3
    text_w = 3.3
    strip_w = [] if own is None else [2.6]
    fig_w, fig_h = n_thumbs * (thumb_w + 0.08) + sum(strip_w) + text_w, len(samples) * (thumb_h + 0.62) + 0.9
    fig = plt.figure(figsize=(fig_w, fig_h), layout="constrained")
    grid = fig.add_gridspec(len(samples), n_thumbs + len(strip_w) + 1,
                            width_ratios=[thumb_w] * n_thumbs + strip_w + [text_w])
    strips: list[tuple[int, tuple[float, ...]]] = []
    headers = [f"query t-{seq_len - 1 - k}" for k in range(seq_len - 1)] + ["query t", "single-frame match",
                                                                           "sequence match", "true reference"]
    frames = []
    for i, sample in enumerate(samples):
        row = sample.row
        q = row.query - lo
        window = np.asarray(matrix[:, q - built.lookback : q + built.lookahead + 1], dtype=np.float64)
        single_word, single_colour = _verdict(row.single_correct)
        sequence_word, sequence_colour = _verdict(row.sequence_correct)
        if row.true_reference is None:
            true_text = "no correct reference"
        else:
            true_local = row.true_reference - reference_lo
            true_d = float(window[true_local, built.lookback]) if 0 <= true_local < window.shape[0] else None
            true_s = _true_score(window, true_local, built, None if own is None else own.get(q))
            true_text = f"true r={row.true_reference}"
            true_text += "" if true_d is None else (f"\nD={true_d:.4g}"
                                                    + ("" if true_s is None else f" {symbol}={true_s:.4g}"))
        query_frames = [row.query - seq_len + 1 + k for k in range(seq_len)]
        shown: list[tuple[str, int | None, str, str, float]] = [
            ("query", f, f"q {f}", NEUTRAL if k < seq_len - 1 else "black", 1.0 if k < seq_len - 1 else 2.0)
            for k, f in enumerate(query_frames)]
        shown += [
            ("reference", row.single_match, f"single r={row.single_match}\nD={row.single_distance:.4g} "
             f"{single_word}", single_colour, 3.5),
            ("reference", row.sequence_match, f"sequence r={row.sequence_match}\n{symbol}={row.sequence_distance:.4g} "
             f"{sequence_word}", sequence_colour, 3.5),
            ("reference", row.true_reference, true_text, NEUTRAL, 1.5),
        ]
        for j, (side, frame, caption, colour, width) in enumerate(shown):
            ax = fig.add_subplot(grid[i, j])
            if frame is None:  # a query without a correct reference: nothing to show but the caption
                ax.set_xticks([])
                ax.set_yticks([])
            else:
                ax.imshow(image(side, frame), interpolation="nearest", aspect="auto")
            _frame(ax, colour, width)
            ax.set_xlabel(caption, fontsize=7, labelpad=2)
            if i == 0:
                ax.set_title(headers[j], fontsize=8)
        frames.append(tuple(frame for _, frame, *_ in shown))
        if own is not None and q in own:
            first_r, values = score_strip(own[q], row.sequence_match - reference_lo)
            strips.append((first_r + reference_lo, tuple(values.tolist())))
            ax = fig.add_subplot(grid[i, n_thumbs])
            x = reference_lo + first_r + np.arange(len(values))
            ax.plot(x, np.where(np.isfinite(values), values, np.nan), color="black", lw=0.9, marker=".", ms=3)
            ax.axvline(row.sequence_match, color=sequence_colour, lw=1.2)
            if row.true_reference is not None and x[0] <= row.true_reference <= x[-1]:
                ax.axvline(row.true_reference, color="tab:cyan", lw=1.0, ls="--")
            ax.tick_params(labelsize=6)
            ax.set_xlabel("reference frame", fontsize=7, labelpad=2)
            if i == 0:
                ax.set_title(f"{built.name}'s scores s (match: line, true: dashed)", fontsize=8)
        text = fig.add_subplot(grid[i, n_thumbs + len(strip_w)])
        text.axis("off")
        lines = [*_decision_lines(row), (f"chosen: {sample.reason}", "0.35")]
        for k, (line, colour) in enumerate(lines):
            text.text(0.0, 1.0 - k / max(len(lines), 5), line, fontsize=7.5, color=colour, va="top",
                      transform=text.transAxes)
    fig.suptitle(textwrap.fill(title, width=max(40, int(fig_w * 11))), fontsize=9)
    fig.savefig(path, dpi=MATCH_DPI, format="png", bbox_inches="tight")
    plt.close(fig)
    return MatchRecord(tuple(s.row.query for s in samples), tuple(frames), tuple(s.reason for s in samples),
                       None if own is None else tuple(strips))


def block_means(matrix: Any, block: int) -> np.ndarray:
    """``matrix`` (R x Q, read by column blocks) as the means of ``block x block`` tiles, the last tiles of a row
    or column over what is left: ``ceil(R / block) x ceil(Q / block)``, float32."""
    n_rows, n_cols = matrix.shape
    rows, cols = math.ceil(n_rows / block), math.ceil(n_cols / block)
    out = np.empty((rows, cols), dtype=np.float32)
    step = block * max(1, READ_VALUES // max(n_rows * block, 1))
    for start in range(0, n_cols, step):
        part = np.asarray(matrix[:, start : start + step], dtype=np.float64)
        width = math.ceil(part.shape[1] / block)
        padded = np.full((rows * block, width * block), np.nan)
        padded[:n_rows, : part.shape[1]] = part
        tiles = padded.reshape(rows, block, width, block)
        out[:, start // block : start // block + width] = np.nanmean(tiles, axis=(1, 3))
    return out


def draw_matrix(path: Path | str, split: SplitMatrix, rows: Sequence[QueryRow], tolerance: int, title: str,
                ground_truth: GroundTruth | None = None) -> MatrixRecord:
    """The distance-matrix figure to ``path`` (PNG, written as given): the ``split``'s matrix in dataset frame
    indices, the queries (x) from its ``lo``, the references (y) from its ``ref_lo``; the ground truth (the band
    ``|r - q| <= tolerance``, or the outline of ``ground_truth``'s correct matches when it is not that band or the
    two ranges differ) and the sequence matches of ``rows``."""
    plt = _pyplot()
    matrix, lo, ref_lo = split.matrix, split.lo, split.ref_lo
    n_refs, n_queries = matrix.shape
    # scoring counts indices from each range's first frame: the same ground truth, placed by those offsets
    truth = GroundTruth.aligned(n_refs, n_queries, tolerance) if ground_truth is None else ground_truth
    block = max(1, math.ceil(max(n_refs, n_queries) / MAX_DISPLAY))
    shown = block_means(matrix, block)
    fig, ax = plt.subplots(figsize=(7.6, 7.4), layout="constrained")
    image = ax.imshow(shown, cmap="gray", interpolation="nearest", aspect="auto",
                      extent=(lo - 0.5, lo - 0.5 + shown.shape[1] * block, ref_lo - 0.5 + shown.shape[0] * block,
                              ref_lo - 0.5))
    fig.colorbar(image, ax=ax, shrink=0.8, label="distance D (dark = similar)")
    last_q, last_r = lo + n_queries - 1, ref_lo + n_refs - 1
    if truth.is_aligned_band() and ref_lo == lo:
        band = np.array([lo, last_q], dtype=float)
        for offset, label in ((-tolerance, f"ground truth |r - q| <= {tolerance}"), (tolerance, None)):
            ax.plot(band, band + offset, color="tab:cyan", lw=0.7, label=label)
    else:
        # the correct matches at the shown resolution (one frame per block), outlined
        refs, queries = np.arange(0, n_refs, block), np.arange(0, n_queries, block)
        correct = truth.correct(refs[:, None], queries[None, :]).astype(float)
        if correct.any():
            ax.contour(lo + queries, ref_lo + refs, correct, levels=[0.5], colors="tab:cyan", linewidths=0.7)
            rule = (f"|(r - {ref_lo}) - (q - {lo})| <= {tolerance}" if truth.is_aligned_band()
                    else f"{truth.describe()} of the query's" if truth.kind == POSITIONS else truth.describe())
            ax.plot([], [], color="tab:cyan", lw=0.7, label=f"ground truth: {rule}")
    kept = [r for r in rows if r.kept is True]
    removed = [r for r in rows if r.kept is False]
    unpredicted = [r for r in rows if r.kept is None]
    size = 9 if len(rows) <= 2000 else 5
    if kept:
        ax.scatter([r.query for r in kept], [r.sequence_match for r in kept], s=size, color=UP, marker="o",
                   linewidths=0, zorder=3, label=f"sequence match kept by the predictor ({len(kept)})")
    if removed:
        ax.scatter([r.query for r in removed], [r.sequence_match for r in removed], s=size * 2, color=DOWN,
                   marker="x", linewidths=0.8, zorder=3,
                   label=f"sequence match removed by the predictor ({len(removed)})")
    if unpredicted:
        ax.scatter([r.query for r in unpredicted], [r.sequence_match for r in unpredicted], s=size,
                   color="tab:orange", marker="o", linewidths=0, zorder=3,
                   label=f"sequence match, no prediction ({len(unpredicted)})")
    ax.set(xlim=(lo - 0.5, last_q + 0.5), ylim=(last_r + 0.5, ref_lo - 0.5), xlabel="query frame (dataset index)",
           ylabel="reference frame (dataset index)")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.08), ncol=2, fontsize=7, markerscale=2)
    note = (f"D is {n_refs} x {n_queries}, shown as means of {block} x {block} blocks" if block > 1
            else f"D is {n_refs} x {n_queries}, every value shown")
    fig.suptitle(textwrap.fill(f"{title}. {note}.", width=95), fontsize=9)
    fig.savefig(path, dpi=MATRIX_DPI, format="png", bbox_inches="tight")
    plt.close(fig)
    return MatrixRecord((n_refs, n_queries), block, len(kept), len(removed), len(unpredicted))


def _text(value: Any) -> str | None:
    if value is None:
        return None
    return value.decode() if isinstance(value, bytes) else str(value)


def _distance_provenance(path: Path) -> dict[str, Any]:
    return read_provenance(path) if not is_user_matrix(path) and h5py.is_hdf5(path) else {}


def _split_range(path: Path, provenance: dict[str, Any], given: tuple[int, int] | None,
                 n_queries: int) -> tuple[int, int]:
    stored = provenance.get("split_range")
    stored_range = None if stored is None else (int(stored[0]), int(stored[1]))
    if given is not None and stored_range is not None and tuple(given) != stored_range:
        raise ValueError(f"{path} holds frames {stored_range[0]}..{stored_range[1] - 1}, not the split's "
                         f"{given[0]}..{given[1] - 1}: run the workflow again")
    split_range = given if given is not None else stored_range
    if split_range is None and (is_user_matrix(path) or not h5py.is_hdf5(path)):
        # a user's matrix: `vpr-smr queries` numbers its queries from 0, so the inspector does too
        return 0, n_queries
    if split_range is None:
        raise ValueError(f"{path} does not say which frames it covers: give the split's frames (--frames LO HI)")
    return int(split_range[0]), int(split_range[1])


def _check_dataset(dataset_name: str | None, dataset_settings: dict[str, Any] | None,
                   match_figure: Path | None) -> None:
    """Before any work: the match figure shows the frames' images, so it needs a dataset that has a loader."""
    if (dataset_name is None) != (dataset_settings is None):
        raise ValueError("give --dataset NAME and --dataset-settings JSON together (the dataset whose images the "
                         "match figure shows), or neither")
    if match_figure is None:
        return
    fix = "or leave out --match-figure to draw only the distance-matrix figure (it needs no images)"
    if dataset_settings is None:
        raise ValueError("the match figure shows the frames' images, so it needs a dataset with images: give "
                         "--dataset NAME and --dataset-settings JSON (its configuration entry, e.g. "
                         '{"loader": "folders", "reference": DIR, "query": DIR}), ' + fix)
    if dataset_settings.get("loader") is None:
        raise ValueError(f"--dataset-settings gives dataset {dataset_name!r} no loader, but the match figure shows "
                         "the frames' images, so it needs a dataset with images: give its configuration entry (e.g. "
                         '{"loader": "folders", "reference": DIR, "query": DIR}), ' + fix)


def _split_of(rows: Sequence[QueryRow], queries_csv: Path, split: str | None) -> str:
    """``split``, which the CSV must have; None: the CSV's only split (a user's matrix has one, ``all``)."""
    splits = list(dict.fromkeys(r.split for r in rows))
    named = ", ".join(repr(s) for s in splits) or "none"
    if split is None:
        if len(splits) != 1:
            raise ValueError(f"{queries_csv} has the splits {named}: choose one with --split")
        return splits[0]
    if split not in splits:
        raise ValueError(f"{queries_csv} has no queries of split {split!r} (its splits: {named}): give one of them "
                         "with --split")
    return split


def _check_rows(rows: Sequence[QueryRow], queries_csv: Path, split: str, seq_len: int, lo: int, hi: int,
                matcher: MatcherSpec | None = None) -> None:
    """The CSV's rows of ``split`` are the evaluated queries of frames ``lo .. hi-1`` at ``seq_len``: those the
    ``matcher`` (default ``MatcherSpec.of()``) evaluates with a window of ``L`` columns (seqslam: exactly
    ``lo + L - 1 .. hi - 1``), each once (a CSV made at another L, or for another split, is refused)."""
    if not rows:
        raise ValueError(f"{queries_csv} has no queries of split {split!r}")
    spec = matcher or MatcherSpec.of()
    first, stop = spec.build(seq_len).evaluated(hi - lo)
    queries = sorted(r.query for r in rows)
    expected = list(range(lo + max(first, seq_len - 1), lo + stop))
    if queries != expected:
        first_q, last_q = queries[0], queries[-1]
        found = (f"queries {first_q}..{last_q}" if queries == list(range(first_q, last_q + 1))
                 else f"{len(queries)} queries {first_q}..{last_q}, not one per frame")
        want = f"{expected[0]}..{expected[-1]}" if expected else "none"
        raise ValueError(f"{queries_csv}: split {split!r} has {found}, but at L = {seq_len} the distance matrix of "
                         f"frames {lo}..{hi - 1} has the evaluated queries {want} (those the matcher {spec} matches "
                         f"with a window of L columns): was the CSV made at another sequence length or for another "
                         f"split? Make it again from this distance matrix at --seq-len {seq_len} (vpr-smr queries), "
                         "or run the workflow again")


def _check_matches(samples: Sequence[Sampled], matrix: Any, queries_csv: Path, distances: Path, lo: int,
                   reference_lo: int | None = None) -> None:
    """The sampled rows' single-frame matches are this matrix's: ``single_match - lo`` is the stable argmin (the
    lowest index on ties) of the query's column, as ``eval.scoring`` finds it, at the distance the CSV gives. A CSV
    made from another distance matrix (another method, or other descriptors) is refused."""
    fix = ("the CSV was made from another distance matrix (another method or run): give the queries CSV of this "
           "distance matrix (vpr-smr queries --distances it), or run the workflow again; for a matrix of "
           "similarities made into distances by vpr-smr queries --similarity, give --similarity")
    for sample in samples:
        row = sample.row
        column = np.asarray(matrix[:, row.query - lo], dtype=np.float64)
        best = int(np.argmin(column))
        ref_lo = lo if reference_lo is None else reference_lo
        if row.single_match - ref_lo != best:
            raise ValueError(f"{queries_csv}: query {row.query}'s single-frame match is reference {row.single_match}, "
                             f"but the nearest reference in {distances} is {best + ref_lo}: {fix}")
        # float32 matrices are read back exactly; the tolerance allows a CSV of a float32 copy of a float64 one
        if not np.isclose(row.single_distance, column[best], rtol=1e-6, atol=0.0):
            raise ValueError(f"{queries_csv}: query {row.query}'s single-frame distance is {row.single_distance:.6g}, "
                             f"but it is {column[best]:.6g} in {distances}: {fix}")


def _check_matcher(rows: Sequence[QueryRow], queries_csv: Path, matcher: MatcherSpec) -> None:
    """The CSV's sequence matches were made by ``matcher`` (its ``matcher`` column): the sequence distances the
    figures show, and the true reference's, are then of one matcher."""
    expected = str(matcher)
    found = sorted({row.matcher for row in rows})
    if found != [expected]:
        raise ValueError(f"{queries_csv} holds the sequence matches of the matcher {' and '.join(found)}, but this "
                         f"stage was given the matcher {expected}: give the matcher of the run that made it (its "
                         "name and settings), or the queries CSV of this matcher")


def main(job: InspectJob) -> tuple[Path | None, Path]:
    """The ``inspect`` stage: the match figure (unless ``job.match_figure`` is None) and the distance-matrix figure
    of ``job.split`` (PNG, all or none); returns their paths (the match figure's or None, the matrix figure's).

    ``dataset`` and ``dataset_settings``: the dataset and its configuration entry (``load_frames``; split
    settings are ignored), needed by the match figure only (its thumbnails); without them (a user's matrix) only
    the distance-matrix figure can be drawn. ``frames_sha256``: the fingerprint of the frames the run's
    descriptors were computed from (default: the distances file's); the images are refused when theirs differs.
    ``split``: None is the queries CSV's only split. ``frames``: the split's frames ``(lo, hi)`` (default: the
    distances file's ``split_range``; for a ``.npy``, ``0 .. Q``; its references: the file's ``reference_range``
    when it has one, method §11). ``truth``: the ground truth, as the queries CSV was scored (frames within
    ``tolerance``, the band drawn; positions within ``radius``, those the distances file holds or the given
    ``reference_positions`` and ``query_positions`` of a user's matrix, as ``vpr-smr metrics`` takes them; or a
    ground-truth file, outlined). ``matcher``: the run's sequence matcher. ``matrix``: how a user's matrix is read,
    as ``vpr-smr queries`` read it (``io.open_distance_matrix``). ``per_class``, ``mistakes``, ``seed``: the
    sample (``sample_queries``).
    The queries CSV must be this matrix's at ``seq_len``: its rows of ``split`` are exactly the queries
    ``lo + L - 1 .. hi - 1``, and each sampled row's single-frame match and distance are its column's minimum.
    """
    queries_csv, distances, seq_len, truth_source = Path(job.queries), Path(job.distances), job.seq_len, job.truth
    tolerance, matcher = truth_source.tolerance, job.matcher
    similarity, key, transpose = job.matrix.similarity, job.matrix.key, job.matrix.transpose
    per_class, mistakes, seed = job.per_class, job.mistakes, job.seed
    split_range = None if job.frames is None else (job.frames[0], job.frames[1])
    dataset_settings = (None if job.dataset_settings is None
                        else json_object(job.dataset_settings, "--dataset-settings"))
    match_figure = (None if job.match_figure is None
                    else check_suffix(job.match_figure, (".png",), "the match figure (PNG)", "--match-figure"))
    matrix_figure = check_suffix(job.matrix_figure, (".png",), "the distance-matrix figure (PNG)", "--matrix-figure")
    _check_dataset(job.dataset, dataset_settings, match_figure)
    if seq_len < 1:
        raise ValueError(f"the sequence length must be >= 1, got {seq_len}")
    if not distances.is_file():
        raise FileNotFoundError(f"distance matrix not found: {distances}")
    provenance = _distance_provenance(distances)
    name = job.dataset or _text(provenance.get("dataset")) or distances.stem
    stored_sha = _text(provenance.get("frames_sha256"))
    if job.frames_sha256 and stored_sha and stored_sha != job.frames_sha256:
        raise ValueError(f"{distances} was computed from other frames of dataset {name!r} than the run's "
                         "(its frames_sha256 differs): run the workflow again")
    expected = job.frames_sha256 or stored_sha
    pair = None
    if match_figure is not None and dataset_settings is not None:  # the images: for the match figure only
        from vpr_smr.datasets import load_frames

        pair = load_frames(name, dataset_settings)
        if expected and pair.fingerprint() != expected:
            raise ValueError(f"dataset {name!r}: its frames changed on disk since the run computed its "
                             f"descriptors (the frame lists' SHA-256 is {pair.fingerprint()[:12]}..., the run's "
                             f"{expected[:12]}...); run the workflow again")
    truth_file = None if truth_source.ground_truth is None else read_ground_truth(
        truth_source.ground_truth, truth_source.ground_truth_key, within=scored_shape([distances], key, transpose))
    all_rows = read_queries(queries_csv)
    split = _split_of(all_rows, queries_csv, job.split)
    rows = [r for r in all_rows if r.split == split]
    with open_distance_matrix(distances, similarity, key, transpose) as matrix:
        lo, hi = _split_range(distances, provenance, split_range, int(matrix.shape[1]))
        stored_reference = provenance.get("reference_range")
        if stored_reference is not None:
            ref_lo, ref_hi = int(stored_reference[0]), int(stored_reference[1])
        else:  # a user's matrix counts its references from 0, as `vpr-smr queries` does
            ref_lo, ref_hi = (0, int(matrix.shape[0])) if is_user_matrix(distances) else (lo, hi)
        if pair is not None and not (0 <= lo < hi <= len(pair.query) and 0 <= ref_lo < ref_hi <= len(pair.reference)):
            raise ValueError(f"split {split!r} = frames {lo}..{hi - 1} is outside dataset {name!r}'s "
                             f"{len(pair.query)} frames: run the workflow again")
        _check_rows(rows, queries_csv, split, seq_len, lo, hi, matcher)
        samples = sample_queries(rows, split, per_class, mistakes, seed)
        method = _text(provenance.get("method"))
        what = f"{name}{'' if method is None else f', {method}'}, L = {seq_len}, split {split!r}"
        sample_text = (f"{len(samples)} of {len(rows)} queries: up to {per_class} per true class (seed {seed}) and "
                       f"the predictor's {mistakes} most confident mistakes")
        if tuple(matrix.shape) != (ref_hi - ref_lo, hi - lo):
            raise ValueError(f"{distances}: the distance matrix is {matrix.shape[0]} x {matrix.shape[1]}, but split "
                             f"{split!r} has {ref_hi - ref_lo} reference frames ({ref_lo}..{ref_hi - 1}) and "
                             f"{hi - lo} query frames ({lo}..{hi - 1}): run the workflow again")
        truth = split_ground_truth(distances, tuple(matrix.shape), tolerance, truth_source.radius,
                                   truth_source.reference_positions, truth_source.query_positions, truth_file)
        rule = f"|r - q| <= {tolerance}" if truth.is_aligned_band() else truth.describe()
        built, split_matrix = matcher.build(seq_len), SplitMatrix(matrix, lo, ref_lo)
        match_title = (f"Match inspector: {what}. {sample_text}. Frames: green = correct ({rule}), "
                       "red = wrong; D = single-frame distance, "
                       + ("S = sequence distance" if built.scores_are_attribute_sums
                          else f"s = the matcher {matcher.name}'s score"))
        _check_matches(samples, matrix, queries_csv, distances, lo, ref_lo)
        _check_matcher(rows, queries_csv, matcher)
        with ExitStack() as stack:  # the files are renamed into place only when all are drawn
            matrix_tmp = stack.enter_context(atomic_path(matrix_figure))
            if match_figure is not None and pair is not None:
                match_tmp = stack.enter_context(atomic_path(match_figure))
                draw_matches(match_tmp, pair, samples, split_matrix, built, match_title)
            draw_matrix(matrix_tmp, split_matrix, rows, tolerance,
                        f"Distance matrix: {what}, sequence matches kept or removed by the predictor", truth)
    return match_figure, matrix_figure
