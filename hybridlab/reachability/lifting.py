"""Clock polynomials lifted to new states: modes that are affine but for their clocks.

A timed reference generator makes a mode's flow polynomial in its clocks: a cart that
tracks ``x_ref = x_s + v_s tau + a_s tau^2 / 2`` has the terms ``tau^2`` and
``v_s tau`` in its flow, where ``tau' = 1`` and ``x_s, v_s, a_s`` are constant in the
mode. Linearised step by step, such a mode is reduced at every step, so it wraps, and
its sets lose the correlations that the next jump needs (the reference against the
recorded target).

Every monomial ``mu`` in clocks (``k' = 1``) and constants (``c' = 0``) has a derivative
that is again such a polynomial of lower degree (``d(c tau^2)/dt = 2 c tau``). So with the
monomials of degree two and more as extra states ``m``, closed under that derivative, a
flow that is affine in the other states and the inputs, plus a polynomial in the clocks
and constants, is *exactly* affine in ``(z, m)``. :class:`ClockLift` finds those
monomials and builds the affine flow; the flowpipe of the lifted system (an
:class:`~hybridlab.reachability.chain.AffineChain`, with no remainder and no reduction
between steps) projected on ``z`` encloses the mode's flowpipe.

What it rests on: the lifted flow is the mode's flow with each monomial renamed (a
symbolic identity); the lifted initial set encloses ``(z, mu(z))`` over the set by the
mean-value form (:meth:`~hybridlab.reachability.meanvalue.MeanValue.affine_bounds`),
exact where the clocks are zero (a segment entered with ``tau := 0``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sp

from hybridlab.reachability.meanvalue import MeanValue
from hybridlab.reachability.rounding import product_error, up
from hybridlab.reachability.sets import Zonotope
from hybridlab.reachability.system import ModeSystem, Rows

__all__ = ["MAX_MONOMIALS", "ClockLift"]

MAX_MONOMIALS = 16
"""Most monomials a mode is lifted with (a larger closure: the mode is linearised)."""


@dataclass(frozen=True, eq=False)
class ClockLift:
    """A mode whose flow is affine in ``(z, m)``, ``m`` the monomials of its clocks and
    constants of degree two and more.

    Attributes
    ----------
    n : int
        Dimension of the mode's states ``z`` (the lifted states follow them).
    monomials : tuple of sympy.Expr
        The lifted monomials, in the order of the extra states.
    flow : ModeSystem
        The affine flow over ``(z, m)`` and the mode's inputs.

    Examples
    --------
    A cart that tracks ``x_ref = x_s + v_s tau + tau**2 / 2`` with a P controller:

    >>> x, tau, x_s, v_s = sp.symbols("x tau x_s v_s", real=True)
    >>> flow = (10 * (x_s + v_s * tau + tau**2 / 2 - x), sp.Integer(1), sp.Integer(0),
    ...         sp.Integer(0))
    >>> zs = (x, tau, x_s, v_s)
    >>> mode = ModeSystem("track", flow, zs, (), Rows([], zs), (), Rows([], zs))
    >>> lift = ClockLift.of(mode)
    >>> lift.monomials, lift.flow.affine
    ((tau**2, tau*v_s), True)
    >>> lift.flow.flow[4:]          # (tau**2)' = 2 tau, (v_s tau)' = v_s
    (2*tau, v_s)
    >>> P = Zonotope([0.0, 0.0, 1.0, 0.5], np.diag([0.01, 0.0, 0.1, 0.1]))
    >>> bool(np.abs(lift.lift(P).bounds()[4:]).max() < 1e-200)   # 0 at tau = 0
    True
    """

    n: int
    monomials: tuple[sp.Expr, ...]
    flow: ModeSystem
    _values: MeanValue

    @staticmethod
    def of(mode: ModeSystem) -> ClockLift | None:
        """The lift of ``mode``, or ``None`` when its flow is affine already, or is not
        affine in the states other than clocks and constants plus a polynomial in those,
        or needs more than :data:`MAX_MONOMIALS` monomials."""
        if mode.affine:
            return None
        zs, us = mode.zsyms, mode.usyms
        clocks = [s for s, f in zip(zs, mode.flow, strict=True) if f == 1]
        slow = set(clocks) | {s for s, f in zip(zs, mode.flow, strict=True) if f == 0}
        found: dict[sp.Expr, None] = {}  # insertion-ordered set
        terms = []
        for f in mode.flow:
            split = _terms(f, zs + us, slow)
            if split is None:
                return None
            terms.append(split)
            for _, mono in split:
                if mono is not None:
                    found.setdefault(mono)
        queue = list(found)
        while queue:  # closed under d/dt: each clock's degree lowered by one
            rate = _rate(queue.pop(), clocks)
            split = _terms(rate, zs + us, slow)
            if split is None:  # cannot happen for a monomial in clocks and constants
                return None
            for _, mono in split:
                if mono is not None and mono not in found:
                    found.setdefault(mono)
                    queue.append(mono)
            if len(found) > MAX_MONOMIALS:
                return None
        if not found:
            return None
        monomials = tuple(found)
        extra = tuple(sp.Symbol(f"_lift{i}", real=True) for i in range(len(monomials)))
        rename = dict(zip(monomials, extra, strict=True))

        def renamed(split: list[tuple[sp.Expr, sp.Expr | None]]) -> sp.Expr:
            return sp.Add(*[c if m is None else c * rename[m] for c, m in split])

        flows = [renamed(s) for s in terms]
        for mono in monomials:
            split = _terms(_rate(mono, clocks), zs + us, slow)
            if split is None:  # the closure above split every rate: never reached
                return None
            flows.append(renamed(split))
        lifted_z = zs + extra
        flow = ModeSystem(mode.name, tuple(flows), lifted_z, us,
                          Rows([], lifted_z), mode.sigma_index, Rows([], lifted_z))
        if not flow.affine:  # a term the split missed: never lift unsoundly
            return None
        return ClockLift(n=len(zs), monomials=monomials, flow=flow,
                         _values=MeanValue(list(monomials), zs, ()))

    def lift(self, P: Zonotope) -> Zonotope | None:
        """A zonotope over ``(z, m)`` containing ``(z, mu(z))`` for every ``z`` in ``P``
        (``None`` where the enclosure of the monomials is not finite)."""
        a, lo, hi = self._values.affine_bounds(P)
        if not (np.all(np.isfinite(a)) and np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
            return None
        c, G = P.center, P.generators
        mid = 0.5 * (lo + hi)
        abs_a = np.abs(a)
        rad = up(0.5 * (hi - lo) + (hi - lo) * 1e-16
                 + product_error(abs_a, np.abs(c)) + product_error(abs_a, np.abs(G).sum(axis=1))
                 + np.spacing(np.abs(a @ c + mid)), 4)
        center = np.r_[c, a @ c + mid]
        q = len(self.monomials)
        gens = np.vstack([np.hstack([G, np.zeros((self.n, q))]),
                          np.hstack([a @ G, np.diag(rad)])])
        return Zonotope(center, gens)

    def project(self, Z: Zonotope) -> Zonotope:
        """``Z`` over ``(z, m)`` projected on ``z`` (its generators in the same order)."""
        return Zonotope(Z.center[:self.n], Z.generators[:self.n])


def _rate(mono: sp.Expr, clocks: list[sp.Symbol]) -> sp.Expr:
    """``d mono / dt`` for a monomial in clocks (rate 1) and constants (rate 0)."""
    return sp.expand(sp.Add(*[sp.diff(mono, k) for k in clocks]))


def _terms(expr: sp.Expr, ws: tuple[sp.Symbol, ...], slow: set[sp.Symbol]
           ) -> list[tuple[sp.Expr, sp.Expr | None]] | None:
    """``expr`` as ``sum coeff * mono``: ``mono`` is ``None`` for the affine part (a term of
    degree at most one, kept whole), else a monomial of degree two or more in ``slow``
    symbols only; ``None`` when some term is neither (or the coefficients are symbolic)."""
    expr = sp.expand(expr)
    if not expr.is_polynomial(*ws):
        return None
    out: list[tuple[sp.Expr, sp.Expr | None]] = []
    for monom, coeff in sp.Poly(expr, *ws).terms():
        if not coeff.is_number:
            return None
        factors = [w**k for w, k in zip(ws, monom, strict=True) if k]
        mono = sp.Mul(*factors)
        if sum(monom) <= 1:
            out.append((coeff * mono, None))
        elif all(w in slow for w, k in zip(ws, monom, strict=True) if k):
            out.append((coeff, mono))
        else:
            return None
    return out
