"""ARCH-COMP spacecraft rendezvous SRA01, proved with no option beyond the benchmark.

The linearised rendezvous of Chan and Mitra (ARCH 2017; the ARCH-COMP AFF category since
2018): 5 states, modes approaching / rendezvous / aborting, an abort at t = 120 min, a
horizon of 300 min. The model and its specs are the SpaceEx files in ``models/spaceex/``
(``spacecraft.xml``, ``spacecraft_sra01.cfg``): in rendezvous the speeds stay bounded and the
chaser inside the line-of-sight cone; after the abort it never enters the target box.

:func:`hybridlab.verify.check_safety` gets the specs, the initial set, the uncertain abort
time and the horizon only, not the ``.cfg``'s sampling time: the verdict chooses its step
(horizon / 400, halved while that tightens the failing bound; see
``docs/verification.md``, "How a verdict is reached"). Checks:

1. the verdict is SAFE, with a positive proven margin, complete over 300 min;
2. every simulated run of the falsification (run here if the proof needed none) stayed
   at least that margin away from a violation (the proof is not contradicted by the
   samples);
3. the flowpipe contains the simulated run from the centre of the initial set (400
   instants of its dense output in each mode).

Run ``python examples/reach_rendezvous.py [--plot FILE.png]``; the plot shows the reach
sets' boxes in the ``x``-``y`` plane (the chaser's position relative to the target) with
the simulated run. Exits with status 1 if a check fails.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

import hybridlab
from hybridlab.verify import VerdictStatus, check_safety

SPACEEX = Path(__file__).resolve().parents[1] / "models" / "spaceex"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", metavar="FILE.png")
    args = parser.parse_args(argv)
    problem = hybridlab.load_spaceex(SPACEEX / "spacecraft.xml", SPACEEX / "spacecraft_sra01.cfg")
    kwargs = problem.reach_kwargs()
    kwargs.pop("step")  # the verdict chooses the step
    started = time.perf_counter()
    verdict = check_safety(problem.model, safe=problem.safe_specs(), **kwargs)
    elapsed = time.perf_counter() - started
    print(f"SRA01: {verdict.status.name} in {elapsed:.1f} s; {verdict.reason}")
    ok = True
    if verdict.status is not VerdictStatus.SAFE or not verdict.margin > 0:
        print("FAIL: not proved safe")
        return 1
    if not verdict.reach.complete:
        print("FAIL: the reach result is incomplete")
        ok = False
    found = verdict.falsification
    if found is None:  # proved before any simulation: falsify now, for check 2
        print("the proof needed no simulation")
        found = check_safety(problem.model, safe=problem.safe_specs(), prove=False,
                             **kwargs).falsification
    lowest = min(found.margins.values())
    if not lowest >= verdict.margin:
        print(f"FAIL: a simulation came closer ({lowest:.6g}) than the proven margin")
        ok = False
    # the centre run against the flowpipe, at every simulated instant
    centre = {name: 0.5 * (lo + hi) for name, (lo, hi) in kwargs["initial"].items()}
    params = {name: 0.5 * (lo + hi) for name, (lo, hi) in kwargs.get("params", {}).items()}
    run = hybridlab.simulate(problem.model, initial=centre, mode=kwargs["mode"], params=params,
                             t_end=kwargs["t_end"])
    names = list(run.state_names)
    sets = verdict.reach.sets
    boxes = np.stack([rs.bounds() for rs in sets])            # (sets, states, 2)
    spans = np.array([rs.t for rs in sets])
    modes = np.array([rs.mode for rs in sets])
    instants = misses = 0
    for seg in run.segments:
        ts = np.linspace(seg.t_start, seg.t_end, 400)
        for t, y in zip(ts, seg(ts).T, strict=True):
            live = (modes == seg.mode) & (spans[:, 0] <= t) & (t <= spans[:, 1])
            inside = np.all((boxes[live, :, 0] - 1e-6 <= y) & (y <= boxes[live, :, 1] + 1e-6),
                            axis=1)
            instants += 1
            misses += not np.any(inside)
    print(f"centre run: {instants} instants, {misses} outside the flowpipe boxes")
    if misses:
        print("FAIL: the simulated run left the flowpipe")
        ok = False
    if args.plot:
        _plot(verdict.reach, run, names, args.plot)
    print("all checks passed" if ok else "some checks FAILED")
    return 0 if ok else 1


def _plot(result: hybridlab.ReachResult, run, names: list[str], path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    ix, iy = names.index("x"), names.index("y")
    fig, ax = plt.subplots(figsize=(7, 5))
    colours = {"approaching": "tab:blue", "rendezvous": "tab:green", "aborting": "tab:red"}
    for rs in result.sets:
        b = rs.bounds()
        ax.add_patch(Rectangle((b[ix, 0], b[iy, 0]), b[ix, 1] - b[ix, 0], b[iy, 1] - b[iy, 0],
                               facecolor=colours.get(rs.mode, "grey"), alpha=0.15, lw=0))
    for seg in run.segments:
        y = seg(np.linspace(seg.t_start, seg.t_end, 400))
        ax.plot(y[ix], y[iy], color="k", lw=0.8)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title("SRA01: reach sets by mode (blue approaching, green rendezvous, red aborting)")
    ax.autoscale()
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


if __name__ == "__main__":
    sys.exit(main())
