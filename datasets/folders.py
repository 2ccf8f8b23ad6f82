"""Any two image folders with a frame-aligned order: file names in natural order, or explicit list files."""

from __future__ import annotations

import re
from pathlib import Path

from vpr_smr.core.constants import DEFAULT_TOLERANCE
from vpr_smr.datasets.base import (
    DatasetError,
    Traverse,
    TraversePair,
    images_from_list,
    list_files,
    order_note,
    resolved,
    sorted_images,
)


def _traverse(folder: Path | str, images: tuple[Path, ...], by_name: bool) -> Traverse:
    note = order_note([p.name for p in images]) if by_name else None
    return Traverse(Path(folder).name, images, order_note=note)


PAIRINGS = ("by_name", "by_order")
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
) -> TraversePair:
    """Pair two folders frame by frame: image names in natural order, or the order of the list files.

    Without lists, position i of both folders is one place only when the names say so (the same names, or the
    same numbers in them), or when ``pairing="by_order"`` accepts pairing by position alone.
    ``check_files=False`` leaves files named by the lists but missing to ``dataset check``.
    """
    if pairing not in PAIRINGS:
        raise DatasetError(f"datasets.{name}.pairing is {pairing!r}; choose one of {', '.join(PAIRINGS)}")
    if bool(reference_list) != bool(query_list):
        given, other = ("reference_list", "query_list") if reference_list else ("query_list", "reference_list")
        raise DatasetError(f"dataset {name!r}: {given} is set but {other} is not; give both frame lists (line i "
                           "of both names one place) or neither")
    if reference_list and query_list:
        ref_images = images_from_list(reference, reference_list)
        query_images = images_from_list(query, query_list)
        how = f"by the frame lists (line i of {Path(reference_list).name} and {Path(query_list).name})"
        chosen = f"the frames named by the lists {resolved(reference_list)} and {resolved(query_list)}"
    else:
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
        chosen = "every image in them, in natural file-name order"
    pair = TraversePair(
        name=name,
        reference=_traverse(reference, ref_images, by_name=not reference_list),
        query=_traverse(query, query_images, by_name=not query_list),
        tolerance=tolerance,
        splits=dict(splits or {}),
        pairing=how,
        source=f"image folders {resolved(reference)} (reference) and {resolved(query)} (query): {chosen}",
    )
    if check_files:
        pair.check_files()
    return pair
