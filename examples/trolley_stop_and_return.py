"""The trolley's event-based stop-and-return, from the one declarative model.

The cart accelerates towards two photoelectric sensors fixed on the frame.
When sensor 1 sees the screw at the bottom of the pendulum rod (a guard on
the rod tip's horizontal position), a transition records the cart position
in its reset and switches to a braking trajectory computed at that instant;
the cart stops, returns to the recorded position and holds there, while the
sensors count the residual swings of the load.

Usage::

    python examples/trolley_stop_and_return.py [--plot FILE.png] [--sensor M] [--accel A]

Exits non-zero if the cart does not come back to within 0.5 mm of the
recorded position.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

import hybridlab

MODEL = Path(__file__).resolve().parents[1] / "models" / "trolley.toml"


def plot_stop_and_return(result, path: Path, t_max: float | None = None) -> None:
    """Cart position, pendulum angle and sensor pulses of a stop-and-return run."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(result.state_names)
    ts, ys = result.sample(1e-3)
    if t_max is not None:
        keep = ts <= t_max
        ts, ys = ts[keep], ys[:, keep]
    fig, (a1, a2, a3) = plt.subplots(3, 1, figsize=(7, 6.5), sharex=True)
    a1.plot(ts, ys[names.index("x")] * 1e3, label="cart x")
    a1.plot(ts, result.observe("x_ref", ts) * 1e3, "--", lw=0.8, label="reference")
    stop = next(e for e in result.jumps if e.transition == "stop")
    a1.axhline(stop.post["x_e"] * 1e3, color="gray", lw=0.6, label="recorded x_e")
    a1.axvline(stop.t, color="red", lw=0.6)
    a1.set(ylabel="x [mm]", title="Event-based stop-and-return")
    a1.legend(loc="lower right", fontsize=8)
    a2.plot(ts, np.degrees(ys[names.index("phi")]), lw=0.8)
    a2.set(ylabel="phi [deg]")
    a3.step(ts, ys[names.index("S_1")], where="post", label="sensor 1")
    a3.step(ts, ys[names.index("S_2")] + 1.2, where="post", label="sensor 2")
    a3.set(xlabel="t [s]", ylabel="pulses", yticks=[])
    a3.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", type=Path, help="write the figure here (PNG)")
    parser.add_argument("--sensor", type=float, default=0.25, help="sensor 1 position [m]")
    parser.add_argument("--accel", type=float, default=1.0, help="acceleration [m/s^2]")
    parser.add_argument("--hold", type=float, default=10.0, help="time held after the run [s]")
    args = parser.parse_args(argv)

    started = time.perf_counter()
    model = hybridlab.load_model(MODEL)
    compiled = hybridlab.compile_model(model)
    compiled_at = time.perf_counter()
    result = hybridlab.simulate(compiled, params={"p_1": args.sensor, "a_max": args.accel},
                                t_end=3.0 + args.hold)
    elapsed = time.perf_counter() - compiled_at
    stop = next((e for e in result.jumps if e.transition == "stop"), None)
    arrive = next((e for e in result.jumps if e.transition == "arrive"), None)
    print(f"model {model.name!r}: {len(model.modes)} modes, {len(model.transitions)} transition "
          f"declarations; compiled in {compiled_at - started:.1f} s, simulated in {elapsed:.1f} s")
    print(f"status: {result.status.name} ({result.message})")
    if stop is None or arrive is None:
        print("the sensor never saw the screw: no stop-and-return happened")
        return 1
    x_e = stop.post["x_e"]
    error_mm = 1e3 * (result.final.state["x"] - x_e)
    residual = [e for e in result.jumps if e.transition in ("s1_on", "s1_off") and e.t > arrive.t]
    swing = np.degrees(np.abs(result(np.linspace(arrive.t, result.final.t, 2000))[2]).max())
    print(f"sensor event:   t = {stop.t:.6f} s, cart at x_e = {1e3 * x_e:.3f} mm "
          f"(sensor 1 at {1e3 * args.sensor:.0f} mm, acceleration {args.accel:g} m/s^2)")
    print(f"back and held:  t = {arrive.t:.4f} s; cart at rest {error_mm:+.4f} mm from x_e")
    print(f"residual swing: {len(residual)} sensor-1 edges after arrival, "
          f"max |phi| {swing:.2f} deg")
    if args.plot:
        plot_stop_and_return(result, args.plot, t_max=arrive.t + min(args.hold, 6.0))
        print(f"wrote {args.plot}")
    return 0 if abs(error_mm) < 0.5 else 1


if __name__ == "__main__":
    sys.exit(main())
