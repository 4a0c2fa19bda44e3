"""The linearisation remainder to third order, with the set's correlations kept.

The Lagrange remainder of a linearisation at ``w*``, ``1/2 d' Hess(xi) d`` with ``d = w - w*``,
is bounded by :mod:`~hybridlab.reachability.nonlinear` from the Hessian's enclosure over the
step set's box: its centre part over the zonotope (correlations kept), its radius part
``1/2 sum rad_jk |d_j| |d_k|`` over the box. Where a nonlinear factor multiplies a stiff
linear one, that radius part is what counts: a cart's position controller, whose force
``F = 59,200 N/m (x_ref - x) + ...`` acts on a pendulum it carries through ``cos(phi)``, so
``d2 omega' / d phi d x`` and ``d2 omega' / d phi d x_ref`` vary with ``phi`` across the box
and their radius parts add ``|d x| + |d x_ref|`` (millimetres) where the two terms cancel to
``|d (x_ref - x)|`` (micrometres). On a braking set of such a cart that part is 34 times the
centre part.

One order further, with the Hessian at ``w*`` exactly and the third derivatives
``T_jkl`` enclosed over the box::

    f(w) = f(w*) + J d + 1/2 d' Hess(w*) d + 1/6 sum_jkl T_jkl(xi) d_j d_k d_l.

The quadratic term is bounded over the zonotope as before (its Hessian now a point). The cubic
term is a sum over the monomials ``d_j d_k d_l`` (``j <= k <= l``, each with its multiplicity);
each monomial is read as ``(d_j d_k) * d_l`` with ``l`` an index the flow is affine in where
there is one (else one that is not repeated), and the monomials that share their pair ``j, k``
form one linear form ``L_jk(d) = sum_l c_jkl d_l``, bounded over the zonotope exactly (its
support function), so that ``c_jkx d_x + c_jkx_ref d_x_ref`` cancels as the set's correlation
allows; the pair is bounded by the box, ``|d_j d_k| <= delta_j delta_k``. The enclosures'
radii ``rad T_jkl`` count over the box, a term of fourth order. The bound is used where it is
smaller than the second-order one, row by row; both are sound.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sp

from hybridlab.reachability.derivatives import Derivatives
from hybridlab.reachability.rounding import PRODUCT_SLACK, SLACK
from hybridlab.symbolic.intervals import IntervalFunction

__all__ = ["ThirdOrder"]


@dataclass(frozen=True, eq=False)
class ThirdOrder:
    """The third derivatives of a flow, grouped for :meth:`bound`.

    Attributes
    ----------
    function : IntervalFunction
        Enclosure of every nonzero ``d3 f_i / dw_j dw_k dw_l`` with ``j <= k <= l``.
    rows, first, second, linear : numpy.ndarray of int
        For each entry: ``i``, the pair read as the product ``d_j d_k`` and the index ``l``
        of its linear factor.
    multiplicity : numpy.ndarray
        How many orderings of ``(j, k, l)`` the entry stands for (1, 3 or 6).
    group : numpy.ndarray of int
        For each entry, its linear form ``L_jk`` of row ``i``.
    group_rows : numpy.ndarray of int
        The row ``i`` of each linear form.

    Examples
    --------
    ``x' = x^2 y``: the third derivatives are ``d3/dx2 dy = 2`` (three orderings) and
    nothing else; ``y`` is the index the flow is affine in, so the monomial is read as
    ``x^2 * y``:

    >>> x, y = sp.symbols("x y", real=True)
    >>> from hybridlab.reachability.derivatives import jacobian
    >>> third = ThirdOrder.of(jacobian([x**2 * y, -y], [x, y]), [x, y])
    >>> third.function.exprs, third.multiplicity.tolist(), third.linear.tolist()
    ((2,), [3.0], [1])
    >>> D = np.array([[0.1, 0.0], [0.0, 0.2]])      # d = D beta, |beta| <= 1
    >>> delta = np.abs(D).sum(axis=1)
    >>> third.bound(np.zeros(2), np.ones(2), D, delta, 2).round(6).tolist()
    [0.002, 0.0]
    """

    function: IntervalFunction
    rows: np.ndarray
    first: np.ndarray
    second: np.ndarray
    linear: np.ndarray
    multiplicity: np.ndarray
    group: np.ndarray
    group_rows: np.ndarray

    @staticmethod
    def of(jac: sp.Matrix, wsyms: list[sp.Symbol] | tuple[sp.Symbol, ...],
           derivatives: Derivatives | None = None) -> ThirdOrder | None:
        """The third derivatives over ``wsyms`` of the flow whose Jacobian is ``jac``
        (``d f_i / d w_j``, impulses dropped), taken through ``derivatives`` (the ones the
        flow's Hessian took are not taken again); ``None`` when all are zero."""
        d = Derivatives() if derivatives is None else derivatives
        ws = list(wsyms)
        entries: list[tuple[int, int, int, int, sp.Expr]] = []
        curved = set()  # indices j with some d2 f_i / dw_j^2 != 0: the flow is not affine in them
        for i in range(jac.rows):
            for j in range(len(ws)):
                dj = jac[i, j]
                free = dj.free_symbols
                for k in range(j, len(ws)):
                    if ws[k] not in free:
                        continue
                    djk = d.of(dj, ws[k])
                    if k == j and djk != 0:
                        curved.add(j)
                    free_jk = djk.free_symbols
                    for m in range(k, len(ws)):
                        if ws[m] in free_jk:
                            d3 = d.of(djk, ws[m])
                            if d3 != 0:
                                entries.append((i, j, k, m, d3))
        if not entries:
            return None
        rows, first, second, linear, mult = [], [], [], [], []
        for i, j, k, m, _ in entries:
            triple = [j, k, m]
            distinct = len(set(triple))
            mult.append({1: 1.0, 2: 3.0, 3: 6.0}[distinct])
            affine = [t for t in triple if t not in curved]
            single = [t for t in triple if triple.count(t) == 1]
            lin = affine[-1] if affine else (single[-1] if single else triple[-1])
            rest = list(triple)
            rest.remove(lin)
            rows.append(i)
            first.append(rest[0])
            second.append(rest[1])
            linear.append(lin)
        keys = list(zip(rows, first, second, strict=True))
        index = {key: g for g, key in enumerate(dict.fromkeys(keys))}
        return ThirdOrder(
            function=IntervalFunction([e for *_, e in entries], ws),
            rows=np.array(rows), first=np.array(first), second=np.array(second),
            linear=np.array(linear), multiplicity=np.array(mult),
            group=np.array([index[key] for key in keys]),
            group_rows=np.array([key[0] for key in index], dtype=int))

    def bound(self, lo: np.ndarray, hi: np.ndarray, D: np.ndarray, delta: np.ndarray,
              n_rows: int) -> np.ndarray:
        """Bound per row of ``|1/6 sum_jkl T_jkl(xi) d_j d_k d_l|`` for ``xi`` in the box
        ``[lo, hi]`` and ``d = D beta`` (``|beta| <= 1``), ``|d| <= delta``.

        Non-finite where an enclosure is (the caller keeps its other bound there)."""
        t_lo, t_hi = self.function(lo, hi)
        mid = 0.5 * (t_lo + t_hi)
        rad = np.nextafter(np.maximum(t_hi - mid, mid - t_lo), np.inf)
        out = np.zeros(n_rows)
        j, k, m = self.first, self.second, self.linear
        with np.errstate(over="ignore", invalid="ignore"):
            np.add.at(out, self.rows, self.multiplicity * rad * delta[j] * delta[k] * delta[m])
            coef = np.zeros((self.group_rows.size, D.shape[0]))
            np.add.at(coef, (self.group, m), self.multiplicity * mid)
            forms = np.abs(coef @ D).sum(axis=1)
            # rounding of the products, relative to the products of magnitudes
            forms += PRODUCT_SLACK * (np.abs(coef) @ np.abs(D)).sum(axis=1)
            pair = np.zeros(self.group_rows.size)
            pair[self.group] = delta[j] * delta[k]
            np.add.at(out, self.group_rows, forms * pair)
        return np.nextafter(out / 6.0 * (1 + SLACK), np.inf)

