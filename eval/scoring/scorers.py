"""The scorers of method §12, one entry each of the registry ``SCORERS``, in the order of the tables and figures.

A scorer is a ``Scorer`` record: its name, its kind (training-free, the oracle or the predictor), its colour in the
figures, its description in the report, the record of the baselines settings it reads (``Settings``: declared once,
as a matcher's or a backend's, ``core.settings``), and, for all but the predictor, the function computing its
confidence ``c_a`` of a split's evaluated queries from one signature (``Confidence``). Everything that lists scorers
(``baselines.query_scores``, the per-query table's ``c_<name>`` columns, the report's tables, figures and description)
reads the registry when it runs (``names``, ``entries``), so a new scorer is one more entry here, or one an installed
package registers through the entry point group ``vpr_smr.scorers`` (placed before ``random``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from importlib.metadata import entry_points
from typing import Any, Literal

import numpy as np

from vpr_smr.core.constants import DEFAULT_R_WINDOW, DEFAULT_SPREAD_K, candidates_needed, half_window
from vpr_smr.core.registry import Registry
from vpr_smr.core.settings import declared, group, setting
from vpr_smr.eval.matching.attributes import QueryFeatures
from vpr_smr.eval.matching.confidence import uniqueness

__all__ = [
    "DEFAULT_SETTINGS", "ENTRY_POINT_GROUP", "KINDS", "NATIVE", "NO_NATIVE", "ORACLE", "PREDICTOR", "RANDOM", "SCORERS",
    "BaselineSettings", "Confidence", "Scorer", "SpreadSettings", "UniquenessSettings", "colour", "entries", "names",
    "predictor_confidence", "random_scores", "registered", "scorer", "spread", "training_free", "uniqueness",
]

ENTRY_POINT_GROUP = "vpr_smr.scorers"

RANDOM, ORACLE, PREDICTOR, NATIVE = "random", "oracle", "predictor", "native"
# the one sentence for features that hold neither the matcher's native confidence nor the name of its scorer
NO_NATIVE = ("the attributes hold no native confidence of their matcher (sequence_native: a file written before it "
             "was stored, by a matcher that names no native_scorer)")
Kind = Literal["training-free", "oracle", "predictor"]
KINDS: tuple[Kind, ...] = ("training-free", "oracle", "predictor")


@dataclass(frozen=True)
class UniquenessSettings:
    """The settings of ``uniqueness``, ``single_uniqueness`` and ``native`` (which may be seqslam's uniqueness)."""

    r_window: int = setting(
        DEFAULT_R_WINDOW, "uniqueness (SeqSLAM's, OpenSeqSLAM2's rWindow): the smallest sequence distance outside "
        "|r - r*| <= r_window / 2 of the sequence match r*, over the match's; single_uniqueness the same on the "
        "query's own distance column (reference frames)", minimum=0)


@dataclass(frozen=True)
class SpreadSettings:
    """The settings of ``spread``."""

    spread_k: int = setting(
        DEFAULT_SPREAD_K, "spread: minus the standard deviation of the positions (frame indices, or the dataset's "
        "positions) of the spread_k end references of smallest sequence distance", minimum=1)


# the records the scorers declare, in the order of the configuration's `baselines` (dataclass fields of the bases
# come last base first)
SETTINGS_RECORDS = (UniquenessSettings, SpreadSettings)


@dataclass(frozen=True)
class BaselineSettings(SpreadSettings, UniquenessSettings):
    """Method §12: the scorers set beside the predictor (the training-free uniqueness, single_uniqueness, spread,
    distance, native and random, and the oracle); params of the attributes jobs (how many candidates each query
    keeps, ``candidates``: max(2 floor(r_window / 2) + 2, spread_k)) and of the baselines, metrics and queries jobs."""

    def __post_init__(self) -> None:
        candidates_needed(self.r_window, self.spread_k)  # a ValueError naming the bad setting

    @property
    def half_window(self) -> int:
        return half_window(self.r_window)

    @property
    def candidates(self) -> int:
        """The candidates per query an attributes file must hold (``core.constants.candidates_needed``)."""
        return candidates_needed(self.r_window, self.spread_k)

    def meta(self) -> dict[str, int]:
        """What an output records of the settings."""
        return {"r_window": int(self.r_window), "spread_k": int(self.spread_k)}


def baseline_settings() -> Any:
    """The field of a job's training-free scorers' settings (``BaselineSettings``)."""
    return group(BaselineSettings, "the training-free scorers' settings (method §12)")


DEFAULT_SETTINGS = BaselineSettings()  # the configuration's defaults (method §12: r_window 10, K 10)

# a scorer's c_a of a split's evaluated queries: the features (with their candidates), the settings, the reference
# positions ``spread`` measures (``baselines.spread_positions``) and the random seed
Confidence = Callable[[QueryFeatures, BaselineSettings, np.ndarray, int], np.ndarray]


@dataclass(frozen=True)
class Scorer:
    """One scorer of method §12. ``Settings`` is the record of the baselines settings it reads (one of
    ``SETTINGS_RECORDS``: the configuration's ``baselines`` holds their settings), None for none; ``confidence`` is
    None for the predictor only (its ``c_a`` comes from a trained model's probabilities, ``predictor_confidence``);
    ``description`` is the report's clause after ``name:``."""

    name: str
    kind: Kind
    colour: str  # a Matplotlib colour, the same in both baseline figures
    description: str
    Settings: type | None
    confidence: Confidence | None

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"scorer {self.name!r}: kind {self.kind!r} is none of {', '.join(KINDS)}")
        if (self.confidence is None) != (self.kind == "predictor"):
            raise ValueError(f"scorer {self.name!r}: every scorer but the predictor computes its own confidence")
        if not self.colour or not self.description:
            raise ValueError(f"scorer {self.name!r} needs a colour and a description")
        if self.Settings is not None and self.Settings not in SETTINGS_RECORDS:
            raise ValueError(f"scorer {self.name!r}: its Settings {self.Settings!r} is none of the baselines' "
                             f"records ({', '.join(r.__name__ for r in SETTINGS_RECORDS)}, in "
                             "vpr_smr.eval.scoring.scorers), whose settings the configuration's baselines holds; "
                             "declare one of them, or None")

    @property
    def settings(self) -> tuple[str, ...]:
        """The names of the baselines settings it reads."""
        return () if self.Settings is None else tuple(item.name for item in declared(self.Settings))


# --- the computations ------------------------------------------------------------------------------------------


def spread(references: np.ndarray, positions: np.ndarray, count: int) -> np.ndarray:
    """Per row, the population standard deviation of the positions of its first ``count`` references (as many as
    it has, when fewer): ``positions`` ``(R,)`` gives it directly, ``(R, d)`` as the root of the summed per-axis
    variances."""
    references = np.asarray(references)
    valid = references[:, :count] >= 0
    n = int(valid.sum(axis=1).min()) if len(references) else 0  # every query of a split has as many end references
    chosen = np.asarray(positions, dtype=np.float64)[references[:, :n]]
    # relative to the best one's: the spread does not change, and a frame index and a position that are the same
    # up to an offset (a split's frames, UTM metres) give the same bits
    chosen = chosen - chosen[:, :1]
    out: np.ndarray = (np.std(chosen, axis=1) if chosen.ndim == 2
                       else np.sqrt(np.var(chosen, axis=1).sum(axis=-1)))
    return out


def random_scores(n_queries: int, seed: int) -> np.ndarray:
    """A uniformly random order of the queries: ``numpy.random.default_rng(seed).permutation(n_queries)``."""
    return np.random.default_rng(seed).permutation(n_queries).astype(np.float64)


def predictor_confidence(probabilities: np.ndarray, classes: np.ndarray) -> np.ndarray:
    """``1 - P(class 1) - P(class 3)``: the predictor's probability that the sequence match is correct (a class
    the predictor was not trained on has probability 0)."""
    values = np.asarray(probabilities, dtype=np.float64)
    labels: list[int] = [int(c) for c in np.asarray(classes).tolist()]
    out = np.ones(len(values))
    for label in (1, 3):
        if label in labels:
            out = out - values[:, labels.index(label)]
    return out


# --- each scorer's confidence (``Confidence``): the features hold the candidates (``baselines.check_candidates``) -


def _sequence_uniqueness(features: QueryFeatures, settings: BaselineSettings, positions: np.ndarray,
                         seed: int) -> np.ndarray:
    assert features.sequence_candidates is not None and features.sequence_candidate_references is not None
    return uniqueness(features.sequence_candidates, features.sequence_candidate_references, settings.half_window)


def _single_uniqueness(features: QueryFeatures, settings: BaselineSettings, positions: np.ndarray,
                       seed: int) -> np.ndarray:
    assert features.single_candidates is not None and features.single_candidate_references is not None
    return uniqueness(features.single_candidates, features.single_candidate_references, settings.half_window)


def _spread(features: QueryFeatures, settings: BaselineSettings, positions: np.ndarray, seed: int) -> np.ndarray:
    assert features.sequence_candidate_references is not None
    return -spread(features.sequence_candidate_references, positions, settings.spread_k)


def _distance(features: QueryFeatures, settings: BaselineSettings, positions: np.ndarray, seed: int) -> np.ndarray:
    return -np.asarray(features.sequence_distance, dtype=np.float64)


def _native(features: QueryFeatures, settings: BaselineSettings, positions: np.ndarray, seed: int) -> np.ndarray:
    """The matcher's native confidence (method §14): its own numbers where the features hold them, else the §12
    scorer it names (seqslam's ``uniqueness``: the same numbers as that scorer's)."""
    if features.sequence_native is not None:
        return np.asarray(features.sequence_native, dtype=np.float64)
    named = features.native_scorer
    if named is None:
        raise ValueError(NO_NATIVE)
    found = scorer(named)
    if found.kind != "training-free" or found.name in (NATIVE, RANDOM) or found.confidence is None:
        allowed = ", ".join(n for n in training_free() if n not in (NATIVE, RANDOM))
        raise ValueError(f"the matcher's native_scorer {named!r} is no deterministic training-free scorer of "
                         f"method §12: name one of {allowed}")
    return found.confidence(features, settings, positions, seed)


def _random(features: QueryFeatures, settings: BaselineSettings, positions: np.ndarray, seed: int) -> np.ndarray:
    return random_scores(len(features.queries), seed)


def _oracle(features: QueryFeatures, settings: BaselineSettings, positions: np.ndarray, seed: int) -> np.ndarray:
    return np.asarray(features.sequence_correct, dtype=np.float64)


# --- the registry ----------------------------------------------------------------------------------------------

def _plugin(name: str, item: object) -> Scorer:
    """An installed package's scorer: a training-free ``Scorer`` of its entry point's name."""
    if not isinstance(item, Scorer) or item.name != name or item.kind != "training-free":
        given = f"the {item.kind} scorer {item.name!r}" if isinstance(item, Scorer) else repr(item)
        raise ValueError(f"the scorer entry point {name!r} (group {ENTRY_POINT_GROUP}) gives {given}: give a "
                         f"Scorer named {name!r} of kind training-free (vpr_smr.eval.scoring.scorers.Scorer)")
    return item


# every scorer, in the order of the tables; the predictor stands out in the figures, the oracle is a ceiling
SCORERS: Registry[Scorer] = Registry("scorer", ENTRY_POINT_GROUP, check=_plugin)
for _scorer in (
    Scorer("uniqueness", "training-free", "tab:blue",
           "SeqSLAM's, the smallest sequence distance outside a window around the match over the match's",
           UniquenessSettings, _sequence_uniqueness),
    Scorer("single_uniqueness", "training-free", "tab:cyan", "the same on the query's own distances",
           UniquenessSettings, _single_uniqueness),
    Scorer("spread", "training-free", "tab:olive", "minus the spread of the best end references", SpreadSettings,
           _spread),
    Scorer("distance", "training-free", "tab:gray",
           "minus the sequence distance (a threshold on it, which is what VPR+SM's curve already sweeps: about 0 by "
           "construction)", None, _distance),
    Scorer(NATIVE, "training-free", "tab:purple",
           "the matcher's own confidence, the rule its authors accept a match by (seqslam: the uniqueness above)",
           UniquenessSettings, _native),
    Scorer(RANDOM, "training-free", "tab:pink", "a random order", None, _random),
    Scorer(ORACLE, "oracle", "black", "the ground truth", None, _oracle),
    Scorer(PREDICTOR, "predictor", "tab:orange", "one minus the predictor's probabilities of classes 1 and 3", None,
           None),
):
    SCORERS.add(_scorer.name, _scorer)


def names() -> tuple[str, ...]:
    """Every registered scorer's name: the built-ins in their order, the installed packages' (sorted) before
    ``random``."""
    built_in = SCORERS.builtins()
    plugins = [name for name in SCORERS.names() if name not in built_in]
    at = built_in.index(RANDOM)
    return (*built_in[:at], *plugins, *built_in[at:])


def entries() -> tuple[Scorer, ...]:
    """Every registered scorer, in ``names``' order."""
    return tuple(SCORERS[name] for name in names())


def __getattr__(attribute: str) -> tuple[Scorer, ...]:
    # ``REGISTRY``, the tuple of every scorer that this module held before ``SCORERS``: its readers (the baselines'
    # scores, the report's description) get ``entries()``, plugins included
    if attribute == "REGISTRY":
        return entries()
    raise AttributeError(f"module {__name__!r} has no attribute {attribute!r}")


def registered() -> str:
    """What the jobs that compute every scorer depend on beyond their records (their rule param ``scorers``): the
    registered scorers' names in ``names``' order, an installed package's as ``name==version`` of the distribution
    that declares its entry point, e.g. ``uniqueness,...,native,my_scorer==1.2,random,oracle,predictor``. The same
    for every run of this version without plugins; installing, upgrading or removing a scorer plugin changes it, so
    that the workflow computes those jobs again (a file written before lacks the new scorer: a stale result)."""
    built_in = set(SCORERS.builtins())
    # the installed entry points as SCORERS reads them (the registry keeps their distributions to itself)
    versions = {point.name: _version(point) for point in entry_points(group=ENTRY_POINT_GROUP)}
    return ",".join(name if name in built_in else f"{name}=={versions.get(name, '?')}" for name in names())


def _version(point: Any) -> str:
    # an entry point read from an installed distribution knows it (importlib.metadata.EntryPoint.dist); one made by
    # hand (a test's) may not: "?"
    dist = getattr(point, "dist", None)
    version = getattr(dist, "version", None)
    return str(version) if version else "?"


def training_free() -> tuple[str, ...]:
    """The names of the training-free scorers (kind ``training-free``), in the registry's order."""
    return tuple(s.name for s in entries() if s.kind == "training-free")


def best_training_free(values: Mapping[str, float | None]) -> str | None:
    """The training-free scorer with the largest defined value among ``values`` (scorer name -> e.g. its reduction
    at the predictor's budget), the first in the registry's order on a tie; None when none is defined."""
    defined = [name for name in training_free() if values.get(name) is not None]
    return max(defined, key=lambda name: float(values[name] or 0.0), default=None)


def scorer(name: str) -> Scorer:
    """The registered scorer ``name``; a ValueError naming the registered ones when there is none."""
    found = SCORERS.get(name, None)
    if found is None:
        raise ValueError(f"no scorer {name!r} is registered (eval/scoring/scorers.py SCORERS has {', '.join(names())}"
                         f"; a package adds one through the entry point group {ENTRY_POINT_GROUP})")
    return found


def colour(name: str) -> str:
    """The figures' colour of the registered scorer ``name``."""
    return scorer(name).colour
