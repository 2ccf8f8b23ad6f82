"""The datasets table: one row per dataset card (``pipeline.plan.dataset_cards``): its traverses, frames per split,
tolerance, frame lists and where the images came from. The page folds it under the dataset cards (no section of
its own); it says each dataset's ground truth in a column of its own (``protocol=False``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from vpr_smr.eval.report.registry import Table
from vpr_smr.eval.report.results import Order, ground_truth_text, split_text
from vpr_smr.eval.report.rows import column
from vpr_smr.eval.report.tabulate import Inputs


@dataclass(frozen=True)
class DatasetRow:
    """``datasets``: one dataset's card (``pipeline.plan.dataset_cards``) as texts and counts."""

    dataset: str = column()
    reference: str = column()
    query: str = column()
    n_frames: Any = column()  # a count, or "reference / query" frames for a dataset with positions (method §11)
    splits: str = column()
    tolerance: Any = column()  # the frames within the tolerance, else the ground truth's text (positions, a file)
    pairing: str = column()
    overlaps: str = column()
    frames_sha256: str = column()
    source: str = column()

    @classmethod
    def of(cls, name: str, info: dict[str, Any]) -> DatasetRow:
        return cls(name, info.get("reference", ""), info.get("query", ""),
                   info.get("n_frames") if info.get("n_query_frames") is None
                   else f"{info.get('n_frames')} / {info['n_query_frames']}",
                   split_text(info.get("splits", {}), info.get("reference_splits")),
                   info.get("tolerance") if info.get("radius") is None and info.get("ground_truth") is None
                   else ground_truth_text(info),
                   info.get("pairing", ""), "; ".join(info.get("overlaps", [])), info.get("frames_sha256", ""),
                   info.get("source", ""))


def dataset_rows(datasets: dict[str, dict[str, Any]], order: Order | None = None) -> list[DatasetRow]:
    """One row per dataset card (``pipeline.plan.dataset_cards``), in the configuration's order."""
    order = order or Order(tuple(datasets))
    return [DatasetRow.of(name, datasets[name]) for name in sorted(datasets, key=order.dataset)]


def make_datasets(inputs: Inputs) -> list[DatasetRow] | None:
    return dataset_rows(inputs.datasets, inputs.order) if inputs.datasets else None


TABLE = Table("datasets", "Datasets: traverses, frames per split, tolerance, frame lists and where the images came "
              "from", ("datasets",), row=DatasetRow, make=make_datasets, protocol=False)
