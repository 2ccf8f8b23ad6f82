"""A throw-away one-node SLURM cluster for the tests (no test is collected from this module).

`start_cluster(workdir)` installs Debian's SLURM and MUNGE packages when missing (as root), writes a MUNGE key and a
`slurm.conf` for one node (this host) and one default partition, starts `munged`, `slurmctld` and `slurmd`, and waits
until `sinfo` shows the node idle. `SlurmCluster.stop()` (or leaving the `with` block) cancels the cluster's jobs and
stops exactly the daemons it started.

Isolation instead of reuse: every cluster gets its own MUNGE socket, its own free TCP ports, its own state, spool
and log folders under `workdir/vpr_smr_slurm/`, and a unique `ClusterName`. Clients find it only through the
`SLURM_CONF` variable of `SlurmCluster.env()`, so a system-wide SLURM or MUNGE, or a cluster left running by an
earlier run, is never touched and never in the way. Daemons an earlier run left behind (the test process was killed
before `stop()`) are recognised by the owner file beside their configuration: when that owner process is gone,
`start_cluster` stops them first, so they do not pile up.

Errors (packages cannot be installed, a daemon exits, the node never becomes idle) raise `SlurmError` with the
reason and the daemons' log tails: a test using this module fails, it is never skipped silently.
"""

from __future__ import annotations

import os
import secrets
import shutil
import signal
import socket
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path

PACKAGES = ("slurmctld", "slurmd", "slurm-client", "munge")
# Programs the cluster needs, with the Debian package that ships each.
PROGRAMS = {"munged": "munge", "slurmctld": "slurmctld", "slurmd": "slurmd", "sinfo": "slurm-client",
            "sbatch": "slurm-client", "squeue": "slurm-client", "scancel": "slurm-client", "srun": "slurm-client"}
SUBDIR = "vpr_smr_slurm"  # marks every path of a cluster started here; used to find a dead run's daemons
PARTITION = "main"
# The executor plugin's job step (snakemake-executor-plugin-slurm-jobstep) runs `srun` with every SLURM_* variable
# but a few removed, SLURM_CONF included, so srun inside a job only finds the configuration at SLURM's default
# path: the cluster links it there while it runs.
DEFAULT_CONF = Path("/etc/slurm/slurm.conf")


class SlurmError(RuntimeError):
    """The one-node cluster could not be installed, started or stopped; the message says why."""


@dataclass
class SlurmCluster:
    """A running one-node cluster. Use `env()` for every SLURM client call and for Snakemake."""

    root: Path  # workdir/vpr_smr_slurm
    conf: Path
    cluster_name: str
    node: str
    partition: str
    cpus: int
    memory_mb: int
    startup_s: float = 0.0
    procs: dict[str, subprocess.Popen] = field(default_factory=dict)
    linked_default: bool = False  # DEFAULT_CONF is our symlink (removed by stop())

    def env(self, base: dict[str, str] | None = None) -> dict[str, str]:
        """`base` (default: this process's environment) with SLURM_CONF pointing at this cluster."""
        env = dict(os.environ if base is None else base)
        # A caller running inside a SLURM job would otherwise leak its job's settings into sbatch.
        for key in [k for k in env if k.startswith("SLURM_")]:
            del env[key]
        env["SLURM_CONF"] = str(self.conf)
        return env

    def run(self, *args: str, timeout: float = 30) -> subprocess.CompletedProcess:
        """Run a SLURM client command (`sinfo`, `squeue`, ...) against this cluster."""
        return subprocess.run(list(args), env=self.env(), capture_output=True, text=True, timeout=timeout)

    def log_tails(self, lines: int = 25) -> str:
        return _log_tails(self.root / "log", lines)

    def stop(self, timeout: float = 15) -> None:
        """Cancel this cluster's jobs, then stop the daemons this object started (and only those)."""
        if not self.procs:
            return
        if _alive(self.procs.get("slurmctld")):
            # Jobs first, so that no job step outlives slurmd.
            try:
                self.run("scancel", "--full", "--quiet", "--user", str(os.getuid()), timeout=10)
                deadline = time.monotonic() + 5
                while time.monotonic() < deadline:
                    out = self.run("squeue", "--noheader", "--states=RUNNING,COMPLETING,PENDING", timeout=10)
                    if out.returncode != 0 or not out.stdout.strip():
                        break
                    time.sleep(0.3)
            except (OSError, subprocess.SubprocessError):
                pass  # the daemons are stopped below all the same
        # Reverse start order: slurmd, slurmctld, then munged (both SLURM daemons need MUNGE until they exit).
        for name in ("slurmd", "slurmctld", "munged"):
            proc = self.procs.get(name)
            if proc is not None:
                _terminate(proc, timeout)
        self.procs.clear()
        if self.linked_default and DEFAULT_CONF.is_symlink() and DEFAULT_CONF.resolve() == self.conf.resolve():
            DEFAULT_CONF.unlink()
        self.linked_default = False
        (self.root / "owner.pid").unlink(missing_ok=True)

    def __enter__(self) -> SlurmCluster:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


def start_cluster(workdir: Path, timeout: float = 60, install: bool = True) -> SlurmCluster:
    """Start a one-node cluster with its files under `workdir/vpr_smr_slurm/`; raise SlurmError if it cannot."""
    started = time.monotonic()
    ensure_installed(install)
    reap_stale_daemons()
    root = Path(workdir).resolve() / SUBDIR
    if root.exists():
        # A previous cluster in the same folder: stop what it left running, then start from clean folders.
        _stop_daemons_under(root)
        shutil.rmtree(root)
    for sub in ("munge", "state", "spool", "log", "run"):
        (root / sub).mkdir(parents=True, mode=0o700)
    # munged refuses a key or socket in a folder others can write, and warns when others cannot enter the socket's.
    (root / "munge").chmod(0o755)
    (root / "owner.pid").write_text(f"{os.getpid()}\n")

    node = _short_hostname()
    cpus = os.cpu_count() or 1
    memory_mb = _memory_mb()
    name = "vprsmr" + secrets.token_hex(4)  # SLURM lower-cases cluster names; keep it short and lower-case
    ctld_port, slurmd_port = _free_ports(2)
    key = root / "munge" / "munge.key"
    _write_private(key, secrets.token_bytes(1024))
    socket_path = root / "munge" / "munge.socket"
    conf = root / "slurm.conf"
    _write_private(conf, _slurm_conf(root, name, node, cpus, memory_mb, ctld_port, slurmd_port, socket_path).encode(),
                   mode=0o644)

    cluster = SlurmCluster(root=root, conf=conf, cluster_name=name, node=node, partition=PARTITION, cpus=cpus,
                           memory_mb=memory_mb)
    log = root / "log"
    try:
        _link_default_conf(conf)
        cluster.linked_default = True
        cluster.procs["munged"] = _spawn(
            ["munged", "--foreground", "--force", f"--key-file={key}", f"--socket={socket_path}",
             f"--pid-file={root / 'run' / 'munged.pid'}", f"--log-file={log / 'munged.log'}",
             f"--seed-file={root / 'munge' / 'munged.seed'}"], log / "munged.out", cluster)
        _wait_for(lambda: socket_path.exists(), 10, "munged did not create its socket", cluster)
        cluster.procs["slurmctld"] = _spawn(["slurmctld", "-D", "-i", "-f", str(conf)], log / "slurmctld.out", cluster)
        cluster.procs["slurmd"] = _spawn(["slurmd", "-D", "-f", str(conf), "-N", node], log / "slurmd.out", cluster)
        _wait_for(lambda: _node_state(cluster) == "idle", timeout,
                  f"node {node} did not become idle in {timeout:.0f} s", cluster)
    except BaseException:
        cluster.stop()
        raise
    cluster.startup_s = time.monotonic() - started
    return cluster


def ensure_installed(install: bool = True) -> None:
    """Install the Debian packages when a program is missing (needs root and apt-get); SlurmError if impossible."""
    missing = sorted({pkg for prog, pkg in PROGRAMS.items() if not _which(prog)})
    if not missing:
        return
    if not install:
        raise SlurmError(f"SLURM programs missing (Debian packages {', '.join(missing)}); install them with "
                         f"`apt-get install {' '.join(PACKAGES)}`")
    if os.geteuid() != 0 or not shutil.which("apt-get"):
        raise SlurmError(f"SLURM is not installed (missing Debian packages: {', '.join(missing)}) and cannot be "
                         f"installed here (needs root and apt-get); run `apt-get install {' '.join(PACKAGES)}`")
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    # A fresh machine has no package lists; `apt-get update` takes seconds.
    for cmd in (["apt-get", "update"], ["apt-get", "install", "-y", "--no-install-recommends", *PACKAGES]):
        out = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=600)
        if out.returncode != 0:
            raise SlurmError(f"`{' '.join(cmd)}` failed (exit {out.returncode}):\n{_tail(out.stdout + out.stderr)}")
    still = [prog for prog in PROGRAMS if not _which(prog)]
    if still:
        raise SlurmError(f"after installing {' '.join(PACKAGES)} these programs are still missing: {still}")


def reap_stale_daemons() -> list[int]:
    """Stop munged/slurmctld/slurmd started by this module for a process that no longer exists. Returns their PIDs.

    Only daemons whose command line names a `.../vpr_smr_slurm/...` path are considered, and only when the
    `owner.pid` beside them is missing or names a dead process: a live test's cluster is never touched.
    """
    reaped = []
    for pid, argv in _daemon_processes():
        root = _root_of(argv)
        if root is None or _owner_alive(root):
            continue
        _kill_pid(pid)
        reaped.append(pid)
    return reaped


# --- internals -------------------------------------------------------------------------------------------------


def _link_default_conf(conf: Path) -> None:
    """Point DEFAULT_CONF at `conf`, replacing only a link left by a dead run of this module."""
    if DEFAULT_CONF.is_symlink():
        target = Path(os.readlink(DEFAULT_CONF))
        root = _root_of([str(target)])
        if root is None:
            raise SlurmError(f"{DEFAULT_CONF} links to {target}, not to a test cluster's configuration; remove the "
                             "link (or run the tests on a machine that is not a SLURM node)")
        if _owner_alive(root) and root != conf.parent:
            raise SlurmError(f"another test cluster is running (its configuration {target}, owner process "
                             f"{(root / 'owner.pid').read_text().strip()}); only one can run at a time, because "
                             f"srun inside jobs reads {DEFAULT_CONF}")
        DEFAULT_CONF.unlink()
    elif DEFAULT_CONF.exists():
        raise SlurmError(f"{DEFAULT_CONF} exists: this machine already has a SLURM configuration, which the test "
                         "cluster would replace (srun inside jobs reads that path); run the SLURM test on a machine "
                         "without one, or move it away")
    DEFAULT_CONF.parent.mkdir(parents=True, exist_ok=True)
    tmp = DEFAULT_CONF.with_name(f".slurm.conf.{os.getpid()}.tmp")
    tmp.unlink(missing_ok=True)
    tmp.symlink_to(conf)
    os.replace(tmp, DEFAULT_CONF)


def _slurm_conf(root: Path, name: str, node: str, cpus: int, memory_mb: int, ctld_port: int, slurmd_port: int,
                munge_socket: Path) -> str:
    return f"""\
# One-node test cluster written by tests/slurm_cluster.py; clients use it through SLURM_CONF.
ClusterName={name}
SlurmctldHost={node}(127.0.0.1)
SlurmctldPort={ctld_port}
SlurmdPort={slurmd_port}
# Root runs the daemons: no `slurm` user, and the state folders under the work folder stay writable.
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
# This cluster's own munged, so that the system's (if any) or another test's is never used.
AuthInfo=socket={munge_socket}
StateSaveLocation={root / 'state'}
SlurmdSpoolDir={root / 'spool'}
SlurmctldPidFile={root / 'run' / 'slurmctld.pid'}
SlurmdPidFile={root / 'run' / 'slurmd.pid'}
SlurmctldLogFile={root / 'log' / 'slurmctld.log'}
SlurmdLogFile={root / 'log' / 'slurmd.log'}
SlurmctldDebug=info
SlurmdDebug=info
# No systemd and no cgroup plugin in a container or VM sandbox: track processes through /proc only. task/affinity
# pins each job to the CPUs it was given (sched_setaffinity, no cgroups), so `nproc` in a job equals its threads.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/affinity
JobAcctGatherType=jobacct_gather/none
# No accounting database: `sacct` cannot see finished jobs, so Snakemake must poll with squeue (see the profile).
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU_Memory
# squeue keeps finished jobs this long; the Snakemake plugin only trusts squeue when it is >= 3x its first poll.
MinJobAge=600
ReturnToService=2
SlurmdTimeout=60
InactiveLimit=0
KillWait=5
NodeName={node} NodeAddr=127.0.0.1 NodeHostname={node} CPUs={cpus} RealMemory={memory_mb} State=UNKNOWN
PartitionName={PARTITION} Nodes={node} Default=YES MaxTime=INFINITE State=UP
"""


def _which(prog: str) -> str | None:
    # The daemons live in /usr/sbin, which a non-root PATH may lack.
    return shutil.which(prog) or shutil.which(prog, path="/usr/sbin:/usr/bin:/sbin:/bin")


def _spawn(argv: list[str], out: Path, cluster: SlurmCluster) -> subprocess.Popen:
    exe = _which(argv[0])
    if exe is None:
        raise SlurmError(f"{argv[0]} not found on PATH or in /usr/sbin")
    with open(out, "ab") as sink:
        # Own session: a Ctrl-C in the test's terminal reaches the test, which then stops the cluster in order.
        return subprocess.Popen([exe, *argv[1:]], stdin=subprocess.DEVNULL, stdout=sink, stderr=subprocess.STDOUT,
                                env=cluster.env(), start_new_session=True)


def _wait_for(ready, timeout: float, what: str, cluster: SlurmCluster) -> None:
    deadline = time.monotonic() + timeout
    while True:
        for name, proc in cluster.procs.items():
            if proc.poll() is not None:
                raise SlurmError(f"{name} exited with status {proc.returncode} while starting the test cluster "
                                 f"(files in {cluster.root}).\n{cluster.log_tails()}")
        if ready():
            return
        if time.monotonic() > deadline:
            detail = None
            if cluster.procs.get("slurmctld"):
                detail = cluster.run("sinfo", "-N", "-o", "%N %T %E", timeout=10)
            sinfo = f"sinfo: {(detail.stdout + detail.stderr).strip()}\n" if detail else ""
            raise SlurmError(f"{what} (files in {cluster.root}).\n{sinfo}{cluster.log_tails()}")
        time.sleep(0.25)


def _node_state(cluster: SlurmCluster) -> str:
    try:
        out = cluster.run("sinfo", "--noheader", "--Node", "--format=%T", "--nodes", cluster.node, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return ""
    return out.stdout.strip().rstrip("*~#!%$@^-") if out.returncode == 0 else ""


def _short_hostname() -> str:
    name = socket.gethostname().split(".")[0]
    if not name:
        raise SlurmError("this host has no name (`hostname -s` is empty); SLURM needs one for its node")
    return name


def _memory_mb() -> int:
    with open("/proc/meminfo") as fh:
        for line in fh:
            if line.startswith("MemTotal:"):
                total = int(line.split()[1]) // 1024
                # slurmd drains a node whose configured memory exceeds what it finds; stay 5% (>= 256 MB) below.
                return max(256, total - max(256, total // 20))
    raise SlurmError("cannot read MemTotal from /proc/meminfo")


def _free_ports(count: int) -> list[int]:
    socks = []
    try:
        for _ in range(count):
            s = socket.socket()
            s.bind(("127.0.0.1", 0))
            socks.append(s)
        return [s.getsockname()[1] for s in socks]
    finally:
        for s in socks:
            s.close()


def _write_private(path: Path, data: bytes, mode: int = 0o400) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, mode)
    with os.fdopen(fd, "wb") as fh:
        fh.write(data)
    os.replace(tmp, path)


def _tail(text: str, lines: int = 25) -> str:
    return "\n".join(text.splitlines()[-lines:])


def _log_tails(log_dir: Path, lines: int) -> str:
    parts = []
    for path in sorted(log_dir.glob("*")):
        text = path.read_text(errors="replace").strip()
        if text:
            parts.append(f"--- {path.name} (last {lines} lines) ---\n{_tail(text, lines)}")
    return "\n".join(parts) or f"(no daemon logs in {log_dir})"


def _alive(proc: subprocess.Popen | None) -> bool:
    return proc is not None and proc.poll() is None


def _terminate(proc: subprocess.Popen, timeout: float) -> None:
    if proc.poll() is not None:
        return
    proc.terminate()
    try:
        proc.wait(timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(5)


def _daemon_processes() -> list[tuple[int, list[str]]]:
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            argv = (entry / "cmdline").read_bytes().decode(errors="replace").split("\0")
        except OSError:
            continue
        if argv and os.path.basename(argv[0]) in ("munged", "slurmctld", "slurmd") and _root_of(argv):
            found.append((int(entry.name), argv))
    return found


def _root_of(argv: list[str]) -> Path | None:
    """The `.../vpr_smr_slurm` folder named in a daemon's arguments, if any."""
    for arg in argv:
        value = arg.split("=", 1)[-1]
        marker = f"/{SUBDIR}/"
        if marker in value:
            return Path(value[: value.index(marker) + len(marker) - 1])
    return None


def _owner_alive(root: Path) -> bool:
    try:
        pid = int((root / "owner.pid").read_text().strip())
    except (OSError, ValueError):
        return False
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _stop_daemons_under(root: Path) -> None:
    for pid, argv in _daemon_processes():
        if _root_of(argv) == root:
            _kill_pid(pid)


def _kill_pid(pid: int, timeout: float = 10) -> None:
    try:
        os.kill(pid, signal.SIGTERM)
    except ProcessLookupError:
        return
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if not Path(f"/proc/{pid}").exists() or _is_zombie(pid):
            return
        time.sleep(0.1)
    try:
        os.kill(pid, signal.SIGKILL)
    except ProcessLookupError:
        pass


def _is_zombie(pid: int) -> bool:
    try:
        return (Path(f"/proc/{pid}") / "stat").read_text().split(")")[-1].split()[0] == "Z"
    except (OSError, IndexError):
        return True
