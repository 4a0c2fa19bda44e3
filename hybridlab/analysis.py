"""Small signal metrics for simulation results (step response, crossings)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["StepMetrics", "step_metrics", "count_crossings"]


@dataclass(frozen=True)
class StepMetrics:
    """Overshoot (percent of the step) and settling time into a relative band.

    Examples
    --------
    >>> m = step_metrics([0.0, 1.0, 2.0, 3.0], [0.0, 1.2, 0.99, 1.0], 0.0, 1.0)
    >>> m
    StepMetrics(overshoot_pct=19.99..., settling_time=2.0, band=0.02)
    >>> f"{m.overshoot_pct:.0f} % overshoot, settled at t = {m.settling_time}"
    '20 % overshoot, settled at t = 2.0'
    """

    overshoot_pct: float
    settling_time: float
    band: float


def step_metrics(t: np.ndarray, y: np.ndarray, start: float, target: float,
                 band: float = 0.02) -> StepMetrics:
    """Overshoot and settling time of a step from ``start`` to ``target``.

    Parameters
    ----------
    t, y : numpy.ndarray
        A finely sampled response (use :meth:`SimulationResult.sample`).
    start, target : float
        Initial and final value of the step.
    band : float
        Settling band as a fraction of the step size.

    Examples
    --------
    >>> t = np.linspace(0, 10, 10001)
    >>> y = 1 - np.exp(-t) * np.cos(3 * t)
    >>> m = step_metrics(t, y, 0.0, 1.0)
    >>> round(m.overshoot_pct, 1), round(m.settling_time, 2)
    (37.1, 3.44)
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    size = target - start
    if size == 0:
        raise ValueError("start and target must differ")
    rel = (y - start) / size
    overshoot = max(0.0, float(rel.max()) - 1.0) * 100.0
    outside = np.nonzero(np.abs(rel - 1.0) > band)[0]
    settling = float(t[min(outside[-1] + 1, t.size - 1)]) if outside.size else float(t[0])
    return StepMetrics(overshoot, settling, band)


def count_crossings(y: np.ndarray, level: float = 0.0) -> int:
    """Number of sign changes of ``y - level`` (exact zeros are not counted twice).

    Examples
    --------
    >>> count_crossings(np.sin(np.linspace(0.1, 10, 1000)))
    3
    """
    s = np.sign(np.asarray(y, dtype=float) - level)
    s = s[s != 0]
    return int(np.count_nonzero(s[1:] != s[:-1]))
