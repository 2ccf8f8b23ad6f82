"""The real Nordland sample shipped in ``data/nordland_sample``: 3576 summer/winter frames at 64x32.

Frames are matched one-to-one by file name (every 10th frame of the NRK videos; CC BY 3.0, NRK / Nordland
dataset, see the PROVENANCE.md beside the images).
"""

from __future__ import annotations

from pathlib import Path

from vpr_smr.core.constants import DEFAULT_TOLERANCE
from vpr_smr.datasets.base import TraversePair
from vpr_smr.datasets.folders import folder_pair

DEFAULT_ROOT = Path(__file__).resolve().parents[1] / "data" / "nordland_sample"
SPLITS = {"train": (0, 500), "val": (500, 1000), "test": (1000, 3576)}


def nordland_sample(
    root: Path | str = DEFAULT_ROOT,
    splits: dict[str, tuple[int, int]] | None = None,
    tolerance: int = DEFAULT_TOLERANCE,
) -> TraversePair:
    """Summer is the reference, winter the query."""
    splits = SPLITS if splits is None else splits
    return folder_pair("nordland_sample", Path(root) / "summer", Path(root) / "winter", splits=splits,
                       tolerance=tolerance)
