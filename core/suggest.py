"""The closest valid name to a misspelt one, for messages (a dataset setting, a configuration key)."""

from __future__ import annotations

import difflib
from collections.abc import Sequence


def did_you_mean(name: str, valid: Sequence[str]) -> str:
    """`` (did you mean 'tolerance'?)`` for the valid name closest to ``name``, or empty when none is close."""
    close = difflib.get_close_matches(name, list(valid), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""
