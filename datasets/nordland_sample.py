"""The real Nordland sample shipped in ``data/nordland_sample``: 3576 summer/winter frames at 64x32.

Frames are matched one-to-one by file name (every 10th frame of the NRK videos; CC BY 3.0, NRK / Nordland
dataset, see the PROVENANCE.md beside the images).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

from vpr_smr.core.constants import DEFAULT_TOLERANCE
from vpr_smr.core.settings import setting
from vpr_smr.datasets.base import SHIPPED_DATA, TraversePair, resolved
from vpr_smr.datasets.folders import folder_pair

DEFAULT_ROOT = SHIPPED_DATA / "nordland_sample"
SPLITS = {"train": (0, 500), "val": (500, 1000), "test": (1000, 3576)}
SHIPPED = ("the Nordland 64x32 sample vendored with vpr-smr (data/nordland_sample): every 10th frame of NRK's "
           "Nordlandsbanen summer and winter footage, CC BY 3.0 (NRK / Nordland dataset); its origin and licence: "
           "data/nordland_sample/PROVENANCE.md")


def source(root: Path | str) -> str:
    """Where the sample's images come from: the vendored copy, or another folder of the same layout."""
    folders = f"{resolved(Path(root) / 'summer')} (reference) and {resolved(Path(root) / 'winter')} (query)"
    if resolved(root) == resolved(DEFAULT_ROOT):
        return f"{SHIPPED}; read from {folders}"
    provenance = Path(root) / "PROVENANCE.md"
    note = f"; its provenance: {resolved(provenance)}" if provenance.is_file() else ""
    return f"a folder of the Nordland 64x32 sample's layout: {folders}, paired by file name{note}"


@dataclass(frozen=True)
class NordlandSampleSettings:
    """The settings of the ``nordland_sample`` loader."""

    root: Path | str = setting(DEFAULT_ROOT, "a folder of the sample's layout (summer/, winter/; default: the "
                                             "vendored sample)")


def nordland_sample(
    root: Path | str = DEFAULT_ROOT,
    splits: dict[str, tuple[int, int]] | None = None,
    tolerance: int = DEFAULT_TOLERANCE,
) -> TraversePair:
    """Summer is the reference, winter the query."""
    splits = SPLITS if splits is None else splits
    pair = folder_pair("nordland_sample", Path(root) / "summer", Path(root) / "winter", splits=splits,
                       tolerance=tolerance)
    return replace(pair, source=source(root))
