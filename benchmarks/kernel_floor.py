"""Where a compiled trolley run's time goes: the integration alone against the whole run.

The compiled backend takes the reference engine's own steps (scipy's step-size
control at the same ``rtol``/``atol``), so the integration is a floor no
change to the event handling can go below. This benchmark measures it for the
stop-and-return (12 s) and the Fig. 14 sweep (100 runs of 42 s, serial): it
counts the steps by what slides in them, then times as many DOP853 steps of
the trolley's flow with their dense output and nothing else (no monitors, no
quiet-step bounds, no events), on the kernel's own step functions (plain
steps in mode ``hold``, sliding steps with the same switches sliding). For
the sweep, the steps of all 100 runs are summed and integrated under the first
run's parameters. The last column is the speed-up over the plain scipy loop
that the compiled backend would reach if sampling, locating and handling
events cost nothing. It is an estimate: the flows of other modes cost about
the same, but not exactly.

Run ``python benchmarks/kernel_floor.py [--quick] [--repeat N] [--json FILE]``.
"""

from __future__ import annotations

import sys
from collections import Counter
from collections.abc import Callable, Sequence
from functools import partial

import numba
import numpy as np
import scipy_trolley
from common import Report, run_main, time_call, time_calls

import hybridlab
from hybridlab.model.names import match_modes
from hybridlab.simulation.compiled.backend import prepare
from hybridlab.simulation.compiled.integrate import (
    METHOD_CODES,
    N_COEF,
    N_K,
    dense_coefficients,
    rk_step,
)
from hybridlab.simulation.compiled.kernel import _fc
from hybridlab.simulation.compiled.signatures import model_at
from hybridlab.simulation.compiled.sliding import rhs, workspace

__all__ = ["run"]

TOL = {"method": "DOP853", "rtol": 1e-8, "atol": 1e-10}
#: the Fig. 14 sweep's grid (``fig14_sweep.py``): sensor 1 at 0.10 and 0.25 m, 50 accelerations
FIG14 = [(p_1, float(a)) for p_1 in (0.10, 0.25) for a in np.linspace(0.25, 3.0, 50)]


def _jobs() -> list[tuple[str, list[dict], list[Callable[[], object]], bool]]:
    """(label, hybridlab call arguments per run, scipy loop per run, whether to repeat)."""
    fig14 = [{"t_end": 42.0, "params": {"profile": 1.0, "p_1": p_1, "a_max": a}}
             for p_1, a in FIG14]
    return [
        ("stop-and-return, 12 s", [{"scenario": "default"}],
         [partial(scipy_trolley.stop_and_return, **TOL)], True),
        ("Fig. 14 sweep, 100 runs of 42 s, serial", fig14,
         [partial(scipy_trolley.fig14_point, p_1, a, 30.0, **TOL) for p_1, a in FIG14], False),
    ]


@numba.njit(cache=True)
def _steps(model_address, ints, mode, x0, p, n_sig, sliding, count, method, rtol, atol):
    """``count`` steps of mode ``mode``'s flow from ``x0`` with the switches ``sliding``
    (0/1 per switch) held on their surfaces: the kernel's step and dense output only."""
    model = model_at(model_address)
    n = x0.size
    sig = np.ones(max(n_sig, 1))
    slm = np.zeros(max(n_sig, 1), dtype=np.bool_)
    for k in range(n_sig):
        if sliding[k]:
            slm[k] = True
            sig[k] = 0.0
    W = workspace(n, n_sig)
    fc = _fc(ints, mode, slm, W, np.empty(max(n_sig, 1), dtype=np.int64))
    K = np.empty((N_K[method], n))
    coef = np.zeros((N_COEF[method], n))
    y_new, f_new, f, tmp, scale = np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    x = x0.copy()
    t, h_abs = 0.0, 1e-3
    rhs(model, fc, t, x, p, sig, f)
    for _ in range(count):
        _, t_new, h_abs, h = rk_step(model, method, fc, t, x, f, np.inf, h_abs, np.inf, rtol,
                                     atol, p, sig, K, y_new, f_new, tmp, scale)
        dense_coefficients(model, method, fc, t, h, x, y_new, f_new, p, sig, K, tmp, coef)
        t = t_new
        for i in range(n):
            x[i] = y_new[i]
            f[i] = f_new[i]
    return t


def _steps_by_sliding(result: hybridlab.SimulationResult, n_sig: int) -> Counter:
    """The run's steps counted by the switches sliding in them (a tuple of 0/1 per switch)."""
    [hold] = match_modes("hold", list(result.compiled.modes))
    switches = [s.text for s in result.compiled.modes[hold].switches]
    intervals: list[tuple[int, float, float]] = []
    started: dict[int, float] = {}
    for e in result.events:
        if e.kind == "slide_start":
            started[switches.index(e.transition)] = e.t
        elif e.kind == "slide_end":
            k = switches.index(e.transition)
            intervals.append((k, started.pop(k, 0.0), e.t))
    intervals += [(k, t, np.inf) for k, t in started.items()]
    counts: Counter = Counter()
    for seg in result.segments:
        mid = 0.5 * (seg.t_start + seg.t_end)
        key = tuple(int(any(k == j and a <= mid <= b for j, a, b in intervals))
                    for k in range(n_sig))
        counts[key] += len(seg.interpolants)
    return counts


def run(repeat: int) -> Report:
    """Time the whole compiled run, the integration alone and the scipy loop for each job."""
    compiled = hybridlab.compile_model(hybridlab.load_model("models/trolley.toml"))
    prep = prepare(compiled)
    method = METHOD_CODES[TOL["method"]]
    hold = prep.mode_names.index(match_modes("hold", list(prep.mode_names))[0])
    report = Report("kernel_floor", "The integration alone against the whole compiled run")
    rows = []
    for label, runs, scipy_runs, repeated in _jobs():
        def compiled_loop(runs: list[dict] = runs) -> list[hybridlab.SimulationResult]:
            return [hybridlab.simulate(compiled, backend="compiled", **TOL, **kw) for kw in runs]

        def scipy_loop(scipy_runs: list = scipy_runs) -> list:
            return [call() for call in scipy_runs]
        (t_run, results), (t_scipy, _) = time_calls([compiled_loop, scipy_loop],
                                                    repeat=repeat if repeated else 1)
        counts: Counter = Counter()
        floor = 0.0
        for result in results:
            counts.update(_steps_by_sliding(result, prep.n_sig))
        # the steps of every run, integrated from one state under the first run's parameters
        p = compiled.parameter_vector(runs[0].get("params"))
        x0 = compiled.state_vector({"phi": 0.3, "v": 0.0, "omega": 0.0})
        ints, _ = prep.schedule_tables(np.ascontiguousarray(p, dtype=float))
        for sliding, count in counts.items():
            integrate = partial(_steps, prep.module.model.address, ints, hold, x0, p,
                                prep.n_sig, np.array(sliding, dtype=np.int64), count, method,
                                TOL["rtol"], TOL["atol"])
            floor += time_call(integrate, repeat=repeat)[0].best
        plain = counts.get((0,) * prep.n_sig, 0)
        rows.append([label, f"{plain} / {sum(counts.values()) - plain}",
                     f"{t_run.best * 1e3:.1f}", f"{floor * 1e3:.1f}",
                     f"{floor / t_run.best:.0%}", f"{t_scipy.best * 1e3:.0f}",
                     f"{t_scipy.best / t_run.best:.1f}", f"{t_scipy.best / floor:.0f}"])
        report.records.append({"job": label, "steps": {str(k): v for k, v in counts.items()},
                               "compiled_s": t_run.best, "integration_s": floor,
                               "scipy_s": t_scipy.best})
    report.tables.append((
        f"Best of {repeat} runs (the sweep: one), DOP853 rtol {TOL['rtol']:g} "
        f"atol {TOL['atol']:g}, ms",
        ["job", "steps plain / sliding", "compiled run", "integration alone", "share",
         "plain scipy", "x now", "x if events were free"], rows))
    report.notes.append("integration alone = the same number of steps of the trolley's flow "
                        "(mode hold, the same switches sliding) with dense output, on the "
                        "kernel's step functions; an estimate of the floor.")
    return report


def main(argv: Sequence[str] | None = None) -> int:
    return run_main(run, __doc__.splitlines()[0], argv)


if __name__ == "__main__":
    sys.exit(main())
