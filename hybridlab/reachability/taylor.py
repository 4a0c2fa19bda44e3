"""Taylor-model flowpipes for nonlinear modes (Makino and Berz; Chen, Abraham, Sankaranarayanan).

A *Taylor model* of a state ``x`` is a polynomial ``p(s, q, tau)`` plus an interval
``[-rho, rho]``: for every point of the set there are ``s in [-1, 1]^m``,
``q in [-1, 1]^n`` and ``e in [-rho, rho]`` with ``x = p(s, q, tau) + e`` at the
normalised time ``tau in [0, 1]`` of a step. The variables are

* ``s_1 .. s_m``: one per generator of the zonotope the flowpipe starts from (the
  normalised initial set); polynomials in ``s`` up to the *space order* ``kq``
  carry the nonlinear dependence of the flow on the initial state, so a wide
  initial set bent by the flow is not boxed at every step;
* ``q_1 .. q_r``: the accumulated truncation and rounding errors, linear in ``q``
  and times ``s`` up to degree :data:`ERROR_CROSS_DEGREE` (see *the accumulated
  error* below);
* ``tau``: time within the step, up to the *time order* ``kt``.

A monomial is kept when its ``tau``-degree is at most ``kt`` and it is either free of
``q`` with ``s``-degree at most ``kq``, or a single ``q_i`` times ``s``-degree at most
:data:`ERROR_CROSS_DEGREE`; every other product term is *truncated*: its range over the
domain goes into the interval part.

**One step** (:meth:`TaylorFlowpipe.step`, after Makino and Berz 2003 and Flow*):
the polynomial part is ``kt`` Picard iterations ``x <- x0 + h int_0^tau f(x)`` in
truncated polynomial arithmetic; the interval part is then *validated*: with a
candidate ``rho``, the Picard operator is applied to ``p + [-rho, rho]`` in Taylor
model arithmetic, giving ``p' + [-rho', rho']``; if ``|p' - p| + rho' <= rho``
(``|.|`` a bound of the polynomial's range) the operator maps the set of functions
``p + [-rho, rho]`` into itself, so by Schauder's fixed point theorem and the
uniqueness of solutions of a locally Lipschitz ODE every solution from the start
set stays in it, and also in ``p + [-need, need]``, ``need = |p' - p| + rho'``
(the image of a subset is a subset of the image). Otherwise ``rho`` is enlarged
and the check repeated, at most :data:`VALIDATION_ATTEMPTS` times; then the step
fails with :class:`TaylorError` (the stepper raises ``RemainderError``, so the
callers' refinements -- smaller step, split initial set -- apply).

**The accumulated error** is a zonotope ``M q`` of at most :data:`ERROR_ORDER`
generators per state: at the end of a step the interval part joins it as a box, and
Girard's method boxes the generators a box encloses with the least loss when there are
more (:func:`_errors`). Within a step the flow's linear part maps ``M q`` exactly, so
the large old generators keep their directions and the error contracts where the flow
does; only the smallest ones are boxed again. (Re-enclosing the whole error in one
parallelepiped at every step, Lohner's QR method, wraps it by a few per cent per step
on Laub-Loomis, which compounds to ``e^12`` over its horizon.)

**Soundness rests on** (each operation adds the bound of its own rounding to the
interval part, so the computed model encloses the exact one):

* IEEE double arithmetic with round to nearest: a sum or dot product of ``k``
  terms is within ``gamma(k) = k u / (1 - k u)`` times the sum of the absolute
  terms (:mod:`hybridlab.reachability.rounding`); every monomial is at most 1 in
  absolute value over the domain, so the error of a whole polynomial is at most
  ``gamma`` times the sum of its absolute coefficients;
* ``math.sin``, ``math.cos``, ``math.exp`` accurate to one unit in the last place
  (glibc's documented bound), widened here by the rounding policy of
  :mod:`hybridlab.symbolic.interval_arithmetic` (64 units plus ``1e-300``);
* the Lagrange form of the Taylor remainder for ``sin``, ``cos``, ``exp`` and
  ``1 / x`` (derivatives bounded by 1, by ``exp`` of the upper end, by
  ``1 / min |x|^(k+2)`` of a range that excludes 0);
* constants of the flow: integers exact, other numbers widened by a few units.

The flow's sympy expressions are walked node by node into a program of Taylor-model
operations (``+ - *``, integer powers, ``sin cos exp``, reciprocals); model text is
never evaluated. Anything else (``sqrt``, ``abs``, ...) is a :class:`TaylorError`
when the program is built, and the stepper keeps conservative linearisation.

Examples
--------
``x' = -x`` from ``[0.9, 1.1]`` over one step of 0.1: the end set encloses
``x e^{-0.1}`` tightly.

>>> import sympy as sp
>>> x = sp.Symbol("x")
>>> pipe = TaylorFlowpipe([-x], [x])
>>> X0 = pipe.start(Zonotope([1.0], [[0.1]]))
>>> X1, end, segment = pipe.step(X0, 0.1)
>>> lo, hi = end.bounds()[0]
>>> exact = np.exp(-0.1) * np.array([0.9, 1.1])
>>> bool(lo <= exact[0] and exact[1] <= hi and hi - lo < (exact[1] - exact[0]) * (1 + 1e-9))
True
>>> segment.bounds()[0].round(3).tolist()   # the states over the step: [0.814, 1.1]
[0.799, 1.106]
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import sympy as sp

from hybridlab.errors import HybridlabError
from hybridlab.reachability.rounding import TINY, U, gamma, up
from hybridlab.reachability.sets import Zonotope
from hybridlab.symbolic.interval_arithmetic import WIDEN

__all__ = ["TaylorError", "TaylorFlowpipe", "TaylorSet", "bend", "orders"]

VALIDATION_ATTEMPTS = 10
"""Enlargements of the candidate interval part before a step fails."""

_REFINEMENTS = 2
"""Picard images of a validated interval part taken to tighten it (each is again an
enclosure: the solution is its own image)."""

TIME_ORDER = 6
"""Degree in time within a step. The Picard iterate is exact in ``tau`` to this degree,
so a step's truncation error is of order ``(h |J|)^7 / 7!``: at the default steps
(horizon / 400) of Van der Pol (0.0175) and Laub-Loomis (0.05) that is far below the
rounding, while each further degree costs one more Picard iteration."""

ERROR_ORDER = 6
"""The accumulated errors are a zonotope of at most this many generators per state (the
``q`` variables); each step's interval part joins them as a box, and Girard's method
boxes the smallest ones beyond that. The large old ones keep their directions, which
the flow's linear part maps exactly, so the error is not re-wrapped at every step. With
3 instead of 6, a sixteenth of the coupled Van der Pol box (``b`` in [2.5, 3], ``x1``,
``x2`` in [1.4, 1.55]) at space order 4 bounds ``y1`` by 2.823 instead of 2.737 (the
limit is 2.75; sampled 2.69), and the half ``b`` in [1, 2] at order 5 blows up at
t = 6.8 instead of completing; Laub-Loomis (seven states) takes 40 % longer with 6."""

ERROR_CROSS_DEGREE = 1
"""The error variables are kept times the initial-set variables up to this degree
(``q_i``, ``q_i s_j``): the flow's Jacobian varies over the set, and a product of an
error with that variation is then carried instead of bounded at every step (on
Laub-Loomis with ``W = 0.1`` the set at ``t = 20`` is half as wide, for a quarter more
time per step)."""

_S_MONOMIALS = 120
"""Most monomials in the initial-set variables ``s`` (the cost of a product grows with the
square of the monomial count, and the space order trades against the variable count)."""


def orders(m: int, space_order: int | None = None) -> tuple[int, int]:
    """``(kq, kt)``: the space and time orders for ``m`` initial-set variables.

    The space order is the highest (at most 7) whose number of monomials in ``m``
    variables stays within 120: 7 for up to 3 variables (Van der Pol's box), 4 for 4,
    3 for 5 to 7 (Laub-Loomis's 7), 2 for 8 to 13, 1 beyond. The set's deviation from its
    polynomial model is of the order of its width to the power ``kq + 1``, so a
    quadratic model already takes the curvature that conservative linearisation pays
    for in its remainder; higher orders matter over long horizons where the set bends
    further.

    Examples
    --------
    ``space_order``, when given, is taken as it is.

    >>> orders(2), orders(7), orders(5, space_order=5)
    ((7, 6), (3, 6), (5, 6))
    """
    if space_order is not None:
        return space_order, TIME_ORDER
    kq = 7
    while kq > 1 and math.comb(m + kq, kq) > _S_MONOMIALS:
        kq -= 1
    return kq, TIME_ORDER


class TaylorError(HybridlabError, ArithmeticError):
    """A Taylor-model step cannot be taken: the interval part does not validate, a divisor's
    range contains 0, an expression is not supported, or a number overflows.

    Examples
    --------
    >>> x = sp.Symbol("x")
    >>> TaylorFlowpipe([sp.sqrt(x)], [x])
    Traceback (most recent call last):
    ...
    hybridlab.reachability.taylor.TaylorError: Taylor models do not support sqrt(x) (Pow with a
    non-integer exponent)
    """


def _up(x: float, k: int = 4) -> float:
    """``x >= 0`` enlarged to cover ``k - 1`` roundings of a sum of non-negative terms."""
    return float(x) * (1.0 + gamma(k)) + TINY


@dataclass(frozen=True, eq=False)
class _Basis:
    """The kept monomials in ``(s, q, tau)`` and the index lists of their products."""

    m: int
    n: int
    kq: int
    kt: int
    exps: np.ndarray  # (M, m + n + 1) exponents; row 0 is the constant
    even: np.ndarray  # (M,) whether every s and q exponent is even (range [0, 1])
    even_index: np.ndarray  # the indices of the even monomials but the constant
    tau: np.ndarray  # (M,) tau exponent
    q_groups: np.ndarray  # (n, G) indices of q_i s^alpha (tau^0), q_i first
    s_index: np.ndarray  # (m,) index of s_j (tau^0)
    keep_i: np.ndarray  # the kept products a_i b_j: i ...
    keep_j: np.ndarray  # ... j ...
    keep_target: np.ndarray  # ... the monomial each lands on ...
    keep_even: np.ndarray  # ... and the indices of those that are even
    parity: np.ndarray  # (M,) class of the monomial's s and q exponents modulo 2
    classes: int  # number of parity classes (a product is even iff both share one)
    truncates: bool  # whether some products are truncated
    pairs_per_target: int  # most products summed into one coefficient

    @property
    def size(self) -> int:
        return self.exps.shape[0]

    @property
    def q_index(self) -> np.ndarray:
        """(n,) index of each ``q_i`` alone (tau^0)."""
        return self.q_groups[:, 0]


def _codes(e: np.ndarray, m: int, n: int, kq: int) -> np.ndarray:
    """An integer per ``(s, q)`` exponent vector, unique among products of two kept ones:
    the ``s`` exponents (each at most ``2 kq``) in base ``2 kq + 1``, then which ``q``
    (products of two ``q`` collide, but they are never kept)."""
    base = 2 * max(kq, 1) + 1
    if m * math.log2(base) + math.log2(n + 2) > 62:
        raise TaylorError(f"too many Taylor-model variables ({m} + {n})")
    s_code = e[..., :m] @ (base ** np.arange(m, dtype=np.int64))
    q_code = e[..., m:m + n] @ np.arange(1, n + 1, dtype=np.int64)
    return s_code * (n + 2) + np.minimum(q_code, n + 1)


@functools.lru_cache(maxsize=64)
def _basis(m: int, n: int, kq: int, kt: int, kx: int) -> _Basis:
    """The monomials ``s^alpha tau^a`` (``|alpha| <= kq``) and ``q_i s^alpha tau^a``
    (``|alpha| <= kx``), ``a <= kt``, with every product of two of them that is kept
    (the same degrees, and at most one ``q``)."""
    def powers(degree: int) -> list[list[int]]:
        out = []
        for d in range(degree + 1):
            for combo in itertools.combinations_with_replacement(range(m), d):
                e = [0] * (m + n)
                for j in combo:
                    e[j] += 1
                out.append(e)
        return out

    betas = powers(kq)
    crosses = powers(kx)
    for i in range(n):
        for e in crosses:
            betas.append(e[:m] + [int(k == i) for k in range(n)])
    beta = np.array(betas, dtype=np.int64).reshape(len(betas), m + n)
    T = kt + 1
    # beta outer, tau inner: index = beta * (kt + 1) + a, so integration is index + 1
    exps = np.hstack([np.repeat(beta, T, axis=0), np.tile(np.arange(T), len(betas))[:, None]])
    # the kept products, first of the beta parts ...
    P = beta[:, None, :] + beta[None, :, :]
    sdeg, qdeg = P[..., :m].sum(-1), P[..., m:].sum(-1)
    valid = ((qdeg == 0) & (sdeg <= kq)) | ((qdeg == 1) & (sdeg <= kx))
    codes = _codes(beta, m, n, kq)
    order = np.argsort(codes)
    bi, bj = np.nonzero(valid)
    bk = order[np.searchsorted(codes[order], _codes(P[bi, bj], m, n, kq))]
    # ... then of the tau parts: a1 + a2 <= kt
    a1, a2 = (v.ravel() for v in np.meshgrid(np.arange(T), np.arange(T), indexing="ij"))
    ok = a1 + a2 <= kt
    a1, a2 = a1[ok], a2[ok]
    keep_i = (bi[:, None] * T + a1[None, :]).ravel()
    keep_j = (bj[:, None] * T + a2[None, :]).ravel()
    keep_target = (bk[:, None] * T + (a1 + a2)[None, :]).ravel()
    _, parity = np.unique(exps[:, :m + n] % 2, axis=0, return_inverse=True)
    parity = parity.ravel()
    idx = {tuple(e): k for k, e in enumerate(exps.tolist())}
    unit = np.eye(m + n, dtype=np.int64)
    s_index = np.array([idx[tuple(unit[j]) + (0,)] for j in range(m)], dtype=np.int64)
    first_q = len(betas) - n * len(crosses)
    q_groups = ((first_q + np.arange(n)[:, None] * len(crosses)
                 + np.arange(len(crosses))[None, :]) * T).astype(np.int64)
    M = exps.shape[0]
    even = np.all(exps[:, :m + n] % 2 == 0, axis=1)
    return _Basis(m, n, kq, kt, exps, even, np.flatnonzero(even[1:]) + 1, exps[:, -1],
                  q_groups, s_index, keep_i, keep_j, keep_target,
                  np.flatnonzero(parity[keep_i] == parity[keep_j]), parity,
                  int(parity.max()) + 1,
                  keep_i.size < M * M,
                  int(np.max(np.bincount(keep_target, minlength=M))))


# ----- Taylor-model arithmetic: a model is (coefficients, radius) over one basis ---------
TM = tuple[np.ndarray, float]


def _centred(lo: float, hi: float) -> tuple[float, float]:
    """``(mid, rad)`` with ``[lo, hi]`` inside ``mid +- rad``."""
    mid = 0.5 * (lo + hi)
    return mid, _up(max(hi - mid, mid - lo) + 4 * U * (abs(lo) + abs(hi)), 4)


def _range(B: _Basis, c: np.ndarray) -> tuple[float, float]:
    """An enclosure of the polynomial's range over the domain (monomials bounded one by
    one: ``[0, 1]`` when every s and q exponent is even, ``[-1, 1]`` otherwise)."""
    # every term spans [-|c_k|, |c_k|] but an even one's, which spans [min(c_k, 0),
    # max(c_k, 0)]: |c_k| less max(-c_k, 0) above and less max(c_k, 0) below
    spread = float(np.sum(np.abs(c[1:])))
    even = c[B.even_index]
    above, below = float(np.sum(np.maximum(even, 0.0))), float(np.sum(np.maximum(-even, 0.0)))
    # three sums of at most M terms and the four operations below, relative to |c|_1
    err = _up(gamma(3 * B.size + 8) * (abs(c[0]) + spread), 4)
    hi = math.nextafter(float(c[0]) + (spread - below) + err, math.inf)
    lo = math.nextafter(float(c[0]) - (spread - above) - err, -math.inf)
    return lo, hi


def _mag(B: _Basis, c: np.ndarray) -> float:
    lo, hi = _range(B, c)
    return max(-lo, hi)


def _add(B: _Basis, a: TM, b: TM) -> TM:
    c = a[0] + b[0]
    return c, _up(a[1] + b[1] + U * float(np.sum(np.abs(c))), 4)


def _neg(a: TM) -> TM:
    return -a[0], a[1]


def _scale(B: _Basis, a: TM, k: float, k_rad: float) -> TM:
    """``(k +- k_rad) * a``."""
    c = k * a[0]
    rad = abs(k) * a[1] + (k_rad * (_mag(B, a[0]) + a[1]) if k_rad else 0.0)
    return c, _up(rad + U * float(np.sum(np.abs(c))), 6)


def _add_const(a: TM, k: float, k_rad: float) -> TM:
    c = a[0].copy()
    c[0] += k
    return c, _up(a[1] + k_rad + U * abs(c[0]), 4)


def _const(B: _Basis, k: float, k_rad: float) -> TM:
    c = np.zeros(B.size)
    c[0] = k
    return c, k_rad


def _mul(B: _Basis, a: TM, b: TM, rough: bool = False) -> TM:
    """``a * b``; ``rough``: the kept terms only, no interval part (not an enclosure)."""
    prod = np.take(a[0], B.keep_i) * np.take(b[0], B.keep_j)
    c = np.bincount(B.keep_target, weights=prod, minlength=B.size)
    if rough:
        return c, 0.0
    cross = ((_mag(B, a[0]) * b[1] if b[1] else 0.0) + (_mag(B, b[0]) * a[1] if a[1] else 0.0)
             + a[1] * b[1])
    # every coefficient is a sum of at most pairs_per_target rounded products, and the
    # absolute products sum to at most |a|_1 |b|_1
    norms = float(np.sum(np.abs(a[0]))) * float(np.sum(np.abs(b[0])))
    rad = cross + gamma(B.pairs_per_target + 4) * _up(norms, 4)
    if B.truncates:
        lo, hi = _truncated(B, a[0], b[0], prod)
        mid, half = _centred(lo, hi)
        c[0] += mid
        rad += half + U * abs(c[0])
    if not (np.all(np.isfinite(c)) and math.isfinite(rad)):
        raise TaylorError("a Taylor-model product overflows (the set has blown up)")
    return c, _up(rad, 8)


def _truncated(B: _Basis, a: np.ndarray, b: np.ndarray, kept: np.ndarray) -> tuple[float, float]:
    """An enclosure ``(lo, hi)`` of the truncated products ``sum a_i b_j mono_i mono_j``
    over the domain, given the kept products ``kept`` (in the order of ``B.keep_i``).

    An even product monomial ranges over ``[0, 1]``, so its term lies between 0 and
    ``a_i b_j``; any other over ``[-1, 1]``. The sums over *all* pairs are cheap by
    parity class (a product is even exactly when both factors share a class); the
    truncated sums are those minus the kept ones, each a sum of non-negative rounded
    products, so ``g (total + kept)`` covers the rounding of both and of the products.
    """
    # the sums of non-negative terms below: over the M monomials' classes, and over the
    # kept products twice (all of them, the even ones), whose difference is the odd ones'
    g = gamma(2 * B.keep_i.size + 2 * B.size + 10)
    ap, an = np.maximum(a, 0.0), np.maximum(-a, 0.0)
    bp, bn = np.maximum(b, 0.0), np.maximum(-b, 0.0)
    n = B.classes
    sap, san = np.bincount(B.parity, ap, n), np.bincount(B.parity, an, n)
    sbp, sbn = np.bincount(B.parity, bp, n), np.bincount(B.parity, bn, n)
    even_hi = float(sap @ sbp + san @ sbn)  # sum of max(a_i b_j, 0) over even pairs
    even_lo = float(sap @ sbn + san @ sbp)  # sum of max(-a_i b_j, 0) over even pairs
    total = float(np.sum(ap + an)) * float(np.sum(bp + bn))
    even = kept[B.keep_even]
    kept_hi = float(np.sum(np.maximum(even, 0.0)))
    kept_lo = float(np.sum(np.maximum(-even, 0.0)))
    kept_odd = max(0.0, float(np.sum(np.abs(kept))) - (kept_hi + kept_lo))

    def rest(whole: float, part: float) -> float:
        return max(0.0, _up(whole - part + g * (whole + part), 4))

    drop_hi, drop_lo = rest(even_hi, kept_hi), rest(even_lo, kept_lo)
    drop_odd = rest(total, even_hi + even_lo + kept_odd)
    return -_up(drop_lo + drop_odd, 2), _up(drop_hi + drop_odd, 2)


def _pow(B: _Basis, a: TM, k: int, rough: bool = False) -> TM:
    result: TM | None = None
    base = a
    while k:
        if k & 1:
            result = base if result is None else _mul(B, result, base, rough)
        k >>= 1
        if k:
            base = _mul(B, base, base, rough)
    return result if result is not None else _const(B, 1.0, 0.0)


def _series(B: _Basis, a: TM, coefs: Sequence[tuple[float, float]], lagrange: float,
            rough: bool) -> TM:
    """``sum_k coefs[k] (a - a_0)^k + [-lagrange, lagrange]`` by Horner's scheme."""
    y = (a[0].copy(), a[1])
    y[0][0] = 0.0
    k, k_rad = coefs[-1]
    result = _const(B, k, k_rad)
    for k, k_rad in reversed(coefs[:-1]):
        result = _add_const(_mul(B, result, y, rough), k, k_rad)
    return result[0], _up(result[1] + lagrange, 4)


def _deviation(B: _Basis, a: TM) -> float:
    """A bound of ``|a - a_0|`` over the domain (``a_0`` the constant coefficient)."""
    c = a[0].copy()
    c[0] = 0.0
    return _up(_mag(B, c) + a[1], 4)


def _order(B: _Basis, y: float, factorial: bool = True) -> int:
    """Degree of an elementary function's series over a deviation ``|a - a_0| <= y``: up
    to every kept monomial's total degree, and no further than where ``y^(K+1) / (K+1)!``
    (or ``y^(K+1)`` without ``factorial``; the Lagrange remainder's size) falls below
    ``1e-17``. Any degree is sound: the remainder is always added."""
    degree = 1
    term = y * y / (2 if factorial else 1)
    while term > 1e-17 and degree < B.kq + B.kt:
        degree += 1
        term *= y / (degree + 1 if factorial else 1)
    return degree


def _libm(v: float) -> float:
    """The error bound assumed for a ``math`` function's result ``v``: the rounding
    policy's widening (:mod:`hybridlab.symbolic.interval_arithmetic`)."""
    return WIDEN * abs(v) + TINY


def _sin_cos(B: _Basis, a: TM, cosine: bool, rough: bool = False) -> TM:
    c0 = float(a[0][0])
    y = _deviation(B, a)
    K = _order(B, y)
    s, co = math.sin(c0), math.cos(c0)
    cycle = (co, -s, -co, s) if cosine else (s, co, -s, -co)
    coefs = []
    fact = 1.0
    for k in range(K + 1):
        fact *= max(k, 1)
        v = cycle[k % 4]
        coefs.append((v / fact, _up((_libm(v) + U * abs(v)) / fact, 4)))
    lagrange = _up(y ** (K + 1) / math.factorial(K + 1), K + 6)
    return _series(B, a, coefs, lagrange, rough)


def _exp(B: _Basis, a: TM, rough: bool = False) -> TM:
    c0 = float(a[0][0])
    y = _deviation(B, a)
    K = _order(B, y)
    try:
        e = math.exp(c0)
        top = math.exp(math.nextafter(c0 + y, math.inf))
    except OverflowError as exc:
        raise TaylorError("exp overflows over a Taylor model's range") from exc
    coefs = []
    fact = 1.0
    for k in range(K + 1):
        fact *= max(k, 1)
        coefs.append((e / fact, _up((_libm(e) + U * e) / fact, 4)))
    lagrange = _up((top + _libm(top)) * y ** (K + 1) / math.factorial(K + 1), K + 6)
    return _series(B, a, coefs, lagrange, rough)


def _reciprocal(B: _Basis, a: TM, rough: bool = False) -> TM:
    c0 = float(a[0][0])
    y = _deviation(B, a)
    gap = (abs(c0) - y) * (1 - 4 * U)
    if not gap > 0:
        raise TaylorError(f"a divisor's range [{c0 - y:.6g}, {c0 + y:.6g}] contains 0")
    K = _order(B, y / gap, factorial=False)
    inv = 1.0 / c0
    coefs = []
    v = inv
    for k in range(K + 1):
        coefs.append((v, _up(gamma(k + 3) * abs(v), 4)))
        v = -v * inv
    lagrange = _up(y ** (K + 1) / gap ** (K + 2), 2 * K + 8)
    if not math.isfinite(lagrange):
        raise TaylorError("a reciprocal's remainder overflows")
    return _series(B, a, coefs, lagrange, rough)


def _integrate(B: _Basis, a: TM, h: float) -> TM:
    """``h int_0^tau a dtau'``: tau^a -> tau^(a+1) / (a+1); tau^kt is truncated."""
    w = a[0] * h / (B.tau + 1.0)
    c = np.zeros(B.size)
    top = B.tau == B.kt
    c[1:] = np.where(top[:-1], 0.0, w[:-1])
    rad = h * a[1] + gamma(4) * float(np.sum(np.abs(w)))
    d = w[top]
    if d.size and np.any(d):
        ev = B.even[top]
        hi = float(np.sum(np.where(ev, np.maximum(d, 0.0), np.abs(d))))
        lo = float(np.sum(np.where(ev, np.minimum(d, 0.0), -np.abs(d))))
        mid, half = _centred(lo, hi)
        c[0] += mid
        rad += half + U * abs(c[0])
    return c, _up(rad, 6)


# ----- the flow's expressions as a program of Taylor-model operations ---------------------
def _number(e: sp.Expr) -> tuple[float, float]:
    """A sympy number as ``(value, radius)`` enclosing it."""
    if e.is_Integer and abs(int(e)) <= 2 ** 53:
        return float(int(e)), 0.0
    if e.is_Rational or e.is_Float:
        v = float(e.p) / float(e.q) if e.is_Rational else float(e)
        if math.isfinite(v) and sp.Rational(v) == sp.Rational(e):  # exactly a double
            return v, 0.0
        if e.is_Rational:
            return v, _up(gamma(3) * abs(v), 4)
    value = e.evalf(30)
    if not value.is_real:
        raise TaylorError(f"the constant {e} is not a real number")
    v = float(value)
    if not math.isfinite(v):
        raise TaylorError(f"the constant {e} is not finite")
    return v, _up(4 * U * abs(v), 4)


class _Program:
    """Sympy expressions compiled into a list of operations over slots."""

    def __init__(self, exprs: Sequence[sp.Expr], syms: Sequence[sp.Symbol]) -> None:
        self.index = {s: k for k, s in enumerate(syms)}
        self.ops: list[tuple] = []
        self.slots: dict[sp.Expr, int] = {}
        for e in exprs:
            if not isinstance(e, sp.Basic):
                raise TypeError(f"flow: expected sympy expressions (got {type(e).__name__})")
        self.outputs = [self._visit(e) for e in exprs]

    def _emit(self, e: sp.Expr, op: tuple) -> int:
        self.ops.append(op)
        self.slots[e] = len(self.ops) - 1
        return self.slots[e]

    def _visit(self, e: sp.Expr) -> int:
        if e in self.slots:
            return self.slots[e]
        if e.is_Symbol:
            if e not in self.index:
                raise TaylorError(f"Taylor models: unknown symbol {e} in the flow")
            return self._emit(e, ("var", self.index[e]))
        if e.is_number:
            return self._emit(e, ("const", *_number(e)))
        if e.is_Add or e.is_Mul:
            coeff, rest = e.as_coeff_Add() if e.is_Add else e.as_coeff_Mul()
            args = [self._visit(x) for x in (sp.Add.make_args(rest) if e.is_Add
                                             else sp.Mul.make_args(rest))]
            return self._emit(e, ("add" if e.is_Add else "mul", args, *_number(coeff)))
        if e.is_Pow:
            base, ex = e.args
            if not ex.is_Integer:
                raise TaylorError(f"Taylor models do not support {e} (Pow with a non-integer "
                                  "exponent)")
            return self._emit(e, ("pow", self._visit(base), int(ex)))
        for func, name in ((sp.sin, "sin"), (sp.cos, "cos"), (sp.exp, "exp")):
            if isinstance(e, func):
                return self._emit(e, (name, self._visit(e.args[0])))
        raise TaylorError(f"Taylor models do not support {type(e).__name__} in {e}")

    def run(self, B: _Basis, x: Sequence[TM], rough: bool = False) -> list[TM]:
        """The flow at ``x``; ``rough``: products without their truncation and rounding
        bounds (the Picard iterations of the polynomial part, which is validated after)."""
        vals: list[TM] = []
        for op in self.ops:
            kind = op[0]
            if kind == "var":
                v = x[op[1]]
            elif kind == "const":
                v = _const(B, op[1], op[2])
            elif kind == "add":
                v = vals[op[1][0]]
                for j in op[1][1:]:
                    v = _add(B, v, vals[j])
                if op[2] or op[3]:
                    v = _add_const(v, op[2], op[3])
            elif kind == "mul":
                v = vals[op[1][0]]
                for j in op[1][1:]:
                    v = _mul(B, v, vals[j], rough)
                if op[2] != 1.0 or op[3]:
                    v = _scale(B, v, op[2], op[3])
            elif kind == "pow":
                k = op[2]
                v = _pow(B, vals[op[1]], abs(k), rough)
                if k < 0:
                    v = _reciprocal(B, v, rough)
            elif kind in ("sin", "cos"):
                v = _sin_cos(B, vals[op[1]], kind == "cos", rough)
            else:
                v = _exp(B, vals[op[1]], rough)
            vals.append(v)
        return [vals[k] for k in self.outputs]


# ----- sets --------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class TaylorSet:
    """A vector of Taylor models over one basis: ``coeffs @ monomials + [-rad, rad]``.

    Attributes
    ----------
    coeffs : array of shape (dim, M)
    rad : array of shape (dim,)

    Examples
    --------
    The model of a box has the box's centre and generators as its constant and linear
    coefficients; its zonotope is the box widened by the bound of its rounding:

    >>> X = TaylorFlowpipe([sp.Integer(0)], [sp.Symbol("x")]).start(Zonotope([1.0], [[0.5]]))
    >>> X.dim, float(X.coeffs[0, 0]), X.coeffs[0, X.basis.s_index].tolist()
    (1, 1.0, [0.5])
    >>> lo, hi = X.zonotope().bounds()[0]
    >>> bool(lo <= 0.5 and 1.5 <= hi and hi - lo < 1 + 1e-9)
    True
    """

    basis: _Basis
    coeffs: np.ndarray
    rad: np.ndarray

    @property
    def dim(self) -> int:
        return int(self.coeffs.shape[0])

    def models(self) -> list[TM]:
        return [(self.coeffs[i], float(self.rad[i])) for i in range(self.dim)]

    def zonotope(self) -> Zonotope:
        """A zonotope enclosing the set (:func:`_linearised` says how each monomial is
        split between the centre, the generators and the box); the interval part and
        the rounding go into the box."""
        B, C = self.basis, self.coeffs
        Wc, Wg, Wt, Wb = _linearised(B)
        centre = C @ Wc
        G = C @ Wg
        t_gen = C @ Wt
        aC = np.abs(C)
        # every output is a sum of at most M products of a coefficient and a weight <= 1
        err = 4 * gamma(B.size + 4) * aC.sum(1)
        box = up(aC @ Wb + self.rad + err, B.size + 8)
        cols = [G]
        if np.any(t_gen):
            cols.append(t_gen[:, None])
        cols.append(np.diag(box))
        return Zonotope(centre, np.hstack(cols))


def _odd_power_fit(k: int) -> tuple[float, float]:
    """``(alpha, E)`` with ``|v^k - alpha v| <= E`` for ``v`` in ``[-1, 1]`` (``k`` odd),
    ``alpha`` near the minimax choice.

    On ``[0, 1]`` (the other half is symmetric) ``v^k - alpha v`` is ``1 - alpha`` at
    ``v = 1`` and has its one interior extreme ``-(1 - 1/k) alpha v*`` at
    ``v* = (alpha / k)^(1 / (k - 1))``; ``E`` bounds both, widened for rounding.

    Examples
    --------
    >>> alpha, E = _odd_power_fit(3)
    >>> round(alpha, 6), round(E, 6)
    (0.75, 0.25)
    """
    def deviation(alpha: float) -> float:
        v = (alpha / k) ** (1.0 / (k - 1))
        return max(1.0 - alpha, (1.0 - 1.0 / k) * alpha * v)

    lo, hi = 0.0, 1.0
    for _ in range(60):  # 1 - alpha falls and the interior extreme rises with alpha
        mid = 0.5 * (lo + hi)
        v = (mid / k) ** (1.0 / (k - 1))
        lo, hi = (mid, hi) if 1.0 - mid > (1.0 - 1.0 / k) * mid * v else (lo, mid)
    alpha = lo
    return alpha, deviation(alpha) * (1 + 1e-9) + 1e-15


@functools.lru_cache(maxsize=64)
def _linearised(B: _Basis) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Weights ``(Wc, Wg, Wt, Wb)``: a model ``C`` lies in the zonotope with centre
    ``C Wc``, generators ``C Wg`` (one per variable) and ``C Wt`` (time), and box
    ``|C| Wb``.

    Each monomial ``c mono`` is split as follows (``v`` the one variable of odd
    exponent, ``w`` the product of the other factors, even powers and ``tau^a``, so
    ``w in [0, 1]``):

    * constant: the centre;
    * ``tau^a``: ``c/2`` to the centre, ``c/2`` the time generator (``a = 1``, exactly
      ``c tau = c/2 + c/2 (2 tau - 1)``) or the box;
    * ``v^k`` alone: ``c alpha_k v`` and ``|c| E_k`` in the box (:func:`_odd_power_fit`;
      exact for ``k = 1``);
    * ``v^k w`` with ``w`` not constant: ``c/2 v`` and ``|c|/2`` in the box
      (``v^k w - v/2`` is within ``[-1/2, 1/2]``);
    * only even exponents (``w`` alone): ``c/2`` to the centre, ``|c|/2`` to the box;
    * two or more variables of odd exponent: ``|c|`` in the box.
    """
    M, nvar = B.size, B.m + B.n
    Wc, Wg, Wt, Wb = np.zeros(M), np.zeros((M, nvar)), np.zeros(M), np.zeros(M)
    fits = {k: _odd_power_fit(k) for k in range(3, 2 * max(B.kq, 1) + 2, 2)}
    for i, e in enumerate(B.exps.tolist()):
        *vars_, a = e
        odd = [j for j, p in enumerate(vars_) if p % 2]
        if i == 0:
            Wc[i] = 1.0
        elif len(odd) >= 2:
            Wb[i] = 1.0
        elif len(odd) == 1:
            j = odd[0]
            k = vars_[j]
            if a == 0 and sum(vars_) == k:
                alpha, E = (1.0, 0.0) if k == 1 else fits[k]
                Wg[i, j], Wb[i] = alpha, E
            else:
                Wg[i, j], Wb[i] = 0.5, 0.5
        elif sum(vars_) == 0 and a == 1:
            Wc[i], Wt[i] = 0.5, 0.5
        else:
            Wc[i], Wb[i] = 0.5, 0.5
    return Wc, Wg, Wt, Wb


class TaylorFlowpipe:
    """Validated Taylor-model steps of the flow ``x' = f(x)`` (no inputs).

    Parameters
    ----------
    flow : sequence of sympy expressions
        ``f``, one per state.
    syms : sequence of sympy symbols
        The states, in order.
    space_order : int, optional
        Degree in the initial-set variables; default :func:`orders`'s choice.

    Examples
    --------
    The rotation ``x' = y, y' = -x`` from a box around ``(1, 0)``: a quarter turn
    in 16 steps maps it onto a box around ``(0, -1)`` without wrapping.

    >>> x, y = sp.symbols("x y")
    >>> pipe = TaylorFlowpipe([y, -x], [x, y])
    >>> X = pipe.start(Zonotope([1.0, 0.0], [[0.1, 0.0], [0.0, 0.1]]))
    >>> for _ in range(16):
    ...     X, end, _ = pipe.step(X, np.pi / 32)
    >>> end.bounds().round(6).tolist()
    [[-0.1, 0.1], [-1.1, -0.9]]
    """

    def __init__(self, flow: Sequence[sp.Expr], syms: Sequence[sp.Symbol],
                 space_order: int | None = None) -> None:
        self.dim = len(syms)
        self.space_order = space_order
        if len(flow) != self.dim:
            raise ValueError(f"flow: expected {self.dim} expressions (got {len(flow)})")
        self.program = _Program(flow, syms)
        self._guess: np.ndarray | None = None  # the last step's interval part, per state

    def start(self, P: Zonotope) -> TaylorSet:
        """The Taylor model of a zonotope: one variable ``s_j`` per generator (at most
        ``dim``, the longest); the others become error generators (the ``q`` part)."""
        n = P.dim
        if n != self.dim:
            raise ValueError(f"P: expected dimension {self.dim} (got {n})")
        kept, rest = self.axes(P)
        m = kept.shape[1]
        B = _basis(m, ERROR_ORDER * n, *orders(m, self.space_order), ERROR_CROSS_DEGREE)
        C = np.zeros((n, B.size))
        C[:, 0] = P.center
        C[:, B.s_index] = kept
        if rest.size:
            C[:, B.q_index] = _errors(rest[:, :, None], B.n)[:, :, 0]
        self._guess = None
        return TaylorSet(B, C, np.zeros(n))

    def axes(self, P: Zonotope) -> tuple[np.ndarray, np.ndarray]:
        """``(kept, rest)``: the generators of ``P`` that :meth:`start` makes the variables
        ``s_1 .. s_m`` (column ``j`` is ``s_j``'s), the longest ones, at most ``dim``;
        and the others, which become error generators."""
        G = P.generators[:, np.any(P.generators != 0, axis=0)]
        ranked = np.argsort(-np.sum(np.abs(G), axis=0), kind="stable")
        return G[:, ranked[:self.dim]], G[:, ranked[self.dim:]]

    def _picard(self, B: _Basis, x0: list[TM], x: list[TM], h: float,
                rough: bool = False) -> list[TM]:
        fx = self.program.run(B, x, rough)
        return [_add(B, x0[i], _integrate(B, fx[i], h)) for i in range(self.dim)]

    def step(self, X0: TaylorSet, h: float) -> tuple[TaylorSet, Zonotope, Zonotope]:
        """One validated step of length ``h`` from ``X0``.

        Returns
        -------
        X1 : TaylorSet
            The set at the end of the step, its interval part among the error
            generators; start the next step here.
        end : Zonotope
            A zonotope enclosing ``X1``.
        segment : Zonotope
            A zonotope enclosing every state over the step ``[0, h]``.

        Raises
        ------
        TaylorError
            The interval part does not validate in :data:`VALIDATION_ATTEMPTS`
            enlargements (the step or the set is too large), or an operation fails.
        """
        if not h > 0:
            raise ValueError(f"h must be positive (got {h!r})")
        B = X0.basis
        x0 = X0.models()
        x = [(c, 0.0) for c, _ in x0]
        for _ in range(B.kt):
            x = [(c, 0.0) for c, _ in self._picard(B, x0, x, h, rough=True)]
        p = [c for c, _ in x]
        # a first guess of the interval part: the previous step's, or the image's own
        first = self._picard(B, x0, x, h)
        need = self._need(B, p, first)
        rho = 2.0 * need + TINY
        if self._guess is not None:
            rho = np.maximum(rho, self._guess)
        for _ in range(VALIDATION_ATTEMPTS):
            image = self._picard(B, x0, [(p[i], float(rho[i])) for i in range(self.dim)], h)
            need = self._need(B, p, image)
            if np.all(need <= rho):
                break
            # the states' interval parts feed each other: each follows its own need
            rho = np.maximum(rho, 1.5 * need)
        else:
            raise TaylorError(f"the Taylor model's interval part did not validate in "
                              f"{VALIDATION_ATTEMPTS} attempts (last need {np.max(need):.3g}); "
                              "lower the step or split the initial set")
        # the solution lies in p + [-need, need]; it is the Picard image of itself, so the
        # image of that smaller set encloses it again: refine while that shrinks it
        for _ in range(_REFINEMENTS):
            if not np.all(need <= 0.5 * rho):
                break
            rho = need
            image = self._picard(B, x0, [(p[i], float(rho[i])) for i in range(self.dim)], h)
            need = np.minimum(self._need(B, p, image), rho)
        self._guess = need
        X = TaylorSet(B, np.array(p), need)
        end = self._at_end(X)
        return end, self._end_zonotope(end), X.zonotope()

    def _need(self, B: _Basis, p: list[np.ndarray], image: list[TM]) -> np.ndarray:
        """``|image - p| + rad(image)`` per state: the interval part ``p`` needs."""
        out = np.empty(self.dim)
        for i in range(self.dim):
            d = _add(B, image[i], (-p[i], 0.0))
            out[i] = _up(_mag(B, d[0]) + d[1], 4)
        if not np.all(np.isfinite(out)):
            raise TaylorError("the Taylor model's interval part overflows")
        return out

    def _end_zonotope(self, X: TaylorSet) -> Zonotope:
        return X.zonotope()

    def _at_end(self, X: TaylorSet) -> TaylorSet:
        """``X`` at ``tau = 1``, its interval part added to the error generators."""
        B = X.basis
        at = (np.arange(B.size) // (B.kt + 1)) * (B.kt + 1)
        C = np.zeros_like(X.coeffs)
        for i in range(self.dim):
            C[i] = np.bincount(at, weights=X.coeffs[i], minlength=B.size)
        rad = up(X.rad + gamma(B.kt + 4) * np.sum(np.abs(X.coeffs), axis=1), B.kt + 8)
        groups = C[:, B.q_groups]  # (dim, n, g)
        fresh = np.zeros((self.dim, self.dim, groups.shape[2]))
        fresh[:, :, 0] = np.diag(rad)
        C[:, B.q_groups] = _errors(np.concatenate([groups, fresh], axis=1), B.n)
        return TaylorSet(B, C, np.zeros(self.dim))


def bend(X: TaylorSet) -> np.ndarray:
    """How much of the set's nonlinear part halving each variable's range removes: for
    ``s_j``, ``sum_i sum_alpha |c_i,alpha| (1 - 2^-alpha_j) / L_i`` over the monomials of
    ``s``-degree 2 or more (``L_i`` the sum of state ``i``'s absolute non-constant
    coefficients, so every state counts alike).

    A piece of the initial set half as wide along ``s_j`` has its degree-``d`` terms in
    ``s_j`` scaled by ``2^-d``; the truncation of a Taylor model and the boxing of its
    curvature grow with these terms, so the variable with the largest score is where a
    split pays most.

    Examples
    --------
    ``x' = y^2`` bends the set along ``y`` only:

    >>> x, y = sp.symbols("x y")
    >>> pipe = TaylorFlowpipe([y ** 2, sp.Integer(0)], [x, y])
    >>> X, _, _ = pipe.step(pipe.start(Zonotope([0.0, 1.0], [[0.1, 0.0], [0.0, 0.5]])), 0.5)
    >>> score = bend(X)
    >>> bool(score[0] > 0 and score[1] == 0)  # s_1 is y's generator (the longest), s_2 x's
    True
    """
    B = X.basis
    s = B.exps[:, :B.m]
    degree = s.sum(axis=1)
    plain = ~np.any(B.exps[:, B.m:B.m + B.n], axis=1)  # free of the error variables
    curved = plain & (degree >= 2)
    scale = np.sum(np.abs(X.coeffs[:, plain & (degree >= 1)]), axis=1)
    rows = scale > 0
    share = np.abs(X.coeffs[rows][:, curved]) / scale[rows, None]
    return np.sum(share @ (1.0 - 2.0 ** -s[curved].astype(float)), axis=0)


def _errors(G: np.ndarray, slots: int) -> np.ndarray:
    """Error generators reduced to ``slots``: ``G`` of shape ``(dim, k, g)`` holds, for each
    of ``k`` error variables ``q_i``, the coefficients of ``q_i``, ``q_i s_1``, ...
    (``g`` monomials, ``q_i`` alone first). When there are more than ``slots``, Girard's
    method boxes those a box encloses with the least loss: each such generator lies
    within ``+-w``, ``w`` the sum of its absolute coefficients (every monomial is at
    most 1 in absolute value), and the boxes' sum becomes ``dim`` new generators of
    ``q_i`` alone. Zero generators are dropped and the result padded to ``slots``.

    Examples
    --------
    Four generators of ``q`` alone in two dimensions, three slots: the largest is kept,
    the other three boxed.

    >>> G = np.array([[1.0, 0.1, 0.0, 0.05], [1.0, -0.1, 0.2, 0.0]])[:, :, None]
    >>> _errors(G, 3)[:, :, 0].round(3).tolist()
    [[1.0, 0.15, 0.0], [1.0, 0.0, 0.3]]
    """
    dim, _, g = G.shape
    G = G[:, np.any(G != 0, axis=(0, 2)), :]
    if G.shape[1] > slots:
        w = np.sum(np.abs(G), axis=2)
        score = np.sum(w, axis=0) - np.max(w, axis=0)
        ranked = np.argsort(score, kind="stable")
        n_box = G.shape[1] - slots + dim
        box = np.zeros((dim, dim, g))
        box[:, :, 0] = np.diag(up(np.sum(w[:, ranked[:n_box]], axis=1), n_box * g + 2))
        G = np.concatenate([G[:, np.sort(ranked[n_box:]), :], box], axis=1)
        G = G[:, np.any(G != 0, axis=(0, 2)), :]
    out = np.zeros((dim, slots, g))
    out[:, :G.shape[1], :] = G
    return out
