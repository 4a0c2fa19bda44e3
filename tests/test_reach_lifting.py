"""Modes affine but for their clocks, signs known over a chain, and where guards fire.

* A flow polynomial in clocks and constants is lifted to an affine flow over the clocks'
  monomials (``reachability.lifting``) and stepped as one chain: no remainder, no
  reduction from step to step.
* An affine mode whose switching functions keep known signs is one chain too.
* A guard fires where its last row to hold comes up to 0 (a step set is cut down to that
  surface), or at the entry instant for the part of an entry set already inside it.
"""

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

import hybridlab
from hybridlab import reach
from hybridlab.reachability.lifting import ClockLift
from hybridlab.reachability.nonlinear import FlowStepper
from hybridlab.reachability.options import ReachOptions
from hybridlab.reachability.sets import Zonotope
from hybridlab.reachability.system import ModeSystem, Rows, build_system

#: a follower tracks the parabola a tau^2 / 2 (a an uncertain constant) with feed-forward
TRACKER = """
name = "parabola_tracker"
[parameters]
k = { value = 5.0 }
a = { value = 1.0 }
[states]
x = { initial = 0.0 }
tau = { initial = 0.0 }
[modes.track]
flow = { x = "a*tau + k*(a*tau**2/2 - x)", tau = "1" }
[initial]
mode = "track"
"""


def _tracker_runs(a_values, x0_values, t_end):
    out = []
    for a in a_values:
        for x0 in x0_values:
            t = np.linspace(0.0, t_end, 201)
            sol = solve_ivp(lambda _, z, a=a: [a * z[1] + 5.0 * (a * z[1] ** 2 / 2 - z[0]), 1.0],
                            (0.0, t_end), [x0, 0.0], t_eval=t, rtol=1e-11, atol=1e-12)
            out.append((a, sol.t, sol.y[0]))
    return out


def test_a_clock_polynomial_is_lifted_to_an_affine_flow():
    x, tau, a = sp.symbols("x tau a", real=True)
    zs = (x, tau, a)
    flow = (a * tau + 5 * (a * tau**2 / 2 - x), sp.Integer(1), sp.Integer(0))
    mode = ModeSystem("track", flow, zs, (), Rows([], zs), (), Rows([], zs))
    lift = ClockLift.of(mode)
    assert lift is not None and lift.flow.affine
    assert lift.monomials == (a * tau**2, a * tau)
    # (a tau^2)' = 2 a tau, (a tau)' = a: closed, and the lifted flow agrees with the mode's
    assert lift.flow.flow[3:] == (2 * lift.flow.zsyms[4], a)
    z = np.array([0.3, 0.7, 1.1])
    lifted = np.r_[z, 1.1 * 0.7**2, 1.1 * 0.7]
    assert lift.flow.value(lifted, np.zeros(0))[:3] == pytest.approx(mode.value(z, np.zeros(0)))
    # not liftable: a dynamic state times a clock, a non-polynomial term, an affine flow
    for bad in [(x * tau, sp.Integer(1), sp.Integer(0)),
                (sp.sin(tau), sp.Integer(1), sp.Integer(0)),
                (-x + tau, sp.Integer(1), sp.Integer(0))]:
        assert ClockLift.of(ModeSystem("m", bad, zs, (), Rows([], zs), (), Rows([], zs))) is None


def test_a_lifted_mode_keeps_its_set_tight_and_sound():
    # x(t) = a t^2 / 2 + x0 e^{-5 t}: at t = 2 the exact range over a in [0.9, 1.1] and
    # x0 in [-0.05, 0.05] is [1.8, 2.2] to within 5e-6
    model = hybridlab.loads_model(TRACKER)
    r = reach(model, initial={"x": (-0.05, 0.05)}, params={"a": (0.9, 1.1)}, t_end=2.0,
              step=0.01, lift_clocks=True)
    assert r.complete and not r.incomplete_reasons
    last = r.sets[-1]
    lo, hi = last.bounds()[0]
    assert lo <= 1.8 and hi >= 2.2
    # the exact maximum is 2.2 + 0.05 e^-10; linearised step by step (its remainder
    # boxed at every step) the bound is 2.2012
    assert hi < 2.2 + 1e-4
    for _a, t, xs in _tracker_runs((0.9, 1.1), (-0.05, 0.05), 2.0):
        for ti, xi in zip(t, xs, strict=True):
            inside = [s for s in r.sets if s.t[0] <= ti <= s.t[1]]
            assert any(s.contains([[xi, ti]])[0] for s in inside)


def test_known_signs_step_as_one_chain():
    # the friction oscillator pushed to the right: v > 0 throughout, sign(v) known
    text = """
name = "pushed"
[parameters]
c = { value = 1.0 }
[states]
x = { initial = 0.0 }
v = { initial = 1.0 }
[modes.slide]
flow = { x = "v", v = "-x - 0.1*v - c*sign(v) + 3" }
[initial]
mode = "slide"
"""
    compiled = hybridlab.compile_model(hybridlab.loads_model(text))
    system = build_system(compiled, compiled.parameter_vector(), {}, {})
    stepper = FlowStepper(system, "slide", ReachOptions())
    P = Zonotope([0.0, 1.0], [[0.01, 0.0], [0.0, 0.01]])
    layouts = []
    for _ in range(20):
        P, H = stepper.step(P, 0.02)
        layouts.append(H.generators.shape)
    chain = stepper.chain_for(P, 0.02)
    assert chain is not None and chain.steps == 20
    assert len(set(layouts[1:])) == 1  # every later step set in the layout of the second


#: x runs at unit speed from an uncertain start; the guard x >= 0 records e := x
RECORD = """
name = "record"
[states]
x = { initial = 0.0 }
e = { initial = -1.0 }
[modes.wait]
flow = { x = "1", e = "0" }
[modes.done]
flow = { x = "1", e = "0" }
[[transitions]]
name = "pass"
source = "wait"
target = "done"
guard = "x >= 0"
reset = { e = "x" }
[initial]
mode = "wait"
"""


@pytest.mark.parametrize("start", [(-0.1, 0.1), (-0.3, -0.1)])
def test_a_guard_fires_on_its_surface_or_at_entry(start):
    # a state entering inside the guard fires at once (e = its x); every other fires where
    # x comes up to 0 (e = 0): e lies in [0, max(0, start hi)], a step's smear left out
    r = reach(hybridlab.loads_model(RECORD), initial={"x": start}, t_end=0.6, step=0.05)
    assert r.complete
    done = [s for s in r.sets if s.mode == "done"]
    e_lo = min(s.bounds()[1, 0] for s in done)
    e_hi = max(s.bounds()[1, 1] for s in done)
    assert e_lo >= -1e-9 and e_lo <= 0.0
    assert max(0.0, start[1]) - 1e-12 <= e_hi <= max(0.0, start[1]) + 1e-9
    for x0 in np.linspace(*start, 5):  # simulated: x(t) = x0 + t, e = max(x0, 0)
        e = max(x0, 0.0)
        t_fire = max(-x0, 0.0)
        for t in np.linspace(t_fire, 0.6, 7):
            inside = [s for s in done if s.t[0] <= t <= s.t[1]]
            assert any(s.contains([[x0 + t, e]])[0] for s in inside)
