"""Any two image folders with a frame-aligned order: sorted file names, or explicit list files."""

from __future__ import annotations

from pathlib import Path

from .base import DEFAULT_TOLERANCE, DatasetError, Traverse, TraversePair, images_from_list, list_files, sorted_images


def folder_pair(
    name: str,
    reference: Path | str,
    query: Path | str,
    splits: dict[str, tuple[int, int]],
    tolerance: int = DEFAULT_TOLERANCE,
    reference_list: Path | str | None = None,
    query_list: Path | str | None = None,
) -> TraversePair:
    """Pair two folders frame by frame: sorted image names, or the order of the optional list files."""
    ref_images = images_from_list(reference, reference_list) if reference_list else sorted_images(reference)
    query_images = images_from_list(query, query_list) if query_list else sorted_images(query)
    if not reference_list and not query_list:
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
    pair = TraversePair(
        name=name,
        reference=Traverse(Path(reference).name, ref_images),
        query=Traverse(Path(query).name, query_images),
        tolerance=tolerance,
        splits=dict(splits),
    )
    pair.check_files()
    return pair
