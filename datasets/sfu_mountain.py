"""SFU Mountain, dry against dusk, right stereo camera (method §1).

Layout: ``<root>/part_{a,b}/stereo_right/{dry,dusk}/frames/*.jpg``. The hand-aligned lists of VPRSNN
(``SFU-Mountain_imageNames_{dry,dusk}.txt``, 375 lines like
``./SFU-Mountain/part_a/stereo_right/dry/frames/a001.jpg``, vendored in ``data/lists``) select and order the
frames: line i of both lists shows the same place.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from vpr_smr.core.constants import DEFAULT_TOLERANCE
from vpr_smr.core.settings import REQUIRED, setting
from vpr_smr.datasets.base import SHIPPED_DATA, DatasetError, Traverse, TraversePair, resolved
from vpr_smr.datasets.check import checked_pair, read_list, require_root

LISTS = SHIPPED_DATA / "lists" / "from_VPRSNN"
REFERENCE_LIST = LISTS / "SFU-Mountain_imageNames_dry.txt"
QUERY_LIST = LISTS / "SFU-Mountain_imageNames_dusk.txt"
LIST_PREFIX = "SFU-Mountain"  # the lists' top folder; root stands for it
SPLITS = {"train": (0, 100), "val": (100, 200), "test": (200, 375)}
FIX = (
    "set datasets.sfu_mountain.root (or --root) to the folder that holds part_a/ and part_b/ "
    "(each with stereo_right/dry/frames/ and stereo_right/dusk/frames/)"
)


def list_paths(root: Path, list_file: Path | str, option: str) -> tuple[Path, ...]:
    """List lines as paths under root: ``./SFU-Mountain/part_a/...`` and ``part_a/...`` both map to
    ``<root>/part_a/...``."""
    paths = []
    for line in read_list("sfu_mountain", list_file, option):
        parts = [p for p in PurePosixPath(line.replace("\\", "/")).parts if p != "."]
        if parts and parts[0] == LIST_PREFIX:
            parts = parts[1:]
        if not parts or parts[0] == "/" or ".." in parts:
            raise DatasetError(
                f"dataset 'sfu_mountain': {list_file} names {line!r}; lines must be paths relative to the "
                "dataset folder, like ./SFU-Mountain/part_a/stereo_right/dry/frames/a001.jpg"
            )
        paths.append(root.joinpath(*parts))
    return tuple(paths)


@dataclass(frozen=True)
class SFUMountainSettings:
    """The settings of the ``sfu_mountain`` loader."""

    root: Path | str = setting(REQUIRED, "the folder that holds part_a/ and part_b/")
    reference_list: Path | str = setting(
        REFERENCE_LIST, "the file naming the reference (dry) frames in order (default: VPRSNN's list, shipped)")
    query_list: Path | str = setting(
        QUERY_LIST, "the file naming the query (dusk) frames in order (default: VPRSNN's list, shipped)")


def sfu_mountain(
    root: Path | str,
    reference_list: Path | str = REFERENCE_LIST,
    query_list: Path | str = QUERY_LIST,
    splits: dict[str, tuple[int, int]] | None = None,
    tolerance: int = DEFAULT_TOLERANCE,
    check_files: bool = True,
) -> TraversePair:
    """Dry (reference) against dusk (query), in list order.

    ``check_files=False`` skips the missing-file check (``dataset check`` reports them instead).
    """
    root = require_root("sfu_mountain", root, FIX)
    ref_images = list_paths(root, reference_list, "reference_list")
    query_images = list_paths(root, query_list, "query_list")
    # The alignment is by hand, so only the counts can be checked, not the names.
    if len(ref_images) != len(query_images):
        raise DatasetError(
            f"dataset 'sfu_mountain': the frame lists do not match: {reference_list} names {len(ref_images)} "
            f"frames but {query_list} names {len(query_images)}; give lists of the same places"
        )
    reference, query = Traverse("dry", ref_images), Traverse("dusk", query_images)
    source = (f"SFU Mountain under {resolved(root)}: dry (reference) and dusk (query) frames of the right stereo "
              f"camera, hand-aligned by the lists {resolved(reference_list)} and {resolved(query_list)}")
    return checked_pair("sfu_mountain", root, FIX, reference, query, SPLITS if splits is None else splits, tolerance,
                        check_files, source)
