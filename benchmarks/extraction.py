"""Extraction speed of every backend: the pipeline's batched DataLoader path against a batch-size-1 loop.

Both read the same PNG files from disk and include decoding and preprocessing. The baseline decodes,
preprocesses and runs the network one image at a time in the main process; the pipeline path is
``descriptors.extract.compute_descriptors`` (worker processes, batches). Weights are random (the speed of a
network does not depend on its weights); the images are synthetic 640x480 frames. Prints images per second and
the ratio, on the CPU and, when one is present, on the GPU.

    python benchmarks/extraction.py [--images 16] [--batch 8] [--backends sad hog ...]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
import torch

from vpr_smr.datasets import Traverse
from vpr_smr.descriptors import backend_class
from vpr_smr.descriptors.extract import compute_descriptors

os.environ.setdefault("TQDM_DISABLE", "1")  # the pipeline's progress bars would interleave with the table

# Backend -> settings for the benchmark; full-size backends get a typical 480x640 frame.
BACKENDS = {
    "sad": {},
    "hog": {},
    "efficientnet_lite0_gem": {},
    "cosplace": {"fc_output_dim": 2048},
    "eigenplaces": {"fc_output_dim": 2048},
    "mixvpr": {},
    "netvlad": {},
    "apgem": {"max_size": 640},
    "salad": {},
}
FRAME = (480, 640)


def loop_images_per_second(backend, traverse: Traverse) -> float:
    start = time.perf_counter()
    for index in range(len(traverse)):
        backend.describe(traverse.read(index))
    if backend.device.type == "cuda":
        torch.cuda.synchronize()
    return len(traverse) / (time.perf_counter() - start)


def pipeline_images_per_second(backend, traverse: Traverse, batch: int, workers: int) -> float:
    start = time.perf_counter()
    compute_descriptors(traverse, backend, batch_size=batch, num_workers=workers)
    return len(traverse) / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--images", type=int, default=16)
    parser.add_argument("--batch", type=int, default=None, help="default: the pipeline's (8 on CPU, 32 on GPU)")
    parser.add_argument("--workers", type=int, default=None, help="default: the pipeline's")
    parser.add_argument("--backends", nargs="*", default=list(BACKENDS))
    args = parser.parse_args()
    devices = ["cpu"] + (["cuda"] if torch.cuda.is_available() else [])
    rng = np.random.default_rng(0)
    folder = Path(tempfile.mkdtemp(prefix="vpr-smr-bench-"))
    paths = []
    for i in range(args.images):
        paths.append(folder / f"{i:04d}.png")
        cv2.imwrite(str(paths[-1]), rng.integers(0, 256, (*FRAME, 3), dtype=np.uint8))
    traverse = Traverse("bench", tuple(paths))
    threads = torch.get_num_threads()
    print(f"torch {torch.__version__}, {threads} threads; {args.images} PNG images of {FRAME[1]}x{FRAME[0]}; "
          f"pipeline: batch {args.batch or 'default'}, {'default' if args.workers is None else args.workers} workers")
    print(f"{'backend':<24} {'device':<6} {'dim':>6} {'loop img/s':>11} {'pipeline img/s':>15} {'ratio':>6}")
    for name in args.backends:
        for device in devices:
            backend = backend_class(name)({**BACKENDS[name], "device": device})
            if hasattr(backend, "prepare"):
                backend.prepare()
            dim = backend.describe(traverse.read(0)).shape[0]  # also warms up
            loop = loop_images_per_second(backend, traverse)
            pipeline = pipeline_images_per_second(backend, traverse, args.batch, args.workers)
            print(f"{name:<24} {device:<6} {dim:>6} {loop:>11.1f} {pipeline:>15.1f} {pipeline / loop:>5.2f}x",
                  flush=True)


if __name__ == "__main__":
    main()
