"""Summary statistics of simulated responses, made continuous in the parameters.

Fitting parameters to *summary quantities* (how many times a pendulum crosses the
vertical, its period, the overshoot of a step) needs statistics that change smoothly when
the parameters do, or a least-squares optimiser has no gradient to follow. This module
computes them from a sampled response:

* :func:`level_crossings` -- the times a signal crosses a level, located between samples
  by linear interpolation (the error is second order in the sampling step, so it varies
  smoothly with the parameters instead of jumping from sample to sample);
* :func:`continuous_count` -- the number of crossings plus a fraction in ``(0, 1]`` that
  says how close the response came to one more crossing, so that the count is continuous
  where the integer count jumps;
* :func:`refined_step_metrics` -- :func:`hybridlab.analysis.step_metrics` with the peak
  located by parabolic interpolation and the settling time by linear interpolation of
  the band crossing.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hybridlab.analysis import StepMetrics, step_metrics

__all__ = ["Crossings", "level_crossings", "continuous_count", "refined_step_metrics"]


@dataclass(frozen=True)
class Crossings:
    """Crossings of a level by a sampled signal.

    Attributes
    ----------
    t : numpy.ndarray
        Crossing times (s), interpolated between samples.
    direction : numpy.ndarray
        +1 for an upward crossing, -1 for a downward one.
    extrema : numpy.ndarray
        Largest distance ``|y - level|`` before the first crossing, between consecutive
        crossings and after the last one (``len(t) + 1`` values).
    t_start, t_end : float
        The sampled span.

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 1001)
    >>> c = level_crossings(t, np.cos(2 * np.pi * t))
    >>> len(c), c.select(-1).round(4).tolist(), c.select(+1).round(4).tolist()
    (2, [0.25], [0.75])
    >>> c.extrema.round(3).tolist(), (c.t_start, c.t_end)
    ([1.0, 1.0, 1.0], (0.0, 1.0))
    """

    t: np.ndarray
    direction: np.ndarray
    extrema: np.ndarray
    t_start: float
    t_end: float

    def __len__(self) -> int:
        return len(self.t)

    def select(self, direction: int) -> np.ndarray:
        """Times of the crossings in ``direction`` (+1 up, -1 down, 0 both)."""
        return self.t if direction == 0 else self.t[self.direction == direction]


def _peak(t: np.ndarray, y: np.ndarray) -> float:
    """Largest value of ``y``, refined by a parabola through the top three samples."""
    i = int(np.argmax(y))
    if 0 < i < len(y) - 1:
        a, b, c = y[i - 1], y[i], y[i + 1]
        curvature = a - 2 * b + c
        if curvature < 0:
            return float(b - 0.125 * (c - a) ** 2 / curvature)
    return float(y[i])


def level_crossings(t: np.ndarray, y: np.ndarray, level: float = 0.0) -> Crossings:
    """Where a sampled signal crosses ``level``.

    Samples exactly at the level do not count as a crossing of their own: a sign change
    is counted between the last sample on one side and the next sample on the other.

    Examples
    --------
    >>> t = np.linspace(0.0, 2.0, 2001)
    >>> c = level_crossings(t, np.exp(-t) * np.sin(2 * np.pi * t - 0.3))
    >>> np.round(c.t, 4).tolist(), c.direction.tolist()
    ([0.0477, 0.5477, 1.0477, 1.5477], [1, -1, 1, -1])
    >>> np.round(c.extrema, 3).tolist()
    [0.296, 0.752, 0.456, 0.277, 0.168]
    """
    t = np.asarray(t, dtype=float)
    d = np.asarray(y, dtype=float) - level
    nonzero = np.flatnonzero(d != 0)
    s = np.sign(d[nonzero])
    change = np.flatnonzero(s[1:] != s[:-1])
    i0, i1 = nonzero[change], nonzero[change + 1]
    times = t[i0] + (t[i1] - t[i0]) * d[i0] / (d[i0] - d[i1])
    cuts = np.concatenate([[0], i1, [len(t)]])
    extrema = np.array([_peak(t[a:b], np.abs(d[a:b])) if b > a else 0.0
                        for a, b in zip(cuts[:-1], cuts[1:], strict=True)])
    return Crossings(times, s[change + 1].astype(int), extrema, float(t[0]), float(t[-1]))


def continuous_count(crossings: Crossings) -> float:
    """The number of crossings plus a fraction in ``(0, 1]``, continuous in the parameters.

    The fraction is the smaller of

    * the **amplitude fraction** ``e_N / (e_{N-1} - e_N)``: the last excursion after the
      final crossing, ``e_N``, over the decrement of the last two excursions. For a
      Coulomb-damped oscillation the excursions shrink by a constant ``2 delta`` per half
      swing and one more crossing happens exactly when ``e_N`` exceeds it, so the
      fraction reaches 1 just as the next crossing appears (and restarts near 0 after
      it): the count is then ``e_0 / (2 delta)``, exactly continuous;
    * the **time fraction** ``(t_end - t_N) / (t_N - t_{N-1})``: the time since the last
      crossing in units of the last interval, for a response cut off by ``t_end``.

    Both are clipped to ``[0, 1]``; with fewer than two crossings the count is the
    integer count.

    Examples
    --------
    Excursions 0.9, 0.7, 0.5, 0.3, 0.1 (decrement 0.2): four crossings, and the last
    excursion is half of one more decrement.

    >>> c = Crossings(np.array([1.0, 2.0, 3.0, 4.0]), np.array([1, -1, 1, -1]),
    ...               np.array([0.9, 0.7, 0.5, 0.3, 0.1]), 0.0, 60.0)
    >>> round(continuous_count(c), 6)
    4.5
    """
    n = len(crossings)
    if n < 2:
        return float(n)
    e_last, e_prev = crossings.extrema[-1], crossings.extrema[-2]
    decrement = e_prev - e_last
    amp = float(np.clip(e_last / decrement, 0.0, 1.0)) if decrement > 0 else 1.0
    interval = crossings.t[-1] - crossings.t[-2]
    since = crossings.t_end - crossings.t[-1]
    tim = float(np.clip(since / interval, 0.0, 1.0)) if interval > 0 else 1.0
    return n + min(amp, tim)


def refined_step_metrics(t: np.ndarray, y: np.ndarray, start: float, target: float,
                         band: float = 0.02) -> StepMetrics:
    """Overshoot and settling time, interpolated between the samples.

    :func:`hybridlab.analysis.step_metrics` reports the largest sample and the sample
    after the last one outside the band; both move in steps of the sampling interval
    when a parameter changes. Here the peak is refined by a parabola through the three
    top samples and the settling time is where the straight line between the last
    sample outside the band and the next one meets the band edge.

    Examples
    --------
    >>> t = np.linspace(0, 10, 2001)
    >>> m = refined_step_metrics(t, 1 - np.exp(-t) * np.cos(3 * t), 0.0, 1.0)
    >>> round(m.overshoot_pct, 3), round(m.settling_time, 3)
    (37.06, 3.441)

    (the exact peak is ``1 + exp(-t_p) cos(3 t_p)`` at ``tan(3 t_p) = -1/3``: 37.060 %).
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    coarse = step_metrics(t, y, start, target, band)
    rel = (y - start) / (target - start)
    overshoot = max(0.0, _peak(t, rel) - 1.0) * 100.0 if coarse.overshoot_pct > 0 else 0.0
    dev = np.abs(rel - 1.0) - band
    outside = np.flatnonzero(dev > 0)
    if outside.size == 0 or outside[-1] + 1 >= t.size:
        return StepMetrics(overshoot, coarse.settling_time, band)
    i = int(outside[-1])
    settle = t[i] + (t[i + 1] - t[i]) * dev[i] / (dev[i] - dev[i + 1])
    return StepMetrics(overshoot, float(settle), band)
