"""A dataset loader: the function that builds a ``TraversePair`` and the record of the settings a ``datasets`` entry
gives it (``core.settings``: each a ``setting(default, help)``, the default ``REQUIRED`` for one the loader cannot do
without). The configuration check, ``vpr-smr dataset check`` and the configuration reference read the record; the
workflow calls the function with every setting of the record, the entry's values over the record's defaults.

A loader of 0.16 or before was a bare function whose parameters were its settings: ``as_loader`` still takes one,
with a ``DeprecationWarning`` saying how to declare its record.
"""

from __future__ import annotations

import dataclasses
import inspect
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from vpr_smr.core.deprecation import deprecated
from vpr_smr.core.settings import REQUIRED, Declared, declared, setting
from vpr_smr.datasets.base import TraversePair

__all__ = ["ENTRY_POINT_GROUP", "WORKFLOW_ARGUMENTS", "Loader", "as_loader"]

ENTRY_POINT_GROUP = "vpr_smr.loaders"
# What the workflow gives a loader's function besides its settings, where the loader ``takes`` it: the entry's name,
# whether a missing file is an error (``dataset check`` reports them instead) and the splits (``{}``: the workflow
# applies the entry's own after ``frames`` has sliced the pair).
WORKFLOW_ARGUMENTS = ("name", "check_files", "splits")
# Entry keys that never reach a loader's function (``datasets.SPLIT_SETTINGS``): a legacy function's parameters of
# these names are not settings.
_SPLIT_ARGUMENTS = ("splits", "tolerance", "radius", "ground_truth")


@dataclass(frozen=True)
class Loader:
    """``function(**settings, **workflow arguments)`` builds the pair; ``Settings`` is the frozen dataclass of its
    settings; ``takes`` names which of ``WORKFLOW_ARGUMENTS`` the function takes; ``splits`` are the published splits
    of its dataset (``[lo, hi)`` frame ranges by name), an entry's splits where it names none."""

    function: Callable[..., TraversePair]
    Settings: type
    takes: tuple[str, ...] = ("splits",)
    splits: Mapping[str, tuple[int, int]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        unknown = [argument for argument in self.takes if argument not in WORKFLOW_ARGUMENTS]
        if unknown:
            raise ValueError(f"loader {self.function.__name__}: takes {', '.join(unknown)}, which the workflow does "
                             f"not give; it gives {', '.join(WORKFLOW_ARGUMENTS)}")
        declared(self.Settings)  # a TypeError naming a field that is not a setting

    def settings(self) -> tuple[Declared, ...]:
        """Its settings, in the record's order."""
        return declared(self.Settings)

    def options(self) -> list[str]:
        """The names of its settings."""
        return [item.name for item in self.settings()]

    def required(self) -> list[str]:
        """The settings it cannot do without (``REQUIRED``)."""
        return [item.name for item in self.settings() if item.default is REQUIRED]

    def help(self) -> dict[str, str]:
        """What each setting means (one line each)."""
        return {item.name: item.help for item in self.settings() if item.help}

    def load(self, name: str, settings: dict[str, Any], check_files: bool) -> TraversePair:
        """The pair of the entry ``name`` whose loader settings are ``settings`` (checked: known names, the required
        ones given): each setting's value, or its record's default."""
        given = {item.name: settings.get(item.name, item.default) for item in self.settings()}
        workflow = {"name": name, "check_files": check_files, "splits": {}}
        return self.function(**given, **{argument: workflow[argument] for argument in self.takes})


_LEGACY: dict[Callable[..., TraversePair], Loader] = {}  # one warning per function


def as_loader(name: str, item: Any) -> Loader:
    """The ``Loader`` of the registered ``item``: itself, or a bare function's (deprecated: its parameters read as
    its settings, without help)."""
    if isinstance(item, Loader):
        return item
    if not callable(item):
        raise ValueError(f"dataset loader {name!r} is {item!r}, not a Loader(function, Settings)")
    if item not in _LEGACY:
        deprecated(
            f"dataset loader {name!r} ({getattr(item, '__module__', '?')}.{getattr(item, '__qualname__', item)}) is a "
            "bare function whose parameters are its settings, which a later release will not read: register "
            "Loader(function, Settings) (vpr_smr.datasets.loaders), Settings a frozen dataclass of "
            "core.settings.setting(default, help) fields (docs/extending.md, 'A dataset loader')",
            stacklevel=2)
        parameters = [p for p in inspect.signature(item).parameters.values()
                      if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)]
        fields = [(p.name, p.annotation if p.annotation is not p.empty else Any,
                   setting(REQUIRED if p.default is p.empty else p.default, ""))
                  for p in parameters if p.name not in (*WORKFLOW_ARGUMENTS, *_SPLIT_ARGUMENTS)]
        record = dataclasses.make_dataclass(f"{name}_settings", fields, frozen=True)
        _LEGACY[item] = Loader(item, record, tuple(a for a in WORKFLOW_ARGUMENTS if a in (p.name for p in parameters)))
    return _LEGACY[item]
