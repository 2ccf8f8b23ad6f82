"""Any two image folders: frame-aligned (file names in natural order, or explicit list files), or with positions
(method §11: a CSV per folder, or the @UTM_east@UTM_north@ file names), when the two need not be aligned at all."""

from __future__ import annotations

import re
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from vpr_smr.core.constants import DEFAULT_TOLERANCE
from vpr_smr.core.settings import REQUIRED, setting
from vpr_smr.datasets.base import (
    DatasetError,
    Traverse,
    TraversePair,
    images_from_list,
    list_files,
    order_note,
    positions_pairing,
    resolved,
    sorted_images,
)
from vpr_smr.datasets.positions import METRES, csv_pair_positions, positions_from_names


def _traverse(folder: Path | str, images: tuple[Path, ...], by_name: bool) -> Traverse:
    note = order_note([p.name for p in images]) if by_name else None
    return Traverse(Path(folder).name, images, order_note=note)


PAIRINGS = ("by_name", "by_order")
POSITIONS = ("file_names",)  # `positions:` values: where the positions are, besides CSV files
MAX_SHOWN_PAIRS = 3  # disagreeing name pairs quoted in an error


def _numbers(name: str) -> tuple[int, ...]:
    return tuple(int(n) for n in re.findall(r"\d+", Path(name).stem))


def _pairing(name: str, reference: Path | str, query: Path | str, ref_names: list[str], query_names: list[str],
             pairing: str) -> str:
    """How position i of the two folders (natural order) is known to be one place; raise when nothing says so."""
    if ref_names == query_names:
        return "by file name (the same names in both folders)"
    if [_numbers(n) for n in ref_names] == [_numbers(n) for n in query_names]:
        return f"by the frame numbers in the file names (e.g. {ref_names[0]} with {query_names[0]})"
    if pairing == "by_order":
        return "by position in natural order (pairing: by_order; the file names differ)"
    differ = [i for i, (a, b) in enumerate(zip(ref_names, query_names, strict=True))
              if a != b and _numbers(a) != _numbers(b)]
    shown = "; ".join(f"frame {i}: {ref_names[i]} vs {query_names[i]}" for i in differ[:MAX_SHOWN_PAIRS])
    more = f" and {len(differ) - MAX_SHOWN_PAIRS} more" if len(differ) > MAX_SHOWN_PAIRS else ""
    raise DatasetError(
        f"dataset {name!r}: the file names of {reference} and {query} differ ({shown}{more}), so nothing says "
        "image i of one shows the place of image i of the other. Give frame lists (reference_list, query_list) "
        "naming aligned frames line by line, or set `pairing: by_order` to pair them by position in natural "
        "order, accepting that risk"
    )


def _check_choices(name: str, pairing: str, positions: str | None, reference_list: Path | str | None,
                   query_list: Path | str | None, reference_positions: Path | str | None,
                   query_positions: Path | str | None) -> None:
    """Refuse settings that contradict each other, naming them; each pair of per-traverse files is both or none."""
    if pairing not in PAIRINGS:
        raise DatasetError(f"datasets.{name}.pairing is {pairing!r}; choose one of {', '.join(PAIRINGS)}")
    if positions is not None and positions not in POSITIONS:
        raise DatasetError(f"datasets.{name}.positions is {positions!r}; choose {', '.join(POSITIONS)} (the "
                           "@UTM_east@UTM_north@ names of VPR-methods-evaluation), or give CSV files as "
                           "reference_positions and query_positions")
    for option, (reference, query), what in (
        ("list", (reference_list, query_list), "frame lists (line i of both names one place)"),
        ("positions", (reference_positions, query_positions), "positions files (one CSV per traverse)"),
    ):
        if bool(reference) != bool(query):
            given, other = (f"reference_{option}", f"query_{option}") if reference else \
                (f"query_{option}", f"reference_{option}")
            raise DatasetError(f"dataset {name!r}: {given} is set but {other} is not; give both {what} or neither")
    if positions is not None and reference_positions:
        raise DatasetError(f"dataset {name!r}: positions: {positions} and reference_positions / query_positions "
                           "are both set; give the positions one way")


def _aligned_images(name: str, reference: Path | str, query: Path | str, reference_list: Path | str | None,
                    query_list: Path | str | None, pairing: str) -> tuple[tuple[Path, ...], tuple[Path, ...], str, str]:
    """The frames of both folders, aligned one-to-one; how they are paired and which were chosen."""
    if reference_list and query_list:
        ref_images = images_from_list(reference, reference_list)
        query_images = images_from_list(query, query_list)
        how = f"by the frame lists (line i of {Path(reference_list).name} and {Path(query_list).name})"
        chosen = f"the frames named by the lists {resolved(reference_list)} and {resolved(query_list)}"
        return ref_images, query_images, how, chosen
    ref_images, query_images = sorted_images(reference), sorted_images(query)
    ref_names = [p.name for p in ref_images]
    query_names = [p.name for p in query_images]
    if len(ref_names) != len(query_names):
        only_ref = sorted(set(ref_names) - set(query_names))
        only_query = sorted(set(query_names) - set(ref_names))
        details = []
        if only_ref:
            details.append(f"only in {reference}: {list_files(only_ref)}")
        if only_query:
            details.append(f"only in {query}: {list_files(only_query)}")
        raise DatasetError(
            f"dataset {name!r}: {reference} has {len(ref_names)} images but {query} has {len(query_names)}"
            + ("; " + "; ".join(details) if details else "")
            + ". Give list files (reference_list, query_list) to choose aligned frames."
        )
    how = _pairing(name, reference, query, ref_names, query_names, pairing)
    return ref_images, query_images, how, "every image in them, in natural file-name order"


def _own_images(folder: Path | str, list_file: Path | str | None) -> tuple[Path, ...]:
    """One traverse's frames when nothing pairs them with the other's: its list, or its folder in natural order."""
    return images_from_list(folder, list_file) if list_file else sorted_images(folder)


def _positions(reference: Path | str, query: Path | str, ref_images: tuple[Path, ...], query_images: tuple[Path, ...],
               reference_positions: Path | str | None, query_positions: Path | str | None,
               allow_missing: bool) -> tuple[np.ndarray, np.ndarray, str, str]:
    """Both traverses' positions, their unit and where they came from (``TraversePair.position_source``)."""
    if reference_positions and query_positions:
        ref, qry, unit, how = csv_pair_positions(reference_positions, ref_images, reference, query_positions,
                                                 query_images, query, allow_missing)
        return ref, qry, unit, f"the CSV files {resolved(reference_positions)} and {resolved(query_positions)}, {how}"
    source = "the UTM easting and northing in the @UTM_east@UTM_north@ file names"
    return (positions_from_names(ref_images, allow_missing), positions_from_names(query_images, allow_missing),
            METRES, source)


@dataclass(frozen=True)
class FoldersSettings:
    """The settings of the ``folders`` loader (``folder_pair``)."""

    reference: Path | str = setting(
        REQUIRED, "the reference traverse's image folder (relative: from the working folder, where vpr-smr runs)")
    query: Path | str = setting(REQUIRED, "the query traverse's image folder")
    reference_list: Path | str | None = setting(
        None, "a text file naming the reference images in order, one per line (null: every image of the folder, in "
              "natural name order)")
    query_list: Path | str | None = setting(None, "the same for the query images")
    pairing: str = setting(
        "by_name", "how frame i of both folders is paired without lists: by_name (their names must say they are one "
                   "place) or by_order (the i-th image of each, whatever the names)")
    reference_positions: Path | str | None = setting(
        None, "a CSV name,x,y or name,lat,lon of the reference images' positions (method §11); with query_positions")
    query_positions: Path | str | None = setting(None, "the same for the query images")
    positions: str | None = setting(None, "file_names: the positions are the @UTM_east@UTM_north@ names (method §11)")


def folder_pair(
    name: str,
    reference: Path | str,
    query: Path | str,
    splits: dict[str, tuple[int, int]] | None = None,
    tolerance: int = DEFAULT_TOLERANCE,
    reference_list: Path | str | None = None,
    query_list: Path | str | None = None,
    pairing: str = "by_name",
    check_files: bool = True,
    reference_positions: Path | str | None = None,
    query_positions: Path | str | None = None,
    positions: str | None = None,
    radius: float | None = None,
) -> TraversePair:
    """Pair two folders frame by frame: image names in natural order, or the order of the list files; or, with
    positions, take each folder as it is and match frames by position (method §11).

    Without lists, position i of both folders is one place only when the names say so (the same names, or the
    same numbers in them), or when ``pairing="by_order"`` accepts pairing by position alone.
    ``reference_positions`` and ``query_positions`` (CSV files ``name,x,y`` or ``name,lat,lon``) or
    ``positions="file_names"`` (the ``@UTM_east@UTM_north@`` names) give each frame a position: the folders may
    then hold different numbers of frames, each in natural name order (or its list's order), and a match is
    correct within ``radius``. ``check_files=False`` leaves files named by the lists but missing, and images
    without a position, to ``dataset check``. ``FoldersSettings`` says what each setting means.
    """
    _check_choices(name, pairing, positions, reference_list, query_list, reference_positions, query_positions)
    if positions is None and not reference_positions:
        ref_images, query_images, how, chosen = _aligned_images(name, reference, query, reference_list, query_list,
                                                                pairing)
        pair = TraversePair(
            name=name,
            reference=_traverse(reference, ref_images, by_name=not reference_list),
            query=_traverse(query, query_images, by_name=not query_list),
            tolerance=tolerance,
            splits=dict(splits or {}),
            pairing=how,
            source=f"image folders {resolved(reference)} (reference) and {resolved(query)} (query): {chosen}",
        )
    else:
        pair = _positioned_pair(name, reference, query, reference_list, query_list, reference_positions,
                                query_positions, splits, radius, check_files)
    if check_files:
        pair.check_files()
    return pair


UTM_ORDER_NOTE = ("the names are @UTM_east@UTM_north@ positions, so natural name order is the order of the "
                  "eastings, the recording order only of a route driven due east; give a frame list "
                  "(reference_list / query_list) in recording order for sequence matching")


def _positioned_traverse(folder: Path | str, images: tuple[Path, ...], positions: np.ndarray, by_name: bool,
                         by_utm_names: bool) -> Traverse:
    traverse = replace(_traverse(folder, images, by_name), positions=positions)
    # the generic note (several numbers vary in the names) would not say why that order is wrong; names outside
    # the convention (only `dataset check` loads them) get the generic one
    utm_names = by_utm_names and bool(np.isfinite(positions).all())
    return replace(traverse, order_note=UTM_ORDER_NOTE) if by_name and utm_names and len(images) > 1 else traverse


def _positioned_pair(name: str, reference: Path | str, query: Path | str, reference_list: Path | str | None,
                     query_list: Path | str | None, reference_positions: Path | str | None,
                     query_positions: Path | str | None, splits: dict[str, tuple[int, int]] | None,
                     radius: float | None, check_files: bool) -> TraversePair:
    """Two folders not aligned frame by frame: each traverse in its own order, with a position per frame."""
    ref_images, query_images = _own_images(reference, reference_list), _own_images(query, query_list)
    ref_pos, query_pos, unit, source = _positions(reference, query, ref_images, query_images, reference_positions,
                                                  query_positions, allow_missing=not check_files)
    chosen = "the frames named by the lists" if reference_list else "every image in them, in natural file-name order"
    by_utm_names = reference_positions is None
    return TraversePair(
        name=name,
        reference=_positioned_traverse(reference, ref_images, ref_pos, not reference_list, by_utm_names),
        query=_positioned_traverse(query, query_images, query_pos, not query_list, by_utm_names),
        splits=dict(splits or {}),
        pairing=positions_pairing(source, radius, unit),
        source=f"image folders {resolved(reference)} (reference) and {resolved(query)} (query): {chosen}",
        radius=radius,
        position_unit=unit,
        position_source=source,
    )
