"""Running the Snakemake workflow that ships inside the package (Snakefile, rules, schema, profiles)."""

from __future__ import annotations

import fcntl
import hashlib
import math
import os
import re
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import datetime
from pathlib import Path
from typing import Any

import yaml

from vpr_smr.core.io import atomic_path
from vpr_smr.core.paths import overrides_path
from vpr_smr.pipeline import console, recipes
from vpr_smr.pipeline.config import ConfigError, load_config, parse_overrides
from vpr_smr.pipeline.plan import PLAN_ENV, preflight, save_plan

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


def check_cluster_interpreter(profile: Path, python: str | None = None) -> None:
    """Refuse, before any job, a profile that submits jobs to a cluster when the Python interpreter's path holds
    whitespace: Snakemake's executor interface writes that path into every job script unquoted, so each job would
    fail with "not found" (exit status 127) and the run would stop with empty logs."""
    python = sys.executable if python is None else python
    settings = "\n".join(f.read_text(errors="replace") for f in sorted(profile.glob("config*.yaml")))
    executor = re.search(r"^executor:\s*(\S+)", settings, re.MULTILINE)
    if executor is None or executor[1] in ("local", "dryrun", "touch") or not re.search(r"\s", python):
        return
    raise ValueError(f"profile {profile} submits jobs to {executor[1]}, but the Python of this environment is "
                     f"{python!r}, whose path holds a space: Snakemake writes that path into each job script "
                     "unquoted, so every job would fail. Install vpr-smr in an environment whose path has no spaces "
                     "(e.g. python -m venv ~/vpr-smr-env) to run on a cluster")


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


def configfiles(config: Path | str, overrides: dict[str, Any]) -> list[str]:
    """The configuration file and, with overrides, a second one that Snakemake merges into it as we merge them:
    `--config key=value` would reach the workflow with every nested value as a string. Named by its content, in
    Snakemake's folder of the working directory, which cluster jobs see too."""
    files = [str(config)]
    if overrides:
        text = yaml.safe_dump(overrides, sort_keys=True)
        path = overrides_path(hashlib.sha256(text.encode()).hexdigest())
        if not path.is_file():
            with atomic_path(path) as tmp:
                tmp.write_text(text)
        files.append(str(path))
    return files


def snakemake_command(config: Path | str, overrides: dict[str, Any], cores: int | None, profile: str,
                      dry_run: bool, extra: list[str], forcerun: list[str] | None = None) -> list[str]:
    command = [sys.executable, "-m", "snakemake", "--snakefile", str(SNAKEFILE)]
    if forcerun:  # before the next option, which ends its list of files
        command += ["--forcerun", *forcerun]
    command += ["--configfile", *configfiles(config, overrides), "--profile", str(profile_path(profile))]
    if cores is not None:
        command += ["--cores", str(cores)]
    if dry_run:
        command.append("--dry-run")
    return command + [a for a in extra if a != "--"]


def snakemake_log(folder: Path) -> Path:
    """A new file for Snakemake's output under the run folder's ``logs/``, named by the time of the run."""
    logs = folder / "logs"
    logs.mkdir(parents=True, exist_ok=True)
    stamp = datetime.now().strftime("%Y%m%d-%H%M%S")
    path, n = logs / f"snakemake-{stamp}.log", 1
    while path.exists():  # two runs within a second
        n += 1
        path = logs / f"snakemake-{stamp}-{n}.log"
    return path


def run(config: Path | str, cores: int | None = None, dry_run: bool = False, extra: list[str] | None = None,
        overrides: list[str] | None = None, profile: str = "local", verbose: bool = False) -> int:
    """Run the workflow of ``config`` (with ``key=value`` overrides); print where the results are.

    Shows a compact progress view and sends Snakemake's own output to ``<run folder>/logs/snakemake-<time>.log``;
    ``verbose`` shows Snakemake's output instead, unchanged.
    """
    since = math.floor(time.time())  # an output at least as new as this was made by this run (whole seconds:
    # some filesystems keep no finer times)
    parsed = parse_overrides(overrides)
    conf = load_config(config, parsed)
    plan = preflight(conf, str(config))  # a clean error before Snakemake starts, and the only check of this run
    for warning in plan.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    # Snakemake (and each cluster job that parses the workflow) reads the plan instead of checking again
    os.environ[PLAN_ENV] = str(save_plan(plan, conf).resolve())
    check_cluster_interpreter(profile_path(profile))
    # Each existing output's recorded recipe against the configuration's now, whatever Snakemake's own state says
    from snakemake.exceptions import RuleException, WorkflowError  # Snakemake's errors: imported only to run it

    try:
        jobs = recipes.workflow_jobs(SNAKEFILE, configfiles(config, parsed), conf.run_dir)
    except (WorkflowError, RuleException) as error:  # Snakemake, run next, says why in its own words
        # only Snakemake's own errors of building the graph: any other (a fault of the comparison) stops the run,
        # never a silent "Nothing to be done"
        print(f"warning: the outputs' recorded settings were not compared: {error}", file=sys.stderr)
        jobs = []
    rerun = recipes.stale(jobs, conf.run_dir)
    _carry_over(jobs, conf.run_dir, configfiles(config, parsed), [item.output for item in rerun])
    if rerun:
        print(f"{len(rerun)} job{'s' if len(rerun) > 1 else ''} made {'their' if len(rerun) > 1 else 'its'} outputs "
              f"with other settings or files than the configuration's now; {'would run' if dry_run else 'runs'} "
              "again (with what depends on them):")
        for item in rerun:
            print(f"  {item.output}: {item.reason}")
        sys.stdout.flush()
    command = snakemake_command(config, parsed, cores, profile, dry_run, list(extra or []),
                                [item.output for item in rerun])
    if dry_run:
        return _snakemake(command, None if verbose else console.DryRunView(sys.stdout, sys.stderr))
    # Our lock on the run folder replaces Snakemake's lock on the working folder: it names the run that holds
    # it and cannot outlive a killed run, so no `--unlock` is ever needed.
    with run_lock(conf.run_dir):
        view = None if verbose else console.ProgressView(snakemake_log(conf.run_dir), sys.stdout, sys.stderr)
        status = 1
        try:
            status = _snakemake(command + ["--nolock"], view)
        finally:  # also after a failed or stopped run: what it made is recorded, the rest keeps its record
            recipes.record(jobs, conf.run_dir, since, complete=status == 0 and not extra)
    if status == 0:
        out = conf.run_dir
        print(f"\ntables:  {out / 'tables'}\nfigures: {out / 'figures'}")
        if (out / "report.html").is_file():
            print(f"report:  {out / 'report.html'}")
    return status


def _carry_over(jobs: list[recipes.Job], run_dir: Path, files: list[str], forcerun: list[str]) -> None:
    """Keep Snakemake from making again the outputs that an earlier version made exactly as this one would but whose
    params Snakemake did not store (``recipes.carry_over``; ``forcerun``: the outputs run again for their recipes);
    said in one line. A dry run does it too, so that it shows what the run will do; while another run holds the run
    folder, that run does it instead."""
    carried = recipes.carried_over(jobs, run_dir)
    if not carried:
        return
    try:
        with run_lock(run_dir):
            kept = recipes.carry_over(carried, run_dir, SNAKEFILE, files, forcerun)
    except ConfigError:  # the run folder is in use: that run carries them over
        return
    print(f"{kept} output{'' if kept == 1 else 's'} made by an earlier version of vpr-smr with the settings and files "
          "of now: carried over, not computed again")
    sys.stdout.flush()


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


def _terminate(pid: int) -> None:
    """SIGTERM to every process below ``pid``, deepest first, then to ``pid``.

    On SIGTERM Snakemake alone would wait for its running jobs to finish and go on writing results: the jobs are
    stopped too (they remove their temporary files), then Snakemake.
    """
    for process in [*reversed(_descendants(pid)), pid]:
        try:
            os.kill(process, signal.SIGTERM)
        except ProcessLookupError:
            pass


def _snakemake(command: list[str], view: console.View | None = None) -> int:
    """Run Snakemake, its output to ``view`` (or unchanged to ours); stop it and its jobs on SIGINT or SIGTERM."""
    # Jobs call `vpr-smr <stage>`: the one installed beside this interpreter comes first on their PATH.
    env = {**os.environ, "PATH": os.pathsep.join([str(Path(sys.executable).parent), os.environ.get("PATH", "")])}
    process: subprocess.Popen[bytes] | subprocess.Popen[str] | None = None
    stopped: list[int] = []

    def stop(signum: int, _frame: Any) -> None:
        stopped.append(signum)
        if view is not None:
            view.stopped = signum  # the view says so once Snakemake has stopped, and shows nothing more
        if process is not None:
            _terminate(process.pid)

    # Installed before Snakemake starts, so that no Ctrl-C can leave it running without us.
    previous = {sig: signal.signal(sig, stop) for sig in (signal.SIGTERM, signal.SIGINT)}
    try:
        # Snakemake stays in our process group, so that a signal to the whole group (Ctrl-C, a SIGKILL of the
        # group) reaches it and its jobs too.
        if view is None:
            process = subprocess.Popen(command, env=env)
        else:
            # One pipe for both streams (a dry run logs to stdout, a run to stderr), in UTF-8 whatever the locale
            process = piped = subprocess.Popen(command, env={**env, "PYTHONIOENCODING": "utf-8"},
                                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, encoding="utf-8",
                                               errors="replace")
        if stopped:  # the signal came while it started
            _terminate(process.pid)
        try:
            status = process.wait() if view is None else console.follow(piped, view)
        except BaseException:  # the view failed (a closed stdout): no Snakemake left running unwatched
            _terminate(process.pid)
            raise
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    return 128 + stopped[0] if stopped else status
