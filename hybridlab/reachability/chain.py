"""Wrapping-free flowpipes of a constant affine mode (Girard, HSCC 2005; Girard, Le Guernic
and Maler, HSCC 2006).

For ``x' = A x + c + w(t)`` the state a step ``r`` later is ``x(t + r) = Phi x(t) + v``
with ``v`` in the one-step input set ``V``, for every ``t``. From the set ``X_0`` at
relative time 0 and the set ``H_0`` over ``[0, r]`` (both from
:func:`~hybridlab.reachability.linear.affine_step`) it follows that::

    X_k  in  Phi^k X_0 + S_k,    H_k  in  Phi^k H_0 + S_k,
    S_k = V + Phi V + ... + Phi^(k-1) V,

where ``X_k`` holds the states at relative time ``k r`` and ``H_k`` those over
``[k r, (k + 1) r]``. ``Phi^k X_0`` and ``Phi^k H_0`` keep the generators of
``X_0`` and ``H_0``: they are never reduced, so the flowpipe does not wrap, and a
step costs a few small matrix products. Only the input sum ``S_k`` is reduced
(none for a mode without inputs).

``Phi^k`` is carried as an interval matrix (midpoint and entrywise radius) that
starts from the ball enclosure of ``Phi`` and bounds every product's rounding, so
the sets stay sound. When that radius stops being negligible the chain reports
itself worn and the caller starts a new one from the current set.
"""

from __future__ import annotations

import numpy as np

from hybridlab.reachability.linear import Propagator, affine_step, assemble, interval_map
from hybridlab.reachability.rounding import product_error, up
from hybridlab.reachability.sets import Zonotope

__all__ = ["AffineChain"]

_WORN = 1e-9
"""Relative radius of the enclosure of ``Phi^k`` beyond which a chain is restarted."""


class AffineChain:
    """The flowpipe of one affine mode from ``P`` in steps of ``prop.r``.

    Parameters
    ----------
    prop : Propagator
        The step's matrices.
    P : Zonotope
        The states at relative time 0.
    W : Zonotope, optional
        Zero-centred set of the time-varying input.
    order : float
        Zonotope order of the input sum ``S_k`` (the only set reduced).
    basis : tuple, optional
        Reduction basis ``(S, inv_mid, inv_rad)`` (see ``Zonotope.reduce``).

    Attributes
    ----------
    first : tuple of Zonotope
        ``(X_1, H_0)``, the first step (as :func:`affine_step` gives it).

    Examples
    --------
    >>> prop = Propagator.build(np.array([[0.0, 1.0], [-1.0, 0.0]]), np.zeros(2), 0.1, 10)
    >>> chain = AffineChain(prop, Zonotope([1.0, 0.0], [[0.1, 0.0], [0.0, 0.1]]), None, 20)
    >>> for _ in range(62):                      # X_63: a turn of the rotation, t = 6.3
    ...     X, H = chain.advance()
    >>> X.generators.shape[1]                    # X_0's two and the rounding box's two
    4
    >>> bool(np.all(X.radius() < 0.1 * (np.cos(0.017) + np.sin(0.017)) + 1e-12))
    True

    The square has turned once, exactly: no wrapping (stepping from set to set
    and boxing at every step, it would grow at every step).
    """

    def __init__(self, prop: Propagator, P: Zonotope, W: Zonotope | None, order: float,
                 basis: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> None:
        n = P.dim
        self.prop, self.n, self.order, self.basis = prop, n, order, basis
        self.first = affine_step(P, prop, W)
        self.X0 = P
        self.H0 = self.first[1].reduce(order, basis)
        WG, w_box = prop.input_set(W, n)
        self.V = (assemble(np.zeros(n), WG, w_box) if WG.size or np.any(w_box > 0)
                  else None)
        self.M, self.M_rad = prop.phi.copy(), prop.phi_rad.copy()  # Phi^k for k = 1
        self.S = self.V  # S_1 = V
        self.steps = 1

    @property
    def worn(self) -> bool:
        """Whether the enclosure of ``Phi^k`` has grown too wide to continue."""
        return bool(np.max(self.M_rad) > _WORN * (1.0 + float(np.max(np.abs(self.M)))))

    def advance(self) -> tuple[Zonotope, Zonotope]:
        """``(X_{k+1}, H_k)`` for the next ``k``: the next step's end set and its flowpipe."""
        n = self.n
        c, G, err = interval_map(self.M, self.M_rad, self.H0)
        H = self._plus_sum(assemble(c[:n], G[:n], err[:n]))
        if self.V is not None:
            S_next = self.V.linear_map(self.M[:n, :n], radius=self.M_rad[:n, :n])
            self.S = (S_next if self.S is None else self.S + S_next).reduce(self.order,
                                                                               self.basis)
        phi, phi_rad = self.prop.phi, self.prop.phi_rad
        abs_phi, abs_M = np.abs(phi), np.abs(self.M)
        self.M_rad = up(abs_phi @ self.M_rad + phi_rad @ (abs_M + self.M_rad)
                        + product_error(abs_phi, abs_M))
        self.M = phi @ self.M
        self.steps += 1
        c, G, err = interval_map(self.M, self.M_rad, self.X0)
        X = self._plus_sum(assemble(c[:n], G[:n], err[:n]))
        return X, H

    def _plus_sum(self, Z: Zonotope) -> Zonotope:
        return Z if self.S is None else Z + self.S
