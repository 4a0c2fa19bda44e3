"""The margin of a spec along one simulated run: its lowest value and first violation.

A run is sampled once (:func:`sample_trajectory`): on each flow segment, its stored
points and three interior points of every integrator step, on the segment's dense
output. Every spec is then evaluated on all samples of a mode in one vectorised call
(:func:`trajectory_margin`), the lowest interior dips of the whole run are refined by
bounded minimisation, and the first violation is located by Brent's method on the
dense output of the segment where it happens. A run with thousands of jumps costs a few
array operations per spec, not a loop over its segments.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from hybridlab.reachability.spec import Spec
from hybridlab.simulation.result import SimulationResult
from hybridlab.simulation.tables import Segment
from hybridlab.symbolic.functions import VectorFunction

__all__ = ["SpecMargin", "TrajectorySamples", "sample_trajectory", "trajectory_margin"]

_EMPTY = np.empty(0)
_INTERIOR = (0.25, 0.5, 0.75)  # extra dense points per integrator step
_REFINED = 3  # interior dips refined by minimisation, per spec and run


@dataclass(frozen=True)
class SpecMargin:
    """The lowest margin of one spec along one run.

    ``margin`` is reached at ``t`` in ``mode``; ``violation_t``, ``violation_mode`` and
    ``violation_state`` give the first violation (``None`` when the run has none).
    See :func:`trajectory_margin`.

    Examples
    --------
    >>> m = SpecMargin("v >= -15", 0.992859, 1.427843, "fall")  # lowest at the bounce
    >>> m.margin > 0, m.violation_t is None  # the spec holds along the whole run
    (True, True)
    """

    spec: str
    margin: float
    t: float
    mode: str | None
    violation_t: float | None = None
    violation_mode: str | None = None
    violation_state: np.ndarray | None = field(default=None, repr=False)


@dataclass(frozen=True)
class TrajectorySamples:
    """A run sampled for margins (see :func:`sample_trajectory`).

    Attributes
    ----------
    segments : sequence of Segment
        The run's flow segments.
    start : ndarray
        Segment ``k``'s samples are ``t[start[k]:start[k + 1]]``.
    t, x : ndarray
        All samples' times and states (``x`` has shape ``(n, len(t))``), segment after
        segment.
    mode_of : ndarray
        Each sample's mode, as an index into ``modes``.
    modes : tuple of str

    Examples
    --------
    >>> import hybridlab
    >>> result = hybridlab.simulate("models/bouncing_ball.toml", t_end=2.0)
    >>> samples = sample_trajectory(result)
    >>> len(samples.segments), samples.x.shape[1] == samples.t.size, samples.modes
    (2, True, ('fall',))
    """

    segments: Sequence[Segment]
    start: np.ndarray
    t: np.ndarray
    x: np.ndarray
    mode_of: np.ndarray
    modes: tuple[str, ...]


def sample_trajectory(result: SimulationResult) -> TrajectorySamples:
    """Sample every flow segment of ``result`` at its stored points and at three interior
    points of each integrator step.

    Examples
    --------
    >>> import hybridlab
    >>> result = hybridlab.simulate("models/bouncing_ball.toml", t_end=1.0)
    >>> samples = sample_trajectory(result)
    >>> bool(np.all(np.diff(samples.t) >= 0)), float(samples.t[0]), float(samples.t[-1])
    (True, 0.0, 1.0)
    """
    table = result.segments
    n = len(result.state_names)
    if len(table) == 0:
        return TrajectorySamples(table, np.zeros(1, dtype=np.int64), np.empty(0),
                                 np.empty((n, 0)), np.empty(0, dtype=np.int64), ())
    points = table.t
    owner = np.repeat(np.arange(len(table)), table.n_points)  # each stored point's segment
    pair = np.flatnonzero(owner[1:] == owner[:-1])            # the steps inside segments
    h = points[pair + 1] - points[pair]
    t = np.concatenate([points, *(points[pair] + c * h for c in _INTERIOR)])
    which = np.concatenate([owner, *([owner[pair]] * len(_INTERIOR))])
    order = np.lexsort((t, which))
    t, which = t[order], which[order]
    x = table.dense(which, t).reshape(n, t.size)
    names, codes = np.unique(np.array(table.mode), return_inverse=True)
    start = np.concatenate([[0], np.cumsum(np.bincount(which, minlength=len(table)))])
    return TrajectorySamples(table, start, t, x, codes[which], tuple(names.tolist()))


def trajectory_margin(result: SimulationResult, spec: Spec, fn: Mapping[str, VectorFunction],
                      p: np.ndarray, samples: TrajectorySamples | None = None) -> SpecMargin:
    """The lowest margin of ``spec`` along ``result`` and its first violation.

    Parameters
    ----------
    result : SimulationResult
    spec : Spec
    fn : mapping of mode to VectorFunction
        The spec's rows compiled per mode (``(t, x, p, ())`` functions).
    p : numpy.ndarray
        The run's parameter vector.
    samples : TrajectorySamples, optional
        ``sample_trajectory(result)``, when several specs are measured on one run.

    Returns
    -------
    SpecMargin

    Examples
    --------
    The ball dropped from 10 m reaches ``v = -12`` at ``t = 12 / 9.81``, and
    ``-sqrt(2 g 10) = -14.007`` at the bounce:

    >>> from dataclasses import replace
    >>> from hybridlab.model.checks import TIME
    >>> from hybridlab.reachability.falsify import run_point
    >>> from hybridlab.reachability.spec import parse_spec
    >>> from hybridlab.simulation.problem import HybridProblem
    >>> pb = HybridProblem.build("models/bouncing_ball.toml", t_end=2.0)
    >>> spec, sym = parse_spec("v >= -12", pb.compiled), pb.compiled.symbolic
    >>> fn = {mode: VectorFunction(rows, TIME, sym.states, sym.parameters, ())
    ...       for mode, rows in spec.rows.items()}
    >>> result = run_point(pb, pb.x0, pb.p0, replace(pb.options, backend="reference"))
    >>> m = trajectory_margin(result, spec, fn, pb.p0)
    >>> round(m.margin, 6), round(m.violation_t, 9), m.violation_mode
    (-2.007141, 1.22324159, 'fall')
    """
    s = samples if samples is not None else sample_trajectory(result)
    values = np.full(s.t.size, np.inf)
    for code, mode in enumerate(s.modes):
        if mode in fn:
            at = np.flatnonzero(s.mode_of == code)
            values[at] = spec.margin(fn[mode].batch(s.t[at], s.x[:, at], p, _EMPTY))
    best = SpecMargin(spec.text, math.inf, math.nan, None)
    if not np.any(np.isfinite(values)):
        return best
    which = np.repeat(np.arange(len(s.segments)), np.diff(s.start))  # each sample's segment

    def margin_at(k: int) -> Callable[[float], float]:
        seg, f = s.segments[k], fn[s.segments[k].mode]

        def at(t: float) -> float:
            return float(spec.margin(f(float(t), seg(float(t)), p, _EMPTY)[:, None])[0])

        return at

    # the lowest interior dips of the run, refined on their segments' dense output
    interior = np.ones(s.t.size, dtype=bool)
    interior[s.start[:-1]] = False
    interior[s.start[1:] - 1] = False
    inner = np.flatnonzero(interior)
    dips = inner[(values[inner] <= values[inner - 1]) & (values[inner] <= values[inner + 1])
                 & np.isfinite(values[inner])]
    refined: list[tuple[int, float, float]] = []  # (segment, t, margin)
    for i in dips[np.argsort(values[dips], kind="stable")][:_REFINED]:
        lo, hi = float(s.t[i - 1]), float(s.t[i + 1])
        if not hi > lo:
            continue
        t_min, v_min = _minimum(margin_at(int(which[i])), lo, hi)
        if np.isfinite(v_min):
            refined.append((int(which[i]), t_min, v_min))
    k = int(np.argmin(values))
    best = replace(best, margin=float(values[k]), t=float(s.t[k]), mode=s.segments[which[k]].mode)
    for seg_k, t_min, v_min in refined:
        if v_min < best.margin:
            best = replace(best, margin=v_min, t=t_min, mode=s.segments[seg_k].mode)
    # the first violation: the first segment with a violating sample or refined dip
    bad = np.flatnonzero(spec.violated(values))
    first = int(which[bad[0]]) if bad.size else len(s.segments)
    for seg_k, _, v_min in refined:
        if spec.violated(v_min) and seg_k < first:
            first = seg_k
    if first == len(s.segments):
        return best
    a, b = int(s.start[first]), int(s.start[first + 1])
    ts, vs = s.t[a:b], values[a:b]
    cand = [float(t) for t in ts[spec.violated(vs)]]
    cand += [t for seg_k, t, v in refined if seg_k == first and spec.violated(v)]
    t_v = _first_violation(spec, ts, vs, min(cand), margin_at(first))
    seg = s.segments[first]
    return replace(best, violation_t=t_v, violation_mode=seg.mode,
                   violation_state=np.asarray(seg(t_v), dtype=float))


def _minimum(fn: Callable[[float], float], lo: float, hi: float) -> tuple[float, float]:
    """Bounded scalar minimisation of ``fn`` on ``[lo, hi]``."""
    from scipy import optimize

    res = optimize.minimize_scalar(fn, bounds=(lo, hi), method="bounded",
                                   options={"xatol": 1e-12 * max(1.0, abs(lo))})
    return float(res.x), float(res.fun)


def _first_violation(spec: Spec, ts: np.ndarray, values: np.ndarray, t_bad: float,
                     margin_at: Callable[[float], float]) -> float:
    """The first instant the margin becomes violating, at or before ``t_bad``."""
    ok = np.flatnonzero((ts < t_bad) & ~spec.violated(values))
    if ok.size == 0 or spec.violated(values[0]):
        return float(ts[0])
    # the last good grid point before t_bad; between it and t_bad the margin crosses zero
    lo = float(ts[ok[-1]])
    hi_candidates = ts[(ts > lo) & (ts <= t_bad) & spec.violated(values)]
    hi = float(hi_candidates[0]) if hi_candidates.size else t_bad
    if margin_at(lo) == 0.0:
        return lo
    try:
        from scipy import optimize

        return float(optimize.brentq(margin_at, lo, hi, xtol=1e-14, rtol=4 * np.finfo(float).eps,
                                     maxiter=200))
    except ValueError:  # no sign change (a touch at zero for a strict spec)
        return hi
