"""Identify the trolley's pendulum geometry and drive gain from the paper's published numbers.

The paper (Ruderman et al.) never gives the pendulum's rod mass, length or load position,
nor how the controller output maps to force. It does publish summary quantities of its
experiments and simulations, and ``hybridlab.identify.fit_targets`` fits model parameters
to exactly such numbers:

* geometry (``m_r``, ``L_r``, ``l_l``) from the design period "about 1 s" (Sec. II) and
  the free-drop zero-crossing counts: 63 simulated with the nominal bearing friction
  (Sec. III-C), about 83 (Sec. III-C) and 86 (Table IV) with the identified one, 52 with
  the 0.5 kg load (Table IV);
* the drive gain ``K_u`` from the 10 mm step: overshoot 5.9 % and 2 % settling time
  0.067 s with the 1 kg load (Table IV).

Every fit starts from deliberately wrong values. The free drops run with the pivot held
fixed (cart mass 1e6 kg, controller and cart friction off, sensors moved away): the
paper's counts come from a pendulum simulation, the held cart of the model's
``free_drop`` scenarios changes the continuous count by about 0.1, and the fixed pivot
is about five times cheaper to simulate.

By default (what CI runs, about 15 parameter points) the rod length is fixed at the
model's 0.29 m and ``m_r`` and ``l_l`` are fitted to the period and the 63 / 52 counts;
``--full`` fits all three geometry parameters to all five numbers, and ``K_u`` to all
four Table IV step numbers (both loads), in a few minutes.

Usage::

    python examples/identify_trolley_geometry.py [--full] [--plot FILE.png] [--out FIT.json]

Exits with status 1 if an estimate is further from the model's value than the
tolerance stated below.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import hybridlab
from hybridlab.identify import Target, fit_targets
from hybridlab.identify._report import axes, save_figure, write_json

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "models" / "trolley.toml"
#: The pendulum on a fixed pivot: no cart motion, no sensor events.
FIXED_PIVOT = {"m_C": 1e6, "controller": 0.0, "c": 0.0, "d": 0.0, "p_1": 10.0}
HALF_LOAD = {"m_l": 0.5, "m_C": 3.0}
SIM = {"rtol": 1e-6, "atol": 1e-8}
#: Relative distance from the model's value accepted for each estimate (exit status).
TOLERANCE = {"m_r": 0.25, "L_r": 0.25, "l_l": 0.05, "K_u": 0.03}


def geometry_targets(full: bool) -> list[Target]:
    period = Target("interval", 1.0, 0.05, observable="phi", direction=1,
                    scenario="free_drop", params={"a_b": 0.0, "b_b": 0.0},
                    initial={"phi": 0.02}, t_end=5.0, name="period, small swing (Sec. II)")
    nominal = Target("count", 63, 1.0, observable="phi", scenario="free_drop_nominal",
                     name="crossings, nominal a = 0.04 N m (Sec. III-C)")
    half = Target("count", 52, 2.0, observable="phi", scenario="free_drop",
                  params=HALF_LOAD, name="crossings, 0.5 kg load (Tab. IV)")
    if not full:
        return [period, nominal, half]
    return [period, nominal,
            Target("count", 83, 3.0, observable="phi", scenario="free_drop",
                   name="crossings, identified a, b (Sec. III-C)"),
            Target("count", 86, 3.0, observable="phi", scenario="free_drop",
                   name="crossings, 1 kg load (Tab. IV)"),
            half]


def step_targets(full: bool) -> list[Target]:
    out = [Target("overshoot", 5.9, 0.3, observable="x", final="x_s", scenario="step",
                  name="overshoot, 1 kg (Tab. IV)"),
           Target("settling_time", 0.067, 0.003, observable="x", final="x_s",
                  scenario="step", name="settling time, 1 kg (Tab. IV)")]
    if full:
        out += [Target("overshoot", 4.5, 0.3, observable="x", final="x_s", scenario="step",
                       params=HALF_LOAD, name="overshoot, 0.5 kg (Tab. IV)"),
                Target("settling_time", 0.063, 0.003, observable="x", final="x_s",
                       scenario="step", params=HALF_LOAD, name="settling time, 0.5 kg (Tab. IV)")]
    return out


def pendulum_numbers(p: dict[str, float], g: float = 9.81, m_l: float = 1.0) -> dict:
    """The identifiable combinations: m g l_c, J and the period of small swings."""
    mgl = g * (p["m_r"] * p["L_r"] / 2 + m_l * p["l_l"])
    inertia = p["m_r"] * p["L_r"] ** 2 / 3 + m_l * p["l_l"] ** 2
    return {"mgl_c": mgl, "J": inertia, "T0": 2 * math.pi * math.sqrt(inertia / mgl)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--full", action="store_true",
                        help="fit m_r, L_r and l_l to all five numbers, K_u to both loads")
    parser.add_argument("--plot", type=Path, help="PNG of the residuals before and after")
    parser.add_argument("--out", type=Path, help="write both fits as JSON")
    args = parser.parse_args(argv)
    started = time.perf_counter()

    compiled = hybridlab.compile_model(hybridlab.load_model(MODEL))
    model = dict(zip(compiled.parameter_names, compiled.parameter_vector(), strict=True))

    geo_fit = ["m_r", "L_r", "l_l"] if args.full else ["m_r", "l_l"]
    geo_start = {"m_r": 0.5, "L_r": 0.4, "l_l": 0.35}
    geometry = fit_targets(compiled, geometry_targets(args.full), fit=geo_fit,
                           params=FIXED_PIVOT, initial_guess={n: geo_start[n] for n in geo_fit},
                           max_evaluations=40 if args.full else 20, simulation_options=SIM)
    print("== pendulum geometry ==")
    print(geometry.table())
    found = {**{n: model[n] for n in ("m_r", "L_r", "l_l")}, **geometry.parameters}
    ours, theirs = pendulum_numbers(found), pendulum_numbers(model)
    print("identifiable combinations (estimate / model): " + ", ".join(
        f"{k} {ours[k]:.4g} / {theirs[k]:.4g}" for k in ours))

    drive = fit_targets(compiled, step_targets(args.full), fit=["K_u"],
                        initial_guess={"K_u": 3.0}, max_evaluations=15)
    print("\n== drive gain ==")
    print(drive.table())

    estimates = {**geometry.parameters, **drive.parameters}
    errors = {n: v / model[n] - 1 for n, v in estimates.items()}
    print()
    for n, err in errors.items():
        se = {**geometry.uncertainties, **drive.uncertainties}[n]
        print(f"{n}: model {model[n]:.4g}, identified {estimates[n]:.4g} +- {se:.2g} "
              f"({100 * err:+.1f} %)")
    if args.out:
        write_json(args.out, {"geometry": geometry.as_dict(), "drive": drive.as_dict(),
                              "model": {n: model[n] for n in estimates},
                              "relative_error": errors, "combinations": ours})
    if args.plot:
        ax = axes(nrows=2)
        top, bottom = ax.flat
        geometry.plot(top)
        top.set_title("pendulum geometry")
        drive.plot(bottom)
        bottom.set_title("drive gain")
        save_figure(ax, args.plot)
        print(f"wrote {args.plot}")
    print(f"done in {time.perf_counter() - started:.0f} s")
    return 0 if all(abs(e) <= TOLERANCE[n] for n, e in errors.items()) else 1


if __name__ == "__main__":
    sys.exit(main())
