"""The live matcher's time per frame at R references against the batch attributes' time per query (issue 9).

Both run the same code on the same random float32 distances; the batch reads blocks of query columns, the live
matcher one window of L columns per frame.

    python benchmarks/live.py              # R = 27592 (the paper's Nordland), 300 frames, L = 4
    python benchmarks/live.py --small      # R = 2000, 40 frames (CI)
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import is_small, machine  # noqa: E402

from vpr_smr.eval.matching.attributes import query_features  # noqa: E402
from vpr_smr.eval.matching.live import LiveMatcher  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--references", type=int, default=27592)
    parser.add_argument("--frames", type=int, default=300)
    parser.add_argument("--seq-len", type=int, default=4)
    parser.add_argument("--small", action="store_true", help="a tiny size (also VPR_SMR_BENCH_SMALL=1)")
    args = parser.parse_args()
    n_ref, frames = (2000, 40) if is_small(args.small) else (args.references, args.frames)
    matrix = np.random.default_rng(0).random((n_ref, frames), dtype=np.float32)
    print(f"{machine()}; R = {n_ref}, {frames} frames, L = {args.seq_len}")
    start = time.perf_counter()
    batch = query_features(matrix, args.seq_len)
    batch_s = (time.perf_counter() - start) / len(batch.queries)
    matcher = LiveMatcher(args.seq_len)
    columns = np.ascontiguousarray(matrix.T)  # a robot's frames arrive one by one
    times = []
    for a in range(frames):
        start = time.perf_counter()
        result = matcher.step_distances(columns[a])
        if result is not None:
            times.append(time.perf_counter() - start)
            assert result.sequence_match == batch.sequence_match[a - args.seq_len + 1]
    live_s = float(np.median(times))
    print(f"batch, per query:                {1e6 * batch_s:9.0f} µs")
    print(f"live, per frame (median):        {1e6 * live_s:9.0f} µs")
    print(f"ratio live per frame / batch per query: {live_s / batch_s:.2f}x")


if __name__ == "__main__":
    main()
