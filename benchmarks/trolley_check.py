"""Does the plain scipy trolley (``scipy_trolley.py``) agree with hybridlab?

Both produce an event log named alike: sensor edges (``s1_on`` ...), the
manoeuvre's transitions (``detect``, ``turn``, ``arrive`` ...) and the friction
events (``"slide_start sign(v)"``, ``"crossing sign(omega)"`` ...). Two classes of
events are compared with different tolerances:

* **observable** events (sensor edges, zero crossings of the pendulum's angular
  velocity, manoeuvre transitions): well conditioned; at ``rtol = 1e-10`` both
  implementations agree with a ``rtol = 1e-12`` hybridlab run to about 1e-9 s;
* **stick/slip** events of the cart friction: a velocity reaching zero with a small
  slope, or a required force leaving the friction band slowly, is ill conditioned;
  at ``rtol = 1e-10`` these agree to about 1e-6 s. Once the cart has settled to
  within nanometres of its set point (the last second of the free drop, after
  the pendulum has stopped) the count of these micro stick/slip cycles depends on
  the tolerance even between two hybridlab runs, so they are compared only up to
  a stated horizon.

``check`` runs both and raises ``RuntimeError`` naming the first disagreement; the
trolley benchmarks call it before timing anything.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy_trolley

import hybridlab

__all__ = ["Agreement", "CHECK_ATOL", "CHECK_RTOL", "FREE_DROP_FRICTION_HORIZON",
           "OBSERVABLE_TOL", "FRICTION_TOL", "SAFE_MAX_STEP", "check", "compare",
           "hybridlab_events", "is_friction", "normalise",
           "reference_backend"]

#: Tolerances of the agreement check (tight, so that the check tests the models,
#: not the integrators).
CHECK_RTOL, CHECK_ATOL = 1e-10, 1e-12
#: Largest allowed event-time difference [s] for observable and for stick/slip events.
OBSERVABLE_TOL, FRICTION_TOL = 1e-6, 1e-5
#: Stick/slip events of the free drop are compared up to here [s] (see the module text).
FREE_DROP_FRICTION_HORIZON = 50.0
#: ``max_step`` [s] the scipy loop needs so no breakaway falls inside one step (the
#: required friction force leaves and re-enters its band within 30-60 ms).
SAFE_MAX_STEP = 0.01


def is_friction(name: str) -> bool:
    """Whether an event is a stick/slip event of the cart or bearing friction.

    Zero crossings of the pendulum's velocity (``"crossing sign(omega)"``) count as
    observable: they are the swing's turning points.
    """
    return name.startswith(("slide_start", "slide_end")) or name == "crossing sign(v)"


def hybridlab_events(result: hybridlab.SimulationResult) -> tuple[tuple[float, str], ...]:
    """The event log of a hybridlab run as ``(t, name)`` pairs, named like the scipy log."""
    return tuple((e.t, e.transition if e.kind == "jump" else f"{e.kind} {e.transition}")
                 for e in result.events)


def normalise(log: Sequence[tuple[float, str]]) -> list[tuple[float, str]]:
    """Drop repeated ``slide_start`` of a surface that is already stuck.

    Both implementations re-decide the sticking set at every event, and hybridlab
    logs ``slide_start`` again when a jump (a sensor edge, say) happens while a
    surface sticks; after this every ``slide_start`` kept is a surface starting
    to stick.
    """
    out, stuck = [], set()
    for t, name in log:
        kind, _, surface = name.partition(" ")
        if kind == "slide_start":
            if surface in stuck:
                continue
            stuck.add(surface)
        elif kind == "slide_end":
            stuck.discard(surface)
        out.append((t, name))
    return out


@dataclass(frozen=True)
class Agreement:
    """How two event logs agree, event name by event name.

    Attributes
    ----------
    counts : dict of str to (int, int)
        Events of each name in the first and in the second log.
    max_dt : dict of str to float
        Largest time difference of same-named events, paired in order (only for
        names whose counts agree).
    """

    counts: dict[str, tuple[int, int]]
    max_dt: dict[str, float]

    def mismatched(self) -> list[str]:
        """Names whose counts differ."""
        return [n for n, (a, b) in self.counts.items() if a != b]

    def worst(self, names: Iterable[str] | None = None) -> float:
        """Largest time difference over ``names`` (all by default); 0 if none."""
        keys = self.max_dt if names is None else [n for n in names if n in self.max_dt]
        return max((self.max_dt[n] for n in keys), default=0.0)

    def observable_dt(self) -> float:
        return self.worst(n for n in self.max_dt if not is_friction(n))

    def friction_dt(self) -> float:
        return self.worst(n for n in self.max_dt if is_friction(n))


def compare(a: Sequence[tuple[float, str]], b: Sequence[tuple[float, str]], *,
            friction_until: float = math.inf) -> Agreement:
    """Compare two event logs; stick/slip events only before ``friction_until``."""
    times: tuple[dict[str, list[float]], dict[str, list[float]]] = (defaultdict(list),
                                                                     defaultdict(list))
    for log, out in zip((a, b), times, strict=True):
        for t, name in normalise(log):
            if not is_friction(name) or t < friction_until:
                out[name].append(t)
    counts, max_dt = {}, {}
    for name in sorted(set(times[0]) | set(times[1])):
        ta, tb = np.array(times[0][name]), np.array(times[1][name])
        counts[name] = (ta.size, tb.size)
        if ta.size == tb.size:
            max_dt[name] = float(np.max(np.abs(ta - tb))) if ta.size else 0.0
    return Agreement(counts, max_dt)


def reference_backend() -> dict[str, str]:
    """``simulate`` keywords selecting hybridlab's reference (scipy-stepped) engine."""
    if "backend" in hybridlab.SimulationOptions.__dataclass_fields__:
        return {"backend": "reference"}
    return {}


def _run_pair(job: str, compiled: hybridlab.CompiledModel, t_end: float | None, method: str,
              rtol: float, atol: float, max_step: float):
    if job == "free_drop":
        ours = scipy_trolley.free_drop(t_end=t_end, method=method, rtol=rtol, atol=atol,
                                       max_step=max_step)
        scenario = "free_drop"
    elif job == "stop_and_return":
        ours = scipy_trolley.stop_and_return(t_end=t_end, method=method, rtol=rtol, atol=atol,
                                             max_step=max_step)
        scenario = "default"
    else:
        raise ValueError(f"job must be 'free_drop' or 'stop_and_return' (got {job!r})")
    theirs = hybridlab.simulate(compiled, t_end=t_end, scenario=scenario, method=method,
                                rtol=rtol, atol=atol, **reference_backend())
    if not theirs.status.ok:
        raise RuntimeError(f"hybridlab stopped early: {theirs.status.name}: {theirs.message}")
    return ours, theirs


def check(job: str, compiled: hybridlab.CompiledModel | None = None, *,
          t_end: float | None = None, method: str = "DOP853", rtol: float = CHECK_RTOL,
          atol: float = CHECK_ATOL, max_step: float = SAFE_MAX_STEP,
          observable_tol: float = OBSERVABLE_TOL,
          friction_tol: float = FRICTION_TOL) -> Agreement:
    """Run ``job`` both ways and raise ``RuntimeError`` unless the event logs agree.

    hybridlab runs on its reference backend.

    Parameters
    ----------
    job : {"free_drop", "stop_and_return"}
    compiled : hybridlab.CompiledModel, optional
        The compiled trolley (compiled here if not given).
    t_end : float, optional
        Horizon (default: the scenario's).
    method, rtol, atol, max_step
        Solver settings (``max_step`` for the scipy loop only).
    observable_tol, friction_tol : float
        Largest event-time differences allowed [s].

    Returns
    -------
    Agreement
        Of the scipy log (first) against hybridlab's (second).
    """
    if compiled is None:
        compiled = hybridlab.compile_model(hybridlab.load_model(scipy_trolley.MODEL))
    ours, theirs = _run_pair(job, compiled, t_end, method, rtol, atol, max_step)
    horizon = FREE_DROP_FRICTION_HORIZON if job == "free_drop" else math.inf
    agreement = compare(ours.events, hybridlab_events(theirs), friction_until=horizon)
    bad = agreement.mismatched()
    if bad:
        detail = ", ".join(f"{n} {agreement.counts[n][0]} vs {agreement.counts[n][1]}"
                           for n in bad)
        raise RuntimeError(f"{job}: event counts differ (scipy vs hybridlab): {detail}")
    for label, dt, tol in (("observable", agreement.observable_dt(), observable_tol),
                           ("stick/slip", agreement.friction_dt(), friction_tol)):
        if not dt <= tol:
            raise RuntimeError(f"{job}: {label} event times differ by {dt:.3g} s "
                               f"(allowed {tol:g} s)")
    return agreement
