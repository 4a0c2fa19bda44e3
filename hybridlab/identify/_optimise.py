"""The optimiser driver shared by the simulation-based fits (events and targets).

Each evaluation of the objective costs a simulation, so the fits run under a budget
of parameter points: the objective raises :class:`BudgetSpent` once it is used up,
and the best point evaluated so far is the answer.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np
from scipy.optimize import least_squares, minimize

__all__ = ["BudgetSpent", "ParameterSpace", "minimise_residuals", "simplex"]


class BudgetSpent(Exception):
    """Raised inside the objective when the simulation budget is spent.

    Examples
    --------
    An objective that allows three evaluations; the driver then reports the budget text:

    >>> calls = []
    >>> def residuals(theta):
    ...     if len(calls) == 3:
    ...         raise BudgetSpent
    ...     calls.append(theta.copy())
    ...     return theta - 2.0
    >>> ok, message, jac, x = minimise_residuals(
    ...     residuals, np.zeros(1), np.full(1, -5.0), np.full(1, 5.0), method="least_squares",
    ...     max_evaluations=50, xtol=1e-10, diff_step=1e-6, ftol=1e-10,
    ...     budget_text="stopped after 3 simulations")
    >>> ok, message, len(calls)
    (False, 'stopped after 3 simulations', 3)
    """


def simplex(x0: np.ndarray, step: float) -> np.ndarray:
    """The initial Nelder–Mead simplex: ``x0`` and one step along each axis.

    Examples
    --------
    >>> simplex(np.array([1.0, 2.0]), 0.1).tolist()
    [[1.0, 2.0], [1.1, 2.0], [1.0, 2.1]]
    """
    pts = [x0.copy()]
    for i in range(len(x0)):
        p = x0.copy()
        p[i] += step
        pts.append(p)
    return np.array(pts)


def minimise_residuals(residuals: Callable[[np.ndarray], np.ndarray], theta0: np.ndarray,
                       lo: np.ndarray, hi: np.ndarray, *, method: str, max_evaluations: int,
                       xtol: float, diff_step: float, ftol: float,
                       budget_text: str) -> tuple[bool, str, np.ndarray | None, np.ndarray]:
    """Minimise ``|residuals(theta)|^2`` within bounds by ``least_squares`` or Nelder–Mead.

    Returns ``(success, message, jacobian or None, x)``. When ``residuals`` raises
    :class:`BudgetSpent` the run stops with ``budget_text`` as the message; the
    caller then takes the best point it evaluated.

    Examples
    --------
    >>> r = lambda th: np.array([th[0] - 2.0, 3.0 * (th[1] + 1.0)])
    >>> ok, msg, jac, x = minimise_residuals(r, np.zeros(2), np.full(2, -5.0), np.full(2, 5.0),
    ...     method="least_squares", max_evaluations=50, xtol=1e-10, diff_step=1e-6,
    ...     ftol=1e-10, budget_text="budget")
    >>> ok, np.round(x, 6).tolist()
    (True, [2.0, -1.0])
    """
    success, message, jac, x_opt = False, "", None, theta0
    try:
        if method == "least_squares":
            sol = least_squares(residuals, theta0, bounds=(lo, hi), diff_step=diff_step,
                                xtol=xtol, ftol=ftol, max_nfev=max_evaluations)
            success, message, jac, x_opt = bool(sol.success), str(sol.message), sol.jac, sol.x
        else:
            def half_sum_of_squares(th: np.ndarray) -> float:
                r = residuals(th)
                return 0.5 * float(r @ r)

            sol = minimize(half_sum_of_squares, theta0, method="Nelder-Mead",
                           bounds=list(zip(lo, hi, strict=True)),
                           options={"maxfev": max_evaluations, "xatol": xtol, "fatol": 1e-8,
                                    "initial_simplex": simplex(theta0, 0.1)})
            success, message = bool(sol.success), str(sol.message)
    except BudgetSpent:
        message = budget_text
    return success, message, jac, x_opt


class ParameterSpace:
    """The optimiser's coordinates ``theta`` of the fitted parameters.

    A parameter whose bounds keep its sign is optimised as ``1 + log(p / p0)`` (relative
    changes, positivity for free, and friction-like decays are closer to linear in it);
    any other as ``p / |p0|``. Both start at ``|theta| = 1`` so that relative finite
    difference steps have a sensible size.

    Examples
    --------
    ``c`` keeps its sign (log coordinate); ``d`` may change sign (linear coordinate):

    >>> space = ParameterSpace.around(["c", "d"], {"c": 17.0, "d": 250.0},
    ...                               {"d": (-500.0, 500.0)})
    >>> space.log.tolist(), space.theta0().tolist()
    ([True, False], [1.0, 1.0])
    >>> space.values(np.array([1.0 + np.log(2.0), 1.5])).round(9).tolist()
    [34.0, 375.0]
    >>> [b.tolist() for b in space.bounds()]
    [[-inf, -2.0], [inf, 2.0]]
    """

    @classmethod
    def around(cls, fit: Sequence[str], start: Mapping[str, float],
               bounds: Mapping[str, tuple[float, float]] | None) -> ParameterSpace:
        """The space of parameters ``fit`` starting at ``start``, within ``bounds``
        (default: the half-line of the start value's sign).

        Examples
        --------
        >>> s = ParameterSpace.around(["k", "c"], {"k": 2.0, "c": -1.0}, {"c": (-3.0, 3.0)})
        >>> s.theta0().tolist(), s.values(s.theta0()).tolist()
        ([1.0, -1.0], [2.0, -1.0])
        """
        lower, upper = [], []
        for n in fit:
            b = (bounds or {}).get(n)
            if b is None:
                b = (0.0, np.inf) if start[n] >= 0 else (-np.inf, 0.0)
            if not (len(b) == 2 and b[0] < b[1] and b[0] <= start[n] <= b[1]):
                raise ValueError(f"bounds[{n!r}] must be (low, high) with low < high around the "
                                 f"start value {start[n]:g} (got {b!r})")
            lower.append(float(b[0]))
            upper.append(float(b[1]))
        return cls(np.array([start[n] for n in fit]), np.array(lower), np.array(upper))

    def __init__(self, p0: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> None:
        self.p0 = p0
        self.lower, self.upper = lower, upper
        self.log = (p0 != 0) & (((p0 > 0) & (lower >= 0)) | ((p0 < 0) & (upper <= 0)))
        self.scale = np.where(p0 != 0, np.abs(p0), 1.0)

    def theta0(self) -> np.ndarray:
        return np.where(self.log, 1.0, self.p0 / self.scale)

    def values(self, theta: np.ndarray) -> np.ndarray:
        return np.where(self.log, self.p0 * np.exp(np.where(self.log, theta - 1.0, 0.0)),
                        theta * self.scale)

    def derivative(self, theta: np.ndarray) -> np.ndarray:
        """``|dp / dtheta|`` (to turn standard errors of ``theta`` into those of ``p``)."""
        return np.abs(np.where(self.log, self.values(theta), self.scale))

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio_lo, ratio_hi = self.lower / self.p0, self.upper / self.p0
            lo_log = np.log(np.where(self.p0 > 0, ratio_lo, ratio_hi))
            hi_log = np.log(np.where(self.p0 > 0, ratio_hi, ratio_lo))
        lo = np.where(self.log, 1.0 + lo_log, self.lower / self.scale)
        hi = np.where(self.log, 1.0 + hi_log, self.upper / self.scale)
        return lo, hi
