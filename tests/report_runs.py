"""A whole report run by hand: every experiment's JSON of two methods on one dataset ``d`` (L = 2 and 4), the
standard VPR metrics, match-inspector figures and the speed experiment's files, given to the report (the report's,
the registry's, the speed experiment's and the browser's tests)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vpr_smr.core.io import write_json
from vpr_smr.eval.predictor.records import (
    AttributeAblation,
    AttributeScores,
    AttributeSplit,
    PredictorReport,
    SeedReport,
    SplitScores,
)
from vpr_smr.eval.scoring import speed
from vpr_smr.eval.scoring.adaptive_records import AdaptiveMode, AdaptiveResult, AdaptiveRow, AdaptiveTiming
from vpr_smr.eval.scoring.matcher_comparison import MatcherComparison, MatcherMode, MatcherScores
from vpr_smr.eval.scoring.records import Detection, Interval, Reduction, SeedSummary
from vpr_smr.eval.scoring.speed import SpeedProfile


def predictor_report(seq_len: int) -> PredictorReport:
    """A one-seed predictor report of dataset d, scored on val and test."""
    diagonal = ((10, 0, 0, 0), (0, 5, 0, 0), (0, 0, 3, 0), (0, 0, 0, 2))
    seed = SeedReport(0, {}, 0.5, 30, (30, 10, 10, 7), {"val": SplitScores(0.4, 20, (10, 5, 3, 2), diagonal),
                                                        "test": SplitScores(0.3, 20, (10, 5, 3, 2), diagonal)})
    return PredictorReport({"dataset": "d", "seq_len": seq_len}, 57, (seed,))


DATASET_CARD = {  # as pipeline.plan.dataset_cards gives it
    "reference": "summer", "query": "winter", "n_frames": 60, "tolerance": 2, "splits": {"test": [0, 60]},
    "pairing": "by file name (the same names in both folders)", "overlaps": [], "frames_sha256": "cd" * 32,
    "source": "folders loader: image folders /data/route/summer (reference) and /data/route/winter (query): every "
              "image in them, in natural file-name order",
}
RUN_EXPERIMENTS = {"table1", "predictor", "trust_levels", "restoration", "seq_len", "attributes",
                   "leave_one_method_out", "metrics", "datasets", "baselines"}


def metrics_record(method: str, seq_len: int, modes=("paper", "standard"), dataset: str = "d", sweep: bool = False):
    """The standard VPR metrics of one method, by hand: every value distinct, from the method's, mode's and
    matcher's position; with ``sweep``, a protocol sweep over 0, 2 and 10 frames whose reduction falls with the
    tolerance."""
    from vpr_smr.core.constants import MATCHERS, RECALL_AT
    from vpr_smr.eval.scoring.records import (
        MatcherMetrics,
        ProtocolSweep,
        Reduction,
        SplitMetrics,
        SweepPoint,
        VPRMetrics,
    )

    base = 0.1 + 0.3 * (sum(map(ord, method)) % 3)

    def numbers(m: int, k: int) -> MatcherMetrics:
        value = round(base + 0.05 * m + 0.1 * k, 6)
        return MatcherMetrics(60 - seq_len + 1 if k else 60, {n: round(value + 0.01 * i, 6)
                                                              for i, n in enumerate(RECALL_AT)},
                              round(value / 2, 6), round(value * 0.9, 6), round(value * 0.8, 6))

    def point(tolerance: int) -> SweepPoint:
        reduction = Reduction(1.0, 0.8, 0.9, 0.2, 0.1, 50.0 - 4 * tolerance, 1.0, 0.2, "improved")
        return SweepPoint(float(tolerance), round(base + 0.01 * tolerance, 6), round(base + 0.02 * tolerance, 6),
                          reduction)

    swept = ProtocolSweep("frames", {mode: tuple(point(t) for t in (0, 2, 10)) for mode in modes}) if sweep else None
    return VPRMetrics({"dataset": dataset, "method": method, "seq_len": seq_len, "tolerance": 2},
                      {"test": SplitMetrics({mode: {matcher: numbers(m, k) for k, matcher in enumerate(MATCHERS)}
                                             for m, mode in enumerate(modes)}, sweep=swept)})


def small_png(path: Path, width: int = 240, height: int = 120, shade: int = 0) -> Path:
    """A small PNG (a grey ramp), standing in for a figure the report is given."""
    import cv2

    ramp = np.tile(np.linspace(0, 255, width, dtype=np.uint8), (height, 1))
    ok, data = cv2.imencode(".png", np.stack([ramp, np.full_like(ramp, shade), ramp[:, ::-1]], axis=2))
    assert ok
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data.tobytes())
    return path


def build_run(tmp_path: Path, modes=("paper", "standard"), seq_lens=(2, 4), methods=("m1", "m2"),
              trust_levels=(0.0, 0.9), restoration=True, ablations=True, metrics=True, inspector=True,
              baselines=True, sweep=False, **options) -> tuple[Path, list[Path]]:
    """Every experiment's JSON for the ``methods`` (in that configuration order) on one dataset ``d``, the
    training-free baselines of every L (computed from the same features and predictors), the standard VPR metrics
    and match-inspector figures at L = 4, then report.main; returns (run folder, files). ``options`` go to
    report.write's ReportOptions, but ``speed``, ``matchers`` and ``adaptive`` (those experiments' files) to its
    RunFiles."""
    from vpr_smr.core.paths import match_figure_path, matrix_figure_path, queries_path
    from vpr_smr.eval.matching.attributes import query_features
    from vpr_smr.eval.predictor.estimator import SMRPredictor
    from vpr_smr.eval.report.build import ReportOptions, RunFiles, write
    from vpr_smr.eval.scoring.baselines import DEFAULT_SETTINGS, Prediction, split_baselines
    from vpr_smr.eval.scoring.evaluate import evaluate_split
    from vpr_smr.eval.scoring.records import (
        Baselines,
        Evaluation,
        HeldOut,
        HeldOutPredictors,
        HeldOutScores,
        ModeRemoval,
        Reduction,
        SplitTiming,
        Timing,
    )

    rng = np.random.default_rng(0)
    run = tmp_path / "run"
    evaluations, timings, predictors, baseline_files = [], [], [], []
    for seq_len in seq_lens:
        for i, method in enumerate(methods):
            matrix = rng.random((60, 60)) + (0.5 + 0.2 * i) * (1 - np.eye(60))
            features = query_features(matrix, seq_len, n_candidates=DEFAULT_SETTINGS.candidates)
            fitted = [SMRPredictor(hidden_layer_sizes=(8,), max_iter=30, random_state=s).fit(
                features.attributes[:, 0], features.labels) for s in (0, 1)]
            result, seconds = evaluate_split(features, fitted, modes=modes, trust_levels=trust_levels,
                                             restoration=restoration)
            meta = {"dataset": "d", "method": method, "seq_len": seq_len}
            path = tmp_path / f"e_{method}_L{seq_len}.json"
            write_json(path, Evaluation(meta, ("p.h5",), {"test": result}).to_json())
            evaluations.append(path)
            timings.append(tmp_path / f"e_{method}_L{seq_len}.timing.json")
            write_json(timings[-1], Timing(meta, {"test": SplitTiming.of(0.2, seconds, result.n_queries)}).to_json())
            if baselines:
                predictions = [Prediction(s, p.predict_proba(features.attributes[:, 0]), p.classes_)
                               for s, p in enumerate(fitted)]
                found = split_baselines(features, DEFAULT_SETTINGS, np.arange(60.0), predictions, modes)
                baseline_files.append(tmp_path / f"b_{method}_L{seq_len}.json")
                write_json(baseline_files[-1], Baselines({**meta, **DEFAULT_SETTINGS.meta()},
                                                         {"test": found}).to_json())
        path = tmp_path / f"p_L{seq_len}.json"
        write_json(path, predictor_report(seq_len).to_json())
        predictors.append(path)
    ablation = tmp_path / "a.json"
    table2 = AttributeAblation({"dataset": "d", "seq_len": 4}, {}, 57, {
        name: AttributeScores(None, 0.5, {"val": AttributeSplit(0.5, 20, 0.5), "test": AttributeSplit(0.5, 30, 0.5)})
        for name in ("A1", "A2", "A3", "A4", "all")})
    write_json(ablation, table2.to_json())
    lomo = tmp_path / "lomo.json"
    halved = Reduction(1.0, 0.8, 0.9, 0.2, 0.1, 50.0, 1.0, 0.2, "improved")
    scores = HeldOutScores("p.h5", 0.5, 3, {mode: ModeRemoval(0.5, 0.5, halved) for mode in modes})
    write_json(lomo, HeldOut({"dataset": "d", "method": methods[0], "seq_len": 4}, 57,
                             HeldOutPredictors(scores, scores)).to_json())
    metric_files, match_figures, matrix_figures = [], [], []
    if metrics:
        for method in methods:
            metric_files.append(tmp_path / f"metrics_{method}.json")
            write_json(metric_files[-1], metrics_record(method, 4, modes, sweep=sweep).to_json())
            queries = Path(queries_path(run, "d", method, 4))  # written by the queries job (vpr-smr queries)
            queries.parent.mkdir(parents=True, exist_ok=True)
            queries.write_text("split,query\ntest,0\n")
    if inspector:
        for i, method in enumerate(methods):
            match_figures.append(small_png(Path(match_figure_path(run, "d", method, 4)), 320, 160, 40 * i))
            matrix_figures.append(small_png(Path(matrix_figure_path(run, "d", method, 4)), 160, 160, 40 * i + 20))
    speed = options.pop("speed", ())  # file lists: the rest are ReportOptions
    matchers = options.pop("matchers", ())
    adaptive = options.pop("adaptive", ())
    deployment = options.pop("deployment", ())
    files = RunFiles(evaluations, predictors, [ablation] if ablations else [], [lomo] if ablations else [],
                     timings=timings, metrics=metric_files, match_figures=match_figures, matrix_figures=matrix_figures,
                     baselines=baseline_files, speed=speed, matchers=matchers, adaptive=adaptive,
                     deployment=deployment)
    written = write(run, files, ReportOptions(
        table_seq_lens=[4], seq_len_ablation=len(seq_lens) > 1, config="run: demo\nseq_lens: [2, 4]\n",
        provenance={"checkpoint_sha256": {"m1": "ab" * 32}, "frames_sha256": {"d": "cd" * 32}},
        datasets={"d": DATASET_CARD}, **options))
    return run, written


# --- the speed experiment's files ---


def speed_record(profile: str, numbers: dict[tuple[str, str], tuple[float, float | None]]) -> dict:
    """A hand-made speed file of dataset d, L = 4: per (method, matcher), sequence recall@1 and the reduction."""
    parsed = SpeedProfile.parse(profile)
    matchers = {}
    for matcher, velocities in (("fixed", (1.0,)), ("velocity", (0.5, 1.0, 2.0))):
        methods = {}
        for method in ("m1", "m2"):
            recall, reduction = numbers[(method, matcher)]
            outcome = "nothing_to_reduce" if reduction is None else "improved" if reduction > 0 else "worse"
            removal = Reduction(0.9, 0.5, 0.6, 0.4, 0.3, reduction, 0.9, 0.4, outcome)
            methods[method] = speed.SpeedScores(57, 60, 0.3, recall, removal, 0.5, 3)
        matchers[matcher] = speed.SpeedMatcher(velocities, 100, (40, 20, 20, 20), methods)
    meta = {"dataset": "d", "seq_len": 4, "profile": parsed.name, "tolerance": 2, "mode": "paper", "seed": 0,
            "train_split": ["train", 0, 60], "table_split": ["test", 60, 120]}
    return speed.SpeedResult(meta, parsed.speed, parsed.speed or 1.02, 60, 60, matchers).to_json()


SPEED_NUMBERS = {  # (method, matcher): sequence recall@1, AOC reduction (%)
    "1x": {("m1", "fixed"): (0.8, 50.0), ("m2", "fixed"): (0.6, 30.0), ("m1", "velocity"): (0.8, 40.0),
           ("m2", "velocity"): (0.6, 20.0)},
    "2x": {("m1", "fixed"): (0.2, 10.0), ("m2", "fixed"): (0.1, -30.0), ("m1", "velocity"): (0.7, 40.0),
           ("m2", "velocity"): (0.5, 20.0)},
    "varying": {("m1", "fixed"): (0.4, None), ("m2", "fixed"): (0.2, 5.0), ("m1", "velocity"): (0.7, 1.0),
                ("m2", "velocity"): (0.6, 2.0)},
}


def speed_files(folder: Path) -> list[Path]:
    """The speed files of ``SPEED_NUMBERS`` (dataset d, methods m1 and m2, L = 4), in the profiles' order."""
    files = []
    for profile, numbers in SPEED_NUMBERS.items():
        files.append(folder / f"speed_{profile}.json")
        write_json(files[-1], speed_record(profile, numbers))
    return files


# --- the experiment matchers' file ---


def matcher_reduction(pct: float | None, low: float | None = None, high: float | None = None) -> Reduction:
    """Table I's numbers of a removal whose reduction is ``pct`` (its interval ``[low, high]`` where given)."""
    outcome = "improved" if pct is None or pct > 0 else "worse"  # as curves.outcome names it by the sign
    return Reduction(0.8, 0.6, 0.7, 0.2, 0.2 * (1 - (pct or 0) / 100), pct, 0.8, 0.2, outcome,
                     None if low is None else Interval(low, high))


def matcher_scores(pct: float, low: float, high: float, native: float, native_high: float | None,
                   validation: float, modes=("paper",)) -> MatcherScores:
    """One matcher on one method by hand: the predictor's reduction ``pct`` in ``[low, high]``, the native
    confidence's ``native`` (the paired interval of native - predictor ending at ``native_high``), the best
    training-free scorer ``distance`` at half the predictor's, and the validation recall@1."""
    seeds = SeedSummary(5, 5, pct - 1.0, 2.0, pct - 3.0, pct + 1.0, {s: "improved" for s in range(5)})
    mode = MatcherMode(0.4, 0.7, matcher_reduction(pct, low, high), seeds, "distance", matcher_reduction(pct / 2),
                       matcher_reduction(native),
                       None if native_high is None else Interval(native_high - 5.0, native_high))
    return MatcherScores(30, 9, 4, dict.fromkeys(modes, mode), Detection(0.6, 0.8), Detection(0.4, 0.7),
                         Interval(-0.3, -0.1), validation)


def matchers_records(methods=("sad", "hog"), modes=("paper",)) -> list[MatcherComparison]:
    """Hand-made files of the experiment matchers, dataset d, L = 4, one per method, two matchers: seqslam reduces
    the AOC on both methods (its interval above 0) and beats its native confidence on the first only; bayes_filter's
    interval holds 0 on the first and lies below 0 on the second, where its validation recall@1 (0.2) is under half
    the fixed matcher's (0.6)."""
    first, second = methods
    scores = {first: {"seqslam": matcher_scores(20.0, 5.0, 30.0, 10.0, -1.0, 0.6, modes),
                      "bayes_filter": matcher_scores(3.0, -2.0, 8.0, 1.0, None, 0.7, modes)},
              second: {"seqslam": matcher_scores(10.0, 2.0, 15.0, 12.0, 4.0, 0.5, modes),
                       "bayes_filter": matcher_scores(-6.0, -9.0, -1.0, 2.0, 3.0, 0.2, modes)}}
    return [MatcherComparison({"dataset": "d", "method": method, "seq_len": 4, "modes": list(modes)},
                              ("seqslam", "bayes_filter"), 25, 20,
                              {tag: {method: found} for tag, found in scores[method].items()}, {method: 0.6}, ())
            for method in methods]


def matchers_files(folder: Path) -> list[Path]:
    """The experiment matchers' files of ``matchers_records`` for methods m1 and m2, both modes."""
    paths = []
    for record in matchers_records(("m1", "m2"), ("paper", "standard")):
        paths.append(folder / f"matchers_d_{record.meta['method']}_L4.json")
        write_json(paths[-1], record.to_json())
    return paths


# --- the experiment adaptive_seq_len's files ---

# (AOC at own maximum recall, mean length used, outcome) of the fixed rows of ``adaptive_result``: L4+pred is best
FIXED_ROWS = {"L2": (0.20, 2.0, "kept_all"), "L4": (0.16, 4.0, "kept_all"), "L2+pred": (0.12, 2.0, "improved"),
              "L4+pred": (0.08, 4.0, "improved")}


def adaptive_mode(aoc: float, outcome: str = "improved", minus: tuple[float, float] | None = None,
                  seeds: bool = True) -> AdaptiveMode:
    """One row's numbers in one mode by hand: its AOC ``aoc`` at maximum recall 0.9 (interval +- 0.02), its
    reduction against the longest length's 0.16, and ``minus``: a rule's interval of its AOC minus the best fixed
    row's."""
    pct = 100 * (0.16 - aoc) / 0.16
    reduction = Reduction(0.9, 0.7, 0.8, 0.16, aoc, pct, 0.9, 0.16, outcome, Interval(pct - 5.0, pct + 5.0),
                          aoc_vpr_sm_pred_ci=Interval(aoc - 0.02, aoc + 0.02))
    spread = SeedSummary(3, 3, pct - 1.0, 2.0, pct - 3.0, pct + 1.0, dict.fromkeys(range(3), outcome))
    return AdaptiveMode(reduction, spread if seeds else None, None if minus is None else sum(minus) / 2,
                        None if minus is None else Interval(*minus))


def adaptive_result(method: str, tag: str = "seqslam", modes=("paper",),
                    rules: dict[str, tuple[float, float, str, tuple[float, float] | None]] | None = None,
                    dataset: str = "d") -> AdaptiveResult:
    """The experiment adaptive_seq_len of one dataset, matcher and method by hand, lengths 2 and 4, 57 queries:
    the fixed rows of ``FIXED_ROWS`` (L4+pred the best), then each rule of ``rules`` (name -> AOC, mean length,
    outcome, interval of AOC minus the best fixed row's); default: adaptive below the best fixed row (AOC 0.05,
    mean 2.5), adaptive_fallback indistinguishable from it (0.07, mean 3.0), adaptive_uniqueness above it (0.30)."""
    rules = rules or {"adaptive": (0.05, 2.5, "improved", (-0.05, -0.01)),
                      "adaptive_fallback": (0.07, 3.0, "improved", (-0.03, 0.01)),
                      "adaptive_uniqueness": (0.30, 3.5, "worse", (0.1, 0.3))}
    rows = [AdaptiveRow(name, "fixed+predictor" if name.endswith("+pred") else "fixed", int(name[1]),
                        0 if not name.endswith("+pred") else 9, mean, {int(name[1]): 57}, (mean, mean),
                        {mode: adaptive_mode(aoc, outcome, seeds=name.endswith("+pred")) for mode in modes})
            for name, (aoc, mean, outcome) in FIXED_ROWS.items()]
    rows += [AdaptiveRow(name, "rule", None, 12, mean, {2: 30, 4: 15, -1: 12}, (mean, mean + 0.1),
                         {mode: adaptive_mode(aoc, outcome, minus) for mode in modes},
                         0.25 if name == "adaptive_uniqueness" else None)
             for name, (aoc, mean, outcome, minus) in rules.items()]
    meta = {"dataset": dataset, "method": method, "tag": tag, "modes": list(modes), "seeds": 3}
    return AdaptiveResult(meta, (2, 4), 57, 40, tuple(rows), dict.fromkeys(modes, "L4+pred"), ())


def adaptive_files(folder: Path, methods=("m1", "m2"), modes=("paper", "standard"), timed: bool = True) -> list[Path]:
    """The experiment adaptive_seq_len's files of ``adaptive_result`` for ``methods``, matcher seqslam, each with
    its live timing beside it (``timed``): 0.57 s adaptive and 1.14 s for the longest length, over 57 queries."""
    from vpr_smr.core.paths import timing_path

    paths = []
    for method in methods:
        paths.append(folder / "adaptive" / "d" / "seqslam" / f"{method}.json")
        paths[-1].parent.mkdir(parents=True, exist_ok=True)
        write_json(paths[-1], adaptive_result(method, modes=modes).to_json())
        if timed:
            meta = {"dataset": "d", "method": method, "tag": "seqslam"}
            write_json(Path(timing_path(paths[-1])), AdaptiveTiming(meta, 60, 57, 0.57, 1.14).to_json())
    return paths
