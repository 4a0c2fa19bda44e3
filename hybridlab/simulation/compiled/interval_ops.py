"""The interval arithmetic of :mod:`hybridlab.symbolic.interval_arithmetic`, compiled by numba.

The generated models' box functions (:mod:`.box_printer`) call these to enclose
conditions and switching functions over a step (:mod:`.bounds`). They are the
very functions reachability and the mode graph's checks run in Python, with the
same rounding policy, each compiled with its helpers bound to compiled helpers
(:data:`~hybridlab.symbolic.interval_machine.ARITHMETIC`, which also runs
reachability's interval programs compiled).
An empty result (an operand outside a function's domain) is the pair
``(nan, nan)``; the box functions bound it by the whole line (:func:`i_bound`),
which proves nothing.

Examples
--------
>>> from hybridlab.simulation.compiled.interval_ops import i_mul, i_sqrt
>>> lo, hi = i_mul(-1.0, 2.0, 3.0, 4.0)
>>> lo <= -4.0 and hi >= 8.0
True
>>> i_sqrt(-1.0, 4.0)[0]
0.0
"""

from __future__ import annotations

from collections.abc import Callable

from hybridlab.symbolic import interval_arithmetic as _arithmetic
from hybridlab.symbolic.interval_machine import ARITHMETIC as _OPS

__all__ = [name for name in _arithmetic.__all__ if name.startswith("i_")]


def __getattr__(name: str) -> Callable[..., tuple[float, float]]:
    if name.startswith("i_") and name in _OPS:
        return _OPS[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])
