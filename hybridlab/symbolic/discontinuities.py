"""Discontinuities of a flow made explicit as switching surfaces.

Every ``sign(s)``, ``abs(s)``, ``min(a, b)`` and ``max(a, b)`` in a flow is
replaced by an expression in a new symbol ``sigma_k`` that the simulator holds
at ``+1`` or ``-1`` between events (or at the Filippov equivalent value while
sliding), and ``s`` (``a - b`` for min/max) becomes a switching function
whose zero crossings are located as state events. The flow integrated
between events is therefore smooth.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import sympy as sp

__all__ = ["Switch", "extract_switches"]


@dataclass(frozen=True)
class Switch:
    """One switching surface ``expr = 0`` with its sign symbol.

    Attributes
    ----------
    symbol : sympy.Symbol
        ``sigma_k``: +1 on the side ``expr > 0``, -1 on ``expr < 0``.
    expr : sympy.Expr
        The switching function.
    kind : str
        ``"sign"``, ``"abs"``, ``"min"`` or ``"max"``: what produced it.
    text : str
        A readable form, such as ``"sign(v)"``, used in event logs.

    Examples
    --------
    >>> x, y = sp.symbols("x y", real=True)
    >>> smooth, (switch,) = extract_switches([sp.Max(x, y)])
    >>> switch
    Switch(symbol=_sigma0, expr=x - y, kind='max', text='max(x, y)')
    >>> smooth[0].subs(switch.symbol, 1), smooth[0].subs(switch.symbol, -1)  # x > y, x < y
    (x, y)
    """

    symbol: sp.Symbol
    expr: sp.Expr
    kind: str
    text: str


class _Extractor:
    def __init__(self, prefix: str) -> None:
        self.prefix = prefix
        self.switches: list[Switch] = []
        self._by_expr: dict[sp.Expr, sp.Symbol] = {}

    def sigma(self, s: sp.Expr, kind: str, text: str) -> sp.Expr:
        """The signed sigma for switching function ``s`` (shared with ``-s``)."""
        if s in self._by_expr:
            return self._by_expr[s]
        if -s in self._by_expr:
            return -self._by_expr[-s]
        symbol = sp.Symbol(f"{self.prefix}{len(self.switches)}", real=True)
        self._by_expr[s] = symbol
        self.switches.append(Switch(symbol, s, kind, text))
        return symbol

    def rewrite(self, expr: sp.Expr) -> sp.Expr:
        if expr.is_Atom:
            return expr
        args = [self.rewrite(a) for a in expr.args]
        if isinstance(expr, sp.sign):
            return self.sigma(args[0], "sign", f"sign({args[0]})")
        if isinstance(expr, sp.Abs):
            return self.sigma(args[0], "abs", f"abs({args[0]})") * args[0]
        if isinstance(expr, sp.Max | sp.Min):
            return self._minmax(type(expr), args)
        if isinstance(expr, sp.Heaviside):
            return (1 + self.sigma(args[0], "sign", f"heaviside({args[0]})")) / 2
        return expr.func(*args) if tuple(args) != expr.args else expr

    def _minmax(self, kind: type, args: list[sp.Expr]) -> sp.Expr:
        result = args[0]
        for other in args[1:]:
            diff = result - other
            name = "max" if kind is sp.Max else "min"
            sigma = self.sigma(diff, name, f"{name}({result}, {other})")
            half = (result + other) / 2
            result = half + sigma * diff / 2 if kind is sp.Max else half - sigma * diff / 2
        return result


def extract_switches(
    exprs: Sequence[sp.Expr], prefix: str = "_sigma"
) -> tuple[tuple[sp.Expr, ...], tuple[Switch, ...]]:
    """Replace the discontinuous functions in ``exprs`` by sign symbols.

    Parameters
    ----------
    exprs : sequence of sympy.Expr
        Flow expressions of one mode.
    prefix : str
        Name prefix of the generated sign symbols.

    Returns
    -------
    smooth : tuple of sympy.Expr
        The expressions with ``sigma_k`` symbols in place of the discontinuities.
    switches : tuple of Switch
        One entry per distinct switching function (``s`` and ``-s`` share one).

    Examples
    --------
    >>> v, c, d = sp.symbols("v c d", real=True)
    >>> smooth, switches = extract_switches([-c*sp.sign(v) - d*v])
    >>> smooth[0], switches[0].expr
    (-_sigma0*c - d*v, v)
    """
    extractor = _Extractor(prefix)
    smooth = tuple(extractor.rewrite(e) for e in exprs)
    return smooth, tuple(extractor.switches)



