"""Each sequence matcher at the paper's Nordland scale: ``vpr-smr attributes --matcher NAME`` on an R x Q float32
``.npy`` (default 27592 x 27592, 2.8 GiB), in a fresh process per matcher, against the fixed matcher (``seqslam``,
velocities [1.0]) run in the same round.

Goals (issue 35): each matcher within 10x the fixed matcher's time; peak memory at most 2x the matrix + 300 MB.
The matrix is uniform noise, halved along the diagonal (the aligned traverses' true matches), written block by
block so that making it never holds it in memory twice; the page cache is warmed before the first run.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np
from common import is_small, machine, python, run_measured

from vpr_smr.eval.matching.matchers import MATCHERS

LOAD_AND_SUM = "import sys, numpy as np; print(float(np.load(sys.argv[1]).sum()))"
BASELINE = "seqslam"


def write_matrix(path: Path, size: int, columns: int = 1024) -> None:
    """``size x size`` float32 noise in [0, 1), halved on the diagonal band |r - q| <= 2."""
    out = np.lib.format.open_memmap(path, mode="w+", dtype=np.float32, shape=(size, size))
    rng = np.random.default_rng(0)
    rows = np.arange(size)[:, None]
    for lo in range(0, size, columns):
        hi = min(size, lo + columns)
        block = rng.random((size, hi - lo), dtype=np.float32)
        block[np.abs(rows - np.arange(lo, hi)[None, :]) <= 2] *= 0.5
        out[:, lo:hi] = block
    out.flush()
    del out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--size", type=int, default=27592)
    parser.add_argument("--seq-len", type=int, default=4)
    parser.add_argument("--matchers", nargs="+", default=sorted(set(MATCHERS) - {BASELINE}),
                        help="the matchers compared with seqslam (default: every built-in one)")
    parser.add_argument("--repeat", type=int, default=1, help="rounds; the best of each matcher is kept")
    parser.add_argument("--small", action="store_true", help="a tiny size (also VPR_SMR_BENCH_SMALL=1)")
    args = parser.parse_args()
    size = 300 if is_small(args.small) else args.size
    print(f"{machine()}; {size} x {size} float32, L = {args.seq_len}")
    with tempfile.TemporaryDirectory(prefix="vpr-smr-bench-") as folder:
        path = Path(folder) / "D.npy"
        write_matrix(path, size)
        matrix_mb = path.stat().st_size / 2**20
        run_measured(python(LOAD_AND_SUM, str(path)))  # warm the page cache

        def command(name: str) -> list[str]:
            return [sys.executable, "-m", "vpr_smr.pipeline.cli", "attributes", "--distances", str(path),
                    "--seq-len", str(args.seq_len), "--matcher", name, "--out", str(Path(folder) / f"{name}.h5")]

        best: dict[str, tuple[float, int]] = {}
        for _ in range(1 if is_small(args.small) else max(1, args.repeat)):
            for name in (BASELINE, *args.matchers):
                seconds, rss, _ = run_measured(command(name))
                if name not in best or seconds < best[name][0]:
                    best[name] = (seconds, max(rss, best.get(name, (0.0, 0))[1]))
    base_s = best[BASELINE][0]
    print(f"matrix {matrix_mb:.0f} MB; goal: time <= 10x {BASELINE}, peak <= 2 x matrix + 300 MB "
          f"= {2 * matrix_mb + 300:.0f} MB")
    for name, (seconds, rss) in best.items():
        print(f"{name:14} {seconds:8.2f} s  peak {rss / 2**20:7.0f} MB  "
              f"ratio time / {BASELINE}: {seconds / base_s:5.2f}x  "
              f"peak - 2 x matrix: {rss / 2**20 - 2 * matrix_mb:6.0f} MB")


if __name__ == "__main__":
    main()
