"""Building a model in Python: a bouncing ball that comes to rest.

The ball of ``models/bouncing_ball.toml`` is Zeno: its impacts accumulate at
t = 12.8506 s and the simulation cannot continue past that point. A standard
regularisation is a second mode: when the ball hits the floor slower than
``v_min`` it stops (mode ``rest``) instead of bouncing. This example builds
that automaton with the Python classes (no model file), simulates it past the
accumulation time and checks:

* the run completes (status ``COMPLETED``, not ``ZENO``) and ends in ``rest``;
* the ball stops at the first impact whose incoming speed e^(k-1) v_1 is at
  most ``v_min``, at the closed-form impact time t_k (see
  ``examples/bouncing_ball.py``);
* the counter state ``n``, incremented by the ``bounce`` reset, equals k - 1;
* writing the model as TOML and reading it back gives an equal model.

It then prints the mode graph in Graphviz DOT (render it with
``dot -Tpng``).

Run ``python examples/python_api.py [--plot FILE.png]``. Exits with status 1
if a check fails.
"""

from __future__ import annotations

import argparse
import math
import sys

import hybridlab
from hybridlab import Initial, Mode, Model, Parameter, Scenario, State, Transition


def build() -> Model:
    """The bouncing ball with a rest mode, built from Python objects."""
    return Model(
        name="ball_with_rest",
        description="Bouncing ball that stops once an impact is slower than v_min",
        parameters={
            "g": Parameter(value=9.81, unit="m/s^2", description="gravitational acceleration"),
            "e": Parameter(value=0.8, description="coefficient of restitution"),
            "v_min": Parameter(value=0.5, unit="m/s", description="slowest impact that bounces"),
        },
        states={
            "h": State(initial=10.0, unit="m"),
            "v": State(initial=0.0, unit="m/s"),
            "n": 0.0,  # shorthand for State(initial=0.0): the number of bounces
        },
        modes={
            "fall": Mode(flow={"h": "v", "v": "-g", "n": "0"}, invariant="h >= 0"),
            "rest": Mode(flow={"h": "0", "v": "0", "n": "0"},
                         description="lying on the floor"),
        },
        transitions=[
            # both guards hold at a slow impact; the lower priority number wins
            Transition(name="stop", source="fall", target="rest",
                       guard="h <= 0 and -v_min <= v <= 0", reset={"h": "0", "v": "0"},
                       priority=1),
            Transition(name="bounce", source="fall", target="fall", guard="h <= 0",
                       reset={"v": "-e*v", "n": "n + 1"}, priority=2),
        ],
        initial=Initial(mode="fall"),
        scenarios={"default": Scenario(t_end=20.0, description="past the Zeno time 12.85 s")},
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", metavar="FILE.png", help="write a plot of h(t)")
    args = parser.parse_args(argv)

    model = build()
    # Round trip through TOML text. Compared before simulating: Model equality currently
    # also compares the compiled form that simulate() caches on the model.
    text = hybridlab.dumps_model(model)
    round_trip = hybridlab.loads_model(text) == model
    result = hybridlab.simulate(model)
    print(f"{model.name}: {result.status.name}: {result.message}")
    print(f"  {len(result.jumps)} jumps; last two: "
          + ", ".join(f"{e.transition} at t = {e.t:.6f} ({e.source} -> {e.target})"
                      for e in result.jumps[-2:]))
    print(f"  final: t = {result.final.t:g}, mode {result.final.mode}, "
          f"state {dict(result.final.state)}")

    g, e, v_min = (model.parameters[name].value for name in ("g", "e", "v_min"))
    t1 = math.sqrt(2 * model.states["h"].initial / g)
    v1 = g * t1
    k = 1 + math.ceil(math.log(v_min / v1) / math.log(e))  # first impact slower than v_min
    t_stop = t1 + sum(2 * e**i * v1 / g for i in range(1, k))
    stop = result.jumps[-1]
    print(f"  closed form: stops at impact {k}, t = {t_stop:.6f} "
          f"(error {abs(stop.t - t_stop):.1e} s)")

    ok = True
    if result.status is not hybridlab.Status.COMPLETED or result.final.mode != "rest":
        print("FAIL: expected a complete run ending in mode 'rest'")
        ok = False
    if stop.transition != "stop" or abs(stop.t - t_stop) > 1e-9 or len(result.jumps) != k:
        print(f"FAIL: expected 'stop' as jump {k} at t = {t_stop}")
        ok = False
    if result.final.state["n"] != k - 1:
        print(f"FAIL: bounce counter n = {result.final.state['n']}, expected {k - 1}")
        ok = False
    print(f"  TOML round trip ({len(text.splitlines())} lines): "
          f"{'equal' if round_trip else 'DIFFERENT'}")
    if not round_trip:
        print("FAIL: loads_model(dumps_model(model)) != model")
        ok = False

    print("\nmode graph (Graphviz DOT):")
    print(hybridlab.to_dot(model), end="")

    if args.plot:
        plot(result, args.plot)
        print(f"wrote {args.plot}")
    print("OK" if ok else "FAILED")
    return 0 if ok else 1


def plot(result: hybridlab.SimulationResult, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t, y = result.sample(0.002)
    fig, ax = plt.subplots(figsize=(8, 3.5))
    ax.plot(t, y[0], lw=1, label="h(t)")
    stop = result.jumps[-1]
    ax.axvline(stop.t, color="g", ls="--", lw=1, label=f"enters rest at t = {stop.t:.3f} s")
    ax.set(xlabel="t [s]", ylabel="h [m]")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
