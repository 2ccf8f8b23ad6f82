"""The job records of the studies beyond Table I (``pipeline.stages.studies``): ``speed`` (``SpeedJob``, and the
configuration's ``SpeedExperiment``), ``compare-matchers`` (``MatchersJob``, its ``--inputs`` as ``ComparedInputs``)
and ``adaptive`` (``AdaptiveJob``), each one typed record of its settings, inputs and output (``core.settings``).

They live apart from the work (``eval.scoring.speed``, ``matcher_comparison``, ``adaptive``, which re-export them):
the command line declares every stage when it starts and the configuration reads ``SpeedExperiment``, and the work's
modules import their scoring and figures' records (about 20 ms), which a command that runs no study must not pay
for. It imports settings records only (``scorers.BaselineSettings`` comes with ``scorers``, which the configuration
imports anyway).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from vpr_smr.core.constants import DEFAULT_TOLERANCE
from vpr_smr.core.json_objects import json_object
from vpr_smr.core.settings import REQUIRED, setting
from vpr_smr.eval.matching import sources
from vpr_smr.eval.matching.matchers import MatcherSpec
from vpr_smr.eval.matching.sources import TruthSource
from vpr_smr.eval.predictor.defaults import PredictorParams, allow_split_overlap, predictor_setting
from vpr_smr.eval.predictor.jobs import dataset_name, metric_modes
from vpr_smr.eval.scoring.scorers import BaselineSettings, baseline_settings

__all__ = ["PROFILE_HELP", "VARYING", "VARYING_AMPLITUDE", "VARYING_PERIOD", "AdaptiveJob", "ComparedInputs",
           "MatcherInputs", "MatchersJob", "SpeedExperiment", "SpeedJob", "read_inputs", "velocities"]

Json = dict[str, Any]

# --- speed (method §11) -----------------------------------------------------------------------------------------------

VARYING = "varying"
VARYING_AMPLITUDE = 0.5  # s(t) = 1 + 0.5 sin(2 pi t / 200): between 0.5x and 1.5x, mean 1 over whole periods
VARYING_PERIOD = 200  # query frames per period
PROFILE_HELP = "a constant speed such as 0.5x, 1x or 2x (places per query frame, > 0), or 'varying'"


def velocities() -> Any:
    """The field of the velocity matcher's search set: the one declaration of the configuration's
    ``speed.velocities`` and of the stage's ``--velocities``."""
    return setting(
        (0.5, 0.595, 0.707, 0.841, 1.0, 1.189, 1.414, 1.682, 2.0),
        "the velocity matcher's search set (reference frames per query frame; the fixed matcher is [1.0]): 2**(k/4) "
        "for k = -4..4, rounded to 3 decimals. Log-spaced, so it covers the profiles' range 0.5x-2x evenly in ratio, "
        "and it holds 0.5, 1, 2 but not 0.75, 1.25 or 1.5, nor the varying profile's speeds: most profiles are "
        "matched by a nearby slope, not an exact one, as a real robot's speed would be",
        exclusive_minimum=0, min_items=1, unique=True, metavar="V")


@dataclass(frozen=True)
class SpeedExperiment:
    """The speed experiment (method §11, eval/scoring/speed.py): each dataset's train and table splits re-driven at
    other speeds, scored with the fixed matcher and with velocity search, a seed-0 predictor per matcher."""

    profiles: tuple[float | str, ...] = setting(
        (0.5, 0.75, 1.0, 1.25, 1.5, 2.0, VARYING),
        f"query speeds: a constant c (places per query frame: the query driven c times as fast; 1.0 is the aligned "
        f"pair, the reference point) or \"{VARYING}\" (1 + {VARYING_AMPLITUDE:g} sin(2 pi t / {VARYING_PERIOD}), "
        f"between {1 - VARYING_AMPLITUDE:g}x and {1 + VARYING_AMPLITUDE:g}x)",
        schema={"type": "array", "items": {"anyOf": [{"type": "number", "exclusiveMinimum": 0}, {"const": VARYING}]},
                "minItems": 1, "uniqueItems": True})
    velocities: tuple[float, ...] = velocities()


@dataclass(frozen=True)
class SpeedJob:
    """The ``speed`` stage's job: one dataset under one speed profile (``main``)."""

    dataset: str = dataset_name()
    seq_len: int = sources.seq_len()
    profile: str = setting(REQUIRED, PROFILE_HELP, metavar="PROFILE")
    velocities: tuple[float, ...] = velocities()
    tolerance: int = setting(DEFAULT_TOLERANCE, "a match within this many places of the simulated query's position "
                                                "is correct", minimum=0)
    train: dict[str, str] = setting(REQUIRED, "each method's train split distances (.h5), in the pooled training "
                                              "order", metavar="METHOD=PATH")
    table: dict[str, str] = setting(REQUIRED, "each method's table split distances (.h5), the same methods in the "
                                              "same order (--test: the same option)", metavar="METHOD=PATH",
                                              aliases=("test",))
    predictor: PredictorParams = predictor_setting()
    allow_split_overlap: bool = allow_split_overlap()
    out: str = setting(REQUIRED, "the output file: the speed experiment's result (JSON)", metavar="PATH")


# --- compare-matchers (method §14) ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class MatcherInputs:
    """One compared matcher's files: its spec, its attributes per split and method, its predictors (seed 0
    first)."""

    spec: MatcherSpec
    attributes: dict[str, dict[str, str]]  # split -> method -> path
    predictors: tuple[str, ...]

    def to_json(self) -> Json:
        """The entry as ``read_inputs`` reads it back (no ``predictors`` where there are none: the fixed one's)."""
        return {"matcher": self.spec.provenance(),
                "attributes": {split: dict(paths) for split, paths in self.attributes.items()},
                **({"predictors": list(self.predictors)} if self.predictors else {})}


def read_inputs(data: Mapping[str, Any]) -> tuple[list[MatcherInputs], MatcherInputs | None]:
    """The stage's ``--inputs`` JSON: ``{"matchers": [{"matcher": {...provenance}, "attributes": {split: {method:
    path}}, "predictors": [...]}, ...], "fixed": {...the same, no predictors} or null}``; ValueError naming the
    entry."""
    def one(entry: Any, where: str) -> MatcherInputs:
        if not isinstance(entry, Mapping) or not isinstance(entry.get("attributes"), Mapping):
            raise ValueError(f"--inputs {where}: {entry!r} has no \"attributes\" object")
        spec = MatcherSpec.from_provenance(entry.get("matcher"), f"--inputs {where}")
        attributes = {str(split): {str(m): str(p) for m, p in paths.items()}
                      for split, paths in entry["attributes"].items()}
        return MatcherInputs(spec, attributes, tuple(str(p) for p in entry.get("predictors", ())))

    found = data.get("matchers")
    if not isinstance(found, list) or not found:
        raise ValueError("--inputs: \"matchers\" must be a non-empty list of the compared matchers' files")
    fixed = data.get("fixed")
    return ([one(entry, f"matchers[{i}]") for i, entry in enumerate(found)],
            None if fixed is None else one(fixed, "fixed"))


@dataclass(frozen=True)
class ComparedInputs:
    """The stage's ``inputs`` setting (a value class of ``core.settings``): the compared matchers' files and the
    fixed matcher's validation attributes (None: no validation warning), as ``read_inputs`` reads them; on the
    command line its JSON text (or ``@file``)."""

    matchers: tuple[MatcherInputs, ...]
    fixed: MatcherInputs | None = None

    @classmethod
    def from_setting(cls, value: Any, where: str) -> ComparedInputs:
        compared, fixed = read_inputs(json_object(value, where))
        return cls(tuple(compared), fixed)

    def to_setting(self) -> Json:
        return {"matchers": [entry.to_json() for entry in self.matchers],
                "fixed": None if self.fixed is None else self.fixed.to_json()}


@dataclass(frozen=True)
class MatchersJob:
    """The ``compare-matchers`` stage's job: the experiment ``matchers`` of one dataset and method (``main``)."""

    dataset: str = dataset_name()
    method: str = setting(REQUIRED, "the method's name (a key of the configuration's methods)", metavar="NAME")
    seq_len: int = sources.seq_len()
    inputs: ComparedInputs = setting(
        REQUIRED, "the compared matchers' files as a JSON object (or @file): {\"matchers\": [{\"matcher\": "
                  "{\"name\": ..., \"settings\": {...}}, \"attributes\": {SPLIT: {METHOD: PATH}}, "
                  "\"predictors\": [seed 0 first]}, ...], \"fixed\": the fixed matcher's validation attributes or "
                  "null}", metavar="JSON")
    distances: dict[str, str] = setting(REQUIRED, "the method's table split distances (.h5): the ground truth's "
                                                  "reference positions", metavar="METHOD=PATH")
    split: str = setting(REQUIRED, "the table split (a split of --inputs' attributes)", metavar="SPLIT")
    validation: str | None = setting(None, "the validation split: the warning of a matcher far below the fixed one",
                                     metavar="SPLIT")
    truth: TruthSource = sources.truth()  # as the attributes were computed
    baselines: BaselineSettings = baseline_settings()
    modes: tuple[str, ...] = metric_modes()
    allow_split_overlap: bool = allow_split_overlap()
    out: str = setting(REQUIRED, "the output file: the matchers experiment's result (JSON)", metavar="PATH")


# --- adaptive (method §15) --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class AdaptiveJob:
    """The ``adaptive`` stage's job: the experiment adaptive_seq_len of one dataset, matcher and method (``main``)."""

    attributes: dict[str, tuple[str, ...]] = setting(
        REQUIRED, "the attributes files (vpr-smr attributes) of every sequence length, per split: the table "
                  "split's, and the validation split's for adaptive_uniqueness; each file records its length. "
                  "--attributes SPLIT PATH... per split, or SPLIT=PATH items", metavar="SPLIT PATH")
    predictors: tuple[str, ...] = setting(
        REQUIRED, "one predictor per length, its seed-0 file (vpr-smr train); the other seeds' files beside it "
                  "(L4.seed1.h5, ...) are read too", metavar="PATH", min_items=1)
    seeds: int | None = setting(None, "the seeds to read per length; none: every seed file found", minimum=1)
    split: str = setting(REQUIRED, "the split to score (the table split)", metavar="SPLIT")
    validation: str | None = setting(None, "the validation split: adaptive_uniqueness's threshold is chosen there",
                                     metavar="SPLIT")
    distances: str | None = setting(None, "the table split's distance file: the live matcher's time per query "
                                          "(none without it)", metavar="PATH")
    dataset: str = setting("dataset", "the dataset's name in the result", metavar="NAME")
    method: str = setting("method", "the method's name in the result", metavar="NAME")
    matcher_tag: str | None = setting(None, "the matcher's name in the result; none: its registry name",
                                      metavar="TAG")
    baselines: BaselineSettings = baseline_settings()
    modes: tuple[str, ...] = metric_modes()
    allow_split_overlap: bool = allow_split_overlap()
    out: str = setting(REQUIRED, "the output file: the adaptive sequence length's result (JSON; its timing goes "
                                 "beside it)", metavar="PATH")
