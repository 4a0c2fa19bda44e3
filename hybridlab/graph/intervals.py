"""Interval arithmetic over sympy expression trees, rounded outwards.

A tiny evaluator for the static checks of the mode graph: given a box (one
closed interval per symbol), :func:`interval_eval` returns an interval that
contains every real value the expression takes on the box. Every result is
widened by a few units in the last place, so floating-point rounding (and the
last-place error of ``math.sin`` and friends) cannot make it too narrow.
Anything it does not know is the whole real line, which is always sound.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import sympy as sp

__all__ = ["Interval", "interval_eval", "compile_interval"]

_INF = math.inf


def _down(x: float) -> float:
    # a relative widening of about 4.5 ulps (plus the smallest normal number near 0)
    y = x - (abs(x) * 1e-15 + 1e-300)
    return x if y != y else y  # inf - inf: keep the infinite bound


def _up(x: float) -> float:
    y = x + (abs(x) * 1e-15 + 1e-300)
    return x if y != y else y


class EmptyInterval(ArithmeticError):
    """The expression is undefined everywhere on the box (``sqrt`` of a negative interval)."""


@dataclass(frozen=True)
class Interval:
    """A closed interval ``[lo, hi]`` of reals; the bounds may be infinite.

    Examples
    --------
    >>> product = Interval(-1.0, 2.0) * Interval(3.0, 4.0)
    >>> product.contains(-4.0) and product.contains(8.0) and product.width < 12 + 1e-12
    True
    """

    lo: float
    hi: float

    @staticmethod
    def point(value: float) -> Interval:
        """The interval ``[value, value]`` widened outwards by a few ulps."""
        return Interval(_down(value), _up(value))

    @staticmethod
    def everything() -> Interval:
        """The whole real line."""
        return Interval(-_INF, _INF)

    @property
    def width(self) -> float:
        """``hi - lo`` (infinite for an unbounded interval)."""
        return self.hi - self.lo

    def contains(self, value: float) -> bool:
        """Whether ``value`` lies in the interval."""
        return self.lo <= value <= self.hi

    def __add__(self, other: Interval) -> Interval:
        return Interval(_down(self.lo + other.lo), _up(self.hi + other.hi))

    def __neg__(self) -> Interval:
        return Interval(-self.hi, -self.lo)

    def __mul__(self, other: Interval) -> Interval:
        products = [_times(a, b) for a in (self.lo, self.hi) for b in (other.lo, other.hi)]
        return Interval(_down(min(products)), _up(max(products)))

    def reciprocal(self) -> Interval:
        """``1 / x`` over the interval (the whole line when it contains 0 inside)."""
        if self.lo > 0 or self.hi < 0:
            return Interval(_down(1.0 / self.hi), _up(1.0 / self.lo))
        if self.lo == 0 and self.hi > 0:
            return Interval(_down(1.0 / self.hi), _INF)
        if self.hi == 0 and self.lo < 0:
            return Interval(-_INF, _up(1.0 / self.lo))
        return Interval.everything()


def _times(a: float, b: float) -> float:
    # the bounds stand for finite values: 0 times an unbounded end is 0, not nan
    if a == 0.0 or b == 0.0:
        return 0.0
    return a * b


def _monotone(f: Callable[[float], float], x: Interval, lo_domain: float = -_INF,
              hi_domain: float = _INF, decreasing: bool = False) -> Interval:
    """``f`` over ``x`` for ``f`` monotone on ``[lo_domain, hi_domain]``."""
    lo, hi = max(x.lo, lo_domain), min(x.hi, hi_domain)
    if lo > hi:
        raise EmptyInterval(f.__name__)
    a, b = _call(f, lo), _call(f, hi)
    if decreasing:
        a, b = b, a
    return Interval(_down(a), _up(b))


def _call(f: Callable[[float], float], x: float) -> float:
    try:
        return f(x)
    except OverflowError:
        return math.copysign(_INF, x) if f in _ODD else _INF


def _exp(x: float) -> float:
    return 0.0 if x == -_INF else math.exp(x)


def _log(x: float) -> float:
    return -_INF if x == 0.0 else math.log(x)


def _atan(x: float) -> float:
    return math.atan(x)


def _tanh(x: float) -> float:
    return math.tanh(x)


def _sinh(x: float) -> float:
    return x if math.isinf(x) else math.sinh(x)


_ODD = (_sinh,)


def _periodic_extremum(x: Interval, at: float) -> bool:
    """Whether ``x`` contains a point ``at + 2 k pi`` (with a margin for rounding)."""
    k = math.ceil((x.lo - at) / (2 * math.pi) - 1e-9)
    return at + 2 * math.pi * k <= x.hi + 1e-9 * max(1.0, abs(x.hi))


def _sin(x: Interval) -> Interval:
    if not math.isfinite(x.width) or x.width >= 2 * math.pi:
        return Interval(-1.0, 1.0)
    a, b = math.sin(x.lo), math.sin(x.hi)
    hi = 1.0 if _periodic_extremum(x, math.pi / 2) else _up(max(a, b))
    lo = -1.0 if _periodic_extremum(x, -math.pi / 2) else _down(min(a, b))
    return Interval(max(lo, -1.0), min(hi, 1.0))


def _cos(x: Interval) -> Interval:
    if not math.isfinite(x.width) or x.width >= 2 * math.pi:
        return Interval(-1.0, 1.0)
    a, b = math.cos(x.lo), math.cos(x.hi)
    hi = 1.0 if _periodic_extremum(x, 0.0) else _up(max(a, b))
    lo = -1.0 if _periodic_extremum(x, math.pi) else _down(min(a, b))
    return Interval(max(lo, -1.0), min(hi, 1.0))


def _tan(x: Interval) -> Interval:
    if not math.isfinite(x.width) or x.width >= math.pi:
        return Interval.everything()
    k = math.floor((x.lo + math.pi / 2) / math.pi)
    pole = math.pi / 2 + k * math.pi
    if x.lo - 1e-9 <= pole <= x.hi + 1e-9 or x.lo - 1e-9 <= pole + math.pi <= x.hi + 1e-9:
        return Interval.everything()
    return Interval(_down(math.tan(x.lo)), _up(math.tan(x.hi)))


def _cosh(x: Interval) -> Interval:
    ends = [_call(lambda v: math.cosh(v) if math.isfinite(v) else _INF, e) for e in (x.lo, x.hi)]
    lo = 1.0 if x.contains(0.0) else min(ends)
    return Interval(_down(lo), _up(max(ends)))


def _abs(x: Interval) -> Interval:
    if x.lo >= 0:
        return x
    if x.hi <= 0:
        return -x
    return Interval(0.0, max(-x.lo, x.hi))


def _sign(x: Interval) -> Interval:
    return Interval(float(math.copysign(1, x.lo)) if x.lo != 0 else 0.0,
                    float(math.copysign(1, x.hi)) if x.hi != 0 else 0.0)


def _ipow(v: float, n: int) -> float:
    try:
        return v**n
    except OverflowError:
        return -_INF if v < 0 and n % 2 else _INF


def _fpow(v: float, e: float) -> float:
    try:
        return v**e
    except OverflowError:
        return _INF


def _power(base: Interval, exponent: sp.Expr) -> Interval:
    if exponent.is_Integer:
        n = int(exponent)
        if n == 0:
            return Interval(1.0, 1.0)
        if n < 0:
            return _power(base, sp.Integer(-n)).reciprocal()
        if n % 2 == 0:
            base = _abs(base)
        lo, hi = _ipow(base.lo, n), _ipow(base.hi, n)
        return Interval(_down(lo), _up(hi))
    if exponent.is_Number:  # a fractional power: real only for a non-negative base
        e = float(exponent)
        if e < 0:
            return _power(base, sp.Float(-e)).reciprocal()
        lo, hi = max(base.lo, 0.0), base.hi
        if lo > hi:
            raise EmptyInterval("power")
        return Interval(_down(_fpow(lo, e)), _up(_fpow(hi, e)))
    return Interval.everything()


_UNARY: Mapping[type, Callable[[Interval], Interval]] = {
    sp.sin: _sin,
    sp.cos: _cos,
    sp.tan: _tan,
    sp.exp: lambda x: _monotone(_exp, x),
    sp.log: lambda x: _monotone(_log, x, 0.0),
    sp.atan: lambda x: _monotone(_atan, x),
    sp.tanh: lambda x: _monotone(_tanh, x),
    sp.sinh: lambda x: _monotone(_sinh, x),
    sp.cosh: _cosh,
    sp.asin: lambda x: _monotone(math.asin, x, -1.0, 1.0),
    sp.acos: lambda x: _monotone(math.acos, x, -1.0, 1.0, decreasing=True),
    sp.Abs: _abs,
    sp.sign: _sign,
}


def interval_eval(expr: sp.Expr, box: Mapping[sp.Symbol, Interval]) -> Interval:
    """An interval enclosing every value of ``expr`` for symbols ranging over ``box``.

    Parameters
    ----------
    expr : sympy.Expr
        A real expression over the symbols of ``box`` (parameters already
        substituted by numbers).
    box : mapping of sympy.Symbol to Interval
        The range of each symbol.

    Returns
    -------
    Interval
        Sound (outward-rounded) bounds; the whole real line for constructs it
        does not model.

    Raises
    ------
    EmptyInterval
        When the expression is undefined at every point of the box (such as
        ``sqrt(x)`` with ``x < 0`` throughout).

    Examples
    --------
    >>> x, y = sp.symbols("x y", real=True)
    >>> r = interval_eval(x**2 + sp.sin(y), {x: Interval(-1, 2), y: Interval(0, 0.5)})
    >>> r.lo <= 0.0 and 4.479 < r.hi < 4.4795
    True
    """
    return compile_interval(expr)(box)


#: An expression compiled for repeated interval evaluation over boxes.
IntervalFunction = Callable[[Mapping[sp.Symbol, Interval]], Interval]


def compile_interval(expr: sp.Expr) -> IntervalFunction:
    """Compile ``expr`` once into a function of a box (see :func:`interval_eval`).

    Examples
    --------
    >>> x = sp.Symbol("x", real=True)
    >>> f = compile_interval(sp.Abs(x) - 1)
    >>> f({x: Interval(-3.0, 2.0)}).hi >= 2.0
    True
    """
    if expr.is_Symbol:
        everything = Interval.everything()
        return lambda box: box.get(expr, everything)
    if expr.is_Number or expr.is_NumberSymbol:
        value = float(expr)
        constant = Interval.point(value) if math.isfinite(value) else Interval.everything()
        return lambda box: constant
    if expr.is_Add or expr.is_Mul:
        parts = [compile_interval(arg) for arg in expr.args]
        combine = Interval.__add__ if expr.is_Add else Interval.__mul__

        def fold(box: Mapping[sp.Symbol, Interval]) -> Interval:
            total = parts[0](box)
            for part in parts[1:]:
                total = combine(total, part(box))
            return total
        return fold
    if expr.is_Pow:
        base, exponent = compile_interval(expr.base), expr.exp
        return lambda box: _power(base(box), exponent)
    if isinstance(expr, sp.Min | sp.Max):
        parts = [compile_interval(arg) for arg in expr.args]
        pick = min if isinstance(expr, sp.Min) else max

        def extreme(box: Mapping[sp.Symbol, Interval]) -> Interval:
            values = [part(box) for part in parts]
            return Interval(pick(v.lo for v in values), pick(v.hi for v in values))
        return extreme
    if isinstance(expr, sp.atan2):
        half_turn = Interval(-_up(math.pi), _up(math.pi))
        return lambda box: half_turn
    unary = _UNARY.get(type(expr))
    if unary is not None and len(expr.args) == 1:
        inner = compile_interval(expr.args[0])
        return lambda box: unary(inner(box))
    everything = Interval.everything()
    return lambda box: everything
