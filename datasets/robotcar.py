"""Oxford RobotCar (ORC) Rain against Dusk, front-left stereo camera (method §1).

Layout: ``<root>/<run>/stereo/left/<timestamp>.png`` as the runs unpack from the RobotCar site. The
place-aligned lists of VPRSNN (``ORC_{Rain,Dusk}_timestamps.csv``, vendored in ``data/lists``) give the
timestamp of each aligned index; a timestamp may repeat (the alignment is by place, not by time).

The raw images are Bayer mosaics (one channel, GBRG pattern, like the robotcar-dataset-sdk's
``demosaic(img, 'gbrg')``). ``BayerTraverse.read`` demosaics them, so every reader of the pair gets RGB.

``positions: ins`` (method §11) takes the raw runs instead of the place-aligned lists: every ``every``-th image of
``<run>/stereo/left``, positioned by the run's INS log (``<run>/gps/ins.csv`` of the SDK: a header row, then
``timestamp,...,northing,easting,...`` rows; timestamps in microseconds, as the image names). Each image's
(easting, northing) is interpolated linearly at its timestamp; a match is correct within ``radius`` metres.
"""

from __future__ import annotations

import csv
import re
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from vpr_smr.core.constants import DEFAULT_TOLERANCE
from vpr_smr.core.settings import REQUIRED, setting
from vpr_smr.datasets.base import (
    SHIPPED_DATA,
    DatasetError,
    Traverse,
    TraversePair,
    imread,
    list_files,
    positions_pairing,
    resolved,
)
from vpr_smr.datasets.check import checked_pair, read_list, require_root
from vpr_smr.datasets.positions import METRES

LISTS = SHIPPED_DATA / "lists" / "from_VPRSNN"
REFERENCE_LIST = LISTS / "ORC_Rain_timestamps.csv"
QUERY_LIST = LISTS / "ORC_Dusk_timestamps.csv"
REFERENCE_RUN = "2015-10-29-12-18-17"  # Rain
QUERY_RUN = "2014-11-21-16-07-03"  # Dusk
CAMERA = Path("stereo") / "left"
SPLITS = {"train": (0, 500), "val": (500, 1000), "test": (1000, 2000)}
INS = Path("gps") / "ins.csv"
# The raw runs' ground truth without a `radius` setting: the usual VPR choice (Pitts30k, MSLS and
# VPR-methods-evaluation count a match within 25 m as correct).
DEFAULT_RADIUS = 25.0
POSITIONS = ("ins",)

# OpenCV names a Bayer pattern by the 2x2 block that starts at pixel (1, 1), one row and one column in, not
# at (0, 0) as everyone else does. So a GBRG mosaic (row 0: G B, row 1: R G) is OpenCV's "BayerGR" (newer
# releases also call it COLOR_BayerGBRG2RGB, the same value). COLOR_BayerGB2RGB would be the GRBG pattern;
# tests/unit/test_datasets_benchmarks.py checks the choice on a known image.
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


@dataclass(frozen=True)
class RobotCarSettings:
    """The settings of the ``robotcar`` loader."""

    root: Path | str = setting(REQUIRED, "the folder that holds the run folders")
    reference_list: Path | str | None = setting(
        None, "the timestamps of the reference images in order (null: VPRSNN's place-aligned list, shipped); not "
              "with positions: ins")
    query_list: Path | str | None = setting(None, "the same for the query images")
    reference_run: str = setting(
        REFERENCE_RUN, "the reference run's folder under root (default: Rain, 2015-10-29-12-18-17)")
    query_run: str = setting(QUERY_RUN, "the query run's folder under root (default: Dusk, 2014-11-21-16-07-03)")
    positions: str | None = setting(None, "ins: the raw runs, positioned by gps/ins.csv (method §11)")
    every: int = setting(1, "with positions: ins: keep one image in every N of the raw runs")


def robotcar(
    root: Path | str,
    reference_list: Path | str | None = None,
    query_list: Path | str | None = None,
    reference_run: str = REFERENCE_RUN,
    query_run: str = QUERY_RUN,
    splits: dict[str, tuple[int, int]] | None = None,
    tolerance: int = DEFAULT_TOLERANCE,
    check_files: bool = True,
    positions: str | None = None,
    every: int = 1,
    radius: float | None = None,
) -> TraversePair:
    """Rain (reference) against Dusk (query): frame i of both lists shows the same place (the default); or, with
    ``positions="ins"``, every ``every``-th image of both raw runs, matched by INS position within ``radius``
    metres (default 25).

    ``reference_list`` and ``query_list`` default to VPRSNN's place-aligned lists (``data/lists``).
    ``check_files=False`` skips the missing-file check (``dataset check`` reports them instead).
    """
    fix = (
        "set datasets.robotcar.root (or --root) to the folder that holds the run folders "
        f"{reference_run}/ and {query_run}/, each with {CAMERA.as_posix()}/<timestamp>.png"
    )
    root = require_root("robotcar", root, fix)
    if positions is not None:
        if reference_list or query_list:
            raise DatasetError("dataset 'robotcar': positions: ins takes every image of the raw runs, so the "
                               "place-aligned lists (reference_list, query_list) do not apply; remove them")
        return raw_runs(root, reference_run, query_run, positions, every, radius, splits)
    if every != 1 or radius is not None:
        setting = f"every: {every}" if every != 1 else f"radius: {radius}"
        raise DatasetError(f"dataset 'robotcar': {setting} applies to the raw runs (positions: ins); the "
                           "place-aligned lists are frame-aligned (ground truth: tolerance, in frames)")
    reference_list = REFERENCE_LIST if reference_list is None else reference_list
    query_list = QUERY_LIST if query_list is None else query_list
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


# --- the raw runs, positioned by their INS logs (method §11) ---


@dataclass(frozen=True)
class InsLog:
    """A run's INS log: timestamps (microseconds, increasing) and (easting, northing) in metres of one UTM zone."""

    path: Path
    timestamps: np.ndarray  # int64
    positions: np.ndarray  # (n, 2) float64: easting, northing
    zone: str  # the utm_zone column's value, e.g. "30U" ("" when the log has no such column)


def _ins_columns(path: Path, header: list[str]) -> dict[str, int]:
    columns = {name.strip().lower(): i for i, name in enumerate(header)}
    missing = [name for name in ("timestamp", "northing", "easting") if name not in columns]
    if missing:
        raise DatasetError(f"{path}, line 1: the header has no column {', '.join(missing)}; an INS log of the "
                           "RobotCar SDK starts with timestamp,ins_status,latitude,longitude,altitude,northing,"
                           "easting,...")
    return columns


def read_ins(path: Path | str) -> InsLog:
    """The INS log of a run (``gps/ins.csv``), sorted by time; errors name the file and line."""
    path = Path(path)
    if not path.is_file():
        raise DatasetError(f"dataset 'robotcar': INS log {path} not found; positions: ins needs each run's "
                           f"{INS.as_posix()} (the RobotCar site's GPS/INS download, unpacked into the run folder)")
    with path.open(newline="") as file:
        rows = csv.reader(file)
        header = next(rows, None)
        if header is None:
            raise DatasetError(f"{path} is empty: expected the SDK's INS log (a header row, then one row per reading)")
        columns = _ins_columns(path, header)
        stamps: list[int] = []
        values: list[tuple[float, float]] = []
        zones: set[str] = set()
        zone_column = columns.get("utm_zone")
        for number, row in enumerate(rows, start=2):
            if not row:
                continue
            try:
                stamps.append(int(row[columns["timestamp"]]))
                values.append((float(row[columns["easting"]]), float(row[columns["northing"]])))
            except (ValueError, IndexError):
                raise DatasetError(f"{path}, line {number}: {','.join(row)!r} has no integer timestamp and numeric "
                                   "northing and easting; the file is cut short or not an INS log") from None
            if zone_column is not None and zone_column < len(row):
                zones.add(row[zone_column].strip())
    return _ins_log(path, np.array(stamps, dtype=np.int64), np.array(values, dtype=np.float64).reshape(-1, 2), zones)


def _ins_log(path: Path, stamps: np.ndarray, positions: np.ndarray, zones: set[str]) -> InsLog:
    if len(stamps) < 2:
        raise DatasetError(f"{path} holds {len(stamps)} readings; interpolating positions needs at least two")
    if len(zones) > 1:
        raise DatasetError(f"{path}: the readings lie in {len(zones)} UTM zones ({', '.join(sorted(zones))}); "
                           "positions of one run must share a zone")
    order = np.argsort(stamps, kind="stable")
    stamps, positions = stamps[order], positions[order]
    repeated = stamps[1:][np.diff(stamps) == 0]
    if len(repeated):
        raise DatasetError(f"{path}: {len(repeated)} timestamps occur twice (e.g. {repeated[0]}); each reading "
                           "needs its own time")
    return InsLog(path, stamps, positions, next(iter(zones), ""))


def run_images(root: Path, run: str, every: int) -> tuple[tuple[Path, ...], np.ndarray]:
    """Every ``every``-th image of a raw run's camera folder, in time order, with its timestamp."""
    folder = root / run / CAMERA
    if not folder.is_dir():
        raise DatasetError(f"dataset 'robotcar': {folder} not found; positions: ins needs the run {run!r} under "
                           f"root {root}, with {CAMERA.as_posix()}/<timestamp>.png and {INS.as_posix()}")
    images = [p for p in folder.iterdir() if p.suffix.lower() == ".png" and not p.name.startswith(".")]
    bad = [p.name for p in images if not p.stem.isdigit()]
    if bad:
        raise DatasetError(f"dataset 'robotcar': {len(bad)} images of {folder} are not named <timestamp>.png: "
                           f"{list_files(bad)}; move them out of the run's camera folder")
    if not images:
        raise DatasetError(f"dataset 'robotcar': {folder} holds no <timestamp>.png images")
    images.sort(key=lambda p: int(p.stem))
    kept = images[::every]
    return tuple(kept), np.array([int(p.stem) for p in kept], dtype=np.int64)


def _interpolated(ins: InsLog, stamps: np.ndarray) -> np.ndarray:
    """(easting, northing) at each timestamp, linear between the two INS readings around it."""
    return np.stack([np.interp(stamps, ins.timestamps, ins.positions[:, axis]) for axis in (0, 1)], axis=1)


def _positioned_run(root: Path, run: str, every: int) -> tuple[BayerTraverse, str, str]:
    """A raw run's traverse with INS positions, its UTM zone and a note of the images dropped at its ends.

    Images taken before the INS log's first reading or after its last have no position to interpolate
    (extrapolating a vehicle's path is a guess): they are dropped, and the note says how many. They can only lie
    at the ends of the run, so the frames kept remain one contiguous sequence.
    """
    images, stamps = run_images(root, run, every)
    ins = read_ins(root / run / INS)
    inside = (stamps >= ins.timestamps[0]) & (stamps <= ins.timestamps[-1])
    if not inside.any():
        raise DatasetError(f"dataset 'robotcar': none of the {len(images)} images of run {run!r} lies within the "
                           f"time of its INS log {ins.path} ({ins.timestamps[0]} to {ins.timestamps[-1]}); is it "
                           "the log of this run?")
    before, after = int(np.sum(stamps < ins.timestamps[0])), int(np.sum(stamps > ins.timestamps[-1]))
    note = f"{before} images before its INS log's first reading and {after} after its last dropped" \
        if before or after else ""
    kept = tuple(image for image, keep in zip(images, inside, strict=True) if keep)
    traverse = BayerTraverse(run, kept, positions=_interpolated(ins, stamps[inside]))
    return traverse, ins.zone, note


def raw_runs(root: Path, reference_run: str, query_run: str, positions: str, every: int, radius: float | None,
             splits: dict[str, tuple[int, int]] | None) -> TraversePair:
    """The ``positions: ins`` pair: both raw runs, every ``every``-th image, positioned by their INS logs."""
    if positions not in POSITIONS:
        raise DatasetError(f"datasets.robotcar.positions is {positions!r}; choose {', '.join(POSITIONS)} (the "
                           "raw runs positioned by their INS logs), or leave it unset for the place-aligned lists")
    if isinstance(every, bool) or not isinstance(every, int) or every < 1:
        raise DatasetError(f"datasets.robotcar.every is {every!r}; give a whole number >= 1 (keep one image in "
                           "every N: the raw runs have about 16 images per second)")
    reference, ref_zone, ref_note = _positioned_run(root, reference_run, every)
    query, query_zone, query_note = _positioned_run(root, query_run, every)
    if ref_zone and query_zone and ref_zone != query_zone:
        raise DatasetError(f"dataset 'robotcar': the INS logs of {reference_run} and {query_run} lie in different "
                           f"UTM zones ({ref_zone} and {query_zone}); positions of both runs must share a zone")
    radius = DEFAULT_RADIUS if radius is None else radius
    every_text = "every image" if every == 1 else f"one image in every {every}"
    notes = "".join(f"; {run}: {note}" for run, note in ((reference_run, ref_note), (query_run, query_note)) if note)
    where = f"INS easting, northing of {INS.as_posix()} interpolated at each image's timestamp" + \
        (f", UTM zone {ref_zone}" if ref_zone else "")
    source = (f"Oxford RobotCar raw runs: {resolved(root / reference_run / CAMERA)} (reference) and "
              f"{resolved(root / query_run / CAMERA)} (query), {every_text}, Bayer images demosaiced{notes}")
    return TraversePair(name="robotcar", reference=reference, query=query, splits=dict(splits or {}),
                        pairing=positions_pairing(where, radius, METRES), source=source, radius=radius,
                        position_unit=METRES, position_source=where)
