"""Set representations: boxes, zonotopes and H-polytopes.

All three answer the same three questions — :meth:`bounds` (the interval hull,
shape ``(n, 2)``), :meth:`support` (the support function
``max_{x in S} d . x``) and :meth:`contains_points` — and can be turned into a
:class:`Zonotope`, the set the flowpipes are computed with.

Zonotopes ``{c + G b : b in [-1, 1]^m}`` are closed under linear maps and
Minkowski sums (both exact, by matrix products), which is why they carry the
reachable sets (Girard, HSCC 2005). Order reduction (Girard's box method) keeps
the number of generators bounded at the price of an over-approximation. LPs
(intersection bounds, polytope bounds) use scipy's HiGHS.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from hybridlab.errors import HybridlabError
from hybridlab.reachability.rounding import SLACK, TINY, U, gamma, product_error, up

__all__ = ["SetError", "Box", "Zonotope", "Polytope", "as_zonotope"]


class SetError(HybridlabError, ValueError):
    """A set is malformed (shapes, NaN, lo > hi) or an LP on it failed.

    Examples
    --------
    >>> Box([1.0, 0.0], [0.0, 1.0])
    Traceback (most recent call last):
    ...
    hybridlab.reachability.sets.SetError: lo must not exceed hi (got lo[0]=1.0 > hi[0]=0.0)
    >>> issubclass(SetError, ValueError)
    True
    """


def _vector(x: ArrayLike, name: str) -> np.ndarray:
    v = np.array(x, dtype=float).reshape(-1)
    if not np.isfinite(v).all():
        raise SetError(f"{name} must be finite (got {v.tolist()})")
    return v


def _points(X: ArrayLike, n: int) -> tuple[np.ndarray, bool]:
    P = np.asarray(X, dtype=float)
    single = P.ndim == 1
    P = np.atleast_2d(P)
    if P.shape[1] != n:
        raise SetError(f"points must have {n} columns (got shape {np.shape(X)})")
    return P, single


def _outward(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    return np.column_stack([np.nextafter(lo, -np.inf), np.nextafter(hi, np.inf)])


@dataclass(frozen=True, eq=False, init=False)
class Box:
    """An axis-aligned box ``lo <= x <= hi``.

    Examples
    --------
    >>> b = Box([0.0, -1.0], [1.0, 1.0])
    >>> b.bounds().tolist()
    [[0.0, 1.0], [-1.0, 1.0]]
    >>> float(b.support([1.0, 1.0]))
    2.0
    >>> b.contains_points([[0.5, 0.0], [2.0, 0.0]]).tolist()
    [True, False]
    """

    lo: np.ndarray
    hi: np.ndarray

    def __init__(self, lo: ArrayLike, hi: ArrayLike) -> None:
        # written out (not generated) so that lists and arrays are accepted while the
        # fields are always float vectors
        lo, hi = _vector(lo, "lo"), _vector(hi, "hi")
        if lo.shape != hi.shape:
            raise SetError(f"lo and hi must have the same length (got {lo.size} and {hi.size})")
        if np.any(lo > hi):
            i = int(np.argmax(lo > hi))
            raise SetError(f"lo must not exceed hi (got lo[{i}]={lo[i]} > hi[{i}]={hi[i]})")
        object.__setattr__(self, "lo", lo)
        object.__setattr__(self, "hi", hi)

    @property
    def dim(self) -> int:
        return self.lo.size

    def bounds(self) -> np.ndarray:
        """The box itself, shape ``(n, 2)``."""
        return np.column_stack([self.lo, self.hi])

    def support(self, direction: ArrayLike) -> float:
        """``max d . x`` over the box."""
        d = _vector(direction, "direction")
        return float(np.sum(np.where(d >= 0, d * self.hi, d * self.lo)))

    def contains_points(self, X: ArrayLike, tol: float = 0.0) -> np.ndarray:
        """Whether each row of ``X`` lies in the box (within ``tol``)."""
        P, single = _points(X, self.dim)
        below, above = self.lo - P, P - self.hi
        inside = np.all((below <= tol) & (above <= tol), axis=1)
        return inside[0] if single else inside

    def to_zonotope(self) -> Zonotope:
        """The same box as a zonotope (one generator per non-degenerate axis)."""
        c = 0.5 * (self.lo + self.hi)
        # c and hi - lo are each within one rounding of their exact values
        r = np.where(self.hi > self.lo,
                     up(0.5 * (self.hi - self.lo) * (1 + 2 * U) + U * np.abs(c)), 0.0)
        axes = np.flatnonzero(r > 0)
        G = np.zeros((self.dim, axes.size))
        G[axes, np.arange(axes.size)] = r[axes]
        return Zonotope(c, G)


@dataclass(frozen=True, eq=False, init=False)
class Zonotope:
    """The zonotope ``{center + generators @ b : b in [-1, 1]^m}``.

    Parameters
    ----------
    center : array of shape (n,)
    generators : array of shape (n, m)

    Examples
    --------
    >>> z = Zonotope([1.0, 0.0], [[1.0, 0.5], [0.0, 0.5]])
    >>> z.bounds().round(12).tolist()
    [[-0.5, 2.5], [-0.5, 0.5]]
    >>> z.linear_map([[0.0, 1.0], [1.0, 0.0]]).bounds().round(12).tolist()
    [[-0.5, 0.5], [-0.5, 2.5]]
    >>> bool(z.contains_points([1.0, 0.0])), bool(z.contains_points([2.5, -0.5]))
    (True, False)
    """

    center: np.ndarray
    generators: np.ndarray

    def __init__(self, center: ArrayLike, generators: ArrayLike) -> None:
        # written out (not generated) so that lists and arrays are accepted while the
        # fields are always float arrays
        c = _vector(center, "center")
        G = np.array(generators, dtype=float)
        if G.ndim == 1 and G.size == 0:
            G = G.reshape(c.size, 0)
        if G.ndim != 2 or G.shape[0] != c.size:
            raise SetError(f"generators must have shape ({c.size}, m) (got {G.shape})")
        if not np.isfinite(G).all():
            raise SetError("generators must be finite")
        object.__setattr__(self, "center", c)
        object.__setattr__(self, "generators", G)

    @property
    def dim(self) -> int:
        return self.center.size

    @property
    def order(self) -> float:
        """Number of generators divided by the dimension."""
        return self.generators.shape[1] / max(self.dim, 1)

    def radius(self) -> np.ndarray:
        """Half-widths of the interval hull (rounded up)."""
        return up(np.abs(self.generators).sum(axis=1), self.generators.shape[1])

    def bounds(self) -> np.ndarray:
        """The interval hull, shape ``(n, 2)``, rounded outward."""
        r = self.radius()
        return _outward(self.center - r, self.center + r)

    def support(self, direction: ArrayLike) -> float:
        """``max d . x`` over the zonotope (exact: ``d.c + sum |d.g_i|``)."""
        d = _vector(direction, "direction")
        return float(self.supports(d[None, :])[0])

    def supports(self, directions: np.ndarray) -> np.ndarray:
        """:meth:`support` of each row of ``directions`` (shape ``(k, n)``), rounded up.

        Examples
        --------
        >>> Z = Zonotope([1.0, 0.0], [[1.0, 0.0], [1.0, 2.0]])
        >>> Z.supports(np.array([[1.0, 0.0], [0.0, -1.0]])).round(12).tolist()
        [2.0, 3.0]
        """
        D = np.asarray(directions, dtype=float)
        dG = D @ self.generators
        spread = np.sum(np.abs(dG), axis=1)
        value = D @ self.center + spread
        abs_D = np.abs(D)
        # rounded up: the products' error bounds and the sum's
        err = (product_error(abs_D, np.abs(self.center))
               + np.sum(product_error(abs_D, np.abs(self.generators)), axis=1)
               + 2 * U * (np.abs(value) + spread))
        return up(value + up(err))

    def interval_hull(self) -> Box:
        """The smallest box containing the zonotope."""
        b = self.bounds()
        return Box(b[:, 0], b[:, 1])

    def box(self) -> Zonotope:
        """The interval hull as a zonotope."""
        return self.interval_hull().to_zonotope()

    def linear_map(self, M: ArrayLike, offset: ArrayLike | None = None,
                   radius: ArrayLike | None = None) -> Zonotope:
        """``{M x + offset}``, exact up to the products' rounding, which is enclosed by a box.

        With ``radius`` (entrywise, the shape of ``M``) the map is any matrix within
        ``M +- radius``, also enclosed by the box.
        """
        M = np.atleast_2d(np.asarray(M, dtype=float))
        c = M @ self.center
        if offset is not None:
            c = c + np.asarray(offset, dtype=float)
        G = M @ self.generators
        size = up(np.abs(self.center) + np.sum(np.abs(self.generators), axis=1))
        err = product_error(np.abs(M), size)
        if radius is not None:
            err = err + np.asarray(radius, dtype=float) @ size
        err = up(err + U * np.abs(c))  # the offset's addition
        return Zonotope(c, np.hstack([G, np.diag(err)])).compact()

    def minkowski_sum(self, other: Zonotope | Box | np.ndarray) -> Zonotope:
        """``{x + y}``, exact; ``other`` may also be a vector (a translation)."""
        if isinstance(other, Box):
            other = other.to_zonotope()
        shift = other.center if isinstance(other, Zonotope) else np.asarray(other, dtype=float)
        center = self.center + shift
        gens = [self.generators, np.diag(up(U * np.abs(center)))]  # the addition's rounding
        if isinstance(other, Zonotope):
            gens.insert(1, other.generators)
        return Zonotope(center, np.hstack(gens)).compact()

    __add__ = minkowski_sum

    def project(self, dims: Sequence[int]) -> Zonotope:
        """The projection on the coordinates ``dims``."""
        idx = list(dims)
        return Zonotope(self.center[idx], self.generators[idx])

    def compact(self, tol: float = 0.0) -> Zonotope:
        """The same set without zero generators (and with all-``tol``-small ones dropped
        into a box, which keeps it an over-approximation)."""
        G = self.generators
        size = np.sum(np.abs(G), axis=0)
        keep = size > tol
        if tol > 0 and np.any(~keep & (size > 0)):
            small = np.sum(np.abs(G[:, ~keep]), axis=1)
            return Zonotope(self.center, np.hstack([G[:, keep], np.diag(small)])).compact()
        return Zonotope(self.center, G[:, keep])

    def reduce(self, order: float, basis: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
               ) -> Zonotope:
        """Girard's box method: at most ``order * n`` generators, over-approximating.

        The generators with the smallest ``|g|_1 - |g|_inf`` (the ones a box
        encloses with the least loss) are replaced by their interval hull, or, with
        ``basis = (S, inv_mid, inv_rad)`` (``S^{-1}`` within ``inv_mid +- inv_rad``),
        by the box in the coordinates ``S^{-1} x``: ``{S y : |y| <= rho}``. A basis in
        which the flow contracts (a mode's eigenvectors) stops the box from growing
        when it is mapped and boxed again at every step (the wrapping effect).

        Examples
        --------
        >>> Z = Zonotope([0.0, 0.0], [[1.0, 1.0, 0.5], [1.0, -1.0, 0.5]])
        >>> Z.reduce(1).generators.shape
        (2, 2)
        """
        n = self.dim
        G = self.generators[:, np.any(self.generators != 0, axis=0)]
        limit = max(int(order * n), n)
        if G.shape[1] <= limit:
            return Zonotope(self.center, G)
        score = np.sum(np.abs(G), axis=0) - np.max(np.abs(G), axis=0)
        ranked = np.argsort(score)
        n_box = G.shape[1] - limit + n
        boxed, kept = ranked[:n_box], ranked[n_box:]
        if basis is None:
            radius = up(np.sum(np.abs(G[:, boxed]), axis=1), boxed.size)
            return Zonotope(self.center, np.hstack([G[:, kept], np.diag(radius)])).compact()
        S, inv_mid, inv_rad = basis
        Gb = G[:, boxed]
        abs_b = np.abs(Gb)
        Y = inv_mid @ Gb
        rho = up(np.sum(np.abs(Y), axis=1) + inv_rad @ np.sum(abs_b, axis=1)
                 + product_error(np.abs(inv_mid), np.sum(abs_b, axis=1)), boxed.size)
        box_gens = S * rho[None, :]
        err = product_error(np.abs(S), rho)  # the columns' scaling
        return Zonotope(self.center, np.hstack([G[:, kept], box_gens, np.diag(err)])).compact()

    def halfspaces(self) -> tuple[np.ndarray, np.ndarray] | None:
        """An H-representation ``A x <= b`` for full-dimensional zonotopes with n <= 3.

        ``None`` when the zonotope is degenerate or ``n > 3`` (use LPs then).
        """
        n = self.dim
        G = self.compact().generators
        if n > 3 or G.shape[1] == 0 or np.linalg.matrix_rank(G) < n:
            return None
        if n == 1:
            normals = np.array([[1.0]])
        elif n == 2:
            normals = np.column_stack([-G[1], G[0]])
        else:
            i, j = np.triu_indices(G.shape[1], k=1)
            normals = np.cross(G[:, i].T, G[:, j].T)
        normals = np.vstack([normals, np.eye(n)])
        norm = np.linalg.norm(normals, axis=1)
        normals = normals[norm > 1e-12 * max(1.0, float(norm.max()))]
        normals = normals / np.linalg.norm(normals, axis=1)[:, None]
        A = np.vstack([normals, -normals])
        b = A @ self.center + np.sum(np.abs(A @ G), axis=1)
        return A, b

    def contains_points(self, X: ArrayLike, tol: float = 1e-9) -> np.ndarray:
        """Whether each row of ``X`` lies in the zonotope, within ``tol`` (relative to its
        size). Exact through facets when the zonotope's affine hull has dimension <= 3
        (a degenerate zonotope is tested in its own coordinates), an LP per point otherwise."""
        P, single = _points(X, self.dim)
        scale = tol * (1.0 + float(np.max(np.abs(self.center), initial=0.0))
                       + float(np.max(self.radius(), initial=0.0)))
        G = self.compact().generators
        rank = np.linalg.matrix_rank(G) if G.size else 0
        if rank < self.dim and rank <= 3:
            # degenerate: the point must lie in the affine hull, then test in its coordinates
            U = np.linalg.svd(G)[0][:, :rank] if rank else np.zeros((self.dim, 0))
            D = P - self.center
            Y = D @ U
            off = np.linalg.norm(D - Y @ U.T, axis=1) <= scale
            if rank == 0:
                inside = off
            else:
                flat = Zonotope(np.zeros(rank), U.T @ G)
                inside = off & flat.contains_points(Y, tol * (1 + float(np.max(np.abs(
                    self.center), initial=0.0))) / (1 + float(np.max(flat.radius()))) + tol)
            return inside[0] if single else inside
        H = self.halfspaces()
        if H is not None:
            A, b = H
            excess = P @ A.T - b
            inside = np.all(excess <= scale, axis=1)
        else:
            inside = self._witnessed(P, scale)
            for i in np.flatnonzero(~inside):
                inside[i] = self._contains_lp(P[i], scale)
        return inside[0] if single else inside

    def _witnessed(self, P: np.ndarray, tol: float, rounds: int = 8) -> np.ndarray:
        """Points for which factors ``b`` in ``[-1, 1]`` with ``|G b - (p - c)| <= tol``
        are found without an LP: inside, with ``b`` as the witness.

        The least-squares factors first; where some leave ``[-1, 1]`` they are clipped and
        the residual is taken up by the others, for a few rounds (an active-set heuristic:
        a point it does not settle goes to the LP)."""
        G = self.generators
        inside = np.zeros(len(P), dtype=bool)
        if G.shape[1] == 0 or len(P) == 0:
            return inside
        D = (P - self.center).T
        B = np.linalg.lstsq(G, D, rcond=None)[0]
        inside[:] = (np.max(np.abs(B), axis=0) <= 1.0) & (
            np.max(np.abs(G @ B - D), axis=0) <= tol)
        for k in np.flatnonzero(~inside):
            b = np.clip(B[:, k], -1.0, 1.0)
            for _ in range(rounds):
                residual = D[:, k] - G @ b
                if np.max(np.abs(residual)) <= tol:
                    inside[k] = True
                    break
                free = np.abs(b) < 1.0
                if not free.any():
                    break
                b[free] += np.linalg.lstsq(G[:, free], residual, rcond=None)[0]
                b = np.clip(b, -1.0, 1.0)
        return inside

    def _contains_lp(self, p: np.ndarray, tol: float) -> bool:
        G = self.generators
        if G.shape[1] == 0:
            return bool(np.all(np.abs(p - self.center) <= tol))
        lo = self.bounds()
        if np.any(p < lo[:, 0] - tol) or np.any(p > lo[:, 1] + tol):
            return False
        m = G.shape[1]
        # feasibility of |G b - (p - c)| <= tol with -1 <= b <= 1. Each row is scaled by its
        # extent: states of very different sizes (1e-2 next to 1e-12) otherwise leave HiGHS
        # with coefficients below its drop threshold and an "unknown" status for points that
        # are inside. Scaling rows leaves the feasible set unchanged.
        w = 1.0 / np.maximum(self.radius(), tol)
        Gs, ds = G * w[:, None], (p - self.center) * w
        A = np.vstack([Gs, -Gs])
        rhs = np.concatenate([ds + w * tol, w * tol - ds])
        from scipy.optimize import linprog

        res = linprog(np.zeros(m), A_ub=A, b_ub=rhs, bounds=[(-1, 1)] * m, method="highs")
        if res.status == 0:
            return True
        # HiGHS can call that thin feasible set infeasible for a point on a face where many
        # factors sit at their bounds; the least scaled distance, always feasible, decides
        one = np.ones((len(w), 1))
        A = np.vstack([np.hstack([Gs, -one]), np.hstack([-Gs, -one])])
        cost = np.r_[np.zeros(m), 1.0]
        res = linprog(cost, A_ub=A, b_ub=np.concatenate([ds, -ds]),
                      bounds=[(-1, 1)] * m + [(0, None)], method="highs")
        return bool(res.status == 0 and res.fun <= float(np.min(w)) * tol)

    def intersect_halfspace(self, a: ArrayLike, b: float) -> Zonotope | None:
        """A zonotope containing ``Z ∩ {a . x <= b}`` (``None`` if that is empty).

        Each generator factor's range ``[-1, 1]`` is narrowed to what the
        halfspace allows given the others' extremes (one pass of interval
        constraint propagation), and the zonotope is re-centred on the narrowed
        factors. Exact in one dimension and when one generator alone crosses the
        boundary; otherwise the other generators' spread limits the cut. (The strip
        enclosure of Bravo, Alamo and Camacho 2006 was tried: smaller sets at the cut,
        but the rotated generators made the later flowpipe looser.)

        Examples
        --------
        >>> z = Zonotope([0.0, 0.0], [[1.0, 0.0], [0.0, 1.0]])
        >>> z.intersect_halfspace([1.0, 0.0], 0.5).bounds().round(9).tolist()
        [[-1.0, 0.5], [-1.0, 1.0]]
        """
        a = _vector(a, "a")
        G, c = self.generators, self.center
        d = a @ G
        s = float(b) - float(a @ c)
        spread = float(np.sum(np.abs(d)))
        # relative to the terms of s too: a point on the boundary is never declared outside
        # by the rounding of a . c
        slack = SLACK * (abs(s) + spread + abs(float(b)) + float(np.abs(a) @ np.abs(c))
                          + TINY)
        if -spread > s + slack:
            return None
        if spread <= s:
            return self
        if self.dim == 1 and a[0] != 0:  # an interval: cut it exactly
            lo_x, hi_x = self.bounds()[0]
            edge = float(b) / a[0]
            edge = edge + abs(edge) * 1e-15 + 1e-300 if a[0] > 0 else edge - abs(edge) * 1e-15 \
                - 1e-300
            lo_x, hi_x = (lo_x, min(hi_x, edge)) if a[0] > 0 else (max(lo_x, edge), hi_x)
            if lo_x > hi_x:
                return None
            return Zonotope([0.5 * (lo_x + hi_x)], [[np.nextafter(0.5 * (hi_x - lo_x), np.inf)]])
        lo, hi = -np.ones(d.size), np.ones(d.size)
        room = s + slack + spread  # s minus the others' minimum, before removing |d_i|
        with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
            # room >= 0: a tiny d_i only pushes its limit out (d_i = 0 limits nothing)
            limit = (room - np.abs(d)) / d
            up_hi = np.where(limit > 0, limit * (1 + SLACK), limit * (1 - SLACK)) + TINY
            down_lo = np.where(limit < 0, limit * (1 + SLACK), limit * (1 - SLACK)) - TINY
        rising, falling = d > 1e-300, d < -1e-300
        hi[rising] = np.minimum(1.0, up_hi[rising])
        lo[falling] = np.maximum(-1.0, down_lo[falling])
        if np.any(lo > hi):
            return None
        mid, rad = 0.5 * (lo + hi), 0.5 * (hi - lo)
        rad = up(rad) + U  # mid is within u of (lo + hi) / 2, and |mid| <= 1
        center = c + G @ mid
        err = up(product_error(np.abs(G), np.abs(mid)) + U * np.abs(center)
                 + U * np.sum(np.abs(G) * rad, axis=1))
        return Zonotope(center, np.hstack([G * rad, np.diag(err)])).compact()

    def intersect_slab(self, a: ArrayLike, lo: float, hi: float) -> Zonotope | None:
        """A zonotope containing ``Z ∩ {lo <= a . x <= hi}`` (``None`` if that is empty).

        Where the slab is much thinner than ``Z`` along ``a`` (a set pinned to a sliding
        surface), one generator ``g_j`` is eliminated: on the slab its factor is a function
        of ``a . x`` and the other factors, so every point is ``c + g_j (t - a.c) / d_j +
        sum_i beta_i (g_i - g_j d_i / d_j)`` with ``t`` in the slab (``d = a G``; ``j`` the
        generator most aligned with ``a``). The result has exactly the slab's width along
        ``a``; the rounding of the elimination is enclosed in a box added to it. Otherwise
        this is :meth:`intersect_halfspace` on both sides.

        Examples
        --------
        >>> z = Zonotope([0.0, 0.0], [[1.0, 1.0], [1.0, -1.0]])   # a square turned 45 deg
        >>> pinned = z.intersect_slab([1.0, 0.0], 0.0, 0.0)         # its slice x = 0
        >>> (pinned.bounds().round(9) + 0.0).tolist()
        [[0.0, 0.0], [-2.0, 2.0]]
        >>> z.intersect_slab([1.0, 0.0], 5.0, 6.0) is None
        True
        """
        a = _vector(a, "a")
        Z: Zonotope | None = self.intersect_halfspace(a, hi) if np.isfinite(hi) else self
        if Z is not None and np.isfinite(lo):
            Z = Z.intersect_halfspace(-a, -lo)
        if Z is None:
            return None
        low, high = -Z.support(-a), Z.support(a)
        t_lo, t_hi = max(low, float(lo)), min(high, float(hi))
        if t_lo > t_hi or t_hi - t_lo >= high - low:
            return Z
        # the candidate eliminations and the halfspace cut, the least spread kept
        # (each coordinate in units of its own width; a point coordinate by its magnitude)
        scale = np.maximum(self.radius(), 1e-9 * np.abs(self.center) + TINY)
        best: Zonotope | tuple[np.ndarray, np.ndarray, np.ndarray] = Z
        spread = float(np.sum(Z.radius() / scale))
        for j in self._elimination_candidates(a):
            center, G, err = self._eliminated(a, t_lo, t_hi, j)
            size = float(np.sum((np.sum(np.abs(G), axis=1) + err) / scale))
            if size < spread:
                best, spread = (center, G, err), size
        if isinstance(best, Zonotope):
            return best
        center, G, err = best
        return Zonotope(center, np.hstack([G, np.diag(err)])).compact()

    def _elimination_candidates(self, a: np.ndarray) -> list[int]:
        """The generators most aligned with ``a`` whose elimination is well conditioned."""
        G = self.generators
        d = np.abs(a @ G)
        usable = d > 1e6 * gamma(G.shape[0]) * (np.abs(a) @ np.abs(G))
        order = np.argsort(-d)
        return [int(j) for j in order[:4] if usable[j]]

    def _eliminated(self, a: np.ndarray, t_lo: float, t_hi: float, j: int
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`intersect_slab` by eliminating generator ``j``: the zonotope's centre,
        its generators and the box of the elimination's rounding (its radii)."""
        G, c = self.generators, self.center
        n, m = G.shape
        abs_a = np.abs(a)
        d = a @ G
        e_d = gamma(n) * (abs_a @ np.abs(G))            # |exact d - d|
        ac = float(a @ c)
        e_c = gamma(n) * float(abs_a @ np.abs(c))        # |exact a.c - ac|
        q = G[:, j] / d[j]
        t_mid = 0.5 * (t_lo + t_hi)
        t_rad = float(up(max(t_hi - t_mid, t_mid - t_lo), 2))
        center = c + q * (t_mid - ac)
        rest = np.delete(np.arange(m), j)
        G_new = G[:, rest] - np.outer(q, d[rest])
        abs_q = np.abs(q)
        # the residual of the computed parametrisation and the rounding of forming it
        err = (U * np.abs(G[:, j]) + abs_q * (e_c + float(np.sum(e_d)))
               + 4 * U * (np.abs(c) + abs_q * (abs(t_mid) + abs(ac)))
               + 2 * U * (np.sum(np.abs(G), axis=1) + abs_q * float(np.sum(np.abs(d))))
               + U * abs_q * t_rad)
        return center, np.hstack([G_new, (q * t_rad)[:, None]]), up(err, m + 8)

    def may_intersect(self, a: ArrayLike, b: float) -> bool:
        """Whether some point satisfies ``a . x <= b``."""
        return -self.support(-np.asarray(a, dtype=float)) <= b

    def bounds_in_slab(self, a: ArrayLike, lo: float, hi: float) -> np.ndarray | None:
        """Tight bounds of ``Z ∩ {lo <= a . x <= hi}``, ``None`` if empty.

        Solved through the LP dual, which for one slab is the maximum of a concave
        piecewise-linear function of one multiplier ``mu``: every ``mu`` gives a
        valid bound (weak duality), so the answer is sound whatever the rounding,
        and the best breakpoint is exact (strong duality).

        Examples
        --------
        >>> z = Zonotope([0.0, 0.0], [[1.0, 1.0], [1.0, -1.0]])   # a square rotated 45 deg
        >>> z.bounds_in_slab([1.0, 0.0], 1.5, 2.0).round(9).tolist()
        [[1.5, 2.0], [-0.5, 0.5]]
        """
        a = _vector(a, "a")
        G, c = self.generators, self.center
        d = a @ G
        shift = float(a @ c)
        l, u = float(lo) - shift, float(hi) - shift
        spread = float(np.sum(np.abs(d)))
        tol = SLACK * (spread + abs(l) + abs(u) + TINY) if np.isfinite(l + u) else 0.0
        if u < -spread - tol or l > spread + tol:
            return None
        # breakpoints only where d_j is not negligible: any multiplier gives a valid bound
        nz = np.flatnonzero(np.abs(d) > 1e-12 * spread)
        out = self.bounds().copy()
        if nz.size == 0:
            return out
        # objectives +-G_i; candidate multipliers: the breakpoints -C_ij / d_j and 0
        C = np.vstack([G, -G])                                   # (2n, m)
        mus = np.concatenate([-C[:, nz] / d[nz], np.zeros((2 * G.shape[0], 1))], axis=1)
        vals = -np.sum(np.abs(C[:, None, :] + mus[:, :, None] * d[None, None, :]), axis=2)
        # mu * u and mu * l with an infinite end: +-inf by the sign of mu (0 at mu = 0)
        with np.errstate(invalid="ignore", over="ignore"):  # an overflow is the inf it gives
            mu_u = mus * u if np.isfinite(u) else np.sign(mus) * np.inf * np.sign(u)
            mu_l = mus * l if np.isfinite(l) else np.sign(mus) * np.inf * np.sign(l)
            vals -= np.maximum(np.nan_to_num(mu_u, nan=0.0, posinf=np.inf, neginf=-np.inf),
                               np.nan_to_num(mu_l, nan=0.0, posinf=np.inf, neginf=-np.inf))
        vals = np.where(np.isnan(vals), -np.inf, vals)
        best = np.argmax(vals, axis=1)
        mu = mus[np.arange(C.shape[0]), best]
        g = vals[np.arange(C.shape[0]), best]
        ends = (abs(u) if np.isfinite(u) else 0.0) + (abs(l) if np.isfinite(l) else 0.0)
        size = np.sum(np.abs(C), axis=1) + np.abs(mu) * (spread + ends)
        g = g - SLACK * size - TINY                                # rounding of the evaluation
        n = G.shape[0]
        lower = c + g[:n]          # min G_i b >= g_i
        upper = c - g[n:]          # max G_i b = -min(-G_i b) <= -g_{n+i}
        out[:, 0] = np.maximum(out[:, 0], np.nextafter(lower, -np.inf))
        out[:, 1] = np.minimum(out[:, 1], np.nextafter(upper, np.inf))
        if np.any(out[:, 0] > out[:, 1]):
            return None
        return out

    def bounds_within(self, A: ArrayLike, b: ArrayLike, dims: Sequence[int] | None = None
                      ) -> np.ndarray | None:
        """Tight bounds of ``Z ∩ {A x <= b}``.

        Rows the zonotope satisfies everywhere are dropped; rows that are all
        parallel form one slab (:meth:`bounds_in_slab`, no LP); otherwise by
        ``2 n`` LPs over the generator factors (HiGHS), whose values are certified by
        weak duality (:func:`~hybridlab.reachability.lp.cut_bounds`).
        Returns ``None`` when the intersection is empty. ``dims`` selects the
        coordinates to bound by LP (all by default).
        """
        A = np.atleast_2d(np.asarray(A, dtype=float))
        b = np.asarray(b, dtype=float).reshape(-1)
        G, c = self.generators, self.center
        m = G.shape[1]
        out = self.bounds().copy()
        if m == 0:
            return out if np.all(A @ c <= b + 1e-12 * (1 + np.abs(b))) else None
        # rows the whole zonotope satisfies (support rounded up) cut nothing; what is left
        # is often one slab, bounded without an LP
        active = self.supports(A) > b
        if not active.any():
            return out
        A, b = A[active], b[active]
        slab = _as_slab(A, b)
        if slab is not None:
            return self.bounds_in_slab(*slab)
        from hybridlab.reachability.lp import cut_bounds

        cut = cut_bounds(c, G, A, b, dims)
        if cut is None:
            return None
        out[:, 0] = np.maximum(out[:, 0], cut[:, 0])
        out[:, 1] = np.minimum(out[:, 1], cut[:, 1])
        if np.any(out[:, 0] > out[:, 1]):
            return None
        return out


def _as_slab(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, float, float] | None:
    """``A x <= b`` as ``lo <= a . x <= hi`` when every row is parallel to the first."""
    a = A[0]
    aa = float(a @ a)  # not the norm squared: sqrt(2)**2 != 2 would miss a = (1, -1)
    if aa == 0:
        return None
    lo, hi = -np.inf, np.inf
    for row, bi in zip(A, b, strict=True):
        k = float(row @ a) / aa
        if k == 0 or not np.allclose(row, k * a, rtol=0, atol=1e-15 * np.abs(row).max()):
            return None
        if np.any(row != k * a):  # not exactly parallel: leave it to the LP
            return None
        if k > 0:
            hi = min(hi, bi if k == 1 else float(np.nextafter(bi / k, np.inf)))
        else:
            lo = max(lo, -bi if k == -1 else float(np.nextafter(bi / k, -np.inf)))
    return a, lo, hi


@dataclass(frozen=True, eq=False, init=False)
class Polytope:
    """The H-polytope ``{x : A x <= b}`` (bounded for :meth:`bounds`).

    Examples
    --------
    >>> triangle = Polytope([[-1.0, 0.0], [0.0, -1.0], [1.0, 1.0]], [0.0, 0.0, 1.0])
    >>> (triangle.bounds().round(6) + 0.0).tolist()
    [[0.0, 1.0], [0.0, 1.0]]
    >>> round(triangle.support([1.0, 2.0]), 9)
    2.0
    >>> triangle.contains_points([[0.2, 0.2], [0.8, 0.8]]).tolist()
    [True, False]
    """

    A: np.ndarray
    b: np.ndarray

    def __init__(self, A: ArrayLike, b: ArrayLike) -> None:
        # written out (not generated) so that lists and arrays are accepted while the
        # fields are always float arrays
        A = np.atleast_2d(np.array(A, dtype=float))
        b = _vector(b, "b")
        if A.shape[0] != b.size:
            raise SetError(f"A must have one row per entry of b (got {A.shape} and {b.size})")
        if not np.all(np.isfinite(A)):
            raise SetError("A must be finite")
        object.__setattr__(self, "A", A)
        object.__setattr__(self, "b", b)

    @property
    def dim(self) -> int:
        return self.A.shape[1]

    def support(self, direction: ArrayLike) -> float:
        """``max d . x`` by an LP; ``inf`` if unbounded in that direction."""
        d = _vector(direction, "direction")
        from scipy.optimize import linprog

        res = linprog(-d, A_ub=self.A, b_ub=self.b, bounds=[(None, None)] * self.dim,
                      method="highs")
        if res.status == 3:
            return float("inf")
        if res.status == 2:
            raise SetError("the polytope is empty")
        if res.status != 0:
            raise SetError(f"support LP failed: {res.message}")
        return float(-res.fun)

    def bounds(self) -> np.ndarray:
        """The interval hull by ``2 n`` LPs, widened by the LP tolerance."""
        out = np.empty((self.dim, 2))
        for i in range(self.dim):
            e = np.zeros(self.dim)
            e[i] = 1.0
            hi, lo = self.support(e), -self.support(-e)
            slack = 1e-9 * (1.0 + max(abs(lo), abs(hi)))
            out[i] = (lo - slack, hi + slack)
        if not np.all(np.isfinite(out)):
            raise SetError("the polytope is unbounded; a reachable set must be bounded")
        return out

    def contains_points(self, X: ArrayLike, tol: float = 1e-9) -> np.ndarray:
        """Whether each row of ``X`` satisfies ``A x <= b`` (within ``tol``)."""
        P, single = _points(X, self.dim)
        excess = P @ self.A.T - self.b
        inside = np.all(excess <= tol * (1 + np.abs(self.b)), axis=1)
        return inside[0] if single else inside

    def to_zonotope(self) -> Zonotope:
        """The interval hull as a zonotope (an over-approximation)."""
        b = self.bounds()
        return Box(b[:, 0], b[:, 1]).to_zonotope()


def as_zonotope(s: Box | Zonotope | Polytope) -> Zonotope:
    """Any supported set as a zonotope (exact for boxes and zonotopes).

    Examples
    --------
    >>> (as_zonotope(Box([0.0], [2.0])).bounds().round(12) + 0.0).tolist()
    [[0.0, 2.0]]
    """
    if isinstance(s, Zonotope):
        return s
    if isinstance(s, Box | Polytope):
        return s.to_zonotope()
    raise SetError(f"expected a Box, Zonotope or Polytope (got {type(s).__name__})")
