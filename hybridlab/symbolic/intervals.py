"""Interval arithmetic with outward rounding, and sympy expressions evaluated over boxes.

Every operation rounds its result outward by one unit in the last place
(``numpy.nextafter``), so the exact real result of the operation on the exact
operands always lies inside the computed interval. The elementary functions
(``exp``, ``sin``, ...) come from numpy, which is accurate to about one ulp
but not guaranteed correctly rounded; their results are widened by four ulps
plus ``1e-300`` to cover that.

:class:`IntervalFunction` compiles sympy expressions (everything the model
grammar allows: ``+ - * / **``, ``sin cos tan asin acos atan atan2 sinh cosh
tanh exp log sqrt abs sign min max``, ``clip`` through min/max) once into a
list of operations, each distinct subexpression once, and evaluates them over a box.

Two users with two needs: reachability (:class:`IntervalFunction`,
:func:`interval_eval`) wants every construct enclosed or a clear
:class:`IntervalError`; the static checks of the mode graph
(:func:`compile_interval`) want a bound whatever happens, so there an unknown
symbol, function or non-finite constant is the whole real line. Both raise
:class:`EmptyInterval` (an :class:`IntervalError`) when an expression is
undefined at every point of the box (``sqrt`` or ``log`` of a negative interval,
``asin`` outside ``[-1, 1]``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import sympy as sp

from hybridlab.errors import HybridlabError
from hybridlab.model.expressions import as_expression

__all__ = ["EmptyInterval", "Interval", "IntervalError", "IntervalFunction", "compile_interval",
           "interval_eval"]

_INF = math.inf


class IntervalError(HybridlabError, ValueError):
    """An expression cannot be enclosed by interval arithmetic (unsupported function).

    Examples
    --------
    >>> x = sp.Symbol("x", real=True)
    >>> interval_eval(sp.gamma(x), {x: (1.0, 2.0)})
    Traceback (most recent call last):
    ...
    hybridlab.symbolic.intervals.IntervalError: interval arithmetic does not support gamma in
    gamma(x)
    """


class EmptyInterval(IntervalError):
    """The expression is undefined at every point of the box (``sqrt`` of a negative interval).

    Examples
    --------
    >>> x = sp.Symbol("x", real=True)
    >>> try:
    ...     interval_eval(sp.sqrt(x), {x: (-2.0, -1.0)})
    ... except EmptyInterval as exc:  # also an IntervalError
    ...     print(exc)
    sqrt of a negative interval [-2.0, -1.0]
    >>> interval_eval(sp.sqrt(x), {x: (-1.0, 4.0)}).lo  # defined on part of the box
    0.0
    """


_MAX = float(np.finfo(float).max)


def _down(x: float) -> float:
    """A lower bound of the exact value whose rounded result is ``x``; an overflow to
    ``+inf`` is a finite number too large to represent, so its lower bound is the
    largest float."""
    if math.isfinite(x):
        return float(np.nextafter(x, -_INF))
    return _MAX if x > 0 else x


def _up(x: float) -> float:
    """An upper bound of the exact value whose rounded result is ``x`` (see :func:`_down`)."""
    if math.isfinite(x):
        return float(np.nextafter(x, _INF))
    return -_MAX if x < 0 else x


def _widen(lo: float, hi: float, ulps: int = 4) -> tuple[float, float]:
    """Widen a numpy elementary-function result to cover its (unguaranteed) rounding."""
    for _ in range(ulps):
        lo, hi = _down(lo), _up(hi)
    return lo - 1e-300, hi + 1e-300


@dataclass(frozen=True, slots=True)
class Interval:
    """A closed interval ``[lo, hi]`` of reals; ``lo`` may be ``-inf``, ``hi`` ``inf``.

    Examples
    --------
    >>> a = Interval(1.0, 2.0)
    >>> b = a * Interval(-1.0, 3.0) + 1
    >>> b.lo <= -1.0 and b.hi >= 7.0
    True
    >>> (Interval(-1.0, 2.0) ** 2).lo
    0.0
    """

    lo: float
    hi: float

    def __post_init__(self) -> None:
        if not self.lo <= self.hi:  # also catches NaN
            raise IntervalError(f"interval bounds must satisfy lo <= hi (got [{self.lo}, "
                                f"{self.hi}])")

    # ----- construction -------------------------------------------------------------------
    @staticmethod
    def point(x: float) -> Interval:
        """The degenerate interval ``[x, x]``."""
        return Interval(float(x), float(x))

    @staticmethod
    def of(x: Interval | float) -> Interval:
        """``x`` as an interval."""
        return x if isinstance(x, Interval) else Interval.point(float(x))

    @staticmethod
    def entire() -> Interval:
        """The whole real line."""
        return Interval(-_INF, _INF)

    # ----- properties -----------------------------------------------------------------------
    @property
    def mid(self) -> float:
        """The midpoint (finite intervals only)."""
        return 0.5 * (self.lo + self.hi)

    @property
    def rad(self) -> float:
        """Half the width, rounded up."""
        return _up(0.5 * (self.hi - self.lo))

    @property
    def mag(self) -> float:
        """``max |x|`` over the interval."""
        return max(abs(self.lo), abs(self.hi))

    @property
    def width(self) -> float:
        """``hi - lo`` (infinite for an unbounded interval)."""
        return self.hi - self.lo

    def contains(self, x: float) -> bool:
        """Whether ``x`` lies in the interval."""
        return self.lo <= x <= self.hi

    def hull(self, other: Interval) -> Interval:
        """The smallest interval containing both."""
        return Interval(min(self.lo, other.lo), max(self.hi, other.hi))

    # ----- arithmetic -------------------------------------------------------------------------
    def __add__(self, other: Interval | float) -> Interval:
        o = Interval.of(other)
        return Interval(_down(self.lo + o.lo), _up(self.hi + o.hi))

    __radd__ = __add__

    def __neg__(self) -> Interval:
        return Interval(-self.hi, -self.lo)

    def __sub__(self, other: Interval | float) -> Interval:
        return self + (-Interval.of(other))

    def __rsub__(self, other: Interval | float) -> Interval:
        return Interval.of(other) + (-self)

    def __mul__(self, other: Interval | float) -> Interval:
        o = Interval.of(other)
        products = []
        for a in (self.lo, self.hi):
            for b in (o.lo, o.hi):
                # 0 * inf is 0 here: the interval end is only a bound, never attained
                products.append(0.0 if a == 0.0 or b == 0.0 else a * b)
        return Interval(_down(min(products)), _up(max(products)))

    __rmul__ = __mul__

    def reciprocal(self) -> Interval:
        """``1 / x``; the whole line when the interval contains zero."""
        if self.lo <= 0.0 <= self.hi:
            return Interval.entire()
        return Interval(_down(1.0 / self.hi), _up(1.0 / self.lo))

    def __truediv__(self, other: Interval | float) -> Interval:
        return self * Interval.of(other).reciprocal()

    def __rtruediv__(self, other: Interval | float) -> Interval:
        return Interval.of(other) * self.reciprocal()

    def __pow__(self, exponent: Interval | float) -> Interval:
        if isinstance(exponent, Interval):
            if exponent.lo == exponent.hi:
                return self ** exponent.lo
            return _exp(exponent * _log(self))
        e = float(exponent)
        if e == int(e) and abs(e) <= 1e6:
            return self._ipow(int(e))
        if e == 0.5:
            return _sqrt(self)
        return _exp(Interval.point(e) * _log(self))

    def _ipow(self, k: int) -> Interval:
        if k == 0:
            return Interval(1.0, 1.0)
        if k < 0:
            return self._ipow(-k).reciprocal()
        if k == 1:
            return self
        if k % 2 == 0:  # even: a function of |x|, smallest at the point nearest zero
            a = 0.0 if self.lo <= 0.0 <= self.hi else min(abs(self.lo), abs(self.hi))
            lo, hi = a, self.mag
        else:  # odd: increasing
            lo, hi = self.lo, self.hi
        with np.errstate(over="ignore"):
            plo, phi = float(np.power(lo, k)), float(np.power(hi, k))
        rel = (k + 2) * 2.3e-16  # a float power is within about k ulps of the exact one
        plo, phi = plo - abs(plo) * rel - 1e-300, phi + abs(phi) * rel + 1e-300
        if k % 2 == 0:
            plo = max(plo, 0.0)
        return Interval(plo, phi)


def _monotone(f: Callable[[float], float], x: Interval, increasing: bool = True) -> Interval:
    with np.errstate(all="ignore"):
        a, b = float(f(x.lo)), float(f(x.hi))
    lo, hi = (a, b) if increasing else (b, a)
    return Interval(*_widen(lo, hi))


def _exp(x: Interval) -> Interval:
    r = _monotone(np.exp, x)
    return Interval(max(r.lo, 0.0), r.hi)


def _log(x: Interval) -> Interval:
    if x.hi <= 0.0:  # empty below zero; at hi == 0 only the point 0 (log = -inf) is left
        kind = EmptyInterval if x.hi < 0.0 else IntervalError
        raise kind(f"log of a non-positive interval [{x.lo}, {x.hi}]")
    lo = -_INF if x.lo <= 0.0 else x.lo
    return _monotone(lambda v: np.log(v) if v > 0 else -_INF, Interval(lo, x.hi))


def _sqrt(x: Interval) -> Interval:
    if x.hi < 0.0:
        raise EmptyInterval(f"sqrt of a negative interval [{x.lo}, {x.hi}]")
    r = _monotone(np.sqrt, Interval(max(x.lo, 0.0), x.hi))
    return Interval(max(r.lo, 0.0), r.hi)


def _contains_point_of_lattice(x: Interval, offset: float, period: float) -> bool:
    """Whether ``[lo, hi]`` (slightly widened) contains some ``offset + k * period``."""
    slack = 1e-12 * max(1.0, x.mag)
    k = math.ceil((x.lo - slack - offset) / period)
    return offset + k * period <= x.hi + slack


def _sin(x: Interval) -> Interval:
    if not (math.isfinite(x.lo) and math.isfinite(x.hi)) or x.hi - x.lo >= 2 * math.pi:
        return Interval(-1.0, 1.0)
    a, b = math.sin(x.lo), math.sin(x.hi)
    lo, hi = _widen(min(a, b), max(a, b))
    if _contains_point_of_lattice(x, math.pi / 2, 2 * math.pi):
        hi = 1.0
    if _contains_point_of_lattice(x, -math.pi / 2, 2 * math.pi):
        lo = -1.0
    return Interval(max(lo, -1.0), min(hi, 1.0))


def _cos(x: Interval) -> Interval:
    return _sin(x + Interval(_down(math.pi / 2), _up(math.pi / 2)))


def _tan(x: Interval) -> Interval:
    if (not (math.isfinite(x.lo) and math.isfinite(x.hi)) or x.hi - x.lo >= math.pi
            or _contains_point_of_lattice(x, math.pi / 2, math.pi)):
        return Interval.entire()
    return _monotone(np.tan, x)


def _clamped(f: Callable[[float], float], lo: float, hi: float, increasing: bool = True):
    def apply(x: Interval) -> Interval:
        if x.hi < lo or x.lo > hi:
            raise EmptyInterval(f"argument [{x.lo}, {x.hi}] outside the domain [{lo}, {hi}]")
        return _monotone(f, Interval(max(x.lo, lo), min(x.hi, hi)), increasing)
    return apply


def _cosh(x: Interval) -> Interval:
    hi = _monotone(np.cosh, Interval(x.mag, x.mag)).hi
    lo = 1.0 if x.lo <= 0.0 <= x.hi else _monotone(np.cosh, Interval(*(2 * [min(
        abs(x.lo), abs(x.hi))]))).lo
    return Interval(max(lo, 1.0), hi)


def _abs(x: Interval) -> Interval:
    if x.lo >= 0:
        return x
    if x.hi <= 0:
        return -x
    return Interval(0.0, x.mag)


def _sign(x: Interval) -> Interval:
    lo = -1.0 if x.lo < 0 else (0.0 if x.lo == 0 else 1.0)
    hi = 1.0 if x.hi > 0 else (0.0 if x.hi == 0 else -1.0)
    return Interval(lo, hi)


def _heaviside(x: Interval) -> Interval:
    return Interval(0.0 if x.lo <= 0 else 1.0, 1.0 if x.hi >= 0 else 0.0)


def _min(*xs: Interval) -> Interval:
    return Interval(min(x.lo for x in xs), min(x.hi for x in xs))


def _max(*xs: Interval) -> Interval:
    return Interval(max(x.lo for x in xs), max(x.hi for x in xs))


def _atan2(y: Interval, x: Interval) -> Interval:
    if x.lo > 0:  # right half-plane: atan(y / x) is exact and continuous there
        return _monotone(np.arctan, y / x)
    if y.lo > 0 or y.hi < 0:  # upper or lower half-plane: pi/2 - atan(x / y)
        r = Interval(_down(math.pi / 2), _up(math.pi / 2)) - _monotone(np.arctan, x / y)
        return r if y.lo > 0 else r - Interval(_down(math.pi), _up(math.pi))
    return Interval(_down(-math.pi), _up(math.pi))


_UNARY: Mapping[type, Callable[[Interval], Interval]] = {
    sp.exp: _exp,
    sp.log: _log,
    sp.sin: _sin,
    sp.cos: _cos,
    sp.tan: _tan,
    sp.asin: _clamped(np.arcsin, -1.0, 1.0),
    sp.acos: _clamped(np.arccos, -1.0, 1.0, increasing=False),
    sp.atan: lambda x: _monotone(np.arctan, x),
    sp.sinh: lambda x: _monotone(np.sinh, x),
    sp.cosh: _cosh,
    sp.tanh: lambda x: _monotone(np.tanh, x),
    sp.Abs: _abs,
    sp.sign: _sign,
    sp.Heaviside: _heaviside,
}

Step = Callable[[list[Interval]], Interval]
"""One operation of a :class:`_Program`: the value of a slot from the slots before it."""


def _constant(value: sp.Expr) -> Interval:
    if value.is_Integer or (value.is_Float and float(value) == value):
        v = float(value)
        if v == int(value):
            return Interval.point(v)
    v = float(sp.N(value, 30))
    return Interval(_down(v), _up(v))


def _general_power(base: Interval, exponent: Interval) -> Interval:
    """``base ** exponent`` for a variable exponent: a negative base is not empty there
    (an integer exponent is defined), so the log's :class:`EmptyInterval` is only an error."""
    try:
        return base ** exponent
    except EmptyInterval as exc:
        raise IntervalError(str(exc)) from None


class _Program:
    """Expressions as one list of operations over slots, each distinct subexpression once.

    Slots ``0 .. n-1`` hold the arguments' intervals; every other slot is one operation
    on earlier slots. A subexpression shared by several expressions (a Lagrangian flow's
    ``1/det M(phi)`` in every entry of its Hessian) is evaluated once per call; the
    operations are those of evaluating each expression's tree, so the enclosures are the
    same. ``lenient``: what cannot be enclosed is the whole line instead of an error.
    """

    def __init__(self, index: Mapping[sp.Symbol, int], lenient: bool = False) -> None:
        self.index = index
        self.lenient = lenient
        self.n_args = len(index)
        self.steps: list[Step] = []
        self.slots: dict[sp.Expr, int] = {}

    def add(self, expr: sp.Expr) -> int:
        """The slot holding ``expr``'s enclosure (its operations appended once)."""
        if expr.is_Symbol and not self.lenient or expr.is_Symbol and expr in self.index:
            if expr not in self.index:
                raise IntervalError(f"no interval given for symbol {expr}")
            return self.index[expr]
        known = self.slots.get(expr)
        if known is not None:
            return known
        step = self._step(expr)
        self.steps.append(step)
        slot = self.n_args + len(self.steps) - 1
        self.slots[expr] = slot
        return slot

    def run(self, env: Sequence[Interval]) -> list[Interval]:
        """Every slot's interval, the arguments ``env`` first."""
        vals = list(env)
        for step in self.steps:
            vals.append(step(vals))
        return vals

    def _step(self, expr: sp.Expr) -> Step:
        if self.lenient and not (expr.is_Symbol or expr.is_Number or expr.is_NumberSymbol
                                 or _supported(expr)):
            return lambda vals: _ENTIRE
        if expr.is_Symbol:  # lenient, and not given: the whole line
            return lambda vals: _ENTIRE
        if expr.is_Number or expr.is_NumberSymbol:
            if not expr.is_finite:
                if self.lenient:
                    return lambda vals: _ENTIRE
                raise IntervalError(f"non-finite constant {expr}")
            c = _constant(expr)
            return lambda vals: c
        args = [self.add(a) for a in expr.args]
        if isinstance(expr, sp.Add):
            first, rest = args[0], args[1:]

            def add(vals: list[Interval]) -> Interval:
                total = vals[first]
                for a in rest:
                    total = total + vals[a]
                return total
            return add
        if isinstance(expr, sp.Mul):
            first, rest = args[0], args[1:]

            def mul(vals: list[Interval]) -> Interval:
                total = vals[first]
                for a in rest:
                    total = total * vals[a]
                return total
            return mul
        if isinstance(expr, sp.Pow):
            base, exponent = args
            e = expr.args[1]
            if e.is_Integer:
                k = int(e)
                return lambda vals: vals[base]._ipow(k)
            if e == sp.Rational(1, 2):
                return lambda vals: _sqrt(vals[base])
            if e == sp.Rational(-1, 2):
                return lambda vals: _sqrt(vals[base]).reciprocal()
            if e.is_Number:  # a non-integer constant power: real only for a base >= 0
                return lambda vals: vals[base] ** vals[exponent]
            return lambda vals: _general_power(vals[base], vals[exponent])
        if isinstance(expr, sp.Min):
            return lambda vals: _min(*(vals[a] for a in args))
        if isinstance(expr, sp.Max):
            return lambda vals: _max(*(vals[a] for a in args))
        if isinstance(expr, sp.atan2):
            return lambda vals: _atan2(vals[args[0]], vals[args[1]])
        for kind, f in _UNARY.items():
            if isinstance(expr, kind):
                arg = args[0]
                return lambda vals: f(vals[arg])
        raise IntervalError(f"interval arithmetic does not support {type(expr).__name__} "
                            f"in {expr}")


_ENTIRE = Interval.entire()
_SUPPORTED = (sp.Add, sp.Mul, sp.Pow, sp.Min, sp.Max, sp.atan2, *_UNARY)


def _supported(expr: sp.Expr) -> bool:
    return isinstance(expr, _SUPPORTED)


class IntervalFunction:
    """Sympy expressions compiled for evaluation over boxes.

    Parameters
    ----------
    exprs : sequence of sympy.Expr
        The expressions.
    symbols : sequence of sympy.Symbol
        Their arguments, in the order of the box's rows.

    Examples
    --------
    >>> x, y = sp.symbols("x y", real=True)
    >>> f = IntervalFunction([x * y + sp.sin(x), sp.Abs(y)], [x, y])
    >>> lo, hi = f(np.array([0.0, -1.0]), np.array([1.0, 2.0]))
    >>> bool(lo[0] <= -1.0 and hi[0] >= 2.0 + np.sin(1.0)), float(lo[1]), float(hi[1])
    (True, 0.0, 2.0)
    """

    def __init__(self, exprs: Sequence[sp.Expr], symbols: Sequence[sp.Symbol]) -> None:
        self.exprs = tuple(as_expression(e) for e in exprs)
        self._program = _Program({s: i for i, s in enumerate(symbols)})
        self._outputs = [self._program.add(e) for e in self.exprs]

    def intervals(self, env: Sequence[Interval]) -> list[Interval]:
        """Evaluate on a list of argument intervals."""
        vals = self._program.run(env)
        return [vals[k] for k in self._outputs]

    def __call__(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Enclosures ``(lo, hi)`` of every expression over the box ``[lo, hi]``."""
        env = [Interval(float(a), float(b)) for a, b in zip(lo, hi, strict=True)]
        out = self.intervals(env)
        return (np.array([r.lo for r in out], dtype=float),
                np.array([r.hi for r in out], dtype=float))


def interval_eval(expr: sp.Expr,
                  box: Mapping[sp.Symbol, Interval | tuple[float, float]]) -> Interval:
    """Enclose one sympy expression over a box given per symbol.

    Parameters
    ----------
    expr : sympy.Expr
        A real expression over the symbols of ``box``.
    box : mapping of sympy.Symbol to Interval or (lo, hi)
        The range of each symbol.

    Raises
    ------
    IntervalError
        For a symbol without an interval or a construct it cannot enclose;
        :class:`EmptyInterval` when ``expr`` is undefined everywhere on the box.

    Examples
    --------
    >>> x = sp.Symbol("x", real=True)
    >>> r = interval_eval(x**2 - 2*x, {x: (0.0, 3.0)})
    >>> r.lo <= -1.0 and r.hi >= 3.0
    True
    """
    symbols = sorted(as_expression(expr).free_symbols, key=str)
    missing = [s for s in symbols if s not in box]
    if missing:
        raise IntervalError(f"no interval given for symbol {missing[0]}")
    f = IntervalFunction([expr], symbols)
    return f.intervals([_as_interval(box[s]) for s in symbols])[0]


def _as_interval(bounds: Interval | tuple[float, float]) -> Interval:
    if isinstance(bounds, Interval):
        return bounds
    return Interval(float(bounds[0]), float(bounds[1]))


def compile_interval(expr: sp.Expr) -> Callable[[Mapping[sp.Symbol, Interval]], Interval]:
    """Compile ``expr`` once into a function of a box that always returns a bound.

    Unlike :class:`IntervalFunction` it never fails for want of knowledge: a
    symbol missing from the box, a function it does not model, a non-finite
    constant or a power it cannot settle (``x**y`` with ``x <= 0``) give the whole
    real line, which is always sound.

    Raises
    ------
    EmptyInterval
        (When called.) The expression is undefined at every point of the box.

    Examples
    --------
    >>> x, y = sp.symbols("x y", real=True)
    >>> f = compile_interval(sp.Abs(x) - 1 + sp.Function("g")(y))
    >>> f({x: Interval(-3.0, 2.0)}) == Interval.entire()
    True
    >>> compile_interval(sp.Abs(x) - 1)({x: Interval(-3.0, 2.0)}).hi >= 2.0
    True
    """
    expr = as_expression(expr)
    symbols = sorted(expr.free_symbols, key=str)
    program = _Program({s: i for i, s in enumerate(symbols)}, lenient=True)
    out = program.add(expr)

    def evaluate(box: Mapping[sp.Symbol, Interval]) -> Interval:
        try:
            return program.run([box.get(s, _ENTIRE) for s in symbols])[out]
        except EmptyInterval:
            raise
        except IntervalError:
            return _ENTIRE
    return evaluate
