"""Plugins by name: one registry mechanism for every kind (sequence matchers, descriptor backends, dataset loaders,
scorers, tables, experiments).

A ``Registry`` holds the built-in items of one kind, in the order they are declared, and finds the ones installed
packages add through an entry point group (``name = "package.module:attr"`` under ``[<group>]`` of a package's
``entry_points``). A built-in item is given itself (``add``, ``register``) or as ``"module:attr"`` imported on first
use (``add_lazy``), so that a heavy module (PyTorch) costs nothing until its item is asked for.

Iterating a registry gives its built-in names (what the package itself ships: the reference pages, the default list
of a comparison); ``names()``, ``in`` and ``get`` (``[]``) include the installed plugins too.
"""

from __future__ import annotations

import importlib
import os
import sys
from collections.abc import Callable, Hashable, Iterator
from importlib.metadata import entry_points
from typing import Any, Generic, TypeVar, overload

from vpr_smr.core.suggest import did_you_mean

__all__ = ["Registry"]

T = TypeVar("T")
D = TypeVar("D")
_RAISE = object()  # ``get`` without a default


class Registry(Generic[T]):
    """The items of one ``kind`` by name: built in, then those of the entry point ``group`` (None: built-ins only).

    ``check(name, item)`` validates a plugin's item (and a lazily imported built-in one) when it is loaded and
    returns it typed; a ValueError it raises reaches the caller. ``package`` is what ``add_lazy``'s relative module
    names are relative to.
    """

    def __init__(self, kind: str, group: str | None = None, check: Callable[[str, Any], T] | None = None,
                 package: str | None = None) -> None:
        self.kind = kind
        self.group = group
        self._check = check
        self._package = package
        self._items: dict[str, T] = {}
        self._lazy: dict[str, str] = {}  # name -> "module:attr", until first asked for
        self._order: list[str] = []
        self._found: tuple[Hashable, list[Any]] | None = None  # the installed entry points, and what they were read of

    def add(self, name: str, item: T) -> T:
        """Register ``item`` as ``name``; a name already taken is a ValueError."""
        self._claim(name)
        self._items[name] = item
        return item

    def register(self, name: str) -> Callable[[T], T]:
        """``add`` as a decorator: ``@REGISTRY.register("name")`` above a class or function."""
        return lambda item: self.add(name, item)

    def add_lazy(self, name: str, target: str) -> None:
        """Register ``name`` as the attribute ``target`` (``"module:attr"``, relative to ``package`` when it starts
        with a dot) imported on first ``get``."""
        self._claim(name)
        self._lazy[name] = target

    @overload
    def get(self, name: str) -> T: ...

    @overload
    def get(self, name: str, default: D) -> T | D: ...

    def get(self, name: str, default: Any = _RAISE) -> Any:
        """The item of ``name``: built in, or the installed entry point of that name; for another name ``default``
        where given (as a mapping's ``get``), else ValueError naming the kind, the closest name, the available ones
        and the entry point group."""
        if name in self._items:
            return self._items[name]
        if name in self._lazy:
            module_name, _, attr = self._lazy[name].partition(":")
            item = self._checked(name, getattr(importlib.import_module(module_name, self._package), attr))
            self._items[name] = item  # imported once
            del self._lazy[name]
            return item
        for point in self._points():
            if point.name == name:
                # not kept: the import system keeps the module, and a package installed meanwhile is seen
                return self._checked(name, point.load())
        if default is not _RAISE:
            return default
        raise ValueError(self.unknown(name))

    def unknown(self, name: str) -> str:
        """Why ``name`` is not an item of this registry: the closest name and the available ones."""
        known = sorted(self.names())
        where = f" (a package adds one through the entry point group {self.group})" if self.group else ""
        return f"unknown {self.kind} {name!r}{did_you_mean(name, known)}; available: {', '.join(known)}{where}"

    def names(self) -> list[str]:
        """The built-in names in their order, then the installed plugins' sorted (a plugin cannot hide a built-in)."""
        plugins = {point.name for point in self._points()} - set(self._order)
        return [*self._order, *sorted(plugins)]

    def builtins(self) -> list[str]:
        """The built-in names, in their order."""
        return list(self._order)

    def __contains__(self, name: object) -> bool:
        return name in self._order or any(point.name == name for point in self._points())

    def __getitem__(self, name: str) -> T:
        """``get``, with KeyError for an unknown name (a registry reads as the mapping of names it replaces)."""
        try:
            return self.get(name)
        except ValueError as error:
            if name in self:
                raise  # a plugin that does not pass ``check``
            raise KeyError(str(error)) from None

    def __setitem__(self, name: str, item: T) -> None:
        """Set ``name`` to ``item`` whatever was there (a test's stand-in; ``add`` refuses a name already taken)."""
        if name not in self._order:
            self._order.append(name)
        self._lazy.pop(name, None)
        self._items[name] = item

    def __delitem__(self, name: str) -> None:
        """Remove the built-in ``name`` (what ``monkeypatch.setitem`` undoes); KeyError for another."""
        if name not in self._order:
            raise KeyError(name)
        self._order.remove(name)
        self._lazy.pop(name, None)
        self._items.pop(name, None)

    def items(self) -> list[tuple[str, T]]:
        """The built-ins' names and items, in their order (each imported)."""
        return [(name, self.get(name)) for name in self._order]

    def __iter__(self) -> Iterator[str]:
        return iter(list(self._order))

    def __len__(self) -> int:
        return len(self._order)

    def __repr__(self) -> str:
        return f"Registry({self.kind!r}, {self.group!r}: {', '.join(self._order)})"

    def _claim(self, name: str) -> None:
        if name in self._order:
            raise ValueError(f"the {self.kind} {name!r} is registered twice; give one of them another name")
        self._order.append(name)

    def _checked(self, name: str, item: Any) -> T:
        if self._check is None:
            typed: T = item
            return typed
        return self._check(name, item)

    def _points(self) -> list[Any]:
        # a registry must see what is installed now, and tests install fakes: read again (about 6 ms) whenever the
        # reader, the path or a folder on it changed (installing a package changes its site-packages folder), not on
        # every call (the scorers' names are asked for per table row)
        if not self.group:
            return []
        seen = (entry_points, tuple(sys.path), tuple(_modified(folder) for folder in sys.path))
        if self._found is None or self._found[0] != seen:
            self._found = (seen, list(entry_points(group=self.group)))
        return self._found[1]


def _modified(folder: str) -> int:
    try:
        return os.stat(folder or ".").st_mtime_ns
    except OSError:
        return 0
