"""Import a SpaceEx model and its .cfg, simulate it, and falsify its forbidden set.

Loads ``models/spaceex/bouncing_ball.xml`` (the SpaceEx "bball" example: x' = v,
v' = -g, bounce v := -c*v at x <= 0 with g = 1, c = 0.75) with two configurations:

* ``bouncing_ball.cfg``: initial x in [10, 10.2], v = 0, forbidden x >= 10.25;
* ``bouncing_ball_fast.cfg``: the same initial set, forbidden v <= -4.5.

It prints the imported model as TOML (what ``hybridlab import spaceex`` prints), checks
the first impact of the run from the centre of the initial set against the closed form
t1 = sqrt(2 x0 / g), v1 = -sqrt(2 g x0), and runs the falsification half of
``hybridlab.verify.check_safety`` (``prove=False``, no flowpipes) on both properties:
the second is violated by the trajectories from x0 > 10.125 (impact speed
sqrt(2 g x0) > 4.5), the first by none.

Run ``python examples/import_spaceex.py [--plot FILE.png]``. Exits with status 1 if a
check fails.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import hybridlab
from hybridlab.io import load_spaceex, problem_header
from hybridlab.verify import check_safety

HERE = Path(__file__).resolve().parents[1] / "models" / "spaceex"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", metavar="FILE.png", help="write a plot of x(t)")
    args = parser.parse_args()

    problem = load_spaceex(HERE / "bouncing_ball.xml", HERE / "bouncing_ball.cfg")
    print(problem_header(problem))
    print(hybridlab.dumps_model(problem.model))

    result = hybridlab.simulate(problem.model, 10.0)
    x0, g, c = 10.1, 1.0, 0.75
    t1 = math.sqrt(2 * x0 / g)
    first = result.jumps[0]
    ok = abs(first.t - t1) < 1e-9 and abs(first.post["v"] - c * math.sqrt(2 * g * x0)) < 1e-9
    print(f"first impact at t={first.t:.12g} (closed form {t1:.12g}), "
          f"v after it {first.post['v']:.12g}")

    kwargs = problem.reach_kwargs()
    verdict = check_safety(problem.model, safe=problem.safe_specs(), prove=False, **kwargs)
    print(f"{problem.forbidden[0].relations[0]}: {verdict.status.name} (no flowpipes: "
          f"{verdict.reason.split(';')[-1].strip()})")
    ok &= verdict.status.name == "UNKNOWN"  # not violated by any simulation

    fast = load_spaceex(HERE / "bouncing_ball.xml", HERE / "bouncing_ball_fast.cfg")
    verdict = check_safety(fast.model, safe=fast.safe_specs(), prove=False,
                           **fast.reach_kwargs())
    cx = verdict.counterexample
    print(f"{fast.forbidden[0].relations[0]}: {verdict.status.name}"
          + (f" at t={cx.t:.6g} from x0={cx.initial['x']:.6g}" if cx else ""))
    ok &= verdict.status.name == "UNSAFE" and cx is not None and cx.initial["x"] > 10.125

    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 3))
        ax.plot(result.t, result.y[0])
        ax.set_xlabel("t")
        ax.set_ylabel("x")
        ax.set_title("SpaceEx bouncing ball imported into hybridlab")
        fig.tight_layout()
        fig.savefig(args.plot)
        print(f"wrote {args.plot}")
    print("OK" if ok else "FAILED")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
