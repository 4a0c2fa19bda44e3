"""Stick and slip as phases of the analysis: a set that straddles a switching surface is
split there, and each part follows one side's flow, or the sliding flow on the surface.

A mode's flow ``f = f0 + g sigma_k`` may read the sign ``sigma_k`` of a linear switching
function ``s_k = a z + b`` (Coulomb friction: ``sign(v)``). Where a set lies on one side of
the surface, or on it, :mod:`~hybridlab.reachability.surfaces` steps it with the sign that
side (or Filippov's equivalent control) gives. A set *across* the surface has states on
both sides and possibly on it; one sign range for all of them is free in ``[-1, 1]``, which
acts on every state like an adversarial input (a cart whose velocity set straddles 0 gets
its 17 N friction with either sign, and its pendulum a torque it never has).

Filippov's solutions of such a flow are, piece by piece, solutions of three smooth flows
(for a surface that is not reached tangentially from both sides at once):

* **above** (``+1``): ``f0 + g`` while ``s_k >= 0``;
* **below** (``-1``): ``f0 - g`` while ``s_k <= 0``;
* **sliding** (``0``): on ``s_k = 0``, the equivalent-control flow
  :meth:`ModeSystem.sliding`, while the surface attracts from both sides, i.e.
  ``up = a (f0 + g) <= 0 <= down = a (f0 - g)``.

A solution above that reaches the surface continues sliding where ``down >= 0`` there, and
below where ``down <= 0`` (it crosses); likewise from below with ``up``. A sliding solution
leaves upwards when ``up`` reaches 0 and downwards when ``down`` does. These are the
*phases* of an analysis item; their changes are transitions of the hybrid layer with the
identity reset and the guards above, taken as "may" transitions over each step set (every
solution that changes phase does so at an instant where the guard holds on its state, which
lies in that step's set). A phase's steps are cut to its side (``s_k >= 0`` or ``<= 0``,
:meth:`Zonotope.intersect_slab`), and a sliding set to where the surface still attracts
(``up <= 0 <= down``); its flow keeps it on the surface (``a f = 0``). The rates ``up`` and
``down`` are enclosed by the second-order mean-value form over each set
(:meth:`MeanValue.linear_form`: the value and gradient at the centre, plus a bound of the
rest), with the other switches' signs in the ranges the set gives them; the same form cuts
the sets that change phase to the slab where the rate that decides it has the right sign
(a slide's exit states have that rate exactly 0).

An item is split when its set is *crossing* a linear switching surface that has an
equivalent control: it lies beyond it on both sides by more than the surface rules'
tolerance (:func:`~hybridlab.reachability.surfaces.on_surface_tolerance`; nearer sets are
theirs), the rest of the flow carries all of its states one way (``a f0`` has one sign over
the set, the other signs free), and the sign is strong: it moves the switching function
within one step by at least ``_STRONG`` of the set's extent across the surface. A set that
holds states pushed both ways holds a region where the friction can stop them; there a
sliding set's exits, with rates enclosed loosely, may go either way step after step and the
phases multiply instead of tightening, so such a set keeps the surface rules. Each part, and
each phase change, counts as a jump towards ``max_jumps``; at most ``MAX_PHASE_ITEMS`` items
of an analysis enter a phase. A phase survives a transition of the model when the target
mode has the same switching function and the reset keeps its variables.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import sympy as sp

from hybridlab.reachability.meanvalue import MeanValue
from hybridlab.reachability.rounding import SLACK, TINY
from hybridlab.reachability.sets import Zonotope
from hybridlab.reachability.surfaces import on_surface_tolerance
from hybridlab.reachability.system import ModeSystem, ResetMap, Rows, System
from hybridlab.symbolic.intervals import IntervalFunction

__all__ = ["MAX_PHASE_ITEMS", "Phase", "PhaseWatch", "Phases", "Step", "with_phase",
           "without_phase"]

Step = tuple[Zonotope, Zonotope, float, float]
"""One step of a flowpipe: its start set, its step set, and the step set's time interval."""

Phase = tuple[tuple[str, float], ...]
"""The phases of an item: ``(switching function's text, side)`` pairs, side ``+1`` above,
``-1`` below, ``0`` sliding on the surface; sorted by text."""

#: a straddled surface is split at when its sign moves the switching function, within one
#: step, by at least this fraction of the set's extent along the normal (a weak sign, such
#: as a light bearing friction, costs less free than the branches its phases would take)
_STRONG = 0.05
MAX_PHASE_ITEMS = 64
"""Items an analysis enters in a phase (splits and phase changes together); beyond, no set
is split, and a set that changes phase continues with the sign free again: a sound bound on
the branches a sliding set's exits may take where its rates are not known sharply."""


def _switch_index(mode: ModeSystem, text: str) -> int:
    return mode.switches.texts.index(text)


@dataclass
class Phases:
    """The phase rules of one analysis (caches per mode and phase).

    Examples
    --------
    A block of unit mass under the force ``1 - 4 t`` against friction ``2 sign(v)``, from
    velocities on both sides of rest: the set is split at ``v = 0``, and the part above
    brakes at ``-1 - 4 t`` (not anything in ``[-3, 1]``).

    >>> import hybridlab
    >>> from hybridlab.reachability.system import build_system
    >>> c = hybridlab.compile_model(hybridlab.loads_model('''
    ... name = "block"
    ... states = { v = 0.0 }
    ... [modes.m]
    ... flow = { v = "1 - 4*t - 2*sign(v)" }
    ... [initial]
    ... mode = "m"
    ... '''))
    >>> phases = Phases(build_system(c, c.parameter_vector(), {}, {}))
    >>> P = Zonotope([0.0, 0.0], [[0.1], [0.0]])            # v in [-0.1, 0.1] at t = 0
    >>> phases.straddled("m", (), P, step=0.1)
    'sign(v)'
    >>> up, down = phases.split("m", "sign(v)", P)
    >>> up.bounds()[0].round(9).tolist(), down.bounds()[0].round(9).tolist()
    ([-0.0, 0.1], [-0.1, 0.0])
    >>> phases.flow("m", (("sign(v)", 1.0),)).flow[0]
    -4*t - 1
    """

    system: System
    _flows: dict[tuple[str, Phase], ModeSystem] = field(default_factory=dict, repr=False)
    _rates: dict[str, MeanValue] = field(default_factory=dict, repr=False)
    _gains: dict[tuple[str, int], IntervalFunction | None] = field(default_factory=dict,
                                                                   repr=False)
    _drifts: dict[tuple[str, int], MeanValue] = field(default_factory=dict, repr=False)

    def flow(self, mode: str, phase: Phase) -> ModeSystem:
        """The mode's flow in ``phase``: each side's sign substituted, or the sliding flow,
        with each side's row ``+-s_k >= 0`` added to the invariant."""
        key = (mode, phase)
        if key not in self._flows:
            self._flows[key] = self._phase_flow(self.system.modes[mode], phase)
        return self._flows[key]

    def _phase_flow(self, m: ModeSystem, phase: Phase) -> ModeSystem:
        flow, rows, texts = m.flow, list(m.invariants.exprs), list(m.invariants.texts)
        names = []
        for text, side in phase:
            k = _switch_index(m, text)
            if side == 0:
                slide = _with_flow(m, flow).sliding(k)
                if slide is None:  # straddled() offers only switches that have one
                    raise ValueError(f"switch {text!r} has no sliding flow")
                flow = slide.flow
                names.append(f"{text} = 0")
            else:
                sigma = m.usyms[m.sigma_index[k]]
                flow = tuple(e.xreplace({sigma: sp.Integer(int(side))}) for e in flow)
                rows.append(side * m.switches.exprs[k])
                texts.append(f"{text} {'>' if side > 0 else '<'}= 0")
                names.append(texts[-1])
        return ModeSystem(name=f"{m.name} [{', '.join(names)}]", flow=flow, zsyms=m.zsyms,
                          usyms=m.usyms, switches=m.switches, sigma_index=m.sigma_index,
                          invariants=Rows(rows, m.zsyms, texts), derivatives=m.derivatives)

    def straddled(self, mode: str, phase: Phase, P: Zonotope, step: float) -> str | None:
        """The first switching function (its text) that ``P`` is crossing and that is split
        at: linear, with an equivalent control, not yet a phase, its drift ``a f0`` of one
        sign over ``P``, and strong: its sign moves it within a ``step`` by ``_STRONG`` of
        ``P``'s extent across it; else ``None``."""
        m = self.system.modes[mode]
        if not m.switches.size:
            return None
        taken = {text for text, _ in phase}
        rng = m.switches.range(P)
        box = None
        for k in np.flatnonzero(m.switches.linear).tolist():
            text = m.switches.texts[k]
            lo, hi = rng[k]
            margin = on_surface_tolerance(m.switches, k, P.center)
            if text in taken or not (lo < -margin and hi > margin):
                continue
            gain = self._gain(mode, k)
            if gain is None:
                continue
            box = P.bounds() if box is None else box
            g_lo, g_hi = gain(box[:, 0], box[:, 1])
            if max(abs(g_lo[0]), abs(g_hi[0])) * step < _STRONG * (hi - lo):
                continue
            drift_lo, drift_hi = self._drift(mode, k)(P, *self.system.input_box(mode))
            if drift_lo[0] > 0 or drift_hi[0] < 0:
                return text
        return None

    def _drift(self, mode: str, k: int) -> MeanValue:
        """``a f0``: the rate of ``s_k`` without its sign (the other signs free)."""
        if (mode, k) not in self._drifts:
            parts = self.system.modes[mode]._surface_parts(k)
            if parts is None:  # _gain is None then, and this is not asked for
                raise ValueError(f"switch {k} of mode {mode!r} has no equivalent control")
            m = self.system.modes[mode]
            self._drifts[(mode, k)] = MeanValue([parts[2]], m.zsyms, m.usyms,
                                                     second_order=True)
        return self._drifts[(mode, k)]

    def _gain(self, mode: str, k: int) -> IntervalFunction | None:
        """Interval enclosure of ``a g``, the sign's effect on ``ds_k/dt`` (``None``: no
        equivalent control)."""
        if (mode, k) not in self._gains:
            parts = self.system.modes[mode]._surface_parts(k)
            self._gains[(mode, k)] = (None if parts is None else
                                      IntervalFunction([parts[3]], self.system.zsyms))
        return self._gains[(mode, k)]

    def split(self, mode: str, text: str, P: Zonotope
              ) -> tuple[Zonotope | None, Zonotope | None]:
        """``P`` cut to the sides ``s_k >= 0`` and ``s_k <= 0`` of switch ``text``."""
        return (self.to_sides(mode, ((text, 1.0),), P),
                self.to_sides(mode, ((text, -1.0),), P))

    def to_sides(self, mode: str, phase: Phase, Z: Zonotope | None) -> Zonotope | None:
        """``Z`` cut to the side of each switching surface ``phase`` is above or below
        (:meth:`Zonotope.intersect_slab`, exact along the normal; ``None``: empty)."""
        m = self.system.modes[mode]
        for text, side in phase:
            if Z is None or side == 0:
                continue
            k = _switch_index(m, text)
            a, b = m.switches.a[k], m.switches.b[k]
            Z = Z.intersect_slab(a, -b, np.inf) if side > 0 else \
                Z.intersect_slab(a, -np.inf, -b)
        return Z

    def on_surface(self, mode: str, text: str, Z: Zonotope) -> Zonotope | None:
        """``Z`` cut to the surface of switch ``text`` (``None``: they do not meet)."""
        m = self.system.modes[mode]
        k = _switch_index(m, text)
        return Z.intersect_slab(m.switches.a[k], -m.switches.b[k], -m.switches.b[k])

    def _rate_inputs(self, mode: str, text: str, signs: np.ndarray, side: float
                     ) -> tuple[MeanValue, int, np.ndarray, np.ndarray]:
        """The mode's rates of its switching functions (built once), the index of switch
        ``text``, and the input box with its sign on ``side`` and the others in ``signs``."""
        m = self.system.modes[mode]
        k = _switch_index(m, text)
        if mode not in self._rates:
            self._rates[mode] = MeanValue(m.lie_exprs(m.switches), m.zsyms, m.usyms,
                                          second_order=True)
        n_in = len(m.usyms) - len(m.sigma_index)
        lo_in, hi_in = self.system.input_box(mode)
        u_lo = np.r_[lo_in[:n_in], signs[:, 0]]
        u_hi = np.r_[hi_in[:n_in], signs[:, 1]]
        u_lo[n_in + k] = u_hi[n_in + k] = side
        return self._rates[mode], k, u_lo, u_hi

    def rates(self, mode: str, text: str, Z: Zonotope, signs: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:
        """``(up, down)``: enclosures of ``ds/dt`` over ``Z`` with the flow above
        (``sigma = +1``) and below (``sigma = -1``) the surface of switch ``text``, the
        other signs in ``signs`` (``(n_sigma, 2)`` ranges)."""
        out = []
        for side in (1.0, -1.0):
            rate, k, u_lo, u_hi = self._rate_inputs(mode, text, signs, side)
            lo, hi = rate(Z, u_lo, u_hi)
            out.append(np.array([lo[k], hi[k]]))
        return out[0], out[1]

    def where_rate(self, mode: str, text: str, Z: Zonotope | None, signs: np.ndarray,
                   side: float, lo: float, hi: float) -> Zonotope | None:
        """``Z`` cut to the states where the rate of switch ``text`` on ``side``
        (``up`` for ``+1``, ``down`` for ``-1``) may lie in ``[lo, hi]`` (one bound may be
        infinite): the rate's linear form at the centre, widened by the bound of the rest
        (:meth:`MeanValue.linear_form`), is a slab that holds every such state. ``Z``
        itself where no form is found; ``None`` where no state qualifies."""
        if Z is None:
            return None
        rate, k, u_lo, u_hi = self._rate_inputs(mode, text, signs, side)
        form = rate.linear_form(Z, u_lo, u_hi)
        if form is None:
            return Z
        v_lo, v_hi, grad, slack = form
        g = grad[k]
        at_c = float(g @ Z.center)
        # rate(z) in [v_lo - slack, v_hi + slack] + g . (z - c)
        g_lo = lo - float(v_hi[k]) - float(slack[k]) + at_c if np.isfinite(lo) else -np.inf
        g_hi = hi - float(v_lo[k]) + float(slack[k]) + at_c if np.isfinite(hi) else np.inf
        pad = SLACK * (abs(at_c) + float(np.abs(g) @ np.abs(Z.center)) + TINY)
        if not np.any(g):
            return Z if g_lo - pad <= 0 <= g_hi + pad or not (np.isfinite(g_lo) or
                                                            np.isfinite(g_hi)) else None
        return Z.intersect_slab(g, g_lo - pad, g_hi + pad)

    def carried(self, phase: Phase, target: str, reset: ResetMap) -> Phase:
        """The phases that survive a jump to ``target`` through ``reset``: the target has
        the same switching function and the reset keeps every variable it reads."""
        if not phase:
            return ()
        m = self.system.modes[target]
        kept = []
        for text, side in phase:
            if text not in m.switches.texts:
                continue
            k = _switch_index(m, text)
            reads = np.flatnonzero(m.switches.a[k]).tolist()
            if m.switches.linear[k] and all(reset.exprs[j] == m.zsyms[j] for j in reads):
                kept.append((text, side))
        return tuple(kept)


class PhaseWatch:
    """The phase changes of one item's flowpipe: for each switching surface it is on a side
    of, the run of steps that may reach the surface; on the surface, the runs that may
    leave it upwards and downwards. Each run that ends is handed to ``jump(text, side, to,
    run)`` (``to``: the side a slide leaves to; ``None``: whatever may follow a solution
    reaching the surface from ``side``).

    A side's run starts only once the flow may move towards the surface: an item entered
    on it (just come off the surface) moving strictly away is *leaving*, as a guard is.

    Examples
    --------
    The friction oscillator (``v' = -4 x - 0.5 sign(v)``) above ``v = 0`` at ``x = 1``,
    braking: its second step set reaches the surface, and the run of that one step is handed
    over when the flowpipe ends.

    >>> import hybridlab
    >>> from hybridlab.reachability.system import build_system
    >>> c = hybridlab.compile_model(hybridlab.load_model("models/friction_oscillator.toml"))
    >>> phases = Phases(build_system(c, c.parameter_vector(), {}, {}))
    >>> runs = []
    >>> watch = PhaseWatch(phases, "move", (("sign(v)", 1.0),), Zonotope([1.0, 0.5], [[0], [0.1]]),
    ...                    lambda Z: np.array([[1.0, 1.0]]), lambda *jump: runs.append(jump))
    >>> for v in (0.4, 0.1):   # step sets with v in [0.3, 0.5], then [0.0, 0.2]
    ...     H = Zonotope([1.0, v], [[0.0], [0.1]])
    ...     _ = watch.step(H, H, H, H, 0.0, 0.1)
    >>> watch.flush()
    >>> [(text, side, to, len(run)) for text, side, to, run in runs]
    [('sign(v)', 1.0, None, 1)]
    """

    def __init__(self, phases: Phases, mode: str, phase: Phase, entry: Zonotope,
                 sign_ranges: Callable[[Zonotope], np.ndarray],
                 jump: Callable[[str, float, float | None, list[Step]], None]) -> None:
        m = phases.system.modes[mode]
        self.phases, self.mode, self.phase, self.switches = phases, mode, phase, m.switches
        self.sign_ranges, self.jump = sign_ranges, jump
        self.index = {text: m.switches.texts.index(text) for text, _ in phase}
        self.runs: dict[tuple[str, float | None], list[Step]] = {}
        rng = m.switches.range(entry) if phase else np.zeros((0, 2))
        self.leaving = {text for text, side in phase if side != 0
                        and side * rng[self.index[text]][0 if side > 0 else 1] <= 0}

    def _rates(self, text: str, Z: Zonotope) -> tuple[np.ndarray, np.ndarray]:
        return self.phases.rates(self.mode, text, Z, self.sign_ranges(Z))

    def step(self, P: Zonotope, H: Zonotope, reaching: Zonotope | None,
             P_next: Zonotope | None, t0: float, t1: float) -> bool:
        """Watch one step from ``P``, its set ``H`` over ``[t0, t1]`` (``reaching``: the
        same before the cut to the item's sides, where the flow may cross a surface);
        ``True`` when every solution has left the flowpipe's phase by the step's end
        ``P_next``."""
        gone = False
        for text, side in self.phase:
            if side == 0:
                up, down = self._rates(text, H)
                self._run(text, 1.0, bool(up[1] >= 0), (P, H, t0, t1))
                self._run(text, -1.0, bool(down[0] <= 0), (P, H, t0, t1))
                if P_next is not None:
                    up, down = self._rates(text, P_next)
                    gone |= bool(up[0] > 0 or down[1] < 0)
                continue
            lo, hi = self.switches.range(reaching if reaching is not None else H)[
                self.index[text]]
            may = bool(lo <= 0 if side > 0 else hi >= 0)
            if may and text in self.leaving:
                up, down = self._rates(text, H)
                if (up[0] > 0) if side > 0 else (down[1] < 0):
                    may = False
                else:
                    self.leaving.discard(text)
            elif text in self.leaving:
                self.leaving.discard(text)
            self._run(text, None, may, (P, H, t0, t1))
        return gone

    def _run(self, text: str, to: float | None, may: bool, step: Step) -> None:
        run = self.runs.setdefault((text, to), [])
        if may:
            run.append(step)
        elif run:
            self.jump(text, dict(self.phase)[text], to, run)
            self.runs[(text, to)] = []

    def flush(self) -> None:
        """Hand over the runs still open when the flowpipe ends."""
        for (text, to), run in self.runs.items():
            if run:
                self.jump(text, dict(self.phase)[text], to, run)
        self.runs.clear()


def _with_flow(m: ModeSystem, flow: tuple[sp.Expr, ...]) -> ModeSystem:
    if flow is m.flow:
        return m
    return ModeSystem(name=m.name, flow=flow, zsyms=m.zsyms, usyms=m.usyms,
                      switches=m.switches, sigma_index=m.sigma_index, invariants=m.invariants,
                      derivatives=m.derivatives)


def with_phase(phase: Phase, text: str, side: float) -> Phase:
    """``phase`` with switch ``text`` on ``side`` (replacing its former side).

    Examples
    --------
    >>> with_phase((("v", 1.0),), "v", 0.0), with_phase((), "w", -1.0)
    ((('v', 0.0),), (('w', -1.0),))
    """
    return tuple(sorted([p for p in phase if p[0] != text] + [(text, float(side))]))


def without_phase(phase: Phase, text: str) -> Phase:
    """``phase`` without switch ``text`` (its sign an input again).

    Examples
    --------
    >>> without_phase((("v", 0.0), ("w", 1.0)), "v")
    (('w', 1.0),)
    """
    return tuple(p for p in phase if p[0] != text)
