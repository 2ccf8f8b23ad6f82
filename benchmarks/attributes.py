"""Attributes of every query: the vectorised implementation against a per-query loop, in one process.

Prints the time of each and the speed-up as a ratio; the baseline is the literal per-query transcription of
SPEC section 5 used by the tests (tests/test_attributes.py::naive_attributes).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_attributes import naive_attributes  # noqa: E402

from vpr_smr.eval.attributes import query_attributes  # noqa: E402


def best_of(fn, repeats: int, *args) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn(*args)
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    rng = np.random.default_rng(0)
    print(f"{'R x Q':>12} {'L':>3} {'loop s':>9} {'vectorised s':>13} {'ratio':>7}")
    for size, seq_len in ((300, 4), (1000, 4), (1000, 10)):
        matrix = rng.random((size, size))
        loop = best_of(naive_attributes, 1, matrix, seq_len, 4)
        fast = best_of(query_attributes, 3, matrix, seq_len, 4)
        print(f"{size:>5} x {size:<5} {seq_len:>3} {loop:>9.3f} {fast:>13.4f} {loop / fast:>6.0f}x")
    matrix = rng.random((2576, 2576))  # the demo's test split
    fast = best_of(query_attributes, 1, matrix, 4, 4)
    print(f"2576 x 2576 (demo test split), L=4: {fast:.2f} s, {1e6 * fast / 2573:.0f} µs per query")


if __name__ == "__main__":
    main()
