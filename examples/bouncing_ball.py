"""Bouncing ball: impact times against the closed form, and Zeno detection.

Loads ``models/bouncing_ball.toml`` (h0 = 10 m, v0 = 0, g = 9.81 m/s^2,
restitution e = 0.8) and checks two things:

1. Scenario ``default`` (t_end = 10 s): every impact time against the closed
   form. The first impact is at t_1 = sqrt(2 h0 / g) with speed v_1 = g t_1;
   after bounce k the ball leaves with speed e^k v_1 and flies for
   2 e^k v_1 / g, so t_{k+1} = t_k + 2 e^k v_1 / g.
2. Scenario ``zeno`` (t_end = 20 s): the impact times accumulate at
   t_inf = t_1 (1 + 2 e / (1 - e)) = 12.8506 s. The run must stop there with
   status ``ZENO`` and report the accumulation time in ``result.zeno_time``.

Run ``python examples/bouncing_ball.py [--plot FILE.png]``. Exits with status 1
if a check fails.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

import hybridlab

MODEL = Path(__file__).resolve().parents[1] / "models" / "bouncing_ball.toml"
IMPACT_TOL = 1e-9  # s; the flow is a parabola, so only event location contributes
ZENO_TOL = 1e-6  # s; on the extrapolated accumulation time


def impact_times(h0: float, g: float, e: float, count: int) -> np.ndarray:
    """Closed-form impact times of a ball dropped from rest at height ``h0``."""
    t1 = math.sqrt(2 * h0 / g)
    v1 = g * t1
    times = [t1]
    for k in range(1, count):
        times.append(times[-1] + 2 * e**k * v1 / g)
    return np.array(times)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", metavar="FILE.png", help="write a plot of h(t)")
    args = parser.parse_args(argv)

    ball = hybridlab.load_model(MODEL)
    g, e = ball.parameters["g"].value, ball.parameters["e"].value
    h0 = ball.states["h"].initial
    ok = True

    result = hybridlab.simulate(ball)  # scenario "default": t_end = 10 s
    times = np.array([event.t for event in result.jumps])
    expected = impact_times(h0, g, e, times.size)
    error = np.abs(times - expected)
    print(f"default scenario: {result.status.name}, {times.size} impacts by t = {result.final.t:g}")
    print("   k   t_k (simulated)      t_k (closed form)    |error|")
    for k, (t_sim, t_ref, err) in enumerate(zip(times, expected, error, strict=True), start=1):
        print(f"  {k:2d}   {t_sim:.15f}  {t_ref:.15f}  {err:.1e}")
    if result.status is not hybridlab.Status.COMPLETED or times.size != 7:
        print(f"FAIL: expected 7 impacts and COMPLETED, got {times.size} and {result.status.name}")
        ok = False
    if error.max() > IMPACT_TOL:
        print(f"FAIL: impact time error {error.max():.2e} s > {IMPACT_TOL:g} s")
        ok = False

    zeno = hybridlab.simulate(ball, scenario="zeno")
    t_inf = math.sqrt(2 * h0 / g) * (1 + 2 * e / (1 - e))
    print(f"\nzeno scenario: {zeno.status.name} after {len(zeno.jumps)} impacts")
    print(f"  message:    {zeno.message}")
    print(f"  stopped at  t = {zeno.final.t:.6f} s, h = {zeno.final.state['h']:.1e} m")
    if zeno.zeno_time is None:
        print("FAIL: no accumulation time reported")
        return 1
    print(f"  zeno_time   {zeno.zeno_time:.10f} s")
    print(f"  closed form {t_inf:.10f} s  (error {abs(zeno.zeno_time - t_inf):.1e} s)")
    if zeno.status is not hybridlab.Status.ZENO:
        print(f"FAIL: expected status ZENO, got {zeno.status.name}")
        ok = False
    if abs(zeno.zeno_time - t_inf) > ZENO_TOL or round(zeno.zeno_time, 4) != 12.8506:
        print(f"FAIL: accumulation time {zeno.zeno_time!r} != {t_inf!r}")
        ok = False
    if min(zeno.y[0]) < -1e-9:
        print("FAIL: the ball fell through the floor")
        ok = False

    if args.plot:
        plot(result, zeno, args.plot)
        print(f"\nwrote {args.plot}")
    print("\nOK" if ok else "\nFAILED")
    return 0 if ok else 1


def plot(result: hybridlab.SimulationResult, zeno: hybridlab.SimulationResult,
         path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 3.5))
    t, y = zeno.sample(0.002)  # dense output on a uniform grid
    ax.plot(t, y[0], lw=1, label="h(t), scenario zeno")
    ax.plot([ev.t for ev in zeno.jumps], [0.0] * len(zeno.jumps), "k|", ms=8, label="impacts")
    ax.axvline(zeno.zeno_time, color="r", ls="--", lw=1,
               label=f"zeno_time = {zeno.zeno_time:.4f} s")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("h [m]")
    ax.legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
