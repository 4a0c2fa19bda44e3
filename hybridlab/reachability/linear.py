"""One time step of an affine system with bounded inputs, sound in dense time.

For ``x' = A x + c + w(t)``, ``w(t)`` in a zero-centred zonotope ``W`` (any
measurable signal), a step of length ``r`` from the set ``P`` at relative time
0 returns

* ``P_next``, enclosing every state at relative time ``r``, and
* ``H``, enclosing every state at *every* relative time in ``[0, r]``.

Method (Girard, HSCC 2005; Althoff's thesis 2010, ch. 3): the constant ``c``
is absorbed by the homogeneous coordinate (``A_h = [[A, c], [0, 0]]``), so
the constant drift is propagated exactly by ``e^{A_h r}``.

* ``e^{A_h r}`` is the Taylor sum to ``eta`` terms; every entry of the
  remainder is bounded by ``E = a^(eta+1)/(eta+1)! / (1 - a/(eta+2))`` with
  ``a = |A_h|_inf r`` (a geometric tail bound), which enters as an interval
  matrix.
* Between the step ends: ``e^{A t} x = x + (t/r)(e^{A r} - I) x + F(t) x``
  with ``F(t) = sum_{i>=2} A^i (t^i - t r^(i-1))/i!``; each coefficient lies in
  ``[(i^(-i/(i-1)) - i^(-1/(i-1))) r^i, 0]`` for ``t`` in ``[0, r]`` (the
  correction matrix of Althoff 2010), and the tail beyond ``eta`` is within
  ``E``. The first term is the convex hull of ``P`` and ``e^{A r} P``
  (over-approximated by Girard's zonotope formula), the second the interval
  matrix ``F`` times ``P``: each term ``i`` has a single scalar coefficient,
  so on the centre the leading term ``i = 2`` is kept as a segment (drift and
  state cancel in it), and the rest is boxed.
* Inputs: ``int_0^t e^{A(t-s)} w(s) ds`` lies in ``sum_i A^i t^(i+1)/(i+1)! W``
  plus a tail ``E t |W|`` (Althoff 2010, Thm 3.2); for a symmetric ``W`` the
  set at ``t = r`` contains the sets at all ``t <= r``. The ``i = 0`` term
  ``r W`` is kept as a zonotope, the higher ones are boxed.

Rounding: matrix products are not rounded outward; each result is bloated by
``bloat`` (relative, default ``1e-12``) of its size, which dominates the
accumulated rounding of these small products (documented in
``docs/verification.md``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hybridlab.errors import HybridlabError
from hybridlab.reachability.sets import Zonotope

__all__ = ["StepError", "Propagator", "affine_step"]


class StepError(HybridlabError, ArithmeticError):
    """A reachability step cannot be enclosed (time step too large, remainder diverges)."""


def _abs_z(Z: Zonotope) -> np.ndarray:
    """``max |x|`` over ``Z`` per coordinate."""
    return np.abs(Z.center) + np.sum(np.abs(Z.generators), axis=1)


def _box(radius: np.ndarray) -> np.ndarray:
    """Generators of the box ``[-radius, radius]`` (zero columns dropped)."""
    idx = np.flatnonzero(radius > 0)
    G = np.zeros((radius.size, idx.size))
    G[idx, np.arange(idx.size)] = radius[idx]
    return G


_MAX_TERMS = 80


def _tail(a: float, eta: int) -> float:
    """Bound of ``sum_{i > eta} a^i / i!`` (geometric tail), rounded up."""
    if a == 0:
        return 0.0
    log_term = (eta + 1) * math.log(a) - math.lgamma(eta + 2)
    return math.exp(log_term) / (1.0 - a / (eta + 2)) * (1 + 1e-12) + 1e-300


@dataclass(frozen=True, eq=False)
class Propagator:
    """The matrices of one step for ``(A, c, r)``; reuse it while they do not change.

    Examples
    --------
    >>> prop = Propagator.build(np.array([[-1.0]]), np.array([0.0]), 0.1, 10)
    >>> bool(abs(prop.phi[0, 0] - np.exp(-0.1)) < 1e-15)
    True
    """

    A: np.ndarray
    phi: np.ndarray          # e^{A_h r}, homogeneous (n+1, n+1)
    phi_rad: np.ndarray      # entrywise radius of the interval enclosing the true e^{A_h r}
    F2: np.ndarray           # (rho_2 r^2 / 2) A_h^2: the leading correction term
    F_abs: np.ndarray        # entrywise bound of |F(t)| over [0, r] (all terms, tail included)
    F_rest: np.ndarray       # entrywise bound of the terms i >= 3 and the tail
    input_tail: np.ndarray   # |sum_{i>=1} A^i r^(i+1)/(i+1)!| + E r, (n, n)
    r: float

    @staticmethod
    def build(A: np.ndarray, c: np.ndarray, r: float, eta: int) -> Propagator:
        n = A.shape[0]
        Ah = np.zeros((n + 1, n + 1))
        Ah[:n, :n] = A
        Ah[:n, n] = c
        a = float(np.max(np.sum(np.abs(Ah), axis=1))) * r
        if a >= 0.5 * (_MAX_TERMS + 2):
            raise StepError(f"time step {r:g} too large for |A| = {a / r:.3g}: "
                            f"|A| * step must stay below {(_MAX_TERMS + 2) / 2:g}; lower `step`")
        # more terms while the tail bound is not negligible (stiff modes): a loose tail enters
        # every entry of the interval matrix and is multiplied by the whole state's size
        while eta < _MAX_TERMS and (a >= 0.5 * (eta + 2) or _tail(a, eta) > 1e-15):
            eta += 1
        E = _tail(a, eta)
        term = np.eye(n + 1)
        phi = np.eye(n + 1)
        F2 = np.zeros((n + 1, n + 1))
        F_rest = np.zeros((n + 1, n + 1))
        tail = np.zeros((n, n))
        powers_abs = np.zeros((n + 1, n + 1))
        for i in range(1, eta + 1):
            term = term @ Ah * (r / i)  # A_h^i r^i / i!
            phi = phi + term
            powers_abs += np.abs(term)
            tail += np.abs(term[:n, :n]) * (r / (i + 1))
            if i == 2:
                F2 = term * -0.25  # rho_2 = 2^-2 - 2^-1
            elif i > 2:
                rho = i ** (-i / (i - 1)) - i ** (-1 / (i - 1))
                F_rest += np.abs(term * rho)
        # rounding of the Taylor sum: a few ulps of the sum of absolute terms
        rounding = 8 * (eta + n) * np.finfo(float).eps * (1.0 + powers_abs)
        phi_rad = E + rounding
        F_rest += E + rounding
        return Propagator(A=A, phi=phi, phi_rad=phi_rad, F2=F2, F_abs=np.abs(F2) + F_rest,
                          F_rest=F_rest, input_tail=tail + E * r, r=r)


def affine_step(P: Zonotope, prop: Propagator, W: Zonotope | None = None,
                bloat: float = 1e-12) -> tuple[Zonotope, Zonotope]:
    """``(P_next, H)``: the set at relative time ``r`` and over ``[0, r]``.

    Parameters
    ----------
    P : Zonotope
        States at relative time 0.
    prop : Propagator
        For the system's ``A``, ``c`` and the step ``r``.
    W : Zonotope, optional
        Zero-centred (symmetric) set of the time-varying input ``w(t)``.
    bloat : float
        Relative bloating that covers floating-point rounding.

    Examples
    --------
    >>> prop = Propagator.build(np.array([[-1.0]]), np.array([0.0]), 0.1, 10)
    >>> P1, H = affine_step(Zonotope([1.0], [[0.0]]), prop)
    >>> lo, hi = H.bounds()[0]
    >>> bool(lo <= np.exp(-0.1) and hi >= 1.0), bool(hi - lo < 0.11)
    (True, True)
    """
    n = P.dim
    ch = np.r_[P.center, 1.0]
    Gh = np.vstack([P.generators, np.zeros((1, P.generators.shape[1]))])
    absP = np.r_[_abs_z(P), 1.0]
    phi = prop.phi
    c1, G1 = phi @ ch, phi @ Gh
    err = prop.phi_rad @ absP
    # inputs: r W as a zonotope, the higher-order terms boxed
    if W is not None and W.generators.size:
        WG = prop.r * W.generators
        w_box = prop.input_tail @ W.radius()
    else:
        WG = np.zeros((n, 0))
        w_box = np.zeros(n)
    # set at time r
    nxt_c = c1[:n]
    nxt_rad = err[:n] + w_box
    nxt_G = np.hstack([G1[:n], WG])
    size = np.abs(nxt_c) + np.sum(np.abs(nxt_G), axis=1) + nxt_rad
    P_next = Zonotope(nxt_c, np.hstack([nxt_G, _box(nxt_rad + bloat * size)]))
    # set over [0, r]: convex hull of P and phi P, plus the correction F P
    hull_c = 0.5 * (ch + c1)
    hull_G = np.hstack([0.5 * (Gh + G1), 0.5 * (ch - c1)[:, None], 0.5 * (Gh - G1)])
    # F(t) x = sum_i coef_i(t) A^i x with one scalar coef_i(t) in [rho_i r^i / i!, 0] per
    # term: on the centre the leading term is the segment [0, 1] * F2 c, which keeps the
    # cancellation between drift and state; the rest, and the action on the generators,
    # are boxed (they are of order (|A| r)^2 times the set's width, or (|A| r)^3)
    f2 = 0.5 * (prop.F2 @ ch)
    corr_rad = (prop.F_rest @ np.abs(ch) + prop.F_abs @ np.sum(np.abs(Gh), axis=1) + err)
    H_c = (hull_c + f2)[:n]
    H_G = np.hstack([hull_G[:n], f2[:n, None], WG])
    H_rad = corr_rad[:n] + w_box
    size = np.abs(H_c) + np.sum(np.abs(H_G), axis=1) + H_rad
    H = Zonotope(H_c, np.hstack([H_G, _box(H_rad + bloat * size)]))
    return P_next, H
