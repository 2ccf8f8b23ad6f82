"""Typed results of the predictor stages, each the one home of its keys in the JSON files (method §7, Table II).

``train.main`` builds a ``PredictorReport`` (the ``L<L>.json`` beside each predictor, and the predictor's ``report``
attribute) and ``ablation.attributes_main`` an ``AttributeAblation``; each record's fields are its JSON layout
(``core.records``, the one codec of every record), and the report reads both back with ``from_json``, which takes
exactly that layout (a missing entry is an error, not a default; a file of another results format is refused).
``write_json`` sorts keys, so the fields and values here alone decide a file's bytes. The numbers of a split that
was not given are absent from a file, never null.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from vpr_smr.core.records import FileRecord, Record

Json = dict[str, Any]
# --- a trained predictor -----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SplitScores(Record):
    """One seed's predictor on one evaluation split: macro F1, samples, class counts, confusion (rows true label)."""

    f1: float
    n: int
    class_counts: tuple[int, ...]
    confusion: tuple[tuple[int, ...], ...]


@dataclass(frozen=True)
class SeedReport(Record):
    """One training seed: its predictor's settings, cross-validated F1 (None: not cross-validated, as every seed
    but the first), iterations, the train split's class counts and the scores per given evaluation split (by the
    split's name). ``params`` holds JSON values (lists, not tuples), as the file does.
    """

    seed: int
    params: Json
    f1_cv: float | None
    n_iter: int
    train_class_counts: tuple[int, ...]
    splits: dict[str, SplitScores]

    def f1(self, split: str) -> float | None:
        """Macro F1 on ``split``, None when it was not given."""
        return self.splits[split].f1 if split in self.splits else None


def chance_f1(class_counts: tuple[int, ...]) -> float:
    """Macro F1 at chance on a split with these class counts: ``1 / K`` for the ``K`` classes present, the expected
    macro F1 of guessing each class at its own frequency (each class's F1 is then its frequency; always guessing
    the most frequent class scores ``2 p / (1 + p) / K``, less)."""
    present = sum(1 for count in class_counts if count > 0)
    return 1.0 / present if present else 0.0


def seed_problems(seed: SeedReport, split: str) -> list[str]:
    """Why one seed's predictor cannot be trusted on ``split`` (empty when it can, when the split was not given, or
    when it holds one class only): a macro F1 at or below chance, or one class predicted for every sample."""
    scores = seed.splits.get(split)
    # one class present: chance would be a macro F1 of 1 and one predicted class right; nothing to judge by
    if scores is None or sum(count > 0 for count in scores.class_counts) < 2:
        return []
    problems = []
    chance = chance_f1(scores.class_counts)
    if scores.f1 <= chance:
        present = sum(1 for count in scores.class_counts if count > 0)
        problems.append(f"its {split} macro F1 {scores.f1:.2f} is at or below chance ({chance:.2f}: guessing each of "
                        f"the {present} classes present at its own frequency)")
    predicted = [sum(row[c] for row in scores.confusion) for c in range(len(scores.confusion[0]))]
    if sum(count > 0 for count in predicted) == 1:
        cls = next(c for c, count in enumerate(predicted) if count > 0)
        problems.append(f"it predicts class {cls} for all {scores.n} {split} samples")
    return problems


@dataclass(frozen=True)
class PredictorReport(FileRecord):
    """The report of ``train.main``: every seed (the first one's predictor is the predictor file; ``first_seed``
    gives its numbers). ``seed_models``: the predictor files, only when there are several seeds."""

    meta: Json
    n_train: int
    seeds: tuple[SeedReport, ...]
    seed_models: tuple[str, ...] | None = None

    def first_seed(self) -> Json:
        """The first seed's settings, train class counts, F1, sample counts and iterations, flat (``f1_<split>``,
        ``n_<split>``), as the predictor table takes them."""
        first = self.seeds[0]
        out: Json = {"params": dict(first.params), "train_class_counts": list(first.train_class_counts),
                     "f1_cv": first.f1_cv, "n_iter": first.n_iter}
        for name, scores in first.splits.items():
            out[f"f1_{name}"], out[f"n_{name}"] = scores.f1, scores.n
        return out

    def warning(self, split: str) -> str:
        """Every seed whose predictor cannot be trusted on ``split`` and why (``seed_problems``), in one line; empty
        when none."""
        parts = [f"seed {seed.seed}: {'; '.join(problems)}" for seed in self.seeds
                 if (problems := seed_problems(seed, split))]
        return " | ".join(parts)


# --- Table II ------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class AttributeSplit(Record):
    """A predictor on one attribute set, on one evaluation split: the macro F1 over every method's samples pooled,
    their number, and the mean of the per-method macro F1 (the paper's Table II averages over methods)."""

    f1: float
    n: int
    f1_method_mean: float


@dataclass(frozen=True)
class AttributeScores(Record):
    """A predictor on one attribute set: its input columns (None: all four), macro F1 of cross-validation, and its
    scores on each given evaluation split, by the split's name (the configuration's)."""

    columns: tuple[int, ...] | None
    f1_cv: float
    splits: dict[str, AttributeSplit]


@dataclass(frozen=True)
class AttributeAblation(FileRecord):
    """Table II for one dataset and sequence length (``ablation.attributes_main``): per attribute set its scores."""

    meta: Json
    params: Json
    n_train: int
    attributes: dict[str, AttributeScores]
