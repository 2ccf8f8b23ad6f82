"""Traverses and traverse pairs: two frame-aligned image sequences of one route (SPEC section 1)."""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from ..eval.sequence import DEFAULT_TOLERANCE

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".ppm", ".tif", ".tiff")
MAX_LISTED = 5  # an error lists this many files, then a count


class DatasetError(ValueError):
    """A dataset on disk does not match what its loader expects; the message names the files."""


def list_files(paths: Sequence[Path | str], limit: int = MAX_LISTED) -> str:
    """``a, b, c and 12 more``: the first few files of a problem, then a count."""
    shown = ", ".join(str(p) for p in paths[:limit])
    return shown + (f" and {len(paths) - limit} more" if len(paths) > limit else "")


def imread(path: Path | str, flags: int = cv2.IMREAD_COLOR) -> np.ndarray:
    """``cv2.imread(path, flags)`` (OpenCV's channel order); a missing or undecodable file raises naming it."""
    path = Path(path)
    if not path.is_file():
        raise DatasetError(f"image not found: {path}")
    image = cv2.imread(str(path), flags)
    if image is None:
        raise DatasetError(f"cannot decode image {path}: the file is corrupt or not an image")
    return image


def read_image(path: Path | str) -> np.ndarray:
    """Read an image as RGB ``uint8`` of shape ``H x W x 3``; an unreadable file raises naming it."""
    return cv2.cvtColor(imread(path, cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)


@dataclass(frozen=True)
class Traverse:
    """One ordered sequence of images of a route under one condition."""

    name: str
    images: tuple[Path, ...]

    def __len__(self) -> int:
        return len(self.images)

    def read(self, index: int) -> np.ndarray:
        return read_image(self.images[index])


@dataclass(frozen=True)
class TraversePair:
    """A reference and a query traverse whose frames are aligned one-to-one (frame i shows the same place).

    ``splits`` maps a split name to a half-open index range ``(lo, hi)`` applied to both traverses.
    """

    name: str
    reference: Traverse
    query: Traverse
    tolerance: int = DEFAULT_TOLERANCE
    splits: dict[str, tuple[int, int]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if len(self.reference) != len(self.query):
            raise DatasetError(
                f"dataset {self.name!r}: the reference traverse ({self.reference.name}) has {len(self.reference)} "
                f"frames but the query traverse ({self.query.name}) has {len(self.query)}; "
                "the frames must be aligned one-to-one"
            )
        if len(self.reference) == 0:
            raise DatasetError(f"dataset {self.name!r}: no frames found")
        for split, (lo, hi) in self.splits.items():
            if lo >= hi:
                raise DatasetError(f"dataset {self.name!r}: split {split!r} = [{lo}, {hi}) is empty; give it a "
                                   "range [lo, hi) with lo < hi in the configuration's splits")
            if not 0 <= lo < hi <= len(self.reference):
                raise DatasetError(
                    f"dataset {self.name!r}: split {split!r} = [{lo}, {hi}) is outside the {len(self.reference)} "
                    "frames; fix the split ranges in the configuration"
                )

    def __len__(self) -> int:
        return len(self.reference)

    def split_range(self, split: str) -> tuple[int, int]:
        try:
            return self.splits[split]
        except KeyError:
            raise DatasetError(
                f"dataset {self.name!r} has no split {split!r}; it has {', '.join(self.splits) or 'none'}"
            ) from None

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
        return digest.hexdigest()


def sorted_images(folder: Path | str) -> tuple[Path, ...]:
    """The image files of a folder, sorted by name; any other file (but hidden ones) is an error naming it.

    A stray file would shift the frame alignment of everything after it, so it is not skipped silently.
    """
    folder = Path(folder)
    if not folder.is_dir():
        note = "" if folder.is_absolute() else f" (a relative path, looked for from the working folder {Path.cwd()})"
        raise DatasetError(f"image folder not found: {folder}{note}")
    files = sorted(p for p in folder.iterdir() if not p.name.startswith("."))
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
