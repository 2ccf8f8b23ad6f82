"""Datasets: a loader per layout on disk, selected by name in the configuration.

A loader is a ``loaders.Loader``: its function and the record of its settings. ``LOADERS`` holds the built-in ones
and finds those an installed package registers through the entry point group ``vpr_smr.loaders``.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from vpr_smr.core.registry import Registry
from vpr_smr.core.suggest import did_you_mean
from vpr_smr.datasets.base import (
    DatasetError,
    GroundTruthFile,
    Traverse,
    TraversePair,
    positions_pairing,
    read_image,
    slice_traverse,
)
from vpr_smr.datasets.folders import FoldersSettings, folder_pair
from vpr_smr.datasets.loaders import ENTRY_POINT_GROUP, Loader, as_loader
from vpr_smr.datasets.nordland import SPLITS as NORDLAND_SPLITS
from vpr_smr.datasets.nordland import NordlandSettings, nordland
from vpr_smr.datasets.nordland_sample import SPLITS as NORDLAND_SAMPLE_SPLITS
from vpr_smr.datasets.nordland_sample import NordlandSampleSettings, nordland_sample
from vpr_smr.datasets.robotcar import SPLITS as ROBOTCAR_SPLITS
from vpr_smr.datasets.robotcar import RobotCarSettings, robotcar
from vpr_smr.datasets.settings import SPLIT_SETTINGS, DatasetEntry
from vpr_smr.datasets.sfu_mountain import SPLITS as SFU_MOUNTAIN_SPLITS
from vpr_smr.datasets.sfu_mountain import SFUMountainSettings, sfu_mountain

# a bare function (a test's stand-in, a plugin of 0.16) is read through ``as_loader``: ``loader`` gives every item so
LOADERS: Registry[Loader] = Registry("dataset loader", ENTRY_POINT_GROUP, check=as_loader)
LOADERS.add("folders", Loader(folder_pair, FoldersSettings, ("name", "check_files", "splits")))
# the benchmarks' published splits (method §1); a `folders` dataset has none until the configuration names them
LOADERS.add("nordland_sample", Loader(nordland_sample, NordlandSampleSettings, splits=NORDLAND_SAMPLE_SPLITS))
LOADERS.add("nordland", Loader(nordland, NordlandSettings, ("check_files", "splits"), NORDLAND_SPLITS))
LOADERS.add("robotcar", Loader(robotcar, RobotCarSettings, ("check_files", "splits"), ROBOTCAR_SPLITS))
LOADERS.add("sfu_mountain", Loader(sfu_mountain, SFUMountainSettings, ("check_files", "splits"), SFU_MOUNTAIN_SPLITS))

__all__ = [
    "LOADERS", "SPLIT_SETTINGS", "DatasetEntry", "DatasetError", "Loader", "Traverse", "TraversePair",
    "frames_settings", "load_dataset", "load_frames", "loader", "loader_option_help", "loader_options", "read_image",
    "required_options", "unknown_option",
]


def frames_settings(conf: dict[str, Any]) -> dict[str, Any]:
    """A dataset's configuration entry without its split settings: what selects and orders the frames."""
    return {key: value for key, value in conf.items() if key not in SPLIT_SETTINGS}


def loader(loader_name: str) -> Loader:
    """The registered loader ``loader_name`` (KeyError naming the available ones for another name)."""
    return as_loader(loader_name, LOADERS[loader_name])


def loader_options(loader_name: str) -> list[str]:
    """The settings a loader takes in the configuration (besides ``loader``, ``frames`` and the split settings)."""
    return loader(loader_name).options()


def loader_option_help(loader_name: str) -> dict[str, str]:
    """What each of a loader's settings means (its record's help); the configuration reference shows them."""
    return loader(loader_name).help()


def required_options(loader_name: str) -> list[str]:
    """The settings a loader cannot do without (``reference`` and ``query`` of ``folders``, a benchmark's root)."""
    return loader(loader_name).required()


def unknown_option(loader_name: str, key: str) -> str | None:
    """Why ``key`` is not a setting of the loader (with the closest valid one), or None when it is."""
    # every key a dataset entry may hold: a typo of `tolerance` must find it, not the loader's nearest setting
    valid = ["loader", *loader_options(loader_name), "frames", *SPLIT_SETTINGS]
    if key in valid:
        return None
    hint = did_you_mean(key, valid)
    return f"loader {loader_name!r} has no setting {key!r}{hint}; its settings: {', '.join(valid)}"


def _check_options(name: str, loader_name: str, options: dict[str, Any]) -> None:
    """Name a misspelt or missing loader setting with the valid ones, before the loader runs."""
    for key in options:
        problem = unknown_option(loader_name, key)
        if problem:
            raise DatasetError(f"datasets.{name}.{key}: {problem}")
    missing = [p for p in required_options(loader_name) if p not in options]
    if missing:
        raise DatasetError(f"datasets.{name}: loader {loader_name!r} needs {', '.join(missing)}; e.g. "
                           + ", ".join(f"{p}: path/to/{p}" for p in missing))


def slice_pair(pair: TraversePair, lo: int, hi: int, splits: dict[str, tuple[int, int]]) -> TraversePair:
    """Frames ``lo .. hi-1`` of both traverses (positions too), with split ranges relative to the slice."""
    return replace(
        pair,
        # replace() keeps the traverse's class, e.g. RobotCar's demosaicing reader
        reference=slice_traverse(pair.reference, lo, hi),
        query=slice_traverse(pair.query, lo, hi),
        splits=dict(splits),
        reference_splits={},
    )


def load_frames(name: str, conf: dict[str, Any], check_files: bool = True) -> TraversePair:
    """The frames of a configuration entry ``{loader: ..., <loader settings>, frames?: [lo, hi]}``, in order.

    The one code path that builds a dataset, for the configuration check and for the descriptors job alike;
    split settings in ``conf`` are ignored (``load_dataset`` applies them). With ``frames`` the pair keeps only
    that slice, and has no splits. ``check_files=False`` lets ``dataset check`` report missing files instead of
    stopping at them.
    """
    conf = frames_settings(conf)
    loader_name = conf.pop("loader", None)
    if loader_name not in LOADERS:
        raise DatasetError(
            f"datasets.{name}.loader is {loader_name!r}; choose one of {', '.join(sorted(LOADERS))}"
        )
    frames = conf.pop("frames", None)
    _check_options(name, loader_name, conf)
    try:
        pair = loader(loader_name).load(name, conf, check_files)  # splits: {}: load_dataset applies them
    except TypeError as error:  # a setting of the wrong kind (a number or list where a path is wanted)
        raise DatasetError(f"datasets.{name}: bad settings for loader {loader_name!r}: {error}") from None
    if frames is not None:
        lo, hi = frames
        # both traverses keep the same slice; with positions their lengths may differ: the shorter one counts
        n = min(len(pair.reference), len(pair.query))
        shorter = " of the shorter traverse" if len(pair.reference) != len(pair.query) else ""
        if not 0 <= lo < hi <= n:
            raise DatasetError(f"datasets.{name}.frames = [{lo}, {hi}] is outside the {n} frames{shorter}; "
                               f"give a range within [0, {n}]")
        pair = replace(slice_pair(pair, lo, hi, {}),
                       source=f"{pair.source}; frames [{lo}, {hi}) of its {len(pair)} (the frames setting)")
    return replace(pair, name=name)


def split_ranges(name: str, splits: dict[str, Any]) -> tuple[dict[str, tuple[int, int]], dict[str, tuple[int, int]]]:
    """A configuration's ``splits`` as (query ranges, reference ranges that differ from them).

    A split is ``[lo, hi]`` (both traverses) or ``{reference: [lo, hi], query: [lo, hi]}`` (method §11).
    """
    query: dict[str, tuple[int, int]] = {}
    reference: dict[str, tuple[int, int]] = {}
    for split, value in splits.items():
        if isinstance(value, dict):
            if set(value) != {"reference", "query"}:
                raise DatasetError(f"datasets.{name}.splits.{split} has keys {', '.join(map(str, value)) or 'none'}; "
                                   "give [lo, hi] for both traverses or {reference: [lo, hi], query: [lo, hi]}")
            query[split] = _range(name, split, value["query"])
            if (own := _range(name, split, value["reference"])) != query[split]:
                reference[split] = own
        else:
            query[split] = _range(name, split, value)
    return query, reference


def _range(name: str, split: str, value: Any) -> tuple[int, int]:
    try:
        lo, hi = value
        return int(lo), int(hi)
    except (TypeError, ValueError):
        problem = f"datasets.{name}.splits.{split} is {value!r}; a range is [lo, hi] (frames lo .. hi-1)"
        raise DatasetError(problem) from None


def _ground_truth(name: str, conf: dict[str, Any], pair: TraversePair) -> dict[str, Any]:
    """The entry's ``tolerance`` or ``radius``, whichever the pair's ground truth uses, or its ``ground_truth`` file
    (method §13), as ``replace`` arguments."""
    entry = conf.get("ground_truth")
    if entry is not None:
        given = [key for key in ("tolerance", "radius") if key in conf]
        if given:
            raise DatasetError(f"datasets.{name}: both ground_truth and {given[0]} are set; the file says which "
                               f"references are correct, so {given[0]} would be ignored: remove one of them")
        if pair.has_positions:
            raise DatasetError(f"datasets.{name}.ground_truth is set, but the frames have positions: their ground "
                               "truth is `radius` (method §11); remove ground_truth, or the positions")
        form = "matrix" if "matrix" in entry else "lists"
        return {"ground_truth": GroundTruthFile(form, str(entry[form]), entry.get("key"))}
    if not pair.has_positions:
        return {"tolerance": conf.get("tolerance", pair.tolerance), "radius": conf.get("radius")}
    if "tolerance" in conf:
        raise DatasetError(f"datasets.{name}.tolerance is set, but the frames have positions: a match is correct "
                           f"within `radius` ({pair.position_unit}), not within a number of frames; remove "
                           "tolerance and set radius")
    radius = conf.get("radius", pair.radius)
    if radius is None:
        unit = pair.position_unit
        raise DatasetError(f"datasets.{name}.radius is not set: the frames have positions in {unit}, and a match is "
                           f"correct within radius of its query; give it in {unit}, e.g. radius: 25")
    if isinstance(radius, bool) or not isinstance(radius, int | float):
        raise DatasetError(f"datasets.{name}.radius is {radius!r}: give a number, in {pair.position_unit}")
    return {"radius": float(radius),
            "pairing": positions_pairing(pair.position_source, float(radius), pair.position_unit)}


def load_dataset(name: str, conf: dict[str, Any], check_files: bool = True) -> TraversePair:
    """``load_frames`` with the entry's ``splits`` and ``tolerance``, or ``radius`` for frames with positions
    (default: the loader's).

    With ``frames``, ``splits`` are relative to the slice (default: one split ``all`` over the slice). A pair
    with positions has no default splits: the published ones index the benchmarks' place-aligned lists.
    """
    pair = load_frames(name, conf, check_files)
    if "splits" in conf:
        splits, reference_splits = split_ranges(name, conf["splits"])
    else:
        splits, reference_splits = _default_splits(conf, pair), {}
    return replace(pair, splits=dict(splits), reference_splits=reference_splits, **_ground_truth(name, conf, pair))


def _default_splits(conf: dict[str, Any], pair: TraversePair) -> dict[str, tuple[int, int]]:
    if "frames" in conf:
        return {"all": (0, len(pair))}
    if pair.has_positions:
        return {}
    return dict(loader(conf["loader"]).splits)  # load_frames has checked that it names a loader
