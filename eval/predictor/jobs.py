"""The jobs of the predictor's stages (``core.settings`` records; ``pipeline.stages.predictor``): ``train``
(``TrainJob``), ``evaluate`` (``EvaluateJob``), ``ablation attributes`` (``AttributeAblationJob``), ``ablation
without`` (``WithoutJob``) and ``ablation held-out`` (``HeldOutJob``). They live in a module without scikit-learn, as
``defaults`` does, so that building the command line stays fast; the modules that do the work (``train``,
``ablation``, ``scoring.evaluate``, ``scoring.held_out``) name them too."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from vpr_smr.core.constants import DEFAULT_TRUST_LEVELS, MODES
from vpr_smr.core.settings import REQUIRED, group, setting
from vpr_smr.eval.matching import sources
from vpr_smr.eval.predictor.defaults import PredictorParams, PredictorTraining, allow_split_overlap, predictor_setting

__all__ = ["AttributeAblationJob", "EvaluateJob", "HeldOutJob", "TrainJob", "WithoutJob", "dataset_name",
           "metric_modes"]


def dataset_name() -> Any:
    """The field of a job's dataset name (the one declaration of these stages' ``--dataset``)."""
    return setting(REQUIRED, "the dataset's name (a key of the configuration's datasets)", metavar="NAME")


@dataclass(frozen=True)
class TrainJob:
    """The ``train`` stage's job: one predictor per seed on the pooled train split of every method (method §7)."""

    dataset: str = dataset_name()
    seq_len: int = sources.seq_len()
    train: tuple[str, ...] = setting(REQUIRED, "every method's train-split attributes (.h5), pooled in this order",
                                     min_items=1, metavar="PATH")
    evaluate: dict[str, tuple[str, ...]] | None = setting(
        None, "an evaluation split by its name (the configuration's, e.g. val or check) and every method's "
              "attributes of it (.h5): the predictor's macro F1 on them; repeat it for each split, e.g. --evaluate "
              "val a_val.h5 b_val.h5 --evaluate test a_test.h5 b_test.h5", metavar="SPLIT PATH")
    training: PredictorTraining = group(PredictorTraining, "how the predictor is trained and judged")
    seeds: int = setting(1, "train seeds 0..N-1 (seed 0: the authors' recipe)", minimum=1)
    out: str = setting(REQUIRED, "the seed-0 predictor (.h5); other seeds beside it", metavar="PATH")

    @property
    def splits(self) -> dict[str, tuple[str, ...]]:
        """The evaluation splits by name, each with its files (none: no evaluation split)."""
        return dict(self.evaluate or {})


@dataclass(frozen=True)
class AttributeAblationJob:
    """The ``ablation attributes`` stage's job: Table II of one dataset and sequence length."""

    dataset: str = dataset_name()
    seq_len: int = sources.seq_len()
    predictor: PredictorParams = predictor_setting()
    train: tuple[str, ...] = setting(REQUIRED, "every method's train-split attributes (.h5), pooled in this order",
                                     min_items=1, metavar="PATH")
    evaluate: dict[str, tuple[str, ...]] | None = setting(
        None, "an evaluation split by its name (the configuration's, e.g. val or check) and every method's "
              "attributes of it (.h5): the validation split first, then the last evaluation split (Table II's two); "
              "repeat it for each split, e.g. --evaluate val a_val.h5 b_val.h5 --evaluate test a_test.h5 b_test.h5",
        metavar="SPLIT PATH")
    allow_split_overlap: bool = allow_split_overlap()
    out: str = setting(REQUIRED, "the output file: the attribute ablation (JSON)", metavar="PATH")


@dataclass(frozen=True)
class WithoutJob:
    """The ``ablation without`` stage's job: the predictor trained on every method's train split but one."""

    dataset: str = dataset_name()
    seq_len: int = sources.seq_len()
    method: str = setting(REQUIRED, "the held-out method's name (a key of the configuration's methods)",
                          metavar="NAME")
    train: dict[str, str] = setting(REQUIRED, "the other methods' train-split attributes (.h5), in the "
                                              "configuration's order (--method's, if given, is never read)",
                                    metavar="METHOD=PATH")
    evaluate: dict[str, tuple[str, ...]] | None = setting(
        None, "an evaluation split by its name (the configuration's, e.g. val or check) and each method's "
              "attributes of it (.h5) as METHOD=PATH; repeat it for each split, e.g. --evaluate val a=a_val.h5 "
              "b=b_val.h5 --evaluate test a=a_test.h5 b=b_test.h5", metavar="SPLIT METHOD=PATH")
    training: PredictorTraining = group(PredictorTraining, "how the predictor is trained and judged")
    out: str = setting(REQUIRED, "the output file: the predictor (HDF5; its report goes beside it as .json)",
                       metavar="PATH")

    @property
    def splits(self) -> dict[str, dict[str, str]]:
        """Each evaluation split's files by method (its ``METHOD=PATH`` items); ValueError naming a bad item."""
        out = {}
        for name, items in (self.evaluate or {}).items():
            pairs = [item.split("=", 1) for item in items]
            bad = [item for item, pair in zip(items, pairs, strict=True) if len(pair) != 2]
            if bad:
                raise ValueError(f"--evaluate {name} takes METHOD=PATH items, got {', '.join(bad)}")
            out[name] = dict(pairs)
        return out


def metric_modes() -> Any:
    """The field of a job's metric modes (the one declaration of these stages' ``--modes``)."""
    return setting(MODES, "the metric modes: paper (the authors' rules) and/or standard", choices=MODES)


@dataclass(frozen=True)
class EvaluateJob:
    """The ``evaluate`` stage's job: match removal and precision-recall of one method (method §§7-9)."""

    dataset: str = dataset_name()
    method: str = setting(REQUIRED, "the method's name (a key of the configuration's methods)", metavar="NAME")
    seq_len: int = sources.seq_len()
    attributes: dict[str, str] = setting(REQUIRED, "the method's attributes (.h5) of each evaluated split",
                                         metavar="SPLIT=PATH")
    predictors: tuple[str, ...] = setting(REQUIRED, "one per seed, seed 0 first", min_items=1, metavar="PATH")
    modes: tuple[str, ...] = metric_modes()
    trust_levels: tuple[float, ...] = setting(DEFAULT_TRUST_LEVELS, "trust levels of the trust-level ablation (none: "
                                                                    "skip it)", min_items=0)
    restoration: bool = setting(True, "match restoration (--no-restoration skips it)")
    allow_split_overlap: bool = allow_split_overlap()
    out: str = setting(REQUIRED, "the output file: the evaluation (JSON; its timings go beside it)", metavar="PATH")


@dataclass(frozen=True)
class HeldOutJob:
    """The ``ablation held-out`` stage's job: one method's test split under the pooled and the ``without_``
    predictor."""

    dataset: str = dataset_name()
    method: str = setting(REQUIRED, "the held-out method's name (a key of the configuration's methods)",
                          metavar="NAME")
    seq_len: int = sources.seq_len()
    attributes: str = setting(REQUIRED, "the held-out method's test-split attributes (.h5)", metavar="PATH")
    pooled: str = setting(REQUIRED, "the predictor trained on every method (.h5)", metavar="PATH")
    without: str = setting(REQUIRED, "the predictor trained without the method (.h5, vpr-smr ablation without)",
                           metavar="PATH")
    modes: tuple[str, ...] = metric_modes()
    allow_split_overlap: bool = allow_split_overlap()
    out: str = setting(REQUIRED, "the output file: the leave-one-method-out evaluation (JSON)", metavar="PATH")
