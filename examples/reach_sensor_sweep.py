"""A sensor event in a flowpipe: the tracking error survives the jump.

In ``models/sensor_follower.toml`` a leader moves at unit speed from ``x`` in [0, 0.5] and a
follower tracks it (``y' = 1 + 2 (x - y)``, ``y`` in [0, 0.5]); a light barrier at ``x = 1``
records ``e = x``. The barrier fires over half a second across the initial box, so the step
sets that hit its guard form a long run, in which ``x`` and ``y`` both sweep by 0.5. A box
of that whole run would forget that ``y`` moves with ``x``. But a guard is urgent: every
trajectory fires where ``x`` comes up to 1, so each step set is cut down to that surface
first (``docs/verification.md``, "The hybrid layer"). On the surface ``y - x`` is what the
flow made it, whether the run is then joined into one box (``clustering="box"``) or into
one zonotope that keeps the flowpipe's generators and adds the run's sweep
(``clustering="sweep"``). Both checks keep the initial set whole (``split=1``). Checks:

1. with either join, the spec ``|y - x| <= 0.3`` after the jump is proved (SAFE), with
   ``|y - x|`` bounded by less than 0.25 (the exact bound is ``0.5 e^-1 = 0.18``);
2. the recorded position ``e`` is 1 to within ``1e-9`` in the latched mode;
3. simulations from the initial box's corners lie in the sweep's flowpipe after the jump.

Run ``python examples/reach_sensor_sweep.py [--plot FILE.png]``; the plot shows the bounds of
``y - x`` over time in the latched mode for both joins, and the simulations. Exits with
status 1 if a check fails.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

import hybridlab
from hybridlab.verify import check_safety

MODEL = Path(__file__).resolve().parents[1] / "models" / "sensor_follower.toml"
BOX = {"x": (0.0, 0.5), "y": (0.0, 0.5)}
SPECS = ["latched: y - x <= 0.3", "latched: x - y <= 0.3"]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", metavar="FILE.png")
    args = parser.parse_args(argv)
    model = hybridlab.load_model(MODEL)
    verdicts = {join: check_safety(model, initial=BOX, t_end=1.5, step=0.05, safe=SPECS,
                                   clustering=join, split=1) for join in ("box", "sweep")}
    for join, v in verdicts.items():
        worst = max(0.3 - b.lower for b in v.spec_bounds)
        print(f"clustering={join!r}: {v.status.name}, |y - x| <= {worst:.3f} after the jump")
    ok = all(v.status.name == "SAFE" and max(0.3 - b.lower for b in v.spec_bounds) < 0.25
             for v in verdicts.values())
    result = verdicts["sweep"].reach
    if result is None:
        return 1
    recorded = np.array([s.bounds()[2] for s in result.sets if s.mode == "latched"])
    print(f"recorded position e in [{recorded[:, 0].min():.12f}, {recorded[:, 1].max():.12f}]")
    ok &= bool(np.all(np.abs(recorded - 1.0) <= 1e-9))
    outside = 0
    runs = []
    for x0 in (0.0, 0.5):
        for y0 in (0.0, 0.5):
            run = hybridlab.simulate(model, initial={"x": x0, "y": y0}, t_end=1.5)
            t = np.linspace(0.0, 1.5, 151)
            states = np.array([run(ti) for ti in t])
            after = states[:, 0] >= 1.0 + 1e-9
            outside += int(np.sum(~result.covers(t[after], states[after], "latched")))
            runs.append((t[after], states[after]))
    print(f"simulations: {outside} samples outside the flowpipe after the jump")
    ok &= outside == 0
    if args.plot:
        _plot(verdicts, runs, args.plot)
    print("all checks passed" if ok else "some checks FAILED")
    return 0 if ok else 1


def _plot(verdicts, runs, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    fig, ax = plt.subplots(figsize=(7, 4))
    for join, colour in (("box", "tab:red"), ("sweep", "tab:blue")):
        for s in verdicts[join].reach.sets:
            if s.mode != "latched":
                continue
            d = np.array([-1.0, 1.0, 0.0])  # y - x
            lo, hi = -s.set.support(-d), s.set.support(d)
            ax.add_patch(Rectangle((s.t[0], lo), s.t[1] - s.t[0], hi - lo, facecolor=colour,
                                   alpha=0.25, lw=0))
        ax.plot([], [], color=colour, lw=6, alpha=0.4, label=f'clustering="{join}"')
    for t, z in runs:
        ax.plot(t, z[:, 1] - z[:, 0], color="k", lw=1)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("y - x [m] after the barrier")
    ax.set_title("a light barrier fires over half a second: box and sweep on its surface")
    ax.legend()
    ax.autoscale()
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


if __name__ == "__main__":
    sys.exit(main())
