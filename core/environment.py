"""The numeric environment a result was computed in: CPU, BLAS and thread counts, OpenCV's (where the process
loaded it) and NumPy's versions.

Information, not a setting: every stage records it under ``ENVIRONMENT_KEY`` (an HDF5 attribute of the descriptor
files, an entry of the predictor's and the evaluation's ``meta``), and nothing compares it to decide whether an
output must be computed again. It says why a number may differ on another machine (method document, "Reproducibility
across machines"): the classic descriptors are the same bytes everywhere; the l2 and cosine distances go through the
BLAS, whose kernel (``thread_pools[].kernel``, chosen by CPU) and thread count change their rounding, and with it
the demo's Table I (the predictor's training through the BLAS changed no number there).
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import sys
from collections.abc import MutableMapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vpr_smr.core.records import Record

# The key under which every output records its environment (``NumericEnvironment.to_json()``).
ENVIRONMENT_KEY = "environment"

# CPU flags that decide which SIMD path OpenCV, NumPy and OpenBLAS take (the whole list is kept as a hash).
SIMD_FLAGS = ("sse4_1", "sse4_2", "avx", "avx2", "fma", "f16c", "avx512f", "avx512bw", "avx512vl", "avx512_vnni",
              "avx512_bf16", "amx_tile", "neon", "asimd", "sve")
CPUINFO = Path("/proc/cpuinfo")


@dataclass(frozen=True)
class ThreadPool(Record):
    """One native thread pool of the process (threadpoolctl): a BLAS or an OpenMP runtime."""

    api: str  # "blas" or "openmp"
    library: str  # e.g. "openblas", "mkl", "libgomp"
    version: str
    threads: int
    kernel: str  # the BLAS's kernel for this CPU (OpenBLAS: "Haswell", "SkylakeX", ...); "" when not reported


@dataclass(frozen=True)
class NumericEnvironment(Record):
    """Where the numbers were computed; ``cpu_flags_sha256``: SHA-256 of the sorted flag list (first 16 digits)."""

    machine: str
    cpu_model: str
    cpu_count: int
    simd: tuple[str, ...]
    cpu_flags_sha256: str
    thread_pools: tuple[ThreadPool, ...]
    # None: the process never loaded OpenCV, so none of its numbers went through it (importing it only to record it
    # cost a stage such as `vpr-smr attributes` 20-40 ms, and listed its BLAS among pools the stage never used)
    opencv: str | None
    opencv_optimised: bool | None
    numpy: str
    python: str


def _cpu() -> tuple[str, list[str]]:
    """The CPU's model name and flags, from /proc/cpuinfo (Linux), else what ``platform`` says and no flags."""
    model, flags = platform.processor() or platform.machine(), list[str]()
    try:
        text = CPUINFO.read_text(errors="replace")
    except OSError:
        return model, flags
    for line in text.splitlines():
        key, _, value = line.partition(":")
        key = key.strip()
        if key in ("model name", "Processor", "cpu model") and value.strip():
            model = value.strip()
        elif key in ("flags", "Features") and not flags:
            flags = value.split()
        if key == "" and flags:  # the first processor's block is enough
            break
    return model, flags


def _thread_pools() -> tuple[ThreadPool, ...]:
    """The BLAS and OpenMP libraries this process has loaded, with their thread counts and kernels."""
    from threadpoolctl import threadpool_info  # type: ignore[import-untyped]  # ships no type information

    pools = []
    for info in threadpool_info():
        pools.append(ThreadPool(str(info.get("user_api", "")), str(info.get("internal_api", "")),
                                str(info.get("version") or ""), int(info.get("num_threads") or 0),
                                str(info.get("architecture") or "")))
    return tuple(sorted(set(pools), key=lambda pool: (pool.api, pool.library, pool.version, pool.kernel)))


def current() -> NumericEnvironment:
    """This process's numeric environment now (the libraries loaded so far: call it when the work is done)."""
    import numpy as np

    cv2 = sys.modules.get("cv2")

    model, flags = _cpu()
    present = set(flags)
    return NumericEnvironment(
        machine=platform.machine(),
        cpu_model=model,
        cpu_count=os.cpu_count() or 0,
        simd=tuple(flag for flag in SIMD_FLAGS if flag in present),
        cpu_flags_sha256=hashlib.sha256(" ".join(sorted(present)).encode()).hexdigest()[:16],
        thread_pools=_thread_pools(),
        opencv=None if cv2 is None else str(cv2.__version__),
        opencv_optimised=None if cv2 is None else bool(cv2.useOptimized()),
        numpy=np.__version__,
        python=platform.python_version(),
    )


def record_in(attrs: MutableMapping[str, Any]) -> None:
    """Write ``current()`` into an HDF5 file's attributes (``attrs``) as JSON text under ``ENVIRONMENT_KEY``, as
    ``core.io.atomic_h5`` writes a dict: call it once the work is done, so the libraries it used are loaded."""
    attrs[ENVIRONMENT_KEY] = json.dumps(current().to_json(), sort_keys=True)


def recorded() -> dict[str, Any]:
    """``{ENVIRONMENT_KEY: current() as JSON data}``: the entry every output's meta or attributes add."""
    return {ENVIRONMENT_KEY: current().to_json()}
