"""The jobs of the report's stages: ``report`` (``ReportJob``: the run's files the report reads, ``RunFiles``, how
it shows them and the run folder) and the match inspector's ``inspect`` (``InspectJob``). A module of its own, light
to import: the command line and the workflow's rules build the jobs without the report's tables and figures
(``eval.report.build`` and ``eval.report.inspector`` do the work, and import Matplotlib's helpers)."""

from __future__ import annotations

from dataclasses import dataclass

from vpr_smr.core.json_objects import JsonObject
from vpr_smr.core.settings import REQUIRED, group, setting
from vpr_smr.eval.matching import sources
from vpr_smr.eval.matching.matchers import MatcherSpec
from vpr_smr.eval.matching.sources import MatrixFormat, TruthSource

__all__ = ["InspectJob", "ReportJob", "RunFiles"]


@dataclass(frozen=True)
class RunFiles:
    """The stages' files a report reads, each list optional: the run's paths, resolved in one place (the
    workflow's rule and ``vpr-smr report`` fill it).

    ``evaluations`` (``evaluate.main``, one per dataset, method and L), ``predictors`` (``train.main`` reports),
    ``attribute_ablations`` (``ablation.attributes_main``), ``leave_one_out`` (``scoring.held_out.main``),
    ``timings`` (the ``.timing.json`` files ``evaluate.main`` writes, each matched to its evaluation by dataset,
    method and L; the timing table leaves out evaluations without one), ``metrics`` (``scoring.vpr_metrics``'
    files: the standard VPR metrics of the table split). ``match_figures`` and ``matrix_figures``: the match
    inspector's PNGs (``core.paths.match_figure_path`` and ``matrix_figure_path``), shown in the page, placed by
    their file names. ``speed``: the speed experiment's files (``scoring.speed.main``, one per dataset and profile,
    in the configuration's order of profiles). ``baselines``: the training-free baselines (``vpr-smr baselines``,
    one per dataset, method and L): their tables, figures and findings, and the best of them in the
    sequence-length ablation. ``descriptors``: descriptor files whose provenance attributes the page lists.
    ``matchers``: the experiment matchers' files (``scoring.matcher_comparison.main``, one per dataset).
    ``deployment``: the experiment deployment's files (``scoring.deployment.main``, one per dataset and method).
    ``adaptive``: the experiment adaptive_seq_len's files (``scoring.adaptive.main``, one per dataset, matcher and
    method), each with its live timing (``core.paths.timing_path``) read where that file is beside it.
    """

    evaluations: tuple[str, ...] = setting((), "the evaluations' .json files (vpr-smr evaluate)", metavar="PATH")
    predictors: tuple[str, ...] = setting((), "the predictors' .json reports (written beside each vpr-smr train "
                                              "predictor)", metavar="PATH")
    attribute_ablations: tuple[str, ...] = setting((), "Table II's files (vpr-smr ablation attributes)",
                                                   metavar="PATH")
    leave_one_out: tuple[str, ...] = setting((), "the held-out methods' files (vpr-smr ablation held-out)",
                                             metavar="PATH")
    timings: tuple[str, ...] = setting((), "the evaluations' .timing.json files (matched by dataset, method, L)",
                                       metavar="PATH")
    metrics: tuple[str, ...] = setting((), "the standard VPR metrics files (vpr-smr metrics), at the table's L",
                                       metavar="PATH")
    match_figures: tuple[str, ...] = setting((), "the match inspector's match figures (vpr-smr inspect)",
                                             metavar="PATH")
    matrix_figures: tuple[str, ...] = setting((), "the match inspector's distance-matrix figures", metavar="PATH")
    speed: tuple[str, ...] = setting((), "the speed experiment's files (vpr-smr speed), one per dataset and profile, "
                                         "in the configuration's order", metavar="PATH")
    baselines: tuple[str, ...] = setting(
        (), "the training-free baselines' .json files (vpr-smr baselines), each of one dataset, method and L: their "
            "tables, figures and findings, and the best of them in the sequence-length ablation", metavar="PATH")
    descriptors: tuple[str, ...] = setting((), "descriptor files whose provenance the report shows", metavar="PATH")
    matchers: tuple[str, ...] = setting((), "the experiment matchers' files (vpr-smr compare-matchers), one per "
                                            "dataset and method", metavar="PATH")
    adaptive: tuple[str, ...] = setting((), "the experiment adaptive_seq_len's files (vpr-smr adaptive), one per "
                                            "dataset, matcher and method; each one's .timing.json beside it gives "
                                            "the live time per query", metavar="PATH")
    deployment: tuple[str, ...] = setting((), "the experiment deployment's files (vpr-smr deployment), one per "
                                              "dataset and method", metavar="PATH")


@dataclass(frozen=True)
class ReportJob:
    """The ``report`` stage's job: the run's files (``RunFiles``), how the report shows them (the settings of
    ``ReportOptions`` a command line gives) and the run folder (``main``)."""

    files: RunFiles = group(RunFiles, "the stages' files the report reads")
    split: str | None = setting(None, "the split the tables show: the configuration's table_split; none: the one split "
                                      "every evaluation holds", metavar="SPLIT")
    eval_splits: tuple[str, ...] | None = setting(
        None, "the configuration's eval_splits, in its order: the predictor table's columns; the first is the "
              "validation split of its warnings, Table II shows the first and the last; none: the inputs' "
              "splits, --split last", metavar="SPLIT")
    train_split: str | None = setting(None, "the configuration's train_split, as Table II names it; none: train",
                                      metavar="SPLIT")
    table_seq_lens: tuple[int, ...] | None = setting(None, "sequence lengths of Table I; none: all", minimum=1)
    seq_len_ablation: bool = setting(False, "also the sequence-length table and figure")
    settings: JsonObject = setting(JsonObject(), "the run's settings (JSON, or @file) shown in the report",
                                   metavar="JSON")
    datasets: JsonObject = setting(JsonObject(), "per dataset: traverses, frames, tolerance, splits, pairing, "
                                                 "overlaps (JSON, or @file)", metavar="JSON")
    out: str = setting(REQUIRED, "the run folder: tables/, figures/ and report.html go inside", metavar="PATH")


@dataclass(frozen=True)
class InspectJob:
    """The ``inspect`` stage's job: the match figure and the distance-matrix figure of one split's queries."""

    queries: str = setting(REQUIRED, "the per-query table (.csv) of vpr-smr queries", metavar="PATH")
    distances: str = setting(REQUIRED, "the distance matrix: our .h5, or a references x queries .npy, .npz or .mat",
                             metavar="PATH")
    match_figure: str | None = setting(None, "the match figure (PNG): thumbnails of the frames, so it needs "
                                             "--dataset and --dataset-settings (a dataset with images)",
                                       metavar="PATH")
    matrix_figure: str = setting(REQUIRED, "where to write the distance-matrix figure (.png)", metavar="PATH")
    dataset: str | None = setting(None, "the dataset's name (with --dataset-settings: for the match figure's "
                                        "images)", metavar="NAME")
    # JSON text, not a JsonObject: an empty object given (an entry without a loader) is not one left out
    dataset_settings: str | None = setting(
        None, "the dataset's configuration entry as a JSON object (or @file), e.g. {\"loader\": \"folders\", "
              "\"reference\": DIR, \"query\": DIR}", metavar="JSON")
    frames_sha256: str | None = setting(None, "fail unless the dataset's frame lists have this fingerprint "
                                              "(default: the distances file's)", metavar="SHA256")
    seq_len: int = sources.seq_len()
    split: str | None = setting(None, "the queries CSV's split to show (default: its only split)", metavar="SPLIT")
    # as the queries CSV was made: the matcher, the ground truth, how a user's matrix is read
    truth: TruthSource = sources.truth()
    matcher: MatcherSpec = sources.matcher()
    matrix: MatrixFormat = sources.matrix()
    frames: tuple[int, ...] | None = setting(
        None, "the split's frames lo..hi-1: LO HI (default: the distances file's split_range; a .npy's queries count "
              "from 0)", min_items=2, max_items=2)
    per_class: int = setting(2, "queries sampled per true class", minimum=0)
    mistakes: int = setting(4, "the predictor's most confident mistakes shown", minimum=0)
    seed: int = setting(0, "seed of the sample")
