"""Typed results of the predictor stages, each the one home of its keys in the JSON files (SPEC 7, Table II).

``train.main`` builds a ``PredictorReport`` (the ``L<L>.json`` beside each predictor, and the predictor's ``report``
attribute) and ``ablation.attributes_main`` an ``AttributeAblation``; the report reads both back with ``from_json``,
which takes exactly the layout ``to_json`` writes (a missing key is an error, not a default). ``write_json`` sorts
keys, so the keys and values here alone decide a file's bytes. The numbers of a split that was not given (val,
test) are absent from a file, never null.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

Json = dict[str, Any]
EVALUATION_SPLITS = ("val", "test")  # the splits a predictor may be scored on, in the order train.main scores them


def _ints(values: Any) -> tuple[int, ...]:
    return tuple(values)


def _matrix(rows: Any) -> tuple[tuple[int, ...], ...]:
    return tuple(_ints(row) for row in rows)


# --- a trained predictor -----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SplitScores:
    """One seed's predictor on one evaluation split: macro F1, samples, class counts, confusion (rows true label)."""

    f1: float
    n: int
    class_counts: tuple[int, ...]
    confusion: tuple[tuple[int, ...], ...]


@dataclass(frozen=True)
class SeedReport:
    """One training seed: its predictor's settings, cross-validated F1, iterations and scores per given split.

    Written flat: ``class_counts`` maps ``train`` and each split to its counts, and a split ``s`` adds ``f1_s``,
    ``n_s`` and ``confusion_s``. ``params`` holds JSON values (lists, not tuples), as the file does.
    """

    seed: int
    params: Json
    f1_cv: float
    n_iter: int
    train_class_counts: tuple[int, ...]
    splits: dict[str, SplitScores]

    def f1(self, split: str) -> float | None:
        """Macro F1 on ``split``, None when it was not given."""
        return self.splits[split].f1 if split in self.splits else None

    def to_json(self) -> Json:
        out: Json = {"seed": self.seed, "params": dict(self.params), "f1_cv": self.f1_cv, "n_iter": self.n_iter,
                     "class_counts": {"train": list(self.train_class_counts),
                                      **{name: list(s.class_counts) for name, s in self.splits.items()}}}
        for name, scores in self.splits.items():
            out[f"f1_{name}"], out[f"n_{name}"] = scores.f1, scores.n
            out[f"confusion_{name}"] = [list(row) for row in scores.confusion]
        return out

    @classmethod
    def from_json(cls, data: Json) -> SeedReport:
        counts = data["class_counts"]
        splits = {name: SplitScores(data[f"f1_{name}"], data[f"n_{name}"], _ints(counts[name]),
                                    _matrix(data[f"confusion_{name}"]))
                  for name in EVALUATION_SPLITS if name in counts}
        return cls(data["seed"], dict(data["params"]), data["f1_cv"], data["n_iter"], _ints(counts["train"]),
                   splits)


def chance_f1(class_counts: tuple[int, ...]) -> float:
    """Macro F1 at chance on a split with these class counts: ``1 / K`` for the ``K`` classes present, the expected
    macro F1 of guessing each class at its own frequency (each class's F1 is then its frequency; always guessing
    the most frequent class scores ``2 p / (1 + p) / K``, less)."""
    present = sum(1 for count in class_counts if count > 0)
    return 1.0 / present if present else 0.0


def seed_problems(seed: SeedReport, split: str = "val") -> list[str]:
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
class PredictorReport:
    """The report of ``train.main``: every seed (the first one's predictor is the predictor file) and, at the top
    level, the first seed's numbers in the layout of earlier reports. ``seed_models``: the predictor files, only
    when there are several seeds."""

    meta: Json
    n_train: int
    seeds: tuple[SeedReport, ...]
    seed_models: tuple[str, ...] | None = None

    def first_seed(self) -> Json:
        """The top-level numbers: the first seed's settings, train class counts, F1, sample counts, iterations."""
        first = self.seeds[0]
        out: Json = {"params": dict(first.params), "train_class_counts": list(first.train_class_counts),
                     "f1_cv": first.f1_cv, "n_iter": first.n_iter}
        for name, scores in first.splits.items():
            out[f"f1_{name}"], out[f"n_{name}"] = scores.f1, scores.n
        return out

    def warning(self, split: str = "val") -> str:
        """Every seed whose predictor cannot be trusted on ``split`` and why (``seed_problems``), in one line; empty
        when none."""
        parts = [f"seed {seed.seed}: {'; '.join(problems)}" for seed in self.seeds
                 if (problems := seed_problems(seed, split))]
        return " | ".join(parts)

    def to_json(self) -> Json:
        out = {"meta": dict(self.meta), "n_train": self.n_train, **self.first_seed(),
               "seeds": [seed.to_json() for seed in self.seeds]}
        if self.seed_models is not None:
            out["seed_models"] = list(self.seed_models)
        return out

    @classmethod
    def from_json(cls, data: Json) -> PredictorReport:
        report = cls(dict(data["meta"]), data["n_train"], tuple(SeedReport.from_json(s) for s in data["seeds"]),
                     tuple(data["seed_models"]) if "seed_models" in data else None)
        # the top level repeats the first seed: a file where they differ was not written by train.main
        for key, value in report.first_seed().items():
            if data[key] != value:
                raise ValueError(f"predictor report: top-level {key!r} {data[key]!r} is not the first seed's "
                                 f"{value!r}")
        return report


# --- Table II ------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class AttributeScores:
    """A predictor on one attribute set: its input columns (None: all four) and macro F1 of cross-validation, on
    the val and test splits pooled, and the mean over the methods' test splits (the last four only when given)."""

    columns: tuple[int, ...] | None
    f1_cv: float
    f1_val: float | None = None
    n_val: int | None = None
    f1_test: float | None = None
    n_test: int | None = None
    f1_test_method_mean: float | None = None

    OPTIONAL = ("f1_val", "n_val", "f1_test", "n_test", "f1_test_method_mean")

    def to_json(self) -> Json:
        optional = {name: getattr(self, name) for name in self.OPTIONAL if getattr(self, name) is not None}
        return {"columns": None if self.columns is None else list(self.columns), "f1_cv": self.f1_cv, **optional}

    @classmethod
    def from_json(cls, data: Json) -> AttributeScores:
        columns = data["columns"]
        return cls(None if columns is None else _ints(columns), data["f1_cv"],
                   **{name: data[name] for name in cls.OPTIONAL if name in data})


@dataclass(frozen=True)
class AttributeAblation:
    """Table II for one dataset and sequence length (``ablation.attributes_main``): per attribute set its scores."""

    meta: Json
    params: Json
    n_train: int
    attributes: dict[str, AttributeScores]

    def to_json(self) -> Json:
        return {"meta": dict(self.meta), "params": dict(self.params), "n_train": self.n_train,
                "attributes": {name: scores.to_json() for name, scores in self.attributes.items()}}

    @classmethod
    def from_json(cls, data: Json) -> AttributeAblation:
        return cls(dict(data["meta"]), dict(data["params"]), data["n_train"],
                   {name: AttributeScores.from_json(scores) for name, scores in data["attributes"].items()})
