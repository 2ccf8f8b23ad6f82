"""Dataset loaders through the registry (``datasets.loaders``): each declares its settings as a ``Settings`` record,
an installed package adds one through the entry point group ``vpr_smr.loaders``, and a bare function (a loader of
0.16) still works, with a DeprecationWarning that says how to declare its record."""

import inspect
import warnings
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from vpr_smr.core.settings import REQUIRED, setting
from vpr_smr.datasets import (
    LOADERS,
    DatasetError,
    Loader,
    Traverse,
    TraversePair,
    load_dataset,
    loader,
    loader_option_help,
    loader_options,
    required_options,
)
from vpr_smr.datasets import loaders as loader_module
from vpr_smr.datasets.base import sorted_images
from vpr_smr.datasets.loaders import ENTRY_POINT_GROUP, WORKFLOW_ARGUMENTS

# each loader's settings and the required ones, as the signatures of 0.16 gave them (and docs/configuration.md shows)
OPTIONS = {
    "folders": (["reference", "query", "reference_list", "query_list", "pairing", "reference_positions",
                 "query_positions", "positions"], ["reference", "query"]),
    "nordland_sample": (["root"], []),
    "nordland": (["root", "reference_list", "query_list", "reference", "query"], ["root"]),
    "robotcar": (["root", "reference_list", "query_list", "reference_run", "query_run", "positions", "every"],
                 ["root"]),
    "sfu_mountain": (["root", "reference_list", "query_list"], ["root"]),
}


def test_every_built_in_loader_keeps_its_settings_and_the_defaults_of_its_function():
    assert list(LOADERS) == list(OPTIONS)
    for name, (options, required) in OPTIONS.items():
        assert (loader_options(name), required_options(name)) == (options, required), name
        found = loader(name)
        parameters = inspect.signature(found.function).parameters
        for item in found.settings():  # a direct call of the function and the workflow's agree
            default = parameters[item.name].default
            assert item.default == (REQUIRED if default is inspect.Parameter.empty else default), (name, item.name)
        assert set(found.takes) <= set(parameters), name
        assert (set(WORKFLOW_ARGUMENTS) - set(found.takes)).isdisjoint(parameters), name
    assert loader_option_help("folders")["pairing"].startswith("how frame i of both folders is paired")
    # the published splits (method §1)
    assert {name: dict(loader(name).splits) for name in LOADERS} == {
        "folders": {}, "nordland_sample": {"train": (0, 500), "val": (500, 1000), "test": (1000, 3576)},
        "nordland": {"train": (0, 500), "val": (500, 1000), "test": (1000, 10000)},
        "robotcar": {"train": (0, 500), "val": (500, 1000), "test": (1000, 2000)},
        "sfu_mountain": {"train": (0, 100), "val": (100, 200), "test": (200, 375)}}


def _frames(folder: Path, n: int) -> None:
    folder.mkdir(parents=True)
    for i in range(n):
        cv2.imwrite(str(folder / f"f{i + 1}.png"), np.full((8, 8, 3), 20 * i, np.uint8))


def _route(root: str, night: str = "night", splits: dict | None = None, tolerance: int = 2) -> TraversePair:
    """A route of two folders under ``root``, day against ``night``."""
    day, other = sorted_images(Path(root) / "day"), sorted_images(Path(root) / night)
    return TraversePair("route", Traverse("day", day), Traverse(night, other), tolerance, splits or {},
                        pairing="by name order", source=f"day and {night} under {root}")


@dataclass(frozen=True)
class RouteSettings:
    root: str = setting(REQUIRED, "the folder of day/ and the other traverse")
    night: str = setting("night", "the query traverse's folder under root")


def _install(monkeypatch, **points):
    found = [SimpleNamespace(name=name, load=lambda item=item: item) for name, item in points.items()]
    monkeypatch.setattr("vpr_smr.core.registry.entry_points",
                        lambda group: found if group == ENTRY_POINT_GROUP else [])


def test_a_plugin_loader_declares_its_settings_record(tmp_path, monkeypatch):
    _install(monkeypatch, route=Loader(_route, RouteSettings, splits={"early": (0, 3), "late": (3, 5)}))
    _frames(tmp_path / "day", 5)
    _frames(tmp_path / "dusk", 5)
    assert "route" in LOADERS and LOADERS.names()[-1] == "route" and "route" not in list(LOADERS)
    assert (loader_options("route"), required_options("route")) == (["root", "night"], ["root"])
    pair = load_dataset("r", {"loader": "route", "root": str(tmp_path), "night": "dusk", "splits": {"a": [0, 5]}})
    assert (pair.name, len(pair), pair.query.name, pair.splits) == ("r", 5, "dusk", {"a": (0, 5)})
    pair = load_dataset("r", {"loader": "route", "root": str(tmp_path), "night": "dusk"})  # its published splits
    assert pair.splits == {"early": (0, 3), "late": (3, 5)}
    with pytest.raises(DatasetError, match=r"datasets\.r: loader 'route' needs root"):
        load_dataset("r", {"loader": "route"})
    with pytest.raises(DatasetError, match=r"datasets\.r\.nigth: .*did you mean 'night'"):
        load_dataset("r", {"loader": "route", "root": str(tmp_path), "nigth": "dusk"})


def test_a_bare_function_still_loads_and_warns_once(tmp_path, monkeypatch):
    monkeypatch.setattr(loader_module, "_LEGACY", {})
    _install(monkeypatch, old_route=_route)
    _frames(tmp_path / "day", 4)
    _frames(tmp_path / "night", 4)
    with pytest.warns(DeprecationWarning, match=r"'old_route' .*register Loader\(function, Settings\)"):
        assert loader_options("old_route") == ["root", "night"] == [*required_options("old_route"), "night"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # once per function
        pair = load_dataset("r", {"loader": "old_route", "root": str(tmp_path), "splits": {"a": [1, 4]}})
    assert (len(pair), pair.query.name, pair.splits) == (4, "night", {"a": (1, 4)})
    assert loader("old_route").takes == ("splits",) and loader_option_help("old_route") == {}


def test_a_loader_that_takes_what_the_workflow_does_not_give_is_refused():
    with pytest.raises(ValueError, match="takes seed, which the workflow does not give; it gives name, check_files"):
        Loader(_route, RouteSettings, ("seed",))
    with pytest.raises(ValueError, match="dataset loader 'x' is 3, not a Loader"):
        loader_module.as_loader("x", 3)
