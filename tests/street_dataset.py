"""One street driven twice, with positions: small distinct frames, their positions in @UTM@ file names or in CSVs,
as `folders` dataset entries and a checked configuration (the positions' and the speed check's tests)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from vpr_smr.pipeline.config import validate

# Reference and query of one street, 3 m apart across it, driven at different speeds: 10 m and 15 m a frame.
REFERENCE_XY = [(500000.0 + 10 * i, 4178906.5) for i in range(8)]
QUERY_XY = [(500002.0 + 15 * i, 4178909.5) for i in range(5)]


def image(seed: int) -> np.ndarray:
    """A small distinct image, so every frame has its own descriptor."""
    return np.random.default_rng(seed).integers(0, 256, (24, 32, 3), dtype=np.uint8)


def utm_name(east: float, north: float) -> str:
    """A VPR-methods-evaluation file name: @UTM_east@UTM_north@zone@band@lat@lon@...@.jpg."""
    return f"@{east:010.2f}@{north:.2f}@10@S@37.75594@-122.50037@@@@@@@@.png"


def write_folder(folder: Path, names: list[str], seed: int = 0) -> list[Path]:
    folder.mkdir(parents=True)
    for i, name in enumerate(names):
        cv2.imwrite(str(folder / name), image(seed + i))
    return [folder / name for name in names]


def write_csv(path: Path, header: str, rows: list[tuple[str, float, float]]) -> Path:
    path.write_text(header + "\n" + "".join(f"{name},{a!r},{b!r}\n" for name, a, b in rows))
    return path


def plain_names(n: int) -> list[str]:
    return [f"{i:04d}.png" for i in range(n)]


def utm_dataset(tmp_path: Path, **extra) -> dict:
    """A `folders` entry whose images carry their positions in their @UTM@ names (natural order = east)."""
    write_folder(tmp_path / "utm_ref", [utm_name(*p) for p in REFERENCE_XY])
    write_folder(tmp_path / "utm_qry", [utm_name(*p) for p in QUERY_XY], seed=100)
    return {"loader": "folders", "reference": str(tmp_path / "utm_ref"), "query": str(tmp_path / "utm_qry"),
            "positions": "file_names", "radius": 5.0, **extra}


def csv_dataset(tmp_path: Path, **extra) -> dict:
    """The same images and positions, the images named 0000.png.., their positions in CSVs (name,x,y)."""
    write_folder(tmp_path / "ref", plain_names(len(REFERENCE_XY)))
    write_folder(tmp_path / "qry", plain_names(len(QUERY_XY)), seed=100)
    # the rows in another order than the images, and a longer GPS log than the images: both allowed
    ref_rows = [(name, x, y) for name, (x, y) in zip(plain_names(8), REFERENCE_XY, strict=True)][::-1]
    qry_rows = [(name, x, y) for name, (x, y) in zip(plain_names(5), QUERY_XY, strict=True)] + [("9999.png", 0, 0)]
    return {"loader": "folders", "reference": str(tmp_path / "ref"), "query": str(tmp_path / "qry"),
            "reference_positions": str(write_csv(tmp_path / "ref.csv", "name,x,y", ref_rows)),
            "query_positions": str(write_csv(tmp_path / "qry.csv", "name,x,y", qry_rows)), "radius": 5.0, **extra}


def plan_config(tmp_path: Path, splits: dict, **extra) -> dict:
    dataset = csv_dataset(tmp_path, splits=splits)
    return validate({"run": "r", "output": str(tmp_path / "out"), "datasets": {"street": dataset},
                     "methods": {"sad": {"backend": "sad"}}, "seq_lens": [2],
                     "experiments": {"matchers": False}, **extra})  # 8 frames: too short for openseqslam
