"""The stages from a dataset's frames to the queries' attributes: ``descriptors``, ``distances``, ``attributes``, and
the match inspector (``inspect``), which draws a split's matches. The inspector's module (its figures) is imported
when its stage runs; the other stages' modules hold their job records and are light to import (their heavy work,
PyTorch and the datasets, is imported inside their functions)."""

from __future__ import annotations

from pathlib import Path

from vpr_smr.eval.matching import attributes, distances
from vpr_smr.eval.matching.attributes import AttributesJob, QueryFeatures
from vpr_smr.eval.matching.distances import DistancesJob
from vpr_smr.eval.report.job import InspectJob
from vpr_smr.pipeline import descriptors
from vpr_smr.pipeline.descriptors import DescriptorsJob
from vpr_smr.pipeline.stage import Stage, wrote


def _attributes_summary(job: AttributesJob, found: QueryFeatures) -> str:
    n_queries, n_correct = len(found.queries), int(found.sequence_correct.sum())
    return wrote(f"the attributes of {n_queries} queries", job.out,
                 f"{n_correct} sequence matches correct ({n_correct / max(n_queries, 1):.4f})")


DESCRIPTORS = Stage("descriptors", "compute a method's descriptors of a dataset (HDF5)", DescriptorsJob,
                    descriptors.main,
                    summary=lambda job, out: wrote(f"the {job.method} descriptors of {job.dataset}", out),
                    speed=("threads", "extraction"))

DISTANCES = Stage("distances", "reference x query distance matrix of one split (HDF5)", DistancesJob, distances.main,
                  summary=lambda job, out: wrote(f"the {job.split} split's distance matrix", out))

ATTRIBUTES = Stage("attributes", "sequence matching, SMR attributes and labels of a distance matrix",
                   AttributesJob, attributes.main, summary=_attributes_summary)


def _inspect(job: InspectJob) -> tuple[Path | None, Path]:
    from vpr_smr.eval.report import inspector

    return inspector.main(job)


INSPECT = Stage("inspect", "the match inspector: sampled queries with their matches, and the distance matrix with the "
                           "kept and removed sequence matches (two PNGs)", InspectJob, _inspect,
                summary=lambda job, written: " and ".join(str(path) for path in written if path is not None),
                epilog="e.g. a user's matrix, the distance-matrix figure only (it needs no images): vpr-smr inspect "
                       "--queries queries.csv --distances D.npy --seq-len 4 --matrix-figure d.png")

STAGES: tuple[Stage, ...] = (DESCRIPTORS, DISTANCES, ATTRIBUTES, INSPECT)
