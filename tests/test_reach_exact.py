"""Reachable sets with closed forms: the computed bounds enclose them, and tightly.

Each test states its tolerance: the over-approximation allowed on top of the exact
answer (sound: the exact answer is always inside).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import hybridlab
from hybridlab.reachability import Box, Polytope, Zonotope, reach


def _model(text: str) -> hybridlab.Model:
    return hybridlab.loads_model(text)


DECAY = _model('''
name = "decay"
parameters = { k = 1.0, u = 0.0 }
states = { x = 1.0 }
[modes.on]
flow = { x = "-k*x + u" }
[initial]
mode = "on"
''')

OSCILLATOR = _model('''
name = "oscillator"
states = { x = 1.0, v = 0.0 }
[modes.on]
flow = { x = "v", v = "-x" }
[initial]
mode = "on"
''')

CUBIC = _model('''
name = "cubic"
states = { x = 1.0 }
[modes.on]
flow = { x = "-x**3" }
[initial]
mode = "on"
''')


def test_decay_interval_hull_and_time_point_sets():
    # x' = -x from [1, 2] over [0, 2]: hull [2 e^-2, 2]; at time t: [e^-t, 2 e^-t]
    r = reach(DECAY, initial={"x": (1.0, 2.0)}, t_end=2.0, step=0.01)
    lo, hi = r.bounds["x"]
    assert lo <= math.exp(-2) <= hi and hi >= 2.0
    assert abs(lo - math.exp(-2)) < 5e-3 and abs(hi - 2.0) < 1e-3
    for t in (0.5, 1.0, 1.5):
        sets = r.sets_at(t)
        assert sets
        lo_t = min(s.bounds()[0, 0] for s in sets)
        hi_t = max(s.bounds()[0, 1] for s in sets)
        assert lo_t <= math.exp(-t) and hi_t >= 2 * math.exp(-t)
        # two adjacent steps may cover t; each spans at most 2 steps of decay
        assert hi_t - lo_t < math.exp(-t) * (1 + 0.03)


def test_harmonic_oscillator_hull_is_the_largest_amplitude():
    # x' = v, v' = -x: circles; over a full period x reaches +-max sqrt(x0^2 + v0^2)
    r = reach(OSCILLATOR, initial={"x": (0.9, 1.1), "v": (-0.1, 0.1)}, t_end=2 * math.pi,
              step=0.01)
    amplitude = math.hypot(1.1, 0.1)
    for name in ("x", "v"):
        lo, hi = r.bounds[name]
        assert lo <= -amplitude and hi >= amplitude
        assert hi - amplitude < 2e-2 and -amplitude - lo < 2e-2


def test_bounded_input_reaches_the_closed_form_band():
    # x' = -x + u, u(t) in [-1, 1] arbitrary, x(0) = 0: |x(t)| <= 1 - e^-t, attained
    r = reach(DECAY, initial={"x": 0.0}, inputs={"u": (-1.0, 1.0)}, t_end=3.0, step=0.01)
    lo, hi = r.bounds["x"]
    exact = 1 - math.exp(-3.0)
    assert hi >= exact and lo <= -exact
    assert hi - exact < 2e-2 and -exact - lo < 2e-2


def test_uncertain_constant_parameter():
    # x' = -k x, k in [1, 1.2] constant, x(0) = 1: x(1) in [e^-1.2, e^-1]. k x is bilinear
    # in the extended state (x, k), so this runs the conservative linearisation; its
    # remainder |dk| |dx| grows with the parameter's width (k in [1, 2] is ~0.06 loose)
    r = reach(DECAY, initial={"x": 1.0}, params={"k": (1.0, 1.2)}, t_end=1.0, step=0.005)
    assert r.complete
    final = [s for s in r.sets if s.t[1] >= 1.0]
    lo = min(s.bounds()[0, 0] for s in final)
    hi = max(s.bounds()[0, 1] for s in final)
    assert lo <= math.exp(-1.2) and hi >= math.exp(-1)
    assert math.exp(-1.2) - lo < 5e-3 and hi - math.exp(-1) < 5e-3
    # the parameter is carried as a state: bound() sees it over its interval
    k_lo, k_hi = r.sets[0].bound("k")
    assert k_lo <= 1.0 and k_hi >= 1.2 and k_hi - k_lo < 0.2 + 1e-9
    wide = reach(DECAY, initial={"x": 1.0}, params={"k": (1.0, 2.0)}, t_end=1.0, step=0.005)
    assert min(s.bounds()[0, 0] for s in wide.sets if s.t[1] >= 1.0) <= math.exp(-2)


def test_nonlinear_cubic_decay_matches_its_closed_form():
    # x' = -x^3: x(t) = x0 / sqrt(1 + 2 x0^2 t); from [1, 1.5] at t = 2: [0.4472, 0.4743]
    r = reach(CUBIC, initial={"x": (1.0, 1.5)}, t_end=2.0, step=0.01)
    assert r.complete
    final = r.sets[-1].bounds()[0]
    exact = np.array([1.0, 1.5]) / np.sqrt(1 + 2 * np.array([1.0, 1.5]) ** 2 * 2.0)
    assert final[0] <= exact[0] and final[1] >= exact[1]
    assert exact[0] - final[0] < 1e-2 and final[1] - exact[1] < 2e-2


@pytest.mark.parametrize("h0", [(5.0, 10.0), (10.0, 10.0)])
def test_bouncing_ball_height_bound(h0, models_dir):
    # dropped from rest at h0 with e = 0.8: the height never exceeds max h0, after the first
    # bounce never exceeds e^2 max h0 = 6.4 (energy is lost at each impact), and the impact
    # speed is sqrt(2 g max h0) = 14.007 m/s
    r = reach(models_dir / "bouncing_ball.toml", initial={"h": h0, "v": 0.0}, t_end=5.0,
              step=0.005)
    assert r.complete
    hi = r.bounds["h"][1]
    assert 10.0 <= hi < 10.0 + 1e-3
    after = max(s.bounds()[0, 1] for s in r.sets if s.jumps >= 1)
    assert 6.4 <= after < 6.4 + 5e-2
    v_impact = math.sqrt(2 * 9.81 * 10.0)
    v_lo = r.bounds["v"][0]
    assert v_lo <= -v_impact and -v_impact - v_lo < 5e-2
    assert r.bounds["v"][1] >= 0.8 * v_impact


def test_initial_sets_as_objects_agree():
    box = reach(OSCILLATOR, initial=Box([0.9, -0.1], [1.1, 0.1]), t_end=1.0, step=0.02)
    zono = reach(OSCILLATOR, initial=Zonotope([1.0, 0.0], [[0.1, 0.0], [0.0, 0.1]]), t_end=1.0,
                 step=0.02)
    poly = reach(OSCILLATOR, initial=Polytope([[1, 0], [-1, 0], [0, 1], [0, -1]],
                                              [1.1, -0.9, 0.1, 0.1]), t_end=1.0, step=0.02)
    for name in ("x", "v"):
        assert box.bounds[name] == pytest.approx(zono.bounds[name], abs=1e-9)
        assert box.bounds[name] == pytest.approx(poly.bounds[name], abs=1e-6)


PUSHED_BLOCK = """
name = "pushed_block"
parameters = { c = 1.0 }
states = { x = 0.0, v = 0.0 }
[modes.push]
flow = { x = "v", v = "2*t - c*sign(v)" }
[initial]
mode = "push"
"""


def test_coulomb_friction_holds_a_block_until_the_push_exceeds_it_then_it_never_slides_back():
    # a unit mass under a ramp force 2 t and Coulomb friction c = 1, from rest: it sticks
    # (v = 0, Filippov sliding on v = 0) until 2 t = c at t = 0.5, then v = (t - 0.5)^2 > 0;
    # the friction's sign is free only on the surface, where the flow with either sign
    # points back to it (stick) or away on one side only (break-away)
    r = reach(hybridlab.loads_model(PUSHED_BLOCK), initial={"x": (0.0, 0.1)}, t_end=1.0,
              step=0.01)
    assert r.complete
    stuck = [s.bounds()[1] for s in r.sets if s.t[1] <= 0.49]
    assert max(abs(v) for lo_hi in stuck for v in lo_hi) < 1e-8   # held (a free sign: 0.01)
    assert r.bounds["v"][0] > -1e-8                                # never backwards
    for s in r.sets:
        t_lo, t_hi = s.t
        v_lo, v_hi = s.bounds()[1]
        exact = [max(0.0, t - 0.5) ** 2 for t in (max(t_lo, 0.0), t_hi)]
        assert v_lo <= min(exact) + 1e-9 and max(exact) <= v_hi + 1e-9
    assert 0.25 <= r.bounds["v"][1] < 0.3   # v(1) = 0.25


HELD_BLOCK = """
name = "held_block"
states = { x = 0.0, v = 0.0, y = 1.0 }
[modes.held]
flow = { x = "v", v = "y - 2*sign(v)", y = "-y - y*sign(v)" }
[initial]
mode = "held"
"""


def test_a_block_held_by_friction_follows_the_sliding_flow_not_a_free_sign():
    # v' = y - 2 sign(v) with y < 2: friction holds the block (v = 0); on v = 0 Filippov's
    # equivalent control is sign(v) = y / 2, so y' = -y - y^2 / 2, whose solution is
    # y = 2 y0 / ((2 + y0) e^t - y0). With the sign free in [-1, 1] instead, y' = -y - y s
    # lets y grow like e^0 = 1 at the top: the enclosure would not shrink with the flow.
    r = reach(hybridlab.loads_model(HELD_BLOCK), initial={"y": (0.5, 1.0)}, t_end=2.0,
              step=0.01)
    assert r.complete

    def exact(y0: float, t: float) -> float:
        return 2 * y0 / ((2 + y0) * math.exp(t) - y0)

    for s in r.sets:
        t_lo, t_hi = max(s.t[0], 0.0), min(s.t[1], 2.0)
        (x_lo, x_hi), (v_lo, v_hi), (y_lo, y_hi) = s.bounds()
        assert max(abs(x_lo), abs(x_hi), abs(v_lo), abs(v_hi)) < 1e-8   # held
        lo, hi = exact(0.5, t_hi), exact(1.0, t_lo)                     # y decreases
        assert y_lo <= lo and hi <= y_hi                                # enclosed
        assert y_hi - y_lo < (exact(1.0, t_lo) - exact(0.5, t_hi)) + 0.02  # and tight


SLOWING_BLOCK = """
name = "slowing_block"
states = { x = 0.0, v = 0.0 }
[modes.m]
flow = { x = "v", v = "0.5 - 2*sign(v)" }
[initial]
mode = "m"
"""


def _slowing_block(v0: float, t: float) -> tuple[float, float]:
    """``(x, v)`` of the slowing block from ``(0, v0)``: it decelerates at 1.5 (moving
    forwards) or accelerates at 2.5 (backwards) until it rests, then friction holds it."""
    a = -1.5 if v0 > 0 else 2.5
    rest = -v0 / a if v0 else 0.0
    s = min(t, rest)
    return v0 * s + 0.5 * a * s * s, v0 + a * s


def _slowing_block_inside(r, starts: np.ndarray, t_end: float) -> None:
    """Every trajectory of the slowing block from ``(0, v0)``, ``v0`` in ``starts``, lies in
    each reach set of ``r`` at both ends of its time interval."""
    for s in r.sets:
        (x_lo, x_hi), (v_lo, v_hi) = s.bounds()
        for t in (max(s.t[0], 0.0), min(s.t[1], t_end)):
            for v0 in starts:
                x, v = _slowing_block(float(v0), t)
                assert x_lo - 1e-12 <= x <= x_hi + 1e-12 and v_lo - 1e-12 <= v <= v_hi + 1e-12


def test_a_moving_set_comes_to_rest_on_the_surface_with_the_sign_free():
    # v' = 0.5 - 2 sign(v): friction beats the push, so from v in [-0.1, 0.1] every state
    # comes to rest by t = 0.1 / 1.5 and is held there. With the sign free (no phases) the
    # set straddles v = 0; each side approaches the surface at least at 1.5 and 2.5, the
    # bounds carried from step to step reach 0 together, and the set is put on the surface,
    # where the sliding rule holds it (before, v stayed in [-0.1, 0.1] and x drifted ±0.11).
    r = reach(hybridlab.loads_model(SLOWING_BLOCK), initial={"v": (-0.1, 0.1)}, t_end=1.0,
              step=0.01, sign_phases=False)
    assert r.complete
    rest = [s.bounds() for s in r.sets if s.t[0] >= 0.1]
    assert rest and max(abs(v) for b in rest for v in b[1]) < 1e-12
    assert r.bounds["x"][0] > -0.01 and r.bounds["x"][1] < 0.01
    _slowing_block_inside(r, np.linspace(-0.1, 0.1, 21), 1.0)



def test_a_set_below_an_attracting_surface_comes_to_rest_on_it_by_the_side_rule():
    # from v in [-0.1, 0] every state is below v = 0 or on it: the side rule (sign -1 off
    # the surface, Filippov's equivalent control on it) steps it, and as the surface also
    # attracts from below (v' = 2.5 there), that bound is carried too: every state rests by
    # t = 0.04 and the set is put on the surface (with the sign merely in [-1, max eq],
    # v fell below -0.1 and the set came to lie across the surface, its sign free)
    r = reach(hybridlab.loads_model(SLOWING_BLOCK), initial={"v": (-0.1, 0.0)}, t_end=0.5,
              step=0.01)
    assert r.complete
    rest = [s.bounds() for s in r.sets if s.t[0] >= 0.06]
    assert rest and max(abs(v) for b in rest for v in b[1]) < 1e-12
    assert r.bounds["v"][0] >= -0.1 - 1e-9 and r.bounds["x"][0] > -0.006   # exact: -0.002
    _slowing_block_inside(r, np.linspace(-0.1, 0.0, 11), 0.5)


CLOCKED = """
name = "clocked"
states = { c = 0.0, y = 1.0 }
[modes.a]
flow = { c = "1", y = "-y" }
[modes.b]
flow = { c = "1", y = "0" }
[[transitions]]
name = "tick"
source = "a"
target = "b"
guard = "c >= 1"
[initial]
mode = "a"
"""


def test_a_clock_guard_jumps_at_its_instant_not_over_a_step():
    # c reaches 1 at t = 1 exactly, for every state: the jump takes y(1) = y0 / e (y stays
    # there in b), entering b within 1e-6 of t = 1; crossing over a step would take the
    # step's hull (0.3 here: y0 e^-1.2 .. y0 e^-0.9)
    r = reach(hybridlab.loads_model(CLOCKED), initial={"y": (1.0, 2.0)}, t_end=2.0, step=0.3)
    assert r.complete
    entry = min((s for s in r.sets if s.mode == "b"), key=lambda s: s.t[0])
    assert 1.0 - 1e-6 <= entry.t[0] <= 1.0
    y_lo, y_hi = entry.bounds()[1]
    assert y_lo <= math.exp(-1) <= y_lo + 1e-6 and y_hi - 1e-6 <= 2 * math.exp(-1) <= y_hi
    assert max(s.t[1] for s in r.sets if s.mode == "a") < 1.0 + 1e-6   # none stays in a
