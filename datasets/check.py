"""Check a dataset on disk: frames found per traverse and per split, missing and unreadable images.

``check_dataset(pair)`` builds a report, ``format_report`` turns it into text, and ``main`` backs the
command ``vpr-smr dataset check NAME --root DIR``. The layout helpers (``require_root``, ``require_images``,
``read_list``) are shared by the benchmark loaders so that every loader fails with the same kind of message:
what is missing, where, and how to fix it.
"""

from __future__ import annotations

import math
import os
import sys
from collections import Counter
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from vpr_smr.datasets.base import (
    MAX_LISTED,
    DatasetError,
    GroundTruthFile,
    Traverse,
    TraversePair,
    list_files,
    radius_text,
)

# Checks a pair's ground-truth file (dataset name, pair) -> (problems, notes): the pipeline's own check before the
# first job, handed in because reading the file belongs to the stages above this one.
GroundTruthCheck = Callable[[str, TraversePair], tuple[list[str], list[str]]]

SHOWN_NAMES = 3  # file names shown from each end of a traverse, in the order used
MAX_HINT_DIRS = 200  # folders looked into when guessing a mis-set root (a root may hold many files)


# --- layout checks shared by the loaders ---


def require_root(dataset: str, root: Path | str, fix: str) -> Path:
    """The root as a Path; raise naming it and the fix when it is not an existing folder."""
    root = Path(root).expanduser()
    if not root.exists():
        raise DatasetError(f"dataset {dataset!r}: root folder {root} does not exist; {fix}")
    if not root.is_dir():
        raise DatasetError(f"dataset {dataset!r}: root {root} is not a folder; {fix}")
    return root


def _relative(path: Path, root: Path) -> str:
    try:
        return path.relative_to(root).as_posix()
    except ValueError:
        return str(path)


def unique(paths: Sequence[Path]) -> list[Path]:
    """Paths in first-seen order without repeats (RobotCar lists repeat frames)."""
    return list(dict.fromkeys(paths))


def missing_folders(paths: Sequence[Path]) -> list[Path]:
    """The parent folders of ``paths`` that do not exist, in first-seen order."""
    # Plain strings: pathlib is slow over the 55184 Nordland paths.
    folders = dict.fromkeys(os.path.dirname(p) for p in paths)
    return [Path(folder) for folder in folders if not os.path.isdir(folder)]


def missing_files(paths: Sequence[Path]) -> list[Path]:
    """The ``paths`` that are not files, once each, in first-seen order."""
    return [p for p in unique(paths) if not os.path.isfile(p)]


def _relative_names(paths: Sequence[Path], root: Path) -> list[Path | str]:
    """``paths`` for ``list_files``: the shown ones relative to root (the others are only counted)."""
    return [_relative(p, root) for p in paths[:MAX_LISTED]] + list(paths[MAX_LISTED:])


def _root_hint(root: Path, wanted: Path) -> str:
    """Where ``wanted`` (a folder relative to root) is, if root is one level too high or too low."""
    candidates = []
    try:
        children = [c for c in sorted(root.iterdir())[:MAX_HINT_DIRS] if c.is_dir()]
    except OSError:
        children = []
    candidates.extend(children)
    candidates.append(root.parent)
    for candidate in candidates:
        if (candidate / wanted).is_dir():
            return f" ({wanted.as_posix()}/ is in {candidate}: did you mean root = {candidate}?)"
    return ""


def require_images(dataset: str, root: Path, images: Sequence[Path], fix: str) -> None:
    """Raise when folders or files named by the frame lists are missing (first few, then a count)."""
    folders = missing_folders(images)
    if folders:
        hint = _root_hint(root, folders[0].relative_to(root)) if folders[0].is_relative_to(root) else ""
        raise DatasetError(
            f"dataset {dataset!r}: {len(folders)} image folder(s) missing under root {root}: "
            f"{list_files(_relative_names(folders, root))}{hint}; {fix}"
        )
    missing = missing_files(images)
    if missing:
        wanted = len(unique(images))
        raise DatasetError(
            f"dataset {dataset!r}: {len(missing)} of the {wanted} images named by the frame lists are "
            f"missing under root {root}: {list_files(_relative_names(missing, root))}. "
            "Complete the download, or give shorter frame lists; "
            f"`vpr-smr dataset check {dataset} --root {root}` reports what is missing per split"
        )


def checked_pair(
    dataset: str,
    root: Path,
    fix: str,
    reference: Traverse,
    query: Traverse,
    splits: dict[str, tuple[int, int]],
    tolerance: int,
    check_files: bool,
    source: str,
) -> TraversePair:
    """A loader's pair named ``dataset`` (``source``: where its images come from, ``TraversePair.source``); with
    ``check_files``, first raise when images are missing (``require_images`` over both traverses)."""
    if check_files:
        require_images(dataset, root, [*reference.images, *query.images], fix)
    return TraversePair(name=dataset, reference=reference, query=query, tolerance=tolerance, splits=dict(splits),
                        source=source)


def read_list(dataset: str, list_file: Path | str, option: str) -> list[str]:
    """The non-blank, non-``#`` lines of a frame list; a missing or empty list raises naming ``option``."""
    list_file = Path(list_file).expanduser()
    if not list_file.is_file():
        raise DatasetError(f"dataset {dataset!r}: frame list {list_file} not found; fix or remove {option}")
    lines = [line.strip() for line in list_file.read_text().splitlines()]
    lines = [line for line in lines if line and not line.startswith("#")]
    if not lines:
        raise DatasetError(f"dataset {dataset!r}: frame list {list_file} names no frames; fix {option}")
    return lines


# --- the report ---


@dataclass
class TraverseCheck:
    """What was found of one traverse; indices are frame positions (a repeated file counts at each one)."""

    role: str  # "reference" or "query"
    name: str
    frames: int
    missing: list[int] = field(default_factory=list)
    unreadable: list[int] = field(default_factory=list)
    errors: dict[Path, str] = field(default_factory=dict)  # reason per unreadable file
    missing_files: list[Path] = field(default_factory=list)  # unique, in frame order
    missing_folders: list[Path] = field(default_factory=list)
    sizes: Counter[str] = field(default_factory=Counter)  # "WxHxC" -> number of files
    first: list[str] = field(default_factory=list)  # the first and last file names, in the order used
    last: list[str] = field(default_factory=list)
    order_note: str | None = None
    # method §11, pairs with positions only: frames without a position, and the median step between frames
    unpositioned: list[int] = field(default_factory=list)
    unpositioned_names: list[str] = field(default_factory=list)
    spacing: float | None = None

    @property
    def bad(self) -> set[int]:
        return set(self.missing) | set(self.unreadable)

    @property
    def found(self) -> int:
        return self.frames - len(self.bad)


@dataclass
class SplitCheck:
    name: str
    lo: int
    hi: int
    reference: int  # usable reference frames in [lo, hi) (its reference range, with positions)
    query: int
    both: int  # positions where both images are usable
    reference_range: tuple[int, int] | None = None  # pairs with positions: the reference range (lo, hi: queries)

    @property
    def frames(self) -> int:
        return self.hi - self.lo


@dataclass
class DatasetReport:
    dataset: str
    frames: int
    tolerance: int
    traverses: list[TraverseCheck]
    splits: list[SplitCheck]
    decoded: bool
    pairing: str = ""
    pairs: list[tuple[int, str, str]] = field(default_factory=list)  # (frame, reference name, query name)
    radius: float | None = None  # pairs with positions (method §11): the ground truth's radius, in position_unit
    position_unit: str = ""
    ground_truth: GroundTruthFile | None = None  # a ground-truth file (method §13) in place of the tolerance
    truth_problems: list[str] = field(default_factory=list)  # what is wrong with that file, as `run` refuses it
    truth_notes: list[str] = field(default_factory=list)

    @property
    def positioned(self) -> bool:
        return self.radius is not None

    @property
    def ok(self) -> bool:
        return all(not t.bad and not t.unpositioned for t in self.traverses) and not self.truth_problems

    @property
    def status(self) -> int:
        return 0 if self.ok else 1


def _decode(traverse: Traverse, index: int) -> tuple[str | None, str | None]:
    """(size, None) or (None, reason); reads via Traverse.read, so RobotCar mosaics are demosaiced too."""
    try:
        image = traverse.read(index)
    except (DatasetError, cv2.error, ValueError, OSError) as error:
        return None, str(error)
    if image.size == 0:
        return None, "empty image"
    channels = image.shape[2] if image.ndim == 3 else 1
    return f"{image.shape[1]}x{image.shape[0]}x{channels}", None


def _check_traverse(role: str, traverse: Traverse, decode: bool, workers: int) -> TraverseCheck:
    report = TraverseCheck(role, traverse.name, len(traverse), order_note=traverse.order_note)
    names = [p.name for p in traverse.images]
    report.first = names[:SHOWN_NAMES]
    report.last = names[max(SHOWN_NAMES, len(names) - SHOWN_NAMES):]
    first_index: dict[Path, int] = {}
    for i, path in enumerate(traverse.images):
        first_index.setdefault(path, i)
    report.missing_folders = missing_folders(list(first_index))
    present = []
    for path in first_index:
        if os.path.isfile(path):
            present.append(path)
        else:
            report.missing_files.append(path)
    unreadable: set[Path] = set()
    if decode and present:
        # Decode each file once; OpenCV releases the GIL, so threads overlap the reads.
        with ThreadPoolExecutor(max_workers=max(1, workers)) as pool:
            results = pool.map(lambda p: _decode(traverse, first_index[p]), present)
            for path, (size, reason) in zip(present, results, strict=True):
                if reason is None:
                    assert size is not None  # _decode gives a size exactly when it gives no reason
                    report.sizes[size] += 1
                else:
                    report.errors[path] = reason
                    unreadable.add(path)
    missing = set(report.missing_files)
    for i, path in enumerate(traverse.images):
        if path in missing:
            report.missing.append(i)
        elif path in unreadable:
            report.unreadable.append(i)
    return report


def _check_positions(report: TraverseCheck, traverse: Traverse) -> None:
    """Which frames have no position (NaN: ``dataset check`` loads them without refusing) and the median step."""
    from vpr_smr.datasets.positions import median_spacing

    assert traverse.positions is not None
    report.unpositioned = [int(i) for i in np.flatnonzero(~np.all(np.isfinite(traverse.positions), axis=1))]
    report.unpositioned_names = [traverse.images[i].name for i in report.unpositioned]
    report.spacing = median_spacing(traverse.positions)


def _positioned_splits(pair: TraversePair, traverses: list[TraverseCheck]) -> list[SplitCheck]:
    """Each split's usable frames (found, readable, with a position) in its reference and its query range."""
    ref_unusable = traverses[0].bad | set(traverses[0].unpositioned)
    query_unusable = traverses[1].bad | set(traverses[1].unpositioned)
    splits = []
    for name, (lo, hi) in pair.splits.items():
        ref_lo, ref_hi = pair.reference_range(name)
        ref_ok = sum(1 for i in range(ref_lo, ref_hi) if i not in ref_unusable)
        query_ok = sum(1 for i in range(lo, hi) if i not in query_unusable)
        splits.append(SplitCheck(name, lo, hi, ref_ok, query_ok, min(ref_ok, query_ok), (ref_lo, ref_hi)))
    return splits


def check_dataset(pair: TraversePair, decode: bool = True, workers: int = 4) -> DatasetReport:
    """Look for every image of both traverses and (``decode``) try to read each one; with positions, count the
    frames without one and measure the median spacing of each traverse."""
    traverses = [
        _check_traverse("reference", pair.reference, decode, workers),
        _check_traverse("query", pair.query, decode, workers),
    ]
    if pair.has_positions:
        for report, traverse in zip(traverses, (pair.reference, pair.query), strict=True):
            _check_positions(report, traverse)
        return DatasetReport(pair.name, len(pair), pair.tolerance, traverses, _positioned_splits(pair, traverses),
                             decode, pair.pairing, [], radius=pair.radius, position_unit=pair.position_unit)
    ref_bad, query_bad = traverses[0].bad, traverses[1].bad
    splits = []
    for name, (lo, hi) in pair.splits.items():
        frames = range(lo, hi)
        ref_ok = sum(1 for i in frames if i not in ref_bad)
        query_ok = sum(1 for i in frames if i not in query_bad)
        both = sum(1 for i in frames if i not in ref_bad and i not in query_bad)
        splits.append(SplitCheck(name, lo, hi, ref_ok, query_ok, both))
    n = len(pair)
    shown = sorted({*range(min(SHOWN_NAMES, n)), *range(max(0, n - SHOWN_NAMES), n)})
    pairs = [(i, pair.reference.images[i].name, pair.query.images[i].name) for i in shown]
    return DatasetReport(pair.name, n, pair.tolerance, traverses, splits, decode, pair.pairing, pairs)


def _distance(value: float | None, unit: str) -> str:
    return "n/a" if value is None or math.isnan(value) else radius_text(float(f"{value:.3g}"), unit)


def _positions_line(t: TraverseCheck, unit: str) -> str:
    line = f"    positions: {t.frames - len(t.unpositioned)} of {t.frames} frames, median spacing " \
           f"{_distance(t.spacing, unit)} between consecutive frames"
    if t.unpositioned:
        line += f"; {len(t.unpositioned)} without a position: {list_files(t.unpositioned_names)}"
    return line


def _split_line(s: SplitCheck) -> str:
    if s.reference_range is None:
        incomplete = "" if s.both == s.frames else f" ({s.frames - s.both} incomplete)"
        return (f"  split {s.name} [{s.lo}, {s.hi}): {s.frames} frames; reference {s.reference}, "
                f"query {s.query}, both {s.both}{incomplete}")
    (ref_lo, ref_hi) = s.reference_range
    return (f"  split {s.name}: references [{ref_lo}, {ref_hi}) {ref_hi - ref_lo} frames ({s.reference} usable), "
            f"queries [{s.lo}, {s.hi}) {s.frames} frames ({s.query} usable)")


def _heading(report: DatasetReport) -> str:
    given = report.ground_truth
    if given is not None:
        key = f", key {given.key}" if given.key else ""
        return (f"dataset {report.dataset!r}: {report.frames} aligned frames, correct matches from the ground-truth "
                f"file {given.path} ({given.form}{key})")
    if not report.positioned:
        return f"dataset {report.dataset!r}: {report.frames} aligned frames, tolerance {report.tolerance}"
    reference, query = report.traverses
    assert report.radius is not None
    return (f"dataset {report.dataset!r}: {reference.frames} reference and {query.frames} query frames with "
            f"positions, a match correct within {radius_text(report.radius, report.position_unit)}")


def format_report(report: DatasetReport) -> str:
    """Human-readable text of a report; problems list the first few files, then a count."""
    verb = "found and readable" if report.decoded else "found (not decoded)"
    lines = [_heading(report)]
    if report.pairing and report.positioned:
        lines.append(f"  paired {report.pairing}")
    elif report.pairing:
        lines.append(f"  paired {report.pairing}:")
        width = max(len(ref) for _, ref, _ in report.pairs)
        for i, (frame, ref, query) in enumerate(report.pairs):
            if i and frame != report.pairs[i - 1][0] + 1:
                lines.append("    ...")
            lines.append(f"    {frame:>6}  {ref:<{width}}  <->  {query}")
    for t in report.traverses:
        # a traverse named after its role (folders called reference and query) is named once
        line = f"  {t.role if t.name == t.role else f'{t.role} {t.name}'}: {t.found} of {t.frames} frames {verb}"
        if t.missing:
            line += f", {len(t.missing)} missing ({len(t.missing_files)} files)"
        if t.unreadable:
            line += f", {len(t.unreadable)} unreadable ({len(t.errors)} files)"
        lines.append(line)
        if t.sizes:
            sizes = ", ".join(f"{size} ({n})" for size, n in t.sizes.most_common())
            lines.append(f"    image sizes (W x H x channels): {sizes}")
        if t.first:
            lines.append(f"    order: {', '.join(t.first)}" + (f" ... {', '.join(t.last)}" if t.last else ""))
        if t.order_note:
            lines.append(f"    warning: {t.order_note}")
        if report.positioned:
            lines.append(_positions_line(t, report.position_unit))
    lines.extend(_split_line(s) for s in report.splits)
    for t in report.traverses:
        if t.missing_folders:
            lines.append(f"  missing folders ({t.role} {t.name}): {list_files(t.missing_folders)}")
        if t.missing_files:
            count = len(t.missing_files)
            lines.append(f"  missing files ({t.role} {t.name}, {count}): {list_files(t.missing_files)}")
        if t.errors:
            shown = [f"{path} ({reason})" for path, reason in t.errors.items()]
            lines.append(f"  unreadable files ({t.role} {t.name}, {len(shown)}): {list_files(shown)}")
    lines.extend(f"  note: {note}" for note in report.truth_notes)
    lines.extend(f"  ground truth: {problem}" for problem in report.truth_problems)
    if report.ok:
        lines.append("status: OK")
    else:
        missing = sum(len(t.missing_files) for t in report.traverses)
        unreadable = sum(len(t.errors) for t in report.traverses)
        unpositioned = sum(len(t.unpositioned) for t in report.traverses)
        without = f", {unpositioned} frames without a position" if unpositioned else ""
        truth = ", the ground-truth file refused" if report.truth_problems else ""
        lines.append(f"status: PROBLEMS ({missing} missing files, {unreadable} unreadable files{without}{truth})")
    return "\n".join(lines)


def main(settings: dict[str, Any], name: str | None = None, decode: bool = True, workers: int = 4,
         check_ground_truth: GroundTruthCheck | None = None, source: str | None = None) -> int:
    """``vpr-smr dataset check``: print the report of a dataset's configuration entry (``{loader: ..., ...}``, as
    in a configuration's ``datasets``); 0 if all is well, 1 on problems found, 2 when the dataset cannot be
    loaded at all (unknown loader, missing or misspelt options, missing root or frame lists). An entry with a
    ``ground_truth`` file needs ``check_ground_truth`` (``vpr-smr run``'s check of it), whose problems count.
    ``source``: the configuration file the settings come from, which an error then names with the setting's key."""
    from vpr_smr.datasets import LOADERS, load_dataset, required_options, unknown_option

    loader_name = settings.get("loader")
    if not isinstance(loader_name, str) or loader_name not in LOADERS:
        choices = ", ".join(sorted(LOADERS))
        print(f"error: unknown dataset loader {loader_name!r}; choose one of {choices}", file=sys.stderr)
        return 2
    for key in settings:
        problem = unknown_option(loader_name, key)
        if problem and source:
            print(f"error: {source}: datasets.{name or loader_name}.{key}: {problem}", file=sys.stderr)
            return 2
        if problem:
            print(f"error: {problem} (as options: {', '.join(map(cli_option, loader_options_of(loader_name)))})",
                  file=sys.stderr)
            return 2
    missing = [option for option in required_options(loader_name) if option not in settings]
    if missing:
        example = " ".join(f"{cli_option(option)} {EXAMPLE_VALUES.get(option, 'DIR')}" for option in missing)
        example = example.replace("<loader>", loader_name)
        print(f"error: loader {loader_name!r} needs {', '.join(map(cli_option, missing))}; e.g.\n"
              f"  vpr-smr dataset check {loader_name} {example}", file=sys.stderr)
        return 2
    try:
        pair = load_dataset(name or loader_name, settings, check_files=False)
    except DatasetError as error:
        print(f"error: {f'{source}: ' if source else ''}{error}", file=sys.stderr)
        return 2
    report = check_dataset(pair, decode=decode, workers=workers)
    if pair.ground_truth is not None:
        if check_ground_truth is None:
            raise ValueError("a dataset with a ground-truth file is checked with check_ground_truth")
        report.ground_truth = pair.ground_truth
        report.truth_problems, report.truth_notes = check_ground_truth(name or loader_name, pair)
    print(format_report(report))
    return report.status


EXAMPLE_VALUES = {"reference": "my_route/reference", "query": "my_route/query", "root": "/data/<loader>"}


def cli_option(key: str) -> str:
    """The command-line form of a dataset setting: ``reference_list`` -> ``--reference-list``."""
    return "--" + key.replace("_", "-")


def loader_options_of(loader_name: str) -> list[str]:
    from vpr_smr.datasets import loader_options

    return [*loader_options(loader_name), "frames", "splits", "tolerance", "radius"]
