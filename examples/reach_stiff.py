"""A stiff affine system: tight flowpipes with a step 25 times its fastest time constant.

``x' = -x + y``, ``y' = -2000 y + 1`` (eigenvalues -1 and -2000) from ``x`` in
[0.9, 1.1], ``y`` in [-0.5, 0.5] over 5 s, with the default step (5 / 400 =
0.0125 s, so ``|lambda| r = 25`` for the fast mode). :func:`hybridlab.reach` splits
the mode by time scale (see ``docs/verification.md``, "Stiff modes"); checks:

1. the result is complete and sound: simulations from the corners of the initial
   box (Radau, tolerance 1e-10) stay inside the bounds;
2. the bounds are tight: each state's bound is at most 5 times as wide as its
   simulated range;
3. a safety spec with a thin margin (``x <= 1.11``; the simulated maximum is 1.1)
   is proved by :func:`hybridlab.verify.check_safety`.

Run ``python examples/reach_stiff.py [--plot FILE.png]``; the plot shows each reach
set's bounds of ``x`` and ``y`` over its time interval with the simulations on top. Exits
with status 1 if a check fails.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np
from scipy.integrate import solve_ivp

import hybridlab
from hybridlab.verify import check_safety

MODEL = """
name = "stiff_pair"
description = "a slow state driven by a fast one (eigenvalues -1 and -2000)"
[parameters]
k = { value = 2000.0, unit = "1/s" }
[states]
x = { initial = 1.0 }
y = { initial = 0.0 }
[modes.run]
flow = { x = "-x + y", y = "-k*y + 1" }
[initial]
mode = "run"
"""
INITIAL = {"x": (0.9, 1.1), "y": (-0.5, 0.5)}
T_END = 5.0


def simulations() -> list[tuple[np.ndarray, np.ndarray]]:
    """``(t, z)`` from each corner of the initial box (Radau, tolerance 1e-10)."""
    runs = []
    for x0 in INITIAL["x"]:
        for y0 in INITIAL["y"]:
            sol = solve_ivp(lambda t, z: [-z[0] + z[1], -2000.0 * z[1] + 1.0], (0.0, T_END),
                            [x0, y0], method="Radau", rtol=1e-10, atol=1e-12, dense_output=True)
            t = np.r_[np.linspace(0.0, 0.01, 2001), np.linspace(0.01, T_END, 20001)]
            runs.append((t, sol.sol(t)))
    return runs


def plot(result: hybridlab.ReachResult, runs: list, path: str) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
    for i, (ax, name) in enumerate(zip(axes, ("x", "y"), strict=True)):
        for rs in result.sets:
            (t0, t1), (lo, hi) = rs.t, rs.set.bounds()[i]
            ax.fill_between([max(t0, 1e-5), t1], lo, hi, color="tab:blue", alpha=0.3, lw=0)
        for t, z in runs:
            ax.plot(np.maximum(t, 1e-5), z[i], color="k", lw=0.8)
        ax.set_xscale("log")
        ax.set_ylabel(name)
    axes[1].set_xlabel("t [s] (log scale)")
    fig.suptitle("reach sets (blue) and simulations from the corners (black)")
    fig.savefig(path, dpi=100)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", metavar="FILE.png", help="write the flowpipe plot")
    args = parser.parse_args(argv)
    model = hybridlab.loads_model(MODEL)
    result = hybridlab.reach(model, initial=INITIAL, t_end=T_END)
    runs = simulations()
    states = np.hstack([z for _, z in runs])
    lo, hi = states.min(axis=1), states.max(axis=1)
    ok = result.complete
    for i, name in enumerate(("x", "y")):
        b_lo, b_hi = result.bounds[name]
        sound = b_lo <= lo[i] + 1e-9 and b_hi >= hi[i] - 1e-9
        ratio = (b_hi - b_lo) / (hi[i] - lo[i])
        print(f"{name}: reach [{b_lo:.6g}, {b_hi:.6g}], simulated [{lo[i]:.6g}, {hi[i]:.6g}], "
              f"width ratio {ratio:.3f}")
        ok = ok and sound and ratio <= 5.0
    verdict = check_safety(model, initial=INITIAL, t_end=T_END, safe=["x <= 1.11"])
    print(f"x <= 1.11: {verdict.status.name} ({verdict.reason})")
    ok = ok and verdict.status.name == "SAFE"
    if args.plot:
        plot(result, runs, args.plot)
        print(f"wrote {args.plot}")
    status = "passed" if ok else "FAILED"
    print(f"{len(result.sets)} sets in {result.time_s:.2f} s; checks {status}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
