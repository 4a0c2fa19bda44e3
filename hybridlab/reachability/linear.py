"""One time step of an affine system with bounded inputs, sound in dense time, at any stiffness.

For ``x' = A x + c + w(t)``, ``w(t)`` in a zero-centred zonotope ``W`` (any
measurable signal), a step of length ``r`` from the set ``P`` at relative time
0 returns

* ``P_next``, enclosing every state at relative time ``r``, and
* ``H``, enclosing every state at *every* relative time in ``[0, r]``.

Method (Girard, HSCC 2005; Althoff's thesis 2010, ch. 3; Le Guernic and Girard,
NAHS 2010): the constant ``c`` is absorbed by the homogeneous coordinate
(``A_h = [[A, c], [0, 0]]``), so the constant drift is propagated exactly.

* ``Phi = e^{A_h r}`` is enclosed in ball arithmetic
  (:func:`~hybridlab.reachability.balls.expm_enclosure`): a midpoint matrix and
  an entrywise radius, rigorous at any ``|A| r``.
* Between the step ends, ``e^{A_h t} x = x + (t/r)(Phi - I) x + F(t) x``. The
  first two terms are the convex hull of ``P`` and ``Phi P`` (Girard's zonotope
  formula). The correction ``F(t) x`` is bounded in the basis of
  :mod:`~hybridlab.reachability.modal` when the mode is stiff for ``r``, else in
  the state coordinates, and in the slow block by the Taylor form
  ``F(t) = sum_{i>=2} A^i (t^i - t r^(i-1))/i!``, each coefficient in
  ``[(i^(-i/(i-1)) - i^(-1/(i-1))) r^i, 0]`` (Althoff 2010); its leading term
  on the centre is kept as a segment (drift and state cancel in it). Fast blocks
  use their own enclosures, which are ``O(1)`` whatever ``|lambda| r``.
* Inputs: in the slow block ``int_0^t e^{A(t-s)} w(s) ds`` lies in
  ``sum_i A^i t^(i+1)/(i+1)! W`` plus a tail (Althoff 2010, Thm 3.2), the
  ``i = 0`` term ``r W`` kept as a zonotope; in a fast block it lies within
  ``int_0^r |e^{B_j s}| ds |w|``. For a symmetric ``W`` both cover every
  ``t <= r``.

Rounding: every floating-point product and sum that forms a set is bounded by
:mod:`~hybridlab.reachability.rounding` and added as a box, so the computed
sets contain the exact ones; ``bloat`` is an optional extra margin on top.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hybridlab.errors import HybridlabError
from hybridlab.reachability.balls import expm_enclosure
from hybridlab.reachability.modal import Basis, FastBlock, block_basis, fast_block
from hybridlab.reachability.rounding import SLACK, TINY, U, gamma, product_error, up
from hybridlab.reachability.sets import Zonotope

__all__ = ["StepError", "Propagator", "TaylorBlock", "affine_step", "interval_map", "assemble"]


class StepError(HybridlabError, ArithmeticError):
    """A reachability step cannot be enclosed (the set or the remainder diverges).

    Examples
    --------
    >>> TaylorBlock.build(np.array([[-100.0]]), 1.0, 10)
    Traceback (most recent call last):
    ...
    hybridlab.reachability.linear.StepError: time step 1 too large ... |A| = 100; lower `step`
    >>> issubclass(StepError, ArithmeticError)
    True
    """


def _abs_z(Z: Zonotope) -> np.ndarray:
    """``max |x|`` over ``Z`` per coordinate."""
    return up(np.abs(Z.center) + np.abs(Z.generators).sum(axis=1), Z.generators.shape[1] + 1)


def box_generators(radius: np.ndarray) -> np.ndarray:
    """Generators of the box ``[-radius, radius]`` (zero columns dropped).

    Examples
    --------
    >>> box_generators(np.array([0.5, 0.0, 2.0])).tolist()
    [[0.5, 0.0], [0.0, 0.0], [0.0, 2.0]]
    """
    idx = np.flatnonzero(radius > 0)
    G = np.zeros((radius.size, idx.size))
    G[idx, np.arange(idx.size)] = radius[idx]
    return G


_MAX_TERMS = 80


#: Taylor terms of the hull correction taken on the centre as vectors (3 .. this)
_CENTRE_TERMS = 5


def _tail(a: float, eta: int) -> float:
    """Bound of ``sum_{i > eta} a^i / i!`` (geometric tail), rounded up."""
    if a == 0:
        return 0.0
    log_term = (eta + 1) * math.log(a) - math.lgamma(eta + 2)
    return math.exp(log_term) / (1.0 - a / (eta + 2)) * (1 + SLACK) + TINY


@dataclass(frozen=True, eq=False)
class TaylorBlock:
    """The Taylor correction and input terms of a matrix ``M`` with a moderate ``|M| r``.

    ``F2`` is the leading correction ``rho_2 M^2 r^2 / 2``; ``F_rest`` bounds the
    terms ``i >= 3``, the tail and the rounding of every term entrywise;
    ``F_abs = |F2| + F_rest``; ``F_next`` holds the terms ``rho_i M^i r^i / i!`` for
    ``i = 3 .. 5`` and ``F_tail`` bounds the rest as ``F_rest`` does (a centre's
    correction takes those terms as vectors); ``input_first`` is the first-order input
    term ``M r^2 / 2`` and ``input_tail`` bounds ``sum_{i>=2} |M^i| r^(i+1)/(i+1)!``,
    the tail and the rounding of the first.

    Examples
    --------
    >>> blk = TaylorBlock.build(np.array([[-1.0]]), 0.1, 10)
    >>> bool(abs(blk.F2[0, 0] + 0.25 * 0.1 ** 2 / 2) < 1e-18)
    True
    """

    F2: np.ndarray
    F_rest: np.ndarray
    F_abs: np.ndarray
    input_tail: np.ndarray
    input_first: np.ndarray
    F_next: tuple[np.ndarray, ...] = ()
    F_tail: np.ndarray | None = None

    @staticmethod
    def build(M: np.ndarray, r: float, eta: int) -> TaylorBlock:
        k = M.shape[0]
        abs_M = np.abs(M)
        a = float(up(np.max(np.sum(abs_M, axis=1)))) * r
        if a >= 0.5 * (_MAX_TERMS + 2):
            raise StepError(f"time step {r:g} too large for a non-normal block with "
                            f"|A| = {a / r:.3g}; lower `step`")
        # more terms while the tail bound is not negligible: a loose tail enters every entry
        while eta < _MAX_TERMS and (a >= 0.5 * (eta + 2) or _tail(a, eta) > 1e-15):
            eta += 1
        E = _tail(a, eta)
        term = np.eye(k)
        abs_term = np.eye(k)   # |M|^i r^i / i!, a bound of |term| and of its rounding scale
        F2 = np.zeros((k, k))
        F_rest = np.zeros((k, k))
        F_tail = np.zeros((k, k))
        F_next = []
        tail = np.zeros((k, k))
        first = np.zeros((k, k))
        for i in range(1, eta + 1):
            term = term @ M * (r / i)
            abs_term = abs_term @ abs_M * (r / i)
            # |fl(term) - term| <= gamma(i (k + 2)) |M|^i r^i / i! (i rounded products)
            rounding = gamma(i * (k + 2)) * abs_term
            if i == 1:  # kept as a matrix: the input's generators map through it
                first = term * (r / 2)
                tail += (rounding + gamma(1) * np.abs(term)) * (r / 2)
            else:
                tail += (np.abs(term) + rounding) * (r / (i + 1))
            if i == 2:
                F2 = term * -0.25  # rho_2 = 2^-2 - 2^-1
                F_rest += 0.25 * rounding
                F_tail += 0.25 * rounding
            elif i > 2:
                rho = i ** (-i / (i - 1)) - i ** (-1 / (i - 1))
                F_rest += abs(rho) * (np.abs(term) + rounding)
                if i <= _CENTRE_TERMS:
                    F_next.append(rho * term)
                    # rho * term is rounded too: one more product's worth
                    F_tail += abs(rho) * 2 * rounding + gamma(2) * abs(rho) * np.abs(term)
                else:
                    F_tail += abs(rho) * (np.abs(term) + rounding)
        F_rest = up(F_rest + E)
        return TaylorBlock(F2=F2, F_rest=F_rest, F_abs=up(np.abs(F2) + F_rest),
                           input_tail=up(tail + E * r), F_next=tuple(F_next),
                           F_tail=up(F_tail + E), input_first=first)


def _nonneg_product(L: np.ndarray, R: np.ndarray) -> np.ndarray:
    """``L @ R`` rounded up, for non-negative ``L`` and ``R``."""
    return up(L @ R, 2 * L.shape[-1] + 2)


@dataclass(frozen=True, eq=False)
class Coupling:
    """What replacing ``B`` by its block-diagonal part ``B_D`` changes, per modal coordinate.

    With ``E`` an entrywise bound of ``|B - B_D|`` and ``M`` one of ``|e^{B_D t}|``
    over ``[0, r]``, ``delta(t) = e^{B t} y - e^{B_D t} y = int_0^t e^{B_D (t - s)}
    (B - B_D) e^{B s} y ds`` gives ``sup |delta| <= K (M |y| + sup |delta|)`` with
    ``K = r M E``; for ``k = |K|_inf < 1`` this yields ``sup |delta| <= u + |K u|_inf /
    (1 - k)`` with ``u = K M |y|``, coordinate by coordinate. ``F(t) y`` changes by at
    most twice that. A modal coordinate that the basis scales up (the homogeneous one,
    after balancing) meets only the columns of ``E`` that the same scaling shrinks,
    where an infinity-norm bound would carry its size into every coordinate.
    """

    M: np.ndarray
    K: np.ndarray
    k: float

    @staticmethod
    def build(basis: Basis, fast: tuple[FastBlock, ...], r: float) -> Coupling:
        n = basis.B.shape[0]
        M = np.zeros((n, n))
        s = basis.blocks[0]
        # |e^{B_s t}| <= e^{|B_s| t} <= e^{|B_s| r} entrywise for t in [0, r]
        mid, rad = expm_enclosure(np.abs(basis.B[s, s]), r)
        M[s, s] = np.nextafter(mid + rad, np.inf)
        for b, blk in zip(basis.blocks[1:], fast, strict=True):
            M[b, b] = blk.sup_norm  # an entry is at most its row's sum
        K = np.nextafter(_nonneg_product(M, basis.perturbation) * r, np.inf)
        k = float(np.max(up(np.sum(K, axis=1), n)))
        if not k < 0.5:
            raise StepError(f"the block basis is too ill-conditioned for the step {r:g}")
        return Coupling(M=M, K=K, k=k)

    def bound(self, y_abs: np.ndarray) -> np.ndarray:
        """Upper bound of the change of ``F(t) y`` over ``[0, r]`` for ``|y| <= y_abs``."""
        u = _nonneg_product(self.K, _nonneg_product(self.M, y_abs))
        tail = float(np.max(_nonneg_product(self.K, u))) / (1.0 - self.k)
        return up(2.0 * (u + float(up(tail))), 2)


@dataclass(frozen=True, eq=False)
class Propagator:
    """The matrices of one step for ``(A, c, r)``; reuse it while they do not change.

    ``basis`` is ``None`` for a mode that is not stiff for ``r`` (the correction
    is then computed in the state coordinates), else the block basis with one
    :class:`FastBlock` per fast block.

    Examples
    --------
    >>> prop = Propagator.build(np.array([[-1.0]]), np.array([0.0]), 0.1, 10)
    >>> bool(abs(prop.phi[0, 0] - np.exp(-0.1)) <= prop.phi_rad[0, 0] + 1e-16)
    True
    >>> stiff = Propagator.build(np.array([[-1e6]]), np.array([1e6]), 0.1, 10)
    >>> stiff.basis is not None, bool(abs(stiff.phi[0, 1] - 1.0) < 1e-12)
    (True, True)
    """

    A: np.ndarray
    Ah: np.ndarray           # [[A, c], [0, 0]], homogeneous (n+1, n+1)
    phi: np.ndarray          # e^{A_h r}, homogeneous (n+1, n+1): midpoint
    phi_rad: np.ndarray      # entrywise radius of the ball around it
    r: float
    slow: TaylorBlock        # the Taylor block: the whole A_h, or the basis's slow block
    basis: Basis | None
    fast: tuple[FastBlock, ...]
    coupling: Coupling | None  # what dropping B - B_D changes in F(t) y
    input_coupling: float    # the same for the input integral (inf-norm)

    @staticmethod
    def build(A: np.ndarray, c: np.ndarray, r: float, eta: int) -> Propagator:
        n = A.shape[0]
        Ah = np.zeros((n + 1, n + 1))
        Ah[:n, :n] = A
        Ah[:n, n] = c
        phi, phi_rad = expm_enclosure(Ah, r)
        if not np.all(np.isfinite(phi_rad)):
            raise StepError(f"e^(A r) overflows for the step {r:g}; lower `step`")
        failure = StepError("no basis encloses this step")
        candidates = (lambda: block_basis(Ah, r), lambda: block_basis(Ah, r, stiff=False),
                      lambda: None)
        for candidate in candidates:  # built only when the one before fails
            try:
                return Propagator._in_basis(A, Ah, phi, phi_rad, r, eta, candidate())
            except StepError as exc:  # this basis's bounds are useless: try a plainer one
                failure = exc
        raise failure

    @staticmethod
    def _in_basis(A: np.ndarray, Ah: np.ndarray, phi: np.ndarray, phi_rad: np.ndarray,
                  r: float, eta: int, basis: Basis | None) -> Propagator:
        if basis is None:
            return Propagator(A=A, Ah=Ah, phi=phi, phi_rad=phi_rad, r=r,
                              slow=TaylorBlock.build(Ah, r, eta), basis=None, fast=(),
                              coupling=None, input_coupling=0.0)
        s = basis.blocks[0]
        slow = TaylorBlock.build(basis.B[s, s], r, eta)
        fast = tuple(fast_block(basis.B[b, b], r) for b in basis.blocks[1:])
        slow_norm = float(up(np.max(np.sum(np.abs(basis.B[s, s]), axis=1))))
        sup_norm = max([math.exp(slow_norm * r)] + [f.sup_norm for f in fast])
        # Gronwall: |e^{Bt} - e^{B_D t}| <= M (e^{M eps t} - 1) for t <= r
        growth = sup_norm * basis.eps * r
        if not growth < 1e-3:
            raise StepError(f"the block basis is too ill-conditioned for the step {r:g}")
        drift = sup_norm * math.expm1(growth) * (1 + SLACK) + TINY
        return Propagator(A=A, Ah=Ah, phi=phi, phi_rad=phi_rad, r=r, slow=slow, basis=basis,
                          fast=fast, coupling=Coupling.build(basis, fast, r),
                          input_coupling=drift * r)

    # -- the states between the step ends --------------------------------------------

    def between(self, ch: np.ndarray, Gh: np.ndarray, c1: np.ndarray, G1: np.ndarray,
                absP: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(center, generators, box)`` in homogeneous coordinates containing
        ``e^{A_h t} x`` for every ``t`` in ``[0, r]`` and every ``x`` of the set
        ``(ch, Gh)``, whose image at ``r`` is ``(c1, G1)`` (midpoint ``Phi``)."""
        center = 0.5 * (ch + c1)
        half_sum = 0.5 * (Gh + G1)
        dc, dG = 0.5 * (ch - c1), 0.5 * (Gh - G1)
        basis = self.basis
        if basis is None:
            offset, segment, box, curve = self._taylor_correction(
                ch, Gh, np.zeros_like(ch), slice(0, ch.size))
            gens = np.hstack([half_sum, dc[:, None], dG, segment[:, None], curve])
            return center + offset, gens, box
        # in the block basis: the slow block and the oscillating fast blocks share the
        # interpolation parameter t / r (with their corrections); a real fast mode
        # e^{lam t} y moves monotonically from y to e^{lam r} y, so it takes its own
        # parameter and needs no correction (its difference generators are boxed)
        inv_abs = np.abs(basis.inv_mid)
        y_c = basis.to_modal(ch)
        y_G = basis.to_modal(Gh)
        y_err = up(product_error(inv_abs, up(np.sum(np.abs(Gh), axis=1)))
                   + basis.inv_rad @ absP + product_error(inv_abs, absP))
        y_gen = up(np.sum(np.abs(y_G), axis=1) + y_err)
        dy_c, dy_G = basis.to_modal(dc), basis.to_modal(dG)
        d_abs = up(np.abs(dc) + np.sum(np.abs(dG), axis=1))
        dy_err = up(basis.inv_rad @ d_abs + product_error(inv_abs, d_abs))
        offset = np.zeros_like(y_c)
        rad = np.zeros_like(y_c)
        shared = np.zeros(y_c.size, dtype=bool)
        s = basis.blocks[0]
        offset[s], segment_s, rad[s], curve_s = self._taylor_correction(y_c, y_G, y_err, s)
        shared[s] = True
        own = []  # turning pairs: their own parameter, their difference kept as vectors
        for b, blk in zip(basis.blocks[1:], self.fast, strict=True):
            if blk.monotone and blk.spin:
                own.append(b)
                y_b = np.abs(y_c[b]) + y_gen[b]
                rad[b] = blk.spin * math.sqrt(float(up(y_b @ y_b)))
                continue
            if blk.monotone:
                rad[b] = np.abs(dy_c[b]) + np.sum(np.abs(dy_G[b]), axis=1)
                continue
            shared[b] = True
            v = y_c[b]
            offset[b] = blk.F_mid @ v
            rad[b] = (np.abs(blk.F_mid) @ y_gen[b] + blk.F_rad @ (np.abs(v) + y_gen[b])
                      + product_error(np.abs(blk.F_mid), np.abs(v)))
        coupling = 0.0 if self.coupling is None else self.coupling.bound(np.abs(y_c) + y_gen)
        rad = up(rad + dy_err + coupling)
        S = basis.S
        segment = np.zeros_like(y_c)
        segment[s] = segment_s
        parts = [half_sum, S[:, s] @ curve_s]
        err = (product_error(np.abs(S), np.abs(offset) + np.abs(segment) + rad)
               + product_error(np.abs(S[:, s]), up(np.sum(np.abs(curve_s), axis=1))))
        for cols in [shared] + own:  # Girard's hull, one interpolation parameter per group
            S_g = S[:, cols]
            parts += [basis.from_modal(dy_c[cols], cols)[:, None],
                      basis.from_modal(dy_G[cols], cols)]
            err = err + product_error(np.abs(S_g), up(np.abs(dy_c[cols])
                                                      + np.sum(np.abs(dy_G[cols]), axis=1)))
        parts += [basis.from_modal(segment)[:, None], S * rad[None, :]]
        return center + basis.from_modal(offset), np.hstack(parts), up(err)

    def _taylor_correction(self, y_c: np.ndarray, y_G: np.ndarray, y_err: np.ndarray,
                           s: slice) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The slow block's ``F(t) y`` for ``y`` in ``y_c + y_G beta`` (``+- y_err``):
        ``(offset, segment, box, curve)`` on the coordinates ``s``.

        The leading term is ``lambda rho_2 T_2 y`` with one ``lambda`` in ``[0, 1]``: on the
        centre the segment ``[rho_2 T_2 v, 0]``, i.e. ``offset +- segment``; on the
        generators ``lambda rho_2 T_2 G beta``, inside the zonotope with generators
        ``curve = rho_2 T_2 G`` (``lambda beta`` stays in the cube), which keeps the
        generators' correlations where a box of ``|rho_2 T_2| |G|`` would not (a badly scaled
        controller's ``T_2`` couples states by large gains). The rest is boxed."""
        v, G = y_c[s], y_G[s]
        slow = self.slow
        F2 = slow.F2
        segment = 0.5 * (F2 @ v)
        g_abs = up(np.sum(np.abs(G), axis=1))
        box = (slow.F_rest @ g_abs + slow.F_abs @ y_err[s]
               + product_error(np.abs(F2), np.abs(v) + g_abs))
        # the centre's terms i = 3 .. 5 as segments [F_i v, 0] too (one generator each),
        # the rest boxed: the centre's absolute size would otherwise enter as a box
        segments = [0.5 * (Fi @ v) for Fi in slow.F_next]
        for Fi in slow.F_next:
            box = box + product_error(np.abs(Fi), np.abs(v))
        offset = segment + sum(segments, np.zeros_like(segment))
        magnitude = np.abs(segment) + sum((np.abs(f) for f in segments), np.zeros_like(segment))
        tail = slow.F_rest if slow.F_tail is None else slow.F_tail
        box = up(box + tail @ np.abs(v) + 8 * np.finfo(float).eps * magnitude)
        curve = np.hstack([F2 @ G] + [f[:, None] for f in segments])
        return offset, segment, box, curve

    def input_set(self, W: Zonotope | None, n: int) -> tuple[np.ndarray, np.ndarray]:
        """``(generators, box)`` in state coordinates containing
        ``int_0^t e^{A (t - s)} w(s) ds`` for every ``t`` in ``[0, r]``."""
        if W is None or not W.generators.size:
            return np.zeros((n, 0)), np.zeros(n)
        # the input's own term r w and its first-order term (A r^2 / 2) w stay generators
        # (a bound of both moves coherently however the input varies within the step);
        # the terms of order two and above, and every rounding, are boxed
        w_rad = np.r_[W.radius(), 0.0]
        basis = self.basis
        F = self.slow.input_first
        if basis is None:
            G = np.vstack([W.generators, np.zeros((1, W.generators.shape[1]))])
            first = F @ G
            box = self.slow.input_tail @ w_rad + product_error(np.abs(F), w_rad)
            return np.hstack([self.r * W.generators, first[:n]]), up(box)[:n]
        Sinv = basis.inv_mid[:, :n]
        Z = Sinv @ W.generators
        z_err = up(basis.inv_rad @ w_rad + product_error(np.abs(basis.inv_mid), w_rad))
        z_rad = up(np.sum(np.abs(Z), axis=1) + z_err)
        s = basis.blocks[0]
        first = F @ Z[s]
        box = np.zeros(n + 1)
        box[s] = (self.slow.input_tail @ z_rad[s] + self.r * z_err[s] + np.abs(F) @ z_err[s]
                  + product_error(np.abs(F), z_rad[s]))
        for b, blk in zip(basis.blocks[1:], self.fast, strict=True):
            box[b] = blk.gain @ z_rad[b]
        box = up(box + self.input_coupling * float(np.max(z_rad)))
        S = basis.S
        slow_gens = S[:, s] @ (self.r * Z[s])
        first_gens = S[:, s] @ first
        err = (product_error(np.abs(S), box)
               + product_error(np.abs(S[:, s]), self.r * z_rad[s])
               + product_error(np.abs(S[:, s]), up(np.sum(np.abs(first), axis=1))))
        gens = np.hstack([slow_gens[:n], first_gens[:n], (S * box[None, :])[:n]])
        return gens, up(err[:n])


Homogeneous = tuple[np.ndarray, np.ndarray, np.ndarray]
"""A set in homogeneous coordinates ``x_h = (x, 1)``: its centre, its generators and
``max |x_h|`` per coordinate (see :func:`homogeneous`)."""


def homogeneous(P: Zonotope) -> Homogeneous:
    """``P`` in homogeneous coordinates: ``(center, generators, max |x_h|)``.

    Examples
    --------
    >>> ch, Gh, size = homogeneous(Zonotope([1.0], [[0.5]]))
    >>> ch.tolist(), Gh.tolist(), bool(size[0] >= 1.5 and size[1] == 1.0)
    ([1.0, 1.0], [[0.5], [0.0]], True)
    """
    n, m = P.generators.shape
    ch = np.empty(n + 1)
    ch[:n], ch[n] = P.center, 1.0
    Gh = np.zeros((n + 1, m))
    Gh[:n] = P.generators
    size = np.empty(n + 1)
    size[:n], size[n] = _abs_z(P), 1.0
    return ch, Gh, size


def interval_map(phi: np.ndarray, phi_rad: np.ndarray, P: Zonotope | Homogeneous
                 ) -> Homogeneous:
    """``(center, generators, box)`` in homogeneous coordinates containing ``M x_h`` for
    every ``M`` within ``phi +- phi_rad`` and every ``x`` of ``P`` (``x_h = (x, 1)``;
    ``P`` may be given in those coordinates already, as :func:`homogeneous` forms it).

    Examples
    --------
    ``x' = -x`` over a step of 0.1 from ``[0.5, 1.5]``: ``e^-0.1`` times the set (then the
    homogeneous coordinate 1), with a box of the order of the rounding:

    >>> prop = Propagator.build(np.array([[-1.0]]), np.array([0.0]), 0.1, 10)
    >>> center, gens, box = interval_map(prop.phi, prop.phi_rad, Zonotope([1.0], [[0.5]]))
    >>> center.round(9).tolist(), gens.round(9).tolist()
    ([0.904837418, 1.0], [[0.452418709], [0.0]])
    >>> bool(np.all(box < 1e-14))
    True
    """
    ch, Gh, absP = homogeneous(P) if isinstance(P, Zonotope) else P
    return phi @ ch, phi @ Gh, up(phi_rad @ absP + product_error(np.abs(phi), absP))


def assemble(center: np.ndarray, gens: np.ndarray, box: np.ndarray, bloat: float = 0.0
             ) -> Zonotope:
    """The zonotope ``(center, gens) + box``, enlarged by the rounding of its assembly.

    Each entry of ``center`` and ``gens`` went through at most four roundings (a
    product already bounded, then halvings and sums), covered by ``4 u`` of its size.

    Examples
    --------
    >>> Z = assemble(np.array([1.0]), np.array([[0.5]]), np.array([0.01]))
    >>> Z.generators.shape, Z.bounds().round(9).tolist()
    ((1, 2), [[0.49, 1.51]])
    """
    extra = assembly_box(center, gens, box, bloat)
    return Zonotope(center, np.hstack([gens, box_generators(extra)]))


def assembly_box(center: np.ndarray, gens: np.ndarray, box: np.ndarray, bloat: float = 0.0
                 ) -> np.ndarray:
    """The radius of the box :func:`assemble` adds: ``box`` and the assembly's rounding.

    Works on stacks too: ``center`` and ``box`` of shape ``(..., n)``, ``gens`` of shape
    ``(..., n, m)``.

    Examples
    --------
    >>> assembly_box(np.array([1.0]), np.array([[0.5]]), np.array([0.01])).round(9).tolist()
    [0.01]
    """
    size = up(np.abs(center) + np.abs(gens).sum(axis=-1) + box)
    return up(box + (4 * U + bloat) * size)


def affine_step(P: Zonotope, prop: Propagator, W: Zonotope | None = None,
                bloat: float = 0.0) -> tuple[Zonotope, Zonotope]:
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
        Relative enlargement on top of the rounding bounds (0: none).

    Examples
    --------
    >>> prop = Propagator.build(np.array([[-1.0]]), np.array([0.0]), 0.1, 10)
    >>> P1, H = affine_step(Zonotope([1.0], [[0.0]]), prop)
    >>> lo, hi = H.bounds()[0]
    >>> bool(lo <= np.exp(-0.1) and hi >= 1.0), bool(hi - lo < 0.11)
    (True, True)

    A stiff mode (time constant 1e-6 s) in one step of 0.1 s; over the step the
    states run from [-0.1, 0.1] to 1, and Girard's hull formula adds the set's width:

    >>> stiff = Propagator.build(np.array([[-1e6]]), np.array([1e6]), 0.1, 10)
    >>> P1, H = affine_step(Zonotope([0.0], [[0.1]]), stiff)
    >>> bool(abs(P1.center[0] - 1.0) < 1e-9 and P1.radius()[0] < 1e-9)
    True
    >>> H.bounds().round(6).tolist()
    [[-0.1, 1.1]]
    """
    n = P.dim
    ch, Gh, absP = homogeneous(P)
    c1, G1, err = interval_map(prop.phi, prop.phi_rad, (ch, Gh, absP))
    WG, w_box = prop.input_set(W, n)
    P_next = assemble(c1[:n], np.hstack([G1[:n], WG]), up(err[:n] + w_box), bloat)
    center, gens, box = prop.between(ch, Gh, c1, G1, absP)
    H = assemble(center[:n], np.hstack([gens[:n], WG]), up(box[:n] + err[:n] + w_box), bloat)
    return P_next, H
