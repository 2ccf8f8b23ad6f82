"""Datasets: a loader per layout on disk, selected by name in the configuration."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

from .base import DatasetError, Traverse, TraversePair, read_image
from .folders import folder_pair
from .nordland import nordland
from .nordland_sample import nordland_sample
from .robotcar import robotcar
from .sfu_mountain import sfu_mountain

LOADERS: dict[str, Callable[..., TraversePair]] = {
    "folders": folder_pair,
    "nordland_sample": nordland_sample,
    "nordland": nordland,
    "robotcar": robotcar,
    "sfu_mountain": sfu_mountain,
}

__all__ = ["DatasetError", "LOADERS", "Traverse", "TraversePair", "load_dataset", "read_image"]


def slice_pair(pair: TraversePair, lo: int, hi: int, splits: dict[str, tuple[int, int]]) -> TraversePair:
    """Frames ``lo .. hi-1`` of both traverses, with split ranges relative to the slice."""
    return replace(
        pair,
        # replace() keeps the traverse's class, e.g. RobotCar's demosaicing reader
        reference=replace(pair.reference, images=pair.reference.images[lo:hi]),
        query=replace(pair.query, images=pair.query.images[lo:hi]),
        splits=dict(splits),
    )


def load_dataset(name: str, conf: dict[str, Any]) -> TraversePair:
    """Build the TraversePair of a configuration entry ``{loader: ..., <loader arguments>, frames?: [lo, hi]}``.

    ``frames`` keeps a slice of the frames (for quick runs); ``splits`` are then relative to that slice.
    """
    conf = dict(conf)
    loader_name = conf.pop("loader", None)
    if loader_name not in LOADERS:
        raise DatasetError(
            f"datasets.{name}.loader is {loader_name!r}; choose one of {', '.join(sorted(LOADERS))}"
        )
    frames = conf.pop("frames", None)
    splits = {k: tuple(v) for k, v in conf.pop("splits", {}).items()}
    loader = LOADERS[loader_name]
    kwargs = dict(conf)
    if loader_name == "folders":
        kwargs["name"] = name
    if frames is None:
        if splits:
            kwargs["splits"] = splits
    else:
        kwargs["splits"] = {}  # the splits apply to the slice, below
    try:
        pair = loader(**kwargs)
    except TypeError as error:
        raise DatasetError(f"datasets.{name}: bad settings for loader {loader_name!r}: {error}") from None
    if frames is not None:
        lo, hi = frames
        if not 0 <= lo < hi <= len(pair):
            raise DatasetError(f"datasets.{name}.frames = [{lo}, {hi}] is outside the {len(pair)} frames")
        pair = slice_pair(pair, lo, hi, splits or {"all": (0, hi - lo)})
    return replace(pair, name=name)
