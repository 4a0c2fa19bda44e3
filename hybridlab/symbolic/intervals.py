"""Sympy expressions enclosed over boxes, with the one interval arithmetic.

The arithmetic and its rounding policy are
:mod:`hybridlab.symbolic.interval_arithmetic`'s: every end is rounded
outward, so the exact real result on the exact operands lies inside.
:class:`IntervalProgram` lowers sympy expressions (everything the model
grammar allows: ``+ - * / **``, ``sin cos tan asin acos atan atan2 sinh cosh
tanh exp log sqrt abs sign min max``, ``clip`` through min/max) once into a
list of instructions of that arithmetic, each distinct subexpression once;
this module runs them in Python and the compiled simulator prints them as
numba code.

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
from typing import TYPE_CHECKING

import numpy as np
import sympy as sp

from hybridlab.errors import HybridlabError
from hybridlab.model.expressions import as_expression
from hybridlab.symbolic import interval_arithmetic as ia

if TYPE_CHECKING:
    from hybridlab.symbolic.interval_machine import CompiledProgram

__all__ = ["EmptyInterval", "Instruction", "Interval", "IntervalError", "IntervalFunction",
           "IntervalProgram", "compile_interval", "interval_eval"]

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


class Interval:
    """A closed interval ``[lo, hi]`` of reals; ``lo`` may be ``-inf``, ``hi`` ``inf``.

    The arithmetic is :mod:`hybridlab.symbolic.interval_arithmetic`'s.

    Examples
    --------
    >>> a = Interval(1.0, 2.0)
    >>> b = a * Interval(-1.0, 3.0) + 1
    >>> b.lo <= -1.0 and b.hi >= 7.0
    True
    >>> (Interval(-1.0, 2.0) ** 2).lo
    0.0
    """

    __slots__ = ("lo", "hi")

    lo: float
    hi: float

    def __init__(self, lo: float, hi: float) -> None:
        if not lo <= hi:  # also catches NaN
            raise IntervalError(f"interval bounds must satisfy lo <= hi (got [{lo}, {hi}])")
        object.__setattr__(self, "lo", lo)
        object.__setattr__(self, "hi", hi)

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError(f"Interval is immutable (cannot set {name!r})")

    def __repr__(self) -> str:
        return f"Interval(lo={self.lo!r}, hi={self.hi!r})"

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, Interval) and self.lo == other.lo
                and self.hi == other.hi)

    def __hash__(self) -> int:
        return hash((self.lo, self.hi))

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
        half = 0.5 * (self.hi - self.lo)
        return ia.upper(half, half)

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
        return _checked(ia.i_add(self.lo, self.hi, o.lo, o.hi), "i_add", self)

    __radd__ = __add__

    def __neg__(self) -> Interval:
        return Interval(-self.hi, -self.lo)

    def __sub__(self, other: Interval | float) -> Interval:
        o = Interval.of(other)
        return _checked(ia.i_sub(self.lo, self.hi, o.lo, o.hi), "i_sub", self)

    def __rsub__(self, other: Interval | float) -> Interval:
        return Interval.of(other) - self

    def __mul__(self, other: Interval | float) -> Interval:
        o = Interval.of(other)
        return _checked(ia.i_mul(self.lo, self.hi, o.lo, o.hi), "i_mul", self)

    __rmul__ = __mul__

    def reciprocal(self) -> Interval:
        """``1 / x``; the whole line when the interval contains zero."""
        return _checked(ia.i_recip(self.lo, self.hi), "i_recip", self)

    def __truediv__(self, other: Interval | float) -> Interval:
        o = Interval.of(other)
        return _checked(ia.i_div(self.lo, self.hi, o.lo, o.hi), "i_div", self)

    def __rtruediv__(self, other: Interval | float) -> Interval:
        return Interval.of(other) / self

    def __pow__(self, exponent: Interval | float) -> Interval:
        if isinstance(exponent, Interval) and exponent.lo != exponent.hi:
            return _checked(ia.i_rpow(self.lo, self.hi, exponent.lo, exponent.hi), "i_rpow",
                            self)
        e = float(exponent.lo if isinstance(exponent, Interval) else exponent)
        if math.isfinite(e) and e == int(e) and abs(e) <= 2.0 ** 62:
            return _checked(ia.i_powi(self.lo, self.hi, int(e)), "i_powi", self)
        if e == 0.5:
            return _checked(ia.i_sqrt(self.lo, self.hi), "i_sqrt", self)
        return _checked(ia.i_pow(self.lo, self.hi, e), "i_pow", self)


_UNDEFINED = {"i_sqrt": "sqrt of a negative interval", "i_log": "log of a non-positive interval",
              "i_pow": "non-integer power of a negative interval",
              "i_asin": "asin of an interval outside [-1, 1]",
              "i_acos": "acos of an interval outside [-1, 1]"}


def _undefined(op: str, operand: Interval) -> EmptyInterval:
    """The error for ``op`` undefined on every point of ``operand``."""
    what = _UNDEFINED.get(op, f"{op[2:]} of an interval outside its domain")
    return EmptyInterval(f"{what} [{operand.lo}, {operand.hi}]")


def _checked(pair: tuple[float, float], op: str, operand: Interval) -> Interval:
    lo, hi = pair
    if ia.is_empty(lo, hi):
        raise _undefined(op, operand)
    return Interval(lo, hi)


Pair = tuple[float, float]
Step = Callable[[list[Pair]], Pair]
"""One instruction of a :class:`IntervalProgram` run in Python: a slot from earlier slots."""

_UNARY: Mapping[type, str] = {
    sp.exp: "i_exp", sp.log: "i_log", sp.sin: "i_sin", sp.cos: "i_cos", sp.tan: "i_tan",
    sp.asin: "i_asin", sp.acos: "i_acos", sp.atan: "i_atan", sp.sinh: "i_sinh",
    sp.cosh: "i_cosh", sp.tanh: "i_tanh", sp.Abs: "i_abs", sp.sign: "i_sign",
    sp.Heaviside: "i_heaviside",
}
_FOLD: Mapping[type, str] = {sp.Add: "i_add", sp.Mul: "i_mul", sp.Min: "i_min", sp.Max: "i_max"}
_SUPPORTED = (*_FOLD, sp.Pow, sp.atan2, *_UNARY)


def _op_of(expr: sp.Expr, table: Mapping[type, str]) -> str | None:
    """The instruction of ``table`` for ``expr``'s class, or a class it derives from (the
    same test as :data:`_SUPPORTED`)."""
    for kind, op in table.items():
        if isinstance(expr, kind):
            return op
    return None


@dataclass(frozen=True)
class Instruction:
    """``slot = op(*args, *consts)``: ``args`` are earlier slots, ``consts`` numbers.

    Examples
    --------
    >>> x = sp.Symbol("x")
    >>> IntervalProgram.of([2 * x], [x]).instructions  # doctest: +NORMALIZE_WHITESPACE
    [Instruction(op='i_point', args=(), consts=(2.0,)),
     Instruction(op='i_mul', args=(1, 0), consts=())]
    """

    op: str
    args: tuple[int, ...]
    consts: tuple[float, ...] = ()


class IntervalProgram:
    """Expressions lowered once to interval instructions, each distinct subexpression once.

    Slots ``0 .. n-1`` hold the arguments; every other slot is one
    :class:`Instruction` of :mod:`hybridlab.symbolic.interval_arithmetic` on
    earlier slots. The program is run here in Python (:meth:`run`) and printed
    as numba code by the compiled simulator, so both evaluate the same
    operations. ``lenient``: a construct that cannot be enclosed (an unknown
    function, a symbol without an interval, a non-finite constant) is the whole
    line instead of an :class:`IntervalError`.

    Examples
    --------
    >>> x = sp.Symbol("x")
    >>> program = IntervalProgram.of([sp.sin(x) ** 2 + sp.sin(x)], [x])
    >>> [ins.op for ins in program.instructions]  # sin(x) once
    ['i_sin', 'i_powi', 'i_add']
    >>> lo, hi = program.run([(0.0, math.pi)])[program.outputs[0]]
    >>> -1e-13 < lo <= 0.0 and 2.0 <= hi < 2.0 + 1e-13
    True
    """

    def __init__(self, index: Mapping[sp.Symbol, int], lenient: bool = False) -> None:
        self.index = dict(index)
        self.lenient = lenient
        self.n_args = len(index)
        self.instructions: list[Instruction] = []
        self.outputs: list[int] = []
        self._slots: dict[sp.Expr, int] = {}
        self._steps: list[Step] | None = None

    @classmethod
    def of(cls, exprs: Sequence[sp.Expr], symbols: Sequence[sp.Symbol],
           lenient: bool = False) -> IntervalProgram:
        """The program of ``exprs`` over ``symbols`` (in this order the arguments)."""
        program = cls({s: i for i, s in enumerate(symbols)}, lenient)
        program.outputs = [program.add(as_expression(e)) for e in exprs]
        return program

    def bind(self, symbol: sp.Symbol, expr: sp.Expr) -> None:
        """Make ``symbol`` stand for ``expr`` (a common subexpression) in later expressions."""
        self.index[symbol] = self.add(expr)

    def add(self, expr: sp.Expr) -> int:
        """The slot holding ``expr``'s enclosure (its instructions appended once)."""
        if expr in self.index:
            return self.index[expr]
        known = self._slots.get(expr)
        if known is not None:
            return known
        slot = self._emit(*self._lower(expr))
        self._slots[expr] = slot
        return slot

    def _emit(self, op: str, args: tuple[int, ...] = (), consts: tuple[float, ...] = ()) -> int:
        self.instructions.append(Instruction(op, args, consts))
        return self.n_args + len(self.instructions) - 1

    def _lower(self, expr: sp.Expr) -> tuple[str, tuple[int, ...], tuple[float, ...]]:
        if expr.is_Symbol:
            if not self.lenient:
                raise IntervalError(f"no interval given for symbol {expr}")
            return "i_entire", (), ()
        if expr.is_Number or expr.is_NumberSymbol:
            return self._constant(expr)
        if not isinstance(expr, _SUPPORTED):
            if self.lenient:
                return "i_entire", (), ()
            raise IntervalError(f"interval arithmetic does not support {type(expr).__name__} "
                                f"in {expr}")
        if isinstance(expr, sp.Pow):
            return self._power(expr)
        if isinstance(expr, sp.Mul) and expr.args[0] == -1:  # negation is exact
            return "i_neg", (self.add(sp.Mul(*expr.args[1:])),), ()
        fold = _op_of(expr, _FOLD)
        if fold is not None:
            return self._fold(fold, expr.args)
        if isinstance(expr, sp.atan2):
            return "i_atan2", (self.add(expr.args[0]), self.add(expr.args[1])), ()
        unary = _op_of(expr, _UNARY)
        if unary is None:  # not reached: _SUPPORTED holds exactly these classes
            raise IntervalError(f"interval arithmetic does not support {type(expr).__name__}")
        return unary, (self.add(expr.args[0]),), ()

    def _constant(self, value: sp.Expr) -> tuple[str, tuple[int, ...], tuple[float, ...]]:
        if not value.is_finite:
            if self.lenient:
                return "i_entire", (), ()
            raise IntervalError(f"non-finite constant {value}")
        v = float(sp.N(value, 30))
        exact = ((value.is_Rational and sp.Rational(v) == value)
                 or (value.is_Float and value._prec <= 53))  # a float's own 53 bits
        return ("i_point" if exact else "i_const"), (), (v,)

    def _fold(self, op: str, terms: Sequence[sp.Expr]) -> tuple[str, tuple[int, ...], tuple]:
        """A sum, product, min or max of two or more terms, left to right (a sum subtracts
        the terms with a coefficient of -1)."""
        acc = self.add(terms[0])
        for term in terms[1:-1]:
            acc = self._emit(*self._pair(op, acc, term))
        return self._pair(op, acc, terms[-1])

    def _pair(self, op: str, acc: int, term: sp.Expr) -> tuple[str, tuple[int, ...], tuple]:
        if op == "i_add" and isinstance(term, sp.Mul) and term.args[0] == -1:
            return "i_sub", (acc, self.add(sp.Mul(*term.args[1:]))), ()
        return op, (acc, self.add(term)), ()

    def _power(self, expr: sp.Pow) -> tuple[str, tuple[int, ...], tuple[float, ...]]:
        base, e = expr.args
        b = self.add(base)
        if e.is_Integer:
            return "i_powi", (b,), (int(e),)
        if e == sp.Rational(1, 2):
            return "i_sqrt", (b,), ()
        if e == sp.Rational(-1, 2):
            return "i_recip", (self._emit("i_sqrt", (b,)),), ()
        if e.is_Number:
            if not e.is_finite:
                return self._constant(e)
            return "i_pow", (b,), (float(e),)
        return "i_rpow", (b, self.add(e)), ()

    # ----- running in Python ------------------------------------------------------------------
    def run(self, env: Sequence[Pair]) -> list[Pair]:
        """Every slot's interval, the arguments ``env`` first."""
        if self._steps is None:
            self._steps = [_step(i) for i in self.instructions]
        vals = list(env)
        for step in self._steps:
            vals.append(step(vals))
        return vals

    def undefined(self, vals: Sequence[Pair]) -> EmptyInterval:
        """The error naming the first instruction that came out empty in ``vals``."""
        for k, ins in enumerate(self.instructions):
            if ia.is_empty(*vals[self.n_args + k]) and ins.args:
                operand = vals[ins.args[0]]
                if not ia.is_empty(*operand):
                    return _undefined(ins.op, Interval(*operand))
        return EmptyInterval("an expression is undefined on the whole box")


def _step(ins: Instruction) -> Step:
    """``ins`` as a Python function of the slot list."""
    f = getattr(ia, ins.op)
    c = ins.consts
    if len(ins.args) == 0:
        value = f(*c)
        return lambda vals: value
    if len(ins.args) == 1:
        (a,) = ins.args
        if c:
            return lambda vals: f(*vals[a], *c)
        return lambda vals: f(*vals[a])
    a, b = ins.args
    return lambda vals: f(*vals[a], *vals[b])


class IntervalFunction:
    """Sympy expressions compiled for evaluation over boxes.

    Parameters
    ----------
    exprs : sequence of sympy.Expr
        The expressions.
    symbols : sequence of sympy.Symbol
        Their arguments, in the order of the box's rows.

    Raises
    ------
    IntervalError
        For a symbol not in ``symbols`` or a construct it cannot enclose; when
        called, :class:`EmptyInterval` if an expression is undefined at every
        point of the box.

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
        self.program = IntervalProgram.of(self.exprs, symbols)
        # the calls run in Python so far (-1: numba is missing, all of them will), and the
        # program as the compiled loop's arrays (hybridlab.symbolic.interval_machine) once
        # COMPILE_AFTER have
        self._calls = 0
        self._compiled: CompiledProgram | None = None

    def _compile(self) -> CompiledProgram | None:
        """Count a call in Python; at the :data:`COMPILE_AFTER`-th, switch to the loop."""
        if self._calls < 0:
            return None
        self._calls += 1
        if self._calls < COMPILE_AFTER:
            return None
        machine = _machine()
        if machine is None:
            self._calls = -1
            return None
        self._compiled = machine(self.program)
        return self._compiled

    def pairs(self, env: Sequence[Pair]) -> list[Pair]:
        """Evaluate on argument intervals given as ``(lo, hi)`` pairs."""
        vals = self.program.run(env)
        out = [vals[k] for k in self.program.outputs]
        for lo, hi in out:
            if not lo <= hi:
                raise self.program.undefined(vals)
        return out

    def intervals(self, env: Sequence[Interval]) -> list[Interval]:
        """Evaluate on a list of argument intervals."""
        return [Interval(lo, hi) for lo, hi in self.pairs([(i.lo, i.hi) for i in env])]

    def __call__(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Enclosures ``(lo, hi)`` of every expression over the box ``[lo, hi]``.

        From the :data:`COMPILE_AFTER`-th call on it runs in the compiled loop of
        :mod:`~hybridlab.symbolic.interval_machine` where numba can be imported: the same
        numbers, about 60 times faster on a large program."""
        compiled = self._compiled if self._compiled is not None else self._compile()
        if compiled is not None:
            lo = np.asarray(lo, dtype=float)
            hi = np.asarray(hi, dtype=float)
            if lo.shape == hi.shape == (self.program.n_args,) and bool(np.all(lo <= hi)):
                result = compiled(lo, hi)
                if result is not None:
                    return result
            # bad bounds or an empty result: the Python run below names them
        env = [(float(a), float(b)) for a, b in zip(lo, hi, strict=True)]
        for a, b in env:
            if not a <= b:
                raise IntervalError(f"interval bounds must satisfy lo <= hi (got [{a}, {b}])")
        out = self.pairs(env)
        return (np.array([r[0] for r in out], dtype=float),
                np.array([r[1] for r in out], dtype=float))


COMPILE_AFTER = 8
"""Calls of an :class:`IntervalFunction` run in Python before it switches to the compiled
loop (a one-off evaluation never imports numba)."""


def _machine() -> type[CompiledProgram] | None:
    """:class:`~hybridlab.symbolic.interval_machine.CompiledProgram`, or ``None`` where
    numba cannot be imported."""
    try:
        from hybridlab.symbolic.interval_machine import CompiledProgram
    except ImportError:
        return None
    return CompiledProgram


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
    program = IntervalProgram.of([expr], symbols, lenient=True)
    out = program.outputs[0]
    entire = (-_INF, _INF)

    def evaluate(box: Mapping[sp.Symbol, Interval]) -> Interval:
        env = [(b.lo, b.hi) if (b := box.get(s)) is not None else entire for s in symbols]
        vals = program.run(env)
        lo, hi = vals[out]
        if not lo <= hi:
            raise program.undefined(vals)
        return Interval(lo, hi)
    return evaluate
