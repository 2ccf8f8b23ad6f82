"""The stages of the predictor (``pipeline.stage.Stage``): ``train``, ``evaluate`` and the ablations ``ablation
attributes``, ``ablation without`` and ``ablation held-out``; their summary lines, and their workflow jobs (``JOBS``:
each one's output, inputs and record, of which ``pipeline/rules/jobs.smk`` makes its rule)."""

from __future__ import annotations

import argparse
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

from vpr_smr.core.paths import (
    attribute_ablation_path,
    evaluation_path,
    held_out_path,
    predictor_path,
    predictor_paths,
    predictor_report_path,
    timing_path,
    without_predictor_path,
)
from vpr_smr.eval.predictor.defaults import PredictorParams, PredictorTraining, ablation_splits, validation_split
from vpr_smr.eval.predictor.jobs import AttributeAblationJob, EvaluateJob, HeldOutJob, TrainJob, WithoutJob
from vpr_smr.eval.predictor.records import AttributeAblation, PredictorReport
from vpr_smr.eval.scoring.records import Evaluation, HeldOut, Reduction, Timing
from vpr_smr.pipeline.config import Config, ConfigError, experiments
from vpr_smr.pipeline.experiment import Job, relative
from vpr_smr.pipeline.rule_helpers import RuleFiles, method_items, rule_files
from vpr_smr.pipeline.stage import GROUP, Stage, wrote

if TYPE_CHECKING:
    from vpr_smr.pipeline.plan import Plan

__all__ = ["ABLATION_ATTRIBUTES", "ABLATION_HELD_OUT", "ABLATION_WITHOUT", "EVALUATE", "JOBS", "STAGES", "TRAIN",
           "ablation_headline", "held_out_headline", "reduction_text", "split_files", "training"]



def reduction_text(reduction: Reduction) -> str:
    """A ``records.Reduction`` as a summary line says it: ``40.00 % [20.00, 55.00] improved``, the word earned by
    its interval (``curves.earned``); an undefined one with its reason, and a from-zero one with the interval of the
    AOC difference that judged it: ``n/a (worse than a perfect baseline, AOC difference [+0.0004, +0.0021])``."""
    from vpr_smr.eval.report import outcome_words as words
    from vpr_smr.eval.report.bounds import bracket
    from vpr_smr.eval.scoring.curves import earned

    word = words.said(earned(reduction.outcome, reduction.reduction_pct_ci))
    if reduction.reduction_pct is None:
        difference = reduction.aoc_difference_ci
        return f"n/a ({word})" if difference is None else f"n/a ({word}, {words.difference_words(difference)})"
    return f"{reduction.reduction_pct:.2f} % {bracket(reduction.reduction_pct_ci, '.2f')} {word}"


def ablation_headline(table: AttributeAblation) -> str:
    """Table II's headline (``records.AttributeAblation``): the macro F1 of the predictor on all four attributes,
    cross-validated and on each evaluation split."""
    from vpr_smr.eval.predictor.ablation import ALL_ATTRIBUTES

    every = table.attributes[ALL_ATTRIBUTES]
    return "; ".join([f"macro F1 with all four attributes: cross-validated {every.f1_cv:.3f}",
                      *(f"{name} {split.f1:.3f}" for name, split in every.splits.items())])


def held_out_headline(result: HeldOut, method: str) -> str:
    """The held-out headline (``records.HeldOut``): per mode the AOC reduction of the predictor trained without
    ``method``, then the pooled one's, each with its interval and earned word (``reduction_text``)."""
    return "; ".join(f"{mode} mode: AOC reduction without {method} {reduction_text(without.reduction)}, pooled "
                     f"{reduction_text(result.pooled.modes[mode].reduction)}"
                     for mode, without in result.without.modes.items())


def _macro_f1(report: PredictorReport) -> str:
    from vpr_smr.eval.predictor.train import cv_text, split_f1s

    first = report.seeds[0]  # the predictor file's seed
    return f"macro F1: {cv_text(first)}{split_f1s(first)}"


def _train_summary(job: TrainJob, report: PredictorReport) -> str:
    return wrote("the predictor", job.out, _macro_f1(report))


def _evaluate_summary(job: EvaluateJob, result: tuple[Evaluation, Timing]) -> str:
    evaluation, _ = result
    return wrote(f"the evaluation of {job.method}", job.out, "; ".join(
        f"{name}: the seed-{split.seed} predictor removes {split.removed} of {split.n_queries} matches, macro F1 "
        f"{split.f1_macro:.3f}" for name, split in evaluation.splits.items()))


def _attributes_summary(job: AttributeAblationJob, table: AttributeAblation) -> str:
    return wrote("the attribute ablation (Table II)", job.out, ablation_headline(table))


def _without_summary(job: WithoutJob, report: PredictorReport) -> str:
    return wrote(f"the predictor without {job.method}", job.out, _macro_f1(report))


def _held_out_summary(job: HeldOutJob, result: HeldOut) -> str:
    return wrote(f"{job.method}'s test split under the pooled and the without predictor", job.out,
                  held_out_headline(result, job.method))


# --- the options of an earlier version, and the items' messages --------------------------------------------------

# ``--val`` and ``--test`` of train and the ablations, before the splits took the configuration's names
OLD_SPLIT_OPTIONS = ("--val", "--test")


def _old_split_options(parser: argparse.ArgumentParser) -> None:
    """``--val``/``--test``, hidden: given, they fail with what replaced them (``_check_splits``)."""
    for option in OLD_SPLIT_OPTIONS:
        parser.add_argument(option, nargs="*", dest=f"old_{option[2:]}", help=argparse.SUPPRESS)


def _given(args: argparse.Namespace, name: str) -> Any:
    """The words of the job record's setting ``name`` on the command line (``pipeline.options``' dest), or None."""
    return vars(args).get(f"{GROUP}:{name}")


def _check_pairs(args: argparse.Namespace, name: str, item: str) -> None:
    """The ``item`` (e.g. ``SPLIT=PATH``) words of the setting ``name``, each with its ``=``."""
    words = _given(args, name) or []
    bad = [word for word in words if "=" not in word]
    if bad:
        raise ValueError(f"--{name} takes {item} items, got {', '.join(bad)}")


def _check_splits(args: argparse.Namespace) -> None:
    """The removed ``--val``/``--test`` fail with what replaced them; each ``--evaluate SPLIT ITEM...`` names its
    split once, with its items."""
    old = [option for option in OLD_SPLIT_OPTIONS if getattr(args, f"old_{option[2:]}", None) is not None]
    if old:
        raise ConfigError(f"{' and '.join(old)}: removed; the splits take the configuration's names now: give each "
                          "evaluation split as --evaluate SPLIT FILE..., e.g. --evaluate val a.h5 b.h5 --evaluate "
                          "test c.h5 d.h5 (or --evaluate check ... --evaluate final ...)")
    seen: set[str] = set()
    for name, *items in _given(args, "evaluate") or []:
        if not items:
            raise ConfigError(f"--evaluate {name}: give the split's name, then its files")
        if name in seen:
            raise ConfigError(f"--evaluate {name}: the split is given twice; give all its files after one --evaluate")
        seen.add(name)


def _check_without(args: argparse.Namespace) -> None:
    _check_splits(args)
    _check_pairs(args, "train", "METHOD=PATH")


def training(conf: Config, validation: bool = True) -> PredictorTraining:
    """How the workflow of ``conf`` trains its predictors (the rules' ``training`` group): the configuration's
    predictor settings, its validation split (``validation``; else the first evaluation split a job is given) and
    its ``allow_split_overlap``."""
    return PredictorTraining(PredictorParams.of(conf.predictor.to_json(), "predictor"),
                             validation_split(conf.eval_splits) if validation else None, conf.allow_split_overlap)


def split_files(splits: Sequence[str], items: Sequence[str]) -> dict[str, tuple[str, ...]]:
    """Each split's items, by its name (a rule's ``evaluate`` setting): ``items`` holds each split's items in turn,
    as many for every split (``rule_helpers.RuleFiles.train``); empty without splits or items."""
    if not splits or not items:
        return {}
    per_split, rest = divmod(len(items), len(splits))
    if rest:
        raise ValueError(f"{len(items)} files for {len(splits)} splits: not as many for each")
    return {split: tuple(items[i * per_split:(i + 1) * per_split]) for i, split in enumerate(splits)}


# The work of each stage, imported when it runs: scikit-learn is no import of the command line's.


def _train(job: TrainJob) -> PredictorReport:
    from vpr_smr.eval.predictor import train

    return train.main(job)


def _evaluate(job: EvaluateJob) -> tuple[Evaluation, Timing]:
    from vpr_smr.eval.scoring import evaluate

    return evaluate.main(job)


def _ablation_attributes(job: AttributeAblationJob) -> AttributeAblation:
    from vpr_smr.eval.predictor import ablation

    return ablation.attributes_main(job)


def _ablation_without(job: WithoutJob) -> PredictorReport:
    from vpr_smr.eval.predictor import ablation

    return ablation.train_without(job)


def _held_out(job: HeldOutJob) -> HeldOut:
    from vpr_smr.eval.scoring import held_out

    return held_out.main(job)


TRAIN = Stage("train", "train the predictor on the pooled train attributes of every method", TrainJob, _train,
              summary=_train_summary, legacy=_old_split_options, check=_check_splits)
EVALUATE = Stage("evaluate", "match removal and precision-recall of one method", EvaluateJob, _evaluate,
                 summary=_evaluate_summary,
                 check=lambda args: _check_pairs(args, "attributes", "SPLIT=PATH"))
ABLATION_ATTRIBUTES = Stage("ablation attributes", "Table II: a predictor on each attribute alone and on all four",
                            AttributeAblationJob, _ablation_attributes, summary=_attributes_summary,
                            legacy=_old_split_options, check=_check_splits)
ABLATION_WITHOUT = Stage("ablation without", "train a predictor on every method's train split but one", WithoutJob,
                         _ablation_without, summary=_without_summary, legacy=_old_split_options,
                         check=_check_without)
ABLATION_HELD_OUT = Stage("ablation held-out", "a method's test split under the pooled and the without_ predictor",
                          HeldOutJob, _held_out, summary=_held_out_summary)

STAGES: tuple[Stage, ...] = (TRAIN, EVALUATE, ABLATION_ATTRIBUTES, ABLATION_WITHOUT, ABLATION_HELD_OUT)


# --- the workflow's jobs of these stages (``pipeline/rules/jobs.smk`` makes a rule of each) --------------------------


def _train_record(conf: Config, plan: Plan, wildcards: Mapping[str, str], files: Mapping[str, Any], out: str
                  ) -> TrainJob:
    """Method §7: the predictor's settings, the validation split, the seeds, every evaluation split by its name with
    every method's attributes of it."""
    return TrainJob(wildcards["dataset"], int(wildcards["seq_len"]), tuple(files["train"]),
                    split_files(conf.eval_splits, files["evaluate"]), training(conf), conf.seeds, out)


def _train_outputs(out: str, conf: Config) -> dict[str, str | Sequence[str]]:
    """Every seed's predictor (seed 0's first: the job's output) and the training report beside the first."""
    return {"models": predictor_paths(out, "{dataset}", "{seq_len}", conf.seeds),
            "report": predictor_report_path(predictor_path(out, "{dataset}", "{seq_len}"))}


def _evaluate_record(conf: Config, plan: Plan, wildcards: Mapping[str, str], files: Mapping[str, Any], out: str
                     ) -> EvaluateJob:
    """Methods §§7-9: each evaluation split's attributes by its name, the seeds' predictors, the modes, and the trust
    levels and restoration where the configuration's experiments ask them."""
    chosen = experiments(conf)
    return EvaluateJob(wildcards["dataset"], wildcards["method"], int(wildcards["seq_len"]),
                       dict(zip(conf.eval_splits, files["attributes"], strict=True)), tuple(files["predictors"]),
                       tuple(conf.modes), tuple(conf.trust_levels) if "trust_levels" in chosen else (),
                       "restoration" in chosen, conf.allow_split_overlap, out)


def _evaluate_outputs(out: str, conf: Config) -> dict[str, str | Sequence[str]]:
    """The evaluation and its timings beside it."""
    evaluation = evaluation_path(out, "{dataset}", "{method}", "{seq_len}")
    return {"evaluation": evaluation, "timing": timing_path(evaluation)}


def _attribute_ablation_record(conf: Config, plan: Plan, wildcards: Mapping[str, str], files: Mapping[str, Any],
                               out: str) -> AttributeAblationJob:
    """The predictor's settings, Table II's splits (the validation split, then the last evaluation split) by name
    with every method's attributes."""
    return AttributeAblationJob(wildcards["dataset"], int(wildcards["seq_len"]), training(conf).predictor,
                                tuple(files["train"]), split_files(ablation_splits(conf.eval_splits),
                                                                   files["evaluate"]),
                                conf.allow_split_overlap, out)


def _without_record(conf: Config, plan: Plan, wildcards: Mapping[str, str], files: Mapping[str, Any], out: str
                    ) -> WithoutJob:
    """The other methods' train files by method, the validation split's METHOD=PATH items, the predictor's settings
    (its validation split: the first evaluation split given, the only one)."""
    method, validation = wildcards["method"], validation_split(conf.eval_splits)
    return WithoutJob(wildcards["dataset"], int(wildcards["seq_len"]), method,
                      dict(zip([m for m in conf.methods if m != method], files["train"], strict=True)),
                      split_files([validation] if validation else [],
                                  method_items(list(conf.methods), method, files["validation"])),
                      training(conf, validation=False), out)


def _held_out_record(conf: Config, plan: Plan, wildcards: Mapping[str, str], files: Mapping[str, Any], out: str
                     ) -> HeldOutJob:
    """The held-out method's table split under the pooled and the without predictor."""
    return HeldOutJob(wildcards["dataset"], wildcards["method"], int(wildcards["seq_len"]), files["attributes"],
                      files["pooled"], files["without"], tuple(conf.modes), conf.allow_split_overlap, out)


# The predictor: trained on the pooled train split of every method (the train split's attributes of every method in
# the configuration's order, then every evaluation split's), and scored per method (its attributes of every
# evaluation split, every seed's predictor); their files' layout: a run of an earlier one trains and scores again.
TRAIN_JOB = Job(TRAIN, relative(predictor_path("", "{dataset}", "{seq_len}")), rule_files(RuleFiles.train),
                _train_record, named=_train_outputs, layout=True, rule="train")
EVALUATE_JOB = Job(EVALUATE, relative(evaluation_path("", "{dataset}", "{method}", "{seq_len}")),
                   rule_files(RuleFiles.evaluate), _evaluate_record, named=_evaluate_outputs, rule="evaluate")
# The paper's ablations (at the Table I sequence length): Table II (every method's train split, Table II's two
# splits), the predictor trained without a method (the other methods' train and validation splits: the held-out
# method's files are no inputs, so that a change of them does not retrain it), and the held-out method's table split
# under the pooled predictor and that one.
ATTRIBUTE_ABLATION_JOB = Job(ABLATION_ATTRIBUTES, relative(attribute_ablation_path("", "{dataset}", "{seq_len}")),
                             rule_files(RuleFiles.attribute_ablation), _attribute_ablation_record, layout=True,
                             rule="attribute_ablation")
WITHOUT_JOB = Job(ABLATION_WITHOUT, relative(without_predictor_path("", "{dataset}", "{seq_len}", "{method}")),
                  rule_files(RuleFiles.predictor_without), _without_record, layout=True, rule="predictor_without")
HELD_OUT_JOB = Job(ABLATION_HELD_OUT, relative(held_out_path("", "{dataset}", "{seq_len}", "{method}")),
                   rule_files(RuleFiles.held_out), _held_out_record, rule="held_out")

JOBS: tuple[Job, ...] = (TRAIN_JOB, EVALUATE_JOB, ATTRIBUTE_ABLATION_JOB, WITHOUT_JOB, HELD_OUT_JOB)
