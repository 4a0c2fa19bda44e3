"""The numbers that define event handling, stated once.

Both simulation engines (the reference engine and the numba kernel) and the
hybrid layer of reachability read these; ``docs/semantics.md`` quotes them. The
kernel's compiled code freezes their values, and its disk cache is keyed on
this file, so changing one here recompiles the kernel.

All event-time tolerances scale with the current time: ``xtol(t) = event_tol *
max(1, |t|)`` (:func:`event_time_tolerance`), because a double resolves an
instant only relative to its magnitude.

>>> from hybridlab.simulation import rules
>>> rules.event_time_tolerance(1e-12, 50.0)
5e-11
>>> rules.schedule_index(2.0 - 1e-12, phase=0.0, period=1.0, done=-1)
2
"""

from __future__ import annotations

import math

__all__ = ["RETRIGGER_BAND", "CLUSTER_WIDTH", "ENTRY_BAND", "DUE_WIDTH", "ZENO_RESOLUTION",
           "SCHEDULE_SLACK", "CHECK_AT", "LOCATE_STEP", "LOCATE_ITERATIONS", "MINIMUM_WIDTH",
           "EQUIVALENT_SIGN_SLACK", "EQUAL_SLOPES",
           "event_time_tolerance", "schedule_index"]

#: A guard that was not just entered counts as enabled unless it is below
#: ``-(RETRIGGER_BAND * xtol * |slope| + event_atol)``, or within that band and falling
#: (touching the boundary while leaving).
RETRIGGER_BAND = 8.0
#: Crossings located within ``CLUSTER_WIDTH * xtol`` of the earliest one in a step are
#: simultaneous: they are handled at the same instant, by priority.
CLUSTER_WIDTH = 8.0
#: On entering a mode, a monitor's state is known to ``ENTRY_BAND * xtol * |slope| +
#: event_atol``: an invariant below minus this band is violated at entry, and a guard
#: within it is not armed until it has left the band.
ENTRY_BAND = 16.0
#: A scheduled instant is due at ``t`` when it is within ``DUE_WIDTH * xtol(t)``.
DUE_WIDTH = 2.0
#: The Zeno tracker counts two jumps closer than ``ZENO_RESOLUTION * event_tol`` as one
#: instant when estimating where jump times accumulate.
ZENO_RESOLUTION = 4.0
#: The index of the next scheduled instant is ``ceil((t - phase) / period - SCHEDULE_SLACK)``:
#: an instant a billionth of a period behind ``t`` is still the current one.
SCHEDULE_SLACK = 1e-9
#: Event location samples a step at this fraction of it: ``sqrt(2) - 1``, an irrational
#: split that keeps the sampling grid from aliasing with periodic guards.
CHECK_AT = 0.41421356237309515
#: Brent's method brackets a crossing to ``LOCATE_STEP * xtol``; the event time is then the
#: first of ``root + k * LOCATE_STEP * xtol`` (``k = 0, 1, 2``) where the monitor holds, so it
#: is never before the crossing; failing that (a noisy monitor), bisection of the bracket
#: from ``root - 2 * LOCATE_STEP * xtol`` to width ``xtol``.
LOCATE_STEP = 0.25
#: The most iterations Brent's method and the bisection after it take.
LOCATE_ITERATIONS = 200
#: The bounded minimiser that looks for a monitor's dip between samples stops at
#: ``max(xtol, MINIMUM_WIDTH * max(|a|, |b|, 1))`` on ``[a, b]``.
MINIMUM_WIDTH = 1e-15
#: An equivalent (Filippov) sign whose magnitude exceeds ``1 + EQUIVALENT_SIGN_SLACK`` means
#: the sliding motion has ended on that surface.
EQUIVALENT_SIGN_SLACK = 1e-12
#: Two one-sided derivatives across a switching surface that agree to this relative
#: amount leave the equivalent sign undetermined (the surface is crossed, not slid on).
EQUAL_SLOPES = 1e-14


def event_time_tolerance(event_tol: float, t: float) -> float:
    """The width to which an event time near ``t`` is located: ``event_tol * max(1, |t|)``.

    >>> event_time_tolerance(1e-12, 0.5), event_time_tolerance(1e-12, -200.0)
    (1e-12, 2e-10)
    """
    return event_tol * max(1.0, abs(t))


def schedule_index(t: float, phase: float, period: float, done: int) -> int:
    """The index ``k`` of the first instant ``phase + k * period`` not before ``t``.

    Instants up to :data:`SCHEDULE_SLACK` of a period behind ``t`` still count;
    ``done`` is the index of the last instant already fired (-1 for none) and is
    never repeated.

    >>> schedule_index(2.5, phase=0.0, period=1.0, done=-1)
    3
    >>> schedule_index(2.5, phase=0.0, period=1.0, done=4)
    5
    """
    return max(math.ceil((t - phase) / period - SCHEDULE_SLACK), done + 1, 0)
