"""Interval arithmetic over sympy expressions (hybridlab.symbolic.intervals): sound by sampling.

Shared by reachability (strict: unsupported constructs are errors) and the static
mode-graph checks (lenient: :func:`compile_interval` gives the whole line instead).
"""

from __future__ import annotations

import math
import random

import mpmath
import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from hybridlab.symbolic import interval_arithmetic as ia
from hybridlab.symbolic.interval_arithmetic import WIDEN
from hybridlab.symbolic.intervals import (
    EmptyInterval,
    Interval,
    IntervalError,
    IntervalFunction,
    compile_interval,
    interval_eval,
)

x, y = X, Y = sp.symbols("x y", real=True)


@st.composite
def intervals(draw, lo=-5.0, hi=5.0):
    a = draw(st.floats(lo, hi))
    b = draw(st.floats(lo, hi))
    return Interval(min(a, b), max(a, b))


# ----- interval arithmetic ----------------------------------------------------------------------
EXPRESSIONS = [
    X + Y, X - Y, X * Y, X / (Y + 10), X**2, X**3, (X**2 + 1)**-2, sp.sqrt(X + 6), sp.exp(X),
    sp.log(X + 6), sp.sin(X), sp.cos(X * Y), sp.tan(X / 4), sp.atan(X), sp.asin(X / 6),
    sp.acos(Y / 6), sp.sinh(X), sp.cosh(X), sp.tanh(X), sp.Abs(X), sp.sign(X), sp.Min(X, Y),
    sp.Max(X, 2 * Y), sp.atan2(Y, X), sp.Rational(1, 3) * X**2 - sp.pi * Y,
    (X**2 + Y**2 + 1)**sp.Rational(3, 2), X**Y / (1 + sp.exp(Y)) + 0 * X,
    sp.Heaviside(X),
]


@pytest.mark.parametrize("expr", EXPRESSIONS, ids=[str(e) for e in EXPRESSIONS])
@settings(max_examples=15, deadline=None)
@given(bx=intervals(), by=intervals())
def test_interval_enclosure_contains_every_sampled_value(expr, bx, by):
    if expr.has(X**Y):  # a real power needs a positive base
        base = abs(bx.lo) + 0.1
        bx = Interval(base, base + (bx.hi - bx.lo))
    f = IntervalFunction([expr], [X, Y])
    r = f.intervals([bx, by])[0]
    g = sp.lambdify([X, Y], expr, modules=[{"Heaviside": lambda v, h0=0.5: np.heaviside(v, h0)},
                                              "numpy"])
    xs = np.r_[bx.lo, bx.hi, np.linspace(bx.lo, bx.hi, 41)]
    ys = np.r_[by.lo, by.hi, np.linspace(by.lo, by.hi, 41)]
    xx, yy = np.meshgrid(xs, ys)
    with np.errstate(all="ignore"):
        values = np.asarray(g(xx, yy), dtype=float) * np.ones_like(xx)
    values = values[np.isfinite(values)]
    assert np.all(values >= r.lo) and np.all(values <= r.hi), (r, values.min(), values.max())


def test_interval_rounding_is_outward():
    r = Interval(0.1, 0.1) + Interval(0.2, 0.2)
    assert r.lo < 0.1 + 0.2 < r.hi or r.lo <= 0.3 <= r.hi
    third = interval_eval(sp.Rational(1, 3) * X, {X: (1.0, 1.0)})
    assert third.lo < 1 / 3 < third.hi or third.lo <= 1 / 3 <= third.hi
    assert third.hi - third.lo <= 4 * WIDEN * (1 / 3) + 1e-299  # two roundings, both ends


def test_interval_trigonometry_hits_its_extremes():
    assert Interval(0.0, math.pi).__class__ is Interval
    r = interval_eval(sp.sin(X), {X: (0.0, math.pi)})
    assert r.hi == 1.0 and -1e-15 < r.lo <= 0.0
    r = interval_eval(sp.cos(X), {X: (3.0, 3.3)})
    assert r.lo == -1.0
    assert interval_eval(sp.tan(X), {X: (1.0, 2.0)}).hi == math.inf


def test_interval_errors_are_named():
    with pytest.raises(IntervalError, match="log of a non-positive"):
        interval_eval(sp.log(X), {X: (-2.0, -1.0)})
    with pytest.raises(IntervalError, match="no interval given for symbol y"):
        interval_eval(X + Y, {X: (0.0, 1.0)})
    with pytest.raises(IntervalError, match="lo <= hi"):
        Interval(1.0, 0.0)


def test_division_by_an_interval_containing_zero_is_the_whole_line():
    r = Interval(1.0, 2.0) / Interval(-1.0, 1.0)
    assert r.lo == -math.inf and r.hi == math.inf


# ----- the graph check's use: Interval boxes, lenient compilation ---------------------------
@pytest.mark.parametrize("expr", [x**2 - x * y, sp.sin(3 * x) * y + sp.cos(y), sp.exp(x / 2) -
                                  sp.sqrt(y**2 + 1), sp.Abs(x - y) - sp.Max(x, y) + sp.Min(x, 1),
                                  sp.atan(x) * sp.tanh(y) / (x**2 + 1), x**3 - y**3 + 1 / (y + 9)])
def test_interval_enclosure_contains_sampled_values(expr: sp.Expr) -> None:
    f = sp.lambdify((x, y), expr, "math")
    rng = random.Random(7)
    for _ in range(60):
        xs, ys = sorted(rng.uniform(-4, 4) for _ in range(2)), sorted(rng.uniform(-4, 4)
                                                                        for _ in range(2))
        enclosure = interval_eval(expr, {x: Interval(*xs), y: Interval(*ys)})
        for _ in range(20):
            value = f(rng.uniform(*xs), rng.uniform(*ys))
            assert enclosure.lo <= value <= enclosure.hi


def test_interval_sin_hits_its_extrema_exactly() -> None:
    enclosure = interval_eval(sp.sin(x), {x: Interval(1.0, 2.0)})
    assert enclosure.hi == 1.0 and enclosure.lo == pytest.approx(math.sin(1.0), abs=2 * WIDEN)


def test_lenient_compilation_bounds_what_it_does_not_model_by_the_whole_line() -> None:
    g = sp.Function("g")
    whole = Interval.entire()
    assert compile_interval(g(x) + 1)({x: Interval(0.0, 1.0)}) == whole
    assert compile_interval(x + y)({x: Interval(0.0, 1.0)}) == whole  # y unbounded
    assert compile_interval(x * sp.oo)({x: Interval(1.0, 2.0)}) == whole
    # x**y with x <= 0 is defined for integer y: not empty, just unknown
    assert compile_interval(x**y)({x: Interval(-2.0, -1.0), y: Interval(1.0, 3.0)}) == whole
    with pytest.raises(IntervalError, match="does not support"):
        IntervalFunction([g(x)], [x])


def test_lenient_compilation_still_reports_an_empty_domain() -> None:
    for expr in (sp.sqrt(x), sp.log(x), sp.asin(x + 5), x**sp.Float(1.5)):
        with pytest.raises(EmptyInterval):
            compile_interval(expr)({x: Interval(-3.0, -2.0)})
    r = compile_interval(sp.sqrt(x) + sp.Abs(y))({x: Interval(-1.0, 4.0), y: Interval(-1.0, 0.5)})
    assert r.lo <= 0.0 and 3.0 <= r.hi < 3.0 + 1e-12


def test_text_is_never_evaluated():
    """Strings are refused, not handed to sympify (which would eval them)."""
    with pytest.raises(TypeError, match="parse text"):
        compile_interval("__import__('os').system('echo no')")
    with pytest.raises(TypeError, match="parse text"):
        interval_eval("x + 1", {sp.Symbol("x"): (0.0, 1.0)})


# ----- the arithmetic against exact values (50 digits) ------------------------------------------
_EXACT_UNARY = [
    ("i_exp", mpmath.exp, (-30.0, 30.0)), ("i_log", mpmath.log, (1e-3, 50.0)),
    ("i_sqrt", mpmath.sqrt, (0.0, 50.0)), ("i_sin", mpmath.sin, (-20.0, 20.0)),
    ("i_cos", mpmath.cos, (-20.0, 20.0)), ("i_tan", mpmath.tan, (-1.5, 1.5)),
    ("i_atan", mpmath.atan, (-50.0, 50.0)), ("i_tanh", mpmath.tanh, (-20.0, 20.0)),
    ("i_sinh", mpmath.sinh, (-20.0, 20.0)), ("i_cosh", mpmath.cosh, (-20.0, 20.0)),
    ("i_asin", mpmath.asin, (-1.0, 1.0)), ("i_acos", mpmath.acos, (-1.0, 1.0)),
]


@pytest.mark.parametrize("name, exact, domain", _EXACT_UNARY, ids=[u[0] for u in _EXACT_UNARY])
@settings(max_examples=40, deadline=None)
@given(a=st.floats(0.0, 1.0), b=st.floats(0.0, 1.0))
def test_every_function_encloses_the_exact_value_at_every_point(name, exact, domain, a, b):
    lo, hi = sorted(domain[0] + v * (domain[1] - domain[0]) for v in (a, b))
    out_lo, out_hi = getattr(ia, name)(lo, hi)
    with mpmath.workdps(50):
        for v in np.linspace(lo, hi, 17):
            value = exact(mpmath.mpf(float(v)))
            assert out_lo <= value <= out_hi, (name, lo, hi, v)


@settings(max_examples=200, deadline=None)
@given(a=st.tuples(st.floats(-1e3, 1e3), st.floats(-1e3, 1e3)).map(sorted),
       b=st.tuples(st.floats(-1e3, 1e3), st.floats(-1e3, 1e3)).map(sorted),
       k=st.integers(-5, 7), e=st.floats(0.1, 3.5))
def test_arithmetic_encloses_the_exact_results(a, b, k, e):
    with mpmath.workdps(60):
        ends = [(mpmath.mpf(u), mpmath.mpf(v)) for u in a for v in b]
        checks = [(ia.i_add(*a, *b), [u + v for u, v in ends]),
                  (ia.i_mul(*a, *b), [u * v for u, v in ends])]
        if not b[0] <= 0.0 <= b[1]:
            checks.append((ia.i_div(*a, *b), [u / v for u, v in ends]))
        if not (k < 0 and a[0] <= 0.0 <= a[1]):
            points = [mpmath.mpf(float(v)) for v in np.linspace(a[0], a[1], 9)]
            checks.append((ia.i_powi(*a, k), [p ** k for p in points]))
        if a[1] > 0.0:
            points = [mpmath.mpf(float(v)) for v in np.linspace(max(a[0], 0.0), a[1], 9)]
            checks.append((ia.i_pow(*a, e), [p ** mpmath.mpf(e) for p in points]))
        for (lo, hi), values in checks:
            assert all(lo <= v <= hi for v in values)
