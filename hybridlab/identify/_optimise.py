"""The optimiser driver shared by the simulation-based fits (events and targets).

Each evaluation of the objective costs a simulation, so the fits run under a budget
of parameter points: the objective raises :class:`BudgetSpent` once it is used up,
and the best point evaluated so far is the answer.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.optimize import least_squares, minimize

__all__ = ["BudgetSpent", "minimise_residuals", "simplex"]


class BudgetSpent(Exception):
    """Raised inside the objective when the simulation budget is spent."""


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
