"""SeqSLAM's velocity search (method §11) against the fixed slope-1 matcher, time per query, in one process.

Goal (issue): velocity search costs at most the number of velocities times the fixed matcher per query, block-wise,
with the compiled kernel where it pays. On a random R x Q float32 matrix, read in the blocks of query columns that
``SequenceMatcher.map_blocks`` reads (``SequenceMatcher.block_queries(R)`` queries, ``+ L - 1`` columns each), this
times ``SequenceMatcher.block_features`` on those blocks

- with ``velocities=(1.0,)`` (the fixed matcher's fast path), on its numpy path and, when numba imports, forced onto
  its compiled kernel (``matcher.KERNEL = "numba"``);
- with velocity search, on its numpy twin and on its compiled kernel (``velocity_kernels``), for |V| = 3
  (``2^(k/4)``, k = -1..1) and |V| = 9 (k = -4..4), at L = 4 and L = 10;

and prints each ratio velocity / fixed and that ratio divided by |V| (the goal: <= 1), path against path (numpy
against numpy, compiled against compiled) and best against best (each side's faster path). Each time is the best of
``--repeat`` runs; numba's first dispatch happens before the timings.

    python benchmarks/velocity.py            # 3000 x 3000 and 1000 x 1000
    python benchmarks/velocity.py --small    # 300 x 300: checks that it runs (CI)
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import is_small, machine  # noqa: E402

from vpr_smr.eval.matching import matcher  # noqa: E402
from vpr_smr.eval.matching.matcher import SequenceMatcher, read_columns  # noqa: E402

VELOCITY_SETS = {3: tuple(2 ** (k / 4) for k in range(-1, 2)), 9: tuple(2 ** (k / 4) for k in range(-4, 5))}
SEQ_LENS = (4, 10)


def has_numba() -> bool:
    try:
        import numba  # noqa: F401
    except ImportError:
        return False
    return True


def blocks(matrix: np.ndarray, seq_len: int) -> list[np.ndarray]:
    """The matrix's blocks of query columns as ``map_blocks`` reads them (``read_columns``: ``(Wb, R)``)."""
    n_ref, n_query = matrix.shape
    step = SequenceMatcher.block_queries(n_ref)
    n_out = n_query - seq_len + 1
    return [read_columns(matrix, start, min(n_out, start + step) + seq_len - 1) for start in range(0, n_out, step)]


def block_features(block: np.ndarray, seq_len: int, n_ranks: int, velocities: tuple[float, ...]) -> object:
    return SequenceMatcher(seq_len, velocities).block_features(block, n_ranks)


def per_query(work: Callable[..., object], args: tuple[object, ...], parts: list[np.ndarray], n_queries: int,
              kernel: str, repeat: int) -> float:
    """Seconds per query of ``work(block, *args)`` over every block, on ``kernel``'s path (``matcher.KERNEL``),
    best of ``repeat``; the first block once before the timing (numba's first dispatch, the caches)."""
    previous, matcher.KERNEL = matcher.KERNEL, kernel
    try:
        work(parts[0], *args)
        best = np.inf
        for _ in range(repeat):
            start = time.perf_counter()
            for part in parts:
                work(part, *args)
            best = min(best, time.perf_counter() - start)
    finally:
        matcher.KERNEL = previous
    return float(best / n_queries)


def measure(size: int, repeat: int, kernels: tuple[str, ...]) -> None:
    matrix = np.random.default_rng(0).random((size, size), dtype=np.float32)
    print(f"\n{size} x {size} float32, blocks of {SequenceMatcher.block_queries(size)} queries")
    for seq_len in SEQ_LENS:
        parts = blocks(matrix, seq_len)
        n_queries = size - seq_len + 1
        fixed = {kind: per_query(block_features, (seq_len, 4, (1.0,)), parts, n_queries, kind, repeat)
                 for kind in kernels}
        line = ", ".join(f"{kind} {1e6 * seconds:.0f}" for kind, seconds in fixed.items())
        print(f"L = {seq_len:2}: fixed matcher per query (µs): {line}")
        for n_vel, velocities in VELOCITY_SETS.items():
            searched = {kind: per_query(block_features, (seq_len, 4, velocities), parts, n_queries, kind, repeat)
                        for kind in kernels}
            line = ", ".join(f"{kind} {1e6 * seconds:.0f}" for kind, seconds in searched.items())
            print(f"  |V| = {n_vel}: velocity search per query (µs): {line}")
            pairs = [(kind, kind) for kind in kernels] + [("best", "best")]
            fixed["best"], searched["best"] = min(fixed.values()), min(searched.values())
            for mine, theirs in pairs:
                ratio = searched[mine] / fixed[theirs]
                print(f"    ratio velocity / fixed ({mine:5}): {ratio:5.2f}x; / |V|: {ratio / n_vel:.2f} (goal <= 1)")
            del fixed["best"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", type=int, nargs="+", default=[3000, 1000], help="R = Q of each random matrix")
    parser.add_argument("--repeat", type=int, default=3, help="runs per timing, the best kept")
    parser.add_argument("--small", action="store_true", help="a tiny size (also VPR_SMR_BENCH_SMALL=1)")
    args = parser.parse_args()
    sizes, repeat = ([300], 1) if is_small(args.small) else (args.sizes, args.repeat)
    kernels = ("numpy", "numba") if has_numba() else ("numpy",)
    grids = ", ".join(f"|V| = {n}: {min(v):.3g}..{max(v):.3g}" for n, v in VELOCITY_SETS.items())
    print(f"{machine()}; velocities 2^(k/4), {grids}")
    for size in sizes:
        measure(size, repeat, kernels)


if __name__ == "__main__":
    main()
