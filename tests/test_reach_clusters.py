"""Guard hits joined into one set: the sweep hull keeps the flowpipe's correlations."""

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

import hybridlab
from hybridlab import reach
from hybridlab.reachability.clusters import sweep_hull
from hybridlab.reachability.sets import Zonotope
from hybridlab.verify import check_safety


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**31 - 1), st.integers(2, 6), st.integers(1, 8), st.integers(2, 12))
def test_sweep_hull_contains_every_set_of_the_run(seed, n, p, k):
    # a run of zonotopes that share their layout: centres along a curve, generators drifting
    rng = np.random.default_rng(seed)
    G = rng.normal(size=(n, p))
    path = rng.normal(size=(n, 3))
    sets = []
    for j, s in enumerate(np.linspace(0.0, 1.0, k)):
        centre = path @ np.array([1.0, s, s * s])
        sets.append(Zonotope(centre, G + 0.05 * j * rng.normal(size=(n, p))))
    Z = sweep_hull(sets)
    for Q in sets:
        y = rng.choice([-1.0, 1.0], size=(p, 16))
        y[:, :4] = rng.uniform(-1, 1, (p, 4))
        assert Z.contains_points((Q.center[:, None] + Q.generators @ y).T).all()


def test_sweep_hull_needs_one_layout():
    assert sweep_hull([Zonotope([0.0], [[1.0]]), Zonotope([1.0], [[1.0, 0.5]])]) is None
    assert sweep_hull([]) is None


FOLLOWER = Path(__file__).resolve().parents[1] / "models" / "sensor_follower.toml"


def _follower_runs(corners):
    def rhs(t, z):
        return [1.0, 1.0 + 2.0 * (z[0] - z[1]), 0.0]

    out = []
    for x0, y0 in corners:
        t = np.linspace(0.0, 1.5, 151)
        z = solve_ivp(rhs, (0, 1.5), [x0, y0, 0.0], t_eval=t, rtol=1e-10, atol=1e-12).y.T
        after = z[:, 0] >= 1.0
        z[after, 2] = 1.0  # e latched when x reaches 1 (x' = 1: at x = 1 exactly)
        out.append((t[after], z[after]))
    return out


def test_a_tracking_error_survives_the_jump_as_a_sweep():
    # y tracks x; the sensor at x = 1 fires over half a second across the initial box. A
    # box of the whole run would lose y - x (both sweep by 0.5): the sweep hull keeps it,
    # and so does the box of the run's states on the barrier's surface x = 1, where
    # every trajectory fires (a state inside the guard has fired before)
    model = hybridlab.load_model(FOLLOWER)
    box = {"x": (0.0, 0.5), "y": (0.0, 0.5)}
    specs = ["latched: y - x <= 0.3", "latched: x - y <= 0.3"]
    boxed = check_safety(model, initial=box, t_end=1.5, step=0.05, safe=specs,
                         clustering="box", split=1)  # the whole initial set: only the join
    swept = check_safety(model, initial=box, t_end=1.5, step=0.05, safe=specs,
                         clustering="sweep", split=1)
    assert boxed.status.name == swept.status.name == "SAFE"
    assert swept.margin > 0.05 and boxed.margin > 0.05  # |y - x| <= 0.5 e^-1 = 0.18 latched
    entered = [s for s in reach(model, initial=box, t_end=1.5, step=0.05, clustering="box",
                                split=1).sets if s.mode == "latched"]
    first = min(entered, key=lambda s: s.t[0])
    assert first.bounds()[2].tolist() == pytest.approx([1.0, 1.0], abs=1e-9)  # e := x = 1
    r = reach(model, initial=box, t_end=1.5, step=0.05, clustering="sweep")
    for t, z in _follower_runs([(a, b) for a in (0.0, 0.5) for b in (0.0, 0.5)]):
        assert r.covers(t, z, "latched").all()


def test_a_span_taken_aside_leaves_the_flowpipes_next_step_as_it_was():
    # a run of guard hits is joined as one step of the run's length (FlowStepper.span); that
    # step must not change the remainder guess or the bounds the flowpipe carries
    from hybridlab.reachability.nonlinear import FlowStepper
    from hybridlab.reachability.options import ReachOptions
    from hybridlab.reachability.system import build_system

    c = hybridlab.compile_model(hybridlab.loads_model('''
name = "vdp"
states = { x = 1.4, y = 2.4 }
[modes.m]
flow = { x = "y", y = "(1 - x**2)*y - x" }
[initial]
mode = "m"
'''))
    system = build_system(c, c.parameter_vector(), {}, {})
    P0 = Zonotope([1.4, 2.4], [[0.05, 0.0], [0.0, 0.05]])
    plain = FlowStepper(system, "m", ReachOptions())
    P1, _ = plain.step(P0, 0.01)
    expected = plain.step(P1, 0.01)
    aside = FlowStepper(system, "m", ReachOptions())
    Q1, _ = aside.step(P0, 0.01)
    whole = aside.span(P0, 0.05)
    got = aside.step(Q1, 0.01)
    for a, b in zip(expected, got, strict=True):
        assert np.array_equal(a.center, b.center) and np.array_equal(a.generators, b.generators)
    # and the span holds every state reached from P0 within 0.05 s
    def vdp(t, z):
        return [z[1], (1 - z[0] ** 2) * z[1] - z[0]]

    for x0 in (1.35, 1.45):
        for y0 in (2.35, 2.45):
            path = solve_ivp(vdp, (0.0, 0.05), [x0, y0], t_eval=np.linspace(0.0, 0.05, 11),
                             rtol=1e-10, atol=1e-12).y.T
            assert whole.contains_points(path).all()
