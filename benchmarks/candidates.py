"""What the training-free scorers' candidates (method §12) cost the attributes stage (issue 28: at most 20 % more
time per query), on R x R float32 matrices, in one run.

For each size: ``query_features`` in this process with ``n_candidates`` 0 (what the stage computed before) and 12
(the default settings' candidates), on each path of the matcher (numpy, and the compiled kernels when numba
imports), interleaved so that the machine's load touches both alike, best and median of ``--repeat``; then the whole
command ``vpr-smr attributes`` with ``--candidates 0`` and the default, interleaved, best of ``--repeat``, on the
default path (numpy below ``matcher.KERNEL_MIN_VALUES`` values, compiled above) and forced onto each path.

    python benchmarks/candidates.py                       # 3000 x 3000 and 9000 x 9000, L = 4
    python benchmarks/candidates.py --sizes 3000 --repeat 7
    python benchmarks/candidates.py --small               # 400 x 400: checks that it runs (CI)
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import is_small, machine, run_measured  # noqa: E402

from vpr_smr.core.constants import candidates_needed  # noqa: E402
from vpr_smr.eval.matching import matcher  # noqa: E402
from vpr_smr.eval.matching.attributes import query_features  # noqa: E402

CANDIDATES = candidates_needed()  # 12: r_window 10, spread_k 10


def has_numba() -> bool:
    try:
        import numba  # noqa: F401
    except ImportError:
        return False
    return True


def in_process(matrix: np.ndarray, seq_len: int, kind: str, repeat: int) -> dict[int, list[float]]:
    """Seconds of ``query_features`` on the ``kind`` path with 0 and with ``CANDIDATES`` candidates, interleaved."""
    matcher.KERNEL = kind
    times: dict[int, list[float]] = {0: [], CANDIDATES: []}
    try:
        query_features(matrix[:40, :40], seq_len, n_candidates=CANDIDATES)  # numba's first dispatch, untimed
        for _ in range(repeat):
            for n in times:
                start = time.perf_counter()
                query_features(matrix, seq_len, n_candidates=n)
                times[n].append(time.perf_counter() - start)
    finally:
        matcher.KERNEL = None
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", type=int, nargs="+", default=[3000, 9000])
    parser.add_argument("--seq-len", type=int, default=4)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--small", action="store_true", help="a tiny size (also VPR_SMR_BENCH_SMALL=1)")
    args = parser.parse_args()
    sizes = [400] if is_small(args.small) else args.sizes
    repeat = 1 if is_small(args.small) else args.repeat
    kinds = ["numpy", "numba"] if has_numba() else ["numpy"]
    print(f"{machine()}; float32, L = {args.seq_len}; candidates 0 against {CANDIDATES}; best / median of {repeat}")
    for size in sizes:
        n_queries = size - args.seq_len + 1
        matrix = np.random.default_rng(0).random((size, size), dtype=np.float32)
        for kind in kinds:
            times = in_process(matrix, args.seq_len, kind, repeat)
            cells = []
            for n, seconds in times.items():
                cells.append(f"{n:2d}: {1e6 * min(seconds) / n_queries:6.1f} / "
                             f"{1e6 * statistics.median(seconds) / n_queries:6.1f} µs")
            ratio = min(times[CANDIDATES]) / min(times[0])
            print(f"{size} x {size}, {kind:5} in process, per query  {'   '.join(cells)}   ratio {ratio:.3f}")
        with tempfile.TemporaryDirectory(prefix="vpr-smr-bench-") as folder:
            path = Path(folder) / "D.npy"
            np.save(path, matrix)
            commands = {n: [sys.executable, "-m", "vpr_smr.pipeline.cli", "attributes", "--distances", str(path),
                            "--seq-len", str(args.seq_len), "--candidates", str(n), "--out",
                            str(Path(folder) / f"a{n}.h5")] for n in (0, CANDIDATES)}
            run_measured(commands[0])  # the page cache and numba's on-disk cache warm for both
            for path_name in ("default", *kinds):
                env = {} if path_name == "default" else {"VPR_SMR_KERNEL": path_name}
                whole: dict[int, list[float]] = {n: [] for n in commands}
                for _ in range(repeat):
                    for n, command in commands.items():
                        whole[n].append(run_measured(command, env=env)[0])
                cells = [f"{n:2d}: {min(seconds):5.2f} s ({1e6 * min(seconds) / n_queries:6.1f} µs per query)"
                         for n, seconds in whole.items()]
                print(f"{size} x {size}, vpr-smr attributes ({path_name} path)  {'   '.join(cells)}   "
                      f"ratio {min(whole[CANDIDATES]) / min(whole[0]):.3f}")


if __name__ == "__main__":
    main()
