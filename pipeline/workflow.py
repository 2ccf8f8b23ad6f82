"""Running the Snakemake workflow that ships inside the package (Snakefile, rules, schema, profiles)."""

from __future__ import annotations

import fcntl
import hashlib
import os
import signal
import socket
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import yaml

from ..eval.io import atomic_path
from .config import ConfigError, load_config, parse_overrides, run_dir
from .plan import preflight

PACKAGE = Path(__file__).resolve().parent
SNAKEFILE = PACKAGE / "Snakefile"
PROFILES = PACKAGE / "profiles"


def profile_path(profile: str) -> Path:
    """A profile shipped with the package (``local``, ``slurm``) or a folder of the user's."""
    path = PROFILES / profile if (PROFILES / profile).is_dir() else Path(profile)
    if not path.is_dir():
        shipped = ", ".join(sorted(p.name for p in PROFILES.iterdir() if p.is_dir()))
        raise FileNotFoundError(f"profile not found: {profile} (shipped profiles: {shipped}; or give a folder)")
    return path


LOCK_NAME = ".vpr-smr.lock"


@contextmanager
def run_lock(folder: Path) -> Iterator[None]:
    """Hold the run folder for this process; a second run of it fails at once, naming the holder.

    An ``flock`` dies with its process, so a lock left by a killed run is never in the way.
    """
    folder.mkdir(parents=True, exist_ok=True)
    handle = open(folder / LOCK_NAME, "a+")
    try:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            handle.seek(0)
            holder = handle.read().strip() or "another process"
            raise ConfigError(f"the run folder {folder} is in use by {holder}; wait for that run to finish "
                              "or stop it (or give this configuration another `run` name)") from None
        handle.seek(0)
        handle.truncate()
        handle.write(f"process {os.getpid()} on {socket.gethostname()} (vpr-smr run, working folder {Path.cwd()})")
        handle.flush()
        yield
    finally:
        handle.close()


def snakemake_command(config: Path | str, overrides: dict[str, Any], cores: int | None, profile: str,
                      dry_run: bool, extra: list[str]) -> list[str]:
    configfiles = [str(config)]
    if overrides:
        # A second configuration file, merged into the first by Snakemake as we merge them: `--config key=value`
        # would reach the workflow with every nested value as a string. Named by its content, in Snakemake's
        # folder of the working directory, which cluster jobs see too.
        text = yaml.safe_dump(overrides, sort_keys=True)
        path = Path(".snakemake", "vpr-smr", f"overrides-{hashlib.sha256(text.encode()).hexdigest()[:16]}.yaml")
        if not path.is_file():
            with atomic_path(path) as tmp:
                tmp.write_text(text)
        configfiles.append(str(path))
    command = [sys.executable, "-m", "snakemake", "--snakefile", str(SNAKEFILE), "--configfile", *configfiles,
               "--profile", str(profile_path(profile))]
    if cores is not None:
        command += ["--cores", str(cores)]
    if dry_run:
        command.append("--dry-run")
    return command + [a for a in extra if a != "--"]


def run(config: Path | str, cores: int | None = None, dry_run: bool = False, extra: list[str] | None = None,
        overrides: list[str] | None = None, profile: str = "local") -> int:
    """Run the workflow of ``config`` (with ``key=value`` overrides); print where the results are."""
    parsed = parse_overrides(overrides)
    conf = load_config(config, parsed)
    preflight(conf)  # a clean error before Snakemake starts; the Snakefile checks again for direct callers
    command = snakemake_command(config, parsed, cores, profile, dry_run, list(extra or []))
    if dry_run:
        return _snakemake(command)
    # Our lock on the run folder replaces Snakemake's lock on the working folder: it names the run that holds
    # it and cannot outlive a killed run, so no `--unlock` is ever needed.
    with run_lock(run_dir(conf)):
        status = _snakemake(command + ["--nolock"])
    if status == 0:
        out = run_dir(conf)
        print(f"\ntables:  {out / 'tables'}\nfigures: {out / 'figures'}")
        if (out / "report.html").is_file():
            print(f"report:  {out / 'report.html'}")
    return status


def _descendants(pid: int) -> list[int]:
    """Every process below ``pid`` (from /proc), deepest last."""
    children: dict[int, list[int]] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:  # the process ended while we looked
            continue
        children.setdefault(int(fields[1]), []).append(int(stat.parent.name))
    found, queue = [], [pid]
    while queue:
        for child in children.get(queue.pop(), []):
            found.append(child)
            queue.append(child)
    return found


def _snakemake(command: list[str]) -> int:
    # Jobs call `vpr-smr <stage>`: the one installed beside this interpreter comes first on their PATH.
    env = {**os.environ, "PATH": os.pathsep.join([str(Path(sys.executable).parent), os.environ.get("PATH", "")])}
    # Snakemake stays in our process group, so that a signal to the whole group (Ctrl-C, a SIGKILL of the
    # group) reaches it and its jobs too.
    process = subprocess.Popen(command, env=env)

    def stop(signum: int, _frame: Any) -> None:
        # On SIGTERM Snakemake alone would wait for its running jobs to finish and go on writing results:
        # stop the jobs too (they remove their temporary files), then Snakemake.
        for pid in [*reversed(_descendants(process.pid)), process.pid]:
            try:
                os.kill(pid, signal.SIGTERM)
            except ProcessLookupError:
                pass

    previous = {sig: signal.signal(sig, stop) for sig in (signal.SIGTERM, signal.SIGINT)}
    try:
        status = process.wait()
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    return status
