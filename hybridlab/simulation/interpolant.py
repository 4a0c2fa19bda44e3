"""Time derivative of an integrator step's dense output.

Event location searches a monitor ``phi(x_dense(t))`` along the step's
interpolant. Its slope at the sample points (which decides where the
sampler refines and where the cubic Hermite model predicts a paired
crossing) is taken as the exact derivative of that same function: the
monitor's gradient times the derivative of the interpolating polynomial.
Along the polynomial this is cheaper than a flow evaluation per sample (a
sliding flow costs a projection) and consistent with the values.

scipy's explicit Runge-Kutta interpolants are polynomials with known
coefficients (``RkDenseOutput.Q`` for RK23/RK45, ``Dop853DenseOutput.F``
for DOP853); for the implicit methods' interpolants :func:`dense_slope`
returns ``None`` and the engine takes slopes along the flow instead.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate._ivp.rk import Dop853DenseOutput, RkDenseOutput

__all__ = ["dense_slope"]


def dense_slope(dense: object, tau: np.ndarray) -> np.ndarray | None:
    """Derivative of ``dense`` at the times ``tau``, shape ``(n, len(tau))``.

    Parameters
    ----------
    dense : scipy.integrate.DenseOutput
        One step's interpolant (``solver.dense_output()``).
    tau : numpy.ndarray
        Times within the step (1-D).

    Returns
    -------
    numpy.ndarray or None
        ``d/dt dense(tau)``, or ``None`` for an interpolant this module does
        not know (Radau, BDF, LSODA).

    Examples
    --------
    >>> from scipy.integrate import RK45
    >>> solver = RK45(lambda t, y: np.array([np.cos(t)]), 0.0, np.array([0.0]), 1.0)
    >>> _ = solver.step()
    >>> tau = np.array([0.0, 0.5 * solver.t])
    >>> slope = dense_slope(solver.dense_output(), tau)
    >>> bool(np.allclose(slope[0], np.cos(tau), atol=1e-6))
    True
    """
    tau = np.asarray(tau, dtype=float)
    if isinstance(dense, Dop853DenseOutput):
        x = ((tau - dense.t_old) / dense.h)[:, None]
        y = np.zeros((tau.size, dense.y_old.size))
        dy = np.zeros_like(y)
        for i, f in enumerate(reversed(dense.F)):
            y += f
            if i % 2 == 0:
                dy = dy * x + y
                y *= x
            else:
                dy = dy * (1 - x) - y
                y *= 1 - x
        return dy.T / dense.h
    if isinstance(dense, RkDenseOutput):
        x = (tau - dense.t_old) / dense.h
        powers = np.cumprod(np.vstack([np.ones_like(x), np.tile(x, (dense.order, 1))]), axis=0)
        weights = np.arange(1, dense.order + 2, dtype=float)[:, None]
        return dense.Q @ (weights * powers)
    return None
