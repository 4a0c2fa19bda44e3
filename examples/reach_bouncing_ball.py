"""Bouncing ball: reachable set from a box of initial heights, sound in dense time.

Loads ``models/bouncing_ball.toml`` (g = 9.81 m/s^2, e = 0.8) and computes the
states reachable within 4 s from h0 in [8, 10] m, v0 in [-1, 0] m/s with
:func:`hybridlab.reach`. Checks, all exact consequences of energy conservation
between impacts and its loss at them:

1. the ball starts at rest or falling, so the height bound is the largest h0 = 10 m:
   it is enclosed and exceeded by less than 1 cm;
2. after the first bounce the height is at most ``e^2`` times the largest energy
   height ``max(h0 + v0^2 / (2 g)) = 10.051`` m, i.e. 6.433 m: enclosed, and
   exceeded by less than 5 cm;
3. simulations from the corners and random points of the initial box lie in the
   flowpipes at 2001 instants each (dense time, not only at the reach steps).

Run ``python examples/reach_bouncing_ball.py [--plot FILE.png]``; the plot shows
the flowpipes in the (h, v) plane and over time with the simulations on top. Exits
with status 1 if a check fails.
"""

from __future__ import annotations

import argparse
import itertools
import sys
from pathlib import Path

import numpy as np

import hybridlab

MODEL = Path(__file__).resolve().parents[1] / "models" / "bouncing_ball.toml"
INITIAL = {"h": (8.0, 10.0), "v": (-1.0, 0.0)}
T_END = 4.0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", metavar="FILE.png", help="write the flowpipe plot")
    args = parser.parse_args(argv)

    ball = hybridlab.load_model(MODEL)
    g, e = ball.parameters["g"].value, ball.parameters["e"].value
    result = hybridlab.reach(ball, initial=INITIAL, t_end=T_END, step=0.01)
    print(f"reach: {len(result.sets)} sets in {result.time_s:.2f} s, complete={result.complete}, "
          f"modes {sorted(result.reachable_modes)}")
    for name, (lo, hi) in result.bounds.items():
        print(f"  {name}: [{lo:.4f}, {hi:.4f}]")
    ok = result.complete

    h_top = INITIAL["h"][1]
    h_hi = result.bounds["h"][1]
    print(f"height bound {h_hi:.4f} m, exact {h_top:.4f} m")
    ok &= h_top <= h_hi < h_top + 0.01
    energy = max(h + v * v / (2 * g) for h, v in itertools.product(*INITIAL.values()))
    after = max(s.bounds()[0, 1] for s in result.sets if s.jumps >= 1)
    print(f"after the first bounce {after:.4f} m, exact {e * e * energy:.4f} m")
    ok &= e * e * energy <= after < e * e * energy + 0.05

    rng = np.random.default_rng(0)
    corners = list(itertools.product(*INITIAL.values()))
    starts = corners + [tuple(rng.uniform(*r) for r in INITIAL.values()) for _ in range(6)]
    sims = []
    inside_all = True
    for h0, v0 in starts:
        sim = hybridlab.simulate(ball, t_end=T_END, initial={"h": h0, "v": v0}, rtol=1e-10,
                                 atol=1e-12)
        grid = np.linspace(0.0, sim.final.t, 2001)
        inside = result.covers(grid, sim(grid).T, [sim.mode_at(t) for t in grid], tol=1e-7)
        if not inside.all():
            print(f"  simulation from h0={h0:.3f}, v0={v0:.3f} leaves the flowpipe at "
                  f"t={grid[~inside][0]:.4f}")
            inside_all = False
        sims.append(sim)
    print(f"{len(sims)} simulations x 2001 instants inside the flowpipes: "
          f"{'yes' if inside_all else 'NO'}")
    ok &= inside_all

    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4))
        result.plot("h", "v", ax=ax1, traces=sims)
        result.plot("t", "h", ax=ax2, traces=sims)
        ax1.set_title("flowpipes in (h, v)")
        ax2.set_title("height over time")
        fig.tight_layout()
        fig.savefig(args.plot, dpi=110)
        print(f"wrote {args.plot}")
    print("all checks passed" if ok else "CHECK FAILED")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
