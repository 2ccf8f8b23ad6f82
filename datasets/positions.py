"""Where each frame of a traverse was taken (method §11): positions from a CSV or from the file names.

A traverse pair with positions is not frame-aligned: a match is correct when the two frames lie within a radius
of each other. Positions come from

- a CSV per traverse, ``name,x,y`` (any unit both traverses share) or ``name,lat,lon`` (WGS84 degrees, projected
  to metres in one UTM zone, the same for both traverses: ``csv_pair_positions`` chooses it from the reference);
- the file names, in the ``@UTM_east@UTM_north@...`` convention of VPR-methods-evaluation (metres).

Every function returns an ``(n, 2)`` float64 array, row ``i`` the position of image ``i``. With
``allow_missing`` (``dataset check``), an image without a position gets NaN instead of an error, so that the
check can count and name them.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vpr_smr.datasets.base import DatasetError, list_files, relative_note

__all__ = [
    "METRES", "XY_UNIT", "CsvPositions", "UtmZone", "csv_pair_positions", "median_spacing", "positions_from_csv",
    "positions_from_names", "read_position_csv", "utm_zone",
]

METRES = "metres"
XY_UNIT = "units of the CSVs' x, y"  # a CSV of x, y: whatever unit both traverses share
HEADERS: dict[tuple[str, ...], str] = {("name", "x", "y"): "xy", ("name", "lat", "lon"): "latlon"}
NAMES_EXAMPLE = "@0543256.96@4178906.70@10@S@37.75594@-122.50037@.jpg"


@dataclass(frozen=True)
class CsvPositions:
    """The rows of a positions CSV: ``kind`` is ``xy`` or ``latlon``; ``rows`` maps a name to its two numbers."""

    path: Path
    kind: str
    rows: dict[str, tuple[float, float]]


@dataclass(frozen=True)
class UtmZone:
    """A UTM zone of WGS84 (1..60, north or south of the equator): where lat/lon become metres."""

    number: int
    south: bool

    @property
    def epsg(self) -> int:
        return (32700 if self.south else 32600) + self.number

    def __str__(self) -> str:
        return f"UTM zone {self.number}{'S' if self.south else 'N'} (EPSG:{self.epsg})"


def utm_zone(lat: np.ndarray, lon: np.ndarray) -> UtmZone:
    """The zone of the mean longitude (hemisphere of the mean latitude): one zone for a whole traverse, so that
    a route crossing a zone border is not split into two coordinate systems."""
    number = int((float(np.mean(lon)) + 180.0) // 6.0) % 60 + 1
    return UtmZone(number, float(np.mean(lat)) < 0.0)


def _number(text: str, path: Path, line: int, column: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise DatasetError(f"{path}, line {line}: {column} is {text!r}, not a number; write it as a decimal "
                           "number (e.g. 12.5)")
    return value


def _check_degrees(lat: float, lon: float, path: Path, line: int) -> None:
    if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
        raise DatasetError(f"{path}, line {line}: lat {lat}, lon {lon} are not WGS84 degrees (lat in [-90, 90], "
                           "lon in [-180, 180]); for coordinates in metres write the header name,x,y")


def _header(fields: list[str], path: Path) -> str:
    columns = tuple(f.strip().lower() for f in fields)
    kind = HEADERS.get(columns)
    if kind is None:
        raise DatasetError(
            f"{path}, line 1: the header is {','.join(fields)!r}; a positions CSV starts with the header "
            "'name,x,y' (positions in any unit both traverses share, e.g. metres) or 'name,lat,lon' (WGS84 degrees, "
            "converted to metres), then one row per image: its file name and its two coordinates"
        )
    return kind


def read_position_csv(path: Path | str) -> CsvPositions:
    """The rows of a positions CSV; errors name the file, the line and the fix."""
    path = Path(path).expanduser()
    if not path.is_file():
        raise DatasetError(f"positions file not found: {path}{relative_note(path)}; fix reference_positions / "
                           "query_positions")
    with path.open(newline="", encoding="utf-8-sig") as file:  # utf-8-sig: a spreadsheet's byte-order mark
        lines = [(number, row) for number, row in enumerate(csv.reader(file), start=1) if any(f.strip() for f in row)]
    if not lines:
        raise DatasetError(f"{path} is empty: write the header name,x,y (or name,lat,lon) and one row per image")
    kind = _header(lines[0][1], path)
    rows: dict[str, tuple[float, float]] = {}
    first_line: dict[str, int] = {}
    columns = ("x", "y") if kind == "xy" else ("lat", "lon")
    for number, fields in lines[1:]:
        if len(fields) != 3:
            raise DatasetError(f"{path}, line {number}: {len(fields)} fields ({','.join(fields)!r}); each row is "
                               f"name,{','.join(columns)}")
        name = fields[0].strip()
        if name in first_line:
            raise DatasetError(f"{path}, line {number}: {name!r} has a position already (line {first_line[name]}); "
                               "give each image one row")
        a, b = (_number(text.strip(), path, number, column) for text, column in zip(fields[1:], columns, strict=True))
        if kind == "latlon":
            _check_degrees(a, b, path, number)
        rows[name], first_line[name] = (a, b), number
    return CsvPositions(path, kind, rows)


def _image_keys(images: Sequence[Path], folder: Path | None) -> list[tuple[str, str | None]]:
    """Each image's name relative to its folder, and its bare file name when no other image has it: a CSV row
    may name either."""
    relative = [p.relative_to(folder).as_posix() if folder is not None and p.is_relative_to(folder) else p.name
                for p in images]
    counts: dict[str, int] = {}
    for path in images:
        counts[path.name] = counts.get(path.name, 0) + 1
    return [(rel, p.name if counts[p.name] == 1 else None) for rel, p in zip(relative, images, strict=True)]


def _match_rows(table: CsvPositions, images: Sequence[Path], folder: Path | None,
                allow_missing: bool) -> np.ndarray:
    """The CSV's two numbers of every image, in image order (NaN for a missing one with ``allow_missing``)."""
    values = np.full((len(images), 2), np.nan)
    missing: list[str] = []
    for i, (relative, bare) in enumerate(_image_keys(images, folder)):
        row = table.rows.get(relative)
        if row is None and bare is not None:
            row = table.rows.get(bare)
        if row is None:
            missing.append(relative)
        else:
            values[i] = row
    if missing and not allow_missing:
        where = f" of {folder}" if folder is not None else ""
        raise DatasetError(
            f"{table.path}: no position for {len(missing)} of the {len(images)} images{where}: "
            f"{list_files(missing)}; add a row for each (its file name as in the folder; rows may come in any "
            "order, and rows for other names are ignored)"
        )
    return values


def _project(latlon: np.ndarray, zone: UtmZone) -> np.ndarray:
    """(lat, lon) rows in WGS84 degrees as (easting, northing) metres in ``zone`` (NaN rows stay NaN)."""
    from pyproj import Transformer

    # always_xy: longitude first, easting first, whatever the CRS's axis order says
    transformer = Transformer.from_crs("EPSG:4326", f"EPSG:{zone.epsg}", always_xy=True)
    known = np.all(np.isfinite(latlon), axis=1)
    out = np.full_like(latlon, np.nan)
    if known.any():
        east, north = transformer.transform(latlon[known, 1], latlon[known, 0])
        out[known, 0], out[known, 1] = east, north
    return out


def _positions(table: CsvPositions, images: Sequence[Path], folder: Path | str | None, zone: UtmZone | None,
               allow_missing: bool) -> np.ndarray:
    values = _match_rows(table, images, None if folder is None else Path(folder), allow_missing)
    if table.kind == "xy":
        return values
    if zone is None:
        known = values[np.all(np.isfinite(values), axis=1)]
        if len(known) == 0:
            return values  # nothing to project: every position is missing (and allowed to be)
        zone = utm_zone(known[:, 0], known[:, 1])
    return _project(values, zone)


def positions_from_csv(path: Path | str, images: Sequence[Path], folder: Path | str | None = None,
                       zone: UtmZone | None = None, allow_missing: bool = False) -> np.ndarray:
    """``(n, 2)`` positions of ``images`` from a positions CSV, rows matched by file name (relative to ``folder``,
    or the bare file name when unique). lat/lon become UTM metres in ``zone`` (default: the zone of these points)."""
    return _positions(read_position_csv(path), images, folder, zone, allow_missing)


def _kind_text(kind: str) -> str:
    return "x,y" if kind == "xy" else "lat,lon"


def csv_pair_positions(reference_csv: Path | str, reference_images: Sequence[Path], reference_folder: Path | str,
                       query_csv: Path | str, query_images: Sequence[Path], query_folder: Path | str,
                       allow_missing: bool = False) -> tuple[np.ndarray, np.ndarray, str, str]:
    """Positions of both traverses from their CSVs, in one coordinate system; their unit (``METRES`` for lat/lon,
    else ``XY_UNIT``) and a description of the coordinates.

    Both CSVs must have the same header kind; lat/lon are projected into the UTM zone of the reference's mean
    longitude, for both (distances between points of two zones would be meaningless).
    """
    reference_table, query_table = read_position_csv(reference_csv), read_position_csv(query_csv)
    if reference_table.kind != query_table.kind:
        raise DatasetError(
            f"{reference_table.path} holds {_kind_text(reference_table.kind)} but {query_table.path} holds "
            f"{_kind_text(query_table.kind)}: give both traverses positions in the same coordinates"
        )
    zone = None
    if reference_table.kind == "latlon":
        degrees = _match_rows(reference_table, reference_images, Path(reference_folder), allow_missing=True)
        known = degrees[np.all(np.isfinite(degrees), axis=1)]
        # a reference without any position (only in check mode) leaves the query its own zone
        zone = utm_zone(known[:, 0], known[:, 1]) if len(known) else None
    reference = _positions(reference_table, reference_images, reference_folder, zone, allow_missing)
    query = _positions(query_table, query_images, query_folder, zone, allow_missing)
    if reference_table.kind == "xy":
        return reference, query, XY_UNIT, "x, y as given"
    return reference, query, METRES, f"lat, lon projected to {zone or 'UTM'} of WGS84"


def _utm_of_name(path: Path) -> tuple[float, float] | None:
    fields = path.name.split("@")
    if len(fields) < 4:  # '', east, north, and at least the rest of the name
        return None
    try:
        east, north = float(fields[1]), float(fields[2])
    except ValueError:
        return None
    return (east, north) if math.isfinite(east) and math.isfinite(north) else None


def positions_from_names(images: Sequence[Path], allow_missing: bool = False) -> np.ndarray:
    """``(n, 2)`` UTM (easting, northing) metres from names in VPR-methods-evaluation's convention
    ``@UTM_east@UTM_north@<zone>@<band>@<lat>@<lon>@...@.jpg`` (fields 1 and 2 between ``@``)."""
    values = np.full((len(images), 2), np.nan)
    bad: list[Path] = []
    for i, path in enumerate(images):
        found = _utm_of_name(path)
        if found is None:
            bad.append(path)
        else:
            values[i] = found
    if bad and not allow_missing:
        raise DatasetError(
            f"{len(bad)} of {len(images)} images have names outside the @UTM_east@UTM_north@ convention of "
            f"VPR-methods-evaluation (e.g. {NAMES_EXAMPLE}: fields 1 and 2 between '@' are the UTM easting and "
            f"northing in metres): {list_files(bad)}; rename them, or give positions in CSV files "
            "(reference_positions, query_positions) instead of `positions: file_names`"
        )
    return values


def median_spacing(positions: np.ndarray) -> float:
    """The median distance between consecutive frames (NaN with fewer than two positioned neighbours)."""
    values = np.asarray(positions, dtype=np.float64)
    values = values.reshape(len(values), -1)
    steps = np.sqrt(np.sum(np.diff(values, axis=0) ** 2, axis=1))
    steps = steps[np.isfinite(steps)]
    return float(np.median(steps)) if len(steps) else math.nan
