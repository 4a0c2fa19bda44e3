"""The trolley paper's Fig. 14 sweep: hybridlab.sweep on every core against serial loops.

The job: the event-based stop-and-return of ``models/trolley.toml`` for 2
sensor positions (``p_1`` = 0.10, 0.25 m) x 50 accelerations (0.25 to
3 m/s^2), each run to 12 s + a 30 s hold, counting the sensor-1 edges after
the arrival. Timed once each, in one process, at equal tolerances (DOP853,
rtol 1e-8, atol 1e-10):

* **sweep**: ``hybridlab.sweep`` with the default executor (a process pool
  over every core, fresh worker processes) and default backend;
* **sweep, warm pool**: the same through a process pool that has already run
  a small warm-up sweep (workers hold the compiled model);
* **scipy loop**: a serial Python loop over ``fig14_point`` of the hand-written
  ``solve_ivp`` trolley (``benchmarks/scipy_trolley.py``);
* **default-backend loop**: a serial loop of ``hybridlab.simulate`` in this process (the
  sweep's parallel speed-up is this time over the sweep's);
* **reference loop**: a serial loop of ``hybridlab.simulate(..., backend="reference")``.

Ratios are loop time / sweep time (above 1: the sweep is faster). The counts
of every run are compared between the three implementations.

Run ``python benchmarks/fig14_sweep.py [--accelerations N] [--hold S] [--no-reference]``.
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import os
import sys
import time

import numpy as np
from common import ROOT, format_table, machine_info

import hybridlab
from hybridlab.ensemble import Count

MODEL = ROOT / "models" / "trolley.toml"
POSITIONS = (0.10, 0.25)
RESIDUAL = Count(("s1_on", "s1_off"), after="arrive", name="residual")
TOL = {"method": "DOP853", "rtol": 1e-8, "atol": 1e-10}


def run_sweep(model, accel, hold, executor=None, **options):
    return hybridlab.sweep(model, grid={"p_1": list(POSITIONS), "a_max": list(accel)},
                           params={"profile": 1.0}, t_end=12.0 + hold, events=[RESIDUAL],
                           executor=executor, **TOL, **options)


def _spin(n: int) -> int:
    total = 0
    for i in range(n):
        total += i * i
    return total


def available_parallelism(workers: int, n: int = 5_000_000) -> float:
    """Speed-up of ``workers`` processes over one on a pure-Python busy loop, measured now.

    On a machine shared with other jobs this is what a process pool can gain at
    best; it calibrates the sweep's speed-up below.
    """
    start = time.perf_counter()
    for _ in range(workers):
        _spin(n)
    serial = time.perf_counter() - start
    with cf.ProcessPoolExecutor(max_workers=workers) as pool:
        list(pool.map(_spin, [1000] * workers))  # start the workers
        start = time.perf_counter()
        list(pool.map(_spin, [n] * workers))
        parallel = time.perf_counter() - start
    return serial / parallel


def loop_count(compiled, p_1, a_max, hold, backend="reference") -> int:
    result = hybridlab.simulate(compiled, 12.0 + hold, backend=backend, **TOL,
                                params={"profile": 1.0, "p_1": p_1, "a_max": a_max})
    arrive = next((e.t for e in result.jumps if e.transition == "arrive"), None)
    if arrive is None:
        return -1
    return sum(1 for e in result.jumps if e.transition in ("s1_on", "s1_off") and e.t > arrive)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--accelerations", type=int, default=50)
    parser.add_argument("--hold", type=float, default=30.0)
    parser.add_argument("--no-reference", action="store_true",
                        help="skip the serial loop on hybridlab's reference backend")
    args = parser.parse_args(argv)
    accel = np.linspace(0.25, 3.0, args.accelerations)
    points = [(p, float(a)) for p in POSITIONS for a in accel]
    info = machine_info()
    print(f"Fig. 14 sweep: {len(points)} runs, hold {args.hold:g} s; {info['cpu']}, "
          f"{os.cpu_count()} cores; {info['date']}", flush=True)
    model = hybridlab.load_model(MODEL)
    compiled = hybridlab.compile_model(model)

    hybridlab.simulate(compiled, 13.0, params={"profile": 1.0})  # warm the backend's disk cache
    rows, times, counts = [], {}, {}

    start = time.perf_counter()
    table = run_sweep(model, accel, args.hold)
    times["sweep (fresh pool)"] = time.perf_counter() - start
    print(f"sweep, fresh pool ({table.executor}): {times['sweep (fresh pool)']:.2f} s",
          flush=True)
    counts["sweep"] = table["residual"].tolist()
    label = table.executor

    with cf.ProcessPoolExecutor(max_workers=os.cpu_count()) as pool:
        run_sweep(model, accel[:2], 1.0, executor=pool, chunksize=1)  # warm the workers
        start = time.perf_counter()
        warm = run_sweep(model, accel, args.hold, executor=pool)
        times["sweep (warm pool)"] = time.perf_counter() - start
    print(f"sweep, warm pool: {times['sweep (warm pool)']:.2f} s", flush=True)
    counts["sweep (warm pool)"] = warm["residual"].tolist()

    try:
        sys.path.insert(0, str(ROOT / "benchmarks"))
        from scipy_trolley import fig14_point
    except ImportError:
        fig14_point = None
    if fig14_point is not None:
        fig14_point(0.25, 1.0, 1.0)  # warm-up
        start = time.perf_counter()
        counts["scipy loop"] = [fig14_point(p, a, args.hold) for p, a in points]
        times["scipy loop (serial)"] = time.perf_counter() - start
        print(f"scipy loop: {times['scipy loop (serial)']:.2f} s", flush=True)
    start = time.perf_counter()
    counts["default-backend loop"] = [loop_count(compiled, p, a, args.hold, "auto")
                                      for p, a in points]
    times["default-backend loop (serial)"] = time.perf_counter() - start
    print(f"default-backend loop: {times['default-backend loop (serial)']:.2f} s", flush=True)
    if not args.no_reference:
        start = time.perf_counter()
        counts["reference loop"] = [loop_count(compiled, p, a, args.hold) for p, a in points]
        times["reference loop (serial)"] = time.perf_counter() - start
        print(f"reference loop: {times['reference loop (serial)']:.2f} s", flush=True)

    cores = os.cpu_count() or 1
    print(f"available parallelism now ({cores} busy-loop processes vs one): "
          f"{available_parallelism(cores):.2f}x", flush=True)
    best = times["sweep (warm pool)"]
    fresh = times["sweep (fresh pool)"]
    for name, seconds in times.items():
        rows.append([name, f"{seconds:.2f}", f"{seconds / fresh:.1f}", f"{seconds / best:.1f}"])
    print(f"\nsweep executor: {label}; backend: {hybridlab.SimulationOptions().backend}")
    print(format_table(["job", "seconds", "x fresh sweep", "x warm sweep"], rows))
    base = counts["sweep"]
    for name, other in counts.items():
        diff = sum(1 for a, b in zip(base, other, strict=True) if a != b)
        print(f"{name}: {diff} of {len(base)} counts differ from the sweep's")
    return 0


if __name__ == "__main__":
    sys.exit(main())
