"""Set operations of hybridlab.reachability: sound by sampling (intervals: test_symbolic_intervals).

Every operation must contain the image of every sampled point (Hypothesis draws
the boxes, zonotopes and matrices); the LP-free intersection bounds are compared
with HiGHS.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.optimize import linprog

from hybridlab.reachability import (
    Box,
    Polytope,
    SetError,
    Zonotope,
)

finite = st.floats(-50, 50, allow_nan=False, allow_infinity=False)


@st.composite
def zonotopes(draw, n=None, max_m=6):
    n = n or draw(st.integers(1, 3))
    m = draw(st.integers(0, max_m))
    c = np.array(draw(st.lists(finite, min_size=n, max_size=n)))
    G = np.array(draw(st.lists(st.floats(-3, 3), min_size=n * m, max_size=n * m))).reshape(n, m)
    return Zonotope(c, G)


def _samples(Z: Zonotope, k: int = 200, seed: int = 0) -> np.ndarray:
    """Points of Z: random factors plus every vertex-like corner for small m."""
    rng = np.random.default_rng(seed)
    m = Z.generators.shape[1]
    B = rng.uniform(-1, 1, size=(k, m))
    if 0 < m <= 6:
        corners = np.array(np.meshgrid(*[[-1.0, 1.0]] * m)).reshape(m, -1).T
        B = np.vstack([B, corners])
    return Z.center + B @ Z.generators.T


# ----- zonotopes ---------------------------------------------------------------------------------
@settings(max_examples=40, deadline=None)
@given(Z=zonotopes())
def test_zonotope_bounds_support_and_membership_contain_its_points(Z):
    pts = _samples(Z)
    b = Z.bounds()
    assert np.all(pts >= b[:, 0] - 1e-12) and np.all(pts <= b[:, 1] + 1e-12)
    rng = np.random.default_rng(1)
    for d in rng.normal(size=(5, Z.dim)):
        assert np.all(pts @ d <= Z.support(d) + 1e-9)
    assert np.all(Z.contains_points(pts))


@settings(max_examples=40, deadline=None)
@given(Z=zonotopes(), data=st.data())
def test_linear_map_sum_and_reduction_over_approximate(Z, data):
    n = Z.dim
    entries = data.draw(st.lists(st.floats(-2, 2), min_size=n * n, max_size=n * n))
    M = np.array(entries).reshape(n, n)
    pts = _samples(Z)
    assert np.all(Z.linear_map(M).contains_points(pts @ M.T))
    big = Zonotope(Z.center, np.hstack([Z.generators] * 4))
    reduced = big.reduce(1.0)
    assert reduced.generators.shape[1] <= max(n, 1)
    assert np.all(reduced.contains_points(_samples(big, seed=2)))
    other = Zonotope(np.ones(n), np.eye(n))
    s = Z.minkowski_sum(other)
    assert np.all(s.contains_points(pts + 0.5))


def test_membership_rejects_points_outside():
    Z = Zonotope([0.0, 0.0], [[1.0, 1.0], [0.0, 1.0]])
    assert not Z.contains_points([2.0, 0.0])            # inside the box, outside Z
    assert Z.contains_points([2.0, 1.0])
    flat = Zonotope([0.0, 0.0, 0.0], [[1.0], [1.0], [0.0]])  # degenerate: LP path
    assert flat.contains_points([0.5, 0.5, 0.0])
    assert not flat.contains_points([0.5, -0.5, 0.0])


@settings(max_examples=40, deadline=None)
@given(Z=zonotopes(n=2), a=st.lists(st.floats(-2, 2), min_size=2, max_size=2),
       b=st.floats(-20, 20))
def test_halfspace_intersection_keeps_every_point_that_satisfies_it(Z, a, b):
    a = np.array(a)
    pts = _samples(Z, k=400)
    keep = pts[pts @ a <= b]
    cut = Z.intersect_halfspace(a, b)
    if cut is None:
        assert keep.size == 0
        return
    assert np.all(cut.contains_points(keep, tol=1e-7))


# entries 0 or at least 1e-6 in size: a point sampled from generators near 1e-136 is rounded
# off Z's slice, which no set operation can contain
scaled = st.floats(-3, 3).map(lambda v: 0.0 if abs(v) < 1e-6 else v)


@st.composite
def scaled_zonotopes(draw, n=3, max_m=6):
    m = draw(st.integers(0, max_m))
    c = np.array(draw(st.lists(finite, min_size=n, max_size=n)))
    G = np.array(draw(st.lists(scaled, min_size=n * m, max_size=n * m))).reshape(n, m)
    return Zonotope(c, G)


@settings(max_examples=60, deadline=None)
@given(Z=scaled_zonotopes(), a=st.lists(scaled, min_size=3, max_size=3),
       pick=st.integers(0, 10_000), width=st.sampled_from([0.0, 1e-3, 0.1, 1.0, 10.0]),
       side=st.sampled_from(["both", "lo", "hi"]))
def test_slab_intersection_keeps_every_point_in_the_slab(Z, a, pick, width, side):
    # slabs around a sampled point, down to the hyperplane through it (a sliding surface)
    a = np.array(a)
    pts = _samples(Z, k=400)
    t = pts @ a
    span = float(np.ptp(t))
    t0 = float(t[pick % len(t)])
    lo, hi = t0 - width * span, t0 + width * span
    if side == "lo":
        hi = math.inf
    elif side == "hi":
        lo = -math.inf
    cut = Z.intersect_slab(a, lo, hi)
    assert cut is not None  # the slab holds the point it was drawn around
    keep = pts[(t >= lo) & (t <= hi)]
    assert np.all(cut.contains_points(keep, tol=1e-7))
    if width == 0.0 and side == "both" and np.any(a != 0):
        # pinned: never wider along a than the halfspace cuts alone would leave
        both = Z.intersect_halfspace(a, hi).intersect_halfspace(-a, -lo)
        assert cut.support(a) + cut.support(-a) <= both.support(a) + both.support(-a) + 1e-9


@settings(max_examples=30, deadline=None)
@given(Z=zonotopes(n=3, max_m=5), a=st.lists(st.floats(-2, 2), min_size=3, max_size=3),
       lo=st.floats(-10, 10), width=st.floats(0, 5), side=st.sampled_from(["both", "lo", "hi"]))
def test_slab_bounds_match_highs(Z, a, lo, width, side):
    a = np.array(a)
    # HiGHS drops coefficients below its tolerance, the dual does not: compare where both hold
    assume(np.all((a == 0) | (np.abs(a) > 1e-6)))
    hi = lo + width
    if side == "lo":      # a . x >= lo only
        hi = math.inf
    elif side == "hi":    # a . x <= hi only
        lo = -math.inf
    got = Z.bounds_in_slab(a, lo, hi)
    G, c = Z.generators, Z.center
    m = G.shape[1]
    rows = [(a, hi)] if side == "hi" else [(-a, -lo)] if side == "lo" else [(a, hi), (-a, -lo)]
    A = np.array([r for r, _ in rows]) @ G
    rhs = np.array([b - r @ c for r, b in rows])
    if m == 0:
        return
    ref = []
    for i in range(3):
        r1 = linprog(G[i], A_ub=A, b_ub=rhs, bounds=[(-1, 1)] * m, method="highs")
        if r1.status == 2:
            assert got is None or np.allclose(a @ c, [lo, hi], atol=1e-9)
            return
        r2 = linprog(-G[i], A_ub=A, b_ub=rhs, bounds=[(-1, 1)] * m, method="highs")
        ref.append((c[i] + r1.fun, c[i] - r2.fun))
    ref = np.array(ref)
    if got is None:  # HiGHS accepts 1e-9 infeasibility; the dual bound is exact
        spread = np.abs(a @ G).sum()
        assert min(hi - (a @ c - spread), (a @ c + spread) - lo) < 1e-9
        return
    assert np.all(got[:, 0] <= ref[:, 0] + 1e-7) and np.all(got[:, 1] >= ref[:, 1] - 1e-7)
    assert np.allclose(got, ref, atol=1e-6)


def test_general_intersection_bounds_by_lp():
    Z = Zonotope([0.0, 0.0], [[1.0, 0.0], [0.0, 1.0]])
    b = Z.bounds_within([[1.0, 1.0], [1.0, -1.0]], [0.0, 0.0])   # x <= -|y|
    assert np.allclose(b, [[-1.0, 0.0], [-1.0, 1.0]], atol=1e-8)
    assert Z.bounds_within([[1.0, 0.0]], [-2.0]) is None


def test_rows_the_whole_set_satisfies_are_dropped_before_the_cut():
    Z = Zonotope([0.0, 0.0], [[1.0, 0.5], [0.0, 1.0]])
    slab = Z.bounds_within([[1.0, 0.0]], [0.2])  # one row: the LP-free slab
    with_more = Z.bounds_within([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]], [0.2, 5.0, 10.0])
    assert np.array_equal(slab, with_more)  # the two rows Z satisfies changed nothing
    assert np.array_equal(Z.bounds_within([[0.0, 1.0]], [5.0]), Z.bounds())


def test_opposite_rows_along_a_diagonal_are_one_slab_without_an_lp(monkeypatch):
    # t >= tabort and t <= tabort: the rows (1, -1) and (-1, 1), whose norm squared
    # (sqrt(2)**2) is not exactly 2; the slab needs no LP and equals the slab bounds
    from hybridlab.reachability import lp

    def no_lp(*args, **kwargs):
        raise AssertionError("an LP for a slab")

    monkeypatch.setattr(lp, "cut_bounds", no_lp)
    Z = Zonotope([0.0, 0.0, 1.0], [[1.0, 0.2, 0.0], [0.0, 1.0, 0.0], [0.5, 0.0, 1.0]])
    cut = Z.bounds_within([[-1.0, 1.0, 0.0], [1.0, -1.0, 0.0]], [0.0, 0.0])
    assert np.array_equal(cut, Z.bounds_in_slab(np.array([-1.0, 1.0, 0.0]), -0.0, 0.0))


# ----- boxes and polytopes ----------------------------------------------------------------------
def test_box_and_polytope_agree_on_a_square():
    box = Box([0.0, 0.0], [1.0, 2.0])
    poly = Polytope([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]], [1.0, 0.0, 2.0, 0.0])
    for d in ([1.0, 1.0], [-1.0, 2.0], [0.3, -0.7]):
        assert poly.support(d) == pytest.approx(box.support(d), abs=1e-9)
    assert np.allclose(poly.bounds(), box.bounds(), atol=1e-8)
    z = box.to_zonotope()
    assert np.allclose(z.bounds(), box.bounds())
    pts = np.array([[0.5, 1.0], [1.5, 1.0]])
    assert box.contains_points(pts).tolist() == poly.contains_points(pts).tolist() == [True,
                                                                                        False]


def test_set_errors_name_the_argument():
    with pytest.raises(SetError, match="lo must not exceed hi"):
        Box([1.0], [0.0])
    with pytest.raises(SetError, match="generators must have shape"):
        Zonotope([0.0, 0.0], [[1.0, 0.0, 0.0]])
    with pytest.raises(SetError, match="unbounded"):
        Polytope([[1.0, 0.0]], [1.0]).bounds()
    with pytest.raises(SetError, match="points must have 2 columns"):
        Box([0.0, 0.0], [1.0, 1.0]).contains_points([1.0, 2.0, 3.0])


def test_membership_lp_is_robust_to_badly_scaled_states():
    """A trolley flowpipe set (18 states, 379 generators, extents from 1e-2 down to 3e-12)
    and a simulated state inside it (tests/data; found by the trolley soundness test).
    Unscaled, HiGHS returned an unknown status for this inside point; rows are now scaled by
    their extent. Points pushed outside along the largest generator's direction are rejected."""
    data = np.load(Path(__file__).parent / "data" / "trolley_zonotope_point.npz")
    z = Zonotope(data["center"], data["generators"])
    point = data["point"]
    assert z.halfspaces() is None  # too many generators for facets: the LP decides
    assert bool(z.contains_points(point, 1e-7))
    radius = z.radius()
    outside = point.copy()
    k = int(np.argmax(radius))
    outside[k] = z.center[k] + 1.5 * radius[k]
    assert not bool(z.contains_points(outside, 1e-7))


# ----- guard clusters ----------------------------------------------------------------------------
@settings(max_examples=40, deadline=None)
@given(data=st.data(), k=st.integers(1, 6), n=st.integers(2, 3))
def test_a_cluster_hull_contains_every_piece_within_the_guard(data, k, n):
    """The cluster's joined set (principal or state axes) contains every sampled point of
    every piece that satisfies the guard rows."""
    from hybridlab.reachability.clusters import hull, oriented_hull

    drift = np.array(data.draw(st.lists(st.floats(-5, 5), min_size=n, max_size=n)))
    base = data.draw(zonotopes(n=n, max_m=4))
    rot = np.array(data.draw(st.lists(st.floats(-1, 1), min_size=n * n, max_size=n * n)))
    sets = [base.linear_map(np.eye(n) + 0.1 * j * rot.reshape(n, n), j * drift)
            for j in range(k)]
    rows = data.draw(st.integers(0, 2))
    A = np.array(data.draw(st.lists(st.floats(-2, 2), min_size=rows * n,
                                    max_size=rows * n))).reshape(rows, n)
    b = A @ sets[0].center + np.array(data.draw(st.lists(st.floats(0, 5), min_size=rows,
                                                         max_size=rows)))
    inside = [pts[np.all(pts @ A.T <= b, axis=1)] for pts in (_samples(Z) for Z in sets)]
    cuts = [Z.bounds_within(A, b) if rows else Z.bounds() for Z in sets]
    cuts = [c for c in cuts if c is not None]
    if not cuts:
        return
    axis = hull(cuts)
    joined = oriented_hull(sets, A, b, axis)
    assert joined is not None
    for pts in inside:
        assert np.all(joined.contains_points(pts, tol=1e-7))
