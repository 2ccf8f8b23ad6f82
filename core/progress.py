"""A stage's progress in its log, and `vpr-smr run` reading it back: the one format both use.

A stage writes states ``[<desc>: ]<done>/<total> <unit> (<percent> %) in <seconds> s``, either as a tqdm bar
(``progress_bar``: each update a ``\\r``-separated state, as tqdm writes into a file) or as one line per step
(``write_progress``). `vpr-smr run` reads the last state in the tail of a running job's log (``read_progress``) to
show the job's fraction done and rate, so the writers and the parser share ``FORMAT`` and ``STATE`` here.
"""

from __future__ import annotations

import re
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Never, TextIO

if TYPE_CHECKING:  # tqdm is imported where a bar is drawn: the stages that only read or write states skip its 40 ms
    from tqdm import tqdm

FORMAT = "{n}/{total} {unit} ({percentage:.0f} %) in {elapsed_s:.1f} s"  # tqdm's bar_format keys
STATE = re.compile(
    r"(?:(?P<desc>.+?): )?(?P<done>\d+)/(?P<total>\d+) (?P<unit>\S+) \(\d+ %\) in (?P<elapsed>\d+\.\d) s")
TAIL_BYTES = 4096  # of a log: holds dozens of states, read in well under a millisecond
# A bar redraws at most this often: each redraw adds a state to the log file, and the run's console reads about
# once a second anyway.
MIN_INTERVAL_S = 1.0


@dataclass(frozen=True)
class Progress:
    """One state: ``done`` of ``total`` ``unit`` after ``elapsed_s`` seconds of the bar or the steps."""

    desc: str
    done: int
    total: int
    unit: str
    elapsed_s: float

    @property
    def fraction(self) -> float:
        return self.done / self.total if self.total else 0.0

    @property
    def rate(self) -> float | None:
        """Units per second on average since the start; None before the first unit."""
        return self.done / self.elapsed_s if self.done and self.elapsed_s > 0 else None


def _check(unit: str, total: int) -> None:
    # the parser splits a state at spaces and reads counts as integers
    if not re.fullmatch(r"\S+", unit) or total < 0:
        raise ValueError(f"progress needs a unit without spaces and a total >= 0, got {unit!r} and {total}")


def progress_bar(total: int, unit: str, desc: str = "", file: TextIO | None = None,
                 min_interval_s: float | None = None) -> tqdm[Never]:
    """A tqdm bar (to ``file``, stderr by default) that writes ``STATE``s; advance it with ``update(n)``.

    Closing it writes its final state and a newline (``leave=True``): a redraw held back by ``min_interval_s``
    (least time between redraws, ``MIN_INTERVAL_S`` by default) would otherwise leave an old state as the last one.
    """
    from tqdm import tqdm

    _check(unit, total)
    return tqdm(total=total, desc=desc, unit=unit, file=file, leave=True,
                bar_format=("{desc}: " if desc else "") + FORMAT,
                mininterval=MIN_INTERVAL_S if min_interval_s is None else min_interval_s,
                miniters=1)  # a fixed minimum: tqdm's adaptive one could hold back updates when a job slows down


def format_progress(done: int, total: int, unit: str, elapsed_s: float, desc: str = "") -> str:
    """The state as ``progress_bar`` writes it."""
    _check(unit, total)
    percentage = 100 * done / total if total else 0.0
    text = FORMAT.format(n=done, total=total, unit=unit, percentage=percentage, elapsed_s=elapsed_s)
    return f"{desc}: {text}" if desc else text


def write_progress(done: int, total: int, unit: str, elapsed_s: float, desc: str = "",
                   file: TextIO | None = None) -> None:
    """One line with the state, for steps too long and few for a bar (the logging prefix would hide it)."""
    print(format_progress(done, total, unit, elapsed_s, desc), file=file or sys.stderr, flush=True)


def parse_progress(text: str) -> Progress | None:
    """The last state in ``text`` (a log's tail, its lines and tqdm's redraws in any mix), or None."""
    for piece in reversed(re.split(r"[\r\n]", text)):
        if match := STATE.fullmatch(piece.strip()):
            return Progress(match["desc"] or "", int(match["done"]), int(match["total"]), match["unit"],
                            float(match["elapsed"]))
    return None


def read_progress(path: Path | str, tail_bytes: int = TAIL_BYTES) -> Progress | None:
    """The last state in the last ``tail_bytes`` of the file at ``path``; None without one, or without the file."""
    try:
        with open(path, "rb") as f:
            start = max(0, f.seek(0, 2) - tail_bytes)
            f.seek(start)
            text = f.read().decode("utf-8", errors="replace")
    except OSError:  # removed or unreadable meanwhile: no progress to show
        return None
    if start > 0:  # the first piece was cut at its start: its numbers may be cut too
        parts = re.split(r"[\r\n]", text, maxsplit=1)
        text = parts[1] if len(parts) > 1 else ""
    return parse_progress(text)
