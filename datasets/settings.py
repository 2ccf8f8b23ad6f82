"""A dataset entry's settings, declared once (``core.settings``): ``pipeline.reference`` writes the configuration
schema's dataset entry and its part of ``docs/configuration.md`` from ``DatasetEntry``.

The entry reaches the loader as the configuration gives it: nothing is filled in (the descriptors job's params hash
the entry, so a default written into it would rerun every dataset's descriptors), and a setting that is not given
takes the loader's own default (``UNSET``). Beside these keys an entry holds its loader's own (``reference``,
``query_list``, ...), which the loader's ``Settings`` record declares and ``datasets.unknown_option`` checks.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from vpr_smr.core.constants import DEFAULT_TOLERANCE
from vpr_smr.core.settings import REQUIRED, UNSET, setting
from vpr_smr.datasets.folders import POSITIONS as FOLDERS_POSITIONS
from vpr_smr.datasets.robotcar import DEFAULT_RADIUS
from vpr_smr.datasets.robotcar import POSITIONS as ROBOTCAR_POSITIONS

__all__ = ["SPLIT_SETTINGS", "DatasetEntry"]

_RANGE = {"type": "array", "items": {"type": "integer", "minimum": 0}, "minItems": 2, "maxItems": 2}
# method §13: one file, as a matrix or as lists; `key` names the variable of a .npz or .mat file
_GROUND_TRUTH = {
    "type": "object", "additionalProperties": False,
    "oneOf": [{"required": ["matrix"], "not": {"required": ["lists"]}},
              {"required": ["lists"], "not": {"required": ["matrix"]}}],
    "properties": {form: {"type": "string", "minLength": 1} for form in ("matrix", "lists", "key")},
}
# a split's two forms; the description is what a value that fits neither is told (pipeline.config's messages)
_SPLITS = {"type": "object", "additionalProperties": {
    "description": "a split is [lo, hi] (frames lo .. hi-1 of both traverses) or, for frames with positions, "
                   "{reference: [lo, hi], query: [lo, hi]}",
    "oneOf": [{**_RANGE, "description": "[first, end) frames of both traverses"},
              {"type": "object", "description": "method §11, frames with positions: the reference and the query "
                                                "range apart",
               "required": ["reference", "query"], "additionalProperties": False,
               "properties": {"reference": _RANGE, "query": _RANGE}}]}}


@dataclass(frozen=True)
class DatasetEntry:
    """The settings of a ``datasets`` entry that the schema describes: the loader, its root, the frames, the
    splits, the ground truth and the positions; a loader's other parameters are its own."""

    loader: str = setting(REQUIRED, "the dataset's loader (vpr-smr dataset check --help names them)")
    root: str | None = setting(UNSET, "the dataset's folder (benchmark loaders); null: the loader's own")
    tolerance: int = setting(UNSET, f"frames; default: the loader's ({DEFAULT_TOLERANCE}, method §1)", minimum=0)
    radius: float = setting(
        UNSET, "method §11, frames with positions only: a match is correct within this distance, in the positions' "
               "unit (metres for lat/lon, @UTM@ names and RobotCar's INS; default "
               f"{DEFAULT_RADIUS:g} for robotcar's positions: ins, none for folders)", exclusive_minimum=0)
    ground_truth: dict[str, str] = setting(
        UNSET, "method §13: the correct references of each query from a file instead of a tolerance or radius: "
               "{matrix: FILE} (a boolean references x queries matrix over the whole traverses: .npy, .npz or a .mat "
               "variable such as VPR_Tutorial's GThard) or {lists: FILE} (per-query lists: a JSON object "
               "{\"query\": [references]}, a CSV query,reference, or VPR-Bench's ground_truth_new.npy); a relative "
               "path is looked for from the configuration's folder; key: the variable of a .npz or .mat file",
        schema=_GROUND_TRUTH)
    reference_positions: str = setting(
        UNSET, "folders: a CSV with the header name,x,y or name,lat,lon and one row per reference image (method "
               "§11); with query_positions")
    query_positions: str = setting(UNSET, "folders: the same for the query images")
    positions: str = setting(
        UNSET, "method §11: folders: file_names (the @UTM_east@UTM_north@ names of VPR-methods-evaluation); "
               "robotcar: ins (the raw runs, positioned by gps/ins.csv)",
        choices=FOLDERS_POSITIONS + ROBOTCAR_POSITIONS)
    every: int = setting(UNSET, "robotcar with positions: ins: keep one image in every N of the raw runs", minimum=1)
    frames: tuple[int, ...] = setting(UNSET, "[lo, hi]: keep frames lo .. hi-1 of both traverses only", minimum=0,
                                      min_items=2, max_items=2)
    splits: dict[str, Any] = setting(
        UNSET, "the splits by name (train_split, eval_splits and table_split name them): each [lo, hi] or, for "
               "frames with positions, {reference: [lo, hi], query: [lo, hi]}", schema=_SPLITS)


# Settings that only reach the distances and attributes jobs: the descriptors of a dataset depend on the others.
# `radius` (method §11) is the ground truth of pairs with positions, as `tolerance` is of frame-aligned ones.
# `ground_truth` (method §13) gives the correct references from a file instead.
SPLIT_SETTINGS = ("splits", "tolerance", "radius", "ground_truth")
