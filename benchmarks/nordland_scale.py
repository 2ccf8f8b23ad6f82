"""The paper's full Nordland size through distances -> attributes -> labels in one run (issue 9, goal c).

Writes random descriptors of two traverses of N frames (N = 27592, the paper's Nordland) to HDF5, then runs the
``distances`` stage (faiss, block by block, into a chunked HDF5 matrix) and the ``attributes`` stage (attributes
and labels) in one child process, and reports its wall time per stage and its peak memory (goal: under 8 GB).

    python benchmarks/nordland_scale.py              # N = 27592, 512-D descriptors: needs ~3.2 GB of disk, minutes
    python benchmarks/nordland_scale.py --small      # N = 1500 (CI)
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import is_small, machine, python, run_measured  # noqa: E402

STAGES = """
import sys, time
from vpr_smr.eval.matching import distances
from vpr_smr.eval.matching import attributes
folder = sys.argv[1]
start = time.perf_counter()
distances.main(distances.DistancesJob(folder + "/descriptors.h5", "test", (0, int(sys.argv[2])), out=folder + "/D.h5"))
middle = time.perf_counter()
result = attributes.main(attributes.AttributesJob(folder + "/D.h5", int(sys.argv[3]), out=folder + "/attributes.h5"))
end = time.perf_counter()
print(f"distances {middle - start:.1f} s, attributes {end - middle:.1f} s, labels {result.labels[:5]}...")
"""


def write_descriptors(path: Path, n: int, dim: int) -> None:
    """Two traverses of ``n`` frames; the query is the reference plus noise, so that most matches are correct."""
    rng = np.random.default_rng(0)
    with h5py.File(path, "w") as f:
        reference = f.create_dataset("reference", (n, dim), dtype=np.float32)
        query = f.create_dataset("query", (n, dim), dtype=np.float32)
        for start in range(0, n, 4096):
            stop = min(n, start + 4096)
            block = rng.standard_normal((stop - start, dim), dtype=np.float32)
            reference[start:stop] = block
            query[start:stop] = block + 2 * rng.standard_normal(block.shape, dtype=np.float32)
        f.attrs.update({"distance": "l2", "dataset": "random", "method": "random", "checkpoint_sha256": "none",
                        "frames_sha256": "none"})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, default=27592)
    parser.add_argument("--dim", type=int, default=512)
    parser.add_argument("--seq-len", type=int, default=4)
    parser.add_argument("--folder", default=None, help="where the files go (default: a temporary folder)")
    parser.add_argument("--small", action="store_true", help="a tiny size (also VPR_SMR_BENCH_SMALL=1)")
    args = parser.parse_args()
    n, dim = (1500, 64) if is_small(args.small) else (args.frames, args.dim)
    print(f"{machine()}; {n} x {n} distances from {dim}-D descriptors, L = {args.seq_len}")
    with tempfile.TemporaryDirectory(prefix="vpr-smr-bench-", dir=args.folder) as folder:
        write_descriptors(Path(folder) / "descriptors.h5", n, dim)
        seconds, peak, output = run_measured(python(STAGES, folder, str(n), str(args.seq_len)))
        print(output.strip())
        matrix_gb = (Path(folder) / "D.h5").stat().st_size / 1e9
        with h5py.File(Path(folder) / "attributes.h5", "r") as f:
            labels = np.bincount(f["labels"][()], minlength=4)
    print(f"distances -> attributes -> labels: {seconds:.1f} s, peak memory {peak / 1e9:.2f} GB "
          f"(matrix {matrix_gb:.2f} GB on disk); labels 0..3: {labels.tolist()}")
    print(f"ratio peak / 8 GB: {peak / 8e9:.2f}x (goal < 1)")


if __name__ == "__main__":
    main()
