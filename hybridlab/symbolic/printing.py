"""The one code printer: sympy expressions to Python source in which no model name appears.

Every generated numeric function of hybridlab (the reference engine's flows,
guards and resets, observers, reachability's point functions, the graph
checks' local search and the numba kernel's model functions) is printed here.
A model name could otherwise meet a name the printed code relies on: a
parameter ``e`` would turn ``exp(1)``, printed as numpy's ``e``, into the
parameter's value, and parameters named ``arcsin`` or ``numpy`` would shadow
the functions the code calls. So:

- the caller gives every symbol the code may read a *generated* name (an
  argument ``_a3``, an array element ``x[0]``); common subexpressions are
  named ``_c0, _c1, ...`` with a prefix no symbol of the expressions carries;
- the printer prints a symbol only through that mapping and raises
  :class:`PrintError` for any other symbol, so a model name can never reach
  the text;
- module functions and constants are printed fully qualified (``numpy.sin``,
  ``math.e``), and :func:`numpy_function` runs the text in a namespace that
  holds only the modules ``numpy``, ``math`` and ``functools``.

Model names cannot start with ``_`` (:func:`hybridlab.model.expressions.check_name`),
but the guarantee does not rest on that: the printed text holds no symbol
name at all.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any

import numpy as np
import sympy as sp
from sympy.printing.numpy import NumPyPrinter
from sympy.printing.pycode import PythonCodePrinter

from hybridlab.errors import HybridlabError

__all__ = ["ArrayPrinter", "Lowered", "PrintError", "ScalarPrinter", "common_subexpressions",
           "lower", "numpy_function", "scalar_printer"]


class PrintError(HybridlabError, ValueError):
    """An expression cannot be printed: a symbol without a generated name, or a construct
    the target cannot express.

    Examples
    --------
    >>> x, y = sp.symbols("x y", real=True)
    >>> ArrayPrinter({x: "x[0]"}).doprint(x + y)
    Traceback (most recent call last):
    ...
    hybridlab.symbolic.printing.PrintError: symbol 'y' has no generated name
    """


class _Guarded:
    """Printing of symbols through the generated names only (mixed into the printers)."""

    _names: Mapping[sp.Symbol, str]

    def _print_Symbol(self, expr: sp.Symbol) -> str:
        try:
            return self._names[expr]
        except KeyError:
            raise PrintError(f"symbol {expr.name!r} has no generated name") from None

    _print_Dummy = _print_Symbol

    def _print_not_supported(self, expr: sp.Basic) -> str:
        raise PrintError(f"cannot print {type(expr).__name__} in {expr}")


class ArrayPrinter(_Guarded, NumPyPrinter):
    """numpy source: works element-wise on arrays of points (fully qualified ``numpy.``).

    Examples
    --------
    A parameter named ``e`` is printed as its generated name, Euler's number as ``numpy.e``:

    >>> e, x = sp.symbols("e x", real=True)
    >>> ArrayPrinter({x: "x[0]", e: "p[0]"}).doprint(e * sp.exp(1) + sp.sin(x))
    'numpy.e*p[0] + numpy.sin(x[0])'
    """

    def __init__(self, names: Mapping[sp.Symbol, str]) -> None:
        super().__init__({"fully_qualified_modules": True, "inline": True,
                          "allow_unknown_functions": False, "strict": True})
        self._names = names


class ScalarPrinter(_Guarded, PythonCodePrinter):
    """Scalar ``math`` source (fully qualified ``math.``), for numba and plain floats.

    ``sign`` is printed as a call of ``_sign`` (the caller's module defines it) and
    ``min``/``max`` as the builtins over floats, which numba compiles.

    Examples
    --------
    >>> c, v = sp.symbols("c v", real=True)
    >>> printer = ScalarPrinter({c: "p0", v: "x1"}, sign="_sign")
    >>> printer.doprint(-c * sp.sign(v) + sp.Max(v, 0) + sp.cos(v))
    '-p0*_sign(x1) + math.cos(x1) + max(float(0), float(x1))'
    """

    def __init__(self, names: Mapping[sp.Symbol, str], *, sign: str | None = None) -> None:
        super().__init__({"fully_qualified_modules": True, "standard": "python3",
                          "allow_unknown_functions": False, "strict": True})
        self._names = names
        self._sign = sign

    def _print_sign(self, expr: sp.Expr) -> str:
        if self._sign is None:
            return super()._print_sign(expr)
        return f"{self._sign}({self._print(expr.args[0])})"

    def _print_Min(self, expr: sp.Expr) -> str:
        return "min(" + ", ".join(f"float({self._print(a)})" for a in expr.args) + ")"

    def _print_Max(self, expr: sp.Expr) -> str:
        return "max(" + ", ".join(f"float({self._print(a)})" for a in expr.args) + ")"


def scalar_printer(names: Mapping[sp.Symbol, str], *, sign: str | None = None) -> ScalarPrinter:
    """A :class:`ScalarPrinter` over ``names`` (symbol to generated identifier).

    Examples
    --------
    Without ``sign``, ``sign(x)`` is printed inline:

    >>> x = sp.Symbol("x", real=True)
    >>> printer = scalar_printer({x: "x0"})
    >>> printer.doprint(sp.sign(x)), printer.doprint(sp.sqrt(x))
    ('(0.0 if x0 == 0 else math.copysign(1, x0))', 'math.sqrt(x0)')
    """
    return ScalarPrinter(names, sign=sign)


def _fresh_prefix(exprs: Sequence[sp.Expr], prefix: str) -> str:
    """``prefix`` lengthened until no symbol of ``exprs`` starts with it."""
    taken = [s.name for e in exprs for s in e.free_symbols]
    while any(name.startswith(prefix) for name in taken):
        prefix += "_"
    return prefix


def _temporaries(prefix: str) -> Iterator[sp.Symbol]:
    k = 0
    while True:
        yield sp.Symbol(f"{prefix}{k}")
        k += 1


def common_subexpressions(exprs: Sequence[sp.Expr]
                          ) -> tuple[list[tuple[sp.Symbol, sp.Expr]], list[sp.Expr]]:
    """``sympy.cse`` with temporaries ``_c0, _c1, ...`` whose names no symbol of ``exprs`` has.

    Examples
    --------
    >>> x = sp.Symbol("x")
    >>> common_subexpressions([sp.sin(x) + 1, sp.sin(x) ** 2])
    ([(_c0, sin(x))], [_c0 + 1, _c0**2])
    """
    exprs = [sp.Integer(0) + e for e in exprs]
    return sp.cse(exprs, symbols=_temporaries(_fresh_prefix(exprs, "_c")))


class Lowered:
    """Expressions after common-subexpression elimination, ready to print as statements.

    Attributes
    ----------
    temporaries : list of (sympy.Symbol, sympy.Expr)
        The common subexpressions, in evaluation order.
    results : list of sympy.Expr
        The expressions in terms of the arguments and the temporaries.
    names : dict
        Every symbol that may be printed with its generated name: the arguments'
        names as given, the temporaries' ``_c0, _c1, ...``.

    Examples
    --------
    >>> x = sp.Symbol("x", real=True)
    >>> low = Lowered([sp.sin(x) ** 2 + sp.sin(x), sp.cos(x)], {x: "x[0]"})
    >>> low.temporaries, low.results
    ([(_c0, sin(x))], [_c0**2 + _c0, cos(x)])
    >>> low.statements(ScalarPrinter(low.names), "", "out[{i}] = {value}")
    ['_c0 = math.sin(x[0])', 'out[0] = _c0**2 + _c0', 'out[1] = math.cos(x[0])']
    """

    def __init__(self, exprs: Sequence[sp.Expr], names: Mapping[sp.Symbol, str],
                 cse: bool = True) -> None:
        exprs = [sp.Integer(0) + e for e in exprs]
        used = set().union(*(e.free_symbols for e in exprs)) if exprs else set()
        missing = sorted(s.name for s in used if s not in names)
        if missing:
            raise PrintError(f"symbol {missing[0]!r} is not an argument")
        self.used = used
        if cse:
            self.temporaries, self.results = common_subexpressions(exprs)
        else:
            self.temporaries, self.results = [], exprs
        self.names = {**names, **{s: s.name for s, _ in self.temporaries}}

    def statements(self, printer: Any, indent: str, target: str) -> list[str]:
        """``name = value`` for each temporary, then ``target.format(i=i, value=...)`` for each
        result."""
        lines = [f"{indent}{s.name} = {printer.doprint(e)}" for s, e in self.temporaries]
        lines += [indent + target.format(i=i, value=printer.doprint(e))
                  for i, e in enumerate(self.results)]
        for line in lines:
            if "\n" in line.strip("\n"):
                raise PrintError(f"cannot print {line.strip()[:60]}")
        return lines


def lower(exprs: Sequence[sp.Expr], names: Mapping[sp.Symbol, str], cse: bool = True) -> Lowered:
    """Prepare ``exprs`` for printing; every free symbol must be a key of ``names``.

    Examples
    --------
    >>> e, x = sp.symbols("e x", real=True)
    >>> low = lower([e * sp.exp(1) + sp.sin(x)], {e: "p[0]", x: "x[0]"})
    >>> low.statements(ArrayPrinter(low.names), "", "out[{i}] = {value}")
    ['out[0] = numpy.e*p[0] + numpy.sin(x[0])']
    """
    return Lowered(exprs, names, cse)


#: the only names a generated function sees besides Python's builtins: the modules the
#: printers qualify their calls with (``functools.reduce`` folds a Min of many arguments)
_NAMESPACE: Mapping[str, Any] = {"numpy": np, "math": math, "functools": functools}


def numpy_function(groups: Sequence[sp.Symbol | Sequence[sp.Symbol]], exprs: Sequence[sp.Expr],
                   *, scalar: bool = False, cse: bool = True) -> Callable[..., list[Any]]:
    """A Python function of argument groups returning ``[expr_0, expr_1, ...]``.

    Each group is one positional argument: a symbol (a scalar argument) or a sequence
    of symbols (an array argument read by index). No model name appears in the
    function's text, so no name can capture another (see the module's docstring).

    Parameters
    ----------
    groups : sequence of sympy.Symbol or sequence of sympy.Symbol
        The arguments.
    exprs : sequence of sympy.Expr
        The results; every free symbol must belong to a group.
    scalar : bool
        Print for plain floats (``math``) instead of numpy arrays.
    cse : bool
        Eliminate common subexpressions.

    Raises
    ------
    PrintError
        For a symbol outside the groups or a construct the printer cannot express.

    Examples
    --------
    A parameter named ``e`` is not Euler's number:

    >>> e, x = sp.symbols("e x", real=True)
    >>> f = numpy_function([[x], [e]], [sp.exp(1) * e + x])
    >>> bool(f(np.array([1.0]), np.array([2.0]))[0] == np.e * 2.0 + 1.0)
    True
    """
    names: dict[sp.Symbol, str] = {}
    reads: list[str] = []
    for g, group in enumerate(groups):
        if isinstance(group, sp.Symbol):
            if group not in names:
                names[group] = f"_g{g}"
            continue
        for i, s in enumerate(group):
            if s not in names:  # the first occurrence wins, as in lambdify
                names[s] = f"_a{len(reads)}"
                reads.append(f"_g{g}[{i}]")
    low = lower(exprs, names, cse)
    printer = scalar_printer(low.names) if scalar else ArrayPrinter(low.names)
    lines = [f"def _generated({', '.join(f'_g{g}' for g in range(len(groups)))}):"]
    read = {names[s] for s in low.used}
    lines += [f"    _a{k} = {where}" for k, where in enumerate(reads) if f"_a{k}" in read]
    lines += low.statements(printer, "    ", "_r{i} = {value}")
    lines.append("    return [" + ", ".join(f"_r{i}" for i in range(len(exprs))) + "]")
    modules = {name.split(".")[0] for name in printer.module_imports}
    if not modules <= _NAMESPACE.keys():
        raise PrintError(f"printed code needs the module {sorted(modules - _NAMESPACE.keys())[0]}")
    namespace = dict(_NAMESPACE)
    # the text is printed from sympy trees by the guarded printers above, never model text
    exec(compile("\n".join(lines) + "\n", "<hybridlab generated>", "exec"), namespace)  # noqa: S102
    function: Callable[..., list[Any]] = namespace["_generated"]
    function.__doc__ = "\n".join(lines)
    return function
