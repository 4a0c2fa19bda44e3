"""Reproduce the trolley paper's experiments with the one declarative model.

Every number comes from simulating ``models/trolley.toml`` (scenarios and
parameter overrides only; nothing trolley-specific lives in ``hybridlab``).
The paper's values are written next to ours; ``docs/paper.md`` discusses
each. Sensor counts are edges of the modelled photoelectric sensors; "ideal"
counts are sign changes of the pendulum angle on the dense solution.

Usage::

    python examples/reproduce_paper.py --out paper.json [--plots DIR] [--fast]

``--fast`` shortens the Fig. 14 sweep (fewer accelerations, shorter hold) for CI.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

import hybridlab
from hybridlab.analysis import count_crossings, step_metrics

sys.path.insert(0, str(Path(__file__).resolve().parent))
from trolley_stop_and_return import plot_stop_and_return  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "models" / "trolley.toml"
HALF_PI = math.pi / 2

PAPER = {
    "period_s": "about 1",
    "free_drop_nominal_crossings": 63,
    "free_drop_identified_crossings": "about 83",
    "payload_1kg_crossings": 86,
    "payload_0_5kg_crossings": 52,
    "step_overshoot_pct_1kg": 5.9,
    "step_overshoot_pct_0_5kg": 4.5,
    "settling_time_s_1kg": 0.067,
    "settling_time_s_0_5kg": 0.063,
    "tracking_error_max_mm": "<= 0.14",
    "tangential_velocity_at_crossings": "decreasing",
    "stop_return_final_error_mm": "about 0",
}


def sensor_edges(result, names=("s1_on", "s2_on")) -> list[tuple[float, str]]:
    return [(e.t, e.transition) for e in result.jumps if e.transition in names]


def free_drop(compiled, params: dict, t_end: float = 60.0):
    """Pendulum dropped from 90 deg over the sensor pair, cart held by the controller."""
    result = hybridlab.simulate(compiled, scenario="free_drop", params=params, t_end=t_end)
    t, y = result.sample(1e-4)
    ideal = count_crossings(y[result.state_names.index("phi")])
    on1 = sum(1 for _, n in sensor_edges(result) if n == "s1_on")
    on2 = sum(1 for _, n in sensor_edges(result) if n == "s2_on")
    return result, ideal, min(on1, on2)


def tangential_velocity(result, compiled) -> list[dict]:
    """Eq. (7): v_t = d_s / dt from consecutive edges of the two sensors, against eq. (8)."""
    p = result.parameters
    edges = sensor_edges(result)
    out = []
    i = 0
    while i + 1 < len(edges):
        (t_a, n_a), (t_b, n_b) = edges[i], edges[i + 1]
        if n_a != n_b and t_b - t_a < 0.2:
            mid = 0.5 * (t_a + t_b)
            omega = result(mid)[result.state_names.index("omega")]
            out.append({"t": mid, "v_t_sensors": p["d_s"] / (t_b - t_a),
                        "v_t_model": abs(omega) * p["r"]})
            i += 2
        else:
            i += 1
    return out


def step_response(compiled, params: dict) -> hybridlab.analysis.StepMetrics:
    result = hybridlab.simulate(compiled, scenario="step", params=params)
    t, y = result.sample(1e-5)
    return step_metrics(t, y[0], 0.0, result.final.state["x_s"])


def stop_and_return(compiled, p_1: float, a_max: float, hold: float):
    """The event-based manoeuvre; residual crossings are sensor-1 edges after arrival."""
    result = hybridlab.simulate(compiled, params={"profile": 1.0, "p_1": p_1, "a_max": a_max},
                                t_end=12.0 + hold)
    arrive = next((e for e in result.jumps if e.transition == "arrive"), None)
    stop = next((e for e in result.jumps if e.transition == "stop"), None)
    if arrive is None or stop is None:
        return result, None, None, None
    residual = sum(1 for e in result.jumps if e.transition in ("s1_on", "s1_off")
                   and e.t > arrive.t)
    return result, stop, arrive, residual


def run(fast: bool, plots: Path | None) -> dict:
    model = hybridlab.load_model(MODEL)
    compiled = hybridlab.compile_model(model)
    out: dict = {"paper": PAPER, "model": str(MODEL.relative_to(ROOT))}
    p = compiled.parameter_vector()
    names = compiled.parameter_names
    par = dict(zip(names, p, strict=True))

    # -- period: small-amplitude design target, formula and simulation
    m_p = par["m_r"] + par["m_l"]
    l_c = (par["m_r"] * par["L_r"] / 2 + par["m_l"] * par["l_l"]) / m_p
    inertia = par["m_r"] * par["L_r"] ** 2 / 3 + par["m_l"] * par["l_l"] ** 2
    out["period_formula_s"] = 2 * math.pi * math.sqrt(inertia / (m_p * par["g"] * l_c))
    small = hybridlab.simulate(compiled, scenario="free_drop", t_end=5.0,
                               params={"a_b": 0.0, "b_b": 0.0}, initial={"phi": 0.02})
    crossings = [e.t for e in small.events if e.kind == "crossing" and "omega" in e.transition]
    out["period_s"] = float(np.mean(np.diff(crossings[::2]))) if len(crossings) > 3 else None

    # -- free drops (Sec. III-C) and payload (Table IV)
    nominal, ideal_n, sensor_n = free_drop(compiled, {"a_b": 0.04, "b_b": 0.0})
    identified, ideal_i, sensor_i = free_drop(compiled, {})
    half, ideal_h, sensor_h = free_drop(compiled, {"m_l": 0.5, "m_C": 3.0})
    out["free_drop_nominal_crossings"] = ideal_n
    out["free_drop_nominal_sensor_crossings"] = sensor_n
    out["free_drop_identified_crossings"] = ideal_i
    out["free_drop_identified_sensor_crossings"] = sensor_i
    out["payload_1kg_crossings"] = ideal_i
    out["payload_0_5kg_crossings"] = ideal_h
    out["payload_1kg_sensor_crossings"] = sensor_i
    out["payload_0_5kg_sensor_crossings"] = sensor_h
    out["payload_crossings_change_pct"] = 100.0 * (ideal_h - ideal_i) / ideal_i
    vt = tangential_velocity(identified, compiled)
    out["tangential_velocity_at_crossings"] = [round(v["v_t_sensors"], 5) for v in vt]
    out["tangential_velocity_model"] = [round(v["v_t_model"], 5) for v in vt]

    # -- step response (Table IV)
    s1 = step_response(compiled, {})
    s05 = step_response(compiled, {"m_l": 0.5, "m_C": 3.0})
    out["step_overshoot_pct_1kg"] = s1.overshoot_pct
    out["step_overshoot_pct_0_5kg"] = s05.overshoot_pct
    out["settling_time_s_1kg"] = s1.settling_time
    out["settling_time_s_0_5kg"] = s05.settling_time

    # -- tracking at 400 mm/s (Fig. 7), and without Coulomb friction for comparison
    tracking = hybridlab.simulate(compiled, scenario="tracking")
    out["tracking_error_max_mm"] = 1e3 * float(np.max(np.abs(tracking.observe("x_ref - x"))))
    no_coulomb = hybridlab.simulate(compiled, scenario="tracking", params={"c": 0.0})
    out["tracking_error_max_mm_without_coulomb"] = 1e3 * float(
        np.max(np.abs(no_coulomb.observe("x_ref - x"))))

    # -- a driven run (Fig. 8): a second-order move excites the pendulum; the sensors at the
    #    stop position record the crossing instants of the residual swing
    driven = hybridlab.simulate(compiled, scenario="tracking", t_end=20.0,
                                params={"p_1": 0.3 - par["d_s"] / 2})
    out["driven_run_crossing_times"] = [round(e.t, 6) for e in driven.jumps
                                        if e.transition == "s1_on"]

    # -- stop-and-return (Fig. 13) and the sweep (Fig. 14)
    hold = 8.0 if fast else 30.0
    sr, stop, arrive, residual = stop_and_return(compiled, 0.25, 1.0, hold)
    out["stop_return_event"] = {"t": stop.t, "x_e_mm": 1e3 * stop.post["x_e"]}
    out["stop_return_arrival_s"] = arrive.t
    out["stop_return_final_error_mm"] = 1e3 * (sr.final.state["x"] - sr.final.state["x_e"])
    out["stop_return_residual_sensor_edges"] = residual
    accelerations = [0.5, 1.0, 2.0] if fast else [0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0]
    sweep: dict[str, dict[str, int | None]] = {}
    for label, position in (("100", 0.1), ("250", 0.25)):
        sweep[label] = {}
        for a in accelerations:
            _, _, _, count = stop_and_return(compiled, position, a, hold)
            sweep[label][str(int(round(a * 1000)))] = count
    out["stop_return_crossings"] = sweep
    out["stop_return_hold_s"] = hold

    if plots is not None:
        make_plots(plots, compiled, driven, vt, tracking, sr, sweep)
    return out


def make_plots(directory: Path, compiled, driven, vt, tracking, sr, sweep) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    directory.mkdir(parents=True, exist_ok=True)
    names = list(sr.state_names)

    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.plot([v["t"] for v in vt], [v["v_t_sensors"] for v in vt], "o", ms=3,
            label="two-sensor estimate, eq. (7)")
    ax.plot([v["t"] for v in vt], [v["v_t_model"] for v in vt], "-", label="model, eq. (8)")
    ax.set(xlabel="t [s]", ylabel="v_t [m/s]", title="Fig. 5: tangential velocity at crossings")
    ax.legend()
    fig.tight_layout()
    fig.savefig(directory / "fig05_tangential_velocity.png", dpi=120)

    fig, (a1, a2) = plt.subplots(2, 1, figsize=(6, 5), sharex=True)
    t = tracking.t
    a1.plot(t, tracking.observe("x_ref") * 1e3, label="reference")
    a1.plot(t, tracking.y[0] * 1e3, "--", label="cart")
    a1.set(ylabel="x [mm]", title="Fig. 7: position tracking at 400 mm/s")
    a1.legend()
    a2.plot(t, tracking.observe("x_ref - x") * 1e3)
    a2.set(xlabel="t [s]", ylabel="error [mm]")
    fig.tight_layout()
    fig.savefig(directory / "fig07_tracking.png", dpi=120)

    ts, ys = driven.sample(2e-3)
    fig, ax = plt.subplots(figsize=(7, 3.5))
    ax.plot(ts, np.degrees(ys[names.index("phi")]), lw=0.7, label="phi (simulated)")
    edges = [e.t for e in driven.jumps if e.transition == "s1_on"]
    ax.plot(edges, np.zeros(len(edges)), "|", ms=12, label="sensor 1 rising edges")
    ax.set(xlabel="t [s]", ylabel="phi [deg]",
           title="Fig. 8: crossing instants after a 300 mm move (sensors at the stop position)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(directory / "fig08_crossings.png", dpi=120)

    calm = hybridlab.simulate(compiled, scenario="tracking")
    excited = hybridlab.simulate(compiled, scenario="tracking", initial={"phi": HALF_PI})
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(6, 5), sharex=True)
    for res, label in ((calm, "pendulum at rest"), (excited, "pendulum dropped from 90 deg")):
        a1.plot(res.t, res.observe("F_in"), label=label)
        a2.plot(res.t, res.observe("x_ref - x") * 1e3, label=label)
    a1.set(ylabel="F_in [N]", title="Figs. 9-10: controller output and position error")
    a2.set(xlabel="t [s]", ylabel="error [mm]")
    a1.legend()
    fig.tight_layout()
    fig.savefig(directory / "fig09_10_disturbance.png", dpi=120)

    free = hybridlab.simulate(compiled, scenario="controller_off")
    ts, ys = free.sample(1e-3)
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(6, 5), sharex=True)
    a1.plot(ts, ys[names.index("x")] * 1e3)
    a1.set(ylabel="x [mm]", title="Fig. 11: controller off, pendulum dropped from 90 deg")
    a2.plot(ts, np.degrees(ys[names.index("phi")]))
    a2.set(xlabel="t [s]", ylabel="phi [deg]")
    fig.tight_layout()
    fig.savefig(directory / "fig11_controller_off.png", dpi=120)

    second = hybridlab.simulate(compiled, scenario="jerk_limited", params={"profile": 2.0})
    fourth = hybridlab.simulate(compiled, scenario="jerk_limited")
    fig, ax = plt.subplots(figsize=(6, 3.5))
    for res, label in ((second, "2nd-order profile"), (fourth, "4th-order (jerk-limited)")):
        ts, ys = res.sample(2e-3)
        ax.plot(ts, np.degrees(ys[names.index("phi")]), label=label)
    ax.set(xlabel="t [s]", ylabel="phi [deg]", title="Fig. 12: pendulum swing for two profiles")
    ax.legend()
    fig.tight_layout()
    fig.savefig(directory / "fig12_profiles.png", dpi=120)

    plot_stop_and_return(sr, directory / "fig13_stop_and_return.png")

    fig, ax = plt.subplots(figsize=(6, 3.5))
    for label, counts in sweep.items():
        acc = [int(a) for a in counts]
        ax.plot(acc, [counts[str(a)] for a in acc], "o-", label=f"sensors at {label} mm")
    ax.set(xlabel="acceleration [mm/s^2]", ylabel="residual sensor edges",
           title="Fig. 14: residual oscillation vs acceleration")
    ax.legend()
    fig.tight_layout()
    fig.savefig(directory / "fig14_sweep.png", dpi=120)
    plt.close("all")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, help="JSON file for the results")
    parser.add_argument("--plots", type=Path, help="directory for the figures")
    parser.add_argument("--fast", action="store_true", help="short sweep (CI)")
    args = parser.parse_args(argv)
    started = time.perf_counter()
    out = run(args.fast, args.plots)
    out["runtime_s"] = time.perf_counter() - started
    Path(args.out).write_text(json.dumps(out, indent=1))
    width = max(len(k) for k in PAPER)
    print(f"{'quantity':<{width}}  {'paper':>10}  ours")
    for key, paper in PAPER.items():
        ours = out[key]
        if isinstance(ours, float):
            ours = f"{ours:.4g}"
        elif isinstance(ours, list):
            ours = f"{len(ours)} values, {ours[0]:.3f} ... {ours[-1]:.3f} m/s"
        print(f"{key:<{width}}  {paper!s:>10}  {ours}")
    print(f"stop_return_crossings (sensor-1 edges after arrival): {out['stop_return_crossings']}")
    print(f"wrote {args.out} in {out['runtime_s']:.0f} s")
    checks = [
        abs(out["free_drop_nominal_crossings"] - 63) <= 3,
        abs(out["free_drop_identified_crossings"] - 83) <= 3,
        abs(out["stop_return_final_error_mm"]) < 0.5,
    ]
    return 0 if all(checks) else 1


if __name__ == "__main__":
    sys.exit(main())
