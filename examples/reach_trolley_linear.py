"""The linearised trolley proved over its stop-and-return: on its rail, and held at its target.

``models/trolley_linear.toml`` is the trolley of ``models/trolley.toml`` with its plant
linearised about the pendulum's downward rest; the controller, the sensors, the manoeuvre
logic and both friction laws (Coulomb with stick and slip, viscous) are the same
components, imported from ``trolley.toml``. From an uncertain initial swing (``phi`` in
+-0.01 rad, ``omega`` in +-0.05 rad/s) the cart accelerates, cruises, its screw enters
sensor 1's window at an uncertain instant, it brakes, stops, turns, returns and holds at
the position recorded at the sensor event, ``x_e``. Checks:

1. :func:`hybridlab.verify.check_safety` proves ``-0.05 <= x <= 0.4`` (the rail) and, while
   holding, ``|x - x_e| <= 0.5 mm`` up to ``--t-end`` (default 2.1 s: through the stop, where
   the friction's sign is free while the set lies across ``v = 0``, the turn, the return
   and into the hold), at step 0.001875 s with the guard hits joined as sweeps (keep
   ``--t-end`` a whole number of steps: a last, shorter step starts afresh from the large
   holding set, and its set is looser);
2. in the modes that hold a set point or cruise, the manoeuvre's segment start velocity
   ``v_s`` and acceleration ``a_s`` are constants, which the analysis substitutes: those
   modes' flows, bilinear in ``v_s`` and the segment's clock ``tau`` as written, become
   affine (``hybridlab.reachability.constants``); the others, polynomial in ``tau``, are
   lifted to affine flows over ``tau``'s monomials (``lift_clocks=True``,
   ``hybridlab.reachability.lifting``);
3. simulations from the corners of the initial box lie in the flowpipe at 161 instants.

``--t-end 12`` proves all four specs over the whole 12 s manoeuvre (about 30 s on two
cores; ``docs/verification.md``, Limits, has the numbers). Run
``python examples/reach_trolley_linear.py [--t-end T] [--plot FILE.png]``. Exits with
status 1 if a check fails.
"""

from __future__ import annotations

import argparse
import itertools
import sys
from pathlib import Path

import numpy as np

import hybridlab
from hybridlab.reachability.constants import mode_constants, with_constants
from hybridlab.reachability.sets import Zonotope
from hybridlab.reachability.system import build_system
from hybridlab.verify import check_safety

MODEL = Path(__file__).resolve().parents[1] / "models" / "trolley_linear.toml"
BOX = {"phi": (-0.01, 0.01), "omega": (-0.05, 0.05)}
SPECS = ["x <= 0.4", "x >= -0.05", "hold: x - x_e <= 0.0005", "hold: x_e - x <= 0.0005"]
STEP = 0.001875


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=2.1)
    parser.add_argument("--plot", metavar="FILE.png")
    args = parser.parse_args(argv)
    compiled = hybridlab.compile_model(hybridlab.load_model(MODEL))
    verdict = check_safety(compiled, initial=BOX, t_end=args.t_end, safe=SPECS, step=STEP,
                           clustering="sweep", lift_clocks=True)
    print(f"rail and hold up to t = {args.t_end:g} s: {verdict.status.name} "
          f"in {verdict.time_s:.1f} s")
    ok = verdict.safe
    result = verdict.reach
    if result is None:
        return 1
    x_lo, x_hi = result.bounds["x"]
    held = [s.bound("x - x_e") for s in result.sets
            if s.mode.endswith("logic.hold") and s.jumps > 0]
    print(f"  {len(result.sets)} sets; x in [{x_lo:.6f}, {x_hi:.4f}] m; holding after the "
          f"return, x - x_e in [{min(lo for lo, _ in held):.6f}, "
          f"{max(hi for _, hi in held):.6f}] m")

    system = build_system(compiled, compiled.parameter_vector(), {}, {})
    x0 = compiled.state_vector()
    found = mode_constants(system, compiled.model.initial.mode,
                           Zonotope(x0, np.zeros((x0.size, 0))))
    substituted = with_constants(system, found)
    for mode in ("logic.hold", "logic.approach_cruise"):
        [full] = [m for m in found if m.endswith(mode)]
        known = {system.znames[i]: v for i, v in found[full].items()
                 if system.znames[i] in ("v_s", "a_s")}
        affine = substituted.modes[full].affine and not system.modes[full].affine
        print(f"  {mode}: {known} constant, so its flow is affine: {affine}")
        ok &= affine

    times = np.linspace(0.0, args.t_end, 161)
    runs = []
    for phi, omega in itertools.product(BOX["phi"], BOX["omega"]):
        run = hybridlab.simulate(compiled, initial={"phi": phi, "omega": omega},
                                 t_end=args.t_end, rtol=1e-10, atol=1e-12)
        states = run(times).T
        runs.append(states[:, compiled.state_names.index("x")])
        modes = [run.mode_at(t) for t in times]
        ok &= bool(result.covers(times, states, modes, tol=1e-7).all())
    print(f"simulations: {len(runs)} runs, each inside the flowpipe: {'yes' if ok else 'NO'}")
    if args.plot:
        _plot(result, times, runs, args.plot)
    print("all checks passed" if ok else "some checks FAILED")
    return 0 if ok else 1


def _plot(result: hybridlab.ReachResult, times: np.ndarray, runs: list[np.ndarray],
          path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    ix = result.state_names.index("x")
    fig, ax = plt.subplots(figsize=(8, 4))
    for s in result.sets:
        lo, hi = s.bounds()[ix]
        ax.add_patch(Rectangle((s.t[0], lo), s.t[1] - s.t[0], hi - lo,
                               facecolor="tab:blue", edgecolor="tab:blue", alpha=0.25,
                               lw=0.5))
    ax.plot([], [], color="tab:blue", lw=6, alpha=0.4, label="reach sets")
    for x in runs:
        ax.plot(times, x, color="k", lw=0.7)
    ax.axhline(0.4, color="tab:red", lw=1, label="rail ends")
    ax.axhline(-0.05, color="tab:red", lw=1)
    ax.set_xlim(0.0, times[-1])
    ax.set_xlabel("t [s]")
    ax.set_ylabel("x [m]")
    ax.set_title("linearised trolley: cart position reach sets and simulations")
    ax.legend(loc="lower right", fontsize=8)
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


if __name__ == "__main__":
    sys.exit(main())
