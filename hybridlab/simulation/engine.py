"""The reference simulation engine: scipy steppers driven one step at a time.

Semantics are specified in ``docs/semantics.md``; in short:

* transitions are urgent: one fires at the first instant its guard holds;
  event times are located on the dense output of each step;
* every guard, invariant and switching function is a *monitor* examined at
  adaptively refined interior points of each step (see
  :mod:`hybridlab.simulation.location`), so crossings in pairs are not missed;
* at an event instant the enabled transition with the best priority fires,
  then the guards are evaluated again in the new state (event iteration),
  at most ``max_event_iterations`` times;
* a transition that just fired cannot fire again at the same instant, and a
  guard that holds only on its boundary while the flow leaves it is not taken;
* discontinuities of a flow (sign, abs, min, max) are switching surfaces with
  Filippov sliding; scheduled transitions fire at exact times.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from scipy import integrate

from hybridlab.errors import SimulationError, ZenoError
from hybridlab.simulation import rules
from hybridlab.simulation.interpolant import dense_slope
from hybridlab.simulation.location import (
    Trigger,
    first_trigger,
    hermite_extremes,
    sample_step,
)
from hybridlab.simulation.options import SimulationOptions
from hybridlab.simulation.result import (
    Event,
    FinalState,
    Segment,
    SimulationResult,
    SimulationStats,
    Status,
)
from hybridlab.simulation.sliding import equivalent_sigma, equivalent_sigma_batch, resolve_switches
from hybridlab.simulation.tables import EventTable, SegmentTable
from hybridlab.simulation.zeno import ZenoTracker
from hybridlab.symbolic.compile import CompiledMode, CompiledModel, CompiledTransition

__all__ = ["run", "resume", "Checkpoint"]

_SOLVERS = {
    "RK45": integrate.RK45, "RK23": integrate.RK23, "DOP853": integrate.DOP853,
    "Radau": integrate.Radau, "BDF": integrate.BDF, "LSODA": integrate.LSODA,
}
_NO_SIGMA = np.empty(0)


@dataclass(frozen=True)
class Checkpoint:
    """A run stopped part-way: everything :func:`resume` needs to continue it.

    The compiled backend hands a run it cannot finish (an invariant violated at a
    mode's entry, a zero-dwell cascade, a failed step, non-affine sliding) to the
    reference engine as one of these.

    Attributes
    ----------
    t, x, mode
        Where the run stands.
    entry
        ``"iterate"``: at an event iteration without fresh guards (the mode's signs
        already entered); ``"handle"``: a flow segment just ended on ``triggers``;
        ``"flow"``: about to flow from ``(t, x)``.
    jumps
        The hybrid time's jump counter ``j``.
    events, segments
        The run's record so far.
    sigma, sliding
        The signs of the mode's switching functions (empty when it has none) and
        the indices of those it slides on.
    schedules_done
        The index of the last instant fired, by scheduled transition index.
    last_step
        The integrator's last step size (``None``: choose afresh).
    zeno_history
        Per Zeno key (a transition's name, or ``"switch:..."``): how many times it
        fired and its most recent firing times.
    stats
        Counters carried on (``steps``, ``refinements``, ``events_located``,
        ``quiet_steps``).
    triggers
        The monitors that ended the last flow segment (``entry="handle"``).

    Examples
    --------
    Stop a bouncing ball at t = 2 and continue it to t = 5; the impacts are those of one
    run to t = 5:

    >>> import hybridlab
    >>> from hybridlab.simulation.options import SimulationOptions
    >>> compiled = hybridlab.compile_model(hybridlab.load_model("models/bouncing_ball.toml"))
    >>> first = run(compiled, t0=0.0, x0=compiled.state_vector(), mode="fall", t_end=2.0,
    ...             p=compiled.parameter_vector(), options=SimulationOptions())
    >>> here = Checkpoint(t=first.final.t, x=list(first.final.state.values()), mode="fall",
    ...                   entry="flow", jumps=first.final.j, events=list(first.events),
    ...                   segments=[])
    >>> rest = resume(compiled, here, p=compiled.parameter_vector(),
    ...               options=SimulationOptions(), t_end=5.0)
    >>> rest.final.j, [round(e.t, 6) for e in rest.events]
    (2, [1.427843, 3.712392])
    """

    t: float
    x: Sequence[float] | np.ndarray
    mode: str
    entry: Literal["iterate", "handle", "flow"]
    jumps: int
    events: Sequence[Event]
    segments: Sequence[Segment]
    sigma: np.ndarray = field(default_factory=lambda: _NO_SIGMA)
    sliding: tuple[int, ...] = ()
    schedules_done: Mapping[int, int] = field(default_factory=dict)
    last_step: float | None = None
    zeno_history: Mapping[str, tuple[int, Sequence[float]]] = field(default_factory=dict)
    stats: Mapping[str, int] = field(default_factory=dict)
    triggers: Sequence[Trigger] = ()


def _no_conditions(mode: CompiledMode) -> RuntimeError:
    """The error for a guard or invariant monitor of a mode without conditions (monitors()
    makes those rows only for a mode with a guard or an invariant, so never raised)."""
    return RuntimeError(f"mode {mode.name!r}: a guard or invariant monitor, but no conditions")


@dataclass(frozen=True)
class _Monitor:
    """What a monitor row watches: a guard, an invariant, a switch or a sliding exit."""

    kind: str
    ref: int


@dataclass
class _Stop(Exception):
    status: Status
    message: str
    zeno_time: float | None = None


@dataclass
class _Pieces:
    """The growing segment: stored points and one interpolant per step."""

    mode: str
    j: int
    t: list[float] = field(default_factory=list)
    y: list[np.ndarray] = field(default_factory=list)
    dense: list[object] = field(default_factory=list)

    def freeze(self) -> Segment:
        return Segment(self.mode, self.j, np.asarray(self.t, dtype=float),
                       np.column_stack(self.y), tuple(self.dense))


class _Run:
    def __init__(self, compiled: CompiledModel, p: np.ndarray, options: SimulationOptions,
                 t_end: float, deadline: int | None = None) -> None:
        self.c = compiled
        #: the wall-clock deadline in ``time.monotonic_ns()`` (``None``: no limit)
        self.deadline = deadline if deadline is not None else deadline_of(options)
        self.p = p
        self.o = options
        self.t_end = t_end
        self.names = compiled.state_names
        self.events: list[Event] = []
        self.segments: list[Segment] = []
        self.j = 0
        self.sigma = _NO_SIGMA
        self.sliding: tuple[int, ...] = ()
        self.sched_done: dict[int, int] = {}
        # (period, phase) of every enabled schedule, evaluated for this run's parameters
        self.schedules = {tr.index: sched for tr in compiled.transitions
                          if (sched := tr.period_and_phase(p)) is not None}
        self.h_last: float | None = None
        self.zeno = ZenoTracker(options.zeno_window, options.zeno_tol,
                                 rules.ZENO_RESOLUTION * options.event_tol)
        self.stats: SimulationStats = {"steps": 0, "refinements": 0, "events_located": 0,
                                       "segments": 0}

    # ----- small helpers -------------------------------------------------------------------
    def xtol(self, t: float) -> float:
        return rules.event_time_tolerance(self.o.event_tol, t)

    def state_map(self, x: np.ndarray) -> dict[str, float]:
        return {n: float(v) for n, v in zip(self.names, x, strict=True)}

    def log(self, t: float, transition: str, source: str, target: str, pre: np.ndarray,
            post: np.ndarray, kind: str, grazing: bool = False) -> None:
        self.events.append(Event(float(t), self.j, transition, source, target,
                                 self.state_map(pre), self.state_map(post), kind, grazing))
        if len(self.events) >= self.o.max_events:
            # the run ends after the event it logged: in its target, in its post state
            self.last = (t, post.copy(), self.c.modes[target])
            raise _Stop(Status.MAX_EVENTS, f"{len(self.events)} events logged by t = {t!r}")

    # ----- sign bookkeeping of discontinuous flows -----------------------------------------
    def enter_mode(self, mode: CompiledMode, t: float, x: np.ndarray) -> None:
        """Fresh signs for a mode's switches at (t, x)."""
        m = len(mode.switches)
        self.sliding = ()
        if m == 0:
            self.sigma = _NO_SIGMA
            return
        sigma = np.ones(m)
        s = mode.switch_fields.values(t, x, self.p, sigma)
        tiny = [k for k in range(m) if abs(s[k]) <= self.o.event_atol]
        sigma = np.where(s >= 0, 1.0, -1.0)
        self.sigma, self.sliding = resolve_switches(mode, t, x, self.p, sigma, tiny)

    def sigma_at(self, mode: CompiledMode, t: float, x: np.ndarray) -> np.ndarray:
        if not self.sliding:
            return self.sigma
        sigma = self.sigma.copy()
        sigma[list(self.sliding)] = equivalent_sigma(mode, t, x, self.p, sigma, self.sliding)
        return sigma

    # ----- scheduled transitions -----------------------------------------------------------
    def _sched_index(self, tr: CompiledTransition, t: float) -> int:
        period, phase = self.schedules[tr.index]
        return rules.schedule_index(t, phase, period, self.sched_done.get(tr.index, -1))

    def _sched_time(self, tr: CompiledTransition, k: int) -> float:
        period, phase = self.schedules[tr.index]
        return phase + k * period

    def next_scheduled(self, mode: CompiledMode, t: float) -> float:
        times = [self._sched_time(tr, self._sched_index(tr, t))
                 for tr in mode.outgoing if tr.index in self.schedules]
        return min(times, default=math.inf)

    def due(self, tr: CompiledTransition, t: float) -> bool:
        if tr.index not in self.schedules:
            return False
        instant = self._sched_time(tr, self._sched_index(tr, t))
        return abs(instant - t) <= rules.DUE_WIDTH * self.xtol(t)

    # ----- guards at an instant ------------------------------------------------------------
    def guard_state(self, tr: CompiledTransition, mode: CompiledMode, t: float,
                    x: np.ndarray) -> tuple[float, float]:
        """Guard value G = min_i g_i (holds when G >= 0) and its time derivative."""
        if tr.guard is None:
            raise SimulationError(f"transition {tr.name!r} has no guard to evaluate")
        g = tr.guard.values(t, x, self.p, _NO_SIGMA)
        f = mode.flow(t, x, self.p, self.sigma_at(mode, t, x))
        dg = tr.guard.derivative(t, x, self.p, _NO_SIGMA, f)
        undefined = np.flatnonzero(~np.isfinite(g))
        if undefined.size:
            k = int(undefined[0])
            raise _Stop(Status.SOLVER_FAILED,
                        f"the guard of {tr.name!r} ({tr.guard_texts[k]}) is {float(g[k])!r} at "
                        f"t = {t!r} in mode {mode.name!r} (state {self.state_map(x)})")
        i = int(np.argmin(g))
        return float(g[i]), float(dg[i])

    def enabled(self, tr: CompiledTransition, mode: CompiledMode, t: float, x: np.ndarray,
                fresh: set[int], previous: int | None) -> bool:
        if tr.scheduled:
            if not self.due(tr, t):
                return False
            return tr.guard is None or self.guard_state(tr, mode, t, x)[0] >= 0
        if tr.index in fresh:
            return True
        if tr.index == previous:
            return False  # no re-triggering right after its own reset
        value, slope = self.guard_state(tr, mode, t, x)
        if math.isnan(slope):
            slope = 0.0
        # a vertical tangent (infinite slope) gives no time band
        band = (rules.RETRIGGER_BAND * self.xtol(t) * abs(slope) if math.isfinite(slope)
                else 0.0) + self.o.event_atol
        if value < -band:
            return False
        return not (value <= band and slope < 0)  # touching the boundary while leaving

    def event_iteration(self, mode: CompiledMode, t: float, x: np.ndarray,
                        fresh: set[int], grazing: set[int]) -> tuple[CompiledMode, np.ndarray,
                                                                     set[int]]:
        """Fire enabled transitions at instant ``t`` until none is enabled."""
        fired_now: set[int] = set()
        previous: int | None = None
        for _ in range(self.o.max_event_iterations):
            chosen = next((tr for tr in mode.outgoing
                           if self.enabled(tr, mode, t, x, fresh, previous)), None)
            if chosen is None:
                break
            pre = x
            x = chosen.reset(t, pre, self.p, _NO_SIGMA)
            if not np.all(np.isfinite(x)):
                raise _Stop(Status.SOLVER_FAILED,
                            f"reset of transition {chosen.name!r} at t = {t!r} gave a "
                            f"non-finite state {self.state_map(x)}")
            self.j += 1
            target = self.c.modes[chosen.target]
            self.log(t, chosen.name, mode.name, target.name, pre, x, "jump",
                     chosen.index in grazing)
            fired_now.add(chosen.index)
            previous = chosen.index
            if chosen.scheduled:
                self.sched_done[chosen.index] = self._sched_index(chosen, t)
            else:
                verdict = self.zeno.record(chosen.name, t)
                if verdict is not None:
                    self.finish_zeno(verdict.describe(), verdict.accumulation_time, t, x, target)
            mode = target
            self.enter_mode(mode, t, x)
            fresh = set()
        else:
            names = sorted({self.events[-k].transition
                            for k in range(1, min(len(self.events), 10) + 1)})
            self.finish_zeno(f"{self.o.max_event_iterations} jumps at the same instant t = {t!r} "
                             f"(a zero-dwell cycle through {', '.join(names)})", t, t, x, mode)
        for tr in mode.outgoing:  # scheduled instants that passed without firing are consumed
            if self.due(tr, t) and tr.index not in fired_now:
                self.sched_done[tr.index] = self._sched_index(tr, t)
        return mode, x, fired_now

    def finish_zeno(self, text: str, t_acc: float, t: float, x: np.ndarray,
                    mode: CompiledMode) -> None:
        self.last = (t, x, mode)
        if self.o.zeno == "error":
            raise ZenoError(f"Zeno behaviour: {text}")
        raise _Stop(Status.ZENO, text, t_acc)

    # ----- monitors ------------------------------------------------------------------------
    def monitors(self, mode: CompiledMode) -> list[_Monitor]:
        rows = [_Monitor("guard", tr.index) for tr in mode.outgoing
                if not tr.scheduled and tr.guard is not None]
        rows += [_Monitor("invariant", k) for k in range(mode.invariants.size)]
        rows += [_Monitor("exit" if k in self.sliding else "switch", k)
                 for k in range(len(mode.switches))]
        return rows

    def monitor_batch(self, mode: CompiledMode, rows: list[_Monitor], tau: np.ndarray,
                      x: np.ndarray,
                      xdot: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Monitor values and slopes at the points ``(tau, x)``.

        The slopes are taken along ``xdot`` (the dense output's derivative at
        a step's samples) when given, else along the flow (with the
        equivalent signs while switches slide).
        """
        p = self.p
        sigma = self.sigma
        eq = None
        if self.sliding:
            eq = equivalent_sigma_batch(mode, tau, x, p, sigma, self.sliding)
        if xdot is not None:
            f = xdot
        elif self.sliding:
            sig_k = np.repeat(sigma[:, None], tau.size, axis=1)
            sig_k[list(self.sliding)] = eq
            f = mode.flow.batch(tau, x, p, sig_k)  # sigma per sample: rows broadcast
        else:
            f = mode.flow.batch(tau, x, p, sigma)
        phi = np.empty((len(rows), tau.size))
        dphi = np.empty_like(phi)
        cond = sw = None
        if mode.conditions is not None:
            cond = (mode.conditions.values.batch(tau, x, p, _NO_SIGMA),
                    mode.conditions.batch_derivative(tau, x, p, _NO_SIGMA, f))
        n_guard_rows = mode.invariant_offset
        cols = np.arange(tau.size)
        for r, row in enumerate(rows):
            if row.kind == "guard":
                if cond is None:
                    raise _no_conditions(mode)
                rows_of = mode.guard_rows[row.ref]
                g, dg = cond[0][rows_of], cond[1][rows_of]
                i = np.argmin(g, axis=0)
                phi[r], dphi[r] = -g[i, cols], -dg[i, cols]
            elif row.kind == "invariant":
                if cond is None:
                    raise _no_conditions(mode)
                phi[r], dphi[r] = cond[0][n_guard_rows + row.ref], cond[1][n_guard_rows + row.ref]
            elif row.kind == "switch":
                if sw is None:
                    sw = (mode.switch_fields.values.batch(tau, x, p, sigma),
                          mode.switch_fields.batch_derivative(tau, x, p, sigma, f))
                phi[r] = sigma[row.ref] * sw[0][row.ref]
                dphi[r] = sigma[row.ref] * sw[1][row.ref]
            else:  # sliding exit: |sigma_eq| reaching 1
                if eq is None:  # monitors() makes exit rows only for sliding switches
                    raise RuntimeError(f"mode {mode.name!r}: a sliding-exit monitor while no "
                                       "switch slides")
                value = 1.0 - np.abs(eq[self.sliding.index(row.ref)])
                phi[r] = value
                dphi[r] = np.gradient(value, tau) if tau.size > 1 else 0.0
        return phi, dphi

    def monitor_value(self, mode: CompiledMode, row: _Monitor, t: float, x: np.ndarray) -> float:
        """One monitor's value at one point (the root finder's inner loop)."""
        p = self.p
        conditions = mode.conditions
        if row.kind == "guard":
            if conditions is None:
                raise _no_conditions(mode)
            return -float(np.min(conditions.values(t, x, p, _NO_SIGMA)[
                mode.guard_rows[row.ref]]))
        if row.kind == "invariant":
            if conditions is None:
                raise _no_conditions(mode)
            return float(conditions.values(t, x, p, _NO_SIGMA)[mode.invariant_offset
                                                               + row.ref])
        if row.kind == "switch":
            return float(self.sigma[row.ref]
                         * mode.switch_fields.values(t, x, p, self.sigma)[row.ref])
        eq = equivalent_sigma(mode, t, x, p, self.sigma, self.sliding)
        return 1.0 - abs(float(eq[self.sliding.index(row.ref)]))

    def scan(self, mode: CompiledMode, rows: list[_Monitor], armed: np.ndarray,
             floors: list[float | None], dense, t0: float,
             t1: float) -> tuple[list[Trigger], np.ndarray]:
        if not rows:
            return [], armed

        def batch(tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            return self.monitor_batch(mode, rows, tau, dense(tau), dense_slope(dense, tau))

        tau, phi, dphi, refinements = sample_step(t0, t1, batch, self.o.samples_per_step,
                                                  self.o.max_refine, self.o.event_atol)
        self.stats["refinements"] += refinements
        xtol = self.xtol(min(abs(t0), abs(t1)))
        cluster_width = rules.CLUSTER_WIDTH * xtol
        # locate monitors in the order their first candidate interval starts, and stop once
        # the rest can only fire after the earliest located event (plus the cluster width)
        tol = self.o.event_atol
        h = np.diff(tau)[None, :]
        extremes = hermite_extremes(h, phi[:, :-1], phi[:, 1:], dphi[:, :-1], dphi[:, 1:])
        lower = np.minimum(np.minimum(phi[:, :-1], phi[:, 1:]), extremes[0])
        upper = np.maximum(np.maximum(phi[:, :-1], phi[:, 1:]), extremes[2])
        order = []
        for r in range(len(rows)):
            if armed[r]:
                cand = np.nonzero(lower[r] <= tol)[0]
                if cand.size == 0:
                    continue  # stays above zero throughout the step
                start = tau[cand[0]]
            else:
                sinking = floors[r] is not None and np.any(lower[r] <= floors[r])
                if not sinking and not np.any(upper[r] > tol):
                    continue  # stays disarmed and above its floor
                start = t0
            order.append((start, r))
        order.sort()
        triggers: list[Trigger] = []
        new_armed = armed.copy()
        earliest = math.inf
        for start, r in order:
            if start > earliest + cluster_width:
                new_armed[r] = armed[r]
                continue

            def value(t: float, r: int = r) -> float:
                return self.monitor_value(mode, rows[r], t, dense(t))

            if math.isfinite(earliest) and armed[r]:
                # a surface that coincides with an already located one needs no new search
                at, before = value(earliest), value(earliest - cluster_width)
                if at <= 0 < before:
                    triggers.append(Trigger(r, earliest, False))
                    continue
            trig, new_armed[r] = first_trigger(
                r, tau, phi[r], dphi[r], bool(armed[r]), value, xtol, tol, floors[r],
                tuple(e[r] for e in extremes),
                (earliest, cluster_width) if math.isfinite(earliest) else None)
            if trig is not None:
                triggers.append(trig)
                earliest = min(earliest, trig.t)
        if not triggers:
            return [], new_armed
        cluster = [tr for tr in triggers if tr.t <= earliest + cluster_width]
        self.stats["events_located"] += len(cluster)
        return cluster, new_armed

    @staticmethod
    def floors(rows: list[_Monitor], phi0: np.ndarray, dphi0: np.ndarray, band: np.ndarray,
               armed: np.ndarray) -> list[float | None]:
        """Safety floors of monitors that start on their boundary.

        Such a monitor must rise before it can fire; if instead it sinks below
        its start by more than the event tolerance, it fires anyway, so a state
        never passes through a boundary unnoticed. A guard that holds and keeps
        holding (it just fired and must first become false) has no floor.
        """
        out: list[float | None] = []
        for r, row in enumerate(rows):
            if armed[r] or (row.kind == "guard" and dphi0[r] <= 0):
                out.append(None)
            else:
                out.append(min(float(phi0[r]), 0.0) - float(band[r]))
        return out

    # ----- one flow segment ----------------------------------------------------------------
    def flow(self, mode: CompiledMode, t: float, x: np.ndarray,
             t_stop: float) -> tuple[float, np.ndarray, list[Trigger], list[_Monitor]]:
        p = self.p
        pieces = _Pieces(mode.name, self.j, [t], [x.copy()])
        rows = self.monitors(mode)
        if rows:
            phi0, dphi0 = self.monitor_batch(mode, rows, np.array([t]), x[:, None])
            armed = phi0[:, 0] > self.o.event_atol
            # the state of an event is known to within the event-time tolerance
            band = rules.ENTRY_BAND * self.xtol(t) * np.abs(dphi0[:, 0]) + self.o.event_atol
            floors = self.floors(rows, phi0[:, 0], dphi0[:, 0], band, armed)
            for r, row in enumerate(rows):
                if row.kind == "invariant" and phi0[r, 0] < -band[r]:
                    self.segments.append(pieces.freeze())
                    self.stop_outside_invariant(mode, t, x, row.ref)
        else:
            armed, floors = np.zeros(0, dtype=bool), []
        sigma = self.sigma
        if self.sliding:
            sliding = list(self.sliding)

            def rhs(tt: float, y: np.ndarray) -> np.ndarray:
                sig = self.sigma_at(mode, tt, y)
                f = mode.flow(tt, y, p, sig)
                # remove the rounding-level drift off the sliding surfaces: project the
                # equivalent flow onto their tangent space (exact for s = a state)
                grad = mode.switch_fields.gradient(tt, y, p, sig)[sliding]
                drift = mode.switch_fields.derivative(tt, y, p, sig, f)[sliding]
                return f - grad.T @ np.linalg.lstsq(grad @ grad.T, drift, rcond=None)[0]
            jac = None
        else:
            def rhs(tt: float, y: np.ndarray) -> np.ndarray:
                return mode.flow(tt, y, p, sigma)

            def jac(tt: float, y: np.ndarray) -> np.ndarray:
                return mode.jacobian(tt, y, p, sigma)
        kwargs: dict[str, object] = {"rtol": self.o.rtol, "atol": self.o.atol,
                                     "max_step": self.o.max_step}
        if self.o.stiff and jac is not None:
            kwargs["jac"] = jac
        if self.h_last is not None:
            kwargs["first_step"] = min(self.h_last, t_stop - t)
        self.check_finite(mode, t, x, rhs(t, x), rows, phi0[:, 0] if rows else None, pieces)
        solver = _SOLVERS[self.o.method](rhs, t, x, t_stop, **kwargs)
        triggers: list[Trigger] = []
        try:
            while True:
                message = solver.step()
                self.stats["steps"] += 1
                if solver.status == "failed":
                    self.stop_in_flow(pieces, t, x, mode, Status.SOLVER_FAILED,
                                      f"{self.o.method} failed at t = {float(solver.t)!r} in mode "
                                      f"{mode.name!r}: {message}")
                t_old, t_new = float(solver.t_old), float(solver.t)
                self.h_last = t_new - t_old
                dense = solver.dense_output()
                triggers, armed = self.scan(mode, rows, armed, floors, dense, t_old, t_new)
                floors = [None if a else f for a, f in zip(armed, floors, strict=True)]
                if triggers:
                    t_event = min(tr.t for tr in triggers)
                    x_event = dense(t_event)
                    pieces.t.append(t_event)
                    pieces.y.append(x_event)
                    pieces.dense.append(dense)
                    t, x = t_event, x_event
                    break
                if not np.all(np.isfinite(solver.y)):  # (scipy rejects non-finite steps: a guard)
                    self.stop_in_flow(pieces, t, x, mode, Status.SOLVER_FAILED,
                                      f"the state became non-finite after t = {t!r} in mode "
                                      f"{mode.name!r}")
                pieces.t.append(t_new)
                pieces.y.append(solver.y.copy())
                pieces.dense.append(dense)
                t, x = t_new, solver.y.copy()
                self.check_budgets(pieces, t, x, mode)
                if solver.status == "finished":
                    break
        except KeyboardInterrupt:  # the run up to the last accepted step is kept
            del pieces.t[len(pieces.dense) + 1:], pieces.y[len(pieces.dense) + 1:]
            self.stop_in_flow(pieces, pieces.t[-1], pieces.y[-1], mode, Status.INTERRUPTED,
                              f"interrupted at t = {pieces.t[-1]!r} in mode {mode.name!r}")
        self.segments.append(pieces.freeze())
        self.stats["segments"] += 1
        return t, x, triggers, rows

    def check_finite(self, mode: CompiledMode, t: float, x: np.ndarray, f: np.ndarray,
                     rows: list[_Monitor], phi: np.ndarray | None, pieces: _Pieces) -> None:
        """Stop with ``SOLVER_FAILED`` naming the first non-finite state, flow or monitor
        value ``phi`` at the start of a flow segment (an integrator fed NaN never finishes
        its first step)."""
        if np.all(np.isfinite(f)) and np.all(np.isfinite(x)) and (
                phi is None or np.all(np.isfinite(phi))):
            return
        declared = self.c.symbolic.modes[mode.name].flow
        where = ""
        for i, name in enumerate(self.names):
            if not math.isfinite(x[i]):
                where = f"the state {name} is {float(x[i])!r}"
            elif not math.isfinite(f[i]):
                text = declared[i] if declared[i] is not None else mode.flow.exprs[i]
                where = f"the flow of {name}, {text}, is {float(f[i])!r}"
            if where:
                break
        if not where and phi is not None:
            bad = [r for r, value in enumerate(phi) if not math.isfinite(value)]
            if bad:
                row = rows[bad[0]]
                where = f"the {row.kind} {self.monitor_text(mode, row)} is {float(phi[bad[0]])!r}"
        if where:
            self.stop_in_flow(pieces, t, x, mode, Status.SOLVER_FAILED,
                              f"{where} at t = {t!r} in mode {mode.name!r} "
                              f"(state {self.state_map(x)})")

    def monitor_text(self, mode: CompiledMode, row: _Monitor) -> str:
        """A readable form of a monitor (a guard's, invariant's or switch's text)."""
        if row.kind == "invariant":
            return repr(mode.invariant_texts[row.ref])
        if row.kind == "guard":
            tr = self.c.transitions[row.ref]
            return f"of {tr.name!r} ({' and '.join(tr.guard_texts)})"
        return repr(mode.switches[row.ref].text)

    def check_budgets(self, pieces: _Pieces, t: float, x: np.ndarray, mode: CompiledMode) -> None:
        """Stop at the step budget or the wall-clock deadline."""
        if self.stats["steps"] >= self.o.max_steps:
            self.stop_in_flow(pieces, t, x, mode, Status.STEP_LIMIT,
                              f"{self.stats['steps']} integrator steps by t = {t!r} "
                              f"(max_steps = {self.o.max_steps})")
        if self.deadline is not None and time.monotonic_ns() >= self.deadline:
            self.stop_in_flow(pieces, t, x, mode, Status.TIME_LIMIT,
                              f"time_limit = {self.o.time_limit!r} s reached at t = {t!r}")

    def stop_in_flow(self, pieces: _Pieces, t: float, x: np.ndarray, mode: CompiledMode,
                     status: Status, message: str) -> None:
        """End the run inside a flow segment; the result keeps what was integrated."""
        self.segments.append(pieces.freeze())
        self.last = (t, x, mode)
        raise _Stop(status, message)

    # ----- events in flow ------------------------------------------------------------------
    def handle(self, mode: CompiledMode, t: float, x: np.ndarray, triggers: list[Trigger],
               rows: list[_Monitor]) -> tuple[CompiledMode, np.ndarray]:
        hit = [rows[tr.monitor] for tr in triggers]
        grazing = {rows[tr.monitor].ref for tr in triggers
                   if tr.grazing and rows[tr.monitor].kind == "guard"}
        switches = {m.ref for m in hit if m.kind == "switch"}
        exits = {m.ref for m in hit if m.kind == "exit"}
        if switches or exits:
            self.update_switches(mode, t, x, switches, exits)
        fresh = {m.ref for m in hit if m.kind == "guard"}
        j_before = self.j
        new_mode, x_new, fired = self.event_iteration(mode, t, x, fresh, grazing)
        if self.j == j_before:
            for m in hit:
                if m.kind == "invariant":
                    self.check_invariant(mode, t, x, m.ref)
        return new_mode, x_new

    def update_switches(self, mode: CompiledMode, t: float, x: np.ndarray, switches: set[int],
                        exits: set[int]) -> None:
        old_sigma, old_sliding = self.sigma_at(mode, t, x), self.sliding
        forced = {k: float(np.sign(old_sigma[k])) for k in exits}
        at_surface = switches | (set(old_sliding) - exits)
        sigma, sliding = resolve_switches(mode, t, x, self.p, self.sigma.copy(), at_surface,
                                          forced)
        self.sigma, self.sliding = sigma, sliding
        for k in sorted(switches | exits):
            text = mode.switches[k].text
            if k in sliding and k not in old_sliding:
                kind = "slide_start"
            elif k in old_sliding and k not in sliding:
                kind = "slide_end"
            else:
                kind = "crossing"
            self.log(t, text, mode.name, mode.name, x, x, kind)
            self.zeno_switch(text, t, x, mode)

    def zeno_switch(self, text: str, t: float, x: np.ndarray, mode: CompiledMode) -> None:
        verdict = self.zeno.record(f"switch:{text}", t)
        if verdict is not None:
            self.finish_zeno(f"the discontinuity {text} chatters: {verdict.describe()}",
                             verdict.accumulation_time, t, x, mode)

    def check_invariant(self, mode: CompiledMode, t: float, x: np.ndarray, k: int) -> None:
        value = mode.invariants.values(t, x, self.p, _NO_SIGMA)[k]
        f = mode.flow(t, x, self.p, self.sigma_at(mode, t, x))
        slope = mode.invariants.derivative(t, x, self.p, _NO_SIGMA, f)[k]
        if slope >= 0 and value >= -self.o.event_atol:
            return  # touched tangentially and stays inside
        waiting = self.holding_guards(mode, t, x)
        detail = (f"; transition(s) {', '.join(waiting)} hold but just fired (a zero-dwell "
                  "self-loop)" if waiting else "")
        status = Status.ZENO if waiting else Status.INVARIANT_VIOLATED
        raise _Stop(status, f"mode {mode.name!r} at t = {t!r}: the flow leaves the invariant "
                            f"{mode.invariant_texts[k]!r} and no transition is enabled{detail}",
                    self.accumulation(waiting, t) if waiting else None)

    def holding_guards(self, mode: CompiledMode, t: float, x: np.ndarray) -> list[str]:
        """Unscheduled transitions of ``mode`` whose guard holds at ``(t, x)``."""
        return [tr.name for tr in mode.outgoing
                if tr.guard is not None and not tr.scheduled
                and self.guard_state(tr, mode, t, x)[0] >= -self.o.event_atol]

    def accumulation(self, names: list[str], t: float) -> float:
        """Where the firings of ``names`` accumulate, from their dwell times (at least ``t``)."""
        return max((self.zeno.estimate(name, t) for name in names), default=t)

    def stop_outside_invariant(self, mode: CompiledMode, t: float, x: np.ndarray,
                               k: int) -> None:
        """Stop a run whose mode is entered outside its invariant ``k``.

        Right after a jump at this instant whose guard still holds, the state can
        neither flow (the invariant) nor jump (the guard must first become false): the
        automaton jumps again at once, forever. That is Zeno, not a violation.
        """
        text = f"mode {mode.name!r} entered at t = {t!r} outside its invariant " \
               f"{mode.invariant_texts[k]!r} (state {self.state_map(x)})"
        just_jumped = bool(self.events) and self.events[-1].t == t \
            and self.events[-1].target == mode.name
        waiting = self.holding_guards(mode, t, x) if just_jumped else []
        if waiting:
            t_acc = self.accumulation(waiting, t)
            self.finish_zeno(f"{text} right after a jump, and the guard of "
                             f"{', '.join(waiting)} still holds: the jumps accumulate at "
                             f"t = {t_acc:.10g} (a zero-dwell self-loop)", t_acc, t, x, mode)
        raise _Stop(Status.INVARIANT_VIOLATED, text)

    # ----- driver --------------------------------------------------------------------------
    def restore(self, checkpoint: Checkpoint) -> None:
        """Take over the record and the discrete state of a run stopped at ``checkpoint``."""
        self.events = list(checkpoint.events)
        self.segments = list(checkpoint.segments)
        self.j = checkpoint.jumps
        self.sigma = np.array(checkpoint.sigma, dtype=float)
        self.sliding = tuple(checkpoint.sliding)
        self.sched_done = dict(checkpoint.schedules_done)
        self.h_last = checkpoint.last_step
        for name, (count, times) in checkpoint.zeno_history.items():
            self.zeno.restore(name, count, times)
        self.stats.update(checkpoint.stats)  # type: ignore[typeddict-item]
        self.stats["segments"] = len(self.segments)

    def run(self, t0: float, x0: np.ndarray, mode_name: str) -> SimulationResult:
        mode = self.c.modes[mode_name]
        t, x = float(t0), np.asarray(x0, dtype=float).copy()
        return self.drive(t, x, mode, "start")

    def drive(self, t: float, x: np.ndarray, mode: CompiledMode, entry: str,
              triggers: list[Trigger] | None = None) -> SimulationResult:
        """Run from ``(t, x, mode)`` to the end; ``entry`` says where the run stands.

        ``"start"``: a fresh run; ``"iterate"``: at an event iteration without
        fresh guards (signs already entered); ``"handle"``: a flow segment just
        ended on ``triggers`` (located with the monitors of the current sliding
        set); ``"flow"``: at the top of the main loop. The compiled backend hands
        a run over at these points. Non-finite values are reported by the checks
        of the run (status ``SOLVER_FAILED``), not by numpy's warnings.
        """
        with np.errstate(all="ignore"):
            return self._drive(t, x, mode, entry, triggers)

    def _drive(self, t: float, x: np.ndarray, mode: CompiledMode, entry: str,
               triggers: list[Trigger] | None = None) -> SimulationResult:
        self.last = (t, x, mode)
        status, message, zeno_time = Status.COMPLETED, "", None
        try:
            if entry == "start":
                self.enter_mode(mode, t, x)
            if entry in ("start", "iterate"):
                mode, x = self.event_iteration(mode, t, x, set(), set())[:2]
            elif entry == "handle":
                mode, x = self.handle(mode, t, x, triggers or [], self.monitors(mode))
            self.last = (t, x, mode)
            while t < self.t_end:
                t_stop = min(self.t_end, self.next_scheduled(mode, t))
                if t_stop - t > self.xtol(t):
                    t, x, triggers, rows = self.flow(mode, t, x, t_stop)
                    self.last = (t, x, mode)
                    if triggers:
                        mode, x = self.handle(mode, t, x, triggers, rows)
                        self.last = (t, x, mode)
                        continue
                t = t_stop
                if t < self.t_end or self.due_any(mode, t):
                    mode, x = self.event_iteration(mode, t, x, set(), set())[:2]
                    self.last = (t, x, mode)
            message = f"reached t_end = {self.t_end!r}"
        except _Stop as stop:
            status, message, zeno_time = stop.status, stop.message, stop.zeno_time
        except KeyboardInterrupt:
            t = self.last[0]
            status, message = Status.INTERRUPTED, f"interrupted at t = {t!r}"
        except SimulationError:
            raise
        t, x, mode = self.last
        if not self.segments or self.segments[-1].t_end < t or self.segments[-1].j != self.j:
            self.segments.append(Segment(mode.name, self.j, np.array([t]), x[:, None].copy()))
        final = FinalState(float(t), self.j, mode.name, self.state_map(x))
        parameters = dict(zip(self.c.parameter_names, map(float, self.p), strict=True))
        return SimulationResult(status, message, EventTable.from_events(self.events, self.names),
                                SegmentTable.from_segments(self.segments, len(self.names)), final,
                                self.names, zeno_time, self.stats.copy(), parameters, self.c)

    def due_any(self, mode: CompiledMode, t: float) -> bool:
        return any(self.due(tr, t) for tr in mode.outgoing)


def deadline_of(options: SimulationOptions) -> int | None:
    """The wall-clock deadline of a run starting now, in ``time.monotonic_ns()``."""
    if options.time_limit is None:
        return None
    return time.monotonic_ns() + int(options.time_limit * 1e9)


def run(compiled: CompiledModel, *, t0: float, x0: np.ndarray, mode: str, t_end: float,
        p: np.ndarray, options: SimulationOptions, deadline: int | None = None
        ) -> SimulationResult:
    """Simulate ``compiled`` from ``(t0, x0, mode)`` to ``t_end`` (see ``hybridlab.simulate``).

    The reference engine itself: everything is given explicitly, nothing is checked or
    taken from a scenario (:class:`~hybridlab.HybridProblem` does that).

    Examples
    --------
    >>> import hybridlab
    >>> compiled = hybridlab.compile_model(hybridlab.load_model("models/bouncing_ball.toml"))
    >>> result = run(compiled, t0=0.0, x0=compiled.state_vector(), mode="fall", t_end=3.0,
    ...              p=compiled.parameter_vector(), options=SimulationOptions())
    >>> result.status.name, result.final.j, round(result.events[0].t, 6)
    ('COMPLETED', 1, 1.427843)
    """
    return _Run(compiled, p, options, t_end, deadline).run(t0, x0, mode)


def resume(compiled: CompiledModel, checkpoint: Checkpoint, *, p: np.ndarray,
           options: SimulationOptions, t_end: float, deadline: int | None = None
           ) -> SimulationResult:
    """Continue a run from ``checkpoint`` to ``t_end`` on the reference engine.

    The result holds the whole run: the checkpoint's events and segments, then
    those made from it on.

    Examples
    --------
    A ball about to flow from its initial state (see :class:`Checkpoint` for a run
    continued part-way):

    >>> import hybridlab
    >>> compiled = hybridlab.compile_model(hybridlab.load_model("models/bouncing_ball.toml"))
    >>> start = Checkpoint(t=0.0, x=compiled.state_vector(), mode="fall", entry="flow",
    ...                    jumps=0, events=[], segments=[])
    >>> result = resume(compiled, start, p=compiled.parameter_vector(),
    ...                 options=SimulationOptions(), t_end=2.0)
    >>> result.status.name, round(result.events[0].t, 6)
    ('COMPLETED', 1.427843)
    """
    engine = _Run(compiled, p, options, t_end, deadline)
    engine.restore(checkpoint)
    mode = compiled.modes[checkpoint.mode]
    return engine.drive(checkpoint.t, np.array(checkpoint.x, dtype=float), mode,
                        checkpoint.entry, list(checkpoint.triggers))
