"""Coulomb friction in a flowpipe: a block that sticks, breaks away and never slides back.

A unit mass on a floor with Coulomb friction ``c = 1`` is pushed by a force growing as
``2 t``, from rest, its position uncertain in [0, 0.1]. While ``2 t < c`` friction holds it
(Filippov sliding on ``v = 0``); at ``t = 0.5`` it breaks away and ``v = (t - 0.5)^2``.
:func:`hybridlab.reach` treats the sign of ``v`` as a free input only on the surface, and
uses the side from which the flow points back to it (see ``docs/verification.md``,
"Discontinuous flows"); checks:

1. the result is complete, and while the push is below the friction the velocity set stays
   at 0 (within 1e-8: with the sign merely free it would grow by ``c * step`` per step);
2. the velocity never goes below 0 (within 1e-8): the block never slides backwards;
3. every reach set contains the closed form ``v = max(0, t - 0.5)^2`` over its time
   interval, and the bound at the end is within 0.05 of the exact 0.25;
4. simulations from the ends of the initial interval lie in the flowpipe's boxes.

Run ``python examples/reach_stick_slip.py [--plot FILE.png]``; the plot shows each reach
set's velocity bounds over its time interval with the closed form on top. Exits with status
1 if a check fails.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

import hybridlab

MODEL = """
name = "pushed_block"
description = "a unit mass pushed by a force 2 t against Coulomb friction c"
parameters = { c = 1.0 }
states = { x = 0.0, v = 0.0 }
[modes.push]
flow = { x = "v", v = "2*t - c*sign(v)" }
[initial]
mode = "push"
"""


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", metavar="FILE.png")
    args = parser.parse_args(argv)
    model = hybridlab.loads_model(MODEL)
    result = hybridlab.reach(model, initial={"x": (0.0, 0.1)}, t_end=1.0, step=0.01)
    ok = result.complete
    stuck = max(float(np.max(np.abs(s.bounds()[1]))) for s in result.sets if s.t[1] <= 0.49)
    lowest = result.bounds["v"][0]
    print(f"{len(result.sets)} sets; while held |v| <= {stuck:.1e}; lowest v {lowest:.1e}; "
          f"v at most {result.bounds['v'][1]:.4f} (exact 0.25)")
    ok &= stuck < 1e-8 and lowest > -1e-8
    for s in result.sets:
        v_lo, v_hi = s.bounds()[1]
        exact = [max(0.0, t - 0.5) ** 2 for t in (max(s.t[0], 0.0), s.t[1])]
        ok &= bool(v_lo <= min(exact) + 1e-9 and max(exact) <= v_hi + 1e-9)
    ok &= 0.25 <= result.bounds["v"][1] < 0.3
    boxes = np.stack([s.bounds() for s in result.sets])
    spans = np.array([s.t for s in result.sets])
    misses = 0
    for x0 in (0.0, 0.1):
        run = hybridlab.simulate(model, initial={"x": x0}, t_end=1.0)
        for t in np.linspace(0.0, 1.0, 201):
            y = run(t)
            live = (spans[:, 0] <= t) & (t <= spans[:, 1])
            inside = np.all((boxes[live, :, 0] - 1e-9 <= y) & (y <= boxes[live, :, 1] + 1e-9),
                            axis=1)
            misses += not bool(np.any(inside))
    print(f"simulations: {misses} of 402 instants outside the flowpipe")
    ok &= misses == 0
    if args.plot:
        _plot(result, args.plot)
    print("all checks passed" if ok else "some checks FAILED")
    return 0 if ok else 1


def _plot(result: hybridlab.ReachResult, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    fig, ax = plt.subplots(figsize=(7, 4))
    for s in result.sets:
        v_lo, v_hi = s.bounds()[1]
        ax.add_patch(Rectangle((s.t[0], v_lo), s.t[1] - s.t[0], v_hi - v_lo,
                               facecolor="tab:blue", alpha=0.3, lw=0))
    t = np.linspace(0.0, 1.0, 201)
    ax.plot(t, np.maximum(0.0, t - 0.5) ** 2, color="k", lw=1, label="v = max(0, t - 0.5)^2")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("v [m/s]")
    ax.set_title("a block pushed against Coulomb friction: velocity reach sets")
    ax.legend()
    ax.autoscale()
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


if __name__ == "__main__":
    sys.exit(main())
