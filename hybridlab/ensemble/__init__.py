"""Ensembles: many simulations of one model, in parallel, as one tidy table.

:func:`sweep` expands a grid or a sample of parameters and initial states;
:func:`simulate_many` takes the runs as :func:`hybridlab.simulate` keyword
arguments. Both run on any :class:`concurrent.futures.Executor` (a process
pool over every core by default; a ``distributed.Client`` for several
machines) and return a :class:`SweepResult`.
"""

from typing import TYPE_CHECKING

from hybridlab._lazy import lazy_exports

if TYPE_CHECKING:  # the public names, loaded on first use (hybridlab._lazy)
    from hybridlab.ensemble.api import simulate_many, sweep
    from hybridlab.ensemble.errors import SweepError
    from hybridlab.ensemble.observables import REDUCTIONS, Count, Observable
    from hybridlab.ensemble.progress import ProgressBar
    from hybridlab.ensemble.result import Pivot, SweepResult

__getattr__, __dir__ = lazy_exports(__name__, __file__)

__all__ = [
    "REDUCTIONS",
    "Count",
    "Observable",
    "Pivot",
    "ProgressBar",
    "SweepError",
    "SweepResult",
    "simulate_many",
    "sweep",
]
