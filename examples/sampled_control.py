"""Sampled-data control: a scheduled transition against the difference equation.

``models/sampled_control.toml`` is an integrator plant x' = u under a
proportional controller sampled every T = 0.1 s with a zero-order hold: the
transition ``sample`` has ``schedule = { period = 0.1, phase = 0.0 }`` and the
reset u := -K x. Between samples u is constant, so at the sampling instants

    x_k = x_0 (1 - K T)^k.

For each gain K the example checks that the samples fire at exactly
t_k = k T (instants are computed, never accumulated, so there is no drift),
that the state just before each sample is x_0 (1 - K T)^k, and that u is held
between samples. K = 2 (the model's default) converges monotonically, K = 15
(K T = 1.5) converges with alternating sign, K = 25 (K T = 2.5) diverges.

Run ``python examples/sampled_control.py [--plot FILE.png]``. Exits with
status 1 if a check fails.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

import hybridlab

MODEL = Path(__file__).resolve().parents[1] / "models" / "sampled_control.toml"
GAINS = (2.0, 15.0, 25.0)
TOL = 1e-12  # relative; the flow is linear in t between samples


def check(model: hybridlab.Model, K: float) -> tuple[bool, hybridlab.SimulationResult]:
    T = model.parameters["T"].value
    x0 = model.states["x"].initial
    result = hybridlab.simulate(model, params={"K": K})
    k = np.arange(len(result.jumps))
    times = np.array([event.t for event in result.jumps])
    x_pre = np.array([event.pre["x"] for event in result.jumps])
    x_ref = x0 * (1 - K * T) ** k
    time_error = np.abs(times - k * T).max()
    x_error = (np.abs(x_pre - x_ref) / np.maximum(1.0, np.abs(x_ref))).max()
    # zero-order hold: u at the middle of each sampling interval is -K x_k
    mid = result((k[:-1] + 0.5) * T)
    u_ref = -K * x_ref[:-1]
    hold_error = (np.abs(mid[1] - u_ref) / np.maximum(1.0, np.abs(u_ref))).max()
    print(f"K = {K:4g}  (1 - K T = {1 - K * T:+.2f}): {len(times)} samples, "
          f"x_20 = {x_pre[-1]:+.6e} (exact {x_ref[-1]:+.6e}); errors: "
          f"t {time_error:.0e}, x {x_error:.0e}, hold {hold_error:.0e}")
    ok = (result.status.ok and len(times) == 21 and time_error < TOL and x_error < TOL
          and hold_error < TOL)
    if not ok:
        print(f"FAIL: K = {K:g} does not follow x_k = x_0 (1 - K T)^k at t_k = k T")
    return ok, result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", metavar="FILE.png", help="write a plot of x(t) for each K")
    args = parser.parse_args(argv)

    model = hybridlab.load_model(MODEL)
    print(f"{model.name}: T = {model.parameters['T'].value:g} s, t_end = "
          f"{model.scenarios['default'].t_end:g} s (samples at t = 0, T, ..., t_end)")
    runs = {K: check(model, K) for K in GAINS}
    ok = all(passed for passed, _ in runs.values())
    if args.plot:
        plot({K: result for K, (_, result) in runs.items()}, args.plot)
        print(f"wrote {args.plot}")
    print("OK" if ok else "FAILED")
    return 0 if ok else 1


def plot(results: dict[float, hybridlab.SimulationResult], path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(results), figsize=(11, 3.2))
    for ax, (K, result) in zip(axes, results.items(), strict=True):
        t, y = result.sample(0.002)
        ax.plot(t, y[0], lw=1, label="x(t)")
        ax.plot([e.t for e in result.jumps], [e.pre["x"] for e in result.jumps], "k.",
                label="x_k")
        ax.set(title=f"K = {K:g}", xlabel="t [s]")
        ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
