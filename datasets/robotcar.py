"""Oxford RobotCar (ORC) Rain against Dusk, front-left stereo camera (SPEC section 1).

Layout: ``<root>/<run>/stereo/left/<timestamp>.png`` as the runs unpack from the RobotCar site. The
place-aligned lists of VPRSNN (``ORC_{Rain,Dusk}_timestamps.csv``, vendored in ``data/lists``) give the
timestamp of each aligned index; a timestamp may repeat (the alignment is by place, not by time).

The raw images are Bayer mosaics (one channel, GBRG pattern, like the robotcar-dataset-sdk's
``demosaic(img, 'gbrg')``). ``BayerTraverse.read`` demosaics them, so every reader of the pair gets RGB.
"""

from __future__ import annotations

import csv
import re
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from vpr_smr.core.constants import DEFAULT_TOLERANCE
from vpr_smr.datasets.base import DatasetError, Traverse, TraversePair, imread, resolved
from vpr_smr.datasets.check import checked_pair, read_list, require_root

LISTS = Path(__file__).resolve().parents[1] / "data" / "lists" / "from_VPRSNN"
REFERENCE_LIST = LISTS / "ORC_Rain_timestamps.csv"
QUERY_LIST = LISTS / "ORC_Dusk_timestamps.csv"
REFERENCE_RUN = "2015-10-29-12-18-17"  # Rain
QUERY_RUN = "2014-11-21-16-07-03"  # Dusk
CAMERA = Path("stereo") / "left"
SPLITS = {"train": (0, 500), "val": (500, 1000), "test": (1000, 2000)}

# OpenCV names a Bayer pattern by the 2x2 block that starts at pixel (1, 1), one row and one column in, not
# at (0, 0) as everyone else does. So a GBRG mosaic (row 0: G B, row 1: R G) is OpenCV's "BayerGR" (newer
# releases also call it COLOR_BayerGBRG2RGB, the same value). COLOR_BayerGB2RGB would be the GRBG pattern;
# tests/test_datasets_benchmarks.py checks the choice on a known image.
GBRG_TO_RGB = cv2.COLOR_BayerGR2RGB

_INDEX = re.compile(r"^(\d+)\.\w+$")
_TIMESTAMP = re.compile(r"^\d+(\.png)?$")


def demosaic_gbrg(raw: np.ndarray) -> np.ndarray:
    """RGB ``H x W x 3`` from a single-channel GBRG mosaic (bilinear, as the SDK's default)."""
    if raw.ndim == 3:
        raw = raw[:, :, 0]
    if raw.dtype == np.uint16:  # 16-bit exports: scale to 8 bits like every other image of the pipeline
        raw = np.round(raw / 257.0).astype(np.uint8)
    return cv2.cvtColor(raw, GBRG_TO_RGB)


def read_bayer_image(path: Path | str) -> np.ndarray:
    """RGB ``uint8`` of a RobotCar image: a one-channel mosaic is demosaiced, a 3-channel copy taken as is."""
    path = Path(path)
    # IMREAD_UNCHANGED: IMREAD_COLOR would silently turn the mosaic into a grey 3-channel image.
    image = imread(path, cv2.IMREAD_UNCHANGED)
    if image.dtype not in (np.uint8, np.uint16):
        raise DatasetError(f"image {path} has pixel type {image.dtype}; expected 8- or 16-bit")
    if image.ndim == 2 or image.shape[2] == 1:
        return demosaic_gbrg(image)
    if image.dtype == np.uint16:
        image = np.round(image / 257.0).astype(np.uint8)
    if image.shape[2] == 4:
        return cv2.cvtColor(image, cv2.COLOR_BGRA2RGB)
    return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)


@dataclass(frozen=True)
class BayerTraverse(Traverse):
    """Raw RobotCar images: ``read`` demosaics. Module-level, so it pickles for DataLoader workers."""

    def read(self, index: int) -> np.ndarray:
        return read_bayer_image(self.images[index])


def read_timestamps(list_file: Path | str, option: str) -> list[str]:
    """The ORC image names (``<timestamp>.png``) of a place-aligned list, by aligned index.

    Rows are ``<index>.png,<timestamp>.png`` (a header row is skipped); the index must count 0, 1, 2, ...
    A one-column list of timestamps is accepted too.
    """
    lines = read_list("robotcar", list_file, option)
    names: list[str] = []
    for number, row in enumerate(csv.reader(lines), start=1):
        fields = [f.strip() for f in row]
        if len(fields) == 1:
            if number == 1 and not _TIMESTAMP.match(fields[0]):
                continue  # header
            name = fields[0]
        else:
            match = _INDEX.match(fields[0])
            if match is None:
                if number == 1:
                    continue  # header
                raise DatasetError(
                    f"dataset 'robotcar': {list_file} row {number} is {','.join(fields)!r}; "
                    "expected '<index>.png,<timestamp>.png'"
                )
            if int(match.group(1)) != len(names):
                raise DatasetError(
                    f"dataset 'robotcar': {list_file} row {number} has index {fields[0]} where {len(names)} "
                    "was expected; the rows must list the aligned indices 0, 1, 2, ... in order"
                )
            name = fields[1]
        if not name.endswith(".png"):
            name += ".png"
        names.append(Path(name).name)
    return names


def robotcar(
    root: Path | str,
    reference_list: Path | str = REFERENCE_LIST,
    query_list: Path | str = QUERY_LIST,
    reference_run: str = REFERENCE_RUN,
    query_run: str = QUERY_RUN,
    splits: dict[str, tuple[int, int]] | None = None,
    tolerance: int = DEFAULT_TOLERANCE,
    check_files: bool = True,
) -> TraversePair:
    """Rain (reference) against Dusk (query): frame i of both lists shows the same place.

    ``check_files=False`` skips the missing-file check (``dataset check`` reports them instead).
    """
    fix = (
        "set datasets.robotcar.root (or --root) to the folder that holds the run folders "
        f"{reference_run}/ and {query_run}/, each with {CAMERA.as_posix()}/<timestamp>.png"
    )
    root = require_root("robotcar", root, fix)
    ref_names = read_timestamps(reference_list, "reference_list")
    query_names = read_timestamps(query_list, "query_list")
    if len(ref_names) != len(query_names):
        raise DatasetError(
            f"dataset 'robotcar': the place-aligned lists do not match: {reference_list} has "
            f"{len(ref_names)} places but {query_list} has {len(query_names)}; give lists of the same places"
        )
    reference = BayerTraverse(reference_run, tuple(root / reference_run / CAMERA / name for name in ref_names))
    query = BayerTraverse(query_run, tuple(root / query_run / CAMERA / name for name in query_names))
    source = (f"Oxford RobotCar: {resolved(root / reference_run / CAMERA)} (reference) and "
              f"{resolved(root / query_run / CAMERA)} (query), Bayer images demosaiced, the places of the "
              f"place-aligned lists {resolved(reference_list)} and {resolved(query_list)}")
    return checked_pair("robotcar", root, fix, reference, query, SPLITS if splits is None else splits, tolerance,
                        check_files, source)
