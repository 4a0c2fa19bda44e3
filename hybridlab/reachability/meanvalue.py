"""Enclosures of smooth functions over zonotopes by the mean-value form.

For ``w = (z, u)`` with ``z`` in the zonotope ``Z = c + G beta`` (``|beta_j| <= 1``) and
``u`` in a box with centre ``u_c`` and radius ``u_r``,

    f(w) = f(w_c) + J(xi) (w - w_c),

with ``xi`` on the segment from ``w_c`` to ``w``, inside the interval hull of ``Z`` and the
input box, so ``J(xi)`` lies in the interval Jacobian ``[J_mid - J_rad, J_mid + J_rad]``
over that hull. Then ``J(xi) (z - c) = (J_mid + D) G beta`` with ``|D| <= J_rad`` is at
most ``sum_j |(J_mid G)_j| + J_rad |G| 1`` in magnitude: the linear part keeps the
zonotope's correlations, which interval arithmetic over its hull loses. The result is
intersected with the plain interval enclosure over the hull, so it is never wider.

What it rests on: the outward-rounded interval arithmetic of
:mod:`hybridlab.symbolic.intervals` for ``f(w_c)`` and ``J``, and the matrix products
rounded up by :data:`~hybridlab.reachability.rounding.PRODUCT_SLACK` of the products of
magnitudes (far above the ``n * 2^-53`` a float dot product of ``n`` terms can be off by).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import sympy as sp

from hybridlab.reachability.derivatives import jacobian
from hybridlab.reachability.rounding import PRODUCT_SLACK, TINY
from hybridlab.reachability.sets import Zonotope
from hybridlab.symbolic.functions import _no_impulses
from hybridlab.symbolic.intervals import IntervalFunction

__all__ = ["MeanValue"]

class MeanValue:
    """Enclosures of ``f(z, u)`` over a zonotope of ``z`` and a box of ``u``.

    Parameters
    ----------
    exprs : sequence of sympy.Expr
        The functions.
    zsyms, usyms : sequence of sympy.Symbol
        The state and input symbols.

    Examples
    --------
    ``x - y`` over the thin diagonal zonotope ``x = y = b``: interval arithmetic over its
    hull gives ``[-2, 2]``, the mean-value form ``0`` up to its rounding slack:

    >>> x, y = sp.symbols("x y", real=True)
    >>> f = MeanValue([x - y, x * y], [x, y], [])
    >>> lo, hi = f(Zonotope([0.0, 0.0], [[1.0], [1.0]]), np.zeros(0), np.zeros(0))
    >>> bool(-1e-9 < lo[0] <= 0.0 <= hi[0] < 1e-9), bool(lo[1] <= 0.0 and hi[1] >= 1.0)
    (True, True)
    """

    def __init__(self, exprs: Sequence[sp.Expr], zsyms: Sequence[sp.Symbol],
                 usyms: Sequence[sp.Symbol], second_order: bool = False) -> None:
        wsyms = tuple(zsyms) + tuple(usyms)
        self.size = len(exprs)
        self.nz = len(zsyms)
        self.value = IntervalFunction([_no_impulses(e) for e in exprs], wsyms)
        jac = jacobian(list(exprs), wsyms)
        self.gradient = IntervalFunction([_no_impulses(e) for e in jac], wsyms)
        self.shape = (self.size, len(wsyms))
        self.hessian: IntervalFunction | None = None
        if second_order:
            entries = [_no_impulses(d) for row in jacobian(list(jac), wsyms).tolist()
                       for d in row]
            self.hessian = IntervalFunction(entries, wsyms)

    def __call__(self, Z: Zonotope, u_lo: np.ndarray, u_hi: np.ndarray,
                 box: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Enclosures ``(lo, hi)`` of every function over ``Z`` and ``[u_lo, u_hi]``
        (``box``: ``Z``'s interval hull, when the caller has it)."""
        box = Z.bounds() if box is None else box
        lo_w, hi_w = np.r_[box[:, 0], u_lo], np.r_[box[:, 1], u_hi]
        lo, hi = self.value(lo_w, hi_w)
        j_lo, j_hi = self.gradient(lo_w, hi_w)
        if not (np.all(np.isfinite(j_lo)) and np.all(np.isfinite(j_hi))):
            return lo, hi
        w_c = np.r_[Z.center, 0.5 * (u_lo + u_hi)]
        v_lo, v_hi = self.value(w_c, w_c)
        j_lo, j_hi = j_lo.reshape(self.shape), j_hi.reshape(self.shape)
        mid = 0.5 * (j_lo + j_hi)
        rad = np.nextafter(np.maximum(j_hi - mid, mid - j_lo), np.inf)
        G = Z.generators
        u_rad = np.nextafter(0.5 * (u_hi - u_lo), np.inf)
        nz = self.nz
        absG = np.abs(G)
        spread = (np.abs(mid[:, :nz] @ G).sum(axis=1) + (rad[:, :nz] @ absG).sum(axis=1)
                  + (np.abs(mid[:, nz:]) + rad[:, nz:]) @ u_rad)
        magnitude = ((np.abs(mid[:, :nz]) + rad[:, :nz]) @ absG).sum(axis=1) \
            + (np.abs(mid[:, nz:]) + rad[:, nz:]) @ u_rad
        with np.errstate(over="ignore", invalid="ignore"):
            spread = spread + PRODUCT_SLACK * magnitude + TINY
            mv_lo = np.nextafter(v_lo - spread, -np.inf)
            mv_hi = np.nextafter(v_hi + spread, np.inf)
        ok = np.isfinite(mv_lo) & np.isfinite(mv_hi)
        lo, hi = np.where(ok, np.maximum(lo, mv_lo), lo), np.where(ok, np.minimum(hi, mv_hi), hi)
        if self.hessian is not None:
            lo, hi = self._second_order(Z, u_lo, u_hi, lo, hi)
        return lo, hi

    def affine_bounds(self, Z: Zonotope, box: np.ndarray | None = None
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(a, lo, hi)`` with ``f_i(z) - a_i . z`` in ``[lo_i, hi_i]`` for every ``z`` in
        ``Z`` (functions of the states only): ``a`` is the interval Jacobian's midpoint
        over ``Z``'s hull, and the bounds take the value at the centre and the Jacobian's
        radius times the hull's reach from the centre (non-finite where the enclosures
        are).

        Examples
        --------
        ``x**2`` over ``[0.9, 1.1]``: ``a = 2`` and ``x**2 - 2 x`` in ``[-1.02, -0.98]``
        (its true range is ``[-1, -0.99]``):

        >>> x = sp.Symbol("x", real=True)
        >>> a, lo, hi = MeanValue([x**2], [x], []).affine_bounds(Zonotope([1.0], [[0.1]]))
        >>> a.round(9).tolist(), round(float(lo[0]), 9), round(float(hi[0]), 9)
        ([[2.0]], -1.02, -0.98)
        """
        box = Z.bounds() if box is None else box
        c = Z.center
        v_lo, v_hi = self.value(c, c)
        j_lo, j_hi = self.gradient(box[:, 0], box[:, 1])
        j_lo, j_hi = j_lo.reshape(self.shape), j_hi.reshape(self.shape)
        mid = 0.5 * (j_lo + j_hi)
        rad = np.nextafter(np.maximum(j_hi - mid, mid - j_lo), np.inf)
        dev = np.nextafter(np.maximum(box[:, 1] - c, c - box[:, 0]), np.inf)
        with np.errstate(over="ignore", invalid="ignore"):
            at_c = mid @ c
            spread = rad @ dev + PRODUCT_SLACK * (np.abs(mid) @ np.abs(c)) + TINY
            lo = np.nextafter(v_lo - at_c - spread, -np.inf)
            hi = np.nextafter(v_hi - at_c + spread, np.inf)
        return mid, lo, hi

    def _second_order(self, Z: Zonotope, u_lo: np.ndarray, u_hi: np.ndarray,
                      lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``f(w_c) + J(w_c) d + d' Hess d / 2`` over ``d = w - w_c``: the Jacobian at
        the centre keeps the zonotope's correlations where the Jacobian over its hull
        varies (a gain that depends on an angle, times deviations that cancel)."""
        form = self.linear_form(Z, u_lo, u_hi)
        if form is None:
            return lo, hi
        v_lo, v_hi, grad, slack = form
        with np.errstate(over="ignore", invalid="ignore"):
            spread = np.abs(grad @ Z.generators).sum(axis=1) * (1 + PRODUCT_SLACK) + slack
            so_lo = np.nextafter(v_lo - spread, -np.inf)
            so_hi = np.nextafter(v_hi + spread, np.inf)
        ok = np.isfinite(so_lo) & np.isfinite(so_hi)
        return np.where(ok, np.maximum(lo, so_lo), lo), np.where(ok, np.minimum(hi, so_hi), hi)

    def linear_form(self, Z: Zonotope, u_lo: np.ndarray, u_hi: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
        """``(v_lo, v_hi, grad, slack)`` with ``f_i(z, u)`` in
        ``[v_lo_i - slack_i, v_hi_i + slack_i] + grad_i . (z - c)`` for every ``z`` in
        ``Z`` (centre ``c``) and ``u`` in its box: the value and the state gradient at the
        centre, and a bound of the rest (the inputs' and the gradient's spread, the
        second-order term over the zonotope). ``None`` without a Hessian, or where the
        enclosures are not finite."""
        from hybridlab.reachability.nonlinear import _deviations, _quadratic_bound
        if self.hessian is None:
            return None
        box = Z.bounds()
        lo_w, hi_w = np.r_[box[:, 0], u_lo], np.r_[box[:, 1], u_hi]
        w_c = np.r_[Z.center, 0.5 * (u_lo + u_hi)]
        nw = lo_w.size
        h_lo, h_hi = self.hessian(lo_w, hi_w)
        v_lo, v_hi = self.value(w_c, w_c)
        g_lo, g_hi = self.gradient(w_c, w_c)
        if not all(np.all(np.isfinite(a)) for a in (h_lo, h_hi, v_lo, v_hi, g_lo, g_hi)):
            return None
        g_lo, g_hi = g_lo.reshape(self.shape), g_hi.reshape(self.shape)
        mid = 0.5 * (g_lo + g_hi)
        rad = np.nextafter(np.maximum(g_hi - mid, mid - g_lo), np.inf)
        u_rad = np.nextafter(0.5 * (u_hi - u_lo), np.inf)
        nz = self.nz
        absG = np.abs(Z.generators)
        D = _deviations(Z, Z.center, u_rad)
        D_full = np.zeros((nw, D.shape[1]))
        D_full[:D.shape[0]] = D
        delta = np.maximum(np.abs(lo_w - w_c), np.abs(hi_w - w_c))
        quad = _quadratic_bound(h_lo.reshape(self.size, nw, nw),
                                h_hi.reshape(self.size, nw, nw), D_full, delta)
        with np.errstate(over="ignore", invalid="ignore"):
            slack = ((rad[:, :nz] @ absG).sum(axis=1)
                     + (np.abs(mid[:, nz:]) + rad[:, nz:]) @ u_rad
                     + PRODUCT_SLACK * ((np.abs(mid[:, :nz]) @ absG).sum(axis=1)) + quad)
        if not np.all(np.isfinite(slack)):
            return None
        return v_lo, v_hi, mid[:, :nz], np.nextafter(slack, np.inf)
