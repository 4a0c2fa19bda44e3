"""Taylor-model flowpipes: exact solutions enclosed tightly, sampled trajectories enclosed."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

import hybridlab
from hybridlab.reachability import reach
from hybridlab.reachability.nonlinear import TAYLOR_APPLIES, FlowStepper, RemainderError
from hybridlab.reachability.options import ReachOptions
from hybridlab.reachability.sets import Zonotope
from hybridlab.reachability.system import build_system
from hybridlab.reachability.taylor import ERROR_ORDER, TaylorError, TaylorFlowpipe, orders

x, y = sp.symbols("x y")


def _pipe(flow, syms, box, h, steps):
    """The end sets and step sets of ``steps`` Taylor-model steps from a box."""
    lo, hi = np.asarray(box, dtype=float).T
    pipe = TaylorFlowpipe(flow, syms)
    X = pipe.start(Zonotope(0.5 * (lo + hi), np.diag(0.5 * (hi - lo))))
    ends, segments = [], []
    for _ in range(steps):
        X, end, segment = pipe.step(X, h)
        ends.append(end)
        segments.append(segment)
    return ends, segments


def _escapes(rhs, box, h, ends, segments, n_random=12, seed=0, per_step=3, corners=16):
    """Trajectories from (at most ``corners``) corners and random points of ``box`` outside
    the sets: at every step's end (in the end set) and at ``per_step`` instants within
    each step (in that step's set)."""
    lo, hi = np.asarray(box, dtype=float).T
    rng = np.random.default_rng(seed)
    vertices = np.array(np.meshgrid(*zip(lo, hi, strict=True))).reshape(lo.size, -1).T
    if len(vertices) > corners:
        vertices = vertices[rng.choice(len(vertices), corners, replace=False)]
    starts = np.vstack([vertices, rng.uniform(lo, hi, (n_random, lo.size))])
    T = h * len(ends)
    escapes = 0
    for z0 in starts:
        sol = solve_ivp(rhs, (0.0, T), z0, rtol=1e-10, atol=1e-12, dense_output=True)
        for k, (end, segment) in enumerate(zip(ends, segments, strict=True)):
            escapes += not end.contains_points(sol.sol((k + 1) * h))
            for tau in rng.uniform(0, 1, per_step):
                escapes += not segment.contains_points(sol.sol((k + tau) * h))
    return escapes


def test_orders_trade_space_order_against_variables():
    assert orders(2)[0] > orders(4)[0] > orders(7)[0] >= 1
    assert [orders(m)[1] for m in (1, 7)] == [6, 6]


def test_linear_decay_is_enclosed_tightly():
    ends, segments = _pipe([-x], [x], [(0.9, 1.1)], 0.1, 10)
    exact = np.exp(-1.0) * np.array([0.9, 1.1])
    lo, hi = ends[-1].bounds()[0]
    assert lo <= exact[0] and exact[1] <= hi
    assert (hi - lo) - (exact[1] - exact[0]) < 1e-8
    # each step's set holds the whole step, and not much more
    for k, seg in enumerate(segments):
        b = seg.bounds()[0]
        assert b[0] <= 0.9 * np.exp(-0.1 * (k + 1)) and b[1] >= 1.1 * np.exp(-0.1 * k)
        assert b[1] - b[0] < 1.1 * (1.1 * np.exp(-0.1 * k) - 0.9 * np.exp(-0.1 * (k + 1)))


def test_cubic_decay_closed_form_is_enclosed_tightly():
    # x' = -x^3 from [0.5, 1]: x(t) = x0 / sqrt(1 + 2 x0^2 t)
    pipe = TaylorFlowpipe([-x ** 3], [x])
    X = pipe.start(Zonotope([0.75], [[0.25]]))
    for _ in range(20):
        X, end, _ = pipe.step(X, 0.05)
    s = np.linspace(-1, 1, 41)
    exact = (0.75 + 0.25 * s) / np.sqrt(1 + 2 * (0.75 + 0.25 * s) ** 2 * 1.0)
    lo, hi = end.bounds()[0]
    assert lo <= exact.min() and exact.max() <= hi
    # the zonotope pays for the curvature (its s^2 term boxed), the model does not: its
    # polynomial at s matches the solution from 0.75 + 0.25 s within its error terms
    B = X.basis
    mono = s[:, None] ** B.exps[:, 0] * (B.exps[:, 1] == 0)  # q_1 = 0, tau = 1 (exps 0)
    model = mono @ X.coeffs[0]
    slack = np.abs(X.coeffs[0, B.q_index]).sum() + X.rad[0]
    assert np.all(np.abs(model - exact) <= slack) and slack < 1e-5
    assert (hi - lo) < 1.15 * (exact.max() - exact.min())


def test_rotation_does_not_wrap():
    # a quarter turn of a box in 32 steps: boxed at every step it would grow by sqrt(2)
    # per eighth turn; the polynomial model turns it exactly
    ends, _ = _pipe([y, -x], [x, y], [(0.9, 1.1), (-0.1, 0.1)], np.pi / 64, 32)
    assert np.allclose(ends[-1].bounds(), [[-0.1, 0.1], [-1.1, -0.9]], atol=1e-9)
    angle = np.linspace(0, 2 * np.pi, 9)[:-1]
    pts = np.column_stack([1 + 0.1 * np.cos(angle), 0.1 * np.sin(angle)])
    turned = np.column_stack([-pts[:, 1], -pts[:, 0]])  # (x, y) -> (-y, -x) after pi/2
    assert ends[-1].contains_points(turned).all()


def _model_at(X, s):
    """The end set's polynomial at initial-set variables ``s`` (rows), ``q = 0``, and the
    slack of its error terms (``q`` part and interval) per state."""
    B = X.basis
    e = B.exps
    errors = e[:, B.m:B.m + B.n].sum(1) > 0
    mono = np.prod(s[:, None, :] ** e[None, :, :B.m], axis=2) * (e[:, B.m:].sum(1) == 0)
    slack = np.abs(X.coeffs[:, errors]).sum(1) + X.rad
    return mono @ X.coeffs.T, slack


@pytest.mark.parametrize("kq", [1, 2, 4])
def test_low_order_models_hold_each_solution_pointwise(kq):
    # at a low space order the truncated terms dominate the error terms: the model at s
    # must still hold the solution from c + G s, point by point (sharper than the sets)
    c, g = np.array([1.4, 2.4]), np.array([0.15, 0.05])
    pipe = TaylorFlowpipe([y, (1 - x ** 2) * y - x], [x, y], space_order=kq)
    X = pipe.start(Zonotope(c, np.diag(g)))
    s = np.random.default_rng(2).uniform(-1, 1, (12, 2))
    s[:4] = [[1, 1], [1, -1], [-1, 1], [-1, -1]]
    for k in range(1, 26):
        X, _, _ = pipe.step(X, 0.04)
        if k % 5 == 0:
            model, slack = _model_at(X, s)
            for z0, m in zip(c + g * s, model, strict=True):
                z = solve_ivp(_vdp, (0, 0.04 * k), z0, rtol=1e-12, atol=1e-13).y[:, -1]
                assert np.all(np.abs(z - m) <= slack), (k, z0, z - m, slack)
    # and the error terms are small, not a box around everything
    assert np.all(slack < {1: 0.15, 2: 0.015, 4: 3e-3}[kq])


def _vdp(t, z):
    return [z[1], (1 - z[0] ** 2) * z[1] - z[0]]


def test_van_der_pol_trajectories_stay_in_the_flowpipe():
    box = [(1.25, 1.55), (2.35, 2.45)]
    ends, segments = _pipe([y, (1 - x ** 2) * y - x], [x, y], box, 0.04, 30)
    assert _escapes(_vdp, box, 0.04, ends, segments, n_random=8, per_step=2) == 0
    # tight: the end set is within a few percent of the sampled hull
    sol = [solve_ivp(_vdp, (0, 1.2), [a, b], rtol=1e-10, atol=1e-12).y[:, -1]
           for a in np.linspace(1.25, 1.55, 7) for b in np.linspace(2.35, 2.45, 3)]
    hull = np.ptp(np.array(sol), axis=0)
    assert np.all(np.ptp(ends[-1].bounds(), axis=1) < 1.3 * hull)


def _laub_loomis(t, z):
    x1, x2, x3, x4, x5, x6, x7 = z
    return [1.4 * x3 - 0.9 * x1, 2.5 * x5 - 1.5 * x2, 0.6 * x7 - 0.8 * x2 * x3,
            2 - 1.3 * x3 * x4, 0.7 * x1 - x4 * x5, 0.3 * x1 - 3.1 * x6, 1.8 * x6 - 1.5 * x2 * x7]


def test_laub_loomis_trajectories_stay_in_the_flowpipe():
    z = sp.symbols("x1:8")
    rat = sp.Rational
    flow = [rat(14, 10) * z[2] - rat(9, 10) * z[0], rat(5, 2) * z[4] - rat(3, 2) * z[1],
            rat(6, 10) * z[6] - rat(8, 10) * z[1] * z[2], 2 - rat(13, 10) * z[2] * z[3],
            rat(7, 10) * z[0] - z[3] * z[4], rat(3, 10) * z[0] - rat(31, 10) * z[5],
            rat(18, 10) * z[5] - rat(3, 2) * z[1] * z[6]]
    centre = np.array([1.2, 1.05, 1.5, 2.4, 1.0, 0.1, 0.45])
    box = np.column_stack([centre - 0.1, centre + 0.1])
    ends, segments = _pipe(flow, z, box, 0.05, 20)
    assert _escapes(_laub_loomis, box, 0.05, ends, segments, n_random=4, per_step=1,
                    corners=8) == 0


def _coupled_vdp(t, z):
    x1, y1, x2, y2, b = z
    return [y1, (1 - x1 ** 2) * y1 + b * (x2 - x1) - x1,
            y2, (1 - x2 ** 2) * y2 - b * (x2 - x1) - x2, 0.0]


def test_coupled_van_der_pol_trajectories_stay_in_the_flowpipe():
    # CVDP23's box, the coupling b in [1, 3] a state of flow 0, over its first 1.4 s at the
    # default step (five uncertain directions: space order 3, error terms times s)
    x1, y1, x2, y2, b = z = sp.symbols("x1 y1 x2 y2 b")
    flow = [y1, (1 - x1 ** 2) * y1 + b * (x2 - x1) - x1,
            y2, (1 - x2 ** 2) * y2 - b * (x2 - x1) - x2, sp.Integer(0)]
    box = [(1.25, 1.55), (2.35, 2.45), (1.25, 1.55), (2.35, 2.45), (1.0, 3.0)]
    ends, segments = _pipe(flow, z, box, 0.0175, 80)
    assert _escapes(_coupled_vdp, box, 0.0175, ends, segments, n_random=6, per_step=1,
                    corners=10) == 0


def test_laub_loomis_wide_box_errors_do_not_compound():
    # W = 0.1 over 8 s: the accumulated errors keep their directions (re-enclosing them
    # in one parallelepiped per step wrapped them until the step failed near t = 8.9)
    z = sp.symbols("x1:8")
    flow = [sp.nsimplify(e) for e in (
        1.4 * z[2] - 0.9 * z[0], 2.5 * z[4] - 1.5 * z[1], 0.6 * z[6] - 0.8 * z[1] * z[2],
        2 - 1.3 * z[2] * z[3], 0.7 * z[0] - z[3] * z[4], 0.3 * z[0] - 3.1 * z[5],
        1.8 * z[5] - 1.5 * z[1] * z[6])]
    centre = np.array([1.2, 1.05, 1.5, 2.4, 1.0, 0.1, 0.45])
    pipe = TaylorFlowpipe(flow, z)
    X = pipe.start(Zonotope(centre, 0.1 * np.eye(7)))
    for _ in range(160):
        X, end, _ = pipe.step(X, 0.05)
    rng = np.random.default_rng(3)
    starts = centre + 0.1 * np.vstack([rng.choice([-1.0, 1.0], (8, 7)),
                                       rng.uniform(-1, 1, (4, 7))])
    hits = [solve_ivp(_laub_loomis, (0, 8), z0, rtol=1e-10, atol=1e-12).y[:, -1]
            for z0 in starts]
    assert end.contains_points(np.array(hits)).all()
    width = np.ptp(end.bounds(), axis=1)
    assert width[3] < 0.6, width  # 0.46 (with the parallelepiped: 1.6)


def test_elementary_functions_and_division_are_enclosed():
    # x' = sin(y) / (2 + cos(x)), y' = exp(-x) - y: a reciprocal, sin, cos and exp
    flow = [sp.sin(y) / (2 + sp.cos(x)), sp.exp(-x) - y]
    box = [(0.0, 0.4), (0.5, 0.8)]
    ends, segments = _pipe(flow, [x, y], box, 0.1, 8)

    def rhs(t, z):
        return [np.sin(z[1]) / (2 + np.cos(z[0])), np.exp(-z[0]) - z[1]]

    assert _escapes(rhs, box, 0.1, ends, segments, n_random=8) == 0
    assert np.all(np.ptp(ends[-1].bounds(), axis=1) < 0.5)


def test_a_divisor_whose_range_contains_zero_is_an_error():
    pipe = TaylorFlowpipe([1 / x], [x])
    X = pipe.start(Zonotope([0.1], [[0.2]]))
    with pytest.raises(TaylorError, match="divisor's range .* contains 0"):
        pipe.step(X, 0.01)


def test_unsupported_operations_are_refused_when_built():
    with pytest.raises(TaylorError, match="do not support"):
        TaylorFlowpipe([sp.Abs(x)], [x])
    with pytest.raises(TypeError, match="sympy expressions"):
        TaylorFlowpipe(["x"], [x])


def test_a_step_too_long_fails_with_a_remainder_error():
    # x' = x^2 from [1, 1.1] blows up before t = 1/1.1: a step of 2 cannot validate
    pipe = TaylorFlowpipe([x ** 2], [x])
    with pytest.raises(TaylorError, match="did not validate|overflows"):
        pipe.step(pipe.start(Zonotope([1.05], [[0.05]])), 2.0)


@st.composite
def _systems(draw):
    """Random 2-D flows: small polynomial and trigonometric terms."""
    c = draw(st.lists(st.floats(-1.0, 1.0, allow_nan=False), min_size=8, max_size=8))
    flow = [c[0] * x + c[1] * y + c[2] * x * y + c[3] * sp.sin(y),
            c[4] * y + c[5] * x ** 2 + c[6] * sp.cos(x) + c[7] * x * y ** 2]

    def rhs(t, z):
        a, b = z
        return [c[0] * a + c[1] * b + c[2] * a * b + c[3] * np.sin(b),
                c[4] * b + c[5] * a ** 2 + c[6] * np.cos(a) + c[7] * a * b ** 2]

    lo = draw(st.tuples(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0)))
    width = draw(st.tuples(st.floats(0.0, 0.3), st.floats(0.01, 0.3)))
    box = [(lo[0], lo[0] + width[0]), (lo[1], lo[1] + width[1])]
    return flow, rhs, box


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_systems())
def test_random_systems_trajectories_are_enclosed(system):
    flow, rhs, box = system
    ends, segments = _pipe(flow, [x, y], box, 0.1, 3)
    assert _escapes(rhs, box, 0.1, ends, segments, n_random=4, per_step=2) == 0


VDP_MODEL = '''
name = "vdp"
states = { x = 1.4, y = 2.4 }
[modes.osc]
flow = { x = "y", y = "(1 - x**2)*y - x" }
[initial]
mode = "osc"
'''


def test_reach_with_taylor_flowpipes_keeps_the_model_between_steps():
    model = hybridlab.loads_model(VDP_MODEL)
    box = {"x": (1.25, 1.55), "y": (2.35, 2.45)}
    r = reach(model, initial=box, t_end=1.0, step=0.02, flowpipe="taylor")
    assert r.complete and len(r.sets) == 50
    rng = np.random.default_rng(5)
    for z0 in rng.uniform([1.25, 2.35], [1.55, 2.45], (6, 2)):
        t = np.linspace(0, 1.0, 101)
        sol = solve_ivp(_vdp, (0, 1.0), z0, rtol=1e-10, atol=1e-12, t_eval=t)
        assert r.covers(t, sol.y.T, "osc").all()
    # the stepper continued its model: each step's set has the model's few generators
    # (s, error generators, time, box)
    assert max(s.set.generators.shape[1] for s in r.sets) <= 2 + ERROR_ORDER * 2 + 1 + 2
    with pytest.raises(ValueError, match="flowpipe must be"):
        ReachOptions(flowpipe="polynomial")


def test_stepper_falls_back_to_linearisation_where_taylor_models_do_not_apply():
    model = hybridlab.loads_model(VDP_MODEL.replace('"(1 - x**2)*y - x"', '"-abs(x)*y"'))
    c = hybridlab.compile_model(model)
    system = build_system(c, c.parameter_vector(), {}, {})
    stepper = FlowStepper(system, "osc", ReachOptions(flowpipe="taylor"))
    P, H = stepper.step(Zonotope([1.4, 2.4], np.diag([0.01, 0.01])), 0.01)
    assert stepper.taylor_model() is None and H.contains_points([1.4, 2.4])
    # its linearisation's failure does not point at Taylor models; Van der Pol's does
    with pytest.raises(RemainderError) as info:
        FlowStepper(system, "osc", ReachOptions()).step(
            Zonotope([1.4, 2.4], np.diag([3.0, 3.0])), 2.0)
    assert TAYLOR_APPLIES not in str(info.value)
    c = hybridlab.compile_model(hybridlab.loads_model(VDP_MODEL))
    with pytest.raises(RemainderError, match=r"flowpipe='taylor'"):
        FlowStepper(build_system(c, c.parameter_vector(), {}, {}), "osc",
                    ReachOptions()).step(Zonotope([1.4, 2.4], np.diag([3.0, 3.0])), 2.0)
    # a Taylor step that fails is a RemainderError, which the callers' refinements know
    blow = hybridlab.loads_model(VDP_MODEL.replace('"(1 - x**2)*y - x"', '"y**2"'))
    c = hybridlab.compile_model(blow)
    stepper = FlowStepper(build_system(c, c.parameter_vector(), {}, {}), "osc",
                          ReachOptions(flowpipe="taylor"))
    with pytest.raises(RemainderError, match="Taylor model"):
        stepper.step(Zonotope([1.0, 2.0], np.diag([0.1, 0.1])), 5.0)


def test_check_tries_taylor_flowpipes_before_splitting(models_dir):
    from hybridlab.io import load_spaceex
    from hybridlab.reachability.falsify import FalsifyOptions
    from hybridlab.reachability.verdict import VerdictStatus, check

    vdp = load_spaceex(models_dir / "spaceex" / "vanderpol.xml",
                       models_dir / "spaceex" / "vanderpol.cfg")
    kw = {k: v for k, v in vdp.reach_kwargs().items() if k != "step"}
    kw["t_end"] = 4.0
    whole = reach(vdp.model, **kw, step=0.05)
    assert not whole.complete and whole.too_wide  # linearised, the set outgrows its remainder
    assert TAYLOR_APPLIES in whole.incomplete_reasons[0]
    verdict = check(vdp.model, safe=vdp.safe_specs(), **kw, step=0.05,
                    falsify_options=FalsifyOptions(samples=0, local_evals=0))
    assert verdict.status is VerdictStatus.SAFE
    assert "flowpipe='taylor'" in verdict.reason and "split" not in verdict.reason


@pytest.mark.parametrize("kq", [1, 13])
@pytest.mark.parametrize("name", ["sin", "cos", "exp", "reciprocal"])
def test_elementary_functions_of_wide_models_enclose_their_values(name, kq):
    # a wide argument: the series is cut at degree kq + kt; at kq = 1 the truncated
    # products, at kq = 13 (no time variable) the Lagrange remainder must cover the rest
    import hybridlab.reachability.taylor as taylor

    B = taylor._basis(1, 0, kq, 0 if kq == 13 else 6, 0)
    c = np.zeros(B.size)
    w = 0.8 if name == "reciprocal" else 2.5  # the Lagrange form of 1/x is loose near 0
    c[0], c[B.s_index[0]] = 2.0, w  # the argument 2 + w s, s in [-1, 1]
    f = {"sin": (lambda a: taylor._sin_cos(B, a, False), np.sin),
         "cos": (lambda a: taylor._sin_cos(B, a, True), np.cos),
         "exp": (lambda a: taylor._exp(B, a), np.exp),
         "reciprocal": (lambda a: taylor._reciprocal(B, a), lambda v: 1 / v)}[name]
    coeffs, rad = f[0]((c, 0.0))
    s = np.linspace(-1, 1, 401)
    model = (s[:, None] ** B.exps[:, 0] * (B.exps[:, 1] == 0)) @ coeffs
    exact = f[1](2.0 + w * s)
    assert np.all(np.abs(exact - model) <= rad)
    assert rad < 3 * np.ptp(exact)  # an enclosure, not the whole line


def _evaluate(B, coeffs: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The polynomial at ``points`` (rows: the s and q variables in [-1, 1], tau in [0, 1])."""
    return np.prod(points[:, None, :] ** B.exps[None, :, :], axis=2) @ coeffs


@pytest.mark.parametrize("seed", range(6))
def test_a_taylor_model_product_encloses_the_product_at_every_point(seed):
    # random models over a basis that truncates (s^2 times s^2, tau^2 times tau), with
    # coefficients over eight orders of magnitude and interval parts: the product's
    # polynomial plus its interval holds every product of two values the factors allow
    import hybridlab.reachability.taylor as taylor

    rng = np.random.default_rng(seed)
    B = taylor._basis(2, 1, 2, 2, 1)
    assert B.truncates
    a = (rng.standard_normal(B.size) * 10.0 ** rng.uniform(-4, 4, B.size), 0.01 * seed)
    b = (rng.standard_normal(B.size) * 10.0 ** rng.uniform(-4, 4, B.size), 0.0)
    c, rad = taylor._mul(B, a, b)
    points = np.column_stack([rng.uniform(-1, 1, (4000, 3)), rng.uniform(0, 1, 4000)])
    points[:8, :3] = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
    points[:8, 3] = 1.0
    va, vb, vc = (_evaluate(B, x, points) for x in (a[0], b[0], c))
    for u in (-1.0, 1.0):  # the factors' interval parts at their ends
        assert np.all(np.abs((va + u * a[1]) * vb - vc) <= rad)
    lo, hi = taylor._range(B, c)
    assert lo <= vc.min() and vc.max() <= hi
    # the monomials bounded one by one: s + s^2 over [-1, 1] is within [-1, 2] exactly
    e = np.zeros(B.size)
    e[B.s_index[0]] = 1.0
    e[int(np.flatnonzero((B.exps == [2, 0, 0, 0]).all(axis=1))[0])] = 1.0
    lo, hi = taylor._range(B, e)
    assert -1.0 - 1e-12 < lo <= -1.0 and 2.0 <= hi < 2.0 + 1e-12
