"""The ``vpr-smr`` command: one subcommand per stage, each a thin wrapper of a ``main`` function."""

from __future__ import annotations

import argparse
import gc
import json
import logging
import signal
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from vpr_smr.core.constants import DEFAULT_TOLERANCE, METRICS, MODES
from vpr_smr.core.io import CSV_SUFFIXES, HDF5_SUFFIXES, JSON_SUFFIXES, check_suffix, package_version
from vpr_smr.eval.matching.matchers import DEFAULT_MATCHER
from vpr_smr.pipeline.config import ConfigError, Extraction, load_config, schema_default
from vpr_smr.pipeline.console import LOG_FORMAT
from vpr_smr.pipeline.experiment import plugin_stages
from vpr_smr.pipeline.options import add_matcher_options, add_options, matcher_of, read_matcher, read_options
from vpr_smr.pipeline.stage import JOB, install
from vpr_smr.pipeline.stages import STAGES

log = logging.getLogger("vpr_smr")


def _wrote(what: str, out: Path | str, headline: str = "") -> None:
    """The one-line summary of a command that wrote a file: what, where, and its headline number."""
    log.info("wrote %s to %s%s", what, out, f": {headline}" if headline else "")


def _reduction(reduction: Any) -> str:
    """A ``records.Reduction`` as a summary line says it: ``40.00 % [20.00, 55.00] improved``, the word earned by
    its interval (``curves.earned``); an undefined one with its reason."""
    from vpr_smr.eval.report import outcome_words as words
    from vpr_smr.eval.report.bounds import bracket
    from vpr_smr.eval.scoring.curves import earned

    word = words.said(earned(reduction.outcome, reduction.reduction_pct_ci))
    if reduction.reduction_pct is None:
        return f"n/a ({word})"
    return f"{reduction.reduction_pct:.2f} % {bracket(reduction.reduction_pct_ci, '.2f')} {word}"


def _json_object(text: str, option: str) -> dict[str, Any]:
    """A JSON object given on the command line, or ``@file`` holding one."""
    if text.startswith("@"):
        text = Path(text[1:]).read_text()
    try:
        value = json.loads(text)
    except json.JSONDecodeError as error:
        raise ValueError(f"{option} is not valid JSON: {error}") from None
    if not isinstance(value, dict):
        raise ValueError(f"{option} must be a JSON object of settings")
    return value


def _predictor_params(args: argparse.Namespace) -> dict[str, Any]:
    """``--predictor``'s JSON object, each setting checked against its declaration (``PredictorSettings``) before
    any file is read; what is not given keeps its default."""
    from vpr_smr.core.settings import parse
    from vpr_smr.eval.predictor.defaults import PredictorSettings

    params = _json_object(args.predictor, "--predictor") if args.predictor else {}
    parse(PredictorSettings, params, "--predictor")
    return params


def _stage_settings(args: argparse.Namespace) -> tuple[dict[str, Any], dict[str, Any]]:
    """The dataset's and the method's settings: given as JSON (the workflow) or taken from ``--config``."""
    if args.config:
        conf = load_config(args.config)
        for section, name, entries in (("datasets", args.dataset, conf.datasets),
                                       ("methods", args.method, conf.methods)):
            if name not in entries:
                raise ConfigError(f"{args.config}: {section} has no {name!r}; it has {', '.join(entries)}")
        return conf.datasets[args.dataset].to_json(), conf.methods[args.method].to_json()
    if not (args.dataset_settings and args.method_settings):
        raise ConfigError("give --config, or both --dataset-settings and --method-settings")
    return (_json_object(args.dataset_settings, "--dataset-settings"),
            _json_object(args.method_settings, "--method-settings"))


def cmd_descriptors(args: argparse.Namespace) -> None:
    from vpr_smr.datasets import load_frames
    from vpr_smr.descriptors import extract

    if args.threads:
        import torch

        torch.set_num_threads(args.threads)
    dataset, method = _stage_settings(args)
    pair = load_frames(args.dataset, dataset)  # the configuration check builds it the same way
    if args.frames_sha256 and pair.fingerprint() != args.frames_sha256:
        raise ConfigError(f"dataset {args.dataset!r}: its frames changed on disk since the workflow was planned "
                          "(the frame lists' SHA-256 differs); run the workflow again")
    extraction = read_options(args, Extraction, "extraction")
    out = extract.main(pair, args.method, method, args.out, batch_size=extraction.batch_size,
                       num_workers=extraction.num_workers)
    _wrote(f"the {args.method} descriptors of {args.dataset}", out)


def cmd_distances(args: argparse.Namespace) -> None:
    from vpr_smr.eval.matching import distances

    out = distances.main(args.descriptors, args.out, args.split, tuple(args.frames), metric=args.metric,
                         reference_range=tuple(args.reference_frames) if args.reference_frames else None)
    _wrote(f"the {args.split} split's distance matrix", out)


def _check_seq_len(args: argparse.Namespace, *groups: Iterable[str] | None) -> None:
    """The attributes files a stage reads were computed at its ``--seq-len``."""
    from vpr_smr.eval.matching.attributes import check_seq_len

    check_seq_len([path for group in groups for path in (group or [])], args.seq_len)


# ``--val`` and ``--test`` of train and the ablations, before the splits took the configuration's names
OLD_SPLIT_OPTIONS = ("--val", "--test")


def _old_split_options(parser: argparse.ArgumentParser) -> None:
    """``--val``/``--test``, hidden: given, they fail with what replaced them (``_evaluation_splits``)."""
    for option in OLD_SPLIT_OPTIONS:
        parser.add_argument(option, nargs="*", dest=f"old_{option[2:]}", help=argparse.SUPPRESS)


def _evaluate_option(parser: argparse.ArgumentParser, what: str, item: str = "PATH") -> None:
    a, b = ("a=", "b=") if item == "METHOD=PATH" else ("", "")
    parser.add_argument("--evaluate", nargs="+", action="append", metavar=("SPLIT", item),
                        help=f"an evaluation split by its name (the configuration's, e.g. val or check) and {what}; "
                             f"repeat it for each split, e.g. --evaluate val {a}a_val.h5 {b}b_val.h5 --evaluate test "
                             f"{a}a_test.h5 {b}b_test.h5")


def _evaluation_splits(args: argparse.Namespace) -> dict[str, list[str]]:
    """``--evaluate SPLIT ITEM...`` (repeatable) as split name -> items, in the order given; the removed
    ``--val``/``--test`` fail with what replaced them."""
    old = [option for option in OLD_SPLIT_OPTIONS if getattr(args, f"old_{option[2:]}", None) is not None]
    if old:
        raise ConfigError(f"{' and '.join(old)}: removed; the splits take the configuration's names now: give each "
                          "evaluation split as --evaluate SPLIT FILE..., e.g. --evaluate val a.h5 b.h5 --evaluate "
                          "test c.h5 d.h5 (or --evaluate check ... --evaluate final ...)")
    splits: dict[str, list[str]] = {}
    for name, *items in args.evaluate or []:
        if not items:
            raise ConfigError(f"--evaluate {name}: give the split's name, then its files")
        if name in splits:
            raise ConfigError(f"--evaluate {name}: the split is given twice; give all its files after one --evaluate")
        splits[name] = items
    return splits


def cmd_train(args: argparse.Namespace) -> None:
    from vpr_smr.eval.predictor import train

    params = _predictor_params(args)  # its settings checked before any file is read
    evaluate = _evaluation_splits(args)
    _check_seq_len(args, args.train, *evaluate.values())
    report = train.main(args.train, args.out, params, evaluate=evaluate,
                        meta={"dataset": args.dataset, "seq_len": args.seq_len}, seeds=tuple(range(args.seeds)),
                        allow_split_overlap=args.allow_split_overlap, validation=args.validation)
    first = report.seeds[0]  # the predictor file's seed
    _wrote("the predictor", args.out, f"macro F1: {train.cv_text(first)}{train.split_f1s(first)}")


def _split_paths(items: list[str], option: str = "--attributes", name: str = "SPLIT") -> dict[str, str]:
    """``NAME=PATH`` items of ``option`` as a mapping."""
    pairs = [item.split("=", 1) for item in items]
    bad = [item for item, pair in zip(items, pairs, strict=True) if len(pair) != 2]
    if bad:
        raise ValueError(f"{option} takes {name}=PATH items, got {', '.join(bad)}")
    return dict(pairs)


def cmd_evaluate(args: argparse.Namespace) -> None:
    from vpr_smr.eval.scoring import evaluate

    attributes = _split_paths(args.attributes)
    _check_seq_len(args, attributes.values())
    evaluation, _ = evaluate.main(attributes, args.predictors, args.out, tuple(args.modes),
                                  tuple(args.trust_levels), meta={"dataset": args.dataset, "method": args.method,
                                                                  "seq_len": args.seq_len},
                                  restoration=args.restoration, allow_split_overlap=args.allow_split_overlap)
    _wrote(f"the evaluation of {args.method}", args.out, "; ".join(
        f"{name}: the seed-{split.seed} predictor removes {split.removed} of {split.n_queries} matches, macro F1 "
        f"{split.f1_macro:.3f}" for name, split in evaluation.splits.items()))


def _distance_paths(items: list[str]) -> dict[str, str]:
    """``--distances``: one PATH (one split, named ``all``) or ``SPLIT=PATH`` items."""
    if len(items) == 1 and ("=" not in items[0] or Path(items[0]).is_file()):
        return {"all": items[0]}
    return _split_paths(items, "--distances")


def cmd_metrics(args: argparse.Namespace) -> None:
    from vpr_smr.eval.scoring import vpr_metrics

    meta = {key: value for key, value in (("dataset", args.dataset), ("method", args.method)) if value is not None}
    result = vpr_metrics.main(_distance_paths(args.distances), args.seq_len, args.tolerance, args.out,
                              predictor=args.predictor, attributes=_split_paths(args.attributes or []),
                              modes=tuple(args.modes), queries=args.queries, meta=meta,
                              allow_split_overlap=args.allow_split_overlap, matcher=_matcher(args),
                              similarity=args.similarity, key=args.key, transpose=args.transpose,
                              sweep=args.sweep, baselines=_baseline_settings(args))
    print(vpr_metrics.format_metrics(result))
    found = vpr_metrics.format_baselines(result)
    if found:
        shown = ", ".join(f"{key} {value}" for key, value in _baseline_settings(args).meta().items())
        print(f"\ntraining-free scorers (method §12; {shown}):\n{found}")
    mode = args.modes[0] if args.modes else None
    _wrote("the metrics", args.out, "; ".join(
        f"{name}: sequence recall@1 {split.modes[mode]['sequence'].recall_at[1]:.4f} ({mode} mode)"
        for name, split in result.splits.items() if mode in split.modes))


def cmd_queries(args: argparse.Namespace) -> None:
    from vpr_smr.eval.scoring import queries_stage

    queries_stage.main(_distance_paths(args.distances), args.seq_len, args.tolerance, args.out,
                       predictor=args.predictor, attributes=_split_paths(args.attributes or []),
                       allow_split_overlap=args.allow_split_overlap, matcher=_matcher(args),
                       similarity=args.similarity, key=args.key, transpose=args.transpose,
                       baselines=_baseline_settings(args))


def cmd_baselines(args: argparse.Namespace) -> None:
    from vpr_smr.eval.scoring import baselines_stage

    attributes = _split_paths(args.attributes)
    _check_seq_len(args, attributes.values())
    settings = _baseline_settings(args)
    assert settings is not None  # the baselines command has no --no-baselines
    found = baselines_stage.main(_split_paths(args.distances, "--distances"), attributes, args.predictors,
                                 args.seq_len, args.tolerance, args.out, settings, tuple(args.modes),
                                 meta={"dataset": args.dataset, "method": args.method},
                                 allow_split_overlap=args.allow_split_overlap, matcher=_matcher(args),
                                 similarity=args.similarity, key=args.key, transpose=args.transpose)
    _wrote(f"the training-free scorers of {args.method}", args.out, "; ".join(
        f"{name}: {split.n_wrong} wrong sequence matches of {split.n_queries}, average precision "
        + ", ".join(f"{scorer} {detection.average_precision:.4f}" for scorer, detection in split.detection.items()
                    if detection.average_precision is not None)
        for name, split in found.splits.items()))


def _baseline_settings(args: argparse.Namespace) -> Any:
    """The scorers' settings of ``_baseline_options`` (``scorers.BaselineSettings``), None with --no-baselines."""
    from vpr_smr.eval.scoring.scorers import BaselineSettings

    if getattr(args, "no_baselines", False):
        return None
    return read_options(args, BaselineSettings, "baselines")


def _matcher(args: argparse.Namespace) -> Any:
    """The matcher options of ``_matcher_options`` as ``vpr_metrics.MatcherSettings``."""
    from vpr_smr.eval.scoring.vpr_metrics import MatcherSettings

    return MatcherSettings(read_matcher(args), args.radius, args.reference_positions, args.query_positions,
                           args.ground_truth, args.ground_truth_key)


def cmd_ablation_attributes(args: argparse.Namespace) -> None:
    from vpr_smr.eval.predictor import ablation

    params = _predictor_params(args)  # its settings checked before any file is read
    evaluate = _evaluation_splits(args)
    _check_seq_len(args, args.train, *evaluate.values())
    table = ablation.attributes_main(args.train, args.out, params, evaluate=evaluate,
                                     meta={"dataset": args.dataset, "seq_len": args.seq_len},
                                     allow_split_overlap=args.allow_split_overlap)
    _wrote("the attribute ablation (Table II)", args.out, ablation_headline(table))


def ablation_headline(table: Any) -> str:
    """Table II's headline (``records.AttributeAblation``): the macro F1 of the predictor on all four attributes,
    cross-validated and on each evaluation split."""
    from vpr_smr.eval.predictor.ablation import ALL_ATTRIBUTES

    every = table.attributes[ALL_ATTRIBUTES]
    return "; ".join([f"macro F1 with all four attributes: cross-validated {every.f1_cv:.3f}",
                      *(f"{name} {split.f1:.3f}" for name, split in every.splits.items())])


def cmd_ablation_without(args: argparse.Namespace) -> None:
    from vpr_smr.eval.predictor import ablation
    from vpr_smr.eval.predictor.train import cv_text, split_f1s

    params = _predictor_params(args)  # its settings checked before any file is read
    train = _split_paths(args.train, "--train", "METHOD")
    evaluate = {name: _split_paths(items, f"--evaluate {name}", "METHOD")
                for name, items in _evaluation_splits(args).items()}
    _check_seq_len(args, train.values(), *(files.values() for files in evaluate.values()))
    meta = {"dataset": args.dataset, "seq_len": args.seq_len}
    report = ablation.train_without(train, args.method, args.out, params, evaluate=evaluate, meta=meta,
                                    allow_split_overlap=args.allow_split_overlap, validation=args.validation)
    _wrote(f"the predictor without {args.method}", args.out,
           f"macro F1: {cv_text(report.seeds[0])}{split_f1s(report.seeds[0])}")


def cmd_ablation_held_out(args: argparse.Namespace) -> None:
    from vpr_smr.eval.scoring import held_out

    _check_seq_len(args, [args.attributes])
    result = held_out.main(args.attributes, args.pooled, args.without, args.out, tuple(args.modes),
                           meta={"dataset": args.dataset, "method": args.method, "seq_len": args.seq_len},
                           allow_split_overlap=args.allow_split_overlap)
    _wrote(f"{args.method}'s test split under the pooled and the without predictor", args.out,
           held_out_headline(result, args.method))


def held_out_headline(result: Any, method: str) -> str:
    """The held-out headline (``records.HeldOut``): per mode the AOC reduction of the predictor trained without
    ``method``, then the pooled one's, each with its interval and earned word (``_reduction``)."""
    return "; ".join(f"{mode} mode: AOC reduction without {method} {_reduction(without.reduction)}, pooled "
                     f"{_reduction(result.pooled.modes[mode].reduction)}"
                     for mode, without in result.without.modes.items())


def cmd_speed(args: argparse.Namespace) -> None:
    from vpr_smr.eval.scoring import speed

    params = _predictor_params(args)  # its settings checked before any file is read
    result = speed.main(args.dataset, args.seq_len, args.profile, _split_paths(args.train, "--train", "METHOD"),
                        _split_paths(args.test, "--table", "METHOD"), args.out, args.velocities, args.tolerance,
                        params, allow_split_overlap=args.allow_split_overlap)
    _wrote(f"the speed profile {args.profile}", args.out, speed_headline(result))


def speed_headline(result: Any) -> str:
    """The speed headline (``speed.SpeedResult``): the range of sequence recall@1 over its matchers and methods."""
    recalls = [scores.recall_at_1_sequence for matcher in result.matchers.values()
               for scores in matcher.methods.values()]
    n_methods = len(recalls) // len(result.matchers)
    return (f"sequence recall@1 {min(recalls):.4f} to {max(recalls):.4f} over {len(result.matchers)} matchers x "
            f"{n_methods} methods ({result.meta['mode']} mode, seed 0)")


def cmd_compare_matchers(args: argparse.Namespace) -> None:
    from vpr_smr.eval.scoring import matcher_comparison

    result = matcher_comparison.main(
        args.dataset, args.method, args.seq_len, _json_object(args.inputs, "--inputs"),
        _split_paths(args.distances, "--distances", "METHOD"), args.split, args.tolerance, args.out,
        _baseline_settings(args), tuple(args.modes), args.validation, args.radius, args.ground_truth,
        args.ground_truth_key, allow_split_overlap=args.allow_split_overlap)
    _wrote(f"the matchers compared on {args.method}", args.out, matchers_headline(result, args.modes))


def matchers_headline(result: Any, modes: Iterable[str]) -> str:
    """The compare-matchers headline (``MatcherComparison``): per mode, how many matcher-method pairs the seed-0
    predictor reduces the AOC for by ``curves.earned`` (its interval above 0)."""
    from vpr_smr.eval.scoring.curves import IMPROVED, earned

    counts = []
    for mode in modes:
        reductions = [scores.modes[mode].reduction for methods in result.matchers.values()
                      for scores in methods.values() if mode in scores.modes]
        reduced = sum(earned(r.outcome, r.reduction_pct_ci) == IMPROVED for r in reductions)
        counts.append(f"{reduced} of {len(reductions)} matcher-method pairs ({mode} mode)")
    return "the seed-0 predictor reduces the AOC, its interval above 0, for " + ", ".join(counts)


def cmd_adaptive(args: argparse.Namespace) -> None:
    from vpr_smr.eval.scoring import adaptive

    attributes: dict[str, list[str]] = {}
    for item in args.attributes:
        split, path = next(iter(_split_paths([item]).items()))
        attributes.setdefault(split, []).append(path)
    result = adaptive.main(
        args.dataset, args.method, attributes, args.predictors, args.split, args.out, args.validation,
        args.distances, args.seeds, _baseline_settings(args), tuple(args.modes), args.matcher_tag,
        allow_split_overlap=args.allow_split_overlap)
    print(adaptive_text(result, adaptive.read_timing(args.out)))
    _wrote(f"the adaptive sequence length of {args.method}", args.out, lowest_rule(result))


def lowest_rule(result: Any) -> str:
    """The length rule of the lowest AOC (seed 0) in the mode that compares rows (else the first), with its
    interval and its difference from the best fixed length's; no direction word (the table above has them)."""
    from vpr_smr.eval.report.bounds import bracket
    from vpr_smr.eval.scoring.adaptive_records import COMPARED_MODE, RULE

    rules = [row for row in result.rows if row.kind == RULE]
    if not rules:
        return "no length rule"
    modes = list(rules[0].modes)
    mode = COMPARED_MODE if COMPARED_MODE in modes else modes[0]
    best = min(rules, key=lambda row: row.modes[mode].reduction.aoc_vpr_sm_pred)
    numbers = best.modes[mode]
    text = (f"lowest AOC of the length rules ({mode} mode, seed 0): {best.name} "
            f"{numbers.reduction.aoc_vpr_sm_pred:.4f} {bracket(numbers.reduction.aoc_vpr_sm_pred_ci, '.4f')}")
    fixed = result.best_fixed.get(mode)
    if fixed is not None and numbers.minus_best_fixed is not None:
        text += (f", minus the best fixed length's ({fixed}) {numbers.minus_best_fixed:+.4f} "
                 f"{bracket(numbers.minus_best_fixed_ci, '.4f')}")
    return text


def adaptive_text(result: Any, timing: Any) -> str:
    """The report's table ``adaptive_seq_len`` of one result, its page columns, per mode, as Markdown."""
    from vpr_smr.eval.report.build import markdown_table
    from vpr_smr.eval.report.rows import cells
    from vpr_smr.eval.report.tables.adaptive import TABLE, adaptive_rows, adaptive_sentence

    rows = [cells(row) for row in adaptive_rows([(result, timing)])]
    out = []
    for mode in dict.fromkeys(row["mode"] for row in rows):
        shown = [row for row in rows if row["mode"] == mode]
        out += [markdown_table(TABLE.page, shown, f"{mode} mode, {result.n_queries} queries every length evaluates"),
                adaptive_sentence(shown), ""]
    return "\n".join([*out, *(f"Note: {note}" for note in result.notes)]).rstrip()


def cmd_inspect(args: argparse.Namespace) -> None:
    from vpr_smr.eval.report import inspector

    settings = (None if args.dataset_settings is None
                else _json_object(args.dataset_settings, "--dataset-settings"))
    written = inspector.main(
        args.queries, args.distances, args.dataset, settings,
        args.frames_sha256, args.seq_len, args.split, args.tolerance, args.match_figure, args.matrix_figure,
        per_class=args.per_class, mistakes=args.mistakes, seed=args.seed,
        split_range=(args.frames[0], args.frames[1]) if args.frames else None, radius=args.radius,
        matcher=read_matcher(args), reference_positions=args.reference_positions,
        query_positions=args.query_positions, similarity=args.similarity, key=args.key, transpose=args.transpose,
        ground_truth=args.ground_truth, ground_truth_key=args.ground_truth_key)
    log.info("wrote %s", " and ".join(str(path) for path in written if path is not None))


def cmd_report(args: argparse.Namespace) -> None:
    from vpr_smr.eval.report import build as report

    provenance = {"vpr_smr_version": package_version()}
    files = report.RunFiles(
        args.evaluations, args.predictors, args.attribute_ablations or (), args.leave_one_out or (),
        timings=args.timings or (), metrics=args.metrics or (), match_figures=args.match_figures or (),
        matrix_figures=args.matrix_figures or (), speed=args.speed or (), baselines=args.baselines or (),
        descriptors=args.descriptors or (), matchers=args.matchers or (), adaptive=args.adaptive or ())
    options = report.ReportOptions(
        split=args.split, eval_splits=args.eval_splits, train_split=args.train_split,
        table_seq_lens=args.table_seq_lens, seq_len_ablation=args.seq_len_ablation,
        config=_json_object(args.settings, "--settings") if args.settings else None, provenance=provenance,
        datasets=_json_object(args.datasets, "--datasets") if args.datasets else None)
    written = report.main(args.out, files, options)
    log.info("wrote %d tables, figures and report files under %s", len(written), args.out)


def _options(items: list[str] | None) -> dict[str, Any]:
    """``key=value`` settings; values parsed as YAML (numbers, lists, null) so they match the config file."""
    import yaml

    options = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise ValueError(f"--option {item!r} is not of the form key=value")
        options[key] = yaml.safe_load(value)
    return options


def cmd_checkpoint_check(args: argparse.Namespace) -> int:
    import numpy as np

    from vpr_smr.descriptors.base import CheckpointError
    from vpr_smr.descriptors.extract import build_backend

    conf = {"backend": args.method, "checkpoint": args.file, **_options(args.option)}
    try:
        backend, digest = build_backend(args.method, conf)
        size = backend.describe(np.full((224, 224, 3), 127, dtype=np.uint8)).shape[0]
    except CheckpointError as error:
        print(f"NOT OK: {error}", file=sys.stderr)
        return 1
    print(f"OK: {args.file} loads into backend {args.method!r} (strict); descriptor size {size}; sha256 {digest}")
    return 0


def cmd_backends(args: argparse.Namespace) -> int:
    from vpr_smr.descriptors.catalogue import backend_facts, format_backends

    print(format_backends(backend_facts()))
    return 0


def cmd_matchers(args: argparse.Namespace) -> int:
    from vpr_smr.pipeline.options import matcher_catalogue

    print(matcher_catalogue())
    return 0


def cmd_convert_checkpoint(args: argparse.Namespace) -> int:
    from vpr_smr.descriptors.convert import CONVERTERS, no_conversion

    if args.method not in CONVERTERS:
        raise ValueError(no_conversion(args.method))
    out = CONVERTERS[args.method](args.input, args.output)
    print(f"wrote {out}: load it with `checkpoint: {out}` in the method's settings")
    return 0


def _frame_range(text: str, option: str) -> list[int]:
    """``LO:HI`` -> ``[LO, HI]`` (frames LO .. HI-1), as the configuration writes a range."""
    lo, sep, hi = text.partition(":")
    if not (sep and lo.strip().isdigit() and hi.strip().isdigit()):
        raise ValueError(f"{option}: {text!r} is not a frame range LO:HI (frames LO to HI-1), e.g. 0:100")
    return [int(lo), int(hi)]


def _splits(items: list[str]) -> dict[str, Any]:
    """``["train=0:40", "val=40:70"]`` -> ``{"train": [0, 40], "val": [40, 70]}``; ``test=0:90/40:70`` gives the
    reference and the query range apart: ``{"test": {"reference": [0, 90], "query": [40, 70]}}``."""
    splits: dict[str, Any] = {}
    for item in items:
        name, sep, frames = item.partition("=")
        if not sep or not name:
            raise ValueError(f"--splits {item!r} is not NAME=LO:HI, e.g. --splits train=0:40 val=40:70 test=70:111")
        reference, slash, query = frames.partition("/")
        splits[name] = _frame_range(frames, f"--splits {name}") if not slash else {
            "reference": _frame_range(reference, f"--splits {name} (references)"),
            "query": _frame_range(query, f"--splits {name} (queries)")}
    return splits


DATASET_OPTIONS = ("root", "reference", "query", "reference_list", "query_list", "pairing", "tolerance",
                   "reference_positions", "query_positions", "positions", "radius")


def _check_ground_truth(name: str, pair: Any) -> tuple[list[str], list[str]]:
    """``dataset check``'s check of a ground-truth file: the one ``vpr-smr run`` makes before its first job, its notes
    over every split of the pair."""
    from vpr_smr.pipeline.plan import ground_truth_problems

    problems: list[str] = []
    notes: list[str] = []
    ground_truth_problems(name, pair, list(pair.splits), problems, notes)
    return problems, notes


def cmd_dataset_check(args: argparse.Namespace) -> int:
    from vpr_smr.datasets import check

    given = {key: getattr(args, key) for key in DATASET_OPTIONS if getattr(args, key) is not None}
    if args.frames:
        given["frames"] = _frame_range(args.frames, "--frames")
    if args.splits:
        given["splits"] = _splits(args.splits)
    given.update(_options(args.option))
    if args.config:
        if args.name or given:
            raise ConfigError("give either --config (and --dataset) or a loader with its options, not both")
        datasets = load_config(args.config).datasets
        name = args.dataset or (next(iter(datasets)) if len(datasets) == 1 else None)
        if name is None or name not in datasets:
            raise ConfigError(f"{args.config}: give --dataset, one of {', '.join(datasets)}" if name is None else
                              f"{args.config}: datasets has no {name!r}; it has {', '.join(datasets)}")
        return check.main(datasets[name].to_json(), name=name, decode=args.decode,
                          check_ground_truth=_check_ground_truth, source=str(args.config))
    if not args.name:
        raise ConfigError("give a loader and its options (vpr-smr dataset check folders --reference DIR --query DIR"
                          " ...), or a configuration (vpr-smr dataset check --config my.yaml --dataset NAME)")
    return check.main({"loader": args.name, **given}, decode=args.decode, check_ground_truth=_check_ground_truth)


def cmd_run(args: argparse.Namespace) -> int:
    from vpr_smr.pipeline import workflow

    return workflow.run(args.config, cores=args.cores, dry_run=args.dry_run, extra=args.snakemake_args,
                        overrides=args.set, profile=args.profile, verbose=args.snakemake_output or args.verbose)


# Each stage command's --out file: what it holds and the suffixes it may have, checked before any work.
OUT_FILES = {
    "descriptors": ("the descriptors (HDF5)", HDF5_SUFFIXES),
    "distances": ("the distance matrix (HDF5)", HDF5_SUFFIXES),
    "attributes": ("the attributes (.csv table or HDF5)", CSV_SUFFIXES + HDF5_SUFFIXES),
    "train": ("the predictor (HDF5; its report goes beside it as .json)", HDF5_SUFFIXES),
    "evaluate": ("the evaluation (JSON)", JSON_SUFFIXES),
    "metrics": ("the VPR metrics (JSON)", JSON_SUFFIXES),
    "queries": ("the per-query table (CSV)", CSV_SUFFIXES),
    "ablation attributes": ("the attribute ablation (JSON)", JSON_SUFFIXES),
    "ablation without": ("the predictor (HDF5; its report goes beside it as .json)", HDF5_SUFFIXES),
    "ablation held-out": ("the leave-one-method-out evaluation (JSON)", JSON_SUFFIXES),
    "baselines": ("the training-free baselines (JSON)", JSON_SUFFIXES),
    "speed": ("the speed experiment's result (JSON)", JSON_SUFFIXES),
    "compare-matchers": ("the matchers experiment's result (JSON)", JSON_SUFFIXES),
    "adaptive": ("the adaptive sequence length's result (JSON; its timing goes beside it)", JSON_SUFFIXES),
}


def _check_out(args: argparse.Namespace) -> None:
    if hasattr(args, "stage"):  # a declared stage: its work checks its output's suffix first
        return
    command = " ".join(filter(None, (args.command, getattr(args, "ablation_command", None))))
    if command in OUT_FILES:
        what, allowed = OUT_FILES[command]
        check_suffix(args.out, allowed, what)


def _required(parser: argparse.ArgumentParser, *options: str) -> None:
    for option in options:
        parser.add_argument(option, required=True)


def _allow_overlap(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--allow-split-overlap", action="store_true",
                        help="let a predictor score frames or matrices it was trained on, or blocks overlapping "
                        "them (a deliberate experiment)")


def _matcher_options(parser: argparse.ArgumentParser, matcher: str) -> None:
    """The sequence matcher (``--matcher`` and its settings), its ground truth (frames within a tolerance, positions
    within a radius, or a file) and how a user's matrix is read."""
    parser.add_argument("--tolerance", type=int, default=DEFAULT_TOLERANCE,
                        help="frame-aligned pairs: a match within this many frames is correct (default 2)")
    add_matcher_options(parser, matcher)
    parser.add_argument("--reference-positions", metavar="PATH",
                        help="one position per reference frame (.npy, or CSV of numbers: x[,y]); with "
                             "--query-positions and --radius, the ground truth of a pair that is not frame-aligned")
    parser.add_argument("--query-positions", metavar="PATH", help="one position per query frame (.npy or CSV)")
    parser.add_argument("--radius", type=float,
                        help="with positions: a match within this distance (the positions' unit) is correct")
    parser.add_argument("--ground-truth", metavar="FILE",
                        help="the ground truth as a file instead of --tolerance or positions: a boolean references x "
                             "queries matrix (.npy, .npz, .mat, e.g. VPR_Tutorial's GThard) or per-query lists of "
                             "correct references (JSON {\"query\": [reference, ...]}, CSV query,reference, "
                             "VPR-Bench's ground_truth_new.npy); a file of a whole dataset is cut to the split of "
                             "an .h5 of vpr-smr distances")
    parser.add_argument("--ground-truth-key", metavar="NAME",
                        help="the variable of a --ground-truth .npz or .mat holding several (e.g. GThard)")
    parser.add_argument("--similarity", action="store_true",
                        help="the matrix holds similarities (larger = more similar): read as distances "
                             "max(M) - M, recorded in the outputs")
    parser.add_argument("--key", metavar="NAME",
                        help="the array of an .npz, or the variable of a MATLAB .mat, holding the matrix (default: "
                             "the file's only 2-D numeric one)")
    parser.add_argument("--transpose", action="store_true",
                        help="the matrix file is queries x references (vpr-smr reads references x queries)")


def _baseline_options(parser: argparse.ArgumentParser, switch: bool = True) -> None:
    """The training-free scorers' settings (method §12: ``scorers.BaselineSettings``); ``switch``: also
    --no-baselines."""
    from vpr_smr.eval.scoring.scorers import BaselineSettings

    add_options(parser, BaselineSettings, "baselines")
    if switch:
        parser.add_argument("--no-baselines", action="store_true",
                            help="leave out the training-free scorers (needed for --attributes files computed "
                                 "with --candidates 0)")


def _matrix_options(parser: argparse.ArgumentParser, predictor_help: str, matcher: str) -> None:
    """The options of the commands that read users' distance matrices (``metrics``, ``queries``)."""
    parser.add_argument("--distances", nargs="+", required=True, metavar="PATH or SPLIT=PATH",
                        help="references x queries matrices (.npy, .npz, .mat or our .h5): one file, or one "
                             "SPLIT=PATH per split")
    parser.add_argument("--seq-len", type=int, required=True)
    _matcher_options(parser, matcher)
    parser.add_argument("--predictor", help=predictor_help)
    parser.add_argument("--attributes", nargs="*", metavar="SPLIT=PATH",
                        help="the splits' attributes (.h5) computed from the same matrices (default: computed here)")


# The top-level help: plain text for users, in the order they run the commands (line breaks kept).
DESCRIPTION = """\
From the images of two traverses of a route (a reference and a query drive) to the tables, figures and report
of sequence-matching receptiveness (SMR) in visual place recognition, offline.

The usual order:
  1. check your data: every image found and decoded, the frames paired and split
       vpr-smr dataset check folders --reference my_route/reference --query my_route/query
       vpr-smr dataset check --config my.yaml
  2. run the whole workflow of a configuration: descriptors, distances, predictor, tables, report.html
       vpr-smr run my.yaml
  3. or score a distance matrix of your own method (references x queries, .npy) stage by stage
       vpr-smr attributes --distances D.npy --seq-len 4 --out attributes.csv
       vpr-smr metrics --distances D.npy --seq-len 4 --out metrics.json
       vpr-smr queries --distances D.npy --seq-len 4 --out queries.csv
"""
EPILOG = """\
A configuration to start from: configs/own_folders.yaml in a checkout (two image folders of your own).
vpr-smr backends lists the descriptor backends with their settings.
vpr-smr COMMAND --help shows a command's options; vpr-smr --debug COMMAND ... shows an error's traceback.
"""

# The help of options that several commands share with one meaning, filled in where a command adds one without
# its own help (``--out``'s comes from OUT_FILES, per command).
SHARED_HELP = {
    "--seq-len": "the sequence length L of SeqSLAM's sequence matching (frames per sequence)",
    "--tolerance": f"a match within this many frames of the query's own is correct (default {DEFAULT_TOLERANCE})",
    "--dataset": "the dataset's name (a key of the configuration's datasets)",
    "--method": "the method's name (a key of the configuration's methods)",
    "--queries": "the per-query table (.csv) of vpr-smr queries",
    "--distances": "the distance matrix: our .h5, or a references x queries .npy, .npz or .mat",
    "--matrix-figure": "where to write the distance-matrix figure (.png)",
    "--modes": "the metric modes: paper (the authors' rules) and/or standard",
}


def _fill_help(parser: argparse.ArgumentParser, command: str = "") -> None:
    """Give every option of every (sub)command added without help its shared one (``SHARED_HELP``, ``OUT_FILES``)."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, subparser in action.choices.items():
                _fill_help(subparser, f"{command} {name}".strip())
        elif action.help is None:
            option = next((o for o in action.option_strings if o.startswith("--")), "")
            if option == "--out" and command in OUT_FILES:
                action.help = f"the output file: {OUT_FILES[command][0]}"
            elif option in SHARED_HELP:
                action.help = SHARED_HELP[option]


def build_parser(matcher: str = DEFAULT_MATCHER, job: bool = False) -> argparse.ArgumentParser:
    """The ``vpr-smr`` command line; the stage commands' ``--matcher`` options are those of ``matcher``'s
    settings (``main`` reads ``--matcher`` first); ``job``: the command line gives a stage's ``--job``."""
    parser = argparse.ArgumentParser(prog="vpr-smr", description=DESCRIPTION, epilog=EPILOG,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"%(prog)s {package_version()}",
                        help="the installed version (the package metadata's); cite it with your results")
    parser.add_argument("-v", "--verbose", action="store_true", help="debug logging")
    parser.add_argument("--debug", action="store_true", help="show the Python traceback of an error")
    sub = parser.add_subparsers(dest="command", required=True, title="commands", metavar="COMMAND")

    p = sub.add_parser("dataset", help="check a dataset on disk before a run (start here)")
    dataset_sub = p.add_subparsers(dest="dataset_command", required=True)
    c = dataset_sub.add_parser(
        "check", help="verify a dataset on disk before a long run",
        description="Every image is found and decoded; prints the frames per traverse and split, the order and "
                    "pairing of the frames, and every problem. The options are the configuration's keys.",
        epilog="e.g. vpr-smr dataset check folders --reference my_route/reference --query my_route/query "
               "--splits train=0:100 val=100:150 test=150:300;  vpr-smr dataset check nordland --root /data/nordland;"
               "  vpr-smr dataset check --config my.yaml --dataset my_route")
    c.add_argument("name", nargs="?", help="loader: folders, nordland_sample, nordland, robotcar, sfu_mountain")
    c.add_argument("--config", help="take the dataset's settings from this configuration file")
    c.add_argument("--dataset", help="with --config: which of its datasets (default: its only one)")
    c.add_argument("--root", help="the dataset's folder (benchmark loaders)")
    c.add_argument("--reference", help="folders: the reference traverse's image folder")
    c.add_argument("--query", help="folders: the query traverse's image folder")
    c.add_argument("--reference-list", help="a frame list naming the reference frames in order")
    c.add_argument("--query-list", help="a frame list naming the query frames in order")
    c.add_argument("--pairing", choices=("by_name", "by_order"), help="folders: how frame i of both is paired")
    c.add_argument("--tolerance", type=int, help="frames of ground-truth tolerance (default 2)")
    c.add_argument("--reference-positions", help="folders: a CSV (name,x,y or name,lat,lon) of the reference frames")
    c.add_argument("--query-positions", help="folders: a CSV (name,x,y or name,lat,lon) of the query frames")
    c.add_argument("--positions", help="positions from the names (folders: file_names) or the INS logs (robotcar: ins)")
    c.add_argument("--radius", type=float, help="with positions: a match is correct within this distance")
    c.add_argument("--frames", metavar="LO:HI", help="keep frames LO .. HI-1 only")
    c.add_argument("--splits", nargs="+", metavar="NAME=LO:HI",
                   help="e.g. train=0:40 val=40:70 test=70:111; with positions NAME=LO:HI/LO:HI gives the "
                        "reference and the query range apart")
    c.add_argument("--option", action="append", metavar="KEY=VALUE", help="any other loader setting (repeatable)")
    c.add_argument("--no-decode", dest="decode", action="store_false", help="only look for the files")
    c.set_defaults(func=cmd_dataset_check)

    p = sub.add_parser("run", help="run the whole workflow of a configuration with Snakemake")
    p.add_argument("config", help="the run's configuration (.yaml), e.g. configs/own_folders.yaml")
    p.add_argument("--cores", type=int, help="default: the profile's (local: 2)")
    p.add_argument("--config", dest="set", action="append", metavar="KEY=VALUE",
                   help="override a setting, dotted keys for nested ones: --config predictor.max_iter=500")
    p.add_argument("--profile", default="local", help="a shipped profile (local, slurm) or a profile folder")
    p.add_argument("-n", "--dry-run", action="store_true", help="only count the jobs that would run, per rule")
    # Its own dest: a subcommand's default would overwrite the global -v/--verbose (`vpr-smr -v run` works too).
    p.add_argument("-v", "--verbose", dest="snakemake_output", action="store_true",
                   help="show Snakemake's own output instead of the progress view (which logs it under "
                        "<run folder>/logs/snakemake-<time>.log)")
    p.epilog = "Arguments after a lone -- go to snakemake unchanged, e.g. vpr-smr run c.yaml -- --forceall"
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("backends", help="list the descriptor backends: checkpoint, input size, default settings",
                       description="Every descriptor backend (built in, or registered by an installed package) with "
                                   "whether it needs a checkpoint, its distance, the input size of its official "
                                   "evaluation and its default settings.")
    p.set_defaults(func=cmd_backends)

    p = sub.add_parser("matchers", help="list the sequence matchers: description, native confidence, settings",
                       description="Every sequence matcher (built in, or registered by an installed package through "
                                   "the entry point group vpr_smr.matchers) with its native confidence and each "
                                   "setting's default and help.")
    p.set_defaults(func=cmd_matchers)

    p = sub.add_parser("checkpoint", help="checkpoint tools")
    checkpoint_sub = p.add_subparsers(dest="checkpoint_command", required=True)
    c = checkpoint_sub.add_parser("check", help="load a downloaded checkpoint exactly as the pipeline would")
    c.add_argument("method", help="backend name, e.g. netvlad, cosplace, salad")
    c.add_argument("file", help="the downloaded checkpoint file")
    c.add_argument("--option", action="append", metavar="KEY=VALUE", help="a backend setting (repeatable)")
    c.set_defaults(func=cmd_checkpoint_check)

    p = sub.add_parser("convert-checkpoint", help="turn an official pickle into a plain tensor file (apgem)")
    p.add_argument("method", help="the backend whose release needs converting (apgem)")
    p.add_argument("input", help="the official file, e.g. Resnet-101-AP-GeM.pt")
    p.add_argument("output", help="the plain tensor file to write; set it as the method's checkpoint")
    p.set_defaults(func=cmd_convert_checkpoint)

    p = sub.add_parser("descriptors", help="compute a method's descriptors of a dataset (HDF5)")
    _required(p, "--dataset", "--method", "--out")
    p.add_argument("--config", help="take the dataset's and method's settings from this configuration file")
    p.add_argument("--dataset-settings", help="the dataset's settings as a JSON object (or @file)")
    p.add_argument("--method-settings", help="the method's settings as a JSON object (or @file)")
    p.add_argument("--frames-sha256", help="fail unless the dataset's frame lists have this fingerprint")
    add_options(p, Extraction, "extraction")
    p.add_argument("--threads", type=int, help="CPU threads of the network")
    p.set_defaults(func=cmd_descriptors)

    p = sub.add_parser("distances", help="reference x query distance matrix of one split (HDF5)")
    p.add_argument("--descriptors", required=True, help="the descriptor file (.h5) of vpr-smr descriptors")
    p.add_argument("--split", required=True, help="the split's name, e.g. test (written in the file)")
    _required(p, "--out")
    p.add_argument("--frames", type=int, nargs=2, required=True, metavar=("LO", "HI"),
                   help="the split's frames lo..hi-1 of both traverses (its queries, with --reference-frames)")
    p.add_argument("--reference-frames", type=int, nargs=2, metavar=("LO", "HI"),
                   help="the split's reference frames lo..hi-1, when they differ from --frames (traverses with "
                        "positions)")
    p.add_argument("--metric", choices=METRICS, help="the distance (default: the descriptor file's, its backend's)")
    p.set_defaults(func=cmd_distances)

    p = sub.add_parser("train", help="train the predictor on the pooled train attributes of every method")
    _required(p, "--dataset")
    p.add_argument("--seq-len", type=int, required=True)
    p.add_argument("--predictor", help="the predictor's settings as a JSON object (or @file)")
    p.add_argument("--seeds", type=int, default=1, help="train seeds 0..N-1 (seed 0: the authors' recipe)")
    p.add_argument("--train", nargs="+", required=True, metavar="PATH",
                   help="every method's train-split attributes (.h5), pooled in this order")
    _evaluate_option(p, "every method's attributes of it (.h5): the predictor's macro F1 on them")
    p.add_argument("--validation", metavar="SPLIT",
                   help="the evaluation split whose F1 decides whether a predictor can be trusted (a warning "
                        "otherwise; default: the first --evaluate split)")
    _old_split_options(p)
    p.add_argument("--out", required=True, help="the seed-0 predictor (.h5); other seeds beside it")
    _allow_overlap(p)
    p.set_defaults(func=cmd_train)

    p = sub.add_parser("evaluate", help="match removal and precision-recall of one method")
    _required(p, "--dataset", "--method")
    p.add_argument("--seq-len", type=int, required=True)
    p.add_argument("--attributes", nargs="+", required=True, metavar="SPLIT=PATH",
                   help="the method's attributes (.h5) of each evaluated split")
    p.add_argument("--predictors", nargs="+", required=True, help="one per seed, seed 0 first")
    p.add_argument("--modes", nargs="+", default=schema_default("modes"), choices=MODES)
    p.add_argument("--trust-levels", nargs="*", type=float, default=schema_default("trust_levels"),
                   help="trust levels of the trust-level ablation (none: skip it)")
    p.add_argument("--no-restoration", dest="restoration", action="store_false", help="skip match restoration")
    _required(p, "--out")
    _allow_overlap(p)
    p.set_defaults(func=cmd_evaluate)

    p = sub.add_parser("metrics", help="standard VPR metrics (recall@N, R@100P, PR-AUC, EP) of distance matrices",
                       epilog="e.g. vpr-smr metrics --distances D.npy --seq-len 4 --out metrics.json;  "
                              "vpr-smr metrics --distances val=val.h5 test=test.h5 --seq-len 4 --predictor L4.h5 "
                              "--queries queries.csv --out metrics.json")
    _matrix_options(p, "the seed-0 predictor (.h5): adds the sequence_predictor matcher", matcher)
    p.add_argument("--modes", nargs="+", default=schema_default("modes"), choices=MODES)
    p.add_argument("--queries", help="also write one row per evaluated query to this .csv (as vpr-smr queries "
                                      "does); both files or neither are written")
    p.add_argument("--sweep", action="store_true",
                   help="also recall@1 and the predictor's AOC reduction over the tolerances 0, 1, 2, 5, 10 frames "
                        "(radii 5, 10, 25, 50 with positions): how the conclusions depend on the protocol")
    p.add_argument("--dataset", help="the dataset's name, written in the metrics' meta")
    p.add_argument("--method", help="the method's name, written in the metrics' meta")
    _baseline_options(p)
    _required(p, "--out")
    _allow_overlap(p)
    p.set_defaults(func=cmd_metrics)

    p = sub.add_parser("queries", help="one row per evaluated query of distance matrices: matches, distances, "
                                       "attributes, true class and the predictor's decision (CSV)",
                       epilog="e.g. vpr-smr queries --distances val=val.h5 test=test.h5 --seq-len 4 --predictor L4.h5 "
                              "--out queries.csv (the same table as vpr-smr metrics --queries)")
    _matrix_options(p, "the seed-0 predictor (.h5): fills predicted_class, probability and kept", matcher)
    _baseline_options(p)
    _required(p, "--out")
    _allow_overlap(p)
    p.set_defaults(func=cmd_queries)

    p = sub.add_parser("baselines", help="training-free scorers against the predictor: wrong-match detection and "
                                         "removal at every predictor seed's budget (method §12)",
                       epilog="e.g. vpr-smr baselines --dataset D --method M --seq-len 4 --distances val=v.h5 "
                              "test=t.h5 --attributes val=va.h5 test=ta.h5 --predictors L4.h5 L4.seed1.h5 "
                              "--out L4.json")
    _required(p, "--dataset", "--method")
    p.add_argument("--seq-len", type=int, required=True)
    p.add_argument("--distances", nargs="+", required=True, metavar="SPLIT=PATH",
                   help="each split's distance matrix (our .h5, or .npy, .npz, .mat): the ground truth's shape and "
                        "positions")
    p.add_argument("--attributes", nargs="+", required=True, metavar="SPLIT=PATH",
                   help="each split's attributes (.h5) with the scorers' candidates (vpr-smr attributes)")
    p.add_argument("--predictors", nargs="+", required=True, help="one per seed, seed 0 first: their budgets")
    _matcher_options(p, matcher)
    _baseline_options(p, switch=False)
    p.add_argument("--modes", nargs="+", default=schema_default("modes"), choices=MODES)
    _required(p, "--out")
    _allow_overlap(p)
    p.set_defaults(func=cmd_baselines)

    p = sub.add_parser("ablation", help="the predictor's ablations")
    ablation_sub = p.add_subparsers(dest="ablation_command", required=True)
    c = ablation_sub.add_parser("attributes", help="Table II: a predictor on each attribute alone and on all four")
    _required(c, "--dataset", "--out")
    c.add_argument("--seq-len", type=int, required=True)
    c.add_argument("--predictor", help="the predictor's settings as a JSON object (or @file)")
    c.add_argument("--train", nargs="+", required=True, metavar="PATH",
                   help="every method's train-split attributes (.h5), pooled in this order")
    _evaluate_option(c, "every method's attributes of it (.h5): the validation split first, then the last "
                        "evaluation split (Table II's two)")
    _old_split_options(c)
    _allow_overlap(c)
    c.set_defaults(func=cmd_ablation_attributes)
    c = ablation_sub.add_parser("without", help="train a predictor on every method's train split but one")
    _required(c, "--dataset", "--method", "--out")
    c.add_argument("--seq-len", type=int, required=True)
    c.add_argument("--predictor", help="the predictor's settings as a JSON object (or @file)")
    c.add_argument("--train", nargs="+", required=True, metavar="METHOD=PATH",
                   help="the other methods' train-split attributes (.h5), in the configuration's order (--method's, "
                        "if given, is never read)")
    _evaluate_option(c, "each method's attributes of it (.h5)", "METHOD=PATH")
    c.add_argument("--validation", metavar="SPLIT",
                   help="the evaluation split whose F1 decides whether the predictor can be trusted (default: the "
                        "first --evaluate split)")
    _old_split_options(c)
    _allow_overlap(c)
    c.set_defaults(func=cmd_ablation_without)
    c = ablation_sub.add_parser("held-out", help="a method's test split under the pooled and the without_ predictor")
    _required(c, "--dataset", "--method")
    c.add_argument("--attributes", required=True, help="the held-out method's test-split attributes (.h5)")
    c.add_argument("--pooled", required=True, help="the predictor trained on every method (.h5)")
    c.add_argument("--without", required=True, help="the predictor trained without the method (.h5, vpr-smr "
                                                    "ablation without)")
    _required(c, "--out")
    c.add_argument("--seq-len", type=int, required=True)
    c.add_argument("--modes", nargs="+", default=schema_default("modes"), choices=MODES)
    _allow_overlap(c)
    c.set_defaults(func=cmd_ablation_held_out)

    p = sub.add_parser("speed", help="one simulated speed profile: Table I's numbers of the fixed matcher "
                                     "and of velocity search, each with its own seed-0 predictor",
                       epilog="e.g. vpr-smr speed --dataset d --seq-len 4 --profile 2x --velocities 0.5 1 2 "
                              "--train sad=train.h5 --table sad=test.h5 --out speed/2x.json")
    _required(p, "--dataset", "--out")
    p.add_argument("--profile", required=True,
                   help="a constant speed such as 0.5x, 1x or 2x (places per query frame), or varying")
    p.add_argument("--seq-len", type=int, required=True)
    p.add_argument("--velocities", type=float, nargs="+", default=schema_default("speed", "velocities"),
                   metavar="V", help="the velocity matcher's search set (reference frames per query frame, each > 0)")
    p.add_argument("--tolerance", type=int, default=DEFAULT_TOLERANCE,
                   help="a match within this many places of the simulated query's position is correct")
    p.add_argument("--train", nargs="+", required=True, metavar="METHOD=PATH",
                   help="each method's train split distances (.h5), in the pooled training order")
    p.add_argument("--table", "--test", dest="test", nargs="+", required=True, metavar="METHOD=PATH",
                   help="each method's table split distances (.h5), the same methods in the same order (--test: "
                        "the same option)")
    p.add_argument("--predictor", help="the predictor's settings as a JSON object (or @file)")
    _allow_overlap(p)
    p.set_defaults(func=cmd_speed)

    p = sub.add_parser("compare-matchers", help="the experiment matchers (method §14): each matcher with its own "
                                                "predictor, on the queries every matcher evaluates",
                       epilog="e.g. vpr-smr compare-matchers --dataset d --method sad --seq-len 4 --inputs "
                              "@inputs.json --distances sad=test.h5 --split test --validation val "
                              "--out matchers/d/sad/L4.json")
    _required(p, "--dataset", "--method", "--out")
    p.add_argument("--seq-len", type=int, required=True)
    p.add_argument("--inputs", required=True,
                   help="the compared matchers' files as a JSON object (or @file): {\"matchers\": [{\"matcher\": "
                        "{\"name\": ..., \"settings\": {...}}, \"attributes\": {SPLIT: {METHOD: PATH}}, "
                        "\"predictors\": [seed 0 first]}, ...], \"fixed\": the fixed matcher's validation attributes "
                        "or null}")
    p.add_argument("--distances", nargs="+", required=True, metavar="METHOD=PATH",
                   help="each method's table split distances (.h5): the ground truth's reference positions")
    p.add_argument("--split", required=True, help="the table split (a split of --inputs' attributes)")
    p.add_argument("--validation", help="the validation split: the warning of a matcher far below the fixed one")
    p.add_argument("--tolerance", type=int, default=DEFAULT_TOLERANCE,
                   help="a match within this many frames is correct (the attributes' own tolerance)")
    p.add_argument("--radius", type=float, help="with positions: the attributes' radius")
    p.add_argument("--ground-truth", metavar="FILE", help="the dataset's ground-truth file, as vpr-smr baselines")
    p.add_argument("--ground-truth-key", metavar="NAME", help="the variable of a --ground-truth .npz or .mat")
    _baseline_options(p, switch=False)
    p.add_argument("--modes", nargs="+", default=schema_default("modes"), choices=MODES)
    _allow_overlap(p)
    p.set_defaults(func=cmd_compare_matchers)

    p = sub.add_parser("adaptive", help="the sequence length chosen per query (method §15): each rule against every "
                                        "fixed length with and without its predictor; prints the table",
                       epilog="e.g. vpr-smr adaptive --attributes test=L2/test.h5 test=L4/test.h5 val=L2/val.h5 "
                              "val=L4/val.h5 --predictors L2.h5 L4.h5 --split test --validation val --distances "
                              "test.h5 --out adaptive.json")
    p.add_argument("--attributes", nargs="+", required=True, metavar="SPLIT=PATH",
                   help="the attributes files (vpr-smr attributes) of every sequence length, each given as SPLIT=PATH: "
                        "the table split's, and the validation split's for adaptive_uniqueness; each file records "
                        "its length")
    p.add_argument("--predictors", nargs="+", required=True, metavar="PATH",
                   help="one predictor per length, its seed-0 file (vpr-smr train); the other seeds' files beside it "
                        "(L4.seed1.h5, ...) are read too")
    p.add_argument("--seeds", type=int, help="the seeds to read per length (default: every seed file found)")
    p.add_argument("--split", required=True, help="the split to score (the table split)")
    p.add_argument("--validation", help="the validation split: adaptive_uniqueness's threshold is chosen there")
    p.add_argument("--distances", metavar="PATH",
                   help="the table split's distance file: the live matcher's time per query (none without it)")
    p.add_argument("--dataset", default="dataset", help="the dataset's name in the result")
    p.add_argument("--method", default="method", help="the method's name in the result")
    p.add_argument("--matcher-tag", help="the matcher's name in the result (default: its registry name)")
    _required(p, "--out")
    _baseline_options(p, switch=False)
    p.add_argument("--modes", nargs="+", default=schema_default("modes"), choices=MODES)
    _allow_overlap(p)
    p.set_defaults(func=cmd_adaptive)

    p = sub.add_parser("inspect", help="the match inspector: sampled queries with their matches, and the distance "
                                       "matrix with the kept and removed sequence matches (two PNGs)",
                       epilog="e.g. a user's matrix, the distance-matrix figure only (it needs no images): vpr-smr "
                              "inspect --queries queries.csv --distances D.npy --seq-len 4 --matrix-figure d.png")
    _required(p, "--queries", "--distances", "--matrix-figure")
    p.add_argument("--match-figure", help="the match figure (PNG): thumbnails of the frames, so it needs "
                                          "--dataset and --dataset-settings (a dataset with images)")
    p.add_argument("--dataset", help="the dataset's name (with --dataset-settings: for the match figure's images)")
    p.add_argument("--dataset-settings", help="the dataset's configuration entry as a JSON object (or @file), "
                                              "e.g. {\"loader\": \"folders\", \"reference\": DIR, \"query\": DIR}")
    p.add_argument("--frames-sha256", help="fail unless the dataset's frame lists have this fingerprint "
                                           "(default: the distances file's)")
    p.add_argument("--seq-len", type=int, required=True)
    p.add_argument("--split", help="the queries CSV's split to show (default: its only split)")
    _matcher_options(p, matcher)  # as the queries CSV was made: the matcher, the ground truth, --similarity
    p.add_argument("--frames", type=int, nargs=2, metavar=("LO", "HI"),
                   help="the split's frames lo..hi-1 (default: the distances file's split_range; a .npy's "
                        "queries count from 0)")
    p.add_argument("--per-class", type=int, default=2, help="queries sampled per true class")
    p.add_argument("--mistakes", type=int, default=4, help="the predictor's most confident mistakes shown")
    p.add_argument("--seed", type=int, default=0, help="seed of the sample")
    p.set_defaults(func=cmd_inspect)

    p = sub.add_parser("report", help="paper-style tables, figures and report.html of a run")
    p.add_argument("--evaluations", nargs="+", required=True, help="the evaluations' .json files (vpr-smr evaluate)")
    p.add_argument("--predictors", nargs="+", required=True,
                   help="the predictors' .json reports (written beside each vpr-smr train predictor)")
    p.add_argument("--attribute-ablations", nargs="*", help="Table II's files (vpr-smr ablation attributes)")
    p.add_argument("--leave-one-out", nargs="*", help="the held-out methods' files (vpr-smr ablation held-out)")
    p.add_argument("--timings", nargs="*", help="the evaluations' .timing.json files (matched by dataset, method, L)")
    p.add_argument("--baselines", nargs="*",
                   help="the training-free baselines' .json files (vpr-smr baselines), each of one dataset, method and "
                        "L: their tables, figures and findings, and the best of them in the sequence-length ablation")
    p.add_argument("--metrics", nargs="*", help="the standard VPR metrics files (vpr-smr metrics), at the table's L")
    p.add_argument("--match-figures", nargs="*", help="the match inspector's match figures (vpr-smr inspect)")
    p.add_argument("--matrix-figures", nargs="*", help="the match inspector's distance-matrix figures")
    p.add_argument("--speed", nargs="*", help="the speed experiment's files (vpr-smr speed), one per dataset and "
                                              "profile, in the configuration's order")
    p.add_argument("--matchers", nargs="*", help="the experiment matchers' files (vpr-smr compare-matchers), one per "
                                                 "dataset and method")
    p.add_argument("--adaptive", nargs="*", help="the experiment adaptive_seq_len's files (vpr-smr adaptive), one per "
                                                 "dataset, matcher and method; each one's .timing.json beside it gives "
                                                 "the live time per query")
    p.add_argument("--descriptors", nargs="*", help="descriptor files whose provenance the report shows")
    p.add_argument("--split", help="the split the tables show: the configuration's table_split (default: the one "
                                   "split every evaluation holds)")
    p.add_argument("--eval-splits", nargs="+", metavar="SPLIT",
                   help="the configuration's eval_splits, in its order: the predictor table's columns; the "
                        "first is the validation split of its warnings, Table II shows the first and the last "
                        "(default: the inputs' splits, --split last)")
    p.add_argument("--train-split", help="the configuration's train_split, as Table II names it (default: train)")
    p.add_argument("--table-seq-lens", type=int, nargs="+", help="sequence lengths of Table I (default: all)")
    p.add_argument("--seq-len-ablation", action="store_true", help="also the sequence-length table and figure")
    p.add_argument("--settings", help="the run's settings (JSON, or @file) shown in the report")
    p.add_argument("--datasets", help="per dataset: traverses, frames, tolerance, splits, pairing, overlaps (JSON)")
    p.add_argument("--out", required=True, help="the run folder: tables/, figures/ and report.html go inside")
    p.set_defaults(func=cmd_report)
    # the declared stages (``pipeline.stages``), each replacing its command of above, then the installed experiments'
    for stage in (*STAGES, *plugin_stages()):
        install(sub, stage, matcher, job)
    _fill_help(parser)
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    # `run ... -- <snakemake arguments>`: split by hand, so that our own options may come in any order.
    extra = argv[argv.index("--") + 1 :] if "--" in argv else []
    argv = argv[: argv.index("--")] if "--" in argv else argv
    args = build_parser(matcher_of(argv), JOB in argv or any(word.startswith(JOB + "=") for word in argv)
                        ).parse_args(argv)
    args.snakemake_args = extra
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.INFO, format=LOG_FORMAT)
    # A stage stopped by SIGTERM unwinds like Ctrl-C, so that its temporary files are removed on the way out.
    signal.signal(signal.SIGTERM, _interrupt)
    try:
        _check_out(args)
        status = args.func(args)
    except KeyboardInterrupt:
        print(f"vpr-smr {args.command}: interrupted; nothing was written under a final name", file=sys.stderr)
        return 130
    except Exception as error:
        if args.debug:
            raise
        known = isinstance(error, ConfigError | ValueError | OSError)
        hint = "" if known else f" ({type(error).__name__}; run with --debug for the traceback)"
        print(f"vpr-smr {args.command}: error: {error}{hint}", file=sys.stderr)
        return 2
    return int(status or 0)


def run() -> None:
    """The ``vpr-smr`` program: ``main`` on this process's arguments, then the process ends with its status."""
    status = main()
    # Nothing is collected after this: the interpreter's exit then skips the collections that free every module's
    # cycles one by one (about half of the 40-90 ms a 9000 x 9000 `vpr-smr attributes` took to exit); exit
    # handlers run as before.
    gc.freeze()
    sys.exit(status)


def _interrupt(signum: int, _frame: Any) -> None:
    raise KeyboardInterrupt


if __name__ == "__main__":
    run()
