"""Discontinuous flows: Filippov sliding and Coulomb stick-slip.

A ``sign(...)`` in a flow is a switching surface, not something to integrate
through. This example checks two models against their analytic behaviour.

1. ``models/relay_sliding.toml``, scenario ``default``: x' = -k sign(x) from
   x = 1 with k = 1. The state reaches the surface x = 0 at t = x0 / k = 1,
   where both sides push towards it; the simulator logs one ``slide_start``
   event and keeps x at 0 (no chattering, no further events).
2. ``models/friction_oscillator.toml``: m x'' = -k x - c sign(x') with
   m = 1, k = 4, c = 0.5, from x = 1 at rest. Each half swing lasts
   pi sqrt(m / k) = pi / 2 and loses 2 c / k = 0.25 of amplitude; at every
   turning point the velocity surface v = 0 is crossed (``crossing``) while
   the spring force beats static friction (k |x| > c); at the first turning
   point where k |x| <= c the mass sticks for good (``slide_start``).

Run ``python examples/sliding_mode.py [--plot FILE.png]``. Exits with status 1
if a check fails.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

import hybridlab

MODELS = Path(__file__).resolve().parents[1] / "models"
TOL = 1e-9


def stick_slip(m: float, k: float, c: float, x0: float) -> list[tuple[float, float, str]]:
    """Turning points ``(t, x, kind)`` of the Coulomb oscillator released at rest at ``x0``."""
    half, loss = math.pi * math.sqrt(m / k), 2 * c / k
    x, out = x0, []
    while k * abs(x) > c:  # the spring beats static friction: one more half swing
        x = math.copysign(loss, x) - x  # mirror image about the shifted equilibrium
        out.append((half * (len(out) + 1), x, "crossing" if k * abs(x) > c else "slide_start"))
    return out


def check_relay() -> tuple[bool, hybridlab.SimulationResult]:
    result = hybridlab.simulate(MODELS / "relay_sliding.toml")
    print(f"relay x' = -sign(x): {result.status.name}, {len(result.events)} event(s)")
    for event in result.events:
        print(f"  t = {event.t:.15f}  {event.kind:11s} on {event.transition}")
    later = result(np.linspace(1.5, result.final.t, 8))[0]
    print(f"  max |x| on [1.5, {result.final.t:g}]: {np.abs(later).max():.1e}")
    ok = (result.status.ok and [e.kind for e in result.events] == ["slide_start"]
          and abs(result.events[0].t - 1.0) < TOL and np.abs(later).max() < TOL)
    if not ok:
        print("FAIL: expected one slide_start at t = 1 and x = 0 afterwards")
    return ok, result


def check_friction() -> tuple[bool, hybridlab.SimulationResult]:
    model = hybridlab.load_model(MODELS / "friction_oscillator.toml")
    p = {name: par.value for name, par in model.parameters.items()}
    expected = stick_slip(p["m"], p["k"], p["c"], model.states["x"].initial)
    result = hybridlab.simulate(model, rtol=1e-12, atol=1e-12)
    print(f"\nCoulomb oscillator: {result.status.name}, {len(result.events)} events "
          f"(half swing pi/2, amplitude loss 2c/k = {2 * p['c'] / p['k']:g})")
    print("  kind (expected)           t (simulated)     t = n pi/2        x (simulated)"
          "  x (exact)")
    for event, (t_ref, x_ref, kind) in zip(result.events, expected, strict=False):
        print(f"  {event.kind:11s} ({kind:11s})  {event.t:.14f}  {t_ref:.14f}  "
              f"{event.pre['x']:+.10f}  {x_ref:+.4f}")
    final = result.final.state
    print(f"  final (t = {result.final.t:g}): x = {final['x']:.1e}, v = {final['v']:.1e}")
    ok = result.status.ok and len(result.events) == len(expected)
    ok = ok and all(
        e.kind == kind and abs(e.t - t_ref) < TOL and abs(e.pre["x"] - x_ref) < TOL
        for e, (t_ref, x_ref, kind) in zip(result.events, expected, strict=True)
    )
    ok = ok and abs(final["x"] - expected[-1][1]) < 1e-8 and abs(final["v"]) < 1e-8
    if not ok:
        print("FAIL: events or final state differ from the stick-slip solution")
    return ok, result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", metavar="FILE.png", help="write plots of both runs")
    args = parser.parse_args(argv)

    ok_relay, relay = check_relay()
    ok_friction, friction = check_friction()
    if args.plot:
        plot(relay, friction, args.plot)
        print(f"wrote {args.plot}")
    ok = ok_relay and ok_friction
    print("OK" if ok else "FAILED")
    return 0 if ok else 1


def plot(relay: hybridlab.SimulationResult, friction: hybridlab.SimulationResult,
         path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 3.5))
    t, y = relay.sample(0.01)
    ax1.plot(t, y[0])
    ax1.plot([e.t for e in relay.events], [0.0] * len(relay.events), "ro", label="slide_start")
    ax1.set(title="relay x' = -sign(x)", xlabel="t", ylabel="x")
    ax1.legend()
    t, y = friction.sample(0.01)
    ax2.plot(t, y[0], label="x")
    ax2.plot(t, y[1], lw=0.8, label="v")
    ax2.plot([e.t for e in friction.events], [e.pre["x"] for e in friction.events], "ko",
             ms=4, label="v = 0 events")
    ax2.set(title="Coulomb friction oscillator", xlabel="t")
    ax2.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
