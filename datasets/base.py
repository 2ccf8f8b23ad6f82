"""Traverses and traverse pairs: two image sequences of one route, frame-aligned (method §1) or with positions
(method §11)."""

from __future__ import annotations

import hashlib
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import cv2
import numpy as np

from vpr_smr.core.constants import DEFAULT_TOLERANCE

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".ppm", ".tif", ".tiff")
MAX_LISTED = 5  # an error lists this many files, then a count
# The data shipped with vpr-smr (the package vpr_smr.data: the Nordland sample and the published frame lists).
SHIPPED_DATA = Path(__file__).resolve().parents[1] / "data"


class DatasetError(ValueError):
    """A dataset on disk does not match what its loader expects; the message names the files."""


def resolved(path: Path | str) -> str:
    """``path`` as an absolute path (``~`` expanded, links resolved): how a dataset's source names its files."""
    return str(Path(path).expanduser().resolve())


def list_files(paths: Sequence[Path | str], limit: int = MAX_LISTED) -> str:
    """``a, b, c and 12 more``: the first few files of a problem, then a count."""
    shown = ", ".join(str(p) for p in paths[:limit])
    return shown + (f" and {len(paths) - limit} more" if len(paths) > limit else "")


JPEG_START, JPEG_END = b"\xff\xd8", b"\xff\xd9"  # start- and end-of-image markers: a JPEG cut short lacks the end


def imread(path: Path | str, flags: int = cv2.IMREAD_COLOR) -> np.ndarray:
    """Decode the whole file as ``cv2.imread(path, flags)`` does (OpenCV's channel order), or raise naming it.

    OpenCV decodes a truncated JPEG with a grey fill and only a warning on stderr, so a JPEG must end with its
    end-of-image marker; other formats fail to decode when cut short. An empty file is named as such.
    """
    path = Path(path)
    if not path.is_file():
        raise DatasetError(f"image not found: {path}")
    data = path.read_bytes()
    if not data:
        raise DatasetError(f"image {path} is empty (0 bytes): copy it again")
    if data.startswith(JPEG_START) and not data.rstrip(b"\x00").endswith(JPEG_END):
        raise DatasetError(f"image {path} is a truncated JPEG (it stops before its end-of-image marker, "
                           f"{len(data)} bytes): the file is incomplete; copy it again")
    image = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), flags)
    if image is None:
        raise DatasetError(f"cannot decode image {path}: the file is corrupt or not an image")
    return image


def read_image(path: Path | str) -> np.ndarray:
    """Read an image as RGB ``uint8`` of shape ``H x W x 3``; an unreadable file raises naming it."""
    return cv2.cvtColor(imread(path, cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)


@dataclass(frozen=True)
class Traverse:
    """One ordered sequence of images of a route under one condition.

    ``positions`` (method §11): where each frame was taken, ``(n, 2)`` float64 (read-only), or None for a traverse
    that is only frame-aligned with its pair. NaN marks a frame without a known position (only ``dataset check``
    builds such traverses: the loaders refuse them otherwise). Left out of equality and hashing, like an array
    must be: the images identify a traverse.
    """

    name: str
    images: tuple[Path, ...]
    order_note: str | None = None  # why the order by file name may not be the recording order (see order_note)
    positions: np.ndarray | None = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        if self.positions is None:
            return
        positions = np.array(self.positions, dtype=np.float64)  # a copy: the caller's array stays writable
        if positions.ndim == 1:
            positions = positions[:, None]
        if positions.ndim != 2 or len(positions) != len(self.images):
            raise DatasetError(f"traverse {self.name!r}: {len(self.images)} images but positions of shape "
                               f"{positions.shape}: give one position per image")
        positions.flags.writeable = False
        object.__setattr__(self, "positions", positions)

    def __len__(self) -> int:
        return len(self.images)

    def read(self, index: int) -> np.ndarray:
        return read_image(self.images[index])


@dataclass(frozen=True)
class TraversePair:
    """A reference and a query traverse of one route.

    Without positions, their frames are aligned one-to-one (frame i of both shows the same place, method §1): the
    traverses have the same length and ``tolerance`` (frames) is the ground truth. With positions on both
    traverses (method §11), a match is correct within ``radius`` (in ``position_unit``), the traverses may differ
    in length, and a split may give its reference range apart from its query range.

    ``splits`` maps a split name to a half-open index range ``(lo, hi)``: its query range, and its reference
    range too unless ``reference_splits`` gives that one (only splits whose two ranges differ are there).
    """

    name: str
    reference: Traverse
    query: Traverse
    tolerance: int = DEFAULT_TOLERANCE
    splits: dict[str, tuple[int, int]] = field(default_factory=dict)
    pairing: str = "by the frame lists (line i of both)"  # how frame i of both traverses is known to be one place
    # where the images came from, in the loader's words (its folders or root, resolved, and the frame lists it
    # read): the dataset card of the report shows it
    source: str = ""
    radius: float | None = None  # method §11: ground truth within this distance, for pairs with positions
    reference_splits: dict[str, tuple[int, int]] = field(default_factory=dict)  # reference ranges that differ
    position_unit: str = ""  # the positions' unit, e.g. "metres", for messages about the radius
    position_source: str = ""  # where the positions came from, e.g. "the CSVs a.csv and b.csv, x, y as given"
    # method §13: the correct references from a file (the configuration's ``ground_truth``), in place of the tolerance
    ground_truth: GroundTruthFile | None = None

    def __post_init__(self) -> None:
        if (self.reference.positions is None) != (self.query.positions is None):
            given, other = ("reference", "query") if self.reference.positions is not None else ("query", "reference")
            raise DatasetError(f"dataset {self.name!r}: the {given} traverse has positions but the {other} traverse "
                               f"has none; give positions for both traverses or for neither")
        if not self.has_positions and len(self.reference) != len(self.query):
            raise DatasetError(
                f"dataset {self.name!r}: the reference traverse ({self.reference.name}) has {len(self.reference)} "
                f"frames but the query traverse ({self.query.name}) has {len(self.query)}; "
                "the frames must be aligned one-to-one"
            )
        if len(self.reference) == 0 or len(self.query) == 0:
            raise DatasetError(f"dataset {self.name!r}: no frames found")
        self._check_positions()
        for split in self.reference_splits:
            if split not in self.splits:
                raise DatasetError(f"dataset {self.name!r}: split {split!r} has a reference range but no query "
                                   "range; give it as {reference: [lo, hi], query: [lo, hi]}")
        for split, (lo, hi) in self.splits.items():
            if self.has_positions:  # each range against its own traverse: their lengths may differ
                self._check_range(split, "query range ", (lo, hi), self.query)
                self._check_range(split, "reference range ", self.reference_range(split), self.reference)
            else:
                self._check_range(split, "", (lo, hi), self.reference)

    def _check_positions(self) -> None:
        if self.radius is not None and not self.has_positions:
            raise DatasetError(f"datasets.{self.name}.radius is set, but the frames have no positions: a "
                               "frame-aligned pair's ground truth is `tolerance` (frames); give positions "
                               "(see the loader's settings) or remove radius")
        if self.radius is not None and not (math.isfinite(self.radius) and self.radius > 0):
            raise DatasetError(f"datasets.{self.name}.radius is {self.radius}: give a distance > 0 in "
                               f"{self.position_unit or 'the positions unit'} within which a match is correct")
        if self.reference_splits and not self.has_positions:
            split = next(iter(self.reference_splits))
            raise DatasetError(
                f"dataset {self.name!r}: split {split!r} gives its reference range apart from its query range, "
                "which needs positions (a match is then correct within radius); a frame-aligned pair's splits "
                "are one range [lo, hi] for both traverses"
            )

    def _check_range(self, split: str, which: str, frames: tuple[int, int], traverse: Traverse) -> None:
        lo, hi = frames
        if lo >= hi:
            raise DatasetError(f"dataset {self.name!r}: split {split!r} {which}= [{lo}, {hi}) is empty; give it a "
                               "range [lo, hi) with lo < hi in the configuration's splits")
        if not 0 <= lo < hi <= len(traverse):
            role = "reference" if traverse is self.reference else "query"
            where = f" of the {role} traverse ({traverse.name})" if self.has_positions else ""
            raise DatasetError(
                f"dataset {self.name!r}: split {split!r} {which}= [{lo}, {hi}) is outside the {len(traverse)} "
                f"frames{where}; fix the split ranges in the configuration"
            )

    def __len__(self) -> int:
        return len(self.reference)

    @property
    def has_positions(self) -> bool:
        """Whether both traverses carry positions (method §11): ground truth within ``radius``, not ``tolerance``."""
        return self.reference.positions is not None and self.query.positions is not None

    def split_range(self, split: str) -> tuple[int, int]:
        """The split's query range (and its reference range too, unless ``reference_range`` differs)."""
        try:
            return self.splits[split]
        except KeyError:
            raise DatasetError(
                f"dataset {self.name!r} has no split {split!r}; it has {', '.join(self.splits) or 'none'}"
            ) from None

    def reference_range(self, split: str) -> tuple[int, int]:
        """The split's reference range: its own when the configuration gives one, else its (query) range."""
        query = self.split_range(split)
        return self.reference_splits.get(split, query)

    def missing_images(self) -> list[Path]:
        return [p for p in (*self.reference.images, *self.query.images) if not p.is_file()]

    def check_files(self) -> None:
        """Raise a DatasetError listing missing images (first few, then a count)."""
        missing = self.missing_images()
        if missing:
            raise DatasetError(f"dataset {self.name!r}: {len(missing)} images are missing: {list_files(missing)}")

    def fingerprint(self) -> str:
        """SHA-256 of the frame lists (names, in order): the provenance of everything computed from them."""
        digest = hashlib.sha256()
        for traverse in (self.reference, self.query):
            for path in traverse.images:
                digest.update(f"{traverse.name}/{path.name}\n".encode())
        if self.has_positions:  # the descriptor file stores them: a changed position is another file
            for traverse in (self.reference, self.query):
                assert traverse.positions is not None
                digest.update(np.ascontiguousarray(traverse.positions, dtype="<f8").tobytes())
        return digest.hexdigest()


@dataclass(frozen=True)
class GroundTruthFile:
    """A dataset's ground truth given as a file (method §13): ``form`` ``matrix`` (a boolean references x queries
    matrix over the dataset's frames) or ``lists`` (per-query lists of correct references), ``key`` the variable of a
    ``.npz`` or ``.mat`` file."""

    form: str
    path: str
    key: str | None = None


def relative_note(path: Path | str) -> str:
    """`` (a relative path, looked for from the working folder /x)`` for a relative path not found, else empty."""
    return "" if Path(path).is_absolute() else f" (a relative path, looked for from the working folder {Path.cwd()})"


def radius_text(radius: float, unit: str) -> str:
    """``25 m``, or ``3 (the unit of the CSVs' x and y)``: a radius with its unit, for messages and cards."""
    return f"{radius:g} m" if unit == "metres" else f"{radius:g} ({unit})" if unit else f"{radius:g}"


def positions_pairing(position_source: str, radius: float | None, unit: str) -> str:
    """A pair's ``pairing`` when its frames have positions: ``by positions within 25 m (<source>)``."""
    within = f" within {radius_text(radius, unit)}" if radius is not None else ""
    return f"by positions{within} ({position_source})"


def slice_traverse(traverse: Traverse, lo: int, hi: int) -> Traverse:
    """Frames ``lo .. hi-1`` of a traverse, positions included; ``replace`` keeps its class (e.g. a Bayer reader)."""
    positions = None if traverse.positions is None else traverse.positions[lo:hi]
    return replace(traverse, images=traverse.images[lo:hi], positions=positions)


_NUMBER = re.compile(r"(\d+)")


def natural_key(name: str) -> tuple[tuple[int, int | str], ...]:
    """Sort key that orders the numbers in a name by value: ``img2`` before ``img10`` (text compares as text)."""
    return tuple((1, int(part)) if part.isdigit() else (0, part) for part in _NUMBER.split(name) if part)


def order_note(names: Sequence[str]) -> str | None:
    """Why the order of ``names`` (already in natural order) may not be the order they were recorded in, or None.

    The order is unambiguous when every name has the same text around one number that differs between them
    (``img1 .. img111``, ``frame_00010``): frames are then ordered by that number.
    """
    if len(names) < 2:
        return None
    if not any(_NUMBER.search(name) for name in names):
        return "the names hold no frame numbers: frames are ordered alphabetically"
    templates = {_NUMBER.sub("#", name) for name in names}
    if len(templates) > 1:
        shown = ", ".join(sorted(templates)[:MAX_LISTED])
        return (f"the names follow {len(templates)} different patterns ({shown}): frames are ordered by name, "
                "pattern by pattern; give a frame list (reference_list / query_list) if that is not the order "
                "they were recorded in")
    numbers = [[int(n) for n in _NUMBER.findall(name)] for name in names]
    varying = [i for i in range(len(numbers[0])) if len({row[i] for row in numbers}) > 1]
    if len(varying) > 1:
        return (f"{len(varying)} numbers vary in the names (e.g. {names[0]}): frames are ordered by the first, "
                "then the next; give a frame list if that is not the order they were recorded in")
    if not varying or len({row[varying[0]] for row in numbers}) < len(names):
        return "two names carry the same frame number (e.g. img01 and img1): their order is alphabetical"
    return None


def sorted_images(folder: Path | str) -> tuple[Path, ...]:
    """The image files of a folder in natural order (``img2`` before ``img10``); any other file (but hidden
    ones) is an error naming it.

    A stray file would shift the frame alignment of everything after it, so it is not skipped silently.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise DatasetError(f"image folder not found: {folder}{relative_note(folder)}")
    files = sorted((p for p in folder.iterdir() if not p.name.startswith(".")),
                   key=lambda p: (natural_key(p.name), p.name))
    others = [p.name for p in files if p.suffix.lower() not in IMAGE_SUFFIXES]
    if others:
        raise DatasetError(
            f"image folder {folder} holds {len(others)} files that are not images ({list_files(others)}); "
            f"move them out, or give a frame list (reference_list / query_list) naming the frames"
        )
    return tuple(files)


def images_from_list(folder: Path | str, list_file: Path | str) -> tuple[Path, ...]:
    """Images named one per line in ``list_file`` (relative to ``folder``; blank lines and ``#`` skipped)."""
    list_file = Path(list_file)
    if not list_file.is_file():
        raise DatasetError(f"frame list not found: {list_file}")
    names = [line.strip() for line in list_file.read_text().splitlines()]
    return tuple(Path(folder) / name for name in names if name and not name.startswith("#"))
