"""Coupled Van der Pol oscillators: the initial set bisected only where, and along what, it fails.

The ARCH-COMP NLN benchmark CVDP23: two Van der Pol oscillators (mu = 1) coupled by
``b (x2 - x1)``, ``b`` in [1, 3], from ``x1, x2`` in [1.25, 1.55], ``y1, y2`` in [2.35, 2.45].
Five uncertain directions make the Taylor models' default degree 3, and the whole box's
model outgrows its error terms at t = 3.66. ``split="auto"`` cuts the failing piece along the
direction its Taylor model bends most (``docs/verification.md``, "Targeted splitting"):
``b``, whose effect is purely nonlinear here (at the box's centre the oscillators are in
phase, so the coupling vanishes), although it moves no state linearly. Checks:

1. the whole box fails before the horizon and names ``b`` as the direction to cut;
2. ``split="auto"`` gets every piece to the horizon, each piece a slice of ``b``'s range
   with the four states' full ranges (no state was cut);
3. simulations from the box's corners and random points lie in the flowpipe at 91 instants.

At degree 3 the two pieces' bounds widen again after t = 4 (the plot shows it); the proof
over the benchmark's 7 s takes degree 4 and 18 pieces (``check_safety`` raises the degree
and bisects further on its own; about 4 minutes).

Run ``python examples/reach_targeted_split.py [--plot FILE.png]``; the plot shows ``y1``'s
bounds over time, one band per piece, with the simulations. Exits with status 1 if a check
fails.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

import hybridlab
from hybridlab.io import load_spaceex

MODELS = Path(__file__).resolve().parents[1] / "models" / "spaceex"
T_END = 4.5
STEP = 0.0175  # the default step of the benchmark's horizon (7 s / 400)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", metavar="FILE.png")
    args = parser.parse_args(argv)
    problem = load_spaceex(MODELS / "coupled_vanderpol.xml", MODELS / "coupled_vanderpol.cfg")
    box = problem.reach_kwargs()["initial"]
    kwargs = dict(initial=box, mode="osc", t_end=T_END, step=STEP, flowpipe="taylor")
    whole = hybridlab.reach(problem.model, **kwargs)
    reached = max(s.t[1] for s in whole.sets)
    direction = whole.split_direction
    named = None if direction is None else whole.state_names[int(np.argmax(np.abs(direction)))]
    print(f"whole box: complete={whole.complete}, reached t = {reached:.3f}; "
          f"bends most along {named}")
    ok = not whole.complete and named == "b"

    pieces = hybridlab.reach(problem.model, split="auto", **kwargs)
    firsts = [s for s in pieces.sets if s.t[0] <= 0.0]  # each piece's first step set
    b_ranges = sorted((round(float(lo), 6), round(float(hi), 6)) for lo, hi in
                      (s.bounds()[pieces.state_names.index("b")] for s in firsts))
    print(f"split='auto': complete={pieces.complete}, {pieces.pieces} pieces, "
          f"{len(pieces.sets)} sets, {pieces.time_s:.1f} s; b ranges {b_ranges}")
    x1 = pieces.state_names.index("x1")
    whole_x1 = all(s.bounds()[x1, 0] <= 1.25 and s.bounds()[x1, 1] >= 1.55 for s in firsts)
    ok &= pieces.complete and pieces.pieces == len(firsts) and whole_x1

    names = pieces.state_names
    lo = np.array([box[n][0] for n in names])
    hi = np.array([box[n][1] for n in names])
    rng = np.random.default_rng(1)
    starts = np.vstack([lo + (hi - lo) * rng.integers(0, 2, (6, len(names))),
                        lo + (hi - lo) * rng.uniform(size=(6, len(names)))])
    t = np.linspace(0.0, T_END, 91)
    runs, misses = [], 0
    for z0 in starts:
        run = hybridlab.simulate(problem.model, initial=dict(zip(names, z0, strict=True)),
                                 t_end=T_END, rtol=1e-10, atol=1e-12)
        states = np.array([run(ti) for ti in t])
        runs.append(states)
        misses += int(np.count_nonzero(~pieces.covers(t, states)))
    print(f"simulations: {misses} of {len(starts) * t.size} instants outside the flowpipe")
    ok &= misses == 0
    if args.plot:
        _plot(pieces, t, runs, args.plot)
    print("all checks passed" if ok else "some checks FAILED")
    return 0 if ok else 1


def _plot(result: hybridlab.ReachResult, t: np.ndarray, runs: list[np.ndarray],
          path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    y1 = result.state_names.index("y1")
    fig, ax = plt.subplots(figsize=(7, 4))
    for s in result.sets:
        lo, hi = s.bounds()[y1]
        ax.fill_between(s.t, lo, hi, color="tab:blue", alpha=0.15, lw=0)
    for states in runs:
        ax.plot(t, states[:, y1], color="k", lw=0.7)
    ax.axhline(2.75, color="tab:red", lw=1, label="y1 = 2.75 (unsafe above)")
    ax.set_xlabel("t")
    ax.set_ylabel("y1")
    ax.set_title(f"Coupled Van der Pol: {result.pieces} pieces of the box, split='auto'")
    ax.legend(loc="lower left")
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


if __name__ == "__main__":
    sys.exit(main())
