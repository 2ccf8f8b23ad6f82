"""The job records of the stages that score distance matrices: ``metrics`` (``MetricsJob``), ``queries``
(``QueriesJob``) and ``baselines`` (``BaselinesJob``), each one typed record of its settings, inputs and output
(``core.settings``; the stages are declared in ``pipeline.stages.scoring``). The shared option groups are those of
``eval.matching.sources`` (the ground truth, how a matrix file is read), the matcher its ``MatcherSpec``, the
training-free scorers' settings ``scorers.BaselineSettings``.

They live apart from the work (``vpr_metrics``, ``queries_stage``, ``baselines_stage``, which name them too): the
command line declares every stage when it starts, and the work's modules import scikit-learn (about 2 s), which a
command that scores nothing must not pay for.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vpr_smr.core.settings import REQUIRED, setting
from vpr_smr.eval.matching import sources
from vpr_smr.eval.matching.matchers import MatcherSpec
from vpr_smr.eval.matching.sources import MatrixFormat, TruthSource
from vpr_smr.eval.predictor.defaults import allow_split_overlap
from vpr_smr.eval.predictor.jobs import dataset_name, metric_modes
from vpr_smr.eval.scoring.scorers import BaselineSettings, baseline_settings

__all__ = ["ALL_SPLIT", "BaselinesJob", "MetricsJob", "QueriesJob", "distance_splits"]

ALL_SPLIT = "all"  # the split's name when ``distances`` is one file
DISTANCES = "--distances"


def distance_splits(items: tuple[str, ...]) -> dict[str, str]:
    """The matrices of ``--distances`` by split: one PATH (one split, named ``all``; also a file whose name holds
    ``=``), or ``SPLIT=PATH`` items; ValueError naming the items that are neither."""
    if len(items) == 1 and ("=" not in items[0] or Path(items[0]).is_file()):
        return {ALL_SPLIT: items[0]}
    pairs = [item.split("=", 1) for item in items]
    bad = [item for item, pair in zip(items, pairs, strict=True) if len(pair) != 2]
    if bad:
        raise ValueError(f"{DISTANCES} takes SPLIT=PATH items, got {', '.join(bad)}")
    return dict(pairs)


# --- the settings these jobs declare alike ----------------------------------------------------------------------


def _user_distances() -> Any:
    return setting(REQUIRED, "references x queries matrices (.npy, .npz, .mat or our .h5): one file, or one "
                             "SPLIT=PATH per split", metavar="PATH or SPLIT=PATH")


def _user_attributes() -> Any:
    return setting(None, "the splits' attributes (.h5) computed from the same matrices (default: computed here)",
                   metavar="SPLIT=PATH")


def _baselines_switch() -> Any:
    return setting(True, "score the training-free scorers (method §12); --no-baselines leaves them out (needed for "
                         "--attributes files computed with --candidates 0)")


class _ScoresMatrices:
    """What the jobs that score a matrix and may leave the training-free scorers out (``metrics``, ``queries``)
    share besides their fields: ``baselines`` (the switch) and ``scorers`` (their settings) are each job's own
    settings, declared in its record so that its options keep their order."""

    baselines: bool
    scorers: BaselineSettings

    @property
    def scorer_settings(self) -> BaselineSettings | None:
        """The training-free scorers' settings, None when they are left out."""
        return self.scorers if self.baselines else None


@dataclass(frozen=True)
class MetricsJob(_ScoresMatrices):
    """The ``metrics`` stage's job: the standard VPR metrics of every split's matrix (``vpr_metrics.main``)."""

    distances: tuple[str, ...] = _user_distances()
    seq_len: int = sources.seq_len()
    truth: TruthSource = sources.truth()
    matcher: MatcherSpec = sources.matcher()
    matrix: MatrixFormat = sources.matrix()
    predictor: str | None = setting(None, "the seed-0 predictor (.h5): adds the sequence_predictor matcher",
                                    metavar="PATH")
    attributes: dict[str, str] | None = _user_attributes()
    modes: tuple[str, ...] = metric_modes()
    queries: str | None = setting(None, "also write one row per evaluated query to this .csv (as vpr-smr queries "
                                        "does); both files or neither are written", metavar="PATH")
    sweep: bool = setting(False, "also recall@1 and the predictor's AOC reduction over the tolerances 0, 1, 2, 5, 10 "
                                 "frames (radii 5, 10, 25, 50 with positions): how the conclusions depend on the "
                                 "protocol")
    dataset: str | None = setting(None, "the dataset's name, written in the metrics' meta", metavar="NAME")
    method: str | None = setting(None, "the method's name, written in the metrics' meta", metavar="NAME")
    baselines: bool = _baselines_switch()
    scorers: BaselineSettings = baseline_settings()
    allow_split_overlap: bool = allow_split_overlap()
    out: str = setting(REQUIRED, "the output file: the VPR metrics (JSON)", metavar="PATH")


@dataclass(frozen=True)
class QueriesJob(_ScoresMatrices):
    """The ``queries`` stage's job: the per-query table of every split's matrix (``queries_stage.main``), scored as
    ``metrics`` scores it."""

    distances: tuple[str, ...] = _user_distances()
    seq_len: int = sources.seq_len()
    truth: TruthSource = sources.truth()
    matcher: MatcherSpec = sources.matcher()
    matrix: MatrixFormat = sources.matrix()
    predictor: str | None = setting(None, "the seed-0 predictor (.h5): fills predicted_class, probability and kept",
                                    metavar="PATH")
    attributes: dict[str, str] | None = _user_attributes()
    baselines: bool = _baselines_switch()
    scorers: BaselineSettings = baseline_settings()
    allow_split_overlap: bool = allow_split_overlap()
    out: str = setting(REQUIRED, "the output file: the per-query table (CSV)", metavar="PATH")


@dataclass(frozen=True)
class BaselinesJob:
    """The ``baselines`` stage's job (method §12): every training-free scorer against the predictor of each seed,
    per split (``baselines_stage.main``)."""

    dataset: str = dataset_name()
    method: str = setting(REQUIRED, "the method's name (a key of the configuration's methods)", metavar="NAME")
    seq_len: int = sources.seq_len()
    distances: dict[str, str] = setting(REQUIRED, "each split's distance matrix (our .h5, or .npy, .npz, .mat): the "
                                                  "ground truth's shape and positions", metavar="SPLIT=PATH")
    attributes: dict[str, str] = setting(REQUIRED, "each split's attributes (.h5) with the scorers' candidates "
                                                   "(vpr-smr attributes)", metavar="SPLIT=PATH")
    predictors: tuple[str, ...] = setting(REQUIRED, "one per seed, seed 0 first: their budgets", metavar="PATH")
    truth: TruthSource = sources.truth()
    matcher: MatcherSpec = sources.matcher()
    matrix: MatrixFormat = sources.matrix()
    scorers: BaselineSettings = baseline_settings()
    modes: tuple[str, ...] = metric_modes()
    allow_split_overlap: bool = allow_split_overlap()
    out: str = setting(REQUIRED, "the output file: the training-free baselines (JSON)", metavar="PATH")
