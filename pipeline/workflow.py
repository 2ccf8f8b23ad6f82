"""Running the Snakemake workflow, and the checks that make a bad configuration fail before any job runs."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

from .config import ConfigError, load_config, run_dir

REPO = Path(__file__).resolve().parents[1]
SNAKEFILE = REPO / "Snakefile"
PROFILE = REPO / "pipeline" / "profiles" / "local"


def preflight(conf: dict[str, Any]) -> None:
    """Every dataset loads and every method has its backend and checkpoint; else one error listing them all."""
    from ..datasets import DatasetError, load_dataset
    from ..descriptors import backend_class

    problems = []
    for name, dataset in conf["datasets"].items():
        if "root" in dataset and not dataset["root"]:
            problems.append(f"datasets.{name}.root is not set: give the folder where dataset {name!r} is on disk")
            continue
        try:
            load_dataset(name, dataset)
        except DatasetError as error:
            problems.append(str(error))
    for name, method in conf["methods"].items():
        try:
            cls = backend_class(method["backend"])
        except (ValueError, ImportError) as error:
            problems.append(f"methods.{name}.backend: {error}")
            continue
        checkpoint = method.get("checkpoint")
        if cls.needs_checkpoint and not checkpoint:
            problems.append(f"methods.{name}.checkpoint is not set: backend {method['backend']!r} needs the path "
                            "of its downloaded checkpoint file")
        elif cls.needs_checkpoint and checkpoint != "package" and not Path(checkpoint).is_file():
            problems.append(f"methods.{name}.checkpoint: file not found: {checkpoint}")
    if problems:
        raise ConfigError("the configuration cannot run:\n  " + "\n  ".join(problems))


def run(config: Path | str, cores: int = 2, dry_run: bool = False, extra: list[str] | None = None) -> int:
    """Run the workflow of ``config``; print where the tables and figures are."""
    conf = load_config(config)
    preflight(conf)
    command = [sys.executable, "-m", "snakemake", "--snakefile", str(SNAKEFILE), "--configfile", str(config),
               "--profile", str(PROFILE), "--cores", str(cores)]
    if dry_run:
        command.append("--dry-run")
    command += [a for a in (extra or []) if a != "--"]
    status = subprocess.call(command)
    if status == 0 and not dry_run:
        out = run_dir(conf)
        print(f"\ntables:  {out / 'tables'} (table1.csv, table1.md, table1.tex, predictor.csv)")
        print(f"figures: {out / 'figures'}")
    return status
