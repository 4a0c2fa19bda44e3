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
``X_0`` and ``H_0``: they are never reduced again, so the flowpipe does not wrap, and
a step costs a few small matrix products. ``H_0`` is reduced once, and the input sum
``S_k`` (none for a mode without inputs) only in its generators beyond a budget; both
are boxed along the state axes, where the interval hull of a sum is the sum of the
interval hulls, so their bounds on every state stay exact (:class:`InputSum`). A box in
the mode's eigenvector coordinates would widen those bounds by the basis's conditioning,
and neither set is boxed again, which is what such a basis guards against. The order's
generators are shared: with inputs, ``H_0`` keeps at most half of them and the sum the
rest, so that neither starves the other. A set that entered the mode after a jump fills
the order on its own; given all of it, ``H_0`` would leave the sum of the mode's inputs a
box, which the next mode maps. On the vehicle platoon (``models/spaceex/platoon.xml``,
three switches in 20 s) that made the spacing bounds after the first switch up to 1.9
times the exact ones; shared, and with :class:`InputSum`'s merging, they are within 23 %.

``Phi^k`` is carried as an interval matrix (midpoint and entrywise radius) that
starts from the ball enclosure of ``Phi`` and bounds every product's rounding, so
the sets stay sound. When that radius stops being negligible, ``Phi^k = e^{A_h k r}``
is enclosed afresh in ball arithmetic; if even that is too wide (an exponential
too large for doubles), the chain reports itself worn and the caller starts a new
one from the current set.
"""

from __future__ import annotations

import numpy as np

from hybridlab.reachability.balls import expm_power_enclosure
from hybridlab.reachability.linear import (
    Propagator,
    affine_step,
    assemble,
    assembly_box,
    box_generators,
    homogeneous,
    interval_map,
)
from hybridlab.reachability.rounding import U, product_error, up
from hybridlab.reachability.sets import Zonotope

__all__ = ["AffineChain", "Ahead", "InputSum"]

_WORN = 1e-6
"""Relative radius of the enclosure of ``Phi^k`` beyond which it is enclosed afresh (and,
if that is still as wide, the chain is worn and restarted)."""


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
        Zonotope order of the flowpipe sets ``H_k`` (``H_0`` and the input sum
        ``S_k`` share it; ``X_0`` is kept whole).

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

    def __init__(self, prop: Propagator, P: Zonotope, W: Zonotope | None,
                 order: float) -> None:
        n = P.dim
        self.prop, self.n = prop, n
        self.first = affine_step(P, prop, W)
        self.X0 = P
        WG, w_box = prop.input_set(W, n)
        self.V = (WG, w_box) if WG.size or np.any(w_box > 0) else None
        # with inputs, H_0 takes at most half the order, so the sum keeps generators too
        self.H0 = self.first[1].reduce(order if self.V is None else order / 2)
        # the two sets every step maps, in homogeneous coordinates (formed once)
        self._X0h, self._H0h = homogeneous(self.X0), homogeneous(self.H0)
        # the sum keeps generators while H_k stays within the order
        budget = int(order * n) - self.H0.generators.shape[1] - 2 * n
        self.S = InputSum(n, max(budget, n))
        if self.V is not None:
            self.S.add(np.eye(n), np.zeros((n, n)), *self.V)  # S_1 = V
        self.M, self.M_rad = prop.phi.copy(), prop.phi_rad.copy()  # Phi^k for k = 1
        self._abs_phi = np.abs(prop.phi)
        self.steps = 1
        self.refreshed = 0  # times Phi^k was enclosed afresh

    @property
    def worn(self) -> bool:
        """Whether the enclosure of ``Phi^k`` has grown too wide to continue (even when
        enclosed afresh: the chain should then start again from the current set)."""
        return self._worn(np.abs(self.M))

    def _worn(self, abs_M: np.ndarray) -> bool:
        return bool(self.M_rad.max() > _WORN * (1.0 + float(abs_M.max())))

    def advance(self) -> tuple[Zonotope, Zonotope]:
        """``(X_{k+1}, H_k)`` for the next ``k``: the next step's end set and its flowpipe."""
        n = self.n
        H = self._plus_sum(*interval_map(self.M, self.M_rad, self._H0h))
        if self.V is not None:
            self.S.add(self.M[:n, :n], self.M_rad[:n, :n], *self.V)  # S_{k+1} = S_k + Phi^k V
        phi, phi_rad, abs_phi = self.prop.phi, self.prop.phi_rad, self._abs_phi
        abs_M = np.abs(self.M)
        self.M_rad = up(abs_phi @ self.M_rad + phi_rad @ (abs_M + self.M_rad)
                        + product_error(abs_phi, abs_M))
        self.M = phi @ self.M
        self.steps += 1
        if self._worn(np.abs(self.M)):  # enclose Phi^k afresh, in ball arithmetic
            self.M, self.M_rad = expm_power_enclosure(self.prop.Ah, self.prop.r, self.steps)
            self.refreshed += 1
        X = self._plus_sum(*interval_map(self.M, self.M_rad, self._X0h))
        return X, H

    def ahead(self, steps: int) -> Ahead | None:
        """The flowpipe sets ``H_k ... H_{k+steps-1}`` of the next steps, as arrays, without
        taking them (fewer where ``Phi^k`` would need enclosing afresh; ``None`` for a mode
        with inputs, whose sum is built step by step). :meth:`skip` then takes some.

        Each set is exactly what :meth:`advance` would return for that step.

        Examples
        --------
        >>> prop = Propagator.build(np.array([[-1.0]]), np.array([0.0]), 0.1, 10)
        >>> chain = AffineChain(prop, Zonotope([1.0], [[0.1]]), None, 20)
        >>> twin = AffineChain(prop, Zonotope([1.0], [[0.1]]), None, 20)
        >>> ahead = chain.ahead(3)
        >>> X, H = twin.advance()
        >>> bool(np.array_equal(ahead.set(0).generators, H.generators))
        True
        >>> X2 = chain.skip(ahead, 1)
        >>> bool(np.array_equal(X2.center, X.center))
        True
        """
        if self.V is not None or steps < 1:
            return None
        phi, phi_rad, abs_phi = self.prop.phi, self.prop.phi_rad, self._abs_phi
        M = np.empty((steps + 1,) + self.M.shape)
        M_rad = np.empty_like(M)
        M[0], M_rad[0] = self.M, self.M_rad
        usable = steps
        for j in range(1, steps + 1):  # the recurrence of advance
            abs_M = np.abs(M[j - 1])
            M_rad[j] = up(abs_phi @ M_rad[j - 1] + phi_rad @ (abs_M + M_rad[j - 1])
                          + product_error(abs_phi, abs_M))
            M[j] = phi @ M[j - 1]
            if bool(M_rad[j].max() > _WORN * (1.0 + float(np.abs(M[j]).max()))):
                usable = j - 1  # Phi^j must be enclosed afresh: advance does that
                break
        if usable < 1:
            return None
        n = self.n
        ch, Gh, absP = self._H0h
        Ms, Mr = M[:usable], M_rad[:usable]
        center = Ms @ ch
        gens = Ms @ Gh
        err = up(Mr @ absP + product_error(np.abs(Ms), absP))
        return Ahead(center[:, :n], gens[:, :n], assembly_box(center[:, :n], gens[:, :n],
                                                                err[:, :n]),
                     M[:usable + 1], M_rad[:usable + 1])

    def skip(self, ahead: Ahead, taken: int) -> Zonotope:
        """Take the first ``taken`` steps of ``ahead``; returns the end set ``X_{k+taken}``."""
        if not 1 <= taken <= len(ahead):
            raise ValueError(f"taken must be in [1, {len(ahead)}] (got {taken})")
        self.M, self.M_rad = ahead.M[taken].copy(), ahead.M_rad[taken].copy()
        self.steps += taken
        return self._plus_sum(*interval_map(self.M, self.M_rad, self._X0h))

    def _plus_sum(self, c: np.ndarray, G: np.ndarray, err: np.ndarray) -> Zonotope:
        """The mapped set (homogeneous ``c``, ``G`` and ``err``) plus the input sum."""
        n = self.n
        if self.V is None:
            return assemble(c[:n], G[:n], err[:n])
        S_gens, S_box = self.S.parts()
        return assemble(c[:n], np.hstack([G[:n], S_gens]), up(err[:n] + S_box))


class InputSum:
    """``S_k = V + Phi V + ... + Phi^(k-1) V``: generators up to a budget, the rest a box.

    The box is along the state axes. The interval hull of a Minkowski sum is the sum
    of the interval hulls, so boxing a term loses nothing in the bounds of any state:
    only directions across the axes (and the set mapped further, which the chain
    never does with ``S_k``, but the next mode does after a jump) feel it. Boxing in the
    mode's eigenvector coordinates instead made the building benchmark's bound on
    ``x25`` two to six times looser. Each term's own box (the input tail and the
    products' rounding) goes there at once. Beyond the budget, each generator too many
    is removed by the cheapest of these actions, all chosen from the costs before any is
    taken, no generator in two of them:

    * box a generator ``g``, at Girard's cost ``|g|_1 - |g|_inf``;
    * merge the generators ``g, h`` of one input column in two consecutive terms into
      ``g + h``, boxing ``|g - h|``, at the cost ``|g - h|_1``:
      ``g a + h b = (g + h) (a + b) / 2 + (g - h) (a - b) / 2``, and both halves stay in
      ``[-1, 1]``. Two fresh consecutive terms differ by
      ``Phi - I``, so merging them costs ``O(r^2)`` where boxing one costs ``O(r)``.

    Merging keeps directions that boxing loses. In random stable 6-state modes over 250
    steps, with 18 generators kept, the sum's support over random directions exceeded the
    exact one by 45 to 82 % on average, against 103 to 184 % with boxing alone. On the
    vehicle platoon (where the sum crosses three switches) the spacing bound no longer
    widens as the step is halved: -28.79, -28.64 and -28.57 at steps 0.05, 0.025 and
    0.0125, against -29.67, -32.10 and -33.30 with boxing alone.

    Parameters
    ----------
    n : int
    budget : int
        Generators kept.

    Examples
    --------
    >>> total = InputSum(1, budget=1)
    >>> for _ in range(3):
    ...     total.add(np.eye(1), np.zeros((1, 1)), np.array([[1.0]]), np.array([0.5]))
    >>> total.zonotope().radius().round(9).tolist()     # three times 1 + 0.5
    [4.5]

    Nearly parallel terms are merged rather than boxed: a rotation by 0.01 rad per term
    keeps one generator of length close to 2 after two terms, and a small box (boxing
    either term would add a box of radius 0.6 and 0.8):

    >>> c, s = np.cos(0.01), np.sin(0.01)
    >>> turning = InputSum(2, budget=1)
    >>> g = np.array([[0.6], [0.8]])
    >>> turning.add(np.eye(2), np.zeros((2, 2)), g, np.zeros(2))
    >>> turning.add(np.array([[c, -s], [s, c]]), np.zeros((2, 2)), g, np.zeros(2))
    >>> gens, box = turning.parts()
    >>> gens.shape, bool(np.linalg.norm(gens) > 1.99), bool(box.max() < 0.011)
    ((2, 1), True, True)
    """

    def __init__(self, n: int, budget: int) -> None:
        self.budget = budget
        self.G = np.zeros((n, 0))
        self.column = np.zeros(0, dtype=int)  # the input column each generator comes from
        self.rho = np.zeros(n)  # radius of the box

    def add(self, M: np.ndarray, M_rad: np.ndarray, WG: np.ndarray, w_box: np.ndarray) -> None:
        """Add ``M V`` for every matrix within ``M +- M_rad``; ``V = WG [-1, 1]^m + box``."""
        size = up(np.sum(np.abs(WG), axis=1) + w_box)
        abs_M = np.abs(M)
        x_box = up(abs_M @ w_box + M_rad @ size + product_error(abs_M, size))
        self.G = np.hstack([self.G, M @ WG])
        self.column = np.r_[self.column, np.arange(WG.shape[1])]
        self.rho = up(self.rho + x_box)
        excess = self.G.shape[1] - self.budget
        if excess > 0:
            self._reduce(excess)

    def _reduce(self, excess: int) -> None:
        """``excess`` generators fewer, each by the cheaper of boxing one and merging two,
        chosen together from the costs before any of them (no generator takes part in two)."""
        abs_G = np.abs(self.G)
        size = abs_G.shape[1]
        score = np.sum(abs_G, axis=0) - np.max(abs_G, axis=0)
        # consecutive generators of one input column, in the order added (merges keep it)
        order = np.argsort(self.column, kind="stable")
        same = self.column[order[1:]] == self.column[order[:-1]]
        first, second = order[:-1][same], order[1:][same]
        merge_cost = np.sum(np.abs(self.G[:, second] - self.G[:, first]), axis=0)
        used = np.zeros(size, dtype=bool)
        boxed: list[int] = []
        kept: list[int] = []
        gone: list[int] = []
        for action in np.argsort(np.r_[score, merge_cost], kind="stable"):
            if len(boxed) + len(gone) == excess:
                break
            if action < size:
                if not used[action]:
                    used[action] = True
                    boxed.append(int(action))
                continue
            a, b = first[action - size], second[action - size]
            if not (used[a] or used[b]):
                used[a] = used[b] = True
                kept.append(int(a))
                gone.append(int(b))
        added = np.sum(abs_G[:, boxed], axis=1)
        if kept:
            g, h = self.G[:, kept], self.G[:, gone]
            # the sums' rounding and the differences', each within U (|g| + |h|)
            added = added + np.sum(np.abs(g - h) + 2 * U * (abs_G[:, kept] + abs_G[:, gone]),
                                   axis=1)
            self.G[:, kept] = g + h
        self.rho = up(self.rho + up(added, len(boxed) + len(kept)))
        keep = np.ones(size, dtype=bool)
        keep[boxed + gone] = False
        self.G, self.column = self.G[:, keep], self.column[keep]

    def parts(self) -> tuple[np.ndarray, np.ndarray]:
        """``(generators, box)``: the kept generators and the box's radius."""
        return self.G, self.rho

    def zonotope(self) -> Zonotope:
        """The sum as a zonotope (its generators and the box)."""
        gens, box = self.parts()
        return assemble(np.zeros(gens.shape[0]), gens, box)


class Ahead:
    """The flowpipe sets of a chain's next steps, as stacked arrays (see
    :meth:`AffineChain.ahead`): set ``j`` is ``centers[j] + generators[j] [-1, 1]^m``
    plus the box of radius ``boxes[j]``.

    Examples
    --------
    >>> prop = Propagator.build(np.array([[-1.0]]), np.array([0.0]), 0.1, 10)
    >>> ahead = AffineChain(prop, Zonotope([1.0], [[0.1]]), None, 20).ahead(4)
    >>> len(ahead), ahead.centers.shape, ahead.supports(np.array([[1.0]])).shape
    (4, (4, 1), (4, 1))
    """

    def __init__(self, centers: np.ndarray, generators: np.ndarray, boxes: np.ndarray,
                 M: np.ndarray, M_rad: np.ndarray) -> None:
        self.centers, self.generators, self.boxes = centers, generators, boxes
        self.M, self.M_rad = M, M_rad  # Phi^k ... Phi^(k + len), for skip

    def __len__(self) -> int:
        return self.centers.shape[0]

    def set(self, j: int) -> Zonotope:
        """Set ``j`` as the zonotope :meth:`AffineChain.advance` would return."""
        return Zonotope(self.centers[j], np.hstack([self.generators[j],
                                                    box_generators(self.boxes[j])]))

    def supports(self, directions: np.ndarray) -> np.ndarray:
        """Upper bounds of ``d . x`` over every set (shape ``(len, k)``), rounded up."""
        D = np.asarray(directions, dtype=float)
        abs_D = np.abs(D)
        value = self.centers @ D.T
        dG = np.abs(np.einsum("kd,jdm->jkm", D, self.generators))
        spread = dG.sum(axis=-1) + self.boxes @ abs_D.T
        # the products' rounding (as Zonotope.supports bounds it) and the sums'
        size = np.abs(self.centers) + np.abs(self.generators).sum(axis=-1) + self.boxes
        err = product_error(abs_D, size.T).T + 2 * U * (np.abs(value) + spread)
        return up(value + spread + up(err))
