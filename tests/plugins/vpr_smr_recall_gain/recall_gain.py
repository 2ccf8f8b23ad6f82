"""The experiment ``recall_gain``, a plugin that lives only in the tests: what sequence matching adds to single-frame
matching's recall@1, per dataset and method at the table's L on the table split, with a 95 % interval.

One module declares all of it: the job (its record, its stage, its output and inputs), the table (its row record)
and the report's section with its sentence; the entry point ``recall_gain`` (group ``vpr_smr.experiments``) of
the dist-info beside it registers it.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from vpr_smr.core.paths import attributes_path
from vpr_smr.core.settings import REQUIRED, setting
from vpr_smr.eval.report.registry import Table
from vpr_smr.eval.report.rows import column
from vpr_smr.eval.report.sections import Declared
from vpr_smr.eval.report.tabulate import Inputs
from vpr_smr.pipeline.experiment import Experiment, Job
from vpr_smr.pipeline.stage import Stage

NAME = "recall_gain"
Z95 = 1.959963984540054  # the normal distribution's 97.5 % quantile


@dataclass(frozen=True)
class RecallGainJob:
    """The ``recall-gain`` stage's job: one attributes file's recall@1 of single-frame and of sequence matching."""

    attributes: str = setting(REQUIRED, "the attributes file (vpr-smr attributes)", metavar="PATH")
    dataset: str = setting(REQUIRED, "the dataset's name, for the table")
    method: str = setting(REQUIRED, "the method's name, for the table")
    out: str = setting(REQUIRED, "the output file (JSON)", metavar="PATH")


def gain(single: np.ndarray, sequence: np.ndarray) -> dict[str, float]:
    """Recall@1 of each and the paired difference (sequence minus single) with its 95 % normal interval."""
    differences = sequence.astype(float) - single.astype(float)
    n = len(differences)
    mean = float(differences.mean())
    half = Z95 * float(differences.std(ddof=1)) / math.sqrt(n) if n > 1 else math.nan
    return {"n_queries": n, "recall_single": float(single.mean()), "recall_sequence": float(sequence.mean()),
            "gain": mean, "gain_low": mean - half, "gain_high": mean + half}


def run(job: RecallGainJob) -> dict[str, Any]:
    with h5py.File(job.attributes, "r") as f:
        single, sequence = f["single_correct"][()], f["sequence_correct"][()]
        seq_len = int(f.attrs["seq_len"])
    result = {"dataset": job.dataset, "method": job.method, "seq_len": seq_len, **gain(single, sequence)}
    Path(job.out).parent.mkdir(parents=True, exist_ok=True)
    Path(job.out).write_text(json.dumps(result, indent=1) + "\n")
    return result


STAGE = Stage("recall-gain", "recall@1 of sequence matching minus that of single-frame matching", RecallGainJob, run,
              summary=lambda job, result: f"the recall gain of {job.dataset} {job.method} to {job.out}: "
                                          f"{result['gain']:+.4f}")


def inputs(out: str, conf: Any, plan: Any, wildcards: Mapping[str, str]) -> dict[str, str]:
    """The table split's attributes file of the job's dataset, method and L."""
    return {"attributes": attributes_path(out, wildcards["dataset"], wildcards["method"], wildcards["seq_len"],
                                          conf.table_split)}


def record(conf: Any, plan: Any, wildcards: Mapping[str, str], files: Mapping[str, Any], out: str) -> RecallGainJob:
    return RecallGainJob(str(files["attributes"]), wildcards["dataset"], wildcards["method"], out)


@dataclass(frozen=True)
class RecallGainRow:
    """One dataset and method: recall@1 of each matching and the gain with its interval."""

    dataset: str = column()
    method: str = column()
    seq_len: int = column()
    n_queries: int = column()
    recall_single: float = column("R@1 single")
    recall_sequence: float = column("R@1 sequence")
    gain: float = column("gain")
    gain_low: float = column("gain, low")
    gain_high: float = column("gain, high")


def make(inputs: Inputs) -> list[RecallGainRow] | None:
    paths: Sequence[Path] = inputs.experiments.get(NAME, ())
    if not paths:
        return None
    return [RecallGainRow(**json.loads(Path(path).read_text())) for path in paths]


SECTION = Declared(NAME, "Recall gain", (NAME,),
                   "Sequence matching's recall@1 minus single-frame matching's on the same queries, per dataset and "
                   "method, with a 95 % normal interval of the paired difference.")

TABLE = Table(NAME, "Recall gain: recall@1 of sequence matching minus that of single-frame matching", (NAME,),
              row=RecallGainRow, make=make, page=("method", "seq_len", "gain", "gain_low", "gain_high"),
              section=SECTION)

EXPERIMENT = Experiment(NAME, "recall@1 of sequence matching minus that of single-frame matching, per dataset and "
                        "method at table_seq_len", (Job(STAGE, "recall_gain/{dataset}/{method}/L{seq_len}.json",
                                                         inputs, record),), (TABLE,))
