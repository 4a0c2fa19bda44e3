"""The linearisation remainder's bound: sound on random flows, and to third order where a
nonlinear factor multiplies a stiff, correlated linear one."""

from __future__ import annotations

import numpy as np
import sympy as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hybridlab.reachability.nonlinear import remainder_bound
from hybridlab.reachability.sets import Zonotope
from hybridlab.reachability.system import ModeSystem, Rows
from hybridlab.symbolic.printing import numpy_function

phi, x, r, u = sp.symbols("phi x r u", real=True)
Z = (phi, x, r)


def _mode(flow, inputs=()) -> ModeSystem:
    return ModeSystem("m", tuple(flow), Z, tuple(inputs), Rows([], Z), (), Rows([], Z))


def _worst_remainder(m: ModeSystem, H: Zonotope, z_star, u_lo, u_hi, n: int, seed: int):
    """The largest ``|f(w) - f(w*) - J(w*) (w - w*)|`` per row over sampled ``w`` (random
    points and vertices of ``H`` times the input box)."""
    f = numpy_function([list(m.zsyms), list(m.usyms)], list(m.flow))
    J = numpy_function([list(m.zsyms), list(m.usyms)],
                       list(sp.Matrix(m.flow).jacobian(m.wsyms)))
    nz, nu = len(m.zsyms), len(m.usyms)
    u_mid = 0.5 * (u_lo + u_hi)
    f0 = np.asarray(f(z_star, u_mid), dtype=float)
    J0 = np.asarray(J(z_star, u_mid), dtype=float).reshape(nz, nz + nu)
    rng = np.random.default_rng(seed)
    beta = rng.uniform(-1, 1, (n, H.generators.shape[1]))
    beta[: n // 2] = np.sign(beta[: n // 2])  # vertices
    worst, size = np.zeros(nz), np.zeros(nz)
    for b in beta:
        z = H.center + H.generators @ b
        v = rng.uniform(u_lo, u_hi) if nu else np.zeros(0)
        d = np.r_[z - z_star, v - u_mid]
        fz = np.asarray(f(z, v), dtype=float)
        worst = np.maximum(worst, np.abs(fz - f0 - J0 @ d))
        size = np.maximum(size, np.abs(fz) + np.abs(f0) + np.abs(J0) @ np.abs(d))
    return worst, size  # size: what this evaluation's own rounding is relative to


@st.composite
def _cases(draw):
    c = draw(st.lists(st.floats(-2.0, 2.0, allow_nan=False), min_size=7, max_size=7))
    gain = draw(st.sampled_from([1.0, 1e3, 6e4]))
    flow = [c[0] * x * phi + c[1] * sp.sin(phi) * r + c[2] * phi ** 3,
            gain * sp.cos(phi) * (r - x) + c[3] * sp.sin(phi) * u + c[4] * x ** 2 * phi,
            c[5] * r * sp.exp(phi / 2) + c[6] * x * r ** 2]
    centre = np.array(draw(st.tuples(*[st.floats(-0.5, 0.5)] * 3)))
    G = np.array(draw(st.lists(st.tuples(*[st.floats(-0.05, 0.05)] * 3), min_size=1,
                               max_size=4))).T
    # x and r move together (a tracking controller), up to a small tracking error
    shared = draw(st.floats(0.0, 0.01))
    G = np.hstack([G * np.array([[1.0], [0.01], [0.01]]), [[0.0], [shared], [shared]]])
    shift = np.array(draw(st.tuples(*[st.floats(-0.01, 0.01)] * 3)))
    return flow, Zonotope(centre, G), centre + shift * np.abs(G).sum(axis=1)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_cases())
def test_the_remainder_bound_holds_on_sampled_points(case):
    flow, H, z_star = case
    m = _mode(flow, (u,))
    u_lo, u_hi = np.array([-1.0]), np.array([1.0])
    bound = remainder_bound(m, H, z_star, u_lo, u_hi, np.zeros(1))
    worst, size = _worst_remainder(m, H, z_star, u_lo, u_hi, 200, seed=1)
    assert np.all(worst <= bound * (1 + 1e-9) + 1e-13 * size), (worst, bound)


def test_a_stiff_factor_times_a_nonlinear_one_is_bounded_to_third_order():
    """``omega' = 6e4 cos(phi) (r - x)`` over a set where ``x`` and ``r`` are millimetres
    wide but micrometres apart: the Hessian's variation with ``phi`` times ``|dx| + |dr|``
    dominates the second-order bound; the third-order one cancels it as ``d(r - x)``."""
    m = _mode([sp.Integer(0), 6e4 * sp.cos(phi) * (r - x), sp.Integer(0)])
    H = Zonotope([0.1, 0.2, 0.2], [[0.05, 0.0, 0.0], [0.0, 3e-3, 1e-6], [0.0, 3e-3, -1e-6]])
    z_star = H.center.copy()
    none = np.zeros(0)
    bound = remainder_bound(m, H, z_star, none, none, none)
    second = _mode(m.flow)
    second.__dict__["third"] = None  # the second-order bound alone
    loose = remainder_bound(second, H, z_star, none, none, none)
    worst, _ = _worst_remainder(m, H, z_star, none, none, 400, seed=2)
    assert worst[1] <= bound[1] and bound[1] < loose[1] / 50
    assert bound[1] < 30 * worst[1]


def test_a_set_of_many_generators_is_reduced_for_the_form_and_the_bound_still_holds(
        monkeypatch):
    """A step set with 600 generators, most of them small (as a flowpipe's are): the
    quadratic form is summed over the zonotope reduced to ``FORM_ORDER`` per variable, a
    superset, so the bound holds on sampled points and stays within a few per cent of the
    sum over every generator."""
    from hybridlab.reachability import nonlinear

    rng = np.random.default_rng(3)
    m = _mode([x * phi + sp.sin(phi) * r, 6e4 * sp.cos(phi) * (r - x), x * r ** 2])
    scale = np.array([[2e-4], [1e-5], [1e-5]])
    G = np.hstack([rng.normal(0.0, 1.0, (3, 60)), 1e-3 * rng.normal(0.0, 1.0, (3, 540))])
    H = Zonotope([0.1, 0.2, 0.2], G * scale)
    z_star = H.center.copy()
    none = np.zeros(0)
    summed = []
    monkeypatch.setattr(nonlinear, "_form_abs_sum", lambda S, D, f=nonlinear._form_abs_sum:
                        summed.append(D.shape[1]) or f(S, D))
    bound = remainder_bound(m, H, z_star, none, none, none)
    assert summed and max(summed) <= nonlinear.FORM_ORDER * 3 < G.shape[1]
    worst, size = _worst_remainder(m, H, z_star, none, none, 400, seed=4)
    assert np.all(worst <= bound * (1 + 1e-9) + 1e-13 * size)
    monkeypatch.setattr(nonlinear, "FORM_ORDER", 10_000)  # every generator summed
    whole = remainder_bound(m, H, z_star, none, none, none)
    assert np.all(whole <= bound) and np.all(bound <= 1.05 * whole)


def test_modes_sharing_rows_take_each_derivative_once_and_get_sympys_derivatives():
    # two modes of one system: the same curved row (a pendulum's), different references;
    # the second mode takes only the derivatives of the row it does not share, and each
    # mode's Hessian and third derivatives are sympy's own, with the sign's impulses dropped
    from hybridlab.reachability.derivatives import Derivatives

    shared = Derivatives()
    rows = [sp.sin(phi) * x**2 + sp.sign(x), -x + r]
    a = ModeSystem("a", (rows[0], rows[1], 1 - r), Z, (), Rows([], Z), (), Rows([], Z),
                   derivatives=shared)
    b = ModeSystem("b", (rows[0], rows[1], 2 - r * x), Z, (), Rows([], Z), (), Rows([], Z),
                   derivatives=shared)
    assert a.hessian is not None and a.third is not None
    after_a = len(shared)
    assert b.hessian is not None and b.third is not None
    alone = Derivatives()
    assert ModeSystem("b", b.flow, Z, (), Rows([], Z), (), Rows([], Z),
                      derivatives=alone).third is not None
    assert 0 < len(shared) - after_a < len(alone)  # b's own row only
    for mode in (a, b):
        hess = [sp.diff(f, v, w).replace(sp.DiracDelta, lambda *_: 0)
                for f in mode.flow for v in Z for w in Z]
        assert [sp.simplify(h - e) for h, e in zip(hess, mode.hessian.exprs, strict=True)] \
            == [0] * len(hess)
        third = mode.third
        for i, j, k, m, e in zip(third.rows, third.first, third.second, third.linear,
                                 third.function.exprs, strict=True):
            assert sp.simplify(sp.diff(mode.flow[i], Z[j], Z[k], Z[m])
                               .replace(sp.DiracDelta, lambda *_: 0) - e) == 0
