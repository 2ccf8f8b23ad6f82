"""Small trees in the layouts of the full benchmarks (Nordland, Oxford RobotCar, SFU Mountain), made of the real
64x32 Nordland sample frames, with short frame lists in the published formats; RobotCar frames are turned back into
GBRG Bayer mosaics (the benchmark loaders' and the paper configuration's tests)."""

from __future__ import annotations

import shutil
from pathlib import Path

import cv2
import numpy as np
from helpers import REPO

from vpr_smr.datasets import read_image

SAMPLE = REPO / "data" / "nordland_sample"
# Frames 500.. of the sample: daylight, textured (the first frames are a dark tunnel).
SAMPLE_NAMES = [f"images-{n:05d}.png" for n in range(500, 800, 10)]
RAIN, DUSK = "2015-10-29-12-18-17", "2014-11-21-16-07-03"


def sample_rgb(season: str, name: str) -> np.ndarray:
    return read_image(SAMPLE / season / name)


def colourise(rgb: np.ndarray) -> np.ndarray:
    """The sample is grey; give each channel its own tone curve so that a red/blue swap shows."""
    grey = rgb[:, :, 0].astype(np.float64)
    return np.stack([grey, 0.6 * grey + 40, 0.25 * grey + 10], axis=-1).clip(0, 255).astype(np.uint8)


def mosaic_gbrg(rgb: np.ndarray) -> np.ndarray:
    """The raw camera image of ``rgb``: one channel, row 0 = G B G B ..., row 1 = R G R G ..."""
    raw = np.empty(rgb.shape[:2], np.uint8)
    raw[0::2, 0::2] = rgb[0::2, 0::2, 1]
    raw[0::2, 1::2] = rgb[0::2, 1::2, 2]
    raw[1::2, 0::2] = rgb[1::2, 0::2, 0]
    raw[1::2, 1::2] = rgb[1::2, 1::2, 1]
    return raw


def write_rgb(path: Path, rgb: np.ndarray) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    assert cv2.imwrite(str(path), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))


def write_lines(path: Path, lines: list[str], newline: str = "\n") -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(newline.join(lines).encode() + newline.encode())
    return path


def nordland_tree(root: Path, names: list[str]) -> None:
    for season in ("summer", "winter"):
        (root / season).mkdir(parents=True, exist_ok=True)
        for name in names:
            shutil.copy(SAMPLE / season / name, root / season / name)


def nordland_lists(tmp: Path, names: list[str], query_names: list[str] | None = None) -> dict[str, Path]:
    """Lists in Patch-NetVLAD's format (``./nordland/<season>/images-NNNNN.png``)."""
    return {
        "reference_list": write_lines(tmp / "index.txt", [f"./nordland/summer/{n}" for n in names]),
        "query_list": write_lines(
            tmp / "query.txt", [f"./nordland/winter/{n}" for n in query_names or names]
        ),
    }


def robotcar_tree(root: Path, stamps: dict[str, list[int]]) -> dict[tuple[str, int], np.ndarray]:
    """Raw GBRG mosaics ``<root>/<run>/stereo/left/<timestamp>.png``; returns each file's colour image."""
    truth = {}
    for run, run_stamps in stamps.items():
        season = "summer" if run == RAIN else "winter"
        for k, stamp in enumerate(sorted(set(run_stamps))):
            rgb = colourise(sample_rgb(season, SAMPLE_NAMES[k % len(SAMPLE_NAMES)]))
            path = root / run / "stereo" / "left" / f"{stamp}.png"
            path.parent.mkdir(parents=True, exist_ok=True)
            assert cv2.imwrite(str(path), mosaic_gbrg(rgb))
            truth[run, stamp] = rgb
    return truth


def robotcar_list(path: Path, stamps: list[int]) -> Path:
    """VPRSNN's format: a header, then ``000123.png,<timestamp>.png``, CRLF line ends."""
    rows = ["Image from this repo,Image from ORC"] + [f"{i:06d}.png,{s}.png" for i, s in enumerate(stamps)]
    return write_lines(path, rows, newline="\r\n")


def sfu_tree(root: Path, frames: dict[str, int]) -> dict[str, list[str]]:
    """JPEG frames ``<root>/part_x/stereo_right/{dry,dusk}/frames/x001.jpg``; returns the list lines."""
    lines: dict[str, list[str]] = {"dry": [], "dusk": []}
    for condition, season in (("dry", "summer"), ("dusk", "winter")):
        k = 0
        for part, count in frames.items():
            for n in range(1, count + 1):
                rel = f"{part}/stereo_right/{condition}/frames/{part[-1]}{n:03d}.jpg"
                write_rgb(root / rel, sample_rgb(season, SAMPLE_NAMES[k % len(SAMPLE_NAMES)]))
                lines[condition].append(f"./SFU-Mountain/{rel}")
                k += 1
    return lines
