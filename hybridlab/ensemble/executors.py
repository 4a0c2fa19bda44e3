"""Where the chunks of a sweep run: in process, in a pool, or on a Dask cluster.

The resolution itself lives in :mod:`hybridlab.simulation.executors` (shared
with :func:`hybridlab.reach`); this module fixes the error type to
:class:`SweepError`.
"""

from __future__ import annotations

from typing import Any

from hybridlab.ensemble.errors import SweepError
from hybridlab.simulation import executors as _shared
from hybridlab.simulation.executors import SERIAL_BELOW, Placement

__all__ = ["SERIAL_BELOW", "Placement", "place"]


def place(executor: Any, n_runs: int) -> Placement:
    """Resolve the ``executor`` argument of :func:`hybridlab.sweep` (see
    :func:`hybridlab.simulation.executors.place`); a bad value is a :class:`SweepError`.

    Examples
    --------
    >>> place("serial", 10).label
    'serial'
    >>> place(None, 2).executor is None
    True
    """
    return _shared.place(executor, n_runs, SweepError)
