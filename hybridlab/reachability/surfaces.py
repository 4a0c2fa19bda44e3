"""Steps of a discontinuous flow near the surface of a switching function.

A mode's flow may read the sign ``sigma_k`` of a linear switching function
``s_k = a z + b`` (Coulomb friction: ``sign(v)``), affinely: ``f = f0 + g sigma_k``. Where a
step's set lies on one side of the surface, ``sigma_k`` is that side's sign. Where it meets
the surface, the sign is not free in ``[-1, 1]``: Filippov's solutions use ``+1`` above,
``-1`` below, and on the surface the *equivalent control*
``sigma_eq = -(a f0) / (a g)`` that keeps ``a f = 0`` (:meth:`ModeSystem.equivalent_control`).
A free sign would let the friction act with either sign on every other state at once (a
held cart's friction of 17 N shaking its pendulum). For a set on the surface or on one side
of it (within ``_ON_SURFACE``), checked over a box around the start set and again over the
step's set ``H`` (every solution stays in ``H``), with ``ds_k/dt`` enclosed by the mean-value
form over the zonotopes (:class:`~hybridlab.reachability.meanvalue.MeanValue`):

* **Sliding**: on the surface, which attracts from both sides (``ds_k/dt < 0`` above with
  ``sigma_k = +1``, ``> 0`` below with ``sigma_k = -1``): every solution stays on it and
  follows the equivalent-control flow :meth:`ModeSystem.sliding` (unique there, by
  Filippov's theorem). A cart held by friction. At most one surface slides at a time.
* **Upper side**: no state far below, and ``ds_k/dt > 0`` below with ``sigma_k = -1``: no
  solution goes below the surface, so ``sigma_k`` is ``+1`` off it and the equivalent
  control on it, ``sigma_k`` in ``[max(-1, min sigma_eq), 1]`` with ``sigma_eq`` enclosed
  over the part of ``H`` on the surface (an a-posteriori check; widened and repeated when
  short). A cart breaking away: the friction's sign is ``+1`` or nearly so (its equivalent
  control reaches 1 at the break-away), not anything in ``[-1, 1]``. Likewise the lower side.

What a step rests on, beyond the mode's own step: a state off its surface by ``|s|`` reaches
it within ``tau = |s| / rate`` (``rate`` the approach's smallest speed over the box around
the start set), moving at most ``tau |f|`` meanwhile (``f`` with every sign free); from the
point ``w`` it reaches, its solution is the stepped flow's solution from ``w`` taken back by
the hitting time, within ``tau |g|`` of ``w`` (``g`` the stepped flow). So every solution
from ``P`` is one of the stepped flow from ``P`` bloated by ``tau (|f| + |g|)``, and the step
starts from that set. ``H`` and the end set are then cut to the side each surface keeps.
"""

from __future__ import annotations

import numpy as np

from hybridlab.reachability.linear import StepError
from hybridlab.reachability.meanvalue import MeanValue
from hybridlab.reachability.sets import Zonotope
from hybridlab.reachability.system import ModeSystem, Rows

__all__ = ["SurfaceSteps", "on_surface_tolerance", "signs_box"]

#: how near 0 a switching function must be over a set to count as on its surface or side
#: (relative to the function's scale); nearer states are bloated by their time to reach it
_ON_SURFACE = 1e-9
#: relative margin around a start set within which the approach speeds are bounded
_MARGIN = 1e-6
#: revisions of a step's plan (a slide that breaks away, an equivalent control widened)
_REVISIONS = 4


def on_surface_tolerance(switches: Rows, k: int, center: np.ndarray) -> float:
    """How near 0 the linear switching function ``k`` must be over a set centred at
    ``center`` for the set to count as on its surface or side (``_ON_SURFACE`` of its scale).

    Examples
    --------
    >>> import sympy as sp
    >>> v = sp.Symbol("v", real=True)
    >>> on_surface_tolerance(Rows([v - 2], [v]), 0, np.array([1.0]))
    4e-09
    """
    return _ON_SURFACE * (1.0 + abs(float(switches.b[k]))
                          + float(np.abs(switches.a[k]) @ np.abs(center)))


def signs_box(signs: np.ndarray) -> np.ndarray:
    """Ranges ``(n, 2)`` of the signs: ``+1``, ``-1``, or ``[-1, 1]`` where 0 (free).

    Examples
    --------
    >>> signs_box(np.array([1.0, 0.0, -1.0])).tolist()
    [[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0]]
    """
    return np.column_stack([np.where(signs == 0, -1.0, signs),
                            np.where(signs == 0, 1.0, signs)])


class SurfaceSteps:
    """The surface rules of :class:`~hybridlab.reachability.nonlinear.FlowStepper` (a mixin:
    the stepper provides the mode, its inputs and ``_step_with``).

    Examples
    --------
    >>> import hybridlab
    >>> from hybridlab.reachability.nonlinear import FlowStepper
    >>> from hybridlab.reachability.options import ReachOptions
    >>> from hybridlab.reachability.system import build_system
    >>> c = hybridlab.compile_model(hybridlab.loads_model('''
    ... name = "held"
    ... states = { v = 0.0, y = 1.0 }
    ... [modes.m]
    ... flow = { v = "y - 2*sign(v)", y = "-y - y*sign(v)" }
    ... [initial]
    ... mode = "m"
    ... '''))
    >>> stepper = FlowStepper(build_system(c, c.parameter_vector(), {}, {}), "m",
    ...                       ReachOptions())
    >>> P_next, H = stepper.step(Zonotope([0.0, 1.0], [[0.0], [0.1]]), 0.1)
    >>> bool(np.abs(H.bounds()[0]).max() < 1e-12)   # held: v stays 0
    True
    """

    mode: ModeSystem
    n_sigma: int
    input_lo: np.ndarray
    input_hi: np.ndarray
    _rates: MeanValue | None
    _equivalent: dict[int, MeanValue]
    #: the last end set of :meth:`_attractive_cut` and bounds ``(n_switches, 2)`` of its
    #: switching functions, tighter than its range where they approach an attracting surface
    _approach: tuple[Zonotope, np.ndarray] | None

    def _step_with(self, P: Zonotope, r: float, sig: np.ndarray, m: ModeSystem
                   ) -> tuple[Zonotope, Zonotope]:
        raise NotImplementedError  # the stepper's

    def _sigma_signs(self, Z: Zonotope) -> np.ndarray:
        raise NotImplementedError  # the stepper's

    def _settled(self, P: Zonotope, r: float, sig: np.ndarray, m: ModeSystem,
                 forced: np.ndarray | None = None) -> tuple[Zonotope, Zonotope, np.ndarray]:
        """A step of the flow ``m`` with each held sign kept where it holds over the step's
        set (one that breaks is freed and the step repeated; a ``forced`` range is kept,
        its caller having shown it); returns the ranges used."""
        sig = sig.copy()
        for _ in range(self.n_sigma + 1):
            P_next, H = self._step_with(P, r, sig, m)
            now = self._sigma_signs(H)
            held = sig[:, 0] == sig[:, 1]
            if forced is not None:
                held &= ~forced
            broken = held & (now != sig[:, 0])
            if not np.any(broken):
                return P_next, H, sig
            sig[broken] = (-1.0, 1.0)
        raise StepError("the signs of the switching functions did not settle")  # unreachable

    def _inputs(self, sig: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return np.r_[self.input_lo, sig[:, 0]], np.r_[self.input_hi, sig[:, 1]]

    def _attraction(self, Z: Zonotope, sig: np.ndarray, k: int
                    ) -> tuple[np.ndarray, np.ndarray]:
        """``(up, down)``: enclosures ``[lo, hi]`` of ``ds_k/dt`` over ``Z`` with the flow
        of the side ``s_k > 0`` (``sigma_k = +1``) and of the side ``s_k < 0``
        (``sigma_k = -1``), the other signs in their ranges ``sig``."""
        m = self.mode
        if self._rates is None:
            self._rates = MeanValue(m.lie_exprs(m.switches), m.zsyms, m.usyms)
        u_lo, u_hi = self._inputs(sig)
        idx = len(self.input_lo) + k
        u_lo[idx] = u_hi[idx] = 1.0
        up_lo, up_hi = self._rates(Z, u_lo, u_hi)
        u_lo[idx] = u_hi[idx] = -1.0
        down_lo, down_hi = self._rates(Z, u_lo, u_hi)
        return np.array([up_lo[k], up_hi[k]]), np.array([down_lo[k], down_hi[k]])

    def _equivalent_range(self, Z: Zonotope, sig: np.ndarray, k: int
                          ) -> tuple[float, float] | None:
        """The equivalent control of switch ``k`` over the part of ``Z`` on its surface
        (``None``: ``Z`` does not meet it)."""
        m = self.mode
        on = Z.intersect_slab(m.switches.a[k], -m.switches.b[k], -m.switches.b[k])
        if on is None:
            return None
        if k not in self._equivalent:
            expr = m.equivalent_control(k)
            if expr is None:  # planned only where the flow is affine in the sign
                raise StepError(f"switch {m.switches.texts[k]!r} has no equivalent control")
            self._equivalent[k] = MeanValue([expr], m.zsyms, m.usyms)
        lo, hi = self._equivalent[k](on, *self._inputs(sig))
        return float(lo[0]), float(hi[0])

    def _plan(self, P: Zonotope, around: Zonotope, rng: np.ndarray, sig: np.ndarray
              ) -> dict[int, float]:
        """Which rule each free switch follows: ``0`` sliding, ``+1``/``-1`` the side."""
        m = self.mode
        plan: dict[int, float] = {}
        for k in np.flatnonzero((sig[:, 0] < sig[:, 1]) & m.switches.linear).tolist():
            eps = on_surface_tolerance(m.switches, k, P.center)
            upper, lower = rng[k, 0] >= -eps, rng[k, 1] <= eps
            if not (upper or lower):
                continue
            up, down = self._attraction(around, sig, k)
            if upper and lower and up[1] < 0 < down[0] and 0.0 not in plan.values() \
                    and m.sliding(k) is not None:
                plan[k] = 0.0
            elif upper and down[0] > 0 and m.equivalent_control(k) is not None:
                plan[k] = 1.0
            elif lower and up[1] < 0 and m.equivalent_control(k) is not None:
                plan[k] = -1.0
        return plan

    def _start(self, P: Zonotope, around: Zonotope, rng: np.ndarray, sig: np.ndarray,
               plan: dict[int, float], flow: ModeSystem) -> Zonotope | None:
        """``P`` bloated by the way its states off their surfaces travel before reaching
        them (``None``: too far to tell)."""
        tau = 0.0
        for k, side in plan.items():
            up, down = self._attraction(around, sig, k)
            if side >= 0 and rng[k, 0] < 0:
                if not down[0] > 0:  # no approach speed known around P (NaN too)
                    return None
                tau += -rng[k, 0] / down[0]
            if side <= 0 and rng[k, 1] > 0:
                if not up[1] < 0:
                    return None
                tau += rng[k, 1] / -up[1]
        if tau == 0.0:
            return P
        box = around.bounds()
        lo = np.r_[box[:, 0], self.input_lo, -np.ones(self.n_sigma)]
        hi = np.r_[box[:, 1], self.input_hi, np.ones(self.n_sigma)]
        f_lo, f_hi = self.mode.flow_interval(lo, hi)
        g_lo, g_hi = flow.flow_interval(lo, hi)
        speed = (np.maximum(np.abs(f_lo), np.abs(f_hi))
                 + np.maximum(np.abs(g_lo), np.abs(g_hi)))
        with np.errstate(over="ignore", invalid="ignore"):
            bloat = np.nextafter(tau * speed * (1 + 1e-12), np.inf)
        margin = _MARGIN * (1.0 + np.abs(P.bounds()).max(axis=1))
        if not np.all(bloat <= margin):  # also false for a non-finite bloat
            return None
        return P.minkowski_sum(Zonotope(np.zeros(P.dim), np.diag(bloat)[:, bloat > 0]))

    def _surface_step(self, P: Zonotope, r: float, sig: np.ndarray
                      ) -> tuple[Zonotope, Zonotope] | None:
        """A step by the surface rules (module docstring), or ``None`` where none applies."""
        m = self.mode
        rng = m.switches.range(P)
        margin = _MARGIN * (1.0 + np.abs(P.bounds()).max(axis=1))
        around = P.minkowski_sum(Zonotope(np.zeros(P.dim), np.diag(margin)))
        plan = self._plan(P, around, rng, sig)
        ranges = sig.copy()
        for k, side in plan.items():
            if side != 0.0:
                eq = self._equivalent_range(around, sig, k)
                ranges[k] = _side_range(side, eq)
        for _ in range(_REVISIONS):
            if not plan:
                return None
            slide = next((k for k, side in plan.items() if side == 0.0), None)
            flow = self.mode if slide is None else m.sliding(slide)
            start = None if flow is None else self._start(P, around, rng, sig, plan, flow)
            if flow is None or start is None:
                return None
            forced = np.zeros(self.n_sigma, dtype=bool)
            forced[[k for k, side in plan.items() if side != 0.0]] = True
            try:
                P_next, H, used = self._settled(start, r, ranges, flow, forced)
            except StepError:
                return None
            revised = False
            for k, side in list(plan.items()):
                up, down = self._attraction(H, used, k)
                if side == 0.0 and not up[1] < 0 < down[0]:
                    # the slide ends within the step: perhaps a break-away to one side
                    side = 1.0 if down[0] > 0 else -1.0 if up[1] < 0 else 0.0
                    if side == 0.0:
                        return None
                    plan[k] = side
                    ranges[k] = _side_range(side, self._equivalent_range(around, sig, k))
                    revised = True
                elif side != 0.0:
                    if not (down[0] > 0 if side > 0 else up[1] < 0):
                        return None
                    need = _side_range(side, self._equivalent_range(H, used, k))
                    if need[0] < ranges[k, 0] or need[1] > ranges[k, 1]:
                        ranges[k] = _widened(ranges[k], need)
                        revised = True
            if revised:
                continue
            free = (used[:, 0] == -1.0) & (used[:, 1] == 1.0)
            free &= ~forced
            # a side's rule keeps its states from crossing (its rate, checked above, makes
            # the cut hold); where the surface attracts them from their side as well, they
            # come to rest on it: the same cut
            free[[k for k, side in plan.items() if side != 0.0]] = True
            return self._attractive_cut(P, P_next, H, used, free, r)
        return None

    def continued(self, stepped: Zonotope | None, P: Zonotope | None) -> None:
        """Say that the next step starts from ``P``: the end set ``stepped`` of the last
        step, reduced or cut to where solutions stay in the mode. The bounds its switching
        functions carry hold for every solution it holds, so they carry over to ``P``
        (:meth:`_attractive_cut`). Any other next start set starts afresh.
        """
        if self._approach is not None and self._approach[0] is stepped and P is not None:
            self._approach = (P, self._approach[1])
        else:
            self._approach = None

    def _attractive_cut(self, P: Zonotope, P_next: Zonotope, H: Zonotope,
                        sig: np.ndarray, free: np.ndarray, r: float
                        ) -> tuple[Zonotope, Zonotope]:
        """Keep each ``free`` switching function within its start range on the sides its
        surface attracts, and on the surface once both sides have reached it.

        If over ``H`` the flow with ``sigma_k = +1`` (the side ``s_k > 0``) has
        ``ds_k/dt <= up_hi <= 0``, no Filippov solution can rise above ``max(0, s_hi)`` of
        the start set: above the surface ``s_k`` does not increase, and from the surface it
        cannot enter that side; after ``r`` it is below ``max(0, s_hi + up_hi r)``, as a
        solution that stays above falls at least that fast. Likewise ``sigma_k = -1`` with
        ``ds_k/dt >= down_lo >= 0`` keeps ``s_k`` above ``min(0, s_lo)``, and above
        ``min(0, s_lo + down_lo r)`` at the end. Both together are sliding (a cart held by
        friction: ``v`` stays 0); one alone is a surface crossed in one direction only (a
        cart breaking away never moves backwards). ``H`` and ``P_next`` are cut to the
        half-spaces that hold (linear ``s_k`` only).

        The end bounds are carried from step to step while each step starts from the last
        one's end set. When both reach 0, every solution has come to rest on the surface (a
        cart still moving as its friction takes over), and ``P_next`` is cut to it, where
        the sliding rule takes over. Short of that the end set is cut to the start range
        only: a thin slab can cost more in the other directions than it gains.
        """
        m = self.mode
        cut = np.flatnonzero(free & m.switches.linear).tolist()
        if not cut:
            return P_next, H
        start = m.switches.range(P)
        approach = np.column_stack([np.full(len(start), -np.inf), np.full(len(start), np.inf)])
        if self._approach is not None and self._approach[0] is P:
            approach = self._approach[1]
        ends = np.column_stack([np.full(len(start), -np.inf), np.full(len(start), np.inf)])
        for k in cut:
            up, down = self._attraction(H, sig, k)
            attracts_above, attracts_below = up[1] <= 0, down[0] >= 0
            if not (attracts_above or attracts_below):
                continue
            a, b = m.switches.a[k], m.switches.b[k]
            hi = max(0.0, start[k, 1]) - b if attracts_above else np.inf  # a z + b <= ...
            lo = min(0.0, start[k, 0]) - b if attracts_below else -np.inf  # a z + b >= ...
            # None cannot happen for a sound H; the uncut set is kept then
            H = H.intersect_slab(a, lo, hi) or H
            if attracts_above:
                ends[k, 1] = _approached(min(start[k, 1], approach[k, 1]), up[1], r)
            if attracts_below:
                ends[k, 0] = -_approached(-max(start[k, 0], approach[k, 0]), -down[0], r)
            if ends[k, 0] == 0.0 == ends[k, 1]:
                lo = hi = -b  # every solution has come to rest on the surface
            P_next = P_next.intersect_slab(a, lo, hi) or P_next
        self._approach = (P_next, ends)
        return P_next, H


def _approached(s_hi: float, rate_hi: float, r: float) -> float:
    """An upper bound of ``max(0, s_hi + rate_hi r)`` (``rate_hi <= 0``), rounded up.

    Examples
    --------
    >>> 0.5 < _approached(1.0, -2.0, 0.25) < 0.5 + 1e-15
    True
    >>> _approached(1.0, -2.0, 1.0), _approached(-1.0, -2.0, 1.0)
    (0.0, 0.0)
    """
    if not s_hi > 0.0:
        return 0.0
    # two roundings, each within 2**-53 of |s_hi| + |rate_hi r|
    end = s_hi + rate_hi * r + 4e-16 * (s_hi - rate_hi * r)
    if not end > 0.0:
        return 0.0
    return float(np.nextafter(end, np.inf))


def _side_range(side: float, eq: tuple[float, float] | None) -> np.ndarray:
    """The sign's range on the upper (``+1``) or lower (``-1``) side: that side's value,
    and the equivalent control ``eq`` clipped to ``[-1, 1]`` where the set meets the
    surface."""
    if side > 0:
        lo = 1.0 if eq is None else eq[0] if eq[0] >= -1.0 else -1.0  # NaN: -1
        return np.array([min(lo, 1.0), 1.0])
    hi = -1.0 if eq is None else eq[1] if eq[1] <= 1.0 else 1.0      # NaN: +1
    return np.array([-1.0, max(hi, -1.0)])


def _widened(have: np.ndarray, need: np.ndarray) -> np.ndarray:
    """``have`` grown past ``need`` by a tenth of the gap (within ``[-1, 1]``)."""
    lo = min(have[0], need[0])
    hi = max(have[1], need[1])
    pad = 0.1 * (hi - lo) + 1e-12
    return np.array([max(-1.0, lo - pad if lo < have[0] else lo),
                     min(1.0, hi + pad if hi > have[1] else hi)])
