"""Stick and slip as phases of a flowpipe: a friction oscillator from a box of states.

``models/friction_oscillator.toml`` is a unit mass on a spring (``k = 4``) with Coulomb
friction ``c = 0.5``: each half swing loses ``2 c / k = 0.25`` of amplitude, and the mass
sticks for good where the spring cannot beat the friction, ``|x| <= c / k = 0.125``.
From ``x`` in [0.9, 1.1] and ``v`` in [-0.1, 0.1] the velocity set lies across ``v = 0``
at every turn. :func:`hybridlab.reach` splits it there and follows each side's flow, and
the sliding flow on the surface, as phases (``docs/verification.md``, "Stick and slip as
phases"); with ``sign_phases=False`` the friction's sign is free wherever the set meets the
surface. Checks:

1. with phases the result is complete, and over the last two seconds every set is stuck:
   ``|v| <= 1e-9`` and ``|x| <= 0.125``, the band where friction can hold the mass;
2. with the sign free the same flowpipe is more than 1 m wide in ``x`` at ``t = 10``;
3. simulations from the box's corners and centre lie in the phased flowpipe at 201
   instants each.

Run ``python examples/reach_friction_phases.py [--plot FILE.png]``; the plot shows the
position bounds of both flowpipes over time with the simulations on top. Exits with status
1 if a check fails.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

import hybridlab
from hybridlab.reachability.options import ReachOptions

MODEL = Path(__file__).resolve().parents[1] / "models" / "friction_oscillator.toml"
BOX = {"x": (0.9, 1.1), "v": (-0.1, 0.1)}
T_END = 10.0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", metavar="FILE.png")
    args = parser.parse_args(argv)
    phased = hybridlab.reach(MODEL, initial=BOX, t_end=T_END)
    free = hybridlab.reach(MODEL, initial=BOX, t_end=T_END,
                           options=ReachOptions(sign_phases=False))
    late = np.stack([s.bounds() for s in phased.sets if s.t[0] >= T_END - 2.0])
    x_lo, x_hi = late[:, 0, 0].min(), late[:, 0, 1].max()
    v_most = np.abs(late[:, 1]).max()
    print(f"phases: {len(phased.sets)} sets in {phased.time_s:.2f} s; over the last 2 s "
          f"x in [{x_lo:.4f}, {x_hi:.4f}], |v| <= {v_most:.1e}")
    ok = phased.complete and v_most <= 1e-9 and x_lo >= -0.125 and x_hi <= 0.125
    end = np.stack([s.bounds() for s in free.sets_at(T_END)])
    width = end[:, 0, 1].max() - end[:, 0, 0].min()
    print(f"sign free: {len(free.sets)} sets in {free.time_s:.2f} s; x at t = {T_END:g} "
          f"spans {width:.2f} m")
    ok &= width > 1.0
    times = np.linspace(0.0, T_END, 201)
    runs = []
    for x0, v0 in [(0.9, -0.1), (0.9, 0.1), (1.1, -0.1), (1.1, 0.1), (1.0, 0.0)]:
        run = hybridlab.simulate(MODEL, initial={"x": x0, "v": v0}, t_end=T_END,
                                 rtol=1e-10, atol=1e-12)
        states = np.array([run(t) for t in times])
        runs.append(states)
        ok &= bool(phased.covers(times, states, tol=1e-7).all())
    print(f"simulations: {len(runs)} runs, each inside the phased flowpipe: "
          f"{'yes' if ok else 'NO'}")
    if args.plot:
        _plot(phased, free, times, runs, args.plot)
    print("all checks passed" if ok else "some checks FAILED")
    return 0 if ok else 1


def _plot(phased: hybridlab.ReachResult, free: hybridlab.ReachResult, times: np.ndarray,
          runs: list[np.ndarray], path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    fig, ax = plt.subplots(figsize=(8, 4))
    for result, colour, label in ((free, "tab:red", "sign free"),
                                  (phased, "tab:blue", "stick and slip as phases")):
        for s in result.sets:
            lo, hi = s.bounds()[0]
            ax.add_patch(Rectangle((s.t[0], lo), s.t[1] - s.t[0], hi - lo,
                                   facecolor=colour, alpha=0.25, lw=0))
        ax.plot([], [], color=colour, lw=6, alpha=0.4, label=label)
    for states in runs:
        ax.plot(times, states[:, 0], color="k", lw=0.7)
    ax.axhspan(-0.125, 0.125, color="0.85", zorder=0, label="|x| <= c/k: friction holds")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("x [m]")
    ax.set_ylim(-1.5, 1.5)
    ax.set_title("friction oscillator from a box: position reach sets")
    ax.legend(loc="upper right", fontsize=8)
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


if __name__ == "__main__":
    sys.exit(main())
