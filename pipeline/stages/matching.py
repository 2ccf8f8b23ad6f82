"""The stages from a dataset's frames to the queries' attributes: ``descriptors``, ``distances``, ``attributes``, and
the match inspector (``inspect``), which draws a split's matches. The inspector's module (its figures) is imported
when its stage runs; the other stages' modules hold their job records and are light to import (their heavy work,
PyTorch and the datasets, is imported inside their functions). Their workflow jobs: ``JOBS`` (each one's output,
inputs and record, of which ``pipeline/rules/jobs.smk`` makes its rule)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vpr_smr.core.paths import (
    attributes_path,
    descriptors_path,
    distances_path,
    match_figure_path,
    matrix_figure_path,
)
from vpr_smr.eval.matching import attributes, distances
from vpr_smr.eval.matching.attributes import AttributesJob, QueryFeatures
from vpr_smr.eval.matching.distances import DistancesJob
from vpr_smr.eval.report.job import InspectJob
from vpr_smr.pipeline import descriptors
from vpr_smr.pipeline.descriptors import DescriptorsJob
from vpr_smr.pipeline.experiment import Job, Wildcard, relative
from vpr_smr.pipeline.rule_helpers import RuleFiles, rule_files
from vpr_smr.pipeline.stage import Stage, wrote

if TYPE_CHECKING:
    from vpr_smr.pipeline.config import Config
    from vpr_smr.pipeline.plan import Plan


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


# --- the workflow's jobs of these stages (``pipeline/rules/jobs.smk`` makes a rule of each) --------------------------


def splits(conf: Config, plan: Plan) -> list[str]:
    """The ``split`` wildcard's values: the train split and every evaluation split (the table split among them)."""
    return [conf.train_split, *conf.eval_splits]


def _descriptors_inputs(out: str, conf: Config, plan: Plan, wildcards: Mapping[str, str]) -> dict[str, list[str]]:
    """The method's checkpoint (none for a backend without one), the dataset's frame lists and (method §11) its
    positions CSVs."""
    checkpoint, dataset = plan.checkpoints[wildcards["method"]], plan.datasets[wildcards["dataset"]]
    return {"checkpoint": [checkpoint] if checkpoint else [], "lists": list(dataset.list_files),
            "positions": list(dataset.positions_files)}


def _descriptors_record(conf: Config, plan: Plan, wildcards: Mapping[str, str], files: Mapping[str, Any], out: str
                        ) -> DescriptorsJob:
    """The frames' settings and fingerprint; the method's settings without ``distance`` (it changes the distance
    matrices, not the descriptors)."""
    from vpr_smr.descriptors import descriptor_settings
    from vpr_smr.pipeline.plan import canonical

    dataset, method = plan.datasets[wildcards["dataset"]], wildcards["method"]
    return DescriptorsJob(wildcards["dataset"], method, dataset_settings=canonical(dataset.frames_settings),
                          method_settings=canonical(descriptor_settings(conf.methods[method].to_json())),
                          frames_sha256=dataset.frames_sha256, out=out)


def _descriptors_revision(conf: Config, plan: Plan, wildcards: Mapping[str, str]) -> int:
    """What the backend's code computes: a new revision computes the descriptors again."""
    from vpr_smr.descriptors import descriptor_revision

    return descriptor_revision(conf.methods[wildcards["method"]].backend)


def _descriptors_resources(conf: Config) -> dict[str, Any]:
    """A GPU, and the batch size and decoding workers: they change how fast a job runs, not what it computes (a
    resource, not a param, so that changing them reruns nothing; the stage's ``speed`` settings, given beside its
    job)."""
    from vpr_smr.pipeline.rule_helpers import extraction_options

    return {"gpu": 1, "extraction": extraction_options(conf)}


def _distances_record(conf: Config, plan: Plan, wildcards: Mapping[str, str], files: Mapping[str, Any], out: str
                      ) -> DistancesJob:
    """The split's frames (method §11: its reference range, only where it differs from its query range) and the
    method's ``distance`` (or its backend's default)."""
    dataset, split = plan.datasets[wildcards["dataset"]], wildcards["split"]
    return DistancesJob(files["descriptors"], split, dataset.splits[split], dataset.reference_splits.get(split),
                        plan.metrics[wildcards["method"]], out=out)


def _attributes_record(conf: Config, plan: Plan, wildcards: Mapping[str, str], files: Mapping[str, Any], out: str
                       ) -> AttributesJob:
    """Method §§5, 11, 13: the matcher, the dataset's ground truth, and the candidates the training-free scorers need
    (method §12: only a change of their number recomputes these)."""
    return AttributesJob(files["distances"], int(wildcards["seq_len"]), plan.datasets[wildcards["dataset"]].truth,
                         conf.sequence_matching, candidates=conf.baselines.candidates, out=out)


def _inspect_record(conf: Config, plan: Plan, wildcards: Mapping[str, str], files: Mapping[str, Any], out: str
                    ) -> InspectJob:
    """The images are read for the thumbnails (the frames' settings and fingerprint, as the descriptors job's); the
    table split's frames; the dataset's ground truth (method §13: a file is cut to the split by the stage) and the
    run's matcher, as its queries CSV was made."""
    from vpr_smr.pipeline.plan import canonical

    dataset = plan.datasets[wildcards["dataset"]]
    matrix = matrix_figure_path(str(conf.run_dir), wildcards["dataset"], wildcards["method"], wildcards["seq_len"])
    return InspectJob(files["queries"], files["distances"], out, matrix, wildcards["dataset"],
                      canonical(dataset.frames_settings), dataset.frames_sha256, int(wildcards["seq_len"]),
                      conf.table_split, dataset.truth, conf.sequence_matching,
                      frames=dataset.splits[conf.table_split])


# A method's descriptors of a dataset's frames: two threads, the stage's own (--threads), and a GPU where there is one.
DESCRIPTORS_JOB = Job(DESCRIPTORS, relative(descriptors_path("", "{dataset}", "{method}")), _descriptors_inputs,
                      _descriptors_record, threads=2, revision=_descriptors_revision,
                      resources=_descriptors_resources, speed="--threads {threads} {resources.extraction}",
                      rule="descriptors")
# From descriptors to attributes: the distance matrix of a split, and its queries' attributes (the split's distances,
# the dataset's ground-truth file: method §13, or none).
DISTANCES_JOB = Job(DISTANCES, relative(distances_path("", "{dataset}", "{method}", "{split}")),
                    rule_files(RuleFiles.distances), _distances_record, wildcards_from=(Wildcard("split", splits),),
                    rule="distances")
ATTRIBUTES_JOB = Job(ATTRIBUTES, relative(attributes_path("", "{dataset}", "{method}", "{seq_len}", "{split}")),
                     rule_files(RuleFiles.attributes), _attributes_record,
                     wildcards_from=(Wildcard("split", splits),), rule="attributes")
# The match inspector: thumbnails of a fixed sample of the table split's queries with their matches, and the split's
# distance matrix with the sequence matches the predictor keeps or removes (the report shows both); it reads the
# per-query table, the table split's distances and the ground-truth file (or none).
INSPECT_JOB = Job(INSPECT, relative(match_figure_path("", "{dataset}", "{method}", "{seq_len}")),
                  rule_files(RuleFiles.inspect), _inspect_record, rule="inspect",
                  named=lambda out, conf: {"matches": match_figure_path(out, "{dataset}", "{method}", "{seq_len}"),
                                           "matrix": matrix_figure_path(out, "{dataset}", "{method}", "{seq_len}")})

JOBS: tuple[Job, ...] = (DESCRIPTORS_JOB, DISTANCES_JOB, ATTRIBUTES_JOB, INSPECT_JOB)
