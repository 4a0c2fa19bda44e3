"""Interval versions of generated functions: sympy expressions printed as calls of
:mod:`.interval_ops`.

:func:`box_body` prints straight-line code that evaluates expressions over a
box (every symbol an interval ``[lo, hi]``), after the same common
subexpression elimination as the point functions of :mod:`.codegen`. Each
subexpression becomes a pair of locals; a construct without an interval
version (``tan``, ``atan2``, a piecewise expression...) evaluates to the whole
real line, which is always a correct enclosure. Like the point printer, it
writes text from sympy trees only: model text never reaches ``eval``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import sympy as sp

from hybridlab.symbolic.printing import common_subexpressions

__all__ = ["box_body"]

_UNARY = {sp.sin: "i_sin", sp.cos: "i_cos", sp.exp: "i_exp", sp.log: "i_log",
          sp.Abs: "i_abs", sp.sign: "i_sign", sp.atan: "i_atan", sp.tanh: "i_tanh",
          sp.sinh: "i_sinh", sp.cosh: "i_cosh", sp.asin: "i_asin", sp.acos: "i_acos"}
_FOLD = {sp.Mul: "i_mul", sp.Min: "i_min", sp.Max: "i_max"}


class _Writer:
    """Statements of one body; every interval lives in a pair of locals."""

    def __init__(self, symbols: Mapping[sp.Symbol, tuple[str, str]], indent: str) -> None:
        self.symbols = dict(symbols)
        self.indent = indent
        self.lines: list[str] = []
        self.count = 0

    def _emit(self, call: str) -> tuple[str, str]:
        lo, hi = f"_b{self.count}l", f"_b{self.count}h"
        self.count += 1
        self.lines.append(f"{self.indent}{lo}, {hi} = _iv.{call}")
        return lo, hi

    def interval(self, e: sp.Expr) -> tuple[str, str]:
        """Names of the locals holding the enclosure of ``e``."""
        if e in self.symbols:
            return self.symbols[e]
        if e.is_Number or isinstance(e, sp.NumberSymbol):
            value = float(e)
            return self._emit(f"i_const({value!r})")
        if isinstance(e, sp.Pow):
            return self._power(e)
        if isinstance(e, sp.Mul) and e.args[0] == -1:  # negation is exact
            return self._emit(f"i_neg({', '.join(self.interval(sp.Mul(*e.args[1:])))})")
        if isinstance(e, sp.Add):
            return self._sum(e.args)
        for kind, name in _FOLD.items():
            if isinstance(e, kind):
                acc = self.interval(e.args[0])
                for arg in e.args[1:]:
                    acc = self._emit(f"{name}({', '.join(acc + self.interval(arg))})")
                return acc
        for kind, name in _UNARY.items():
            if isinstance(e, kind) and len(e.args) == 1:
                return self._emit(f"{name}({', '.join(self.interval(e.args[0]))})")
        return self._emit("i_entire()")

    def _sum(self, terms: Sequence[sp.Expr]) -> tuple[str, str]:
        """A sum, subtracting the terms with a coefficient of -1."""
        acc = self.interval(terms[0])
        for term in terms[1:]:
            if isinstance(term, sp.Mul) and term.args[0] == -1:
                rest = self.interval(sp.Mul(*term.args[1:]))
                acc = self._emit(f"i_sub({', '.join(acc + rest)})")
            else:
                acc = self._emit(f"i_add({', '.join(acc + self.interval(term))})")
        return acc

    def _power(self, e: sp.Pow) -> tuple[str, str]:
        base, exponent = e.args
        b = self.interval(base)
        if exponent.is_Integer:
            return self._emit(f"i_powi({', '.join(b)}, {int(exponent)})")
        if exponent == sp.Rational(1, 2):
            return self._emit(f"i_sqrt({', '.join(b)})")
        if exponent.is_Number:
            return self._emit(f"i_pow({', '.join(b)}, {float(exponent)!r})")
        # a symbolic exponent: b**e = exp(e*log(b)) for b > 0 (else i_log gives the whole line)
        log_b = self._emit(f"i_log({', '.join(b)})")
        product = self._emit(f"i_mul({', '.join(self.interval(exponent) + log_b)})")
        return self._emit(f"i_exp({', '.join(product)})")

    def bind(self, sym: sp.Symbol, e: sp.Expr) -> None:
        """Give a common subexpression its pair of locals."""
        self.symbols[sym] = self.interval(e)


def box_body(exprs: Sequence[sp.Expr], symbols: Mapping[sp.Symbol, tuple[str, str]],
             indent: str) -> list[str]:
    """Statements writing the enclosures of ``exprs`` to ``out``: ``out[i]`` the lower
    bound of ``exprs[i]``, ``out[len(exprs) + i]`` its upper bound.

    ``symbols`` maps every symbol that may occur to the source text of its
    lower and upper bound. The caller's module imports :mod:`.interval_ops`
    as ``_iv``.

    Examples
    --------
    >>> x = sp.Symbol("x")
    >>> lines = box_body([sp.sin(x) + 1], {x: ("x[0]", "x[1]")}, "")
    >>> lines[:3]  # doctest: +NORMALIZE_WHITESPACE
    ['_b0l, _b0h = _iv.i_const(1.0)', '_b1l, _b1h = _iv.i_sin(x[0], x[1])',
     '_b2l, _b2h = _iv.i_add(_b0l, _b0h, _b1l, _b1h)']
    >>> lines[-1]
    'out[1] = _b2h'
    """
    replacements, reduced = common_subexpressions(exprs)
    writer = _Writer(symbols, indent)
    for sym, e in replacements:
        writer.bind(sym, e)
    ends = [writer.interval(e) for e in reduced]
    lines = writer.lines
    for i, (lo, hi) in enumerate(ends):
        lines.append(f"{indent}out[{i}] = {lo}")
        lines.append(f"{indent}out[{len(ends) + i}] = {hi}")
    return lines
