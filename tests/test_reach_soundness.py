"""Soundness in dense time: simulations from the initial set stay inside the flowpipes.

For each bundled model the method handles, simulations start from the corners of
the initial box and from random points in it (fixed seed); every trajectory is
evaluated on a fine time grid (2001 points, not the reach steps) plus both sides of
every jump, and each sample must lie in a reach set of the same mode whose time
interval contains that instant. Uncertain parameters are sampled the same way.

The trolley (18 states, Lagrangian mechanics with stick-slip friction, sensor and
trajectory modes with scheduled and state events) is covered over the first 2 ms of its
step response, in steps of 1e-4 s, over the first 30 ms of its stop-and-return (held by
friction, breaking away, accelerating), in steps of 1e-3 s, and over 0.55 s of a
stop-and-return with sensor 1 at 100 mm (through the sensor event at an uncertain instant
into the braking), in steps of 1.25e-3 s; its linearised plant (``trolley_linear.toml``)
over 2 s, through the stop, the turn and the return into holding. Each step of the trolley's
nonlinear modes costs a few hundredths of a second, so longer horizons cost minutes; see
``docs/verification.md``.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import hybridlab
from hybridlab.reachability import reach

CASES = {
    # id: (model, scenario, initial box, uncertain params, t_end, reach options)
    "bouncing_ball": ("bouncing_ball", None, {"h": (9.0, 10.0), "v": (-1.0, 0.0)}, {}, 6.0,
                      {"step": 0.01}),
    "thermostat": ("thermostat", None, {"T": (19.0, 21.0)}, {}, 40.0, {"step": 0.05}),
    "thermostat_uncertain_loss": ("thermostat", None, {"T": (19.5, 20.5)},
                                  {"a": (0.09, 0.11)}, 20.0, {"step": 0.05}),
    # T > 22 starts outside heat's invariant: the guard fires at t = 0 before the invariant
    # is checked, so those states jump from outside it (a regression: they were cut away)
    "thermostat_entry_outside_invariant": ("thermostat", None, {"T": (15.0, 25.0)}, {}, 15.0,
                                           {"step": 0.1}),
    "relay_sliding": ("relay_sliding", None, {"x": (0.5, 1.5)}, {}, 3.0, {"step": 0.01}),
    "relay_escape": ("relay_sliding", "escape", {"x": (0.5, 1.5)}, {}, 3.0, {"step": 0.01}),
    "friction_oscillator": ("friction_oscillator", None, {"x": (0.9, 1.1), "v": (-0.1, 0.1)},
                            {}, 5.0, {"step": 0.01}),
    "sampled_control": ("sampled_control", None, {"x": (0.9, 1.1), "u": (-0.1, 0.1)}, {}, 2.0,
                        {"step": 0.01}),
    # the cart starts moving towards a 10 mm step with the pendulum anywhere in +-0.01 rad
    "trolley_step_2ms": ("trolley", "step", {"phi": (-0.01, 0.01)}, {}, 0.002, {"step": 1e-4}),
    # the stop-and-return's start: held by friction (sliding), breaking away at about 12 ms
    # (the friction's sign within its equivalent control's range), then accelerating
    "trolley_break_away_30ms": ("trolley", None, {"phi": (-0.01, 0.01), "omega": (-0.05, 0.05)},
                                {}, 0.03, {"step": 1e-3}),
    # the stop-and-return with sensor 1 at 100 mm: the screw enters its window at an
    # uncertain instant near t = 0.4 s, the detection's run of step sets is joined keeping
    # its generators, and the cart brakes; the sensors' outputs, which nothing reads, are
    # left out (their values' hull [0, 1] holds every sample)
    "trolley_sensor_event": ("trolley", None, {"phi": (-0.01, 0.01), "omega": (-0.05, 0.05)},
                             {}, 0.55, {"step": 0.00125, "clustering": "sweep",
                                        "fixed": {"p_1": 0.1}}),
    # the stop-and-return's sensor event at a step where the run's sets do not share their
    # generators' layout (reduced step by step): the run is joined as one step of its
    # whole length, cut to the frame of the oriented hull (cart and pendulum
    # correlations kept through the jump), and the cart brakes
    "trolley_detection_span": ("trolley", None, {"phi": (-0.01, 0.01), "omega": (-0.05, 0.05)},
                               {}, 0.76, {"step": 0.000919118, "clustering": "sweep"}),
    # the linearised trolley through its turn and return into holding: braking, stopped
    # with the friction's sign free while the set lies across v = 0, the return's
    # acceleration, its cruise entered at the deceleration guard's equality (the entry set
    # split), deceleration and arrival; its manoeuvre modes lifted over tau's monomials
    "trolley_linear_turn": ("trolley_linear", None, {"phi": (-0.01, 0.01),
                                                     "omega": (-0.05, 0.05)},
                            {}, 2.0, {"step": 0.001875, "clustering": "sweep",
                                     "lift_clocks": True}),
}
#: samples per trajectory; the trolley's 18-state zonotopes need one LP per membership test
GRID_POINTS = {"trolley_step_2ms": 301, "trolley_break_away_30ms": 301,
               "trolley_sensor_event": 221, "trolley_detection_span": 161,
               "trolley_linear_turn": 401}


def _starts(box: dict, params: dict, n_random: int, seed: int):
    names = list(box) + list(params)
    ranges = [box[k] for k in box] + [params[k] for k in params]
    corners = [dict(zip(names, c, strict=True)) for c in itertools.product(*ranges)]
    rng = np.random.default_rng(seed)
    randoms = [{k: float(rng.uniform(*r)) for k, r in zip(names, ranges, strict=True)}
               for _ in range(n_random)]
    for point in corners + randoms:
        yield ({k: point[k] for k in box}, {k: point[k] for k in params})


@pytest.mark.parametrize("case", list(CASES), ids=list(CASES))
def test_sampled_trajectories_lie_in_the_flowpipes_at_all_times(case, models_dir):
    name, scenario, box, params, t_end, opts = CASES[case]
    opts = dict(opts)
    fixed = opts.pop("fixed", {})  # parameter values of this case (not uncertain)
    model = hybridlab.load_model(models_dir / f"{name}.toml")
    result = reach(model, initial=box, params={**params, **fixed}, t_end=t_end,
                   scenario=scenario, **opts)
    assert result.complete, result.incomplete_reasons
    checked, points = 0, GRID_POINTS.get(case, 2001)
    for x0, p in _starts(box, params, n_random=4, seed=5):
        sim = hybridlab.simulate(model, t_end=t_end, scenario=scenario, initial=x0,
                                 params={**p, **fixed} or None, rtol=1e-10, atol=1e-12)
        assert sim.status.ok, sim.message if hasattr(sim, "message") else sim.status
        grid = np.linspace(sim.segments[0].t_start, sim.final.t, points)
        X = sim(grid).T
        modes = [sim.mode_at(t) for t in grid]
        inside = result.covers(grid, X, modes, tol=1e-7)
        assert inside.all(), (f"{case}: start {x0} {p}: t={grid[~inside][0]:.6g} "
                              f"x={X[~inside][0]} mode {np.asarray(modes)[~inside][0]} "
                              "outside every reach set")
        for ev in sim.jumps:  # both sides of every jump, at the jump instant itself
            pre, post = np.array([list(ev.pre.values())]), np.array([list(ev.post.values())])
            assert result.covers([ev.t], pre, [ev.source], tol=1e-7).all(), (case, ev)
            assert result.covers([ev.t], post, [ev.target], tol=1e-7).all(), (case, ev)
        checked += grid.size
    assert checked >= 5 * points


def test_covers_rejects_states_outside_and_wrong_modes(models_dir):
    """The check above can fail: points off the flowpipe or in another mode are rejected."""
    result = reach(models_dir / "thermostat.toml", initial={"T": (19.0, 21.0)}, t_end=10.0,
                   step=0.05)
    t = np.array([0.3, 0.3, 0.3])           # cool is entered at t >= 10 ln(19/18) = 0.54
    X = np.array([[21.0], [30.0], [21.0]])
    assert result.covers(t, X, ["heat", "heat", "cool"]).tolist() == [True, False, False]


def test_time_varying_input_trajectories_lie_in_the_flowpipes():
    """x' = -x + u, y' = x - y with u(t) in [-1, 1] switching at random instants: every
    sample of every such trajectory (closed form per constant piece) is in the flowpipes."""
    model = hybridlab.loads_model('''
name = "driven_decay"
parameters = { u = 0.0 }
states = { x = 0.0, y = 0.0 }
[modes.on]
flow = { x = "-x + u", y = "x - y" }
[initial]
mode = "on"
''')
    t_end = 3.0
    result = reach(model, initial={"x": (-0.2, 0.2)}, inputs={"u": (-1.0, 1.0)}, t_end=t_end,
                   step=0.01)
    assert result.complete
    rng = np.random.default_rng(3)
    extreme = 0.0
    for run in range(40):
        t0, x0, y0 = 0.0, float(rng.uniform(-0.2, 0.2)), 0.0
        while t0 < t_end:
            t1 = min(t_end, t0 + float(rng.uniform(0.05, 0.6)))
            u = float(rng.choice([-1.0, 1.0])) if run % 2 else float(rng.uniform(-1, 1))
            tau = np.linspace(0.0, t1 - t0, 150)
            x = u + (x0 - u) * np.exp(-tau)
            y = u + (x0 - u) * tau * np.exp(-tau) + (y0 - u) * np.exp(-tau)
            inside = result.covers(t0 + tau, np.column_stack([x, y]), "on", tol=1e-9)
            assert inside.all(), (run, t0 + tau[~inside][0])
            extreme = max(extreme, float(np.abs(x).max()))
            t0, x0, y0 = t1, float(x[-1]), float(y[-1])
    assert extreme > 0.5   # the inputs really drove the state around


def test_nonlinear_guards_and_resets_stay_sound():
    """A two-mode cycle whose return guard (x^2 <= 1/4) and reset (y := sin y + y^2 / 4) are
    nonlinear: sampled runs lie in the flowpipes at all times and on both sides of the jumps."""
    model = hybridlab.loads_model('''
name = "cycle"
states = { x = 0.0, y = 1.0 }
[modes.out]
flow = { x = "1", y = "0.5*y" }
[modes.back]
flow = { x = "-1", y = "-y" }
[[transitions]]
name = "turn"
source = "out"
target = "back"
guard = "x >= 1"
reset = { y = "sin(y) + 0.25*y**2" }
[[transitions]]
name = "restart"
source = "back"
target = "out"
guard = "x**2 <= 0.25"
reset = { x = "x - 0.5" }
[initial]
mode = "out"
''')
    box = {"x": (0.0, 0.2), "y": (0.5, 1.0)}
    result = reach(model, initial=box, t_end=4.0, step=0.01)
    assert result.complete and result.reachable_modes == {"out", "back"}
    assert max(s.jumps for s in result.sets) >= 5
    for x0, _ in _starts(box, {}, n_random=4, seed=11):
        sim = hybridlab.simulate(model, t_end=4.0, initial=x0, rtol=1e-10, atol=1e-12)
        grid = np.linspace(0.0, sim.final.t, 2001)
        inside = result.covers(grid, sim(grid).T, [sim.mode_at(t) for t in grid], tol=1e-7)
        assert inside.all(), (x0, grid[~inside][0])
        assert len(sim.jumps) >= 5
        for ev in sim.jumps:
            pre, post = np.array([list(ev.pre.values())]), np.array([list(ev.post.values())])
            assert result.covers([ev.t], pre, [ev.source], tol=1e-7).all(), ev
            assert result.covers([ev.t], post, [ev.target], tol=1e-7).all(), ev
