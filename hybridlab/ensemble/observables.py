"""What a sweep records of each run: observables and event counts."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from hybridlab.ensemble.errors import SweepError
from hybridlab.simulation.tables import EventTable

__all__ = ["REDUCTIONS", "Count", "Observable", "parse_counts", "parse_observables"]

#: How an expression is reduced to one number per run.
REDUCTIONS = ("final", "min", "max", "at")


@dataclass(frozen=True)
class Observable:
    """One recorded number per run.

    Parameters
    ----------
    name : str
        Column name.
    expression : str, optional
        A model expression (states, parameters, definitions, ``t``), parsed
        with the safe parser.
    reduction : {"final", "min", "max", "at"}
        ``final``: the value at the end of the run (post-jump); ``min`` /
        ``max``: over the stored points (every integrator step and both sides
        of every event, so an extremum between two steps is not located;
        lower ``max_step`` to sample more finely); ``at``: the value at time
        ``time`` (post-jump at a jump instant; missing if the run ended before).
    time : float, optional
        The time for ``at``.
    function : callable, optional
        Instead of an expression: ``function(result) -> float`` on the
        :class:`hybridlab.SimulationResult`. Worker processes receive it by
        pickling, so a process pool or Dask needs a function defined at module
        level (a lambda or a closure only works with ``executor="serial"`` or
        ``"threads"``).

    Examples
    --------
    >>> Observable("peak", "abs(v)", "max")
    Observable(name='peak', expression='abs(v)', reduction='max', time=None, function=None)
    """

    name: str
    expression: str | None = None
    reduction: str = "final"
    time: float | None = None
    function: Callable[[Any], float] | None = None

    def __post_init__(self) -> None:
        if (self.expression is None) == (self.function is None):
            raise SweepError(f"observe {self.name!r}: give an expression or a function")
        if self.reduction not in REDUCTIONS:
            raise SweepError(f"observe {self.name!r}: unknown reduction {self.reduction!r}; "
                             f"expected one of {', '.join(REDUCTIONS)}")
        if self.reduction == "at" and (self.time is None or not math.isfinite(self.time)):
            raise SweepError(f"observe {self.name!r}: 'at' needs a finite time")


@dataclass(frozen=True)
class Count:
    """How often transitions fired in a run, optionally only after another one.

    Parameters
    ----------
    transitions : tuple of str
        Transition names; their jumps are counted together.
    after : str, optional
        Count only jumps strictly after the first jump of this transition;
        the count is missing (``None``, NaN in arrays) when it never fired.
    name : str, optional
        Column name (default ``count:T1+T2`` or ``count:T1+T2@AFTER``).

    Examples
    --------
    >>> Count(("s1_on", "s1_off"), after="arrive").column
    'count:s1_on+s1_off@arrive'
    """

    transitions: tuple[str, ...]
    after: str | None = None
    name: str | None = None

    def __post_init__(self) -> None:
        if isinstance(self.transitions, str):
            object.__setattr__(self, "transitions", (self.transitions,))
        if not self.transitions:
            raise SweepError("events: a count needs at least one transition")

    @property
    def column(self) -> str:
        if self.name:
            return self.name
        text = "count:" + "+".join(self.transitions)
        return text + (f"@{self.after}" if self.after else "")

    def evaluate(self, jumps: Sequence[Any]) -> int | None:
        """The count over a result's jump log (read by columns: no event object is made)."""
        if not isinstance(jumps, EventTable):
            jumps = EventTable.from_events(jumps, ())
        start = -math.inf
        if self.after is not None:
            first = jumps.where(transition=self.after).t
            if not first.size:
                return None
            start = first[0]
        return int(np.count_nonzero(jumps.where(transition=self.transitions).t > start))


def _one_observable(name: str, spec: Any) -> Observable:
    if isinstance(spec, Observable):
        return spec
    if isinstance(spec, str):
        return Observable(name, spec)
    if callable(spec):
        return Observable(name, function=spec)
    if isinstance(spec, tuple | list) and len(spec) in (2, 3) and isinstance(spec[0], str):
        if spec[0] == "at":
            if len(spec) != 3:
                raise SweepError(f"observe {name!r}: write ('at', EXPRESSION, TIME)")
            try:
                time = float(spec[2])
            except (TypeError, ValueError):
                raise SweepError(f"observe {name!r}: time {spec[2]!r} is not a number") from None
            return Observable(name, str(spec[1]), "at", time)
        if len(spec) == 2:
            return Observable(name, str(spec[1]), spec[0])
    raise SweepError(f"observe {name!r}: expected an expression, (REDUCTION, EXPRESSION), "
                     f"('at', EXPRESSION, TIME) or a function (got {spec!r})")


def parse_observables(observe: Any) -> tuple[Observable, ...]:
    """Observables from the ``observe`` argument of :func:`hybridlab.sweep`.

    A mapping ``{column: spec}`` (spec: an expression for its final value,
    ``(REDUCTION, EXPRESSION)``, ``("at", EXPRESSION, TIME)``, a function of the
    result or an :class:`Observable`) or a sequence of expressions (final
    values, named by their text).

    Examples
    --------
    >>> [o.reduction for o in parse_observables({"h_end": "h", "top": ("max", "h")})]
    ['final', 'max']
    >>> parse_observables(["h"])[0].name
    'h'
    """
    if observe is None:
        return ()
    if isinstance(observe, str):
        observe = [observe]
    if isinstance(observe, Mapping):
        items = [(str(k), v) for k, v in observe.items()]
    else:
        items = []
        for spec in observe:
            if isinstance(spec, Observable):
                items.append((spec.name, spec))
            elif isinstance(spec, str):
                items.append((spec, spec))
            else:
                raise SweepError("observe: a sequence must hold expressions or Observables; "
                                 "use a mapping {name: spec} for reductions and functions")
    return tuple(_one_observable(name, spec) for name, spec in items)


def parse_counts(events: Any, transitions: Sequence[str]) -> tuple[Count, ...]:
    """Counts from the ``events`` argument, checked against the model's transitions.

    Examples
    --------
    >>> [c.column for c in parse_counts(["bounce"], ["bounce"])]
    ['count:bounce']
    >>> parse_counts(["bonce"], ["bounce"])
    Traceback (most recent call last):
    ...
    hybridlab.ensemble.errors.SweepError: events: unknown transition 'bonce'; the model has: bounce
    """
    if events is None:
        return ()
    if isinstance(events, str | Count):
        events = [events]
    out = []
    for spec in events:
        count = spec if isinstance(spec, Count) else Count((str(spec),))
        for name in (*count.transitions, *([count.after] if count.after else [])):
            if name not in transitions:
                raise SweepError(f"events: unknown transition {name!r}; the model has: "
                                 f"{', '.join(transitions) or 'none'}")
        out.append(count)
    return tuple(out)
