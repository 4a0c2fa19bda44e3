"""Thermostat: switching times against the exponential solution, and the mode trace.

Loads ``models/thermostat.toml``: the room temperature T follows
T' = -a (T - T_heat) in mode ``heat`` and T' = -a (T - T_out) in mode ``cool``;
the heater turns off at T_high and on at T_low. Each phase is an exponential,
so the time to go from T_1 to T_2 towards the asymptote T_inf is

    ln((T_1 - T_inf) / (T_2 - T_inf)) / a.

The run starts at T = 20 in ``heat``. The example compares every switching
time of scenario ``default`` (60 min) with the sum of these phase durations
and prints the mode trace ``(t_start, j, mode)`` of the hybrid time domain.

Run ``python examples/thermostat.py [--plot FILE.png]``. Exits with status 1 if
a switching time is off by more than 1e-9 min.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

import hybridlab

MODEL = Path(__file__).resolve().parents[1] / "models" / "thermostat.toml"
TOL = 1e-9  # min, with rtol = atol = 1e-12


def switching_times(p: dict[str, float], T0: float, count: int) -> np.ndarray:
    """Closed-form switching times, starting in ``heat`` below ``T_high``."""

    def duration(start: float, stop: float, asymptote: float) -> float:
        return math.log((start - asymptote) / (stop - asymptote)) / p["a"]

    heating = duration(p["T_low"], p["T_high"], p["T_heat"])
    cooling = duration(p["T_high"], p["T_low"], p["T_out"])
    times = [duration(T0, p["T_high"], p["T_heat"])]
    while len(times) < count:
        times.append(times[-1] + (cooling if len(times) % 2 else heating))
    return np.array(times)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", metavar="FILE.png", help="write a plot of T(t) and the mode")
    args = parser.parse_args(argv)

    model = hybridlab.load_model(MODEL)
    p = {name: par.value for name, par in model.parameters.items()}
    result = hybridlab.simulate(model, rtol=1e-12, atol=1e-12)
    times = np.array([event.t for event in result.jumps])
    expected = switching_times(p, model.states["T"].initial, times.size)
    error = np.abs(times - expected)

    print(f"status {result.status.name}; {times.size} switches in {result.final.t:g} min")
    print("mode trace (t_start, j, mode), first 6 of", len(result.mode_trace()))
    for t_start, j, mode in result.mode_trace()[:6]:
        print(f"  {t_start:10.6f}  {j:2d}  {mode}")
    print("switch   t (simulated)        t (closed form)      |error|")
    for event, t_ref, err in list(zip(result.jumps, expected, error, strict=True))[:4]:
        print(f"  {event.transition:8s} {event.t:.15f}  {t_ref:.15f}  {err:.1e}")
    print(f"  ... max |error| over {times.size} switches: {error.max():.1e} min")

    ok = result.status is hybridlab.Status.COMPLETED and times.size == 20
    if not ok:
        print(f"FAIL: expected 20 switches and COMPLETED, got {times.size}, {result.status.name}")
    names = [event.transition for event in result.jumps]
    if names != ["turn_off", "turn_on"] * (times.size // 2):
        print(f"FAIL: switches do not alternate: {names}")
        ok = False
    if error.max() > TOL:
        print(f"FAIL: switching time error {error.max():.2e} > {TOL:g}")
        ok = False
    # between switches the temperature stays within the hysteresis band
    t_grid, y = result.sample(0.01)
    if not (p["T_low"] - 1e-9 <= y[0].min() and y[0].max() <= p["T_high"] + 1e-9):
        print(f"FAIL: T left [T_low, T_high]: [{y[0].min()}, {y[0].max()}]")
        ok = False

    if args.plot:
        plot(result, p, args.plot)
        print(f"wrote {args.plot}")
    print("OK" if ok else "FAILED")
    return 0 if ok else 1


def plot(result: hybridlab.SimulationResult, p: dict[str, float], path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t, y = result.sample(0.05)
    heating = np.array([result.mode_at(tk) == "heat" for tk in t])
    fig, ax = plt.subplots(figsize=(8, 3.5))
    ax.plot(t, y[0], lw=1.2, label="T(t)")
    ax.fill_between(t, p["T_low"], p["T_high"], where=heating, color="tab:red", alpha=0.15,
                    label="heater on")
    for level in (p["T_low"], p["T_high"]):
        ax.axhline(level, color="k", lw=0.6, ls=":")
    ax.set_xlabel("t [min]")
    ax.set_ylabel("T [degC]")
    ax.legend(loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
