"""Bounds of a zonotope cut by half-spaces: certified by weak duality, tight as the LP."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linprog

from hybridlab.reachability.lp import _Cut, cut_bounds


def _lp_bounds(c, G, A, b):
    """The exact LP optimum per coordinate (scipy), or None when infeasible."""
    m = G.shape[1]
    out = []
    for i in range(len(c)):
        row = []
        for sign in (1.0, -1.0):
            res = linprog(sign * G[i], A_ub=A @ G, b_ub=b - A @ c, bounds=[(-1, 1)] * m,
                          method="highs")
            if res.status == 2:
                return None
            row.append(c[i] + sign * res.fun)
        out.append(row)
    return np.array(out)


def _random_cut(rng, n, m, k):
    c = rng.normal(size=n) * 10.0 ** rng.integers(-3, 4)
    G = rng.normal(size=(n, m)) * 10.0 ** rng.integers(-3, 3, size=(n, 1))
    A = rng.normal(size=(k, n))
    b = A @ c + rng.normal(size=k) * np.abs(A @ G).sum(axis=1) * 0.5
    return c, G, A, b


@pytest.mark.parametrize("seed", range(6))
def test_cut_bounds_contain_every_feasible_point_and_match_the_lp(seed):
    rng = np.random.default_rng(seed)
    c, G, A, b = _random_cut(rng, 5, 9, 3)
    out = cut_bounds(c, G, A, b)
    exact = _lp_bounds(c, G, A, b)
    if exact is None:
        assert out is None
        return
    assert out is not None
    scale = 1.0 + np.abs(exact)
    assert np.all(out[:, 0] <= exact[:, 0]) and np.all(out[:, 1] >= exact[:, 1])
    assert np.all(exact[:, 0] - out[:, 0] <= 1e-9 * scale[:, 0])
    assert np.all(out[:, 1] - exact[:, 1] <= 1e-9 * scale[:, 1])
    beta = rng.uniform(-1.0, 1.0, size=(G.shape[1], 20000))
    X = c[:, None] + G @ beta
    inside = np.all(b[:, None] >= A @ X, axis=0)
    assert inside.any()
    X = X[:, inside]
    assert np.all(out[:, :1] <= X) and np.all(out[:, 1:] >= X)


def test_any_nonnegative_dual_gives_a_valid_bound_only_looser():
    rng = np.random.default_rng(7)
    exact = None
    while exact is None:
        c, G, A, b = _random_cut(rng, 4, 6, 3)
        exact = _lp_bounds(c, G, A, b)
    cut = _Cut(A, b, c, G)
    F = np.array([G[0]] * 50)
    Y = np.abs(rng.normal(size=(50, 3))) * 10.0 ** rng.integers(-3, 3, size=(50, 1))
    low = cut.lower_bounds(F, Y)
    assert np.all(c[0] + low <= exact[0, 0] + 1e-12 * (1 + abs(exact[0, 0])))


def test_an_empty_cut_is_none_only_with_a_certificate():
    c, G = np.zeros(3), np.eye(3)
    A = np.array([[1.0, 1.0, 1.0], [-1.0, 0.0, 0.0]])
    assert cut_bounds(c, G, A, np.array([-1.1, -0.95])) is None  # x >= 0.95, x + y + z <= -1.1
    # touching in one point is not empty
    out = cut_bounds(c, G, A, np.array([-1.0, -1.0]))              # x = 1, y = z = -1
    assert out is not None
    assert out[0, 0] <= 1.0 <= out[0, 1] and out[1, 0] <= -1.0 <= out[1, 1]


def test_only_the_asked_coordinates_are_solved():
    c, G = np.ones(2), np.eye(2)
    A, b = np.array([[1.0, 1.0], [-1.0, 1.0]]), np.array([1.0, -0.5])
    out = cut_bounds(c, G, A, b, dims=[1])
    assert out[0].tolist() == pytest.approx([0.0, 2.0])
    assert out[1].tolist() == pytest.approx([0.0, 0.25], abs=1e-12)
