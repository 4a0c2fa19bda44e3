"""Bouncing ball: hybridlab against its strongest peers, one ball and an ensemble.

Peers, all timed in this process and compared as ratios:

* a hand-written numba restart loop (:func:`numba_ball`): scipy's DOP853 (same
  tableau, error norm, step-size control and initial step as ``solve_ivp``),
  its 7th-order dense output, and Brent's method on it for the impact;
* the ``solve_ivp`` restart loop of ``bouncing_ball.py`` (one ball only);
* diffrax (optional): ``Dopri8`` with an ``Event`` root-found by Newton's
  method, a Python restart loop around a jitted solve (one ball) and one
  vmapped, jitted solve with the restart inside (the ensemble).

Job 1, one ball: scenario ``benchmark`` of ``models/bouncing_ball.toml`` (h0 = 10
m, e = 0.95, T = 50 s, 44 bounces), DOP853 at rtol 1e-10, atol 1e-12, timed as the
whole ``simulate`` call and reading the impact times, as event objects (``[e.t for e
in result.jumps]``) and as a column (``result.jumps.t``). Job 2, an
ensemble: 1,000 balls with h0 ~ U[1, 10] m and e ~ U[0.5, 0.95], 10 s, DOP853 at
rtol 1e-8, atol 1e-10; most of them are Zeno before 10 s and are stopped by
hybridlab's Zeno rule, which the numba and diffrax loops copy.

Run ``python benchmarks/ball_peers.py [--quick] [--repeat N] [--json FILE]``.
"""

from __future__ import annotations

import math
import os
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numba
import numpy as np
from bouncing_ball import Ball, exact_impacts, scipy_restart_loop
from common import ROOT, Report, Timing, run_main, time_calls
from scipy.integrate._ivp import dop853_coefficients as _dop

import hybridlab
from hybridlab.simulation import rules

__all__ = ["BallRun", "DiffraxPeer", "Ensemble", "diffrax_peer", "numba_ball", "numba_ensemble",
           "reference_counts", "run", "zeno_stop"]

MODEL = ROOT / "models" / "bouncing_ball.toml"
SCENARIO = "benchmark"
METHOD = "DOP853"
#: job 1: (rtol, atol)
SINGLE_TOL = (1e-10, 1e-12)
#: job 2: (rtol, atol), hybridlab's default
ENSEMBLE_TOL = (1e-8, 1e-10)
ENSEMBLE_SIZE = 1000
ENSEMBLE_T_END = 10.0
ENSEMBLE_SEED = 0
#: threads of the parallel numba loop (the machine this was written on has 2 cores)
THREADS = 2
#: calls of one implementation in a row per round in job 1 (the first is the switched one)
BLOCK = 5
#: impacts a numba run may record before it stops with ``FULL``
CAPACITY = 4096

# hybridlab's defaults, read so that the copies below follow a change of them
_OPTIONS = hybridlab.SimulationOptions()
#: Zeno window, tolerance and time resolution of hybridlab (``docs/semantics.md``, "Zeno
#: behaviour"; ``hybridlab/simulation/zeno.py``): window 6, tol 1e-6, 4 * event_tol
ZENO_WINDOW = int(_OPTIONS.zeno_window)
ZENO_TOL = float(_OPTIONS.zeno_tol)
ZENO_RESOLUTION = float(rules.ZENO_RESOLUTION * _OPTIONS.event_tol)

#: status codes of the numba and diffrax loops: reached t_end, stopped by the Zeno rule,
#: impact buffer full, a flight too short to bracket (the ball would fall through), the
#: stepper failed
COMPLETED, ZENO, FULL, FELL, FAILED = 0, 1, 2, 3, 4
STATUS_NAMES = ("COMPLETED", "ZENO", "FULL", "FELL", "FAILED")

# ----- scipy's DOP853, in numba -------------------------------------------------------------
_EPS = float(np.finfo(float).eps)
_N_STAGES = _dop.N_STAGES  # 12; K[12] is the flow at the new state
_A = np.ascontiguousarray(_dop.A, dtype=np.float64)  # 16 x 16: 12 stages, then 3 for output
_B = np.ascontiguousarray(_dop.B, dtype=np.float64)
_C = np.ascontiguousarray(_dop.C, dtype=np.float64)
_E3 = np.ascontiguousarray(_dop.E3, dtype=np.float64)
_E5 = np.ascontiguousarray(_dop.E5, dtype=np.float64)
_D = np.ascontiguousarray(_dop.D, dtype=np.float64)
_N_EXT = _dop.N_STAGES_EXTENDED  # 16
_N_F = _dop.INTERPOLATOR_POWER  # 7
_SAFETY, _MIN_FACTOR, _MAX_FACTOR = 0.9, 0.2, 10.0
_ERROR_EXPONENT = -1.0 / (7 + 1)  # DOP853's error estimator is of order 7
#: ``solve_ivp`` locates events with ``brentq(xtol=4 * EPS, rtol=4 * EPS)``
_XTOL = _RTOL_ROOT = 4.0 * _EPS


@numba.njit(inline="always")
def _flow(h: float, v: float, g: float) -> tuple[float, float]:
    """The ball's flow: ``h' = v``, ``v' = -g``."""
    return v, -g


@numba.njit
def _initial_step(y: np.ndarray, f: np.ndarray, interval: float, g: float, rtol: float,
                  atol: float) -> float:
    """scipy's ``select_initial_step`` (Hairer's algorithm) for DOP853, forward in time."""
    d0 = d1 = 0.0
    for i in range(2):
        scale = atol + abs(y[i]) * rtol
        d0 += (y[i] / scale) ** 2
        d1 += (f[i] / scale) ** 2
    d0, d1 = math.sqrt(d0 / 2), math.sqrt(d1 / 2)
    h0 = min(1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1, interval)
    f1h, f1v = _flow(y[0] + h0 * f[0], y[1] + h0 * f[1], g)
    d2 = math.sqrt((((f1h - f[0]) / (atol + abs(y[0]) * rtol)) ** 2
                    + ((f1v - f[1]) / (atol + abs(y[1]) * rtol)) ** 2) / 2) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / 8)
    return min(100 * h0, h1, interval)


@numba.njit
def _rk_step(y: np.ndarray, f: np.ndarray, h: float, g: float, K: np.ndarray,
             y_new: np.ndarray) -> None:
    """scipy's ``rk_step`` for DOP853: stages into ``K[:13]``, the solution into ``y_new``."""
    K[0, 0], K[0, 1] = f[0], f[1]
    for s in range(1, _N_STAGES):
        dh = dv = 0.0
        for j in range(s):
            dh += K[j, 0] * _A[s, j]
            dv += K[j, 1] * _A[s, j]
        K[s, 0], K[s, 1] = _flow(y[0] + dh * h, y[1] + dv * h, g)
    dh = dv = 0.0
    for j in range(_N_STAGES):
        dh += K[j, 0] * _B[j]
        dv += K[j, 1] * _B[j]
    y_new[0], y_new[1] = y[0] + h * dh, y[1] + h * dv
    K[_N_STAGES, 0], K[_N_STAGES, 1] = _flow(y_new[0], y_new[1], g)


@numba.njit
def _error_norm(K: np.ndarray, h: float, y: np.ndarray, y_new: np.ndarray, rtol: float,
                atol: float) -> float:
    """scipy's ``DOP853._estimate_error_norm``: the 5th- and 3rd-order estimates combined."""
    e5 = e3 = 0.0
    for i in range(2):
        scale = atol + max(abs(y[i]), abs(y_new[i])) * rtol
        s5 = s3 = 0.0
        for j in range(_N_STAGES + 1):
            s5 += K[j, i] * _E5[j]
            s3 += K[j, i] * _E3[j]
        e5 += (s5 / scale) ** 2
        e3 += (s3 / scale) ** 2
    if e5 == 0.0 and e3 == 0.0:
        return 0.0
    return abs(h) * e5 / math.sqrt((e5 + 0.01 * e3) * 2)


@numba.njit
def _dense(y_old: np.ndarray, y_new: np.ndarray, h: float, g: float, K: np.ndarray,
           F: np.ndarray) -> None:
    """scipy's ``DOP853._dense_output_impl``: three more stages, then the 7 rows of ``F``."""
    for s in range(_N_STAGES + 1, _N_EXT):
        dh = dv = 0.0
        for j in range(s):
            dh += K[j, 0] * _A[s, j]
            dv += K[j, 1] * _A[s, j]
        K[s, 0], K[s, 1] = _flow(y_old[0] + dh * h, y_old[1] + dv * h, g)
    for i in range(2):
        delta = y_new[i] - y_old[i]
        F[0, i] = delta
        F[1, i] = h * K[0, i] - delta
        F[2, i] = 2 * delta - h * (K[_N_STAGES, i] + K[0, i])
        for r in range(_N_F - 3):
            acc = 0.0
            for j in range(_N_EXT):
                acc += _D[r, j] * K[j, i]
            F[3 + r, i] = h * acc


@numba.njit
def _interpolate(F: np.ndarray, y_old: np.ndarray, t_old: float, h: float, t: float,
                 i: int) -> float:
    """Component ``i`` of ``Dop853DenseOutput`` at ``t``."""
    x = (t - t_old) / h
    y = 0.0
    for k in range(_N_F):
        y += F[_N_F - 1 - k, i]
        if k % 2 == 0:
            y *= x
        else:
            y *= 1 - x
    return y + y_old[i]


@numba.njit
def _brentq(F: np.ndarray, y_old: np.ndarray, t_old: float, h: float, i: int, xa: float,
            xb: float) -> float:
    """A root of component ``i`` of the interpolant in ``[xa, xb]``: scipy's ``brentq``
    (``scipy/optimize/Zeros/brentq.c``) with ``xtol = rtol = 4 * EPS``, as ``solve_ivp``."""
    xpre, xcur = xa, xb
    xblk = fblk = spre = scur = 0.0
    fpre = _interpolate(F, y_old, t_old, h, xpre, i)
    fcur = _interpolate(F, y_old, t_old, h, xcur, i)
    if fpre == 0.0:
        return xpre
    if fcur == 0.0:
        return xcur
    for _ in range(100):
        if fpre != 0.0 and fcur != 0.0 and (fpre < 0.0) != (fcur < 0.0):
            xblk, fblk = xpre, fpre
            spre = scur = xcur - xpre
        if abs(fblk) < abs(fcur):
            xpre, xcur, xblk = xcur, xblk, xcur
            fpre, fcur, fblk = fcur, fblk, fcur
        delta = (_XTOL + _RTOL_ROOT * abs(xcur)) / 2
        sbis = (xblk - xcur) / 2
        if fcur == 0.0 or abs(sbis) < delta:
            return xcur
        if abs(spre) > delta and abs(fcur) < abs(fpre):
            if xpre == xblk:  # interpolate
                stry = -fcur * (xcur - xpre) / (fcur - fpre)
            else:  # extrapolate
                dpre = (fpre - fcur) / (xpre - xcur)
                dblk = (fblk - fcur) / (xblk - xcur)
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
            if 2 * abs(stry) < min(abs(spre), 3 * abs(sbis) - delta):  # good short step
                spre, scur = scur, stry
            else:
                spre = scur = sbis
        else:
            spre = scur = sbis
        xpre, fpre = xcur, fcur
        if abs(scur) > delta:
            xcur += scur
        else:
            xcur += delta if sbis > 0 else -delta
        fcur = _interpolate(F, y_old, t_old, h, xcur, i)
    return xcur


@numba.njit
def zeno_stop(times: np.ndarray, n: int, window: int, tol: float, resolution: float) -> bool:
    """hybridlab's Zeno rule (``ZenoTracker.record``) after the ``n``-th impact.

    ``times[:n]`` are the impact times. Zeno when the last ``window`` dwell times
    all shrink, their ratios agree within a factor 1.5, and the accumulation time
    extrapolated from the mean of the last three ratios is within ``tol * max(1, t)``,
    or the last dwell is below ``resolution * max(1, t)``.
    """
    if n < window + 1:
        return False
    base = n - window - 1
    d_prev = times[base + 1] - times[base]
    if d_prev <= 0.0:
        return False
    r_min, r_max, r_last3 = np.inf, -np.inf, 0.0
    d = d_prev
    for k in range(1, window):
        d = times[base + k + 1] - times[base + k]
        if d <= 0.0:
            return False
        r = d / d_prev
        r_min, r_max = min(r_min, r), max(r_max, r)
        if k >= window - 3:
            r_last3 += r
        d_prev = d
    if not (r_max < 1.0 and r_max <= 1.5 * r_min):
        return False
    r = r_last3 / 3
    scale = max(1.0, abs(times[n - 1]))
    return d * r / (1.0 - r) <= tol * scale or d <= resolution * scale


@numba.njit
def _ball(h0: float, v0: float, g: float, e: float, t_end: float, rtol: float, atol: float,
          zeno_tol: float, zeno_resolution: float,
          impacts: np.ndarray) -> tuple[int, float, float, float, int, int]:
    """One ball, integrate-locate-restart; the impacts go into ``impacts``.

    Returns ``(bounces, t, h, v, steps, status)``. Each flight is a fresh
    ``solve_ivp``-like solve: scipy's initial step, then scipy's step control.
    A step that ends with ``h <= 0`` while falling holds an impact: Brent's
    method on the dense output's ``h`` locates it. A flight's first step starts
    on the floor (``h = 0``) and may overfly a whole flight when flights are
    short (Zeno), so there the bracket starts at the apex (``v = 0``, located the
    same way) instead of at the floor.
    """
    K = np.empty((_N_EXT, 2))
    F = np.empty((_N_F, 2))
    y, f, y_new = np.empty(2), np.empty(2), np.empty(2)
    t, y[0], y[1] = 0.0, h0, v0
    n = steps = 0
    while t < t_end:
        # a new solve from (t, y)
        f[0], f[1] = _flow(y[0], y[1], g)
        h_abs = _initial_step(y, f, t_end - t, g, rtol, atol)
        while t < t_end:
            min_step = 10 * abs(np.nextafter(t, np.inf) - t)
            if h_abs < min_step:
                h_abs = min_step
            rejected = False
            while True:
                t_new = t + h_abs
                if t_new > t_end:
                    t_new = t_end
                h = t_new - t
                _rk_step(y, f, h, g, K, y_new)
                err = _error_norm(K, h, y, y_new, rtol, atol)
                if err < 1:
                    factor = _MAX_FACTOR if err == 0 else min(
                        _MAX_FACTOR, _SAFETY * err**_ERROR_EXPONENT)
                    if rejected:
                        factor = min(1.0, factor)
                    h_abs *= factor
                    break
                h_abs *= max(_MIN_FACTOR, _SAFETY * err**_ERROR_EXPONENT)
                rejected = True
                if h_abs < min_step:  # scipy's "step size too small"
                    return n, t, y[0], y[1], steps, FAILED
            steps += 1
            if y_new[0] <= 0.0 and y_new[1] < 0.0:  # an impact in this step
                _dense(y, y_new, h, g, K, F)
                t_old = lo = t
                if y[0] <= 0.0:  # the step starts on the floor: bracket from the apex
                    if y[1] <= 0.0:  # no flight at all (e = 0)
                        return n, t, y[0], y[1], steps, FELL
                    lo = _brentq(F, y, t_old, h, 1, t_old, t_new)
                    if _interpolate(F, y, t_old, h, lo, 0) <= 0.0:
                        return n, t, y[0], y[1], steps, FELL
                t = _brentq(F, y, t_old, h, 0, lo, t_new)
                v = _interpolate(F, y, t_old, h, t, 1)
                impacts[n] = t
                n += 1
                y[0], y[1] = 0.0, -e * v
                if zeno_stop(impacts, n, ZENO_WINDOW, zeno_tol, zeno_resolution):
                    return n, t, y[0], y[1], steps, ZENO
                if n == impacts.size:
                    return n, t, y[0], y[1], steps, FULL
                break
            t = t_new
            y[0], y[1] = y_new[0], y_new[1]
            f[0], f[1] = K[_N_STAGES, 0], K[_N_STAGES, 1]
    return n, t, y[0], y[1], steps, COMPLETED


@numba.njit(parallel=True)
def _ensemble_parallel(h0: np.ndarray, e: np.ndarray, g: float, t_end: float, rtol: float,
                       atol: float, zeno_tol: float, zeno_resolution: float,
                       out: np.ndarray) -> None:
    for k in numba.prange(h0.size):
        impacts = np.empty(CAPACITY)
        n, t, _, _, steps, status = _ball(h0[k], 0.0, g, e[k], t_end, rtol, atol, zeno_tol,
                                          zeno_resolution, impacts)
        out[k, 0], out[k, 1], out[k, 2], out[k, 3] = n, t, steps, status


@numba.njit
def _ensemble_serial(h0: np.ndarray, e: np.ndarray, g: float, t_end: float, rtol: float,
                     atol: float, zeno_tol: float, zeno_resolution: float,
                     out: np.ndarray) -> None:
    impacts = np.empty(CAPACITY)
    for k in range(h0.size):
        n, t, _, _, steps, status = _ball(h0[k], 0.0, g, e[k], t_end, rtol, atol, zeno_tol,
                                          zeno_resolution, impacts)
        out[k, 0], out[k, 1], out[k, 2], out[k, 3] = n, t, steps, status


@dataclass(frozen=True)
class BallRun:
    """One ball's run by any implementation: impacts, end state, steps, how it ended."""

    impacts: np.ndarray
    t: float
    h: float
    v: float
    steps: int
    status: str


@dataclass(frozen=True)
class Ensemble:
    """Per-run results of an ensemble: bounce counts, end times, statuses (names)."""

    bounces: np.ndarray
    t_final: np.ndarray
    status: np.ndarray


def numba_ball(ball: Ball, rtol: float, atol: float) -> BallRun:
    """One ball with the numba restart loop (compiled on the first call).

    Examples
    --------
    >>> ball = Ball(g=9.81, e=0.5, h0=1.0, v0=0.0, t_end=1.0)
    >>> run = numba_ball(ball, 1e-10, 1e-12)
    >>> run.status, run.impacts.size, bool(abs(run.impacts[0] - (2 / 9.81) ** 0.5) < 1e-12)
    ('COMPLETED', 2, True)
    """
    impacts = np.empty(CAPACITY)
    n, t, h, v, steps, status = _ball(ball.h0, ball.v0, ball.g, ball.e, ball.t_end, rtol, atol,
                                      ZENO_TOL, ZENO_RESOLUTION, impacts)
    return BallRun(impacts[:n].copy(), t, h, v, steps, STATUS_NAMES[status])


def numba_ensemble(h0: np.ndarray, e: np.ndarray, g: float, t_end: float, rtol: float,
                   atol: float, parallel: bool = True) -> Ensemble:
    """Many balls dropped from rest, with ``numba.prange`` over them or serially.

    The parallel loop runs on :data:`THREADS` threads (set by the caller with
    ``numba.set_num_threads``).
    """
    out = np.empty((h0.size, 4))
    kernel = _ensemble_parallel if parallel else _ensemble_serial
    kernel(np.ascontiguousarray(h0, dtype=float), np.ascontiguousarray(e, dtype=float), g,
           t_end, rtol, atol, ZENO_TOL, ZENO_RESOLUTION, out)
    return Ensemble(out[:, 0].astype(np.int64), out[:, 1].copy(),
                    np.array(STATUS_NAMES)[out[:, 3].astype(np.int64)])


@numba.njit
def _reference_counts(h0: np.ndarray, e: np.ndarray, g: float, t_end: float, zeno_tol: float,
                      zeno_resolution: float, counts: np.ndarray, zeno: np.ndarray) -> None:
    times = np.empty(CAPACITY)
    for k in range(h0.size):
        t1 = math.sqrt(2.0 * h0[k] / g)
        n, t, flight, zeno[k] = 0, t1, 2.0 * t1 * e[k], False
        while t <= t_end and n < CAPACITY:
            times[n] = t
            n += 1
            if zeno_stop(times, n, ZENO_WINDOW, zeno_tol, zeno_resolution):
                zeno[k] = True
                break
            t += flight
            flight *= e[k]
        counts[k] = n


def reference_counts(h0: np.ndarray, e: np.ndarray, g: float,
                     t_end: float) -> tuple[np.ndarray, np.ndarray]:
    """Bounce counts of the closed form, stopped by hybridlab's Zeno rule.

    The exact impact times (``t_1 = sqrt(2 h0 / g)``, flights ``2 t_1 e^k``) up to
    ``t_end``, cut after the impact at which :func:`zeno_stop` fires. Returns the
    counts and whether each run is Zeno.

    Examples
    --------
    >>> counts, zeno = reference_counts(np.array([10.0, 1.0]), np.array([0.95, 0.5]), 9.81, 10.0)
    >>> counts.tolist(), zeno.tolist()
    ([4, 21], [False, True])
    """
    counts = np.empty(h0.size, dtype=np.int64)
    zeno = np.empty(h0.size, dtype=np.bool_)
    _reference_counts(np.ascontiguousarray(h0, dtype=float), np.ascontiguousarray(e, dtype=float),
                      g, t_end, ZENO_TOL, ZENO_RESOLUTION, counts, zeno)
    return counts, zeno


# ----- diffrax (optional) ---------------------------------------------------------------------
#: most steps diffrax may take in one flight
DIFFRAX_MAX_STEPS = 4096


@dataclass(frozen=True)
class DiffraxPeer:
    """The diffrax implementations of one job, each jitted (compiled on its first call).

    Attributes
    ----------
    flight : callable
        ``(t, y, e) -> (t_new, y_next, hit, ok, steps)``: one ``diffeqsolve`` from
        ``(t, y)`` to ``t_end`` that stops at the impact; ``y_next`` is the state
        after the reset.
    ball : callable
        ``(h0, e) -> (t, y, bounces, impacts, status, steps)``: a whole run, the
        restart loop a ``lax.while_loop`` inside the jitted function.
    ensemble : callable
        ``ball`` vmapped over arrays of ``h0`` and ``e``.
    capacity : int
        Impacts ``ball`` records (later ones are counted, not stored).
    """

    flight: Callable[..., Any]
    ball: Callable[..., Any]
    ensemble: Callable[..., Any]
    capacity: int


def diffrax_peer(g: float, t_end: float, rtol: float, atol: float,
                 capacity: int = 64) -> DiffraxPeer | None:
    """The ball in diffrax (Dopri8, PID controller, an ``Event`` located by Newton's
    method), or ``None`` when jax, diffrax or optimistix is missing.

    The event is ``h`` while falling and 1 while rising, with ``direction=False``
    (a down-crossing): a flight starts on the floor with ``v > 0``, so the event
    starts at 1 and only the impact crosses zero, even when one step overflies
    the whole flight. Enables jax's 64-bit mode.
    """
    try:
        import diffrax
        import jax
        import optimistix as optx
    except ImportError:
        return None
    jax.config.update("jax_enable_x64", True)
    jnp, lax = jax.numpy, jax.lax

    term = diffrax.ODETerm(lambda t, y, args: jnp.stack([y[1], jnp.full_like(y[1], -g)]))
    solver = diffrax.Dopri8()
    controller = diffrax.PIDController(rtol=rtol, atol=atol)
    # Newton stops when the time moves less than 1e-12 + 1e-14 t and |h| < 1e-12 m
    event = diffrax.Event(lambda t, y, args, **kwargs: jnp.where(y[1] < 0, y[0], 1.0),
                          optx.Newton(rtol=1e-14, atol=1e-12), direction=False)
    saveat = diffrax.SaveAt(t1=True)

    def flight(t: Any, y: Any, e: Any) -> tuple[Any, ...]:
        sol = diffrax.diffeqsolve(term, solver, t, t_end, None, y, stepsize_controller=controller,
                                  event=event, saveat=saveat, max_steps=DIFFRAX_MAX_STEPS)
        t_new, y_new = sol.ts[-1], sol.ys[-1]
        hit = sol.result == diffrax.RESULTS.event_occurred
        ok = hit | (sol.result == diffrax.RESULTS.successful)
        y_next = jnp.where(hit, jnp.stack([jnp.zeros_like(y_new[1]), -e * y_new[1]]), y_new)
        return t_new, y_next, hit, ok, sol.stats["num_accepted_steps"]

    def zeno(last: Any, n: Any) -> Any:
        # zeno_stop on the last ZENO_WINDOW + 1 impact times
        d = jnp.diff(last)
        r = d[1:] / d[:-1]
        shrinking = (n >= ZENO_WINDOW + 1) & jnp.all(d > 0) & jnp.all(r < 1.0)
        steady = r.max() <= 1.5 * r.min()
        r3 = jnp.mean(r[-3:])
        scale = jnp.maximum(1.0, jnp.abs(last[-1]))
        near = (d[-1] * r3 / (1.0 - r3) <= ZENO_TOL * scale) | (d[-1] <= ZENO_RESOLUTION * scale)
        return shrinking & steady & near

    def ball(h0: Any, e: Any) -> tuple[Any, ...]:
        def body(c: tuple[Any, ...]) -> tuple[Any, ...]:
            t, y, n, impacts, last, status, steps = c
            t_new, y_next, hit, ok, k = flight(t, y, e)
            impacts = jnp.where(hit, impacts.at[n].set(t_new, mode="drop"), impacts)
            last = jnp.where(hit, jnp.roll(last, -1).at[-1].set(t_new), last)
            n = n + hit.astype(n.dtype)
            status = jnp.where(ok, jnp.where(hit & zeno(last, n), ZENO, COMPLETED), FAILED)
            return t_new, y_next, n, impacts, last, status, steps + k

        def going(c: tuple[Any, ...]) -> Any:
            return (c[0] < t_end) & (c[5] == COMPLETED)

        y0 = jnp.stack([h0, jnp.zeros_like(h0)])
        init = (jnp.zeros_like(h0), y0, jnp.int64(0), jnp.zeros(capacity),
                jnp.zeros(ZENO_WINDOW + 1), jnp.int64(COMPLETED), jnp.int64(0))
        t, y, n, impacts, _, status, steps = lax.while_loop(going, body, init)
        return t, y, n, impacts, status, steps

    return DiffraxPeer(jax.jit(flight), jax.jit(ball), jax.jit(jax.vmap(ball)), capacity)


def diffrax_loop(peer: DiffraxPeer, ball: Ball) -> BallRun:
    """One ball with a Python restart loop around ``peer.flight`` (one jitted solve
    per flight, as a user writes it)."""
    import jax.numpy as jnp

    t, y, e = jnp.asarray(0.0), jnp.asarray([ball.h0, ball.v0]), jnp.asarray(ball.e)
    impacts: list[Any] = []
    steps = 0
    while len(impacts) < CAPACITY:
        t, y, hit, ok, k = peer.flight(t, y, e)
        steps += int(k)
        if not bool(hit):
            if not bool(ok):
                return BallRun(np.asarray(impacts), float(t), float(y[0]), float(y[1]), steps,
                               "FAILED")
            break
        impacts.append(t)
    return BallRun(np.asarray(impacts, dtype=float), float(t), float(y[0]), float(y[1]), steps,
                   "COMPLETED" if len(impacts) < CAPACITY else "FULL")


def diffrax_ball(peer: DiffraxPeer, ball: Ball) -> BallRun:
    """One ball with the restart loop inside the jitted function."""
    t, y, n, impacts, status, steps = peer.ball(ball.h0, ball.e)
    n = int(n)
    stored = np.asarray(impacts)[:min(n, peer.capacity)]
    return BallRun(stored, float(t), float(y[0]), float(y[1]), int(steps),
                   STATUS_NAMES[int(status)] if n <= peer.capacity else "FULL")


def diffrax_ensemble(peer: DiffraxPeer, h0: np.ndarray, e: np.ndarray) -> Ensemble:
    """All balls in one vmapped call of ``peer.ball``."""
    t, _, n, _, status, _ = peer.ensemble(h0, e)
    return Ensemble(np.asarray(n, dtype=np.int64), np.asarray(t),
                    np.array(STATUS_NAMES)[np.asarray(status, dtype=np.int64)])


# ----- hybridlab ------------------------------------------------------------------------------
def hybridlab_single(compiled: hybridlab.CompiledModel) -> tuple[Any, np.ndarray]:
    """Job 1 as timed: the whole ``simulate`` call and reading the impact times."""
    r = hybridlab.simulate(compiled, scenario=SCENARIO, method=METHOD, rtol=SINGLE_TOL[0],
                           atol=SINGLE_TOL[1])
    return r, np.array([ev.t for ev in r.jumps])


def hybridlab_single_columns(compiled: hybridlab.CompiledModel) -> tuple[Any, np.ndarray]:
    """Job 1 with the impact times read as a column (``result.jumps.t``), no event objects."""
    r = hybridlab.simulate(compiled, scenario=SCENARIO, method=METHOD, rtol=SINGLE_TOL[0],
                           atol=SINGLE_TOL[1])
    return r, r.jumps.t


def hybridlab_sweep(compiled: hybridlab.CompiledModel, samples: np.ndarray,
                    executor: str | None) -> Ensemble:
    """Job 2 as timed: one ``sweep`` over the samples and reading its table."""
    table = hybridlab.sweep(compiled, samples=(("h", "e"), samples), t_end=ENSEMBLE_T_END,
                            events=["bounce"], method=METHOD, rtol=ENSEMBLE_TOL[0],
                            atol=ENSEMBLE_TOL[1], progress=False, executor=executor)
    return Ensemble(table["count:bounce"], table["t_final"], table["status"])


def _as_run(value: tuple[Any, np.ndarray]) -> BallRun:
    result, impacts = value
    return BallRun(impacts, result.final.t, result.final.state["h"], result.final.state["v"],
                   int(result.stats.get("steps", -1)), result.status.name)


def _scipy_run(ball: Ball) -> BallRun:
    tr = scipy_restart_loop(ball, METHOD, *SINGLE_TOL)
    return BallRun(tr.impacts, tr.t, tr.h, tr.v, tr.steps, "COMPLETED")


# ----- the report -----------------------------------------------------------------------------
def _ms(seconds: float) -> str:
    return f"{1e3 * seconds:.3g}" if seconds < 0.1 else f"{1e3 * seconds:.0f}"


def _sci(x: float) -> str:
    return "n/a" if math.isnan(x) else f"{x:.1e}"


def _first_call(fn: Callable[[], Any]) -> float:
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def _impact_error(impacts: np.ndarray, reference: np.ndarray) -> float:
    n = min(impacts.size, reference.size)
    return float(np.abs(impacts[:n] - reference[:n]).max()) if n else math.nan


def _agreement(counts: np.ndarray, reference: np.ndarray) -> dict[str, Any]:
    d = np.abs(np.asarray(counts, dtype=np.int64) - reference)
    return {"max_abs_count_difference": int(d.max()), "fraction_equal": float(np.mean(d == 0))}


@dataclass
class _Rows:
    """Rows of the two timing tables and their JSON records, filled phase by phase."""

    single: list[Sequence[str]]
    ensemble: list[Sequence[str]]
    records: list[dict[str, Any]]


def _single_rows(rows: _Rows, timings: Sequence[tuple[str, Timing, BallRun]], hl: Timing,
                 exact: np.ndarray, hl_impacts: np.ndarray, phase: int) -> None:
    for name, timing, r in timings:
        ratio = hl.median / timing.median
        err, vs_hl = _impact_error(r.impacts, exact), _impact_error(r.impacts, hl_impacts)
        rows.single.append([name, str(phase), _ms(timing.median), _ms(timing.switched_median),
                            f"{ratio:.3g}", str(r.impacts.size), _sci(err), _sci(vs_hl),
                            str(r.steps), r.status])
        rows.records.append({"job": "single", "implementation": name, "phase": phase,
                             **timing.as_dict(), "hybridlab_over_this": ratio,
                             "bounces": int(r.impacts.size), "max_impact_error": err,
                             "max_impact_difference_to_hybridlab": vs_hl, "steps": r.steps,
                             "status": r.status, "final": [r.t, r.h, r.v]})


def _ensemble_rows(rows: _Rows, timings: Sequence[tuple[str, Timing, Ensemble]],
                   pool_over_serial: float, hl_serial: Timing, hl_counts: np.ndarray,
                   ref_counts: np.ndarray, phase: int) -> None:
    """Rows of job 2; ``pool_over_serial`` is the ratio of hybridlab's pool and serial
    sweeps in phase 2 (the pool ratio of a phase-3 row is chained through it)."""
    for name, timing, ens in timings:
        vs_hl, vs_ref = _agreement(ens.bounces, hl_counts), _agreement(ens.bounces, ref_counts)
        serial = hl_serial.median / timing.median
        pool = pool_over_serial * serial
        rows.ensemble.append([
            name, str(phase), _ms(timing.median), f"{'~' if phase == 3 else ''}{pool:.3g}",
            f"{serial:.3g}", str(int(np.sum(ens.status == "ZENO"))),
            str(vs_hl["max_abs_count_difference"]), f"{vs_hl['fraction_equal']:.3f}",
            str(vs_ref["max_abs_count_difference"]), f"{vs_ref['fraction_equal']:.3f}"])
        rows.records.append({"job": "ensemble", "implementation": name, "phase": phase,
                             **timing.as_dict(), "hybridlab_pool_over_this": pool,
                             "pool_ratio_chained_through_serial": phase == 3,
                             "hybridlab_serial_over_this": serial,
                             "zeno_runs": int(np.sum(ens.status == "ZENO")),
                             "statuses": {str(k): int(v) for k, v in
                                          zip(*np.unique(ens.status, return_counts=True),
                                              strict=True)},
                             "bounces_vs_hybridlab": vs_hl, "bounces_vs_reference": vs_ref})


def run(repeat: int) -> Report:
    """Time hybridlab against the numba loop, the scipy loop and diffrax, in three phases.

    Phase 1 times job 1 (hybridlab, numba, scipy), phase 2 job 2 (hybridlab's
    process pool and serial sweeps, numba parallel and serial), phase 3 diffrax
    against hybridlab again (serial only). jax is imported only in phase 3:
    hybridlab's process pool forks, and a fork after JAX has started its threads
    can deadlock.
    """
    load = os.getloadavg()
    model = hybridlab.load_model(MODEL)
    compiled = hybridlab.compile_model(model)
    ball = Ball.from_model(model, SCENARIO)
    exact = exact_impacts(ball)
    rng = np.random.default_rng(ENSEMBLE_SEED)
    samples = np.column_stack([rng.uniform(1.0, 10.0, ENSEMBLE_SIZE),
                               rng.uniform(0.5, 0.95, ENSEMBLE_SIZE)])
    h0, e = samples[:, 0], samples[:, 1]
    g = ball.g
    ref_counts, ref_zeno = reference_counts(h0, e, g, ENSEMBLE_T_END)
    if numba.config.NUMBA_NUM_THREADS >= THREADS:
        numba.set_num_threads(THREADS)
    one_off: dict[str, float] = {}

    # phase 1: one ball
    one_off["hybridlab first simulate"] = _first_call(lambda: hybridlab_single(compiled))
    one_off["numba compile (one ball)"] = _first_call(lambda: numba_ball(ball, *SINGLE_TOL))
    (hl_t, hl_v), (hc_t, hc_v), (nb_t, nb), (sp_t, sp) = time_calls(
        [lambda: hybridlab_single(compiled), lambda: hybridlab_single_columns(compiled),
         lambda: numba_ball(ball, *SINGLE_TOL), lambda: _scipy_run(ball)],
        repeat=repeat, block=BLOCK)
    hl = _as_run(hl_v)
    if nb.impacts.size != exact.size or _impact_error(nb.impacts, exact) > 1e-9:
        raise RuntimeError(f"the numba loop is wrong: {nb.impacts.size} bounces (exact "
                           f"{exact.size}), impact error {_impact_error(nb.impacts, exact):.1e}")
    rows = _Rows([], [], [])
    _single_rows(rows, [("hybridlab", hl_t, hl),
                        ("hybridlab, impacts as a column", hc_t, _as_run(hc_v)),
                        ("numba loop", nb_t, nb), ("scipy solve_ivp loop", sp_t, sp)],
                 hl_t, exact, hl.impacts, 1)

    # phase 2: the ensemble without jax
    one_off["hybridlab first sweep (starts the pool)"] = _first_call(
        lambda: hybridlab_sweep(compiled, samples, None))
    one_off["numba compile (parallel ensemble)"] = _first_call(
        lambda: numba_ensemble(h0, e, g, ENSEMBLE_T_END, *ENSEMBLE_TOL, parallel=True))
    one_off["numba compile (serial ensemble)"] = _first_call(
        lambda: numba_ensemble(h0, e, g, ENSEMBLE_T_END, *ENSEMBLE_TOL, parallel=False))
    (pool_t, pool), (ser_t, ser), (par_t, par), (nbs_t, nbs) = time_calls(
        [lambda: hybridlab_sweep(compiled, samples, None),
         lambda: hybridlab_sweep(compiled, samples, "serial"),
         lambda: numba_ensemble(h0, e, g, ENSEMBLE_T_END, *ENSEMBLE_TOL, parallel=True),
         lambda: numba_ensemble(h0, e, g, ENSEMBLE_T_END, *ENSEMBLE_TOL, parallel=False)],
        repeat=repeat, warmup=0)
    _ensemble_rows(rows, [("hybridlab sweep, process pool", pool_t, pool),
                          ("hybridlab sweep, serial", ser_t, ser),
                          (f"numba prange, {numba.get_num_threads()} threads", par_t, par),
                          ("numba serial", nbs_t, nbs)],
                   pool_t.median / ser_t.median, ser_t, ser.bounces, ref_counts, 2)

    # phase 3: diffrax
    notes: list[str] = []
    peer_single = diffrax_peer(g, ball.t_end, *SINGLE_TOL)
    if peer_single is None:
        print("diffrax: not installed")
        notes.append("diffrax: not installed (pip install jax diffrax), so no diffrax rows.")
    else:
        peer_ens = diffrax_peer(g, ENSEMBLE_T_END, *ENSEMBLE_TOL, capacity=1)
        if peer_ens is None:  # cannot happen: the same imports just succeeded
            raise RuntimeError("diffrax imported once but not twice")
        one_off["diffrax compile (flight)"] = _first_call(lambda: diffrax_loop(peer_single, ball))
        one_off["diffrax compile (ball, loop in jit)"] = _first_call(
            lambda: diffrax_ball(peer_single, ball))
        one_off["diffrax compile (vmapped ensemble)"] = _first_call(
            lambda: diffrax_ensemble(peer_ens, h0, e))
        (hl3_t, hl3_v), (dl_t, dl), (dj_t, dj) = time_calls(
            [lambda: hybridlab_single(compiled), lambda: diffrax_loop(peer_single, ball),
             lambda: diffrax_ball(peer_single, ball)], repeat=repeat, block=BLOCK)
        hl3 = _as_run(hl3_v)
        _single_rows(rows, [("hybridlab", hl3_t, hl3), ("diffrax, Python restart loop", dl_t, dl),
                            ("diffrax, restart in jit", dj_t, dj)], hl3_t, exact, hl3.impacts, 3)
        (ser3_t, ser3), (par3_t, par3), (dv_t, dv) = time_calls(
            [lambda: hybridlab_sweep(compiled, samples, "serial"),
             lambda: numba_ensemble(h0, e, g, ENSEMBLE_T_END, *ENSEMBLE_TOL, parallel=True),
             lambda: diffrax_ensemble(peer_ens, h0, e)], repeat=repeat, warmup=0)
        _ensemble_rows(rows, [("hybridlab sweep, serial", ser3_t, ser3),
                              (f"numba prange, {numba.get_num_threads()} threads", par3_t, par3),
                              ("diffrax vmap, restart in jit", dv_t, dv)],
                       pool_t.median / ser_t.median, ser3_t, ser3.bounces, ref_counts, 3)

    report = Report("ball_peers", "hybridlab vs a numba DOP853 loop, solve_ivp and diffrax, "
                    f"one ball ({exact.size} bounces) and {ENSEMBLE_SIZE} balls")
    report.tables.append((
        f"Job 1: one ball, scenario '{SCENARIO}' (h0 = {ball.h0:g}, e = {ball.e}, "
        f"T = {ball.t_end:g}), {METHOD} rtol = {SINGLE_TOL[0]:g}, atol = {SINGLE_TOL[1]:g}; "
        f"median of {repeat} rounds of {BLOCK - 1} warm calls, 'switched' = first call of "
        "a block; ratio = hybridlab / this, hybridlab timed in the same phase",
        ["implementation", "phase", "warm [ms]", "switched [ms]", "ratio", "bounces",
         "max|dt_k| exact", "max|dt_k| vs hl", "steps", "status"],
        rows.single))
    report.tables.append((
        f"Job 2: {ENSEMBLE_SIZE} balls, h0 ~ U[1, 10], e ~ U[0.5, 0.95] (seed "
        f"{ENSEMBLE_SEED}), T = {ENSEMBLE_T_END:g}, {METHOD} rtol = {ENSEMBLE_TOL[0]:g}, "
        f"atol = {ENSEMBLE_TOL[1]:g}; median of {repeat} rounds; ratio = hybridlab / this; "
        f"bounce counts against hybridlab's serial sweep and against the closed form cut by "
        f"hybridlab's Zeno rule ({int(ref_zeno.sum())} Zeno runs)",
        ["implementation", "phase", "median [ms]", "ratio pool", "ratio serial", "Zeno runs",
         "max|dn| hl", "= hl", "max|dn| exact", "= exact"],
        rows.ensemble))
    report.records.extend(rows.records)
    report.records.append({"one_off_s": one_off, "load_average": list(load), "repeat": repeat,
                           "numba_threads": numba.get_num_threads(),
                           "numba_threading_layer": numba.threading_layer(),
                           "exact_impacts": exact.tolist(),
                           "reference_zeno_runs": int(ref_zeno.sum())})
    report.notes += [
        "ratio = hybridlab time / this implementation's time (medians): above 1 hybridlab is "
        "slower, taking that many times as long; below 1 it is faster. Ratios are formed "
        "within a phase, where the implementations alternate round by round.",
        "Phases: 1 and 2 run before jax is imported, 3 after (hybridlab's process pool forks "
        "and a fork after JAX has started its threads can deadlock), so phase 3 re-times "
        "hybridlab serially next to diffrax. A '~' pool ratio (phase 3) is chained through "
        "the serial sweep timed in both phases: (pool / serial, phase 2) x (serial / this, "
        "phase 3).",
        "max|dt_k| exact: largest impact-time error against the closed form [s]; vs hl: "
        "against hybridlab's impact times of the same phase. max|dn|, '=': largest bounce-count "
        "difference per run and the fraction of runs with equal counts.",
        f"Zeno rule (all loops, as hybridlab): after each impact, when the last {ZENO_WINDOW} "
        f"flights shrink with ratios within a factor 1.5 and the accumulation time lies within "
        f"{ZENO_TOL:g} * max(1, t) (or a flight is below {ZENO_RESOLUTION:g} * max(1, t)), "
        "the run stops with status ZENO after that impact.",
        "One-off costs, not in the tables: "
        + "; ".join(f"{k} {1e3 * v:.0f} ms" for k, v in one_off.items()) + ".",
        f"numba: {numba.get_num_threads()} threads, threading layer "
        f"{numba.threading_layer()}. Load average at the start: "
        + ", ".join(f"{x:.2f}" for x in load) + f" on {os.cpu_count()} cores.",
        *notes,
    ]
    return report


def main(argv: Sequence[str] | None = None) -> int:
    return run_main(run, __doc__.splitlines()[0], argv)


if __name__ == "__main__":
    sys.exit(main())
