"""Event location on the integrator's dense output.

Every watched quantity is a *monitor* ``phi(t)`` that fires when it reaches
zero from above. Within one integrator step each monitor is sampled, with its
time derivative, at ``2 * samples_per_step + 1`` points. On every
sub-interval the cubic Hermite interpolant of the samples is compared with
the true value at the midpoint; where they disagree (the monitor is not
resolved, e.g. a guard that oscillates faster than the step) the
sub-interval is bisected, up to ``max_refine`` times. On the resolved
samples each sub-interval is then examined through its cubic: a sign change,
or an interior minimum that reaches zero (two crossings inside one
sub-interval, or a tangential touch), marks a candidate, which is confirmed
and located on the true function by bounded minimisation and a bracketing
root finder that keeps ``phi(lo) > 0 >= phi(hi)`` and returns ``hi``: the
first instant at which the monitor has reached zero.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TypeVar

import numpy as np
from scipy.optimize import brentq, minimize_scalar

from hybridlab.simulation.rules import CHECK_AT, LOCATE_ITERATIONS, LOCATE_STEP, MINIMUM_WIDTH

__all__ = ["Trigger", "sample_step", "first_trigger", "locate_crossing", "hermite_extremes",
           "hermite_minimum_until"]

BatchFn = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
ValueFn = Callable[[float], float]
#: the samples' cubic is formed for all intervals at once or for one
_Values = TypeVar("_Values", float, np.ndarray)


@dataclass(frozen=True)
class Trigger:
    """A monitor reaching zero at time ``t`` (``grazing``: tangentially).

    Examples
    --------
    The guard ``1 - t >= 0`` of a clock, sampled over one step and located:

    >>> batch = lambda tau: (np.atleast_2d(1.0 - tau), np.atleast_2d(-np.ones_like(tau)))
    >>> tau, phi, dphi, _ = sample_step(0.0, 2.0, batch, 4, 3, 1e-12)
    >>> trigger, armed = first_trigger(0, tau, phi[0], dphi[0], True, lambda t: 1.0 - t,
    ...                                1e-12, 1e-12)
    >>> trigger
    Trigger(monitor=0, t=1.0, grazing=False)
    """

    monitor: int
    t: float
    grazing: bool


def _coefficients(h: _Values, fa: _Values, fb: _Values, da: _Values,
                  db: _Values) -> tuple[_Values, _Values, _Values, _Values]:
    """Cubic ``c0 + c1 s + c2 s^2 + c3 s^3`` on s in [0, 1] matching values and slopes."""
    c1 = h * da
    c2 = 3.0 * (fb - fa) - h * (2.0 * da + db)
    c3 = 2.0 * (fa - fb) + h * (da + db)
    return fa, c1, c2, c3


def hermite_extremes(h: np.ndarray, fa: np.ndarray, fb: np.ndarray, da: np.ndarray,
                     db: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Minimum and maximum of the cubic Hermite interpolant on each interval.

    Returns ``(min_value, s_at_min, max_value, s_at_max)`` with ``s`` in [0, 1].

    Examples
    --------
    >>> lo, s_lo, hi, s_hi = hermite_extremes(np.array([1.0]), np.array([1.0]), np.array([1.0]),
    ...                                       np.array([-4.0]), np.array([4.0]))
    >>> float(lo[0]), float(s_lo[0])
    (0.0, 0.5)
    """
    c0, c1, c2, c3 = _coefficients(h, fa, fb, da, db)
    candidates = [np.zeros_like(c0), np.ones_like(c0)]
    # roots of c1 + 2 c2 s + 3 c3 s^2, by the cancellation-free form of the quadratic formula
    a, b, c = 3.0 * c3, 2.0 * c2, c1
    disc = b * b - 4.0 * a * c
    with np.errstate(divide="ignore", invalid="ignore"):
        sq = np.sqrt(np.where(disc >= 0, disc, np.nan))
        q = -0.5 * (b + np.where(b >= 0, 1.0, -1.0) * sq)
        r1 = np.where(a != 0, q / a, np.nan)
        r2 = np.where(q != 0, c / q, np.where(b != 0, -c / b, np.nan))
    for r in (r1, r2):
        inside = np.isfinite(r) & (r > 0) & (r < 1)
        candidates.append(np.where(inside, r, 0.0))
    s = np.stack(candidates)
    values = c0 + s * (c1 + s * (c2 + s * c3))
    i_min = np.argmin(values, axis=0)[None]
    i_max = np.argmax(values, axis=0)[None]

    def pick(a: np.ndarray, i: np.ndarray) -> np.ndarray:
        return np.take_along_axis(a, i, axis=0)[0]

    return pick(values, i_min), pick(s, i_min), pick(values, i_max), pick(s, i_max)


def hermite_minimum_until(h: float, fa: float, fb: float, da: float, db: float,
                          s_end: float) -> float:
    """Minimum of the cubic of :func:`hermite_extremes` on ``[0, s_end]`` (``s_end <= 1``).

    The candidates are the ends and the cubic's critical points inside; the
    arithmetic is that of :func:`hermite_extremes`, term by term.

    Examples
    --------
    The cubic through ``1`` (slope ``-4``) and ``1`` (slope ``4``) dips to ``0`` at the
    middle, but not before a quarter of the interval:

    >>> hermite_minimum_until(1.0, 1.0, 1.0, -4.0, 4.0, 1.0)
    0.0
    >>> hermite_minimum_until(1.0, 1.0, 1.0, -4.0, 4.0, 0.25)
    0.25
    """
    _, c1, c2, c3 = _coefficients(h, fa, fb, da, db)
    a, b, c = 3.0 * c3, 2.0 * c2, c1
    disc = b * b - 4.0 * a * c
    sq = math.sqrt(disc) if disc >= 0 else math.nan
    q = -0.5 * (b + (1.0 if b >= 0 else -1.0) * sq)
    r1 = q / a if a != 0 else math.nan
    r2 = c / q if q != 0 else (-c / b if b != 0 else math.nan)
    best = fa
    for s in (s_end, r1, r2):
        if math.isfinite(s) and 0 < s <= s_end:
            best = min(best, fa + s * (c1 + s * (c2 + s * c3)))
    return best


def sample_step(t0: float, t1: float, batch: BatchFn, samples: int, max_refine: int,
                tol: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Sample every monitor on ``[t0, t1]`` until its shape is resolved.

    Each interval is checked at an interior point (an irrational fraction of
    its length, so that refined grids are not uniform and a periodic guard
    cannot alias): the cubic Hermite interpolant of the end values and slopes
    must predict both the value and the slope there. An interval that fails
    and whose monitor may come near zero is split at that point.

    Parameters
    ----------
    t0, t1 : float
        The step.
    batch : callable
        ``batch(tau) -> (phi, dphi)``, arrays of shape ``(M, len(tau))``.
    samples : int
        Initial number of intervals.
    max_refine : int
        Maximum split depth of an unresolved interval.
    tol : float
        Absolute monitor tolerance (``event_atol``).

    Returns
    -------
    tau, phi, dphi : numpy.ndarray
        Sorted sample times and monitor values and slopes there.
    refinements : int
        How many intervals were split.

    Examples
    --------
    A monitor that oscillates faster than the step, ``cos(20 t) + 0.5`` on ``[0, 1]``
    from two intervals: the unresolved ones are split until its shape is known.

    >>> def batch(tau):
    ...     return np.atleast_2d(np.cos(20 * tau) + 0.5), np.atleast_2d(-20 * np.sin(20 * tau))
    >>> tau, phi, dphi, refinements = sample_step(0.0, 1.0, batch, 2, 6, 1e-12)
    >>> refinements > 0, phi.shape == (1, tau.size), bool(np.all(np.diff(tau) > 0))
    (True, True, True)
    """
    grid = np.linspace(t0, t1, samples + 1)
    g_phi, g_dphi = batch(grid)
    kept_t, kept_phi, kept_dphi = [grid], [g_phi], [g_dphi]
    a_t, b_t = grid[:-1], grid[1:]
    a_phi, b_phi, a_d, b_d = g_phi[:, :-1], g_phi[:, 1:], g_dphi[:, :-1], g_dphi[:, 1:]
    refinements = 0
    for level in range(max_refine + 1):
        if g_phi.shape[0] == 0 or a_t.size == 0:
            break
        h = b_t - a_t
        c_t = a_t + CHECK_AT * h
        c_phi, c_d = batch(c_t)
        kept_t.append(c_t)
        kept_phi.append(c_phi)
        kept_dphi.append(c_d)
        if level == max_refine:
            break
        k0, k1, k2, k3 = _coefficients(h, a_phi, b_phi, a_d, b_d)
        q = CHECK_AT
        predicted = k0 + q * (k1 + q * (k2 + q * k3))
        slope = (k1 + q * (2.0 * k2 + 3.0 * q * k3)) / np.where(h > 0, h, 1.0)
        # value and slope must both agree: one alone can match by accident
        err = np.maximum(np.abs(c_phi - predicted), 0.25 * h * np.abs(c_d - slope))
        values = np.stack([a_phi, c_phi, b_phi])
        scale = np.max(np.abs(values), axis=0)
        lo = np.min(np.abs(values), axis=0)
        sign_change = (np.sign(a_phi) != np.sign(c_phi)) | (np.sign(c_phi) != np.sign(b_phi))
        near = (lo <= 4.0 * err + tol) | sign_change
        split = np.any((err > 0.05 * scale + tol) & near, axis=0)
        if not np.any(split):
            break
        refinements += int(split.sum())
        a_t, b_t = (np.concatenate([a_t[split], c_t[split]]),
                    np.concatenate([c_t[split], b_t[split]]))
        a_phi, b_phi = (np.concatenate([a_phi[:, split], c_phi[:, split]], axis=1),
                        np.concatenate([c_phi[:, split], b_phi[:, split]], axis=1))
        a_d, b_d = (np.concatenate([a_d[:, split], c_d[:, split]], axis=1),
                    np.concatenate([c_d[:, split], b_d[:, split]], axis=1))
    tau = np.concatenate(kept_t)
    tau, first = np.unique(tau, return_index=True)
    phi = np.concatenate(kept_phi, axis=1)[:, first]
    dphi = np.concatenate(kept_dphi, axis=1)[:, first]
    return tau, phi, dphi, refinements


def locate_crossing(fn: ValueFn, lo: float, hi: float, f_lo: float, f_hi: float,
                    xtol: float, max_iter: int = LOCATE_ITERATIONS) -> float:
    """Shrink ``[lo, hi]`` with ``fn(lo) > 0 >= fn(hi)`` to width ``xtol``; return ``hi``.

    Brent's method (:func:`scipy.optimize.brentq`) finds the root; the
    returned time is then moved, if needed, to the side where the monitor has
    reached zero, so it is never before the crossing and at most ``xtol``
    after it.

    Examples
    --------
    >>> t = locate_crossing(lambda t: 2.0 - t * t, 0.0, 2.0, 2.0, -2.0, 1e-14)
    >>> abs(t - 2 ** 0.5) < 1e-13 and 2.0 - t * t <= 0
    True
    """
    if f_hi == 0.0 or hi - lo <= xtol:
        return hi
    root = brentq(fn, lo, hi, xtol=LOCATE_STEP * xtol, rtol=4 * np.finfo(float).eps,
                  maxiter=max_iter)
    for candidate in (root + k * LOCATE_STEP * xtol for k in range(3)):
        if candidate >= hi:
            return hi
        if fn(candidate) <= 0:
            return candidate
    # noisy function near the root: finish by bisection on the guaranteed bracket
    back = max(lo, root - 2 * LOCATE_STEP * xtol)
    lo = back if fn(back) > 0 else lo
    for _ in range(max_iter):
        if hi - lo <= xtol:
            break
        mid = 0.5 * (lo + hi)
        if fn(mid) > 0:
            lo = mid
        else:
            hi = mid
    return hi


def _true_minimum(fn: ValueFn, a: float, b: float, s_guess: float, xtol: float) -> tuple[float,
                                                                                          float]:
    res = minimize_scalar(fn, bounds=(a, b), method="bounded",
                          options={"xatol": max(xtol, MINIMUM_WIDTH * max(abs(a), abs(b), 1.0))})
    t_best, f_best = float(res.x), float(res.fun)
    guess = a + s_guess * (b - a)
    f_guess = fn(guess)
    if f_guess < f_best:
        t_best, f_best = guess, f_guess
    return t_best, f_best


def _search(candidates: np.ndarray, tau: np.ndarray, fa: np.ndarray, fb: np.ndarray,
            lo_val: np.ndarray, lo_s: np.ndarray, fn: ValueFn, t_from: float, level: float,
            index: int, xtol: float, tol: float) -> Trigger | None:
    """First time ``fn`` reaches ``level`` within the candidate intervals."""
    for k in candidates:
        a = max(float(tau[k]), t_from)
        b = float(tau[k + 1])
        f_a = (fn(a) if a != tau[k] else float(fa[k])) - level
        f_b = float(fb[k]) - level
        if f_a <= 0:  # touching at the very start of the interval
            return Trigger(index, a, grazing=True)
        if f_b <= 0 and not (0.0 < lo_s[k] < 1.0 and lo_val[k] < fb[k]):
            t_min, f_min = b, f_b
        else:
            t_min, f_min = _true_minimum(lambda t: fn(t) - level, a, b, float(lo_s[k]), xtol)
            if f_b <= 0 and f_b < f_min:
                t_min, f_min = b, f_b
        if f_min <= 0:
            t_hit = locate_crossing(lambda t: fn(t) - level, a, t_min, f_a, f_min, xtol)
            # a minimum within the contact tolerance of zero is a tangential touch
            return Trigger(index, t_hit, grazing=f_min >= -tol > -np.inf and f_b > tol)
        if f_min <= tol:
            return Trigger(index, t_min, grazing=True)
    return None


def first_trigger(index: int, tau: np.ndarray, phi: np.ndarray, dphi: np.ndarray, armed: bool,
                  fn: ValueFn, xtol: float, tol: float, floor: float | None = None,
                  extremes: tuple[np.ndarray, ...] | None = None,
                  located: tuple[float, float] | None = None) -> tuple[Trigger | None, bool]:
    """The first time monitor ``index`` reaches zero from above within the samples.

    A monitor that is not ``armed`` (it started on or below zero, e.g. a guard
    right after its own reset) must first rise above ``tol``; if ``floor`` is
    given it also fires when it sinks below ``floor`` before it rises (a
    safety net: a state that started on a boundary and went through it). Only
    the part of an interval before the instant it rises counts for the floor.

    ``located = (t, width)``: an event another monitor of the step reaches at
    ``t``. A monitor that has risen before ``t - width`` and is above zero there
    but not at ``t`` coincides with it and fires at ``t`` without a search of
    its own (as the scan does for armed monitors).

    Returns
    -------
    trigger : Trigger or None
    armed : bool
        Whether the monitor is armed at the end of the samples (used to carry
        the state into the next step when nothing triggers).

    Examples
    --------
    The first zero of ``cos(20 t) + 0.5`` is at ``acos(-0.5) / 20 = pi / 30``:

    >>> fn = lambda t: np.cos(20 * t) + 0.5
    >>> def batch(tau):
    ...     return np.atleast_2d(fn(tau)), np.atleast_2d(-20 * np.sin(20 * tau))
    >>> tau, phi, dphi, _ = sample_step(0.0, 1.0, batch, 2, 6, 1e-12)
    >>> trigger, armed = first_trigger(0, tau, phi[0], dphi[0], True, fn, 1e-12, 1e-12)
    >>> bool(abs(trigger.t - np.pi / 30) < 1e-12 and fn(trigger.t) <= 0), trigger.grazing
    (True, False)
    """
    h = np.diff(tau)
    fa, fb, da, db = phi[:-1], phi[1:], dphi[:-1], dphi[1:]
    if extremes is None:
        extremes = hermite_extremes(h, fa, fb, da, db)
    lo_val, lo_s, hi_val, hi_s = extremes
    lower = np.minimum(np.minimum(fa, fb), lo_val)
    start = 0
    t_from = float(tau[0])
    if not armed:
        # where it re-arms: the first instant it is above tol (an interval whose cubic
        # promises more than the function gives does not re-arm it)
        rearmed = False
        start = h.size
        for k in np.nonzero(np.maximum(np.maximum(fa, fb), hi_val) > tol)[0]:
            peak = float(tau[k] + hi_s[k] * h[k])
            if fa[k] > tol:
                t_from, start = float(tau[k]), int(k)
            elif hi_val[k] > tol and hi_s[k] < 1.0 and fn(peak) > tol:
                t_from, start = peak, int(k)
            elif fb[k] > tol:
                t_from, start = float(tau[k + 1]), int(k) + 1
            else:
                continue
            rearmed = True
            break
        if floor is not None:  # before it re-arms, sinking below the floor fires it
            sinking = [int(i) for i in np.nonzero(lower[:start] <= floor)[0]]
            # re-armed inside interval `start`: only its part before that instant counts
            if (rearmed and start < h.size and t_from > tau[start]
                    and hermite_minimum_until(float(h[start]), float(fa[start]), float(fb[start]),
                                              float(da[start]), float(db[start]),
                                              (t_from - float(tau[start])) / float(h[start]))
                    <= floor):
                sinking.append(start)
            trig = _search(np.array(sinking, dtype=int), tau, fa, fb, lo_val, lo_s, fn,
                           float(tau[0]), floor, index, xtol, 0.0)
            if trig is not None and (not rearmed or trig.t <= t_from):
                return trig, False
        if not rearmed:
            return None, False
        if start >= h.size:
            return None, bool(phi[-1] > tol)
        if located is not None:
            t_event, width = located
            if t_from <= t_event - width and fn(t_event) <= 0 < fn(t_event - width):
                return Trigger(index, t_event, False), True
    candidates = np.nonzero(lower[start:] <= tol)[0] + start
    return _search(candidates, tau, fa, fb, lo_val, lo_s, fn, t_from, 0.0, index, xtol,
                   tol), True
