"""The stages from descriptors to attributes: ``distances`` and ``attributes``."""

from __future__ import annotations

from vpr_smr.eval.matching import attributes
from vpr_smr.eval.matching.attributes import AttributesJob, QueryFeatures
from vpr_smr.pipeline.stage import Stage


def _attributes_summary(job: AttributesJob, found: QueryFeatures) -> str:
    n_queries, n_correct = len(found.queries), int(found.sequence_correct.sum())
    return (f"the attributes of {n_queries} queries to {job.out}: {n_correct} sequence matches correct "
            f"({n_correct / max(n_queries, 1):.4f})")


ATTRIBUTES = Stage("attributes", "sequence matching, SMR attributes and labels of a distance matrix",
                   AttributesJob, attributes.main, summary=_attributes_summary)

STAGES: tuple[Stage, ...] = (ATTRIBUTES,)
