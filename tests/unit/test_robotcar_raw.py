"""Oxford RobotCar's raw runs positioned by their INS logs (``positions: ins``, method §11): a tiny fake run of Bayer
PNGs named by timestamps and an ``ins.csv`` in the SDK's layout."""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np
import pytest
from benchmark_trees import DUSK, RAIN, robotcar_tree

from vpr_smr.datasets import DatasetError, load_dataset
from vpr_smr.datasets.robotcar import DEFAULT_RADIUS, BayerTraverse, robotcar

# The SDK's gps/ins.csv header (timestamps in microseconds, as the image names).
HEADER = ("timestamp,ins_status,latitude,longitude,altitude,northing,easting,down,utm_zone,velocity_north,"
          "velocity_east,velocity_down,roll,pitch,yaw")


def write_ins(root: Path, run: str, rows: list[tuple[int, float, float]], zone: str = "30U") -> Path:
    """``rows`` of (timestamp, northing, easting), written out of time order (the loader sorts them)."""
    path = root / run / "gps" / "ins.csv"
    path.parent.mkdir(parents=True, exist_ok=True)
    lines = [HEADER] + [f"{t},INS_SOLUTION_GOOD,51.76,-1.26,110.0,{n!r},{e!r},-110.0,{zone},0,0,0,0,0,0"
                        for t, n, e in reversed(rows)]
    path.write_text("\n".join(lines) + "\n")
    return path


# Rain: INS readings every second; images at 0.5 s steps from before the first reading to after the last.
RAIN_INS = [(1_000_000, 5_735_000.0, 620_000.0), (2_000_000, 5_735_010.0, 620_020.0),
            (3_000_000, 5_735_030.0, 620_020.0)]
RAIN_IMAGES = [500_000, 1_000_000, 1_250_000, 1_500_000, 2_000_000, 2_750_000, 3_000_000, 3_500_000]
DUSK_INS = [(10_000_000, 5_735_000.0, 620_000.0), (14_000_000, 5_735_000.0, 620_040.0)]
DUSK_IMAGES = [10_000_000, 11_000_000, 12_000_000, 13_000_000, 14_000_000]


@pytest.fixture
def runs(tmp_path: Path) -> Path:
    robotcar_tree(tmp_path, {RAIN: RAIN_IMAGES, DUSK: DUSK_IMAGES})
    write_ins(tmp_path, RAIN, RAIN_INS)
    write_ins(tmp_path, DUSK, DUSK_INS)
    return tmp_path


def test_positions_interpolated_at_the_image_timestamps(runs: Path) -> None:
    pair = robotcar(runs, positions="ins")
    # by hand, (easting, northing): Rain's 0.5 s and 3.5 s images lie outside its INS log and are dropped;
    # 1.25 s is a quarter of the way from reading 1 to 2, 2.75 s three quarters from reading 2 to 3
    assert [int(p.stem) for p in pair.reference.images] == RAIN_IMAGES[1:-1]
    np.testing.assert_allclose(pair.reference.positions, [
        (620_000.0, 5_735_000.0), (620_005.0, 5_735_002.5), (620_010.0, 5_735_005.0), (620_020.0, 5_735_010.0),
        (620_020.0, 5_735_025.0), (620_020.0, 5_735_030.0)])
    np.testing.assert_allclose(pair.query.positions, [(620_000.0 + 10 * k, 5_735_000.0) for k in range(5)])
    assert pair.has_positions and pair.radius == DEFAULT_RADIUS == 25.0 and pair.position_unit == "metres"
    assert isinstance(pair.reference, BayerTraverse) and pair.reference.read(0).shape == (32, 64, 3)  # demosaiced
    assert f"{RAIN}: 1 images before its INS log's first reading and 1 after its last dropped" in pair.source
    assert pair.pairing == ("by positions within 25 m (INS easting, northing of gps/ins.csv interpolated at each "
                            "image's timestamp, UTM zone 30U)")
    assert pickle.loads(pickle.dumps(pair.reference)).positions.shape == (6, 2)  # DataLoader workers get them


def test_every_nth_image_and_the_configuration(runs: Path) -> None:
    conf = {"loader": "robotcar", "root": str(runs), "positions": "ins", "every": 2, "radius": 12.5,
            "splits": {"train": {"reference": [0, 3], "query": [0, 2]}, "test": [2, 3]}}
    pair = load_dataset("orc_raw", conf)
    # every 2nd of the sorted images (0.5, 1.25, 2 and 3 s), then the one before the INS log dropped
    assert [int(p.stem) for p in pair.reference.images] == [1_250_000, 2_000_000, 3_000_000]
    assert [int(p.stem) for p in pair.query.images] == [10_000_000, 12_000_000, 14_000_000]
    np.testing.assert_allclose(pair.query.positions[:, 0], [620_000.0, 620_020.0, 620_040.0])
    assert pair.radius == 12.5 and pair.name == "orc_raw"
    assert "one image in every 2" in pair.source and "1 images before its INS log's first reading and 0 after" \
        in pair.source and "within 12.5 m" in pair.pairing
    # no published splits for raw runs: they index the place-aligned lists
    assert load_dataset("orc_raw", {k: v for k, v in conf.items() if k != "splits"}).splits == {}


def test_the_place_aligned_mode_is_unchanged(runs: Path) -> None:
    pair = robotcar(runs, check_files=False)
    assert not pair.has_positions and len(pair) == 3876 and pair.tolerance == 2 and pair.radius is None
    with pytest.raises(DatasetError, match="every: 3 applies to the raw runs"):
        robotcar(runs, every=3, check_files=False)


def test_raw_run_errors(runs: Path) -> None:
    with pytest.raises(DatasetError, match="the place-aligned lists .* do not apply; remove them"):
        robotcar(runs, positions="ins", reference_list=runs / "list.csv")
    with pytest.raises(DatasetError, match=r"positions is 'gps'; choose ins"):
        robotcar(runs, positions="gps")
    with pytest.raises(DatasetError, match=r"every is 0; give a whole number >= 1"):
        robotcar(runs, positions="ins", every=0)
    with pytest.raises(DatasetError, match=rf"run '2014-01-01' under root .*{runs.name}"):
        robotcar(runs, positions="ins", query_run="2014-01-01")
    write_ins(runs, DUSK, DUSK_INS, zone="31U")
    with pytest.raises(DatasetError, match=r"different UTM zones \(30U and 31U\)"):
        robotcar(runs, positions="ins")
    write_ins(runs, DUSK, [(20_000_000, 0.0, 0.0), (21_000_000, 1.0, 1.0)])
    with pytest.raises(DatasetError, match=rf"none of the 5 images of run '{DUSK}' lies within the time of its INS "
                                           r"log .*ins.csv \(20000000 to 21000000\)"):
        robotcar(runs, positions="ins")
    ins = runs / DUSK / "gps" / "ins.csv"
    ins.write_text(HEADER + "\n10000000,INS_SOLUTION_GOOD,51,-1,0,abc,620000,0,30U,0,0,0,0,0,0\n")
    with pytest.raises(DatasetError, match=r"ins.csv, line 2: .* has no integer timestamp and numeric northing"):
        robotcar(runs, positions="ins")
    ins.write_text("timestamp,latitude,longitude\n1,2,3\n")
    with pytest.raises(DatasetError, match=r"ins.csv, line 1: the header has no column northing, easting"):
        robotcar(runs, positions="ins")
    ins.unlink()
    with pytest.raises(DatasetError, match=r"INS log .*ins.csv not found; positions: ins needs each run's "
                                           r"gps/ins.csv"):
        robotcar(runs, positions="ins")
