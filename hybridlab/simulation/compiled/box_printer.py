"""Interval versions of generated functions: sympy expressions printed as calls of
:mod:`.interval_ops`.

:func:`box_body` prints straight-line code that evaluates expressions over a
box (every symbol an interval ``[lo, hi]``), after the same common
subexpression elimination as the point functions of :mod:`.codegen`. The
expressions are lowered by :class:`~hybridlab.symbolic.intervals.IntervalProgram`,
the same lowering reachability and the mode graph's checks run in Python, and
each instruction becomes one call writing a pair of locals. A construct
without an interval version (a piecewise expression, an unknown function)
evaluates to the whole real line, which is always a correct enclosure, and so
does an expression undefined on the whole box. Like the point printer, it
writes text from sympy trees only: model text never reaches ``eval``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import sympy as sp

from hybridlab.symbolic.intervals import IntervalProgram
from hybridlab.symbolic.printing import common_subexpressions

__all__ = ["box_body"]


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
    >>> lines  # doctest: +NORMALIZE_WHITESPACE
    ['_b1l, _b1h = _iv.i_point(1.0)', '_b2l, _b2h = _iv.i_sin(x[0], x[1])',
     '_b3l, _b3h = _iv.i_add(_b1l, _b1h, _b2l, _b2h)',
     'out[0], out[1] = _iv.i_bound(_b3l, _b3h)']
    """
    replacements, reduced = common_subexpressions(exprs)
    program = IntervalProgram({s: k for k, s in enumerate(symbols)}, lenient=True)
    for sym, e in replacements:
        program.bind(sym, e)
    ends = [program.add(e) for e in reduced]
    names = [*symbols.values()]
    names += [(f"_b{k}l", f"_b{k}h") for k in range(len(names), program.n_args
                                                     + len(program.instructions))]
    lines = []
    for k, ins in enumerate(program.instructions):
        args = [text for a in ins.args for text in names[a]] + [repr(c) for c in ins.consts]
        lo, hi = names[program.n_args + k]
        lines.append(f"{indent}{lo}, {hi} = _iv.{ins.op}({', '.join(args)})")
    for i, slot in enumerate(ends):
        lo, hi = names[slot]
        lines.append(f"{indent}out[{i}], out[{len(ends) + i}] = _iv.i_bound({lo}, {hi})")
    return lines
