"""Interval programs run by one compiled loop: the one arithmetic, at machine speed.

An :class:`~hybridlab.symbolic.intervals.IntervalProgram` is a list of instructions of
:mod:`hybridlab.symbolic.interval_arithmetic`. Run in Python, each instruction costs a
function call and a tuple; a flow's Hessian over a box (a cart with a pendulum and a
cascaded controller, 19 states: 367 instructions, 8,379 entries) takes about 4 ms, and
reachability runs such programs tens of times per step. This module compiles, with
numba, one loop that runs *any* program handed to it as arrays (an op code, two operand
slots and a constant per instruction): about 60 times faster on that Hessian.

**The same numbers.** The loop calls the arithmetic's own functions, compiled (the ones
the compiled simulator's quiet-step proofs call too), on the same operands in the same order, so
every slot holds the same floats as the Python run, bit for bit (the tests compare them on
random programs). Soundness rests on the arithmetic's rounding policy either way.

**When.** :class:`~hybridlab.symbolic.intervals.IntervalFunction` switches to the loop
after a few calls when numba can be imported (the ``fast`` extra), so one-off
evaluations (``hybridlab check``) never import numba. The loop is compiled once per
machine and version and kept in numba's cache, which is dropped when this module or the
arithmetic changes (numba itself checks a cached function only against its own source
file). ``make test`` and ``make demo`` compile it during set-up.

Examples
--------
>>> import numpy as np, sympy as sp
>>> from hybridlab.symbolic.intervals import IntervalProgram
>>> x, y = sp.symbols("x y", real=True)
>>> program = IntervalProgram.of([x * sp.sin(y) + x**2], [x, y])
>>> compiled = CompiledProgram(program)
>>> lo, hi = compiled(np.array([1.0, 0.0]), np.array([2.0, 1.0]))
>>> python = program.run([(1.0, 2.0), (0.0, 1.0)])[program.outputs[0]]
>>> (float(lo[0]), float(hi[0])) == python
True
"""

from __future__ import annotations

import types
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numba
import numpy as np

from hybridlab._numba_cache import refresh_cache, tell
from hybridlab.symbolic import interval_arithmetic as _arithmetic
from hybridlab.symbolic.interval_arithmetic import (
    i_abs,
    i_acos,
    i_add,
    i_asin,
    i_atan,
    i_atan2,
    i_const,
    i_cos,
    i_cosh,
    i_div,
    i_empty,
    i_entire,
    i_exp,
    i_heaviside,
    i_log,
    i_max,
    i_min,
    i_mul,
    i_neg,
    i_point,
    i_pow,
    i_powi,
    i_recip,
    i_rpow,
    i_sign,
    i_sin,
    i_sinh,
    i_sqrt,
    i_sub,
    i_tan,
    i_tanh,
)

if TYPE_CHECKING:
    from hybridlab.symbolic.intervals import IntervalProgram

__all__ = ["ARITHMETIC", "OPS", "CompiledProgram", "compiled_arithmetic", "warm"]


def compiled_arithmetic() -> dict[str, Any]:
    """Every function of the arithmetic jitted, calling the jitted versions of the others
    (the constants of the arithmetic's module are bound alongside).

    Examples
    --------
    >>> ops = compiled_arithmetic()
    >>> lo, hi = ops["i_mul"](-1.0, 2.0, 3.0, 4.0)
    >>> lo <= -4.0 and hi >= 8.0
    True
    """
    namespace: dict[str, Any] = {name: value for name, value in vars(_arithmetic).items()
                                 if not isinstance(value, types.FunctionType)}
    for name, f in vars(_arithmetic).items():
        if isinstance(f, types.FunctionType) and f.__module__ == _arithmetic.__name__:
            rebound = types.FunctionType(f.__code__, namespace, name, f.__defaults__,
                                         f.__closure__)
            rebound.__doc__ = f.__doc__
            namespace[name] = numba.njit(cache=True)(rebound)
    return namespace


ARITHMETIC = compiled_arithmetic()
"""The compiled arithmetic: the loop calls these, and so do the compiled simulator's box
functions (:mod:`hybridlab.simulation.compiled.interval_ops`)."""

#: each instruction of a program and how the loop calls it: ``const`` takes the
#: instruction's number, ``int`` and ``float`` an operand and the number, ``unary`` and
#: ``binary`` one and two operands, ``nullary`` nothing; the index is the op code
OPS: tuple[tuple[str, str], ...] = (
    ("i_point", "const"), ("i_const", "const"), ("i_entire", "nullary"),
    ("i_empty", "nullary"),
    ("i_add", "binary"), ("i_sub", "binary"), ("i_mul", "binary"), ("i_div", "binary"),
    ("i_min", "binary"), ("i_max", "binary"), ("i_atan2", "binary"), ("i_rpow", "binary"),
    ("i_powi", "int"), ("i_pow", "float"),
    ("i_neg", "unary"), ("i_recip", "unary"), ("i_sqrt", "unary"), ("i_exp", "unary"),
    ("i_log", "unary"), ("i_sin", "unary"), ("i_cos", "unary"), ("i_tan", "unary"),
    ("i_asin", "unary"), ("i_acos", "unary"), ("i_atan", "unary"), ("i_sinh", "unary"),
    ("i_cosh", "unary"), ("i_tanh", "unary"), ("i_abs", "unary"), ("i_sign", "unary"),
    ("i_heaviside", "unary"),
)
_CODES = {name: code for code, (name, _) in enumerate(OPS)}


def _run(code, a, b, k, c, lo, hi, n_args):  # noqa: ANN001, ANN202 - compiled by numba
    """Run a program's instructions on the slots ``lo``, ``hi`` (the arguments first).

    One branch per op code of :data:`OPS`, in its order; ``a``, ``b`` are each
    instruction's operand slots, ``k`` and ``c`` its integer and real constant. As written
    it calls the arithmetic in Python; :data:`_RUN` is the same code compiled, bound to
    the compiled arithmetic."""
    for i in range(code.shape[0]):
        op = code[i]
        al, ah, bl, bh = lo[a[i]], hi[a[i]], lo[b[i]], hi[b[i]]
        if op == 0:
            r = i_point(c[i])
        elif op == 1:
            r = i_const(c[i])
        elif op == 2:
            r = i_entire()
        elif op == 3:
            r = i_empty()
        elif op == 4:
            r = i_add(al, ah, bl, bh)
        elif op == 5:
            r = i_sub(al, ah, bl, bh)
        elif op == 6:
            r = i_mul(al, ah, bl, bh)
        elif op == 7:
            r = i_div(al, ah, bl, bh)
        elif op == 8:
            r = i_min(al, ah, bl, bh)
        elif op == 9:
            r = i_max(al, ah, bl, bh)
        elif op == 10:
            r = i_atan2(al, ah, bl, bh)
        elif op == 11:
            r = i_rpow(al, ah, bl, bh)
        elif op == 12:
            r = i_powi(al, ah, k[i])
        elif op == 13:
            r = i_pow(al, ah, c[i])
        elif op == 14:
            r = i_neg(al, ah)
        elif op == 15:
            r = i_recip(al, ah)
        elif op == 16:
            r = i_sqrt(al, ah)
        elif op == 17:
            r = i_exp(al, ah)
        elif op == 18:
            r = i_log(al, ah)
        elif op == 19:
            r = i_sin(al, ah)
        elif op == 20:
            r = i_cos(al, ah)
        elif op == 21:
            r = i_tan(al, ah)
        elif op == 22:
            r = i_asin(al, ah)
        elif op == 23:
            r = i_acos(al, ah)
        elif op == 24:
            r = i_atan(al, ah)
        elif op == 25:
            r = i_sinh(al, ah)
        elif op == 26:
            r = i_cosh(al, ah)
        elif op == 27:
            r = i_tanh(al, ah)
        elif op == 28:
            r = i_abs(al, ah)
        elif op == 29:
            r = i_sign(al, ah)
        elif op == 30:
            r = i_heaviside(al, ah)
        else:
            r = i_empty()
        lo[n_args + i] = r[0]
        hi[n_args + i] = r[1]


def _compile_loop() -> Any:
    """:func:`_run` with its names bound to the compiled arithmetic, jitted."""
    # __name__: numba's cache imports the function's module when it loads the machine code
    namespace = {"__name__": __name__, **{name: ARITHMETIC[name] for name, _ in OPS}}
    loop = types.FunctionType(_run.__code__, namespace, "_run")
    return numba.njit(cache=True, nogil=True)(loop)


_RUN = _compile_loop()


def _cache_folder() -> Path:
    path = getattr(getattr(_RUN, "_cache", None), "_cache_path", None)
    return Path(path) if path else Path(__file__).parent / "__pycache__"


# numba checks the loop's cache against this file only: drop it when the arithmetic changed
refresh_cache(_cache_folder(), (Path(__file__), Path(_arithmetic.__file__)),
              "interval-machine.sha256", ("interval_machine.*.nbi", "interval_machine.*.nbc"))


class CompiledProgram:
    """One :class:`~hybridlab.symbolic.intervals.IntervalProgram` as the loop's arrays.

    Calling it with a box returns the enclosures of the program's outputs, or ``None``
    when one of them is empty (an expression undefined on the whole box), which the
    caller reports as the Python run does.

    Examples
    --------
    >>> import sympy as sp
    >>> from hybridlab.symbolic.intervals import IntervalProgram
    >>> x = sp.Symbol("x", real=True)
    >>> CompiledProgram(IntervalProgram.of([sp.sqrt(x)], [x]))(np.array([-2.0]),
    ...                                                         np.array([-1.0])) is None
    True
    """

    __slots__ = ("code", "first", "second", "ints", "consts", "n_args", "n_slots", "outputs")

    def __init__(self, program: IntervalProgram) -> None:
        if not _RUN.signatures and not any(_cache_folder().glob("interval_machine._run-*.nbi")):
            tell("compiling the interval loop: once per machine and version, about 10 s")
        n = len(program.instructions)
        self.code = np.empty(n, dtype=np.int64)
        self.first = np.zeros(n, dtype=np.int64)
        self.second = np.zeros(n, dtype=np.int64)
        self.ints = np.zeros(n, dtype=np.int64)
        self.consts = np.zeros(n)
        for i, ins in enumerate(program.instructions):
            self.code[i] = _CODES[ins.op]  # a KeyError here is an op the table lacks
            if ins.args:
                self.first[i] = ins.args[0]
            if len(ins.args) > 1:
                self.second[i] = ins.args[1]
            if ins.consts:
                if ins.op == "i_powi":
                    self.ints[i] = int(ins.consts[0])
                else:
                    self.consts[i] = ins.consts[0]
        self.n_args = program.n_args
        self.n_slots = program.n_args + n
        self.outputs = np.asarray(program.outputs, dtype=np.int64)

    def __call__(self, lo: np.ndarray, hi: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray] | None:
        """Enclosures ``(lo, hi)`` of the outputs over the box ``[lo, hi]`` (checked by the
        caller); ``None`` if one is empty."""
        slots_lo = np.empty(self.n_slots)
        slots_hi = np.empty(self.n_slots)
        slots_lo[:self.n_args] = lo
        slots_hi[:self.n_args] = hi
        _RUN(self.code, self.first, self.second, self.ints, self.consts, slots_lo, slots_hi,
             self.n_args)
        out_lo, out_hi = slots_lo[self.outputs], slots_hi[self.outputs]
        if not np.all(out_lo <= out_hi):  # NaN (empty) too
            return None
        return out_lo, out_hi


def warm() -> None:
    """Compile (or load from the cache) the loop and the arithmetic it calls.

    Examples
    --------
    >>> warm()
    """
    import sympy as sp

    from hybridlab.symbolic.intervals import IntervalProgram

    x = sp.Symbol("x", real=True)
    CompiledProgram(IntervalProgram.of([x + 1], [x]))(np.zeros(1), np.ones(1))
