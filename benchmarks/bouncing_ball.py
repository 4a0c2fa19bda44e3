"""Bouncing ball: hybridlab against a hand-written ``solve_ivp`` restart loop.

The job is scenario ``benchmark`` of ``models/bouncing_ball.toml``: a ball
dropped from h0 = 10 m (g = 9.81 m/s^2, restitution e = 0.95) up to T = 50 s,
which takes 44 bounces. Both implementations use the same scipy method and
the same ``rtol``/``atol``; the flow is polynomial of degree 2, so every
Runge-Kutta step is exact up to rounding and the errors measured here are
those of event location and of the restarts.

Reference (closed form, v0 = 0): the first impact is at t_1 = sqrt(2 h0 / g)
with speed v_1 = g t_1. After bounce k the ball leaves the floor with speed
e^k v_1 and flies for 2 e^k v_1 / g, so t_{k+1} = t_k + 2 e^k v_1 / g. Between
bounces h is the parabola h(t) = u (t - t_k) - g (t - t_k)^2 / 2 with
u = e^k v_1.

Run ``python benchmarks/bouncing_ball.py [--quick] [--json FILE]``.
"""

from __future__ import annotations

import math
import statistics
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from common import ROOT, Report, run_main, time_calls
from scipy.integrate import solve_ivp

import hybridlab

__all__ = ["Ball", "Trajectory", "exact_impacts", "exact_state", "hybridlab_run", "run",
           "scipy_restart_loop"]

MODEL = ROOT / "models" / "bouncing_ball.toml"
SCENARIO = "benchmark"
METHODS = ("DOP853", "RK45")
#: (rtol, atol) levels, loosest first; the middle one is hybridlab's default.
TOLERANCES = ((1e-6, 1e-9), (1e-8, 1e-10), (1e-10, 1e-12))


@dataclass(frozen=True)
class Ball:
    """The numbers of the job, read from the model file so both sides agree."""

    g: float
    e: float
    h0: float
    v0: float
    t_end: float

    @classmethod
    def from_model(cls, model: hybridlab.Model, scenario: str) -> Ball:
        sc = model.scenarios[scenario]
        params = {name: p.value for name, p in model.parameters.items()} | sc.parameters
        initial = {name: s.initial for name, s in model.states.items()} | sc.initial
        return cls(g=params["g"], e=params["e"], h0=initial["h"], v0=initial["v"],
                   t_end=sc.t_end)


@dataclass(frozen=True)
class Trajectory:
    """What either implementation produced: impact times, end state, step count."""

    impacts: np.ndarray
    t: float
    h: float
    v: float
    steps: int
    stats: Mapping[str, int] = field(default_factory=dict)


# ----- closed form ------------------------------------------------------------------------
def exact_impacts(ball: Ball) -> np.ndarray:
    """Impact times t_k <= t_end (needs v0 = 0)."""
    if ball.v0 != 0.0:
        raise ValueError(f"the closed form assumes v0 = 0 (got v0 = {ball.v0!r})")
    t1 = math.sqrt(2.0 * ball.h0 / ball.g)
    flight = 2.0 * t1  # 2 v_1 / g with v_1 = g t_1
    times = [t1]
    terms = [t1]
    while True:
        terms.append(flight * ball.e ** len(times))
        t_next = math.fsum(terms)  # summed exactly, so the reference has no drift
        if t_next > ball.t_end:
            return np.array(times)
        times.append(t_next)


def exact_state(ball: Ball, impacts: np.ndarray, t: float) -> tuple[float, float]:
    """``(h, v)`` at time ``t`` (after the impacts at or before ``t``)."""
    k = int(np.searchsorted(impacts, t, side="right"))
    if k == 0:
        return ball.h0 - 0.5 * ball.g * t**2, -ball.g * t
    u = ball.e**k * ball.g * math.sqrt(2.0 * ball.h0 / ball.g)
    tau = t - impacts[k - 1]
    return u * tau - 0.5 * ball.g * tau**2, u - ball.g * tau


# ----- the plain scipy baseline -----------------------------------------------------------
def scipy_restart_loop(ball: Ball, method: str, rtol: float, atol: float) -> Trajectory:
    """The loop an engineer writes: integrate to the floor, flip v, start again.

    After each bounce the solver restarts at the impact time with ``h = 0`` and
    ``v = -e v``. Two guards make the restart safe (they are the usual fixes):

    * ``h`` is set to exactly 0 instead of the located ``h`` (a few 1e-14 either way):
      a start slightly below the floor could hide the next impact if one
      solver step spanned a whole flight (both endpoint signs negative);
    * the event function returns +1 at the restart instant itself, so the
      impact just handled cannot be found again at ``t0`` (``solve_ivp`` would
      report a root at ``t0`` whenever ``g(t0) = 0`` and the first step ends
      below the floor).

    Both hazards need a first step longer than a whole flight. On this job
    scipy's automatic first step after a restart is at most a few
    milliseconds, so the unguarded loop also reaches 44 bounces here; forcing
    ``first_step = 3 s`` breaks it (the ball falls through the floor after 4
    bounces, or with ``h = 0`` the event fires at ``t0`` again and again) while
    the guarded loop still gets 44. The guards cost nothing measurable.
    """
    g, e = ball.g, ball.e

    def rhs(t: float, y: np.ndarray) -> list[float]:
        return [y[1], -g]

    t, y = 0.0, np.array([ball.h0, ball.v0])
    impacts: list[float] = []
    steps = 0
    while t < ball.t_end:
        def floor(tt: float, yy: np.ndarray, t_start: float = t) -> float:
            return 1.0 if tt == t_start else yy[0]

        floor.terminal = True  # type: ignore[attr-defined]
        floor.direction = -1  # type: ignore[attr-defined]
        sol = solve_ivp(rhs, (t, ball.t_end), y, method=method, rtol=rtol, atol=atol,
                        events=floor)
        if sol.status == -1:
            raise RuntimeError(f"solve_ivp failed at t = {sol.t[-1]!r}: {sol.message}")
        steps += sol.t.size - 1
        if sol.status != 1:  # reached t_end
            return Trajectory(np.array(impacts), float(sol.t[-1]), float(sol.y[0, -1]),
                              float(sol.y[1, -1]), steps)
        t = float(sol.t_events[0][0])
        impacts.append(t)
        y = np.array([0.0, -e * sol.y_events[0][0][1]])
    return Trajectory(np.array(impacts), t, float(y[0]), float(y[1]), steps)


# ----- hybridlab --------------------------------------------------------------------------
def hybridlab_run(compiled: hybridlab.CompiledModel, method: str, rtol: float,
                  atol: float, backend: str = "reference") -> Trajectory:
    """One ``hybridlab.simulate`` of the scenario; the model is compiled beforehand."""
    result = hybridlab.simulate(compiled, scenario=SCENARIO, method=method, rtol=rtol, atol=atol,
                                backend=backend)
    if not result.status.ok:
        raise RuntimeError(f"hybridlab stopped early: {result.status.name}: {result.message}")
    impacts = np.array([ev.t for ev in result.jumps if ev.transition == "bounce"])
    final = result.final
    return Trajectory(impacts, final.t, final.state["h"], final.state["v"],
                      int(result.stats.get("steps", -1)), dict(result.stats))


# ----- accuracy ---------------------------------------------------------------------------
def errors(ball: Ball, exact: np.ndarray, run: Trajectory) -> dict[str, Any]:
    """Impact-time and end-state errors against the closed form."""
    n = min(exact.size, run.impacts.size)
    dt = np.abs(run.impacts[:n] - exact[:n])
    h, v = exact_state(ball, exact, run.t)
    return {
        "bounces": int(run.impacts.size),
        "max_impact_error": float(dt.max()) if n else math.nan,
        "max_impact_rel_error": float((dt / exact[:n]).max()) if n else math.nan,
        "final_t": run.t,
        "final_h_error": abs(run.h - h),
        "final_v_error": abs(run.v - v),
        "steps": run.steps,
        "stats": dict(run.stats),
    }


def _ms(seconds: float) -> str:
    return f"{1e3 * seconds:.1f}"


def _sci(x: float) -> str:
    return "nan" if math.isnan(x) else f"{x:.1e}"


#: calls of one implementation in a row per round (the first is the switched one)
BLOCK = 5


def run(repeat: int) -> Report:
    """Time and check both implementations at every method and tolerance level."""
    model = hybridlab.load_model(MODEL)
    ball = Ball.from_model(model, SCENARIO)
    exact = exact_impacts(ball)
    h_end, v_end = exact_state(ball, exact, ball.t_end)

    # One-off costs of hybridlab, each on a freshly loaded model (compiling is cached on it).
    # The first pass is the warm-up (imports, sympy caches) and is dropped.
    load_times, compile_times = [], []
    for _ in range(repeat + 1):
        start = time.perf_counter()
        fresh = hybridlab.load_model(MODEL)
        loaded = time.perf_counter()
        hybridlab.compile_model(fresh)
        load_times.append(loaded - start)
        compile_times.append(time.perf_counter() - loaded)
    load_ms = 1e3 * statistics.median(load_times[1:])
    compile_ms = 1e3 * statistics.median(compile_times[1:])
    compiled = hybridlab.compile_model(model)

    report = Report("bouncing_ball", f"hybridlab vs a solve_ivp restart loop, {exact.size} "
                    f"bounces, e = {ball.e}, T = {ball.t_end:g}")
    speed_rows, state_rows, fast_rows = [], [], []
    start = time.perf_counter()
    hybridlab.simulate(compiled, scenario=SCENARIO, backend="compiled")
    first_compiled_ms = 1e3 * (time.perf_counter() - start)
    for method in METHODS:
        for rtol, atol in TOLERANCES:
            (base_time, base), (hl_time, hl), (fast_time, fast) = time_calls(
                [lambda m=method, r=rtol, a=atol: scipy_restart_loop(ball, m, r, a),
                 lambda m=method, r=rtol, a=atol: hybridlab_run(compiled, m, r, a),
                 lambda m=method, r=rtol, a=atol: hybridlab_run(compiled, m, r, a, "compiled")],
                repeat=repeat, block=BLOCK)
            base_err, hl_err = errors(ball, exact, base), errors(ball, exact, hl)
            fast_err = errors(ball, exact, fast)
            ratio = hl_time.median / base_time.median
            ratio_best = hl_time.best / base_time.best
            speedup = base_time.median / fast_time.median
            speedup_switched = base_time.switched_median / fast_time.switched_median
            speed_rows.append([method, f"{rtol:g}", f"{atol:g}", _ms(base_time.median),
                               _ms(hl_time.median), f"{ratio:.1f}", f"{ratio_best:.1f}",
                               str(base_err["bounces"]), str(hl_err["bounces"]),
                               _sci(base_err["max_impact_error"]),
                               _sci(hl_err["max_impact_error"])])
            fast_rows.append([method, f"{rtol:g}", _ms(base_time.median),
                              f"{1e3 * fast_time.median:.2f}", f"{speedup:.0f}",
                              f"{1e3 * fast_time.switched_median:.2f}",
                              f"{speedup_switched:.0f}",
                              f"{hl_time.median / fast_time.median:.0f}",
                              str(fast_err["bounces"]), _sci(fast_err["max_impact_error"]),
                              str(fast.stats.get("backend"))])
            state_rows.append([method, f"{rtol:g}",
                               _sci(base_err["final_h_error"]), _sci(hl_err["final_h_error"]),
                               _sci(base_err["final_v_error"]), _sci(hl_err["final_v_error"]),
                               str(base_err["steps"]), str(hl_err["steps"])])
            report.records.append({
                "method": method, "rtol": rtol, "atol": atol, "ratio_median": ratio,
                "ratio_best": ratio_best,
                "scipy_loop": {**base_time.as_dict(), **base_err},
                "hybridlab": {**hl_time.as_dict(), **hl_err},
                "compiled": {**fast_time.as_dict(), **fast_err},
                "compiled_speedup_vs_scipy": speedup,
                "compiled_speedup_vs_scipy_switched": speedup_switched,
                "compiled_speedup_vs_reference": hl_time.median / fast_time.median,
            })
    report.records.append({"exact_bounces": int(exact.size), "exact_impacts": exact.tolist(),
                           "exact_final_h": h_end, "exact_final_v": v_end,
                           "load_model_ms": load_ms, "compile_model_ms": compile_ms,
                           "first_compiled_run_ms": first_compiled_ms,
                           "repeat": repeat})
    report.tables.append((
        f"Speed and event accuracy (median of {repeat} rounds of {BLOCK - 1} warm runs each, "
        f"the implementations alternating round by round; closed form: {exact.size} bounces)",
        ["method", "rtol", "atol", "scipy [ms]", "hybridlab [ms]", "ratio", "ratio best",
         "bounces scipy", "bounces hl", "max|dt_k| scipy", "max|dt_k| hl"],
        speed_rows))
    report.tables.append((
        "Compiled backend (numba): speed-up = scipy time / compiled time (medians; above 1 the "
        "compiled backend is faster); warm, and right after the other implementation ran",
        ["method", "rtol", "scipy [ms]", "compiled [ms]", "x vs scipy", "compiled switched [ms]",
         "x switched", "x vs reference", "bounces", "max|dt_k|", "backend"],
        fast_rows))
    report.tables.append((
        f"End state at T = {ball.t_end:g} against the closed form "
        f"(h = {h_end:.6g} m, v = {v_end:.6g} m/s), and integrator steps",
        ["method", "rtol", "|dh| scipy", "|dh| hl", "|dv| scipy", "|dv| hl", "steps scipy",
         "steps hl"],
        state_rows))
    t_next = exact[-1] + 2.0 * ball.e**exact.size * math.sqrt(2.0 * ball.g * ball.h0) / ball.g
    report.notes += [
        "ratio = hybridlab time / scipy time (medians; 'ratio best' from the fastest runs): "
        "above 1 means hybridlab (hl) is slower, taking that many times as long; below 1 it "
        "is faster.",
        f"Each round calls each implementation {BLOCK} times in a row: the first call of a "
        "block runs right after another implementation (cold caches, its garbage) and is "
        "reported as 'switched'; the other calls are warm and give the medians.",
        "max|dt_k| is the largest |t_k - t_k(exact)| over all bounces, in seconds; "
        f"bounce {exact.size} is at {exact[-1]:.6f} s, the next one would be at {t_next:.6f} s.",
        f"One-off hybridlab costs, not in the timed column: load_model {load_ms:.1f} ms, "
        f"compile_model {compile_ms:.1f} ms; first compiled run in this process (code "
        f"generation, loading the disk cache or compiling) {first_compiled_ms:.0f} ms.",
    ]
    return report


def main(argv: Sequence[str] | None = None) -> int:
    return run_main(run, __doc__.splitlines()[0], argv)


if __name__ == "__main__":
    sys.exit(main())
