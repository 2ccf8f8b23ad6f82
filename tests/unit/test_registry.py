"""``core.registry.Registry``: built-ins in order, plugins found through a (fake) entry point group, the messages."""

import os
import re
from types import SimpleNamespace

import pytest

from vpr_smr.core import registry as registry_module
from vpr_smr.core.registry import Registry

GROUP = "vpr_smr.widgets"


def _install(monkeypatch, **points):
    """Entry points of ``GROUP`` an installed package would declare: name -> the object its ``load`` gives."""
    found = [SimpleNamespace(name=name, load=lambda item=item: item) for name, item in points.items()]
    monkeypatch.setattr(registry_module, "entry_points", lambda group: found if group == GROUP else [])


def _widgets() -> Registry[int]:
    widgets: Registry[int] = Registry("widget", GROUP)
    widgets.add("zeta", 1)
    widgets.add("alpha", 2)
    return widgets


def test_built_ins_in_their_order_then_plugins_sorted(monkeypatch):
    _install(monkeypatch, omega=30, beta=20, alpha=99)  # a plugin named as a built-in does not replace it
    widgets = _widgets()
    assert widgets.names() == ["zeta", "alpha", "beta", "omega"]
    assert list(widgets) == widgets.builtins() == ["zeta", "alpha"] and len(widgets) == 2
    assert widgets.get("alpha") == 2 and widgets.get("beta") == 20
    assert "omega" in widgets and "zeta" in widgets and "gamma" not in widgets and 3 not in widgets


def test_an_unknown_name_names_the_closest_the_available_and_the_group(monkeypatch):
    _install(monkeypatch, beta=20)
    with pytest.raises(ValueError, match=re.escape("unknown widget 'alpah' (did you mean 'alpha'?); available: "
                                                   "alpha, beta, zeta (a package adds one through the entry point "
                                                   "group vpr_smr.widgets)")):
        _widgets().get("alpah")
    local: Registry[int] = Registry("dataset loader")  # no group: no plugins, no word of them
    local.add("folders", 1)
    with pytest.raises(ValueError, match=r"^unknown dataset loader 'nope'; available: folders$"):
        local.get("nope")


def test_a_name_registered_twice_is_refused():
    widgets = _widgets()
    with pytest.raises(ValueError, match="the widget 'zeta' is registered twice"):
        widgets.add("zeta", 3)
    with pytest.raises(ValueError, match="the widget 'alpha' is registered twice"):
        widgets.add_lazy("alpha", "json:dumps")


def test_register_is_add_as_a_decorator():
    functions: Registry[object] = Registry("function")

    @functions.register("double")
    def double(x: int) -> int:
        return 2 * x

    assert functions.get("double") is double and double(3) == 6


def test_a_lazy_item_is_imported_on_first_use_and_checked(monkeypatch):
    _install(monkeypatch, bad="not callable")
    seen: list[str] = []

    def check(name, item):
        seen.append(name)
        if not callable(item):
            raise ValueError(f"the widget {name!r} is not callable")
        return item

    widgets: Registry[object] = Registry("widget", GROUP, check, package="json")
    widgets.add_lazy("dumps", ".encoder:JSONEncoder")  # relative to package: json.encoder
    widgets.add_lazy("loads", "json:loads")
    import json

    assert widgets.get("dumps") is json.encoder.JSONEncoder and widgets.get("dumps") is json.encoder.JSONEncoder
    assert widgets.get("loads") is json.loads
    assert seen == ["dumps", "loads"]  # each built-in checked once, when imported
    with pytest.raises(ValueError, match="the widget 'bad' is not callable"):
        widgets.get("bad")


def test_a_real_entry_point_is_found(tmp_path, monkeypatch):
    """A package's dist-info on the path is what ``importlib.metadata`` reads: its entry point is a plugin."""
    (tmp_path / "my_widgets.py").write_text("WIDGET = 42\n")
    info = tmp_path / "my_widgets-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: my-widgets\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(f"[{GROUP}]\nanswer = my_widgets:WIDGET\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    widgets = _widgets()
    assert "answer" in widgets and widgets.names() == ["zeta", "alpha", "answer"]
    assert widgets.get("answer") == 42


def test_a_registry_reads_as_a_mapping_of_its_names(monkeypatch):
    _install(monkeypatch, beta=20)
    widgets = _widgets()
    assert widgets["zeta"] == 1 and widgets["beta"] == 20 and sorted(widgets) == ["alpha", "zeta"]
    assert widgets.items() == [("zeta", 1), ("alpha", 2)]  # the built-ins, as iterating gives them
    with pytest.raises(KeyError, match="unknown widget 'gamma'"):
        widgets["gamma"]


def test_a_stand_in_is_set_and_removed_as_in_a_mapping(monkeypatch):
    widgets = _widgets()
    with monkeypatch.context() as patch:
        patch.setitem(widgets, "alpha", 5)  # replaces the built-in, in its place
        patch.setitem(widgets, "new", 6)
        assert widgets.builtins() == ["zeta", "alpha", "new"] and widgets.get("alpha") == 5 and widgets["new"] == 6
    assert widgets.builtins() == ["zeta", "alpha"] and widgets.get("alpha") == 2 and "new" not in widgets
    with pytest.raises(KeyError):
        del widgets["new"]


def test_a_package_installed_into_a_folder_on_the_path_is_seen_at_once(tmp_path, monkeypatch):
    """The entry points are kept between calls, but installing a package (its dist-info appears in a folder on the
    path, changing the folder) is seen by the next call."""
    monkeypatch.syspath_prepend(str(tmp_path))
    os.utime(tmp_path, ns=(0, 0))  # long ago: the folder changes below whatever the clock's resolution
    widgets = _widgets()
    assert widgets.names() == ["zeta", "alpha"]
    (tmp_path / "late_widgets.py").write_text("WIDGET = 7\n")
    info = tmp_path / "late_widgets-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: late-widgets\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(f"[{GROUP}]\nlate = late_widgets:WIDGET\n")
    assert widgets.names() == ["zeta", "alpha", "late"] and widgets.get("late") == 7
