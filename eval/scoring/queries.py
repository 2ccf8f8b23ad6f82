"""The per-query table of ``vpr-smr queries`` (and ``metrics --queries``): one row per evaluated query (``a >= L-1``)
of every split.

Frame indices (``query``, ``single_match``, ``sequence_match``, ``true_reference``) are the dataset's: the split's
first query (reference) frame plus the index within the split. The true reference of query ``a`` is ``a`` in a
frame-aligned pair, the reference nearest to its position otherwise (method §11; the lowest on ties), and with a
ground-truth matrix the correct reference nearest to the query's own frame (``GroundTruth.true_references``); the
cell is empty for a query without any correct reference.
``A1..A4`` are the rank-0 attributes under the paper's names (method §5: minimum sum, minimum value, block sum and group
sum rates), the order ``QueryFeatures.attributes`` stores them in; the predictor takes them in that order and feeds
its network the code's order ``[A1, A2, A4, A3]`` itself (``SMRPredictor.column_order``). ``predicted_class``,
``probability`` (its class probability, the highest) and ``kept`` (1 when the predicted class is one of
``core.constants.KEPT_CLASSES``) are the seed-0 predictor's, empty without a predictor. ``matcher``: the sequence
matcher that made the sequence matches, its name and settings (``str(MatcherSpec)``, e.g. ``seqslam (velocities
[1.0])``), so that a reader of the table (the match inspector) knows which matcher made them.

Then one column per scorer of method §12 (``SCORE_COLUMNS``: ``c_uniqueness`` .. ``c_predictor``), its confidence
``c_a`` that the sequence match is correct (higher: more likely; ``c_random`` of seed 0, ``c_predictor`` the seed-0
predictor's ``1 - P(class 1) - P(class 3)``, ``c_native`` the matcher's own confidence, method §14); empty where not
computed (``c_predictor`` without a predictor).
"""

from __future__ import annotations

import csv
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vpr_smr.core.io import atomic_path
from vpr_smr.eval.matching.attributes import ATTRIBUTE_NAMES, QueryFeatures, recorded_matcher
from vpr_smr.eval.matching.ground_truth import NO_REFERENCE
from vpr_smr.eval.matching.matchers import MatcherSpec
from vpr_smr.eval.scoring import scorers
from vpr_smr.eval.scoring.curves import keep_mask

MATCHER_COLUMN = "matcher"
OLD_MATCHER_COLUMN = "velocities"  # where a table of vpr-smr 0.9 named its matcher: seqslam's velocities
QUERY_COLUMNS = (
    "split", "query", "single_match", "single_distance", "single_correct", "sequence_match", "sequence_distance",
    "sequence_correct", "true_reference", *ATTRIBUTE_NAMES, "label", "predicted_class", "probability", "kept",
    MATCHER_COLUMN,
)


def row_matcher(record: Mapping[str, str], where: str) -> str:
    """The ``matcher`` cell of a row read by column name; a row of vpr-smr 0.9 (no ``matcher`` column) names
    ``seqslam`` by its ``velocities`` cell (space-separated numbers), read as such (``recorded_matcher``)."""
    if MATCHER_COLUMN in record:
        return record[MATCHER_COLUMN]
    old = [float(v) for v in record[OLD_MATCHER_COLUMN].split()]
    return str(recorded_matcher({OLD_MATCHER_COLUMN: old}, where))


# the scorers' confidences (method §12), after QUERY_COLUMNS: a reader of the columns above (the match inspector)
# reads a table written before these existed as it always did; one per entry of scorers.REGISTRY, read as it runs
def score_columns() -> tuple[str, ...]:
    """The scorers' columns: ``c_<name>`` of every registered scorer, in the registry's order."""
    return tuple(f"c_{name}" for name in scorers.names())


SCORE_COLUMNS = score_columns()  # as declared, for callers that read them once


@dataclass(frozen=True)
class Prediction:
    """The predictor's decision on the rank-0 attributes of a split's evaluated queries, as ``evaluate`` takes it:
    the class of highest probability, that probability, and whether the match is kept (trust level 0)."""

    predicted: np.ndarray  # (N,) class
    probability: np.ndarray  # (N,) the highest class probability
    probabilities: np.ndarray | None = None  # (N, C) every class's, columns in ``classes`` order
    classes: np.ndarray | None = None

    @classmethod
    def of(cls, predictor: Any, features: QueryFeatures) -> Prediction:
        """``predictor`` (``predict_proba`` and ``classes_``, e.g. ``SMRPredictor``) on ``features``' rank 0."""
        probabilities = np.asarray(predictor.predict_proba(features.attributes[:, 0, :]))
        classes = np.asarray(predictor.classes_)
        return cls(classes[np.argmax(probabilities, axis=1)], probabilities.max(axis=1), probabilities, classes)

    @property
    def kept(self) -> np.ndarray:
        """Which queries keep their sequence match: ``curves.keep_mask`` at trust level 0."""
        return keep_mask(self.predicted, self.probability)


@dataclass(frozen=True)
class SplitQueries:
    """What the table needs of one split: its features, the single-frame distances ``D[single_match, a]`` of the
    evaluated queries, the split's first frame in the dataset, and the predictor's decision (None without one)."""

    split: str
    first_frame: int  # the split's first query frame (and first reference frame, unless reference_first_frame)
    features: QueryFeatures
    single_distance: np.ndarray  # (N,)
    prediction: Prediction | None
    reference_first_frame: int | None = None  # the split's first reference frame when its ranges differ (method §11)
    # (N,) split-local, NO_REFERENCE for a query without a correct one; None: the query's own index (frame-aligned)
    true_reference: np.ndarray | None = None
    matcher: MatcherSpec | None = None  # the sequence matcher (None: the default, MatcherSpec.of())
    scores: dict[str, np.ndarray] | None = None  # scorer -> (N,) c_a (method §12), None: not computed


def _number(value: Any) -> str:
    """A float with every digit it needs to be read back exactly (``repr``)."""
    return repr(float(value))


def query_rows(table: SplitQueries) -> Iterator[list[str]]:
    """The rows of one split, ``QUERY_COLUMNS`` in order, as text."""
    f, first = table.features, table.first_frame
    first_ref = first if table.reference_first_frame is None else table.reference_first_frame
    true_reference = f.queries if table.true_reference is None else table.true_reference
    prediction = table.prediction
    kept = prediction.kept if prediction is not None else None
    matcher = str(table.matcher or MatcherSpec.of())
    scores = table.scores or {}
    by_scorer = [scores.get(name) for name in scorers.names()]
    for n, query in enumerate(f.queries):
        predicted = ["", "", ""] if prediction is None or kept is None else [
            str(int(prediction.predicted[n])), _number(prediction.probability[n]), str(int(kept[n]))]
        yield [
            table.split, str(first + int(query)),
            str(first_ref + int(f.single_match[n])), _number(table.single_distance[n]),
            str(int(f.single_correct[n])),
            str(first_ref + int(f.sequence_match[n])), _number(f.sequence_distance[n]),
            str(int(f.sequence_correct[n])),
            "" if true_reference[n] == NO_REFERENCE else str(first_ref + int(true_reference[n])),
            *(_number(v) for v in f.attributes[n, 0, :]),
            str(int(f.labels[n])), *predicted, matcher,
            *("" if values is None else _number(values[n]) for values in by_scorer),
        ]


def write_queries(path: Path | str, tables: Sequence[SplitQueries]) -> None:
    """The table of every split in the given order, written atomically (``core.io.atomic_path``)."""
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as handle:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow((*QUERY_COLUMNS, *score_columns()))
        for table in tables:
            if len(table.single_distance) != len(table.features.queries):
                raise ValueError(f"split {table.split!r}: {len(table.single_distance)} single-frame distances for "
                                 f"{len(table.features.queries)} queries")
            writer.writerows(query_rows(table))
