"""Detection of Zeno behaviour: jumps accumulating at a finite time."""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["ZenoVerdict", "ZenoTracker"]


@dataclass(frozen=True)
class ZenoVerdict:
    """Evidence that one transition's firings accumulate at ``accumulation_time``.

    Examples
    --------
    >>> verdict = ZenoVerdict("bounce", 40, 0.8, 12.8506)
    >>> verdict.describe()
    "transition 'bounce' fired 40 times with dwell times shrinking by a factor 0.8;
    firings accumulate at t = 12.8506"
    """

    transition: str
    firings: int
    ratio: float
    accumulation_time: float

    def describe(self) -> str:
        return (f"transition {self.transition!r} fired {self.firings} times with dwell times "
                f"shrinking by a factor {self.ratio:.4g}; firings accumulate at "
                f"t = {self.accumulation_time:.10g}")


class ZenoTracker:
    """Watches the dwell times between firings of each transition.

    When the last ``window`` dwell times shrink geometrically and the
    extrapolated accumulation point ``t + d r / (1 - r)`` is closer than
    ``tol * max(1, |t|)`` (or the dwell is below the event time resolution),
    the run is Zeno.

    Examples
    --------
    >>> z = ZenoTracker(window=4, tol=1e-3, time_resolution=1e-12)
    >>> verdict = None
    >>> t, d = 0.0, 1.0
    >>> while verdict is None:
    ...     t, d = t + d, d * 0.5
    ...     verdict = z.record("bounce", t)
    >>> round(verdict.accumulation_time, 6)
    2.0
    """

    def __init__(self, window: int, tol: float, time_resolution: float) -> None:
        self.window = window
        self.tol = tol
        self.time_resolution = time_resolution
        self._times: dict[str, deque[float]] = {}
        self._counts: dict[str, int] = {}

    def record(self, name: str, t: float) -> ZenoVerdict | None:
        times = self._times.setdefault(name, deque(maxlen=self.window + 1))
        times.append(t)
        self._counts[name] = self._counts.get(name, 0) + 1
        if len(times) < self.window + 1:
            return None
        dwell = np.diff(np.asarray(times))
        if np.any(dwell <= 0):
            return None
        ratios = dwell[1:] / dwell[:-1]
        if not (np.all(ratios < 1.0) and ratios.max() <= 1.5 * ratios.min()):
            return None
        r = float(np.mean(ratios[-3:]))
        remaining = dwell[-1] * r / (1.0 - r)
        scale = max(1.0, abs(t))
        if remaining <= self.tol * scale or dwell[-1] <= self.time_resolution * scale:
            return ZenoVerdict(name, self._counts[name], r, float(t + remaining))
        return None

    def restore(self, name: str, count: int, times: Sequence[float]) -> None:
        """Take up ``name``'s history from another run: ``count`` firings, the latest at
        ``times`` (the last ``window + 1`` are kept).

        Examples
        --------
        >>> z = ZenoTracker(window=6, tol=1e-6, time_resolution=1e-12)
        >>> z.restore("bounce", 12, [0.0, 1.0, 1.5])
        >>> z.estimate("bounce", 1.5)
        2.0
        """
        self._counts[name] = int(count)
        self._times[name] = deque((float(t) for t in times), maxlen=self.window + 1)

    def estimate(self, name: str, t: float) -> float:
        """The accumulation time of ``name``'s firings extrapolated from its last two dwell
        times (``t`` when they do not shrink or fewer than three firings are known).

        Examples
        --------
        >>> z = ZenoTracker(window=6, tol=1e-6, time_resolution=1e-12)
        >>> for t in (0.0, 1.0, 1.5):
        ...     _ = z.record("bounce", t)
        >>> z.estimate("bounce", 1.5)
        2.0
        """
        times: Sequence[float] = self._times.get(name, ())
        if len(times) < 3:
            return t
        d_prev, d_last = times[-2] - times[-3], times[-1] - times[-2]
        if not 0 < d_last < d_prev:
            return t
        r = d_last / d_prev
        return max(t, float(times[-1] + d_last * r / (1.0 - r)))
