"""The report's side of the bootstrap intervals over queries (method §8.7): one home for how a table row holds an
interval, how a cell writes it, and whether a number has a direction.

A row (a CSV row) holds the interval of its number ``name`` as two columns, ``<name>_ci_low`` and
``<name>_ci_high``, both empty (None) where there is no interval. A number has a direction (``sign``) only when its
interval excludes 0; a sentence states a direction only then, and a cell is coloured only then.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from vpr_smr.eval.scoring.intervals import CONFIDENCE, Interval

LOW, HIGH = "_ci_low", "_ci_high"
UNDEFINED = "n/a"
LEVEL = f"{round(100 * CONFIDENCE)} %"  # "95 %"


def columns(name: str) -> tuple[str, str]:
    """The two columns of ``name``'s interval."""
    return f"{name}{LOW}", f"{name}{HIGH}"


def is_bound(column: str) -> bool:
    """A column of an interval's bound."""
    return column.endswith((LOW, HIGH))


def base(column: str) -> str:
    """The number a bound column belongs to (``<number>_ci_low`` -> ``<number>``)."""
    return column.removesuffix(LOW).removesuffix(HIGH)


def flat(name: str, interval: Interval | None) -> dict[str, float | None]:
    """The row's two columns of ``name``'s interval (both None without one)."""
    low, high = columns(name)
    return {low: None if interval is None else interval.low, high: None if interval is None else interval.high}


def flatten(data: Mapping[str, Any]) -> dict[str, Any]:
    """A record's JSON (``to_json``) as a row: each interval entry (``<name>_ci``: low and high) as its two columns;
    an interval absent from the JSON (None) leaves both columns out, which a row reads as none."""
    out: dict[str, Any] = {}
    for key, value in data.items():
        if key.endswith("_ci") and isinstance(value, Mapping):
            out.update(flat(key.removesuffix("_ci"), Interval(float(value["low"]), float(value["high"]))))
        else:
            out[key] = value
    return out


def of(row: Mapping[str, Any], name: str) -> Interval | None:
    """The interval of ``name`` that ``row`` holds, None where it has none."""
    low, high = (row.get(column) for column in columns(name))
    return None if low is None or high is None else Interval(float(low), float(high))


def sign(interval: Interval | None) -> int | None:
    """+1 or -1 when ``interval`` lies wholly above or below 0, 0 when it contains 0, None without one."""
    return None if interval is None else interval.sign()


def bracket(interval: Interval | None, fmt: str) -> str:
    """``[70.10, 85.00]``, or ``[n/a]`` without an interval."""
    return f"[{UNDEFINED}]" if interval is None else f"[{interval.low:{fmt}}, {interval.high:{fmt}}]"


def number(value: float) -> str:
    """A bound as a sentence says it: one decimal, two significant digits below 0.05 in magnitude."""
    return f"{value:.1f}" if abs(value) >= 0.05 or value == 0 else f"{value:.2g}"


def span(interval: Interval, unit: str = " %", fmt: str = "") -> str:
    """An interval as a sentence says it: ``-40.0 % to 35.0 %`` (``fmt``: a format spec instead of ``number``)."""
    low, high = (f"{v:{fmt}}" if fmt else number(v) for v in (interval.low, interval.high))
    return f"{low}{unit} to {high}{unit}"


def holds_zero(interval: Interval, of: str = "", queries: str = "", fmt: str = "") -> str:
    """An interval that holds 0, stated as the fact it is, never with a cause: ``the 95 % interval of sad's
    reduction [-3.3, 0.3] holds 0 (2573 queries)`` (``of``: what it is of; ``queries``: how many it is over, e.g.
    ``28`` or ``28-31``; ``fmt``: a format spec of the bounds instead of ``number``)."""
    low, high = (f"{v:{fmt}}" if fmt else number(v) for v in (interval.low, interval.high))
    over = f" ({queries} queries)" if queries else ""
    return f"the {LEVEL} interval{f' of {of}' if of else ''} [{low}, {high}] holds 0{over}"
