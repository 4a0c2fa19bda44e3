"""Where the chunks of a sweep run: in process, in a pool, or on a Dask cluster."""

from __future__ import annotations

import concurrent.futures as cf
import os
from dataclasses import dataclass
from typing import Any

from hybridlab.ensemble.errors import SweepError

__all__ = ["SERIAL_BELOW", "Placement", "place"]

#: Sweeps with fewer runs than this run in process by default (a pool costs more).
SERIAL_BELOW = 4


@dataclass(frozen=True)
class Placement:
    """The executor chosen for a sweep.

    Attributes
    ----------
    executor : concurrent.futures.Executor or None
        ``None``: run serially in this process.
    owned : bool
        Created here, so the sweep shuts it down.
    in_process : bool
        Runs share this process (serial or threads): nothing is pickled.
    workers : int
        Parallel workers (for the default chunk size).
    label : str
    """

    executor: cf.Executor | None
    owned: bool
    in_process: bool
    workers: int
    label: str


def _cpus() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on every platform
        return os.cpu_count() or 1


def place(executor: Any, n_runs: int) -> Placement:
    """Resolve the ``executor`` argument of :func:`hybridlab.sweep`.

    ``None`` (auto): serial below :data:`SERIAL_BELOW` runs or on one core,
    else a process pool over every core; ``"serial"``, ``"threads"``,
    ``"processes"``; an int ``N`` (a process pool of ``N`` workers, 1 = serial);
    any :class:`concurrent.futures.Executor`; or a ``distributed.Client``
    (its ``get_executor()`` is used).

    Examples
    --------
    >>> place("serial", 10).label
    'serial'
    >>> place(None, 2).executor is None
    True
    """
    cpus = _cpus()
    if executor is None:
        executor = "serial" if n_runs < SERIAL_BELOW or cpus < 2 else "processes"
    if isinstance(executor, bool):
        raise SweepError(f"executor: expected an Executor, a Client, an int or one of "
                         f"'serial', 'threads', 'processes' (got {executor!r})")
    if isinstance(executor, int):
        if executor < 1:
            raise SweepError(f"executor: a worker count must be at least 1 (got {executor})")
        if executor == 1:
            return Placement(None, False, True, 1, "serial")
        pool = cf.ProcessPoolExecutor(max_workers=min(executor, max(n_runs, 1)))
        return Placement(pool, True, False, executor, f"processes({executor})")
    if executor == "serial":
        return Placement(None, False, True, 1, "serial")
    if executor == "threads":
        n = min(cpus, max(n_runs, 1))
        return Placement(cf.ThreadPoolExecutor(max_workers=n), True, True, n, f"threads({n})")
    if executor == "processes":
        n = min(cpus, max(n_runs, 1))
        return Placement(cf.ProcessPoolExecutor(max_workers=n), True, False, n, f"processes({n})")
    if isinstance(executor, cf.ThreadPoolExecutor):
        n = getattr(executor, "_max_workers", cpus)
        return Placement(executor, False, True, n, f"{type(executor).__name__}")
    if isinstance(executor, cf.Executor):
        n = getattr(executor, "_max_workers", cpus)
        return Placement(executor, False, False, n, f"{type(executor).__name__}")
    get_executor = getattr(executor, "get_executor", None)
    if callable(get_executor):  # a distributed.Client, without importing distributed here
        n = cpus
        info = getattr(executor, "nthreads", None)
        if callable(info):
            try:
                n = max(1, sum(info().values()))
            except Exception:  # a client that cannot report its workers: assume local cores
                n = cpus
        return Placement(get_executor(), False, False, n, f"dask({n})")
    raise SweepError(f"executor: expected an Executor, a Client, an int or one of "
                     f"'serial', 'threads', 'processes' (got {executor!r})")
