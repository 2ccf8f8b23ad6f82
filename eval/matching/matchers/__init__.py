"""Sequence matchers, selected by name: the one seam every stage builds its matcher through.

Built-in matchers are registered in ``MATCHERS`` (a ``core.registry.Registry``); third-party ones register through
the entry point group ``vpr_smr.matchers`` (``name = "package.module:Class"``, a subclass of ``Matcher``). A stage
never reads a matcher's settings: it holds a ``MatcherSpec`` (the name and the settings, validated, defaults filled),
records it in its files' provenance (``MatcherSpec.provenance``), compares it (``==``) and builds the matcher from it
(``MatcherSpec.build``).
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from vpr_smr.core.registry import Registry

if TYPE_CHECKING:
    from vpr_smr.eval.matching.matchers.base import Matcher

__all__ = ["DEFAULT_MATCHER", "ENTRY_POINT_GROUP", "MATCHERS", "MatcherSpec", "available_matchers", "matcher_class"]

ENTRY_POINT_GROUP = "vpr_smr.matchers"
DEFAULT_MATCHER = "seqslam"


def _matcher(name: str, cls: Any) -> type[Matcher]:
    """``cls`` if it is the ``Matcher`` subclass that calls itself ``name``; ValueError otherwise."""
    from vpr_smr.eval.matching.matchers.base import Matcher

    if not (isinstance(cls, type) and issubclass(cls, Matcher)):
        raise ValueError(f"the sequence matcher {name!r} ({cls!r}) is not a subclass of "
                         "vpr_smr.eval.matching.matchers.Matcher")
    matcher: type[Matcher] = cls
    if matcher.name != name:
        raise ValueError(f"the sequence matcher registered as {name!r} calls itself {matcher.name!r}")
    return matcher


MATCHERS: Registry[type[Matcher]] = Registry("sequence matcher", ENTRY_POINT_GROUP, _matcher, package=__name__)
MATCHERS.add_lazy("seqslam", ".seqslam:SeqSLAM")  # imported on first use
MATCHERS.add_lazy("bayes_filter", ".bayes_filter:BayesFilter")
MATCHERS.add_lazy("monotone", ".monotone:Monotone")
MATCHERS.add_lazy("openseqslam", ".openseqslam:OpenSeqSLAM")


def available_matchers() -> list[str]:
    """The built-in matchers and those installed packages register, sorted."""
    return sorted(MATCHERS.names())


def matcher_class(name: str) -> type[Matcher]:
    """The matcher class of ``name`` (built in, or an entry point of ``ENTRY_POINT_GROUP``); ValueError listing the
    available ones."""
    return MATCHERS.get(name)


NAME_KEY = "matcher"  # the key of the matcher's name among its settings (a configuration's sequence_matching too)


@dataclass(frozen=True)
class MatcherSpec:
    """A matcher by name and settings: ``settings`` is the canonical JSON text of the matcher's settings record
    (every field, defaults filled, keys in declaration order), so that two specs are equal exactly when they make
    the same matches, and the spec is hashable."""

    name: str = DEFAULT_MATCHER
    settings: str = ""

    @classmethod
    def of(cls, name: str = DEFAULT_MATCHER, settings: Mapping[str, Any] | None = None,
           where: str = "sequence_matching") -> MatcherSpec:
        """The spec of ``name`` with ``settings`` (missing ones at their defaults); ValueError naming ``where``
        and the setting for an unknown or invalid one."""
        record = matcher_class(name).settings_of(settings or {}, where)
        return cls(name, json.dumps(_jsonable(dataclasses.asdict(record))))

    @property
    def values(self) -> dict[str, Any]:
        """The settings as JSON data (lists for tuples)."""
        data: dict[str, Any] = json.loads(self.settings or "{}")
        return data

    def record(self) -> Any:
        """The matcher's typed settings record."""
        return matcher_class(self.name).settings_of(self.values, f"matcher {self.name}")

    def build(self, seq_len: int) -> Matcher:
        """The matcher itself, for sequences of ``seq_len``."""
        return matcher_class(self.name)(seq_len, self.record())

    def provenance(self) -> dict[str, Any]:
        """What a file records of its matcher: ``{"name": ..., "settings": {...}}``."""
        return {"name": self.name, "settings": self.values}

    @classmethod
    def from_provenance(cls, data: Any, where: str) -> MatcherSpec:
        """The spec a file's ``matcher`` provenance records (``provenance``); ValueError naming ``where``."""
        if not (isinstance(data, Mapping) and isinstance(data.get("name"), str)
                and isinstance(data.get("settings", {}), Mapping)):
            raise ValueError(f"{where}: its matcher record {data!r} is not of the form "
                             "{\"name\": ..., \"settings\": {...}}: compute it again")
        return cls.of(data["name"], data.get("settings", {}), where)

    @classmethod
    def from_setting(cls, data: Any, where: str) -> MatcherSpec:
        """The spec of a stage's ``matcher`` setting: ``{"matcher": NAME, SETTING: VALUE, ...}``, as a
        configuration's ``sequence_matching`` writes it (``core.settings``' value classes)."""
        if not (isinstance(data, Mapping) and isinstance(data.get(NAME_KEY, DEFAULT_MATCHER), str)):
            raise ValueError(f"{where}: expected {{\"{NAME_KEY}\": NAME, SETTING: VALUE, ...}}, got {data!r}")
        name = data.get(NAME_KEY, DEFAULT_MATCHER)
        return cls.of(name, {key: value for key, value in data.items() if key != NAME_KEY}, where)

    def to_setting(self) -> dict[str, Any]:
        """The setting ``from_setting`` reads: the matcher's name under ``matcher``, then every setting."""
        return {NAME_KEY: self.name, **self.values}

    def __str__(self) -> str:
        shown = ", ".join(f"{key} {value}" for key, value in self.values.items())
        return f"{self.name} ({shown})" if shown else self.name


def _jsonable(value: Any) -> Any:
    if isinstance(value, tuple | list):
        return [_jsonable(item) for item in value]
    if isinstance(value, Mapping):
        return {key: _jsonable(item) for key, item in value.items()}
    return value
