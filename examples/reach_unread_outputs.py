"""A sensor output nothing reads: left out of the flowpipe, followed only where observed.

In ``models/barrier_follower.toml`` a follower tracks a leader (``y' = 1 + 2 (x - y)``,
``x' = 1``) from ``x``, ``y`` in [0, 0.1]; a light barrier around ``x = 1`` sets ``seen``
while the leader is within 0.1 of it and clears it after. Nothing in the model reads
``seen``. Each of the barrier's two transitions fires at an instant the initial box makes
uncertain, so followed, each is a branch that may or may not have jumped, and the joined
crossings jump again and again.
Left out (the default, see ``docs/verification.md``, "Outputs nothing reads are left
out"), the flowpipe is one branch and ``seen`` lies in ``[0, 1]`` throughout. Checks:

1. left out, the spec ``|y - x| <= 0.3`` is proved (SAFE) with one flowpipe;
2. followed (``observed=("seen",)``), the analysis has more than twice the sets and runs
   into ``max_jumps`` (UNKNOWN), the tracking bound looser;
3. simulations from the initial box's corners lie in the first flowpipe, ``seen`` included.

Run ``python examples/reach_unread_outputs.py [--plot FILE.png]``; the plot shows the bounds
of ``y - x`` over time for both analyses, and the simulations. Exits with status 1 if a
check fails.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

import hybridlab
from hybridlab.verify import check_safety

MODEL = Path(__file__).resolve().parents[1] / "models" / "barrier_follower.toml"
BOX = {"x": (0.0, 0.1), "y": (0.0, 0.1)}
SPECS = ["y - x <= 0.3", "x - y <= 0.3"]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", metavar="FILE.png")
    args = parser.parse_args(argv)
    model = hybridlab.compile_model(hybridlab.load_model(MODEL))
    verdicts = {}
    for label, observed in (("left out", ()), ("followed", ("seen",))):
        v = check_safety(model, initial=BOX, t_end=2.0, step=0.01, safe=SPECS,
                         observed=observed, max_jumps=8, clustering="box")
        verdicts[label] = v
        worst = max(0.3 - b.lower for b in v.spec_bounds)
        print(f"seen {label}: {v.status.name}, {len(v.reach.sets)} sets, |y - x| <= "
              f"{worst:.3f}, seen in [{v.reach.bounds['seen'][0]:.3g}, "
              f"{v.reach.bounds['seen'][1]:.3g}]")
    out, kept = verdicts["left out"], verdicts["followed"]
    ok = out.status.name == "SAFE" and kept.status.name == "UNKNOWN"
    ok &= len(kept.reach.sets) > 2 * len(out.reach.sets)
    outside, runs = 0, []
    t = np.linspace(0.0, 2.0, 201)
    for x0 in BOX["x"]:
        for y0 in BOX["y"]:
            run = hybridlab.simulate(model, initial={"x": x0, "y": y0}, t_end=2.0)
            states = np.array([run(ti) for ti in t])
            outside += int(np.sum(~out.reach.covers(t, states, "run")))
            runs.append(states)
    print(f"simulations: {outside} samples outside the flowpipe")
    ok &= outside == 0
    if args.plot:
        _plot(verdicts, t, runs, args.plot)
    print("all checks passed" if ok else "some checks FAILED")
    return 0 if ok else 1


def _plot(verdicts, t, runs, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    fig, ax = plt.subplots(figsize=(7, 4))
    for label, colour in (("followed", "tab:red"), ("left out", "tab:blue")):
        for s in verdicts[label].reach.sets:
            d = np.array([-1.0, 1.0, 0.0])  # y - x
            lo, hi = -s.set.support(-d), s.set.support(d)
            ax.add_patch(Rectangle((s.t[0], lo), s.t[1] - s.t[0], hi - lo, color=colour,
                                   alpha=0.25, lw=0))
        ax.plot([], [], color=colour, lw=6, alpha=0.4, label=f"seen {label}")
    for states in runs:
        ax.plot(t, states[:, 1] - states[:, 0], color="black", lw=0.8)
    ax.axhline(0.3, color="grey", ls="--", lw=0.8)
    ax.axhline(-0.3, color="grey", ls="--", lw=0.8)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("y - x [m]")
    ax.set_xlim(0.0, 2.0)
    ax.set_ylim(-1.0, 1.0)
    ax.legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    print(f"wrote {path}")


if __name__ == "__main__":
    sys.exit(main())
