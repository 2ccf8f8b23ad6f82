"""Extraction speed of every backend: batched forward passes against a batch-size-1 loop, in one process.

Weights are random (the speed of a network does not depend on its weights), images synthetic at each
backend's working size. Prints images per second and the batched/loop ratio, on the CPU and, when one is
present, on the GPU.

    python benchmarks/extraction.py [--images 16] [--batch 8] [--backends sad hog ...]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import torch
from vpr_smr.descriptors import backend_class

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


def images_per_second(backend, tensors: list[torch.Tensor], batch: int) -> float:
    start = time.perf_counter()
    for i in range(0, len(tensors), batch):
        backend.forward(torch.stack(tensors[i : i + batch]))
    if backend.device.type == "cuda":
        torch.cuda.synchronize()
    return len(tensors) / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--images", type=int, default=16)
    parser.add_argument("--batch", type=int, default=8)
    parser.add_argument("--backends", nargs="*", default=list(BACKENDS))
    args = parser.parse_args()
    devices = ["cpu"] + (["cuda"] if torch.cuda.is_available() else [])
    rng = np.random.default_rng(0)
    images = [rng.integers(0, 256, (*FRAME, 3), dtype=np.uint8) for _ in range(args.images)]
    threads = torch.get_num_threads()
    print(f"torch {torch.__version__}, {threads} threads; {args.images} images of {FRAME[1]}x{FRAME[0]}")
    print(f"{'backend':<24} {'device':<6} {'dim':>6} {'loop img/s':>11} {'batch img/s':>12} {'ratio':>6}")
    for name in args.backends:
        for device in devices:
            backend = backend_class(name)({**BACKENDS[name], "device": device})
            if hasattr(backend, "prepare"):
                backend.prepare()
            tensors = [torch.as_tensor(backend.preprocess(image)) for image in images]
            dim = backend.forward(tensors[0][None]).shape[1]  # also warms up
            loop = images_per_second(backend, tensors, 1)
            batched = images_per_second(backend, tensors, args.batch)
            print(f"{name:<24} {device:<6} {dim:>6} {loop:>11.1f} {batched:>12.1f} {batched / loop:>5.2f}x")


if __name__ == "__main__":
    main()
