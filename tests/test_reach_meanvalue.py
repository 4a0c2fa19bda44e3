"""The mean-value enclosures over zonotopes: sound for random smooth functions, and tight
where interval arithmetic over the box is not."""

from __future__ import annotations

import numpy as np
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from hybridlab.reachability.meanvalue import MeanValue
from hybridlab.reachability.sets import Zonotope

X, Y, U = sp.symbols("x y u", real=True)
TERMS = [X, Y, U, X * Y, X**2, sp.sin(X), sp.cos(Y), U * X, sp.exp(Y / 2), Y**3]
#: a random function of the terms, a zonotope of (x, y), an input box and a sampling seed
RANDOM_CASES = dict(
    coefs=st.lists(st.floats(-3, 3), min_size=len(TERMS), max_size=len(TERMS)),
    centre=st.tuples(st.floats(-1, 1), st.floats(-1, 1)),
    gens=st.lists(st.floats(-0.5, 0.5), min_size=6, max_size=6),
    u_box=st.tuples(st.floats(-1, 1), st.floats(0, 0.5)),
    seed=st.integers(0, 2**16))


@settings(max_examples=40, deadline=None)
@given(**RANDOM_CASES)
def test_sampled_points_lie_in_the_enclosure(coefs, centre, gens, u_box, seed):
    f = sum((c * t for c, t in zip(coefs, TERMS, strict=True)), sp.Integer(0))
    mv = MeanValue([f, sp.diff(f, X)], [X, Y], [U])
    Z = Zonotope(list(centre), np.array(gens).reshape(2, 3))
    u_lo, u_hi = np.array([u_box[0]]), np.array([u_box[0] + u_box[1]])
    lo, hi = mv(Z, u_lo, u_hi)
    value = sp.lambdify([X, Y, U], [f, sp.diff(f, X)], "numpy")
    rng = np.random.default_rng(seed)
    beta = rng.uniform(-1, 1, size=(200, 3))
    beta[:8] = np.sign(beta[:8])  # corners too
    points = Z.center + beta @ Z.generators.T
    us = rng.uniform(u_lo[0], u_hi[0], size=200)
    for (x, y), u in zip(points, us, strict=True):
        v = np.array(value(x, y, u), dtype=float)
        slack = 1e-12 * (1 + np.abs(v))
        assert np.all(lo - slack <= v) and np.all(v <= hi + slack)


def test_correlated_states_cancel_where_the_box_does_not():
    # a stiff controller's force 5000 (z - x) over a thin set along x = z: the box gives
    # +-5000, the mean-value form nearly 0
    mv = MeanValue([5000 * (Y - X)], [X, Y], [])
    Z = Zonotope([0.5, 0.5], [[0.5, 1e-6], [0.5, 0.0]])
    lo, hi = mv(Z, np.zeros(0), np.zeros(0))
    box_lo, box_hi = mv.value(*Z.bounds().T)
    assert hi[0] - lo[0] < 0.011 and box_hi[0] - box_lo[0] > 9999


@settings(max_examples=40, deadline=None)
@given(**RANDOM_CASES)
def test_the_second_order_form_holds_sampled_points(coefs, centre, gens, u_box, seed):
    f = sum((c * t for c, t in zip(coefs, TERMS, strict=True)), sp.Integer(0))
    mv = MeanValue([f], [X, Y], [U], second_order=True)
    Z = Zonotope(list(centre), np.array(gens).reshape(2, 3))
    u_lo, u_hi = np.array([u_box[0]]), np.array([u_box[0] + u_box[1]])
    lo, hi = mv(Z, u_lo, u_hi)
    form = mv.linear_form(Z, u_lo, u_hi)
    assert form is not None
    v_lo, v_hi, grad, slack = form
    value = sp.lambdify([X, Y, U], f, "numpy")
    rng = np.random.default_rng(seed)
    beta = rng.uniform(-1, 1, size=(200, 3))
    beta[:8] = np.sign(beta[:8])
    points = Z.center + beta @ Z.generators.T
    us = rng.uniform(u_lo[0], u_hi[0], size=200)
    for z, u in zip(points, us, strict=True):
        v = float(value(z[0], z[1], u))
        tol = 1e-12 * (1 + abs(v))
        assert lo[0] - tol <= v <= hi[0] + tol
        affine = float(grad[0] @ (z - Z.center))
        assert v_lo[0] - slack[0] + affine - tol <= v <= v_hi[0] + slack[0] + affine + tol


def test_the_second_order_form_keeps_a_gain_that_varies_with_an_angle():
    # k (x - y) cos(phi) over x = y (correlated) and a range of phi: the first-order form's
    # Jacobian over the box varies with phi, times the wide spread of x and y separately;
    # the second-order form takes the Jacobian at the centre (where x - y cancels) and
    # only the Hessian's spread over the box (sin(phi) over [0.2, 0.4]) by the box
    phi = sp.Symbol("phi", real=True)
    f = 1000 * (X - Y) * sp.cos(phi)
    Z = Zonotope([5.0, 5.0, 0.3], [[1.0, 0.0], [1.0, 0.0], [0.0, 0.1]])
    first = MeanValue([f], [X, Y, phi], [])(Z, np.zeros(0), np.zeros(0))
    second = MeanValue([f], [X, Y, phi], [], second_order=True)(Z, np.zeros(0), np.zeros(0))
    assert first[0][0] < -100 and first[1][0] > 100              # 1000 * 0.1 * sin(0.4) ...
    assert -30 < second[0][0] <= 0 <= second[1][0] < 30
