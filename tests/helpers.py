"""Helpers shared by the tests (not part of the package): the tests' folders, small files in the pipeline's formats,
a tiny plugin network, frames of known colours, query features by hand and a researcher's own route."""

from __future__ import annotations

from dataclasses import fields
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from vpr_smr.core.io import atomic_h5
from vpr_smr.eval.matching.attributes import QueryFeatures
from vpr_smr.eval.matching.io import open_distance_matrix
from vpr_smr.eval.matching.matchers import MatcherSpec

# The tests folder and the checkout, wherever a test module sits below tests/ (this file stays in tests/).
TESTS = Path(__file__).resolve().parent
REPO = TESTS.parent


def seqslam(*velocities: float) -> MatcherSpec:
    """The ``seqslam`` matcher searching ``velocities`` (none: its default, [1.0])."""
    return MatcherSpec.of("seqslam", {"velocities": list(velocities)} if velocities else {})


SEQSLAM_PROVENANCE = {"name": "seqslam", "settings": {"velocities": [1.0]}}  # the default matcher, as files record it


def write_distance_matrix(path: Path | str, distance_matrix: np.ndarray, provenance: dict[str, Any]) -> None:
    """A references x queries matrix in the distances stage's HDF5 layout."""
    with atomic_h5(path, provenance) as f:
        f.create_dataset("distance_matrix", data=distance_matrix.astype(np.float32))


def read_distance_matrix(path: Path | str) -> np.ndarray:
    """A references x queries matrix from our HDF5 file (``distance_matrix``) or a user's ``.npy``, in memory."""
    with open_distance_matrix(path) as matrix:
        return np.asarray(matrix[()] if isinstance(matrix, h5py.Dataset) else np.array(matrix))


# --- a tiny learned backend, written as a plugin module (``module:TinyNet``) that tests and jobs import ---

TINY_NET = '''
from dataclasses import dataclass

import torch
from vpr_smr.core.settings import setting
from vpr_smr.descriptors.base import TorchBackend, to_tensor


@dataclass(frozen=True)
class TinyNetSettings:
    channels: int = setting(8, "the convolution's output channels")
    kernel: int = setting(3, "the convolution's kernel size")


class TinyNet(TorchBackend):
    """A convolution and global average pooling: a learned backend whose weights come from a file."""

    name = "tiny_net"
    Settings = TinyNetSettings

    def build_model(self):
        conv = torch.nn.Conv2d(3, self.conf["channels"], self.conf["kernel"])
        return torch.nn.Sequential(conv, torch.nn.AdaptiveAvgPool2d(1), torch.nn.Flatten())

    def preprocess(self, image):
        return to_tensor(image)  # full size: frames of different sizes cannot share a batch
'''


def tiny_net_model(channels: int = 8, kernel: int = 3) -> Any:
    """The network of ``TINY_NET``'s backend with these settings (to write its checkpoints)."""
    import torch

    conv = torch.nn.Conv2d(3, channels, kernel)
    return torch.nn.Sequential(conv, torch.nn.AdaptiveAvgPool2d(1), torch.nn.Flatten())


# --- frames whose colour says which they are (the match inspector's tests) ---

COLOUR_FRAMES = 24  # frames per traverse of the ``colour_frames`` fixture


def reference_colour(i: int) -> tuple[int, int, int]:
    return (20 + 9 * i, 240 - 7 * i, 101)


def query_colour(i: int) -> tuple[int, int, int]:
    return (99, 15 + 8 * i, 230 - 5 * i)


# --- query features by hand (the restoration, evaluation and ablation tests) ---


def make_features(sequence_correct, rank_correct, **overrides) -> QueryFeatures:
    """QueryFeatures by hand; ``all_single_correct`` is filled in when the dataclass has that field."""
    n = len(sequence_correct)
    rank_correct = np.asarray(rank_correct, dtype=bool)
    values = {
        "queries": np.arange(1, n + 1),
        "attributes": np.zeros((n, rank_correct.shape[1], 4)),
        "rank_references": np.tile(np.arange(rank_correct.shape[1]) + 100, (n, 1)),  # never the removed match
        "single_match": np.zeros(n, int),
        "sequence_match": np.arange(n),
        "sequence_distance": np.array([0.1, 0.2, 0.3, 0.4])[:n],
        "labels": np.zeros(n, int),
        "single_correct": np.ones(n, bool),
        "sequence_correct": np.asarray(sequence_correct, dtype=bool),
        "rank_correct": rank_correct,
        "sequence_min": 0.1,
        "sequence_max": 0.4,
        "all_single_correct": np.ones(n + 1, bool),
        **overrides,
    }
    names = {f.name for f in fields(QueryFeatures)}
    return QueryFeatures(**{k: v for k, v in values.items() if k in names})


# --- a researcher's own route and the README's examples (the own-data tests) ---

def sample_names() -> list[str]:
    """The file names of the shipped Nordland sample, sorted."""
    from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT

    return sorted(p.name for p in (DEFAULT_ROOT / "summer").iterdir())


def write_route(folder: Path, n: int, start: int = 1000, name: str = "img{}.jpg", scale: int = 1) -> tuple[Path, Path]:
    """``n`` real frames of the shipped sample (summer as reference, winter as query) as JPEGs named without
    zero padding (img1.jpg .. imgN.jpg), the way a camera or a script often names them; ``scale`` enlarges them."""
    import cv2

    from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT

    names = sample_names()
    reference, query = folder / "reference", folder / "query"
    for path, season in ((reference, "summer"), (query, "winter")):
        path.mkdir(parents=True)
        for i in range(n):
            image = cv2.imread(str(DEFAULT_ROOT / season / names[start + i]))
            image = cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_CUBIC)
            cv2.imwrite(str(path / name.format(i + 1)), image)
    return reference, query


DOC_PAGES = (REPO / "README.md", *sorted((REPO / "docs").glob("*.md")))
# A block's marker, the line above its fence: ``<!-- NAME -->`` or ``<!-- NAME: a note -->`` (format: the name's
# pattern); doc_block and tests/unit/test_docs_blocks.py read it.
DOC_MARKER = r"<!-- ({name})(?:[:\s][^>]*)?-->\n"


def doc_block(marker: str) -> str:
    """The fenced block that follows ``<!-- marker ... -->`` in the README or a page of docs/ (each marker names one
    block of them all; tests/unit/test_docs_blocks.py checks that every block has one and a test that reads it)."""
    import re

    pattern = re.compile(DOC_MARKER.format(name=re.escape(marker)) + r"```[a-z]*\n(.*?)```", re.S)
    found = [match.group(2) for page in DOC_PAGES for match in pattern.finditer(page.read_text())]
    assert len(found) == 1, f"{len(found)} blocks after <!-- {marker} --> in README.md and docs/ (one expected)"
    return found[0]


def doc_page_blocks(page: str) -> list[tuple[str, str]]:
    """Every fenced block of ``docs/<page>`` in order, as (language, text), MyST directives (```{toctree}) left out:
    for a test that runs a whole page (the Python walkthrough, the extending recipes)."""
    import re

    text = (REPO / "docs" / page).read_text()
    return re.findall(r"^```([a-z]*)\n(.*?)^```", text, re.S | re.M)


def bootstrap_indices(n: int, draws: int) -> np.ndarray:
    """The queries the tool's bootstrap draws (method §8.7), written out naively: runs of b consecutive queries
    (the smallest b with b**3 >= n), wrapping around, ceil(n / b) runs a draw, the first n kept; the runs' starts
    are the first ``draws`` rows of ``default_rng(0).integers(0, n, (1000, runs))``."""
    block = next(b for b in range(1, n + 2) if b**3 >= n)
    runs = -(-n // block)
    starts = np.random.default_rng(0).integers(0, n, (1000, runs))[:draws]
    return np.array([[(s + j) % n for s in row for j in range(block)][:n] for row in starts])


def session_alive(pid: int, seconds: float = 15.0) -> list[str]:
    """The processes still in the session of ``pid`` (a stopped run's), waiting up to ``seconds`` for them to end:
    the jobs' processes end on the signal they were passed, and on a loaded machine one may take a few seconds."""
    import subprocess
    import time

    deadline = time.monotonic() + seconds
    while True:
        time.sleep(0.5)
        alive = subprocess.run(["pgrep", "-s", str(pid)], capture_output=True, text=True).stdout.split()
        if not alive or time.monotonic() > deadline:
            return alive
