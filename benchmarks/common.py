"""Helpers shared by the benchmarks: a child process's wall time and peak memory, and the machine's description."""

from __future__ import annotations

import os
import platform
import subprocess
import sys
import time


def run_measured(command: list[str], env: dict[str, str] | None = None) -> tuple[float, int, str]:
    """Run ``command``; return its wall time in seconds, its peak resident memory in bytes (``wait4``) and its output.

    Raises ``RuntimeError`` with its output when it fails.
    """
    start = time.perf_counter()
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                               env={**os.environ, **(env or {})})
    output = process.stdout.read()
    _, status, usage = os.wait4(process.pid, 0)
    seconds = time.perf_counter() - start
    process.returncode = os.waitstatus_to_exitcode(status)
    if process.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} failed ({process.returncode}):\n{output.decode(errors='replace')}")
    return seconds, usage.ru_maxrss * 1024, output.decode(errors="replace")  # ru_maxrss: kilobytes on Linux


def python(*code_and_args: str) -> list[str]:
    """A fresh interpreter running ``-c code args...``."""
    return [sys.executable, "-c", *code_and_args]


def machine() -> str:
    return f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}"


def is_small(flag: bool) -> bool:
    """``--small`` or ``VPR_SMR_BENCH_SMALL=1``: a tiny size that only checks the benchmark still runs (CI)."""
    return flag or os.environ.get("VPR_SMR_BENCH_SMALL", "") not in ("", "0")
