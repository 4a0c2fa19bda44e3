"""The trolley paper's Fig. 14 as one ensemble: residual swings against acceleration.

The event-based stop-and-return (``profile = 1`` in ``models/trolley.toml``)
is run for every acceleration ``a_max`` and both sensor positions
``p_1 = 0.10`` and ``0.25`` m with :func:`hybridlab.sweep`, in parallel over
every core. The recorded quantity is the paper's: the edges of sensor 1
(``s1_on`` and ``s1_off`` jumps) after the cart has arrived back at the
recorded position (the ``arrive`` jump), counted by
``Count(("s1_on", "s1_off"), after="arrive")``.

Usage::

    python examples/sweep_fig14.py [--fast] [--plot FILE.png] [--out FILE.csv] [--workers N]

``--fast`` (CI) takes 4 accelerations and an 8 s hold; the full sweep takes
50 accelerations from 0.25 to 3 m/s^2 and a 30 s hold. Exits non-zero unless
every run completed, one point agrees with a direct ``hybridlab.simulate``
call, and both curves rise from the lowest to the highest acceleration.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

import hybridlab
from hybridlab.ensemble import Count

MODEL = Path(__file__).resolve().parents[1] / "models" / "trolley.toml"
POSITIONS = (0.10, 0.25)
RESIDUAL = Count(("s1_on", "s1_off"), after="arrive", name="residual")


def accelerations(fast: bool) -> np.ndarray:
    return np.array([0.5, 1.0, 2.0, 3.0]) if fast else np.linspace(0.25, 3.0, 50)


def fig14_sweep(model, accel: np.ndarray, hold: float, executor=None,
                **options) -> hybridlab.SweepResult:
    """The sweep: ``p_1`` x ``a_max`` stop-and-return runs, residual edges per run."""
    return hybridlab.sweep(model, grid={"p_1": list(POSITIONS), "a_max": list(accel)},
                           params={"profile": 1.0}, t_end=12.0 + hold,
                           events=[RESIDUAL, "stop", "arrive"], executor=executor, **options)


def direct_count(model, p_1: float, a_max: float, hold: float) -> int:
    """The same number from one plain ``simulate`` call (the cross-check)."""
    result = hybridlab.simulate(model, 12.0 + hold,
                                params={"profile": 1.0, "p_1": p_1, "a_max": a_max})
    arrive = next(e.t for e in result.jumps if e.transition == "arrive")
    return sum(1 for e in result.jumps if e.transition in ("s1_on", "s1_off") and e.t > arrive)


def plot(table: hybridlab.SweepResult, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pivot = table.pivot("a_max", "p_1", "residual")
    fig, ax = plt.subplots(figsize=(6, 3.5))
    for k, p_1 in enumerate(pivot.columns):
        ax.plot(pivot.index * 1e3, pivot.values[:, k], "o-", ms=3,
                label=f"sensors at {p_1 * 1e3:.0f} mm")
    ax.set(xlabel="acceleration [mm/s^2]", ylabel="residual sensor-1 edges",
           title="Fig. 14: residual oscillation vs acceleration")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fast", action="store_true", help="4 accelerations, 8 s hold (CI)")
    parser.add_argument("--plot", type=Path, help="write the figure")
    parser.add_argument("--out", type=Path, help="write the table as CSV")
    parser.add_argument("--workers", type=int, default=None,
                        help="worker processes (default: every core)")
    args = parser.parse_args(argv)
    hold = 8.0 if args.fast else 30.0
    model = hybridlab.load_model(MODEL)
    started = time.perf_counter()
    table = fig14_sweep(model, accelerations(args.fast), hold, executor=args.workers)
    print(f"{len(table)} runs in {time.perf_counter() - started:.1f} s on {table.executor}")
    pivot = table.pivot("a_max", "p_1", "residual")
    print("a_max [m/s^2]  " + "  ".join(f"p_1={p:.2f} m" for p in pivot.columns))
    for a, counts in zip(pivot.index, pivot.values, strict=True):
        print(f"{a:13.3f}  " + "  ".join(f"{c:10.0f}" for c in counts))
    if args.out:
        table.to_csv(args.out)
        print(f"wrote {args.out}")
    if args.plot:
        plot(table, args.plot)
        print(f"wrote {args.plot}")

    k = len(table) // 2 + 1  # a run of the second sensor position
    expected = direct_count(model, float(table["p_1"][k]), float(table["a_max"][k]), hold)
    checks = {
        "every run completed": table.ok,
        "stop and arrive fired once in every run": bool(
            np.all(table["count:stop"] == 1) and np.all(table["count:arrive"] == 1)),
        "the sweep agrees with a direct simulate call": int(table["residual"][k]) == expected,
        "residual swings grow with acceleration": bool(
            np.all(pivot.values[-1] > pivot.values[0])),
    }
    for name, ok in checks.items():
        print(f"{'ok  ' if ok else 'FAIL'} {name}")
    return 0 if all(checks.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
