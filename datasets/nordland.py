"""The full Nordland benchmark: ``<root>/{summer,winter}/images-NNNNN.png`` (method §1).

The 27592-frame "Nordland clean" list (tunnels and stops removed; Patch-NetVLAD's
``nordland_imageNames_{index,query}.txt``, vendored in ``data/lists``) selects and orders the frames. Frames
are aligned by file name: line i of both lists names the same ``images-NNNNN.png``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from vpr_smr.core.constants import DEFAULT_TOLERANCE
from vpr_smr.core.settings import REQUIRED, setting
from vpr_smr.datasets.base import SHIPPED_DATA, DatasetError, Traverse, TraversePair, resolved
from vpr_smr.datasets.check import checked_pair, read_list, require_root

LISTS = SHIPPED_DATA / "lists"
REFERENCE_LIST = LISTS / "from_Patch-NetVLAD" / "nordland_imageNames_index.txt"
QUERY_LIST = LISTS / "from_Patch-NetVLAD" / "nordland_imageNames_query.txt"
SPLITS = {"train": (0, 500), "val": (500, 1000), "test": (1000, 10000)}
MAX_SHOWN = 3  # disagreeing list lines quoted in an error


def _file_name(line: str) -> str:
    return line.replace("\\", "/").rsplit("/", 1)[-1]  # not PurePosixPath: slow over 27592 lines


def _fix(reference: str, query: str) -> str:
    return f"set datasets.nordland.root (or --root) to the folder that holds {reference}/ and {query}/"


@dataclass(frozen=True)
class NordlandSettings:
    """The settings of the ``nordland`` loader."""

    root: Path | str = setting(REQUIRED, "the folder that holds the seasons' folders (summer/, winter/, ...)")
    reference_list: Path | str = setting(
        REFERENCE_LIST, "the file naming the reference frames in order (default: Patch-NetVLAD's list, shipped)")
    query_list: Path | str = setting(
        QUERY_LIST, "the file naming the query frames in order (default: Patch-NetVLAD's list, shipped)")
    reference: str = setting("summer", "the reference season's folder under root")
    query: str = setting("winter", "the query season's folder under root")


def nordland(
    root: Path | str,
    reference_list: Path | str = REFERENCE_LIST,
    query_list: Path | str = QUERY_LIST,
    reference: str = "summer",
    query: str = "winter",
    splits: dict[str, tuple[int, int]] | None = None,
    tolerance: int = DEFAULT_TOLERANCE,
    check_files: bool = True,
) -> TraversePair:
    """Summer (``reference``) against winter (``query``) over the frames of the lists, in list order.

    Only the file name of each list line is used (the lists say ``./nordland/summer/...``); it is looked up in
    ``<root>/<reference>`` and ``<root>/<query>``, so other seasons (spring, fall) work with the same lists.
    ``check_files=False`` skips the missing-file check (``dataset check`` reports them instead).
    """
    fix = _fix(reference, query)
    root = require_root("nordland", root, fix)
    ref_names = [_file_name(line) for line in read_list("nordland", reference_list, "reference_list")]
    query_names = [_file_name(line) for line in read_list("nordland", query_list, "query_list")]
    if len(ref_names) != len(query_names):
        raise DatasetError(
            f"dataset 'nordland': the frame lists do not match: {reference_list} names {len(ref_names)} "
            f"frames but {query_list} names {len(query_names)}; give lists of the same frames"
        )
    # Nordland is aligned by frame number, so both lists must name the same files line by line.
    differ = [i for i, (a, b) in enumerate(zip(ref_names, query_names, strict=True)) if a != b]
    if differ:
        shown = "; ".join(f"line {i + 1}: {ref_names[i]} vs {query_names[i]}" for i in differ[:MAX_SHOWN])
        more = f" and {len(differ) - MAX_SHOWN} more lines" if len(differ) > MAX_SHOWN else ""
        raise DatasetError(
            f"dataset 'nordland': the frame lists {reference_list} and {query_list} name different frames "
            f"({shown}{more}); line i of both lists must name the same images-NNNNN.png"
        )
    ref_folder, query_folder = root / reference, root / query
    ref_traverse = Traverse(reference, tuple(ref_folder / name for name in ref_names))
    query_traverse = Traverse(query, tuple(query_folder / name for name in query_names))
    source = (f"Nordland (NRK's Nordlandsbanen footage, CC BY 3.0): {resolved(ref_folder)} (reference) and "
              f"{resolved(query_folder)} (query), the frames of the lists {resolved(reference_list)} and "
              f"{resolved(query_list)}")
    return checked_pair("nordland", root, fix, ref_traverse, query_traverse, SPLITS if splits is None else splits,
                        tolerance, check_files, source)
