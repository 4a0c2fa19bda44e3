"""The hybrid layer: a waiting list of (mode, set, time interval, jumps).

Each item is flowed with :class:`~hybridlab.reachability.nonlinear.FlowStepper`
step by step. For every step set ``H`` (all states over the step's time
window):

* **Invariant**: a trajectory still in the mode satisfies the mode's invariant
  (the simulator jumps or stops with ``INVARIANT_VIOLATED`` otherwise), so
  ``H`` and the next start set are cut down to its linear rows
  (:meth:`Zonotope.intersect_halfspace`); if some row is negative over all of
  ``H``, the flowpipe ends.
* **Entry outside the invariant**: guards fire at an entry instant before the invariant is
  checked, so the part of an entry set outside the invariant is recorded at that instant and
  jumps through every guard that may hold on it.
* **Guards** (urgent): a transition *may* fire when every guard row can be
  non-negative over ``H`` (nonlinear rows by the mean-value form over the zonotope).
  Consecutive steps that may fire it form a cluster. A trajectory fires at its entry
  or where the guard's last row to hold comes up to 0, so a step set with one row in
  doubt is cut down to that row's surface, a step set inside the guard (fired before)
  is dropped, and an entry set across the guard is split: its inner part jumps at the
  entry instant and the rest flows on (:func:`_firing_surface`).
  Each step set is cut down to the guard and the source invariant (LPs over the
  zonotope, plus exact clipping by axis-aligned rows), the cluster's pieces are
  joined (``clustering="box"``) into their box in the state axes or in the run's
  principal axes, whichever is smaller (:mod:`~hybridlab.reachability.clusters`),
  the reset is applied
  (exactly for affine resets, by the mean-value form with an interval Jacobian
  otherwise) and the result, with the union of the cluster's time windows,
  goes on the waiting list. The flow continues past a cluster because the guard
  does not *necessarily* hold there: taking every "may" transition and
  continuing the flow over-approximates the simulator's urgent semantics. The
  flow stops after a step whose set lies strictly inside a guard (every
  trajectory has jumped by then).
* **Leaving a guard**: a guard row that is ``<= 0`` (to ``1e-12``) on the
  initial set and whose time derivative is negative over each step set so far
  cannot hold during those steps; this is how a ball that bounces off ``h = 0``
  does not bounce again at once (the simulator's re-trigger and
  touching-while-leaving rules).
* **Scheduled transitions** need an exactly known time; the steps are cut at
  the scheduled instants and the time-point set there is reset. With an
  uncertain time the branch stops, incomplete, with the reason.
* **Fixpoint**: an initial set inside an earlier initial set of the same mode
  (time-invariant models) ends its branch; the earlier branch's sets then cover
  it at every later time, so their time intervals are extended to ``t_end``.
"""

from __future__ import annotations

import heapq
import math
import sys
import time as _time
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from hybridlab.reachability.chain import AffineChain
from hybridlab.reachability.clusters import GROUP_GROWTH, groups, hull, oriented_hull, sweep_hull
from hybridlab.reachability.linear import StepError
from hybridlab.reachability.nonlinear import FlowStepper, RemainderError
from hybridlab.reachability.options import ReachOptions
from hybridlab.reachability.phases import (
    MAX_PHASE_ITEMS,
    Phase,
    Phases,
    PhaseWatch,
    Step,
    with_phase,
    without_phase,
)
from hybridlab.reachability.result import ReachResult, ReachSet, _Context
from hybridlab.reachability.rounding import SLACK, TINY
from hybridlab.reachability.sets import Box, SetError, Zonotope
from hybridlab.reachability.slicing import Slice, unread_outputs
from hybridlab.reachability.spec import Spec, lowers_on
from hybridlab.reachability.system import Rows, System
from hybridlab.simulation.rules import SCHEDULE_SLACK, schedule_index
from hybridlab.symbolic.intervals import IntervalFunction

__all__ = ["Item", "run_analysis"]

Hit = tuple[Zonotope, float, float, Zonotope, float]
"""A step whose set may fire a guard: its set, its time interval, its start set and its
length."""

#: a guard's crossing instant is landed on when known within this fraction of the step
_SHARP = 1e-3
#: a guard row's spread over a time-point set, relative to its size, below which its
#: crossing instant may be sharp (wider rows are not landed on)
_POINT = 1e-6
#: the step across a landed crossing, relative to 1 + |t|
_TINY_STEP = 1e-9
#: shortened steps in a row at most (a rate that is not constant moves the instant)
_LANDINGS = 4


@dataclass(frozen=True, eq=False)
class Item:
    """A waiting-list entry: flow ``P`` in ``mode`` from a time in ``[t_lo, t_hi]``.

    ``parent`` is the id of the item whose flow jumped here (``None`` for the initial set).

    Examples
    --------
    The initial item of an analysis of the thermostat from ``T`` in ``[19, 21]``:

    >>> item = Item(0, None, "heat", Zonotope([20.0], [[1.0]]), 0.0, 0.0, 0)
    >>> item.mode, item.P.center.tolist(), (item.t_lo, item.t_hi), item.jumps, item.parent
    ('heat', [20.0], (0.0, 0.0), 0, None)
    """

    id: int
    parent: int | None
    mode: str
    P: Zonotope
    t_lo: float
    t_hi: float
    jumps: int
    #: scheduled instant this item starts at and the transitions already fired there
    sched_done: tuple[float, frozenset[int]] | None = None
    #: the sides of the switching surfaces it is analysed on (:mod:`.phases`)
    phase: Phase = ()


def _is_box(Z: Zonotope) -> bool:
    G = Z.generators
    return bool(np.all(np.count_nonzero(G, axis=0) <= 1))


def _contained_in_hull(inner: Zonotope, outer: Zonotope) -> bool:
    """A sufficient test for ``inner ⊆ outer``, for an ``inner`` already inside ``outer``'s
    interval hull."""
    if _is_box(outer):
        return True
    H = outer.halfspaces()
    if H is None:
        return False
    A, b = H
    return all(inner.support(a) <= bi for a, bi in zip(A, b, strict=True))


def _within(Z: Zonotope | None, rows: Rows) -> Zonotope | None:
    """``Z`` cut down to the linear rows ``a z + b >= 0`` (an over-approximating zonotope).

    Sound for a mode's invariant: a trajectory still in the mode satisfies it."""
    if Z is None:
        return None
    linear = np.flatnonzero(rows.linear)
    if linear.size == 0:
        return Z
    # rows the set already satisfies (support rounded up) cost one product, not a cut
    crossing = linear[Z.supports(-rows.a[linear]) > rows.b[linear]]
    for i in crossing:
        Z = Z.intersect_halfspace(-rows.a[i], rows.b[i])
        if Z is None:
            return None
    return Z


def _no_wider(Z: Zonotope, box: np.ndarray) -> bool:
    """Whether ``Z``'s interval hull lies within ``box`` (up to the rounding of its bounds)."""
    bounds = Z.bounds()
    scale = 1e-12 * (1.0 + np.abs(box).max(axis=1))
    return bool(np.all(bounds[:, 0] >= box[:, 0] - scale)
                and np.all(bounds[:, 1] <= box[:, 1] + scale))


def _frames_alike(swept: Zonotope, box: np.ndarray) -> bool:
    """Whether a sweep hull's interval hull stays within :data:`GROUP_GROWTH` times the run's
    box (each coordinate's width): when the run's sets do not share their generators'
    meaning (other branches, another layout), their differences make it wider."""
    width = box[:, 1] - box[:, 0]
    bounds = swept.bounds()
    scale = 1e-12 * (1.0 + np.abs(box).max(axis=1))
    return bool(np.all(bounds[:, 1] - bounds[:, 0] <= GROUP_GROWTH * width + scale))


_ACROSS = 1e-9
"""An entry set is split at a guard row whose range over it reaches this far (relative)
to both sides of 0; nearer, it lies on the surface to within rounding."""


def _firing_surface(Z: Zonotope, guard: Rows, row: int) -> Zonotope | None:
    """``Z`` cut down to the surface ``g_row(z) = 0`` (linearised over ``Z`` by the
    mean-value form where the row is nonlinear); ``Z`` itself where that does not apply.

    Sound for the states where a trajectory fires, when it entered its flow with some
    guard row negative: the guard holds first at an instant when every row is ``>= 0``
    and one of them has just come up from below, so that row is 0 there (the rows are
    continuous along the flow). A step set on which only ``row`` may be negative holds
    that instant only on that row's surface, or at the step's start, which the step
    before covers."""
    a, lo, hi = guard.affine_bounds(Z)
    if not (np.all(np.isfinite(a[row])) and np.isfinite(lo[row]) and np.isfinite(hi[row])):
        return Z
    return Z.intersect_slab(a[row], -hi[row], -lo[row])


def _linear_rows(*rows: Rows) -> tuple[np.ndarray, np.ndarray]:
    """The linear rows ``a z + b >= 0`` of ``rows`` as ``A z <= b``."""
    return (np.vstack([-r.a[r.linear] for r in rows]),
            np.concatenate([r.b[r.linear] for r in rows]))


def _clip_axis(box: np.ndarray, rows: Rows) -> np.ndarray | None:
    """Intersect a box with the axis-aligned linear rows ``a_i z_j + b >= 0``, exactly."""
    box = box.copy()
    for i in np.flatnonzero(rows.linear):
        nz = np.flatnonzero(rows.a[i])
        if nz.size != 1:
            continue
        j = int(nz[0])
        a, b = rows.a[i, j], rows.b[i]
        bound = -b / a  # exact when b == 0; otherwise rounded outward below
        if a > 0:  # z_j >= -b / a
            box[j, 0] = max(box[j, 0], float(np.nextafter(bound, -np.inf)) if b else 0.0)
        else:      # z_j <= -b / a
            box[j, 1] = min(box[j, 1], float(np.nextafter(bound, np.inf)) if b else 0.0)
        if box[j, 0] > box[j, 1]:
            return None
    return box


class _EntrySets:
    """The sets one mode was entered with, for the fixpoint test, and their interval hulls
    as arrays: a new set is compared with all hulls at once, and only those whose hull holds
    it are tested further."""

    def __init__(self, n: int) -> None:
        self.items: list[Item] = []
        self.lo, self.hi = np.empty((0, n)), np.empty((0, n))

    def add(self, item: Item) -> None:
        box = item.P.bounds()
        self.items.append(item)
        self.lo = np.vstack([self.lo, box[None, :, 0]])
        self.hi = np.vstack([self.hi, box[None, :, 1]])

    def covering(self, P: Zonotope) -> Item | None:
        """The first entered set that contains ``P`` (a sufficient test)."""
        if not self.items:
            return None
        box = P.bounds()
        inside = np.all(self.lo <= box[:, 0], axis=1) & np.all(box[:, 1] <= self.hi, axis=1)
        for k in np.flatnonzero(inside):
            if _contained_in_hull(P, self.items[k].P):
                return self.items[k]
        return None


class _Analysis:
    def __init__(self, system: System, options: ReachOptions, t_start: float, t_end: float,
                 p: np.ndarray, stop_unproved: Sequence[Spec] = ()) -> None:
        self.system = system
        self.options = options
        self.stop_unproved = tuple(stop_unproved)
        self.t_start = t_start
        self.t_end = t_end
        if options.step is None:  # reach() resolves the default step before the analysis
            raise ValueError("the analysis needs options.step")
        self.step = float(options.step)
        self.compiled = system.compiled
        self.started = _time.time()
        self.shown = 0.0  # when progress was last shown (0: never)
        self.progress_tty = sys.stderr.isatty()
        self.steppers: dict[tuple[str, Phase], FlowStepper] = {}
        self.phases = Phases(system)
        self.phase_items = 0  # items entered in a phase by a split or a phase change
        self.records: list[tuple[int, ReachSet]] = []
        # the kept sets' centres and generators, with those that the analyses sharing
        # the budget keep (max_memory)
        self.kept_bytes = int(options.memory_held * 2**30)
        self.reasons: list[str] = []
        self.too_wide: set[str] = set()  # the reasons that are a set outgrowing a linearisation
        self.items: dict[int, Item] = {}
        self.seen: dict[tuple[str, Phase], _EntrySets] = {}
        self.fixpoints: list[tuple[int, float]] = []
        self.open_branches = 0  # branches ended by t_end (not by a fixpoint or dying)
        self.next_id = 0
        self.queue: list[tuple[float, int, Item]] = []
        self.lie: dict[tuple[str, int], IntervalFunction] = {}
        self.sliced = unread_outputs(system, options.observed)
        self.schedules = {tr.index: tr.period_and_phase(p) for tr in self.compiled.transitions
                          if tr.scheduled and tr.index not in self.sliced.transitions}
        self.use_fixpoint = (options.fixpoint and not system.timed
                             and not any(v is not None for v in self.schedules.values()))
        self.context = _Context(
            namespace=self.compiled.symbolic.namespace(), zsyms=system.zsyms,
            values=system.values,
            inputs={s: system.inputs[str(s)] for s in
                    (next(iter(system.modes.values())).usyms[:len(system.inputs)]
                     if system.modes else ())},
            t_index=system.time_index, modes=self.compiled.symbolic.modes,
            local_names=self.compiled.symbolic.local_names)
        self.n = system.n_states
        self.no_rows = Rows([], system.zsyms)
        self.split_direction: np.ndarray | None = None  # see ReachResult.split_direction

    # ----- waiting list -------------------------------------------------------------------
    def push(self, parent: int | None, mode: str, P: Zonotope, t_lo: float, t_hi: float,
             jumps: int, sched_done: tuple[float, frozenset[int]] | None = None,
             phase: Phase = ()) -> None:
        if t_lo > self.t_end:
            return
        if jumps > self.options.max_jumps:
            self._reason(f"max_jumps={self.options.max_jumps} reached: a branch entering "
                         f"mode {mode!r} at t in [{t_lo:.6g}, {t_hi:.6g}] was not followed")
            return
        # a set entered outside the target's invariant is kept: a guard may still fire at the
        # entry instant (the simulator fires guards before it checks the invariant)
        item = Item(self.next_id, parent, mode, P, t_lo, t_hi, jumps, sched_done, phase)
        self.next_id += 1
        self.items[item.id] = item
        if self.use_fixpoint:
            seen = self.seen.setdefault((mode, phase), _EntrySets(P.dim))
            old = seen.covering(P)
            if old is not None:
                self.fixpoints.append((old.id, min(0.0, t_lo - old.t_lo)))
                return
            seen.add(item)
        heapq.heappush(self.queue, (t_lo, item.id, item))

    def _reason(self, text: str) -> None:
        if text not in self.reasons:
            self.reasons.append(text)

    def stepper(self, mode: str, phase: Phase = ()) -> FlowStepper:
        key = (mode, phase)
        if key not in self.steppers:
            flow = self.phases.flow(mode, phase) if phase else None
            self.steppers[key] = FlowStepper(self.system, mode, self.options, flow)
        return self.steppers[key]

    def record(self, item: Item, H: Zonotope, t0: float, t1: float,
               inside: bool = False, ends: tuple[Zonotope, Zonotope | None] | None = None
               ) -> None:
        """Keep ``H``, the set over ``[t0, t1]`` (``inside``: known to lie within the mode's
        invariant, so its hull needs no cut; ``ends``: the sets at ``t0`` and ``t1``, to
        tell a spec that fails only between the two instants)."""
        full = H
        box = H.bounds()
        rows = self.stepper(item.mode, item.phase).mode.invariants
        within = (rows.range(H)[:, 0] >= 0 if rows.size and not inside
                  else np.ones(rows.size, dtype=bool))
        for i in np.flatnonzero(rows.linear & ~within):  # exact hull of H within the invariant
            cut = H.bounds_in_slab(rows.a[i], -rows.b[i], np.inf)
            if cut is not None:
                box = np.column_stack([np.maximum(box[:, 0], cut[:, 0]),
                                       np.minimum(box[:, 1], cut[:, 1])])
        rs = ReachSet(mode=item.mode, t=(float(np.nextafter(t0, -np.inf)),
                                         float(np.nextafter(min(t1, self.t_end), np.inf))),
                      jumps=item.jumps,
                      set=full if full.dim == self.n else full.project(range(self.n)), _full=full,
                      _context=self.context, _box=box[:self.n])
        self.records.append((item.id, rs))
        for spec, lower in zip(self.stop_unproved, lowers_on(self.stop_unproved, rs),
                               strict=True):
            if lower is not None and not spec.holds(lower):
                self._note_bend(item)
                raise _Unproved(self._between(item, spec, ends, rs.t),
                                f"stopped at the first set that does not prove spec "
                                f"{spec.text!r} (t in [{rs.t[0]:.6g}, {rs.t[1]:.6g}] in mode "
                                f"{rs.mode!r}, bound {lower:.6g})")
        if len(self.records) > self.options.max_sets:
            raise _Budget(f"max_sets={self.options.max_sets} flowpipe sets computed; the "
                          f"analysis stopped early (raise max_sets or the step)")
        self.kept_bytes += rs.nbytes
        if self.kept_bytes > self.options.max_memory * 2**30:
            held = ("" if not self.options.memory_held else
                    f", and {self.options.memory_held:.3g} GiB held for the other analyses "
                    f"sharing the budget")
            raise _Budget(f"max_memory={self.options.max_memory:g} GiB of flowpipe sets kept "
                          f"({len(self.records)} sets here{held}); the analysis stopped early "
                          f"(raise max_memory, or lower order or the number of branches)")
        if len(self.records) % 16 == 0:
            self._watch(item.mode, t1)

    def _watch(self, mode: str, t: float) -> None:
        """The time budget, and progress on a terminal for runs longer than 3 s."""
        now = _time.time()
        deadline = self.options.deadline
        if deadline is not None and now > deadline:
            budget = self.options.time_budget
            what = "the time budget" if budget is None else f"the time budget of {budget:g} s"
            raise _Budget(f"{what} ran out at t = {t:.6g} in mode {mode!r}; the sets so far "
                          "are kept")
        show = self.options.progress
        if show is None:
            show = self.progress_tty
        if show and now - self.started > 3.0 and now - self.shown >= 1.0:
            self.shown = now
            print(f"\rreach: t = {t:.6g} of {self.t_end:g} in mode {mode!r}, "
                  f"{len(self.records)} sets, {len(self.queue)} waiting, "
                  f"{now - self.started:.0f} s ", end="", file=sys.stderr, flush=True)

    # ----- one item -----------------------------------------------------------------------
    def flow(self, item: Item) -> None:
        system = self.system
        cmode = self.compiled.modes[item.mode]
        stepper = self.stepper(item.mode, item.phase)
        mode = stepper.mode  # with the phase's flow and sides (reachability.phases)
        stepper.reset()
        guarded = [tr for tr in cmode.outgoing
                   if not tr.scheduled and tr.index not in self.sliced.transitions]
        scheduled = [tr for tr in cmode.outgoing
                     if tr.scheduled and self.schedules.get(tr.index) is not None]
        exact_time = item.t_lo == item.t_hi
        if scheduled and not exact_time:
            names = ", ".join(tr.name for tr in scheduled)
            self._reason(f"mode {item.mode!r} is entered at an uncertain time "
                         f"[{item.t_lo:.6g}, {item.t_hi:.6g}] and has scheduled transitions "
                         f"({names}); that branch was not followed")
            return
        self._entry_outside_invariant(item, guarded)
        # guard rows that the flow leaves from the initial set (see the module docstring)
        leaving: dict[int, set[int]] = {}
        scale = 1.0 + float(np.max(np.abs(item.P.bounds())))
        for tr in guarded:
            rows = system.guards[tr.index]
            rng = rows.range(item.P)
            leaving[tr.index] = {i for i in range(rows.size) if rng[i, 1] <= 1e-12 * scale}
        # each guard's current run of hits: (step set, its times, the step's start set, r)
        clusters: dict[int, list[Hit]] = {tr.index: [] for tr in guarded}
        P = item.P
        # which guards no entry state fires at once: there, every firing comes up from below
        from_below: dict[int, bool] = {}
        for tr in guarded:
            rng = system.guards[tr.index].range(P)
            from_below[tr.index] = bool(np.any(rng[:, 1] < 0))
        # an entry set across the one guard that may hold on it: its inner part fires at
        # once (no other transition could take it instead) and the rest flows on
        may_fire = [tr for tr in guarded if not (from_below[tr.index] or leaving[tr.index])]
        if len(may_fire) == 1 and not scheduled:
            split = self._entry_split(item, may_fire[0], P)
            if split is not None:
                P, from_below[may_fire[0].index] = split, True
        P_next: Zonotope | None  # None once cut away by the invariant
        H: Zonotope | None
        rel = 0.0
        now = item.t_lo  # exact current time (only meaningful when exact_time)
        done_at = item.sched_done
        # quiet stretches of an affine chain are taken many steps at a time (_quiet_steps)
        landings = 0  # steps shortened in a row to land on a guard's crossing instant
        quiet = _QuietRun(not scheduled and bool(np.all(mode.invariants.linear)) and all(
            bool(np.all(system.guards[tr.index].linear)) for tr in guarded))
        sides = PhaseWatch(self.phases, item.mode, item.phase, item.P, stepper.sign_ranges,
                           lambda text, side, to, run: self._phase_jump(item, text, side, to,
                                                                        run))
        while True:
            start_lo = item.t_lo + rel if not exact_time else now
            if quiet.due() and not any(clusters.values()):
                chain = stepper.quiet_chain(P, self.step)
                if chain is not None:
                    taken, P, rel, now = self._quiet_steps(item, stepper, chain, P, rel, now,
                                                           exact_time, guarded, leaving,
                                                           quiet.size)
                    quiet.ran(taken)
                    if taken:
                        continue
            if scheduled:
                instant, due = self._next_scheduled(scheduled, now, done_at)
                if instant == now and due:
                    if self._fire_scheduled(item, due, P, now):
                        break  # a transition without guard fired: no flow in this mode
                    done_at = (now, frozenset(tr.index for tr in due))
                    continue
            if start_lo >= self.t_end:
                self.open_branches += 1
                if rel == 0.0:  # entered at t_end: the set itself is all there is
                    self.record(item, P, item.t_lo, item.t_hi)
                break
            straddled = (self.phases.straddled(item.mode, item.phase, P, self.step)
                         if self.options.sign_phases and self.phase_items < MAX_PHASE_ITEMS
                         else None)
            if straddled is not None:
                self._split(item, straddled, P, start_lo,
                            now if exact_time else item.t_hi + rel,
                            done_at if exact_time else None)
                break
            r = min(self.step, self.t_end - start_lo)
            if scheduled and instant < now + r:
                r = instant - now
            if r <= 0:
                r = self.step
            if landings < _LANDINGS:
                landed = self._landing(item.mode, guarded, P, r, start_lo)
                landings = landings + 1 if landed < r else 0
                r = landed
            try:
                P_next, H = stepper.step(P, r)
            except (StepError, SetError) as exc:  # SetError: a set became non-finite
                text = f"mode {item.mode!r} at t = {start_lo:.6g}: {exc}"
                if isinstance(exc, RemainderError):
                    self.too_wide.add(text)
                    self._note_bend(item)
                self._reason(text)
                break
            t0 = start_lo
            t1 = (now + r) if exact_time else item.t_hi + rel + r
            reaching = H  # before the cuts: does the flow reach a surface?
            stepped = P_next
            H = _within(stepper.reduce(H, self.options.order), mode.invariants)
            P_next = _within(stepper.reduce(P_next, self.options.order), mode.invariants)
            if item.phase:
                H = self._in_phase(item, stepper, H)
                P_next = self._in_phase(item, stepper, P_next)
            stepper.continued(stepped, P_next)
            if H is None:
                break  # every trajectory has left the mode
            inv = mode.invariants.range(H)
            if inv.size and np.any(inv[:, 1] < 0):
                break
            self.record(item, H, t0, t1, ends=(P, P_next))
            stop = False
            for tr in guarded:
                rows = system.guards[tr.index]
                rng = rows.range(H)
                may = bool(np.all(rng[:, 1] >= 0))
                if may and leaving[tr.index]:
                    lie = self._lie(item.mode, tr.index)
                    u_lo, u_hi = system.input_box(item.mode)
                    box = H.bounds()
                    lo, hi = lie(np.r_[box[:, 0], u_lo], np.r_[box[:, 1], u_hi])
                    still = {i for i in leaving[tr.index] if hi[i] < 0}
                    leaving[tr.index] = still
                    if still:
                        may = False
                elif leaving[tr.index]:
                    leaving[tr.index] = set()
                if may:
                    clusters[tr.index].append((H, t0, t1, P, r))
                    # every trajectory meets the guard during the step, or at its end
                    if rows.size == 0 or bool(np.all(rng[:, 0] > 0)) or (
                            P_next is not None and bool(np.all(rows.range(P_next)[:, 0] > 0))):
                        stop = True
                elif clusters[tr.index]:
                    self._jump(item, tr, clusters[tr.index], from_below[tr.index])
                    clusters[tr.index] = []
            if sides.step(P, H, reaching, P_next, t0, t1):
                stop = True
            if stop or P_next is None:
                break
            P = P_next
            rel += r
            now = now + r
            if scheduled and abs(now - instant) <= 1e-12 * max(1.0, abs(instant)):
                now = instant
        for tr in guarded:
            if clusters[tr.index]:
                self._jump(item, tr, clusters[tr.index], from_below[tr.index])
        sides.flush()

    def _in_phase(self, item: Item, stepper: FlowStepper, Z: Zonotope | None
                  ) -> Zonotope | None:
        """``Z`` cut to where solutions may still be in the item's phase: on the side of
        each surface it is above or below, and where it slides, where the surface still
        attracts (``up <= 0 <= down``)."""
        Z = self.phases.to_sides(item.mode, item.phase, Z)
        for text, side in item.phase:
            if side == 0 and Z is not None:
                signs = stepper.sign_ranges(Z)
                Z = self.phases.where_rate(item.mode, text, Z, signs, 1.0, -np.inf, 0.0)
                Z = self.phases.where_rate(item.mode, text, Z, signs, -1.0, 0.0, np.inf)
        return Z

    def _split(self, item: Item, text: str, P: Zonotope, t_lo: float, t_hi: float,
               sched_done: tuple[float, frozenset[int]] | None) -> None:
        """Continue ``P`` (at times ``[t_lo, t_hi]``) as two items, one on each side of
        the surface of switch ``text`` (:mod:`.phases`)."""
        for side, part in zip((1.0, -1.0), self.phases.split(item.mode, text, P), strict=True):
            if part is not None:
                self.phase_items += 1
                self.push(item.id, item.mode, part, t_lo, t_hi, item.jumps + 1, sched_done,
                          with_phase(item.phase, text, side))

    def _phase_jump(self, item: Item, text: str, side: float, to: float | None,
                    run: list[Step]) -> None:
        """Continue a run of steps ``(start set, step set, t0, t1)`` that may leave
        ``side`` of switch ``text``: their sets, joined and cut to its surface, enter side
        ``to``, or (``None``) each phase that may follow a solution reaching the surface
        from ``side`` (:mod:`.phases`).

        The join is one step of the run's whole length from its first start set: it holds
        every state of the run's steps, with the flow's correlations (a box or a sweep of
        the step sets would lose those between the states a stiff feedback ties together).
        """
        stepper = self.stepper(item.mode, item.phase)
        t_lo = run[0][2]
        t_hi = min(run[-1][3], self.t_end)
        joined = run[0][1]
        if len(run) > 1:
            # the run's length: from its first step's start to its last step's end
            length = run[-1][3] - run[0][2] - (item.t_hi - item.t_lo)
            try:
                joined = stepper.span(run[0][0], length)
            except (StepError, SetError):
                box = hull([H.bounds() for _, H, _, _ in run])
                joined = Box(box[:, 0], box[:, 1]).to_zonotope()
        on = self.phases.on_surface(item.mode, text, joined)
        if on is None:
            return
        on = on.reduce(self.options.order)
        signs = stepper.sign_ranges(on)
        where = self.phases.where_rate
        if to is not None:  # a slide ends where the rate on side ``to`` comes to 0
            entries = [(to, where(item.mode, text, on, signs, to, 0.0, 0.0))]
        else:  # from above it slides where down >= 0, and crosses where down <= 0
            entries = [(0.0, where(item.mode, text, on, signs, -side, 0.0, np.inf) if side > 0
                        else where(item.mode, text, on, signs, -side, -np.inf, 0.0)),
                       (-side, where(item.mode, text, on, signs, -side, -np.inf, 0.0)
                        if side > 0 else where(item.mode, text, on, signs, -side, 0.0, np.inf))]
        if self.phase_items >= MAX_PHASE_ITEMS:  # no more phases: the sign in [-1, 1] again
            self.push(item.id, item.mode, on, t_lo, t_hi, item.jumps + 1,
                      phase=without_phase(item.phase, text))
            return
        for target, entry in entries:
            if entry is not None:
                self.phase_items += 1
                self.push(item.id, item.mode, entry, t_lo, t_hi, item.jumps + 1,
                          phase=with_phase(item.phase, text, target))

    def _note_bend(self, item: Item) -> None:
        """Keep where the root item's Taylor model bends most, as the analysis ends there."""
        stepper = self.steppers.get((item.mode, item.phase))
        if item.parent is None and stepper is not None:
            self.split_direction = stepper.bent_direction(item.P)

    def _between(self, item: Item, spec: Spec, ends: tuple[Zonotope, Zonotope | None] | None,
                 t: tuple[float, float]) -> bool:
        """Whether ``spec`` holds on both ``ends``: the sets at the instants that bound
        the set which failed it (so a smaller step may prove it)."""
        if ends is None:
            return False
        for E in ends:
            if E is None:  # the step's end set left the mode: no instant to compare with
                return False
            rs = ReachSet(mode=item.mode, t=t, jumps=item.jumps, set=E.project(range(self.n)),
                          _full=E, _context=self.context, _box=E.bounds()[:self.n])
            lower = spec.lower_on(rs)
            if lower is None or not spec.holds(lower):
                return False
        return True

    def _quiet_steps(self, item: Item, stepper: FlowStepper, chain: AffineChain, P: Zonotope,
                     rel: float, now: float, exact_time: bool, guarded,
                     leaving: dict[int, set[int]], size: int
                     ) -> tuple[int, Zonotope, float, float]:
        """Take the next steps of ``chain`` while they are quiet, up to ``size`` of them.

        A step is quiet when its set lies inside the mode's invariant (no cut) and meets
        no guard (no jump): then :meth:`flow` would only record it. The sets, their
        invariant and guard bounds come from one stacked computation
        (:meth:`AffineChain.ahead`); each set is the one the step would give, recorded
        as it would record it. The bounds here are support functions rounded up, with a
        relative slack ten times the one of ``Rows.range``, so every step that the
        one-step path would treat as meeting a guard or the invariant's boundary ends
        the run here first. Returns ``(steps taken, end set, rel, now)``.
        """
        r = self.step
        start = item.t_lo + rel if not exact_time else now
        full = int((self.t_end - start) / r) - 1  # whole steps, the last one left to flow
        ahead = chain.ahead(min(size, full)) if full >= 1 else None
        if ahead is None:
            return 0, P, rel, now
        system = self.system
        quiet = np.ones(len(ahead), dtype=bool)
        inv = stepper.mode.invariants
        if inv.size:  # min over the set of a z + b must stay >= 0
            support = ahead.supports(-inv.a)
            quiet &= np.all(inv.b - support >= _QUIET_SLACK * (np.abs(support)
                                                              + np.abs(inv.b)), axis=1)
        for tr in guarded:  # some row's max of a z + b below 0: the guard is not met
            rows = system.guards[tr.index]
            if rows.size == 0:
                quiet[:] = False
                break
            support = ahead.supports(rows.a)
            quiet &= np.any(support + rows.b < -_QUIET_SLACK * (np.abs(support)
                                                                + np.abs(rows.b)), axis=1)
        taken = len(ahead) if bool(quiet.all()) else int(np.argmin(quiet))
        for j in range(taken):
            t0 = item.t_lo + rel if not exact_time else now
            t1 = (now + r) if exact_time else item.t_hi + rel + r
            self.record(item, ahead.set(j), t0, t1, inside=True)
            rel += r
            now = now + r
        if taken:
            for tr in guarded:
                leaving[tr.index] = set()  # not met on the way: no longer "leaving"
            P = stepper.skip(chain, ahead, taken)
        return taken, P, rel, now

    def _entry_outside_invariant(self, item: Item, guarded) -> None:
        """States entering outside the mode's invariant cannot flow: at the entry instant they
        jump, if a guard holds (or the simulator stops). Record them and take those jumps.

        States inside the invariant are left to the flow (with its leaving rule), so a ball
        bouncing off ``h = 0`` is not bounced again here."""
        rows = self.system.modes[item.mode].invariants
        if rows.size == 0:
            return
        rng = rows.range(item.P)
        # below -1e-9 relative: the rounding slack of a set entered on the boundary (a ball
        # reset at h = 0) must not count; states nearer the boundary than that are caught by
        # the first step's guard cluster
        tol = 1e-9 * (1.0 + float(np.max(np.abs(item.P.bounds()))))
        outside = np.flatnonzero(rng[:, 0] < -tol)
        if outside.size == 0:
            return
        self.record(item, item.P, item.t_lo, item.t_hi)
        for i in outside:
            # the part of P with row_i <= 0, i.e. a z + b <= 0 (all of P for a nonlinear row)
            piece = (item.P.intersect_halfspace(rows.a[i], -rows.b[i]) if rows.linear[i]
                     else item.P)
            if piece is None:
                continue
            for tr in guarded:
                guard = self.system.guards[tr.index]
                if guard.size and np.any(guard.range(piece)[:, 1] < 0):
                    continue
                self._fire(item, tr, self._cut(piece, guard, self.no_rows), item.t_lo,
                           item.t_hi)

    def _landing(self, mode: str, guarded, P: Zonotope, r: float, t: float) -> float:
        """The step length ``r``, shortened to land on the instant a guard is crossed
        when that instant is known sharply.

        A guard whose unmet rows each have a known value over the time-point set ``P``
        and a known positive rate (the clock ``tau >= 0.4``, or ``v_s + a_s tau >= v_max``
        with ``v_s`` and ``a_s`` known) is met by every trajectory at nearly one instant.
        Stepping across it would put a whole step's hull through the jump (a smear of
        the step in time); landing just short of it, then taking one tiny step across,
        puts only the time-point set there. Only the step length changes, so this needs no proof: a
        prediction that is off merely costs a step.
        """
        tiny = _TINY_STEP * (1.0 + abs(t))
        box = P.bounds()
        u_lo, u_hi = self.system.input_box(mode)
        best = r
        for tr in guarded:
            rows = self.system.guards[tr.index]
            if rows.size == 0:
                continue
            rng = rows.range(P, box)
            unmet = np.flatnonzero(rng[:, 0] <= 0)
            early = late = 0.0
            if unmet.size:
                values = rng[unmet]
                if np.any(values[:, 1] - values[:, 0]
                          > _POINT * (1.0 + np.max(np.abs(values), axis=1))):
                    continue  # a value spread over the set: no sharp instant (rates unasked)
                rate_lo, rate_hi = self._lie(mode, tr.index)(np.r_[box[:, 0], u_lo],
                                                            np.r_[box[:, 1], u_hi])
                if not np.all(rate_lo[unmet] > 0):
                    continue
                early = float(np.max(np.maximum(0.0, -rng[unmet, 1]) / rate_hi[unmet]))
                late = float(np.max(-rng[unmet, 0] / rate_lo[unmet]))
            if not (late - early <= _SHARP * r and early - tiny < r):
                continue
            # just short of the instant (so the step's hull misses the guard), then across
            best = min(best, early - tiny if early >= 2 * tiny else late + tiny)
        return best

    def _lie(self, mode: str, index: int) -> IntervalFunction:
        key = (mode, index)
        if key not in self.lie:
            self.lie[key] = self.system.modes[mode].lie(self.system.guards[index])
        return self.lie[key]

    # ----- scheduled transitions ------------------------------------------------------------
    def _next_scheduled(self, scheduled, now, done_at):
        best, due = math.inf, []
        for tr in scheduled:
            period, phase = self.schedules[tr.index]
            k = schedule_index(now, phase, period, done=-1)
            s = phase + k * period
            if done_at is not None and abs(done_at[0] - s) <= 1e-12 * max(1.0, abs(s)) \
                    and tr.index in done_at[1]:
                s = phase + (k + 1) * period
            if abs(s - now) <= SCHEDULE_SLACK * period:
                s = now
            if s < best - 1e-12 * max(1.0, abs(s)):
                best, due = s, [tr]
            elif abs(s - best) <= 1e-12 * max(1.0, abs(s)):
                due.append(tr)
        return best, sorted(due, key=lambda tr: tr.order_key)

    def _fire_scheduled(self, item: Item, due, P: Zonotope, now: float) -> bool:
        """Fire the scheduled transitions due now from the time-point set ``P``.

        Returns whether one of them must fire (so the flow in this mode ends)."""
        self.record(item, P, now, now)  # the pre-jump states at the instant itself
        fired = frozenset(tr.index for tr in due)
        previous = item.sched_done[1] if item.sched_done and item.sched_done[0] == now else \
            frozenset()
        for tr in due:
            rows = self.system.guards[tr.index]
            rng = rows.range(P)
            if rows.size and np.any(rng[:, 1] < 0):
                continue
            # no invariant cut: at an entry instant P may lie partly outside it
            piece = self._cut(P, rows, self.no_rows)
            if piece is None:
                continue
            try:
                post = self._reset(tr.index, piece)
            except StepError as exc:  # the branch is not followed: the result says so
                self._too_wide_for_reset(exc)
            else:
                self.push(item.id, tr.target, post, now, now, item.jumps + 1,
                          (now, previous | fired), self._carried(item, tr))
            if rows.size == 0 or np.all(rng[:, 0] > 0):
                return True
        return False

    # ----- jumps ----------------------------------------------------------------------------
    def _cut(self, Z: Zonotope, guard: Rows, invariant: Rows) -> Zonotope | None:
        """``Z`` intersected with the guard and invariant rows, over-approximated by a box
        (or ``Z`` itself when nothing cuts it)."""
        A, b = _linear_rows(guard, invariant)
        box: np.ndarray | None = Z.bounds()
        if A.shape[0] and self.options.intersection == "lp":
            box = Z.bounds_within(A, b)
            if box is None:
                return None
        for rows in (guard, invariant):
            box = _clip_axis(box, rows) if box is not None else None
        if box is None:
            return None
        return Box(box[:, 0], box[:, 1]).to_zonotope()

    def _too_wide_for_reset(self, exc: StepError) -> None:
        """A set on which a reset is unbounded: like a remainder that does not settle, a set
        too wide for its enclosure, which a smaller set (step or piece) may avoid."""
        self.too_wide.add(str(exc))
        self._reason(str(exc))

    def _reset(self, index: int, Z: Zonotope) -> Zonotope:
        reset = self.system.resets[index]
        M = reset.matrix
        if M is not None:
            return Z.linear_map(M, reset.offset)
        box = Z.bounds()
        z_star = Z.center
        nz = Z.dim
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # checked below
            value = reset.value(z_star)
            lo, hi = reset.jacobian_interval(box[:, 0], box[:, 1])
            J_lo, J_hi = lo.reshape(nz, nz), hi.reshape(nz, nz)
            J_mid, J_rad = 0.5 * (J_lo + J_hi), 0.5 * (J_hi - J_lo)
        if not (np.all(np.isfinite(J_mid)) and np.all(np.isfinite(value))):
            raise StepError(f"reset of transition {self.compiled.transitions[index].name!r} "
                            "is unbounded over the set")
        dev = np.maximum(np.abs(box[:, 0] - z_star), np.abs(box[:, 1] - z_star))
        rad = J_rad @ dev + SLACK * (np.abs(value) + np.abs(J_mid) @ dev) + TINY
        G = np.hstack([J_mid @ Z.generators, np.diag(rad)])
        return Zonotope(value, G)

    def _entry_split(self, item: Item, tr, P: Zonotope) -> Zonotope | None:
        """An entry set ``P`` across a guard with one row in doubt: its part inside the
        guard jumps at the entry instant, and the part outside is returned to flow on
        (urgent semantics: a state inside a guard does not flow). ``None`` (nothing done)
        unless that row's range over ``P`` is well on both sides of 0."""
        guard = self.system.guards[tr.index]
        rng = guard.range(P)
        doubt = np.flatnonzero(rng[:, 0] < 0)
        if doubt.size != 1:
            return None
        i = int(doubt[0])
        lo, hi = rng[i]
        if not (lo < -_ACROSS * (1.0 + abs(lo) + abs(hi)) and hi > _ACROSS * (1.0 + abs(lo)
                                                                          + abs(hi))):
            return None  # on the surface to within rounding: the step sets take it
        a, e_lo, e_hi = guard.affine_bounds(P)
        if not (np.all(np.isfinite(a[i])) and np.isfinite(e_lo[i]) and np.isfinite(e_hi[i])):
            return None
        invariant = self.system.modes[item.mode].invariants
        inside = P.intersect_halfspace(-a[i], e_hi[i])  # g_i = a z + e >= 0
        self._fire(item, tr, _within(_within(inside, guard), invariant), item.t_lo, item.t_hi)
        return P.intersect_halfspace(a[i], -e_lo[i])  # g_i <= 0

    def _jump(self, item: Item, tr, cluster: list[Hit], from_below: bool) -> None:
        guard = self.system.guards[tr.index]
        invariant = self.system.modes[item.mode].invariants
        # a trajectory fires at its entry, or where the guard's last row to hold comes up
        # to 0 (_firing_surface): a step set inside the guard holds no firing of its own,
        # and one with a single unmet row fires on that row's surface; the first step set
        # also holds the entry instant, unless no entry state fires there (from_below)
        pieces, sets, raw, rows, hit = [], [], [], [], []
        for k, (H, t0, t1, _, _) in enumerate(cluster):
            row = -1
            if guard.size and (from_below or t0 != item.t_lo):
                unmet = np.flatnonzero(guard.range(H)[:, 0] < 0)
                if unmet.size == 0:
                    continue
                row = int(unmet[0]) if unmet.size == 1 else -1
            on = H if row < 0 else _firing_surface(H, guard, row)
            piece = None if on is None else self._cut(on, guard, invariant)
            if piece is not None and on is not None:
                pieces.append((piece.bounds(), t0, t1))
                sets.append(on)
                raw.append(H)
                rows.append(row)
                hit.append(k)
        A, b = _linear_rows(guard, invariant)
        for group in groups(pieces, self.options.clustering):
            t_lo = min(pieces[k][1] for k in group)
            t_hi = max(pieces[k][2] for k in group)
            box = hull([pieces[k][0] for k in group])
            joined: Zonotope | None = None
            if self.options.clustering == "sweep":
                joined = sweep_hull([raw[k] for k in group])
                if joined is not None and not _frames_alike(joined, hull([raw[k].bounds()
                                                                         for k in group])):
                    joined = None  # the sets' generators do not correspond
            cut = None if joined is None else _within(_within(joined, guard), invariant)
            if joined is None and len(group) == 1:
                # one hit (a guard crossed within one step, such as a clock's instant landed
                # on): its own set, cut, where that is no wider than the box on any state,
                # keeps the correlations any box loses
                own = _within(_within(sets[group[0]], guard), invariant)
                if own is not None and _no_wider(own, box):
                    joined, cut = sets[group[0]], own
            if joined is not None:
                pre = cut
                row = rows[group[0]]
                if pre is not None and row >= 0 and all(rows[k] == row for k in group):
                    pre = _firing_surface(pre, guard, row)
            elif self.options.intersection == "lp":
                pre = oriented_hull([sets[k] for k in group], A, b, box,
                                    [pieces[k][0] for k in group])
            else:
                pre = Box(box[:, 0], box[:, 1]).to_zonotope()
            if joined is None and pre is not None and self.options.clustering == "sweep":
                row = rows[group[0]] if all(rows[k] == rows[group[0]] for k in group) else -1
                pre = self._spanned(item, cluster[hit[group[0]]:hit[group[-1]] + 1], pre,
                                    guard, invariant, row)
            self._fire(item, tr, pre, t_lo, t_hi)

    def _spanned(self, item: Item, run: list[Hit], pre: Zonotope, guard: Rows,
                 invariant: Rows, row: int) -> Zonotope:
        """``pre``, a join of a run's firing states, tightened by the correlations the flow
        gives them: one step of the run's whole length from its first start set
        (:meth:`FlowStepper.span`, which holds every state of the run) cut to ``pre``'s
        frame (its support along each axis and each of its generators' dual directions),
        to the guard and invariant, and to the surface of guard row ``row`` where every
        step of the run fires on it (``-1``: none); ``pre`` itself where that step fails.
        Both hold every firing state, so their intersection does."""
        try:
            Z: Zonotope | None = self.stepper(item.mode, item.phase).span(
                run[0][3], sum(hit[4] for hit in run))
        except (StepError, SetError):
            return pre
        with np.errstate(all="ignore"):
            duals = np.linalg.pinv(pre.generators).T if pre.generators.size else None
        directions = [np.eye(pre.dim)]
        if duals is not None and np.all(np.isfinite(duals)):
            directions.append(duals.T)
        D = np.vstack(directions)
        D = D[np.any(D != 0, axis=1)]
        highs, lows = pre.supports(D), -pre.supports(-D)
        for d, lo, hi in zip(D, lows, highs, strict=True):
            if Z is None:
                return pre
            Z = Z.intersect_slab(d, lo, hi)
        Z = _within(_within(Z, guard), invariant) if Z is not None else None
        if Z is not None and row >= 0:
            Z = _firing_surface(Z, guard, row)
        return pre if Z is None else Z

    def _fire(self, item: Item, tr, pre: Zonotope | None, t_lo: float, t_hi: float) -> None:
        """Reset ``pre`` (``None``: nothing fires) and put it on the waiting list."""
        if pre is None:
            return
        try:
            post = self._reset(tr.index, pre)
        except StepError as exc:
            self._too_wide_for_reset(exc)
            return
        self.push(item.id, tr.target, post, t_lo, min(t_hi, self.t_end), item.jumps + 1,
                  phase=self._carried(item, tr))

    def _carried(self, item: Item, tr) -> Phase:
        return self.phases.carried(item.phase, tr.target, self.system.resets[tr.index])

    # ----- driver ---------------------------------------------------------------------------
    def run(self) -> None:
        while self.queue:
            _, _, item = heapq.heappop(self.queue)
            self.flow(item)

    def finish(self, started: float) -> ReachResult:
        records = self.records
        if self.fixpoints:
            children: dict[int, list[int]] = {}
            for it in self.items.values():
                if it.parent is not None:
                    children.setdefault(it.parent, []).append(it.id)
            shift: dict[int, float] = {}
            for root, lo_shift in self.fixpoints:
                stack = [root]
                while stack:
                    i = stack.pop()
                    shift[i] = min(shift.get(i, 0.0), lo_shift)
                    stack.extend(children.get(i, []))
            records = [(i, replace(rs, t=(rs.t[0] + shift[i], self.t_end)) if i in shift else rs)
                       for i, rs in records]
        sets = tuple(rs for _, rs in records)
        names = self.compiled.state_names
        if sets:
            allb = np.stack([s.bounds() for s in sets])
            lo, hi = allb[:, :, 0].min(axis=0), allb[:, :, 1].max(axis=0)
            bounds = {n: (float(lo[i]), float(hi[i])) for i, n in enumerate(names)}
        else:
            bounds = {}
        complete = not self.reasons
        return ReachResult(
            sets=sets, bounds=bounds, reachable_modes=frozenset(s.mode for s in sets),
            complete=complete, incomplete_reasons=tuple(self.reasons),
            too_wide=bool(self.too_wide) and self.too_wide == set(self.reasons),
            fixpoint=complete and bool(self.fixpoints) and self.open_branches == 0,
            nonlinear=any(not self.system.modes[m].affine for m, _ in self.steppers),
            time_s=_time.perf_counter() - started, state_names=names,
            t_span=(self.t_start, self.t_end), options=self.options)


class _Budget(Exception):  # noqa: N818 - a signal, not an error
    pass


_QUIET_SLACK = 1e-12
"""Relative slack of the quiet-step tests (ten times that of ``Rows.range``)."""
_QUIET_FIRST = 8
"""Steps looked ahead at first; the look-ahead doubles while every step is quiet ..."""
_QUIET_MOST = 256
"""... up to this many."""
_QUIET_PAUSE = 8
"""Steps taken one at a time after a look-ahead found its first step not quiet."""


class _QuietRun:
    """When :meth:`_Analysis.flow` looks ahead for quiet steps, and how far.

    Examples
    --------
    >>> run = _QuietRun(True)
    >>> run.due(), run.size
    (True, 8)
    >>> run.ran(8); run.size
    16
    >>> run.ran(0); [run.due() for _ in range(9)].count(True)
    1
    """

    def __init__(self, possible: bool) -> None:
        self.possible = possible
        self.size = _QUIET_FIRST
        self.pause = 0

    def due(self) -> bool:
        """Whether to look ahead before this step (counts the paused steps down)."""
        if not self.possible:
            return False
        if self.pause:
            self.pause -= 1
            return False
        return True

    def ran(self, taken: int) -> None:
        """A look-ahead took ``taken`` steps."""
        if taken == self.size:
            self.size = min(2 * self.size, _QUIET_MOST)
        elif taken == 0:
            self.size, self.pause = _QUIET_FIRST, _QUIET_PAUSE
        else:
            self.size = max(_QUIET_FIRST, taken)


class _Unproved(_Budget):
    """A set does not prove one of the specs the analysis was asked to stop on;
    ``between``: the sets at both ends of its step prove it."""

    def __init__(self, between: bool, text: str) -> None:
        super().__init__(text)
        self.between = between


def _widened(P0: Zonotope, sliced: Slice) -> Zonotope:
    """``P0`` with each unread variable's dimension replaced by its hull (and no longer
    correlated with the others: nothing reads it)."""
    if not sliced.hulls:
        return P0
    box = P0.bounds()
    lo, hi = sliced.widen(box[:, 0], box[:, 1])
    rows = list(sliced.hulls)
    c, G = P0.center.copy(), P0.generators.copy()
    G[rows] = 0.0
    c[rows] = 0.5 * (lo[rows] + hi[rows])
    E = np.zeros((P0.dim, len(rows)))
    E[rows, range(len(rows))] = np.nextafter(np.maximum(hi[rows] - c[rows], c[rows] - lo[rows]),
                                             np.inf)
    return Zonotope(c, np.hstack([G, E]))


def run_analysis(system: System, options: ReachOptions, mode: str, P0: Zonotope,
                 t_start: float, t_end: float, p: np.ndarray,
                 stop_unproved: Sequence[Spec] = ()) -> ReachResult:
    """Run the analysis from one initial item (used by :func:`hybridlab.reach`); it ends,
    incomplete, at the first set that does not prove one of ``stop_unproved``.

    Examples
    --------
    >>> import hybridlab
    >>> from hybridlab.reachability.system import build_system
    >>> compiled = hybridlab.compile_model(hybridlab.load_model("models/thermostat.toml"))
    >>> p = compiled.parameter_vector()
    >>> system = build_system(compiled, p, {}, {})
    >>> result = run_analysis(system, ReachOptions(step=0.1), "heat", Zonotope([20.0], [[1.0]]),
    ...                       0.0, 1.0, p)
    >>> result.complete, sorted(result.reachable_modes), len(result.sets)
    (True, ['cool', 'heat'], 16)
    >>> cut = run_analysis(system, ReachOptions(step=0.1, max_jumps=0), "heat",
    ...                    Zonotope([20.0], [[1.0]]), 0.0, 1.0, p)
    >>> cut.complete
    False
    >>> print(cut.incomplete_reasons[0])
    max_jumps=0 reached: a branch entering mode 'cool' at t in [0.5, 1] was not followed
    """
    started = _time.perf_counter()
    analysis = _Analysis(system, options, t_start, t_end, p, stop_unproved)
    analysis.push(None, mode, _widened(P0, analysis.sliced), t_start, t_start, 0)
    stopped = between = False
    try:
        analysis.run()
    except _Budget as exc:
        analysis._reason(str(exc))
        stopped = isinstance(exc, _Unproved)
        between = isinstance(exc, _Unproved) and exc.between
    if analysis.shown:
        print(file=sys.stderr)  # end the progress line
    return replace(analysis.finish(started), stopped_unproved=stopped,
                   unproved_between_steps=between, split_direction=analysis.split_direction)
