"""Bounds of a zonotope cut by half-spaces: linear programs with certified values.

For ``Z = {c + G beta : |beta|_inf <= 1}`` and the cut ``{x : A x <= b}``, coordinate
``i`` of ``Z`` within the cut is bounded below by ``c_i + min G_i beta`` over the
``beta`` with ``M beta <= d`` (``M = A G``, ``d = b - A c``) and ``|beta|_inf <= 1``,
and above likewise. HiGHS solves these ``2 n`` linear programs on one model, changing
only the objective, so each re-solve starts from the previous basis.

The bound used is never the solver's value. For any ``y >= 0``, weak duality gives,
for every feasible ``beta``::

    f beta = (f + M^T y) beta - y^T M beta  >=  -|f + M^T y|_1 - y^T d,

and the solver's row duals are such a ``y`` (clipped to ``y >= 0``). The right-hand
side is evaluated with every rounding directed outward, with ``M`` and ``d``
enclosed (their products rounded, :mod:`~hybridlab.reachability.rounding`), so the
bound holds whatever the solver's tolerances; a poor dual gives a looser bound, never a
wrong one. An empty cut is reported only with a Farkas certificate from the solver's
dual ray (``y >= 0`` with ``y^T d < -|M^T y|_1``); a cut the solver calls empty without
one keeps the zonotope's own bounds. This is the method of Neumaier and Shcherbina,
"Safe bounds in linear and mixed-integer linear programming" (Math. Program. 2004).

Examples
--------
The square ``[-1, 1]^2`` cut by ``x + y <= 0``, bounds on both coordinates:

>>> import numpy as np
>>> out = cut_bounds(np.zeros(2), np.eye(2), np.array([[1.0, 1.0]]), np.array([0.0]))
>>> (out.round(12) + 0.0).tolist()
[[-1.0, 1.0], [-1.0, 1.0]]
>>> out = cut_bounds(np.zeros(2), np.eye(2), np.array([[1.0, 1.0], [-1.0, 0.0]]),
...                  np.array([0.0, -0.5]))          # and x >= 0.5: y <= -0.5
>>> (out.round(12) + 0.0).tolist()
[[0.5, 1.0], [-1.0, -0.5]]
>>> cut_bounds(np.zeros(2), np.eye(2), np.array([[1.0, 1.0]]), np.array([-3.0])) is None
True
"""

from __future__ import annotations

from collections.abc import Sequence

import highspy
import numpy as np

from hybridlab.reachability.rounding import TINY, U, product_error, up

__all__ = ["cut_bounds"]


def cut_bounds(c: np.ndarray, G: np.ndarray, A: np.ndarray, b: np.ndarray,
               dims: Sequence[int] | None = None) -> np.ndarray | None:
    """Certified bounds of ``{c + G beta : |beta|_inf <= 1, A (c + G beta) <= b}``.

    Parameters
    ----------
    c, G : ndarray
        The zonotope's centre (``n``) and generators (``n x m``).
    A, b : ndarray
        The cut, ``k x n`` and ``k``.
    dims : sequence of int, optional
        The coordinates to bound by linear programs (all by default); the others keep
        the zonotope's interval hull.

    Returns
    -------
    ndarray or None
        ``n x 2`` lower and upper bounds, or ``None`` when the cut is certified empty.

    Examples
    --------
    The square ``[0, 2]^2`` cut by ``x + y <= 1`` and ``x - y >= 0.5``, and the same
    with only ``y`` bounded by linear programs:

    >>> import numpy as np
    >>> A, b = np.array([[1.0, 1.0], [-1.0, 1.0]]), np.array([1.0, -0.5])
    >>> (cut_bounds(np.ones(2), np.eye(2), A, b).round(9) + 0.0).tolist()
    [[0.5, 1.0], [0.0, 0.25]]
    >>> (cut_bounds(np.ones(2), np.eye(2), A, b, dims=[1]).round(9) + 0.0).tolist()
    [[0.0, 2.0], [0.0, 0.25]]
    """
    c, G = np.asarray(c, dtype=float), np.asarray(G, dtype=float)
    A, b = np.atleast_2d(np.asarray(A, dtype=float)), np.asarray(b, dtype=float).reshape(-1)
    radius = up(np.sum(np.abs(G), axis=1), G.shape[1] + 1)
    out = np.column_stack([np.nextafter(c - radius, -np.inf), np.nextafter(c + radius, np.inf)])
    m = G.shape[1]
    if m == 0:
        return out
    cut = _Cut(A, b, c, G)
    solver = _quiet_solver()
    solver.passModel(cut.model())
    columns = np.arange(m, dtype=np.int32)
    solved: list[tuple[int, int]] = []  # (coordinate, 0 lower / 1 upper) per objective
    objectives, duals = [], []
    for i in range(len(c)) if dims is None else dims:
        if not np.any(G[i]):
            continue
        for sign, col in ((1.0, 0), (-1.0, 1)):
            f = sign * G[i]
            solver.changeColsCost(m, columns, f)
            solver.run()
            status = solver.getModelStatus()
            if status == highspy.HighsModelStatus.kInfeasible:
                ray_found, ray = solver.getDualRay()[1:]
                if ray_found and cut.certifies_empty(np.asarray(ray, dtype=float)):
                    return None
                break  # not certified: this coordinate keeps the zonotope's bounds
            if status != highspy.HighsModelStatus.kOptimal:
                break
            solved.append((i, col))
            objectives.append(f)
            duals.append(np.asarray(solver.getSolution().row_dual, dtype=float))
    if not solved:
        return out
    low = cut.lower_bounds(np.array(objectives), np.array(duals))
    for (i, col), value in zip(solved, low.tolist(), strict=True):
        if col == 0:  # x_i = c_i + G_i beta >= c_i + low
            out[i, 0] = max(out[i, 0], float(np.nextafter(c[i] + value, -np.inf)))
        else:         # x_i = c_i - (-G_i beta) <= c_i - low
            out[i, 1] = min(out[i, 1], float(np.nextafter(c[i] - value, np.inf)))
    if np.any(out[:, 0] > out[:, 1]):
        return None  # the certified bounds themselves cross: nothing is in the cut
    return out


def _quiet_solver():  # noqa: ANN202 - highspy's binding class has no stub
    """A HiGHS instance that prints nothing.

    ``highspy.Highs`` writes a banner to the process's standard output (from C, on its
    first construction), which would corrupt a CLI's output; ``highspy._Highs`` is the
    binding that class wraps, without it.
    """
    solver = highspy._Highs()
    solver.setOptionValue("output_flag", False)
    return solver


class _Cut:
    """``M beta <= d`` with enclosures of ``M = A G`` and ``d = b - A c``."""

    def __init__(self, A: np.ndarray, b: np.ndarray, c: np.ndarray, G: np.ndarray) -> None:
        self.M = A @ G
        self.M_err = product_error(np.abs(A), np.abs(G))          # |M_exact - M|
        Ac = A @ c
        d = b - Ac
        # d_exact <= d_hi: the product's error, the subtraction's rounding
        self.d_hi = d + up(product_error(np.abs(A), np.abs(c)) + 2 * U * np.abs(d), 4) + TINY

    def model(self) -> highspy.HighsLp:
        k, m = self.M.shape
        lp = highspy.HighsLp()
        lp.num_col_, lp.num_row_ = m, k
        lp.col_cost_ = np.zeros(m)
        lp.col_lower_, lp.col_upper_ = -np.ones(m), np.ones(m)
        lp.row_lower_ = np.full(k, -highspy.kHighsInf)
        lp.row_upper_ = self.d_hi
        lp.a_matrix_.format_ = highspy.MatrixFormat.kRowwise
        lp.a_matrix_.start_ = np.arange(0, k * m + 1, m, dtype=np.int32)
        lp.a_matrix_.index_ = np.tile(np.arange(m, dtype=np.int32), k)
        lp.a_matrix_.value_ = self.M.ravel()
        return lp

    def _upper(self, Y: np.ndarray, F: np.ndarray) -> np.ndarray:
        """Upper bounds of ``|f + M_exact^T y|_1 + y^T d_exact``, one per row of ``Y``
        (each ``>= 0``) and of ``F``."""
        k, m = self.M.shape
        S = F + Y @ self.M
        S_err = (product_error(Y, np.abs(self.M)) + up(Y @ self.M_err, k + 1)
                 + 2 * U * np.abs(S) + TINY)
        norm = up(np.sum(np.abs(S) + S_err, axis=1), m + 1)
        yd = Y @ self.d_hi + product_error(Y, np.abs(self.d_hi))
        total = norm + yd
        return total + 2 * U * np.abs(total) + TINY

    def lower_bounds(self, F: np.ndarray, row_duals: np.ndarray) -> np.ndarray:
        """Certified lower bounds of ``f beta`` over the cut, one per row of ``F``, from
        the solver's row duals (either sign, clipped to ``y >= 0``: the better bound)."""
        plus = -self._upper(np.maximum(-row_duals, 0.0), F)
        minus = -self._upper(np.maximum(row_duals, 0.0), F)
        return np.maximum(plus, minus)

    def certifies_empty(self, ray: np.ndarray) -> bool:
        """Whether ``y`` (either sign of the ray, clipped to ``y >= 0``) proves the cut
        empty: ``y^T d_exact + |M_exact^T y|_1 < 0``."""
        Y = np.array([np.maximum(ray, 0.0), np.maximum(-ray, 0.0)])
        bound = self._upper(Y, np.zeros((2, self.M.shape[1])))
        return bool(np.any(np.any(Y > 0, axis=1) & (bound < 0)))
