"""Small functions the Snakemake rules use to list files and build arguments (kept out of the rule files, as
Snakemake's lint asks); every path itself comes from ``core.paths``."""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from vpr_smr.core.paths import (
    attributes_path,
    descriptors_path,
    distances_path,
    matcher_attributes_path,
    matcher_predictor_paths,
    predictor_path,
    predictor_paths,
    queries_path,
    without_predictor_path,
)

if TYPE_CHECKING:
    from vpr_smr.eval.matching.matchers import MatcherSpec
    from vpr_smr.eval.report.job import RunFiles
    from vpr_smr.pipeline.config import Config
    from vpr_smr.pipeline.plan import Plan


@dataclass(frozen=True)
class RuleFiles:
    """Each core job's named input files for its wildcards (``dataset``, ``method``, ``seq_len``, ``split``), from
    ``core.paths``: its ``Job.inputs`` (``rule_files``), which its rule's ``input:`` lists and its job record reads,
    so that each path is written once and the record is computed from the wildcards alone."""

    out: str
    conf: Config
    plan: Plan

    def _attributes(self, wc: Mapping[str, str], split: str, methods: Sequence[str] | None = None) -> list[str]:
        """Every method's (or ``methods``') attributes of one split at ``wc["seq_len"]``, the configuration's order
        (the pooled training order)."""
        return [attributes_path(self.out, wc["dataset"], method, wc["seq_len"], split)
                for method in (list(self.conf.methods) if methods is None else methods)]

    def _method_attributes(self, wc: Mapping[str, str], splits: Sequence[str]) -> list[str]:
        """``wc["method"]``'s attributes of each of ``splits`` at ``wc["seq_len"]``."""
        return [attributes_path(self.out, wc["dataset"], wc["method"], wc["seq_len"], split) for split in splits]

    def _distances(self, wc: Mapping[str, str]) -> list[str]:
        """``wc["method"]``'s distances of each evaluation split."""
        return [distances_path(self.out, wc["dataset"], wc["method"], split) for split in self.conf.eval_splits]

    def distances(self, wc: Mapping[str, str]) -> dict[str, Any]:
        return dict(descriptors=descriptors_path(self.out, wc["dataset"], wc["method"]))

    def attributes(self, wc: Mapping[str, str]) -> dict[str, Any]:
        return dict(distances=distances_path(self.out, wc["dataset"], wc["method"], wc["split"]),
                    truth=ground_truth_input(self.plan, wc["dataset"]))

    def train(self, wc: Mapping[str, str]) -> dict[str, Any]:
        """The train split's attributes of every method, then those of each evaluation split, split by split."""
        return dict(train=self._attributes(wc, self.conf.train_split),
                    evaluate=[path for split in self.conf.eval_splits for path in self._attributes(wc, split)])

    def evaluate(self, wc: Mapping[str, str]) -> dict[str, Any]:
        return dict(attributes=self._method_attributes(wc, self.conf.eval_splits),
                    predictors=predictor_paths(self.out, wc["dataset"], wc["seq_len"], self.conf.seeds))

    def baselines(self, wc: Mapping[str, str]) -> dict[str, Any]:
        return dict(distances=self._distances(wc), attributes=self._method_attributes(wc, self.conf.eval_splits),
                    predictors=predictor_paths(self.out, wc["dataset"], wc["seq_len"], self.conf.seeds),
                    truth=ground_truth_input(self.plan, wc["dataset"]))

    def metrics(self, wc: Mapping[str, str]) -> dict[str, Any]:
        """The VPR metrics' and the per-query table's: as the baselines', with the seed-0 predictor only (the
        authors' recipe)."""
        return dict(distances=self._distances(wc), attributes=self._method_attributes(wc, self.conf.eval_splits),
                    predictor=predictor_path(self.out, wc["dataset"], wc["seq_len"]),
                    truth=ground_truth_input(self.plan, wc["dataset"]))

    def inspect(self, wc: Mapping[str, str]) -> dict[str, Any]:
        return dict(queries=queries_path(self.out, wc["dataset"], wc["method"], wc["seq_len"]),
                    distances=distances_path(self.out, wc["dataset"], wc["method"], self.conf.table_split),
                    truth=ground_truth_input(self.plan, wc["dataset"]))

    def attribute_ablation(self, wc: Mapping[str, str]) -> dict[str, Any]:
        """The train split's attributes of every method, then those of Table II's splits (the validation split and
        the last evaluation split), split by split."""
        from vpr_smr.eval.predictor.defaults import ablation_splits

        return dict(train=self._attributes(wc, self.conf.train_split),
                    evaluate=[path for split in ablation_splits(self.conf.eval_splits)
                              for path in self._attributes(wc, split)])

    def predictor_without(self, wc: Mapping[str, str]) -> dict[str, Any]:
        """The other methods' train split's attributes and their validation split's (none without one); the
        held-out method's files are not inputs, so that a change of them does not retrain this predictor."""
        from vpr_smr.eval.predictor.defaults import validation_split

        others = [method for method in self.conf.methods if method != wc["method"]]
        validation = validation_split(self.conf.eval_splits)
        return dict(train=self._attributes(wc, self.conf.train_split, others),
                    validation=self._attributes(wc, validation, others) if validation else [])

    def held_out(self, wc: Mapping[str, str]) -> dict[str, Any]:
        table = self.conf.table_split
        return dict(attributes=attributes_path(self.out, wc["dataset"], wc["method"], wc["seq_len"], table),
                    pooled=predictor_path(self.out, wc["dataset"], wc["seq_len"]),
                    without=without_predictor_path(self.out, wc["dataset"], wc["seq_len"], wc["method"]))


def rule_files(files: Callable[[RuleFiles, Mapping[str, str]], dict[str, Any]]
               ) -> Callable[[str, Config, Plan, Mapping[str, str]], dict[str, Any]]:
    """A job's ``inputs`` (``pipeline.experiment.Job``: of the run folder, the configuration, the plan and the
    wildcards) from a ``RuleFiles`` method: ``rule_files(RuleFiles.train)``."""
    return lambda out, conf, plan, wildcards: files(RuleFiles(out, conf, plan), wildcards)


def extraction_options(conf: Config) -> str:
    """The descriptors jobs' ``extraction`` options (those set; a job's resource, not a param)."""
    from vpr_smr.pipeline.options import flags

    return flags(conf.extraction)


def method_items(methods: Sequence[str], held_out: str, paths: Sequence[str]) -> list[str]:
    """``METHOD=PATH`` items (unquoted) for the methods but ``held_out``, in the configuration's order; none without
    ``paths`` (a run without a validation split: the predictor trained without a method scores none)."""
    if not paths:
        return []
    others = [method for method in methods if method != held_out]
    return [f"{method}={path}" for method, path in zip(others, paths, strict=True)]


def speed_profiles(conf: Config) -> list[str]:
    """The speed experiment's profiles by name (``eval.scoring.speed``: ``0.5x``, ``varying``), in the
    configuration's order: the names of its files and the ``profile`` wildcard's values."""
    from vpr_smr.eval.scoring.speed import profile_names

    return profile_names(conf.speed.profiles)


# What the report rule always gives the report besides the configuration's experiments: the standard VPR metrics
# (rule vpr_metrics) and the dataset cards (report_datasets).
REPORT_INPUTS = {"metrics", "datasets"}


def report_outputs(conf: Config, experiments: set[str], speed_datasets: list[str] | None = None,
                   sweep_datasets: list[str] | None = None) -> list[str]:
    """The report's files, relative to the run folder (``eval.report.registry.expected_outputs``); the speed
    experiment's figures for ``speed_datasets`` only and the protocol sweep's for ``sweep_datasets`` only (default:
    every dataset)."""
    from vpr_smr.eval.report.registry import expected_outputs

    return expected_outputs(list(conf.datasets), conf.seq_lens, conf.modes, experiments | REPORT_INPUTS,
                            table_seq_lens=[conf.table_seq_len], speed_datasets=speed_datasets,
                            sweep_datasets=sweep_datasets)


def report_files(given: Any) -> RunFiles:
    """The report rule's inputs, named as the settings of ``RunFiles`` (each a list of paths), as its record."""
    from vpr_smr.core.settings import declared
    from vpr_smr.eval.report.job import RunFiles

    return RunFiles(**{item.name: tuple(getattr(given, item.name)) for item in declared(RunFiles)})


def report_settings(settings: Mapping[str, Any]) -> str:
    """The configuration's settings (``Config.to_json``) minus what changes speed only (``extraction``) as JSON text:
    its sections in the schema's order, so that writing out a section at its defaults (``sequence_matching:
    {matcher: seqslam}``) changes nothing, and within them the configuration's own order (not sorted like
    ``plan.canonical``: the methods' order is the pooled training order, part of the predictor's recipe): shown in
    the report, a param of it."""
    from vpr_smr.pipeline.config import SCHEMA_PATH

    order = list(json.loads(SCHEMA_PATH.read_text())["properties"])
    keys = sorted((key for key in settings if key != "extraction"),
                  key=lambda key: order.index(key) if key in order else len(order))
    return json.dumps({key: settings[key] for key in keys}, separators=(",", ":"))


def report_datasets(plan: Plan) -> str:
    """The dataset cards (``plan.dataset_cards``) as JSON text in the configuration's order, the datasets and each
    one's splits as configured (not sorted like ``plan.canonical``: the report shows them in this order): the
    report's ``--datasets``, a param of it."""
    from vpr_smr.pipeline.plan import dataset_cards

    return json.dumps(dataset_cards(plan), separators=(",", ":"))


def ground_truth_input(plan: Plan, dataset: str) -> list[str]:
    """The dataset's ground-truth file (method §13) as an input of the jobs that score (none for a tolerance or a
    radius), so that a changed file scores again."""
    given = plan.datasets[dataset].ground_truth
    return [given.path] if given is not None else []




def length_files(splits: Sequence[tuple[str | None, Sequence[str]]]) -> dict[str, tuple[str, ...]]:
    """Each split's files (one per sequence length), the splits in the given order: a split named twice gets its
    files one after the other, a split of None (no validation split) or without files none."""
    out: dict[str, tuple[str, ...]] = {}
    for split, paths in splits:
        if split is not None and paths:
            out[split] = (*out.get(split, ()), *paths)
    return out


# --- the experiment ``matchers`` (method §14) ------------------------------------------------------------------


def compared_matchers(conf: Config) -> dict[str, MatcherSpec]:
    """The experiment ``matchers``' matchers by tag (``matcher_comparison.matcher_tag``), the configuration's order,
    and the fixed matcher (the validation warning's reference) after them when it is not one of them."""
    from vpr_smr.eval.scoring.matcher_comparison import fixed_matcher, matcher_tag

    specs = {matcher_tag(spec): spec for spec in conf.matchers}
    fixed = fixed_matcher()
    if fixed not in specs.values():
        specs[matcher_tag(fixed)] = fixed
    return specs


def own_matcher_tags(conf: Config) -> list[str]:
    """The tags of the compared matchers (and the fixed one) other than the run's own (``sequence_matching``),
    whose attributes and predictors the experiment computes under ``matchers/``: the ``tag`` wildcard's values."""
    return [tag for tag, spec in compared_matchers(conf).items() if spec != conf.sequence_matching]


def experiment_attributes(out: str, conf: Config, tag: str, dataset: str, method: str, seq_len: int | str,
                          split: str) -> str:
    """A compared matcher's attributes of one split: the run's own files for the run's matcher, else its own."""
    if compared_matchers(conf)[tag] == conf.sequence_matching:
        return attributes_path(out, dataset, method, seq_len, split)
    return matcher_attributes_path(out, dataset, tag, method, seq_len, split)


def experiment_predictors(out: str, conf: Config, tag: str, dataset: str, seq_len: int | str) -> list[str]:
    """A compared matcher's predictors, seed 0 first: the run's own for the run's matcher, else its own."""
    if compared_matchers(conf)[tag] == conf.sequence_matching:
        return predictor_paths(out, dataset, seq_len, conf.seeds)
    return matcher_predictor_paths(out, dataset, tag, seq_len, conf.seeds)


def adaptive_matchers(conf: Config, chosen: set[str]) -> dict[str, MatcherSpec]:
    """The experiment ``adaptive_seq_len``'s matchers by tag: the run's own (``sequence_matching``), then, with the
    experiment ``matchers`` on (``chosen``: ``config.experiments``), each matcher it compares, in its order."""
    from vpr_smr.eval.scoring.matcher_comparison import matcher_tag

    specs = {matcher_tag(conf.sequence_matching): conf.sequence_matching}
    if "matchers" in chosen:
        for spec in conf.matchers:
            specs.setdefault(matcher_tag(spec), spec)
    return specs


def adaptive_files(out: str, conf: Config, spec: MatcherSpec, tag: str, dataset: str, method: str, split: str
                   ) -> list[str]:
    """One matcher's attributes of ``method`` on ``split`` at every ``L`` of ``seq_lens``: the run's own files for
    the run's matcher, else the experiment ``matchers``' (``matcher_attributes_path``)."""
    if spec == conf.sequence_matching:
        return [attributes_path(out, dataset, method, seq_len, split) for seq_len in conf.seq_lens]
    return [matcher_attributes_path(out, dataset, tag, method, seq_len, split) for seq_len in conf.seq_lens]


def adaptive_predictors(out: str, conf: Config, spec: MatcherSpec, tag: str, dataset: str) -> list[str]:
    """One matcher's predictors at every ``L`` of ``seq_lens``, each length's seeds together, seed 0 first."""
    if spec == conf.sequence_matching:
        return [path for seq_len in conf.seq_lens for path in predictor_paths(out, dataset, seq_len, conf.seeds)]
    return [path for seq_len in conf.seq_lens
            for path in matcher_predictor_paths(out, dataset, tag, seq_len, conf.seeds)]


def experiment_inputs(out: str, conf: Config, dataset: str, method: str, seq_len: int | str) -> dict[str, Any]:
    """The experiment's ``--inputs`` of one method (``matcher_comparison.read_inputs``): per compared matcher its
    table and validation split's attributes of ``method`` and its predictors, and the fixed matcher's validation
    attributes (None without a validation split)."""
    from vpr_smr.eval.predictor.defaults import validation_split
    from vpr_smr.eval.scoring.matcher_comparison import fixed_matcher, matcher_tag

    validation = validation_split(conf.eval_splits)
    splits = [conf.table_split] + ([validation] if validation else [])
    specs = compared_matchers(conf)

    def files(tag: str, among: list[str]) -> dict[str, dict[str, str]]:
        return {split: {method: experiment_attributes(out, conf, tag, dataset, method, seq_len, split)}
                for split in among}

    compared = [{"matcher": specs[matcher_tag(spec)].provenance(), "attributes": files(matcher_tag(spec), splits),
                 "predictors": experiment_predictors(out, conf, matcher_tag(spec), dataset, seq_len)}
                for spec in conf.matchers]
    fixed = matcher_tag(fixed_matcher())
    return {"matchers": compared, "fixed": None if validation is None else {
        "matcher": specs[fixed].provenance(), "attributes": files(fixed, [validation])}}


def experiment_files(inputs: Mapping[str, Any]) -> list[str]:
    """Every file of ``experiment_inputs``, each once: the experiment job's input."""
    entries = [*inputs["matchers"], *([inputs["fixed"]] if inputs["fixed"] else [])]
    found = [path for entry in entries for paths in entry["attributes"].values() for path in paths.values()]
    found += [path for entry in inputs["matchers"] for path in entry["predictors"]]
    return list(dict.fromkeys(found))
