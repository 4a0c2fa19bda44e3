"""Van der Pol from the ARCH-COMP box, proved safe in one piece with Taylor models.

The ARCH-COMP NLN benchmark VDP (mu = 1): ``x' = y``, ``y' = (1 - x^2) y - x`` from
``x`` in [1.25, 1.55], ``y`` in [2.35, 2.45], for 7 s, must keep ``y < 2.75``. Conservative
linearisation outgrows its remainder on this box part-way round the cycle; Taylor-model
flowpipes keep the set's curvature and go round in one piece (see ``docs/verification.md``,
"Nonlinear modes: Taylor models"). Checks:

1. ``check_safety`` with no option beyond the SpaceEx files answers SAFE, by Taylor models;
2. its proven bound on ``y`` is below 2.75 and above every simulated ``y`` (sound);
3. simulations from the corners and the centre of the box lie in the flowpipe at 141
   instants each.

Run ``python examples/reach_vanderpol_taylor.py [--plot FILE.png]``; the plot shows the
reach sets' boxes in the ``(x, y)`` plane with the simulations on top. Exits with status 1 if
a check fails.
"""

from __future__ import annotations

import argparse
import itertools
import sys
from pathlib import Path

import numpy as np

import hybridlab
from hybridlab.io import load_spaceex
from hybridlab.verify import VerdictStatus, check_safety

MODELS = Path(__file__).resolve().parents[1] / "models" / "spaceex"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", metavar="FILE.png")
    args = parser.parse_args(argv)
    problem = load_spaceex(MODELS / "vanderpol.xml", MODELS / "vanderpol.cfg")
    kwargs = problem.reach_kwargs()
    kwargs.pop("step", None)  # the benchmark's own step is not an option of the proof
    verdict = check_safety(problem.model, safe=problem.safe_specs(), **kwargs)
    print(f"verdict: {verdict.status.name}: {verdict.reason[:160]}")
    ok = verdict.status is VerdictStatus.SAFE and "taylor" in verdict.reason
    result = verdict.reach  # the flowpipe that proved it
    if result is None:
        print("some checks FAILED: the verdict kept no reach result")
        return 1
    y_hi = result.bounds["y"][1]
    starts = list(itertools.product((1.25, 1.55), (2.35, 2.45))) + [(1.4, 2.4)]
    t = np.linspace(0.0, 7.0, 141)
    simulated, misses = -np.inf, 0
    runs = []
    for x0, y0 in starts:
        run = hybridlab.simulate(problem.model, initial={"x": x0, "y": y0}, t_end=7.0,
                                 rtol=1e-10, atol=1e-12)
        states = np.array([run(ti) for ti in t])
        runs.append(states)
        simulated = max(simulated, float(states[:, 1].max()))
        misses += int(np.count_nonzero(~result.covers(t, states)))
    print(f"{len(result.sets)} sets; y <= {y_hi:.4f} proven (limit 2.75), simulated maximum "
          f"{simulated:.4f}; simulations: {misses} of {len(starts) * t.size} instants outside")
    ok &= simulated <= y_hi < 2.75 and misses == 0
    if args.plot:
        _plot(result, runs, args.plot)
    print("all checks passed" if ok else "some checks FAILED")
    return 0 if ok else 1


def _plot(result: hybridlab.ReachResult, runs: list[np.ndarray], path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    fig, ax = plt.subplots(figsize=(6, 5))
    for s in result.sets:
        (x_lo, x_hi), (y_lo, y_hi) = s.bounds()
        ax.add_patch(Rectangle((x_lo, y_lo), x_hi - x_lo, y_hi - y_lo,
                               facecolor="tab:blue", alpha=0.2, lw=0))
    for states in runs:
        ax.plot(states[:, 0], states[:, 1], color="k", lw=0.8)
    ax.axhline(2.75, color="tab:red", lw=1, label="y = 2.75 (unsafe above)")
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.set_title("Van der Pol: Taylor-model reach sets and simulations")
    ax.legend(loc="lower right")
    ax.autoscale()
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


if __name__ == "__main__":
    sys.exit(main())
