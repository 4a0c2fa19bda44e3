"""Errors of the ensemble layer."""

from __future__ import annotations

from hybridlab.errors import HybridlabError

__all__ = ["SweepError"]


class SweepError(HybridlabError, ValueError):
    """A sweep is set up wrongly (an unknown name, a bad grid, an unknown observable).

    The message is one line naming the argument and the offending token.

    Examples
    --------
    >>> isinstance(SweepError("grid: 'hh' is not a name"), ValueError)
    True
    """
