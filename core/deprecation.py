"""The warning of a deprecated form (the version policy in CHANGELOG.md): a ``DeprecationWarning`` that is shown.

Python shows a ``DeprecationWarning`` only where it is attributed to ``__main__``; the forms vpr-smr deprecates (a
plugin's old declaration) are met inside the command line and the workflow's jobs, where it would never be seen by
the person who must change the plugin. ``Deprecated`` is shown once per place by default (a filter for this
category alone); ``pytest.warns(DeprecationWarning)`` still catches it.
"""

from __future__ import annotations

import warnings

__all__ = ["Deprecated", "deprecated"]


class Deprecated(DeprecationWarning):
    """A form of vpr-smr that still works and that a later release removes."""


warnings.filterwarnings("default", category=Deprecated)


def deprecated(message: str, stacklevel: int = 1) -> None:
    """Warn ``message`` as ``Deprecated``, attributed ``stacklevel`` frames above the caller (1: the caller's
    caller, as ``warnings.warn``'s 2)."""
    warnings.warn(message, Deprecated, stacklevel=stacklevel + 2)
