"""The ``descriptors`` stage's job: a method's descriptors of a dataset, its settings given as JSON objects (the
workflow's rules) or taken from a configuration file (``--config``).

The job lives in the workflow's layer, not beside ``descriptors.extract``: reading a configuration file and its
``extraction`` section (``config.Extraction``) belongs here, and ``extract.main`` stays the work on a dataset's
frames that the layers below can call.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vpr_smr.core.io import HDF5_SUFFIXES, check_suffix
from vpr_smr.core.json_objects import json_object
from vpr_smr.core.settings import REQUIRED, group, setting
from vpr_smr.pipeline.config import ConfigError, Extraction, load_config

__all__ = ["DescriptorsJob", "main", "settings_of"]

log = logging.getLogger("vpr_smr")


@dataclass(frozen=True)
class DescriptorsJob:
    """The ``descriptors`` stage's job: what is computed (the dataset, the method, their settings, the output) and
    how fast (``threads``, ``extraction``: no result depends on them)."""

    dataset: str = setting(REQUIRED, "the dataset's name (a key of the configuration's datasets)", metavar="NAME")
    method: str = setting(REQUIRED, "the method's name (a key of the configuration's methods)", metavar="NAME")
    config: str | None = setting(None, "take the dataset's and method's settings from this configuration file",
                                 metavar="PATH")
    # JSON text, as the inspector's: an empty object given is not one left out
    dataset_settings: str | None = setting(None, "the dataset's settings as a JSON object (or @file)",
                                           metavar="JSON")
    method_settings: str | None = setting(None, "the method's settings as a JSON object (or @file)", metavar="JSON")
    frames_sha256: str | None = setting(None, "fail unless the dataset's frame lists have this fingerprint",
                                        metavar="SHA256")
    extraction: Extraction = group(Extraction, "how fast the descriptors are computed")
    threads: int | None = setting(None, "CPU threads of the network (none or 0: PyTorch's own number)", minimum=0)
    out: str = setting(REQUIRED, "the output file: the descriptors (HDF5)", metavar="PATH")


def settings_of(job: DescriptorsJob) -> tuple[dict[str, Any], dict[str, Any]]:
    """The dataset's and the method's settings: ``job.config``'s entries, else the JSON objects it gives."""
    if job.config:
        conf = load_config(job.config)
        for section, name, entries in (("datasets", job.dataset, conf.datasets),
                                       ("methods", job.method, conf.methods)):
            if name not in entries:
                raise ConfigError(f"{job.config}: {section} has no {name!r}; it has {', '.join(entries)}")
        return conf.datasets[job.dataset].to_json(), conf.methods[job.method].to_json()
    if job.dataset_settings is None or job.method_settings is None:
        raise ConfigError("give --config, or both --dataset-settings and --method-settings")
    return (json_object(job.dataset_settings, "--dataset-settings"),
            json_object(job.method_settings, "--method-settings"))


def main(job: DescriptorsJob) -> Path:
    """The ``descriptors`` stage: the method's descriptors of both traverses of the dataset to ``job.out``
    (``extract.main``: skipped when that file holds them already); ConfigError when the frames on disk are not
    those of ``job.frames_sha256`` (the workflow's plan)."""
    from vpr_smr.datasets import load_frames
    from vpr_smr.descriptors import extract  # PyTorch: only when the stage runs

    out = check_suffix(job.out, HDF5_SUFFIXES, "the descriptors (HDF5)")  # before any work
    if job.threads:
        import torch

        torch.set_num_threads(job.threads)
    dataset, method = settings_of(job)
    pair = load_frames(job.dataset, dataset)  # the configuration check builds it the same way
    if job.frames_sha256 and pair.fingerprint() != job.frames_sha256:
        raise ConfigError(f"dataset {job.dataset!r}: its frames changed on disk since the workflow was planned "
                          "(the frame lists' SHA-256 differs); run the workflow again")
    return extract.main(pair, job.method, method, out, batch_size=job.extraction.batch_size,
                        num_workers=job.extraction.num_workers)
