"""Bad input ends in a status that says why: names, non-finite flows, budgets, a sticky ball.

Four runs that used to give a wrong answer or never end, each checked against what it must
give:

1. a parameter named ``e`` next to ``exp(1)``: the flow ``x' = -x + exp(1)*e`` against its
   closed form ``x(t) = c + (x0 - c) exp(-t)``, ``c = e * 0.5``, on both backends;
2. ``x' = sqrt(x - 2)`` from ``x = 1``: ``SOLVER_FAILED`` at t = 0, naming the flow;
3. an oscillator to ``t_end = 1e300`` with ``max_steps = 2000``: ``STEP_LIMIT``, its final
   state on ``cos(t)``;
4. a ball with restitution 0.01 on a floor it may not cross (invariant ``h >= 0``): ``ZENO``
   at the accumulation time ``t1 (1 + 2e / (1 - e))``, never below the floor.

Run ``python examples/bounded_runs.py [--plot FILE.png]`` (the plot: the sticky ball's
height). Exits with status 1 if a check fails. See docs/robustness.md.
"""

from __future__ import annotations

import argparse
import math
import sys

import numpy as np

import hybridlab
from hybridlab import Status


def model(text: str) -> hybridlab.Model:
    return hybridlab.loads_model(text, source="<example>")


EULER = model("""
name = "euler"
parameters = { e = 0.5 }
states = { x = 1.0 }
[modes.run]
flow = { x = "-x + exp(1)*e" }
[initial]
mode = "run"
""")
UNDEFINED = model("""
name = "undefined"
states = { x = 1.0 }
[modes.run]
flow = { x = "sqrt(x - 2)" }
[initial]
mode = "run"
""")
OSCILLATOR = model("""
name = "oscillator"
states = { x = 1.0, v = 0.0 }
[modes.run]
flow = { x = "v", v = "-x" }
[initial]
mode = "run"
""")
STICKY_BALL = model("""
name = "sticky_ball"
parameters = { g = 9.81, e = 0.01 }
states = { h = 1.0, v = 0.0 }
[modes.fall]
flow = { h = "v", v = "-g" }
invariant = "h >= 0"
[[transitions]]
name = "bounce"
source = "fall"
target = "fall"
guard = "h <= 0"
reset = { v = "-e*v" }
[initial]
mode = "fall"
""")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", metavar="FILE.png", help="plot the sticky ball's height")
    args = parser.parse_args(argv)
    ok = True

    def check(condition: bool, text: str) -> None:
        nonlocal ok
        print(("  ok    " if condition else "  FAIL  ") + text)
        ok = ok and condition

    c = math.e * 0.5
    exact = c + (1 - c) * math.exp(-1)
    print("1. a parameter named e beside exp(1)")
    for backend in ("reference", "auto"):
        x = hybridlab.simulate(EULER, t_end=1.0, backend=backend, rtol=1e-11,
                               atol=1e-12).final.state["x"]
        check(abs(x - exact) < 1e-9, f"{backend}: x(1) = {x:.12f}, exact {exact:.12f}")

    print("2. a flow undefined where the run starts")
    for backend in ("reference", "auto"):
        r = hybridlab.simulate(UNDEFINED, t_end=1.0, backend=backend)
        check(r.status is Status.SOLVER_FAILED and "sqrt(x - 2)" in r.message,
              f"{backend}: {r.status.name}: {r.message}")

    print("3. a horizon of 1e300 under a step budget")
    r = hybridlab.simulate(OSCILLATOR, t_end=1e300, max_steps=2000)
    t = r.final.t
    check(r.status is Status.STEP_LIMIT and abs(r.final.state["x"] - math.cos(t)) < 1e-5,
          f"{r.status.name} at t = {t:.1f}: x = {r.final.state['x']:.6f}, cos(t) = "
          f"{math.cos(t):.6f}")

    print("4. a ball that loses almost all its speed at each impact")
    e = 0.01
    t_acc = math.sqrt(2 / 9.81) * (1 + 2 * e / (1 - e))
    r = hybridlab.simulate(STICKY_BALL, t_end=5.0)
    ts = np.linspace(0.0, r.final.t, 2001)
    lowest = float(r(ts)[0].min())
    check(r.status is Status.ZENO and abs(r.zeno_time - t_acc) < 1e-5 * t_acc,
          f"{r.status.name} after {len(r.jumps)} bounces: accumulation at "
          f"{r.zeno_time:.9f} s, exact {t_acc:.9f} s")
    check(lowest >= -1e-9, f"lowest height {lowest:.2e} m: never through the floor")

    if args.plot:
        plot(r, args.plot)
        print(f"wrote {args.plot}")
    print("OK" if ok else "FAILED")
    return 0 if ok else 1


def plot(result: hybridlab.SimulationResult, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.linspace(0.0, result.final.t, 2001)
    fig, ax = plt.subplots(figsize=(7, 3.2))
    ax.plot(t, result(t)[0], lw=1.2, label="h(t)")
    ax.axvline(result.zeno_time, color="k", lw=0.8, ls=":", label="accumulation time")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("h [m]")
    ax.legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
