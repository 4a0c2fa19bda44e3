"""Verdicts: SAFE (proved by reachability), UNSAFE (a counterexample), UNKNOWN (and why).

:func:`check` first tries a quick proof: the flowpipes at the default step, ended at
the first set that does not prove every spec or after a second; a proof needs no
simulation, so a small model is proved before the simulator would have loaded. When that
set fails a spec only between two step instants (the sets at both ends of its step prove
every spec), the step is halved, still before any simulation, while that stays so.
Otherwise falsification by simulation from the centre, corners and samples of the
initial set (:mod:`hybridlab.reachability.falsify`) runs; a violation found there
is a concrete trajectory, so the verdict is UNSAFE. Otherwise the flowpipes of
:func:`hybridlab.reach` are computed and every spec is bounded over every reach
set of the modes it covers (``ReachSet.bound``: exact for rows linear in the
states, interval arithmetic otherwise). All lower bounds ``>= 0`` (``> 0`` for
a region to avoid) on a complete reach result (every branch followed to
``t_end``) is a proof: SAFE. Anything else is UNKNOWN, with the reason and the
tightest bound, its mode and its time interval. The falsification's local
search (many more simulations) runs only where the flowpipes did not prove
every spec, so it can still turn an unproved spec into UNSAFE.
"""

from __future__ import annotations

import enum
import math
import time
import weakref
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from hybridlab.errors import HybridlabError
from hybridlab.model.schema import Model
from hybridlab.reachability.falsify import (
    Counterexample,
    Falsification,
    FalsificationSearch,
    FalsifyOptions,
)
from hybridlab.reachability.nonlinear import TAYLOR_APPLIES
from hybridlab.reachability.options import MAX_TAYLOR_ORDER, ReachOptions
from hybridlab.reachability.spec import Avoid, Spec, as_specs, lowers_on
from hybridlab.reachability.taylor import orders
from hybridlab.simulation.executors import check_executor
from hybridlab.simulation.options import SimulationOptions
from hybridlab.simulation.problem import HybridProblem
from hybridlab.symbolic.compile import CompiledModel

__all__ = ["VerdictStatus", "SpecBound", "Verdict", "check", "bound_specs"]


class VerdictStatus(enum.Enum):
    """The outcome of a safety check; each value says what it means.

    Examples
    --------
    >>> [status.name for status in VerdictStatus]
    ['SAFE', 'UNSAFE', 'UNKNOWN']
    >>> VerdictStatus.UNKNOWN.value
    'neither proved nor refuted: the reason says what was missing'
    """

    SAFE = ("proved: every state reachable from the initial set satisfies every spec up to "
            "t_end")
    UNSAFE = ("a simulated trajectory from the initial set violates a spec: see the "
              "counterexample (its replay() runs it again)")
    UNKNOWN = "neither proved nor refuted: the reason says what was missing"


@dataclass(frozen=True)
class SpecBound:
    """The lower bound of one spec's margin over the reach sets, where it is tightest.

    Attributes
    ----------
    spec : str
    lower : float
        Lower bound of the margin over every reach set the spec covers
        (``inf`` if none).
    mode : str or None
        Mode of the set where the bound is lowest.
    t : (float, float) or None
        Time interval of that set.
    jumps : int or None
        Jumps before that set.
    sets : int
        Reach sets the spec was bounded over.

    Examples
    --------
    >>> bound = SpecBound("T <= 25", 3.0, "cool", (0.5, 1.0), 1, 16)
    >>> bound.where()
    "in mode 'cool' for t in [0.5, 1]"
    >>> bound.as_dict()["t"], SpecBound("T <= 25", float("inf")).as_dict()["lower"]
    ([0.5, 1.0], None)
    """

    spec: str
    lower: float
    mode: str | None = None
    t: tuple[float, float] | None = None
    jumps: int | None = None
    sets: int = 0

    def where(self) -> str:
        """``in mode 'm' for t in [a, b]`` (or an empty string)."""
        if self.mode is None or self.t is None:
            return ""
        # the sets' times are widened by an ulp for soundness: show 0 as 0, not -5e-324
        lo, hi = (0.0 if abs(v) < 1e-300 else v for v in self.t)
        return f"in mode {self.mode!r} for t in [{lo:.6g}, {hi:.6g}]"

    def as_dict(self) -> dict[str, Any]:
        """A JSON-ready mapping."""
        return {"spec": self.spec, "lower": _json_float(self.lower), "mode": self.mode,
                "t": list(self.t) if self.t else None, "jumps": self.jumps, "sets": self.sets}


def _json_float(x: float | None) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


@dataclass(frozen=True)
class Verdict:
    """The answer of a safety check.

    Attributes
    ----------
    status : VerdictStatus
    specs : tuple of str
        The specs checked.
    reason : str
        Why this verdict, and for UNKNOWN what to change.
    margin : float or None
        SAFE: the smallest proven margin (``>= 0``). UNSAFE: the most negative
        margin of the counterexample. UNKNOWN: the lowest lower bound from the
        flowpipes (``where`` says where), or ``None`` if none was computed.
    where : SpecBound or None
        The spec, mode and time of ``margin`` (from the flowpipes).
    spec_bounds : tuple of SpecBound
        The flowpipe bound of every spec.
    counterexample : Counterexample or None
    reach : ReachResult or None
    falsification : Falsification or None
    time_s : float

    Examples
    --------
    >>> v = check("models/thermostat.toml", initial={"T": (19.0, 21.0)}, t_end=1.0,
    ...           safe="T <= 25", step=0.1)
    >>> v.safe, round(v.margin, 6), v.where.where()
    (True, 2.999999, "in mode 'cool' for t in [0.5, 1]")
    >>> v.counterexample is None, sorted(v.as_dict()["reachable_modes"])
    (True, ['cool', 'heat'])
    """

    status: VerdictStatus
    specs: tuple[str, ...]
    reason: str
    margin: float | None = None
    where: SpecBound | None = None
    spec_bounds: tuple[SpecBound, ...] = ()
    counterexample: Counterexample | None = None
    reach: Any = field(default=None, repr=False)
    falsification: Falsification | None = field(default=None, repr=False)
    time_s: float = 0.0

    @property
    def safe(self) -> bool:
        return self.status is VerdictStatus.SAFE

    def as_dict(self) -> dict[str, Any]:
        """A JSON-ready mapping (the CLI's ``--out`` layout)."""
        reach = self.reach
        data: dict[str, Any] = {
            "verdict": self.status.name,
            "reason": self.reason,
            "margin": _json_float(self.margin),
            "where": self.where.as_dict() if self.where else None,
            "specs": list(self.specs),
            "spec_bounds": [b.as_dict() for b in self.spec_bounds],
            "bounds": ({k: [float(lo), float(hi)] for k, (lo, hi) in reach.bounds.items()}
                       if reach is not None else None),
            "reachable_modes": sorted(reach.reachable_modes) if reach is not None else None,
            "reach_complete": bool(reach.complete) if reach is not None else None,
            "counterexample": (self.counterexample.as_dict()
                               if self.counterexample is not None else None),
            "time_s": self.time_s,
        }
        if self.falsification is not None:
            f = self.falsification
            data["falsification"] = {"runs": f.runs, "incomplete_runs": f.incomplete_runs,
                                     "margins": {k: _json_float(v) for k, v in f.margins.items()},
                                     "time_s": f.time_s}
        return data


def bound_specs(specs: Iterable[Spec], reach_result: Any) -> tuple[SpecBound, ...]:
    """Lower-bound every spec's margin over the reach sets of the modes it covers.

    Each row is bounded with ``ReachSet.bound``; a conjunction's margin bound is
    the least row bound, a region's the best single separating row.

    Examples
    --------
    >>> import hybridlab
    >>> from hybridlab.reachability.spec import as_specs
    >>> compiled = hybridlab.compile_model(hybridlab.load_model("models/thermostat.toml"))
    >>> result = hybridlab.reach(compiled, initial={"T": (19.0, 21.0)}, t_end=1.0, step=0.1)
    >>> upper, lower = bound_specs(as_specs(["T <= 25", "heat: T >= 18"], compiled), result)
    >>> round(upper.lower, 6), upper.mode, upper.sets  # T reaches at most 22
    (2.999999, 'cool', 16)
    >>> round(lower.lower, 4), lower.mode, lower.sets  # only the 11 heating sets
    (1.0, 'heat', 11)
    """
    specs = list(specs)
    best = [SpecBound(spec.text, math.inf) for spec in specs]
    count = [0] * len(specs)
    for rs in reach_result.sets:
        for k, lower in enumerate(lowers_on(specs, rs)):
            if lower is None:
                continue
            count[k] += 1
            if lower < best[k].lower or best[k].mode is None and lower == best[k].lower:
                best[k] = SpecBound(specs[k].text, lower, rs.mode,
                                    (float(rs.t[0]), float(rs.t[1])), int(rs.jumps))
    return tuple(SpecBound(b.spec, b.lower, b.mode, b.t, b.jumps, n)
                 for b, n in zip(best, count, strict=True))


def check(
    model: Model | CompiledModel | str | Path | HybridProblem,
    *,
    initial: Mapping[str, float | tuple[float, float]] | Any = None,
    t_end: float | None = None,
    safe: str | Avoid | Spec | Iterable[str | Avoid | Spec] = (),
    mode: str | None = None,
    scenario: str | None = None,
    params: Mapping[str, float | tuple[float, float]] | None = None,
    inputs: Mapping[str, tuple[float, float]] | None = None,
    options: Any = None,
    falsify_options: FalsifyOptions | None = None,
    simulation: SimulationOptions | None = None,
    prove: bool = True,
    executor: Any = None,
    **reach_overrides: Any,
) -> Verdict:
    """Check safety specs on every trajectory from an initial set: prove, falsify, refine.

    Parameters
    ----------
    model : Model, CompiledModel, path or HybridProblem
        A problem carries the initial set, horizon, mode, scenario, parameters
        and inputs; the arguments below override it.
    initial : mapping or set
        States given as a number (a point) or a ``(lo, hi)`` interval (others
        take their scenario or model value), or a ``Box``/``Zonotope``/``Polytope``
        over all states.
    t_end : float
        Horizon (default: the problem's or the scenario's).
    safe : spec or sequence of specs
        Texts such as ``"x >= -100"`` or ``"attempt, brake: x >= -100"``,
        :class:`~hybridlab.reachability.spec.Avoid` regions, or bound specs.
    mode, scenario : str, optional
        Initial mode and the scenario supplying defaults.
    params : mapping, optional
        Parameter values; a ``(lo, hi)`` pair is an uncertain constant.
    inputs : mapping, optional
        Parameters that vary in time within ``(lo, hi)``.
    options : ReachOptions, optional
        Reachability settings; ``**reach_overrides`` (e.g. ``max_jumps=5``)
        override its fields.
    falsify_options : FalsifyOptions, optional
        The falsification budget; ``FalsifyOptions(samples=0, local_evals=0)``
        keeps it to the centre and corners.
    simulation : SimulationOptions, optional
        Integrator settings for falsification (default: the scenario's).
    prove : bool
        ``False`` skips reachability (the verdict is then UNSAFE or UNKNOWN).
    executor : optional
        Where :func:`~hybridlab.reachability.reach` analyses the pieces of a
        split initial set (``split=k``): ``"threads"``, ``"processes"``, a
        worker count, an Executor or a Dask Client; default serial. A bad value
        is an ``ExecutorError`` (a ``ValueError``) before any work.

    Returns
    -------
    Verdict

    Examples
    --------
    >>> v = check("models/thermostat.toml", initial={"T": (19.0, 21.0)}, t_end=1.0,
    ...           safe="T <= 25", step=0.1)
    >>> print(v.status.name, v.reason)
    SAFE every spec holds on all 16 reach sets up to t_end=1; smallest proven margin 3
    (spec 'T <= 25' in mode 'cool' for t in [0.5, 1])
    >>> v = check("models/thermostat.toml", initial={"T": (19.0, 21.0)}, t_end=1.0,
    ...           safe="T <= 20.5", step=0.1)
    >>> v.status.name, v.counterexample.initial, round(v.counterexample.t, 6)
    ('UNSAFE', {'T': 20.0}, 0.253178)
    """
    check_executor(executor)
    # a misspelt option fails first
    resolved = (options or ReachOptions()).updated(**reach_overrides)
    started = time.perf_counter()
    problem = HybridProblem.build(model, t_end, initial=initial, mode=mode, scenario=scenario,
                                  params=params, inputs=inputs, options=simulation)
    compiled = problem.compiled
    specs = as_specs(safe, compiled)
    if not specs:
        raise ValueError("safe: give at least one spec or region to avoid")
    if resolved.observed:  # a misspelt name fails before any work
        from hybridlab.reachability.api import check_observed  # the flowpipes: a sibling
        check_observed(compiled, resolved.observed)
    texts = tuple(s.text for s in specs)

    search = FalsificationSearch(problem, specs, falsify_options)
    if not prove:
        found = search.sample()
        unsafe = _unsafe(found, texts, started)
        if unsafe is not None:
            return unsafe
        found = search.local()
        unsafe = _unsafe(found, texts, started)
        if unsafe is not None:
            return unsafe
        return Verdict(VerdictStatus.UNKNOWN, texts,
                       f"reachability was not attempted (prove=False); {_evidence(found)}",
                       falsification=found, time_s=time.perf_counter() - started)

    # the flowpipes: a sibling module
    from hybridlab.reachability.api import PreparedReach, prepare_reach, reach_prepared

    # refinements where the flowpipes prove too little, each only if the caller left that
    # knob alone: the step halved while each halving tightens the failing bound, then the
    # guard hits grouped into compact clusters (one time budget covers every stage)
    clustering_chosen = "clustering" in reach_overrides or (
        options is not None and getattr(options, "clustering", "box") != "box")
    step_chosen = "step" in reach_overrides or getattr(options, "step", None) is not None
    overrides = dict(reach_overrides)
    read = {str(s) for spec in specs for rows in spec.rows.values() for e in rows
            for s in e.free_symbols}  # what the specs read is followed exactly
    overrides["observed"] = tuple(sorted(read.union(resolved.observed)))
    dwell_known = "dwell" in overrides or getattr(options, "dwell", None) is not None
    budget = overrides.get("time_budget", getattr(options, "time_budget", None))
    deadline = overrides.get("deadline", getattr(options, "deadline", None))
    if budget is not None and deadline is None:
        deadline = overrides["deadline"] = time.time() + float(budget)

    tried: list[str] = []  # the refinements run, for the reason

    max_sets = overrides.get("max_sets", getattr(options, "max_sets", None))
    prepared: list[PreparedReach] = []
    # the results of the attempts still referenced (those dropped leave the set)
    alive: weakref.WeakSet[Any] = weakref.WeakSet()
    held_before = float(overrides.get("memory_held", getattr(options, "memory_held", 0.0)))

    def attempt(stage: dict[str, Any], until: float | None = None, *,
                stop: bool = False, again: bool = False, sets: int | None = None) -> _Attempt:
        """One analysis; ``until`` or ``stop``: it ends at the first set that does not
        prove every spec; ``sets``: it ends after that many flowpipe sets (or the caller's
        ``max_sets``, if fewer); ``again``: a stage already counted in ``tried``."""
        if stage and not again:
            tried.append(_describe(stage))
        extra: dict[str, Any] = {} if until is None else {"deadline": until}
        if sets is not None:
            extra["max_sets"] = sets if max_sets is None else min(sets, int(max_sets))
        # one max_memory for the whole verdict: the analyses still held count against it
        held = sum(r.nbytes for r in alive)
        if held:
            extra["memory_held"] = held_before + held / 2**30
        if not prepared:  # once: every attempt shares the system and its derivatives
            prepared.append(prepare_reach(problem))
        result = reach_prepared(prepared[0], options=options, executor=executor,
                                stop_unproved=specs if until is not None or stop else (),
                                **{**overrides, **stage, **extra})
        alive.add(result)
        return _Attempt.of(specs, result, stage)

    failures = (HybridlabError, ArithmeticError, NotImplementedError, RuntimeError)
    # a quick proof first: a small system is often proved before the simulator has loaded,
    # and a proof needs no simulation; the attempt ends at the first set that does not
    # prove every spec, or after _QUICK_PROOF_S
    quick_until = time.time() + _QUICK_PROOF_S
    try:
        quick: _Attempt | None = attempt({}, quick_until if deadline is None
                                         else min(deadline, quick_until))
    except failures:
        quick = None
    if quick is not None and quick.proved and quick.result.complete:
        return _safe(quick, problem.t_end, texts, started, None)
    if quick is not None and not step_chosen and quick.result.unproved_between_steps:
        # it failed only between two step instants (the sets at both ends prove every
        # spec): a finer step is tried before any simulation, while that stays so
        finer = _between_refined(quick, lambda step: attempt({"step": step}, stop=True))
        if finer.proved and finer.result.complete:
            return _safe(finer, problem.t_end, texts, started, None)

    found = search.sample()
    unsafe = _unsafe(found, texts, started)
    if unsafe is not None:
        return unsafe
    if not (step_chosen or dwell_known) and found.most_jumps:
        # the busiest simulated run's dwell sets the default step (see default_step)
        overrides["dwell"] = (problem.t_end - problem.t_start) / (found.most_jumps + 1)
    # the quick attempt stops at its first unproved set, so it stands only where the
    # caller's whole time budget is spent anyway
    stands = deadline is not None and time.time() >= deadline
    try:
        best = quick if quick is not None and stands else attempt({})
    except failures as exc:
        found = search.local()
        unsafe = _unsafe(found, texts, started)
        if unsafe is not None:
            return unsafe
        text = " ".join(str(exc).split())
        return Verdict(VerdictStatus.UNKNOWN, texts,
                       f"reachability failed ({type(exc).__name__}: {text}); "
                       f"{_evidence(found)}",
                       falsification=found, time_s=time.perf_counter() - started)

    def halved(best: _Attempt) -> _Attempt:
        """The step halved while each halving tightens the failing bound."""
        step = best.step
        stalled = 0  # halvings in a row that did not tighten the failing bound
        for _ in range(_STEP_HALVINGS):
            step /= 2
            # (a halving that does not prove ends at its first unproved set)
            finer = attempt({**best.stage, "step": step}, stop=True)
            if not (finer.result.complete or finer.result.stopped_unproved):
                break  # out of budget: the coarser result stands
            improved = finer.lower > best.lower
            stalled = 0 if improved else stalled + 1
            if improved or finer.proved:
                best = finer
            if not best.unproved or stalled == _STEP_PATIENCE:
                break
        if best.result.stopped_unproved and not stands:
            best = attempt(best.stage, again=True)  # the whole flowpipe, for what follows
        return best

    split_chosen = "split" in reach_overrides or getattr(options, "split", 1) != 1
    order_chosen = ("taylor_order" in reach_overrides
                    or getattr(options, "taylor_order", None) is not None)
    flowpipe_chosen = "flowpipe" in reach_overrides or (
        getattr(options, "flowpipe", "zonotope") != "zonotope")
    bisections: list[_Attempt] = []  # the initial set is bisected once at most

    def bisected(best: _Attempt, capped: bool) -> _Attempt:
        """``best``, or its initial set bisected where the pieces fail (each piece ends at
        its first set that does not prove every spec), along the direction its set bends
        most, if that proves the specs; ``capped``: in at most _OPEN_SPLIT_PIECES
        analyses."""
        stage = {**best.stage, "split": "auto"}
        if capped:
            stage["max_pieces"] = min(_OPEN_SPLIT_PIECES, resolved.max_pieces)
        pieces = attempt(stage, stop=True)
        bisections.append(pieces)
        return pieces if pieces.proved and pieces.result.complete else best

    def fails_at_step_instants() -> bool:
        """Whether the first set that does not prove every spec fails at its step instants
        too, not only between them: as the quick attempt found, or, where its time cap
        ended it before that set, as an attempt that ends there finds (so the machine's
        speed does not choose the refinement)."""
        if quick is None or stands:
            return False
        first = quick
        if not (quick.result.stopped_unproved or quick.result.complete):
            first = attempt({}, stop=True, again=True)
        return first.result.stopped_unproved and not first.result.unproved_between_steps

    try:  # a refinement that fails leaves the result before it standing
        # a nonlinear flowpipe of one mode whose first unproved set fails at its step
        # instants too is too wide rather than too coarse in time: bisected first
        if (best.open and not split_chosen and not best.jumped and best.result.nonlinear
                and fails_at_step_instants()):
            best = bisected(best, capped=True)
        if best.open and not step_chosen:
            best = halved(best)
        if ((best.open or not best.result.complete and not stands) and best.jumped
                and not clustering_chosen):
            # one zonotope per run, which keeps correlations at the cost of one set; then
            # compact groups, more branches. Where a branch failed after a jump (a box of
            # the guard hits may be what made its set too wide) only the sweep is tried,
            # within _SWEEP_SETS times the failed analysis's sets (a count, so the
            # machine's speed does not choose the refinement)
            failed = not best.result.complete
            for clustering in ("sweep",) if failed else ("sweep", "auto"):
                reached = best.reached(problem.t_start, problem.t_end)
                cap = max(1, int(_SWEEP_SETS * len(best.result.sets))) if failed else None
                clustered = attempt({**best.stage, "clustering": clustering}, stop=failed,
                                    sets=cap)
                complete = clustered.result.complete
                further = clustered.reached(problem.t_start, problem.t_end)
                # both failed at the same instant: before any join they differ in, so the
                # comparison says nothing; the sweep stays for the refinements below (a
                # smaller step that gets past that instant meets the joins with it)
                tie = not (complete or best.result.complete) and further == reached
                if (clustered.proved and complete or complete and clustered.lower > best.lower
                        or not best.result.complete and further > reached or tie):
                    best = clustered
                if best.proved and best.result.complete:
                    break
        # a nonlinear mode's set outgrew its linearisation part-way: Taylor models (which
        # keep the set's curvature) in one piece where they apply to that mode, else a
        # smaller step while the flowpipe gets further; then the initial set in pieces,
        # while the pieces get further
        reached = best.reached(problem.t_start, problem.t_end)
        if best.result.too_wide and not flowpipe_chosen and any(
                TAYLOR_APPLIES in r for r in best.result.incomplete_reasons):
            taylor = attempt({**best.stage, "flowpipe": "taylor"})
            space_order = orders(problem.dims)[0]
            if taylor.result.too_wide and not order_chosen and space_order < MAX_TAYLOR_ORDER:
                # a wide set bent further than the order follows: a degree more
                higher = attempt({**taylor.stage, "taylor_order": min(
                    MAX_TAYLOR_ORDER, space_order + _ORDER_RAISE)})
                if (higher.reached(problem.t_start, problem.t_end)
                        > taylor.reached(problem.t_start, problem.t_end)
                        or higher.result.complete):
                    taylor = higher
            if taylor.open and not step_chosen:
                taylor = halved(taylor)
            further = taylor.reached(problem.t_start, problem.t_end)
            if (taylor.proved and taylor.result.complete or further > reached
                    or taylor.result.complete and taylor.lower > best.lower):
                best, reached = taylor, further
        elif best.result.too_wide and not step_chosen:
            # no Taylor models for that mode: the remainder shrinks with the step
            step, stalled = best.step, 0
            for _ in range(_STEP_HALVINGS):
                step /= 2
                finer = attempt({**best.stage, "step": step})
                further = finer.reached(problem.t_start, problem.t_end)
                if not (finer.proved and finer.result.complete or further > reached):
                    stalled += 1
                    if stalled == _STEP_PATIENCE:
                        break
                    continue
                best, reached, stalled = finer, further, 0
                if not best.result.too_wide:
                    best = halved(best) if best.open else best
                    break
        wide = best.result.too_wide and reached >= _SPLIT_PROGRESS
        if (wide or best.open) and not split_chosen and not bisections:
            best = bisected(best, capped=not wide)
    except failures as exc:
        tried[-1] += f" (failed: {type(exc).__name__})"
    if best.proved and best.result.complete:
        return _safe(best, problem.t_end, texts, started, found)
    # the local search only pays where the flowpipes proved too little
    found = search.local()
    unsafe = _unsafe(found, texts, started)
    if unsafe is not None:
        return unsafe
    result, bounds, tightest = best.result, best.bounds, best.tightest
    margin = None if not math.isfinite(tightest.lower) else tightest.lower
    elapsed = time.perf_counter() - started
    common = dict(margin=margin, where=tightest if tightest.mode else None, spec_bounds=bounds,
                  reach=result, falsification=found)
    reasons = []
    if not result.complete:
        why = "; ".join(result.incomplete_reasons) or "not every branch reached t_end"
        reasons.append(f"the reach result is incomplete ({why}): nothing is proved past it")
    failing = [b for s, b in zip(specs, bounds, strict=True) if not s.holds(b.lower)]
    for b in failing:
        reasons.append(f"the flowpipe bound of spec {b.spec!r} reaches {_fmt(b.lower)} "
                       f"{b.where()} (after {b.jumps} jump(s)) while no simulation violated "
                       f"it: the overlap may be spurious; tighten the reach (smaller time step, "
                       f"higher zonotope order, less clustering) or split the initial set")
    if tried:
        reasons.append(f"refined without proving it ({'; then '.join(tried)})")
    return Verdict(VerdictStatus.UNKNOWN, texts, "; ".join(reasons) + f"; {_evidence(found)}",
                   time_s=elapsed, **common)


_ORDER_RAISE = 1
"""Degrees added to the Taylor models' default space order when they outgrow their set
(the coupled Van der Pol oscillators: order 3 fails at t = 3.66, order 4 at t = 4.2; their
box bisected at order 4 is proved in 203 s and 18 pieces, at order 5 in 281 s and 13)."""
_OPEN_SPLIT_PIECES = 32
"""A complete flowpipe that proves too little is bisected (``split="auto"``) in at most this
many analyses (Van der Pol from the ARCH box over 3 s, linearised, bounds ``y >= -2.721``
whole and ``-2.616`` in two halves: ``y >= -2.7`` is proved in 3 analyses; the sensor
follower with its guard hits joined in a box in 10 pieces). Where the looseness is not the
set's width, pieces do not help, and the cap bounds what finding that out costs: a number of
analyses, so the verdict does not depend on the machine's speed."""
_SPLIT_PROGRESS = 0.25
"""A split is tried only when the whole set got through this fraction of the horizon before
it outgrew its linearisation (Van der Pol: half; a cart's pendulum swinging from a wide set:
0.4 %, where pieces do not get far either and cost their number in time)."""
_STEP_HALVINGS = 5
"""Halvings of the step at most when a verdict is refined."""

_QUICK_PROOF_S = 1.0
"""Seconds the proof attempted before any simulation may take: about what loading the
compiled simulator and a first falsification cost on a small model, so a model proved
in that time needs no simulation, and one that is not loses at most that."""

_BETWEEN_HALVINGS = 3
"""Halvings of the step at most before any simulation, while the flowpipe fails only
between step instants (the spacecraft rendezvous: two)."""

_STEP_PATIENCE = 2
"""Halvings in a row that do not tighten the failing bound before the refinement stops
(the bound is not monotone in the step: a finer grid meets a guard differently)."""

_SWEEP_SETS = 3.0
"""A result whose branch failed after a jump is tried again with ``clustering="sweep"`` for
at most this many times its own number of flowpipe sets (the sweep keeps one set per run,
but where a model's own transitions fire together its branches can multiply)."""

@dataclass(frozen=True)
class _Attempt:
    """One reach analysis of a verdict and its spec bounds."""

    result: Any
    bounds: tuple[SpecBound, ...]
    tightest: SpecBound
    proved: bool
    stage: dict[str, Any]
    jumped: bool

    @staticmethod
    def of(specs: Sequence[Spec], result: Any, stage: dict[str, Any]) -> _Attempt:
        bounds = bound_specs(specs, result)
        proved = all(s.holds(b.lower) for s, b in zip(specs, bounds, strict=True))
        return _Attempt(result, bounds, min(bounds, key=lambda b: b.lower), proved, stage,
                        any(rs.jumps for rs in result.sets))

    @property
    def lower(self) -> float:
        return self.tightest.lower

    @property
    def step(self) -> float:
        return float(self.result.options.step)

    @property
    def open(self) -> bool:
        """Complete, yet not proved: what a refinement may settle."""
        return self.result.complete and not self.proved

    def reached(self, t_start: float, t_end: float) -> float:
        """The fraction of ``[t_start, t_end]`` the flowpipe covers (to its last set)."""
        last = max((rs.t[1] for rs in self.result.sets), default=t_start)
        return min(1.0, (last - t_start) / (t_end - t_start))

    @property
    def unproved(self) -> bool:
        """Open, or stopped at a set that does not prove a spec."""
        return not self.proved and (self.result.complete or self.result.stopped_unproved)

    def refinement(self) -> str:
        """The reason's note of the refinements this attempt used ("" for none)."""
        if not self.stage:
            return ""
        pieces = self.result.pieces
        return (f" (refined: {_describe(self.stage)}"
                + (f"; {pieces} pieces" if pieces > 1 else "") + ")")


def _between_refined(first: _Attempt, attempt: Any) -> _Attempt:
    """Halve the step of ``first`` while each attempt fails only between step instants
    and tightens the failing bound, at most ``_BETWEEN_HALVINGS`` times; the last
    attempt made (``attempt(step)`` runs one, ending at its first unproved set)."""
    best = first
    for _ in range(_BETWEEN_HALVINGS):
        finer = attempt(best.step / 2)
        if finer.proved or not finer.result.unproved_between_steps or finer.lower <= best.lower:
            return finer
        best = finer
    return best


def _describe(stage: dict[str, Any]) -> str:
    parts = []
    if stage.get("clustering") == "auto":
        parts.append("the guard hits grouped into compact clusters, clustering='auto'")
    elif "clustering" in stage:
        parts.append(f"the guard hits joined keeping the flowpipe's generators, "
                     f"clustering={stage['clustering']!r}")
    if "step" in stage:
        parts.append(f"step={stage['step']:.6g}")
    if "flowpipe" in stage:
        parts.append(f"{stage['flowpipe']} flowpipes, flowpipe={stage['flowpipe']!r}")
    if "taylor_order" in stage:
        parts.append(f"space order {stage['taylor_order']}, taylor_order={stage['taylor_order']}")
    if stage.get("split") == "auto":
        parts.append("the initial set bisected where its pieces failed, split='auto'")
    elif "split" in stage:
        parts.append(f"the initial set split into {stage['split']} per uncertain direction, "
                     f"split={stage['split']}")
    return ", ".join(parts)


def _safe(best: _Attempt, t_end: float, texts: tuple[str, ...], started: float,
          found: Falsification | None) -> Verdict:
    """The SAFE verdict of a proved, complete attempt."""
    tightest, result = best.tightest, best.result
    return Verdict(VerdictStatus.SAFE, texts,
                   f"every spec holds on all {len(result.sets)} reach sets up to "
                   f"t_end={t_end:g}; smallest proven margin {_fmt(tightest.lower)} "
                   f"(spec {tightest.spec!r} {tightest.where()}){best.refinement()}",
                   margin=tightest.lower if math.isfinite(tightest.lower) else None,
                   where=tightest if tightest.mode else None,
                   spec_bounds=best.bounds, reach=result, falsification=found,
                   time_s=time.perf_counter() - started)


def _evidence(found: Falsification) -> str:
    return (f"falsification found no violation in {found.runs} simulation(s) (lowest "
            f"simulated margin {min(found.margins.values()):.6g})")


def _unsafe(found: Falsification, texts: tuple[str, ...], started: float) -> Verdict | None:
    """The UNSAFE verdict of a falsification that found a counterexample, else ``None``."""
    cx = found.counterexample
    if cx is None:
        return None
    state = ", ".join(f"{k}={v:.6g}" for k, v in cx.state.items())
    reason = (f"spec {cx.spec!r} is violated at t={cx.t:.10g} in mode {cx.mode!r} "
              f"({state}); the lowest margin along that run is {cx.margin:.6g} at "
              f"t={cx.t_worst:.6g} (found in {found.runs} simulation(s))")
    return Verdict(VerdictStatus.UNSAFE, texts, reason, margin=cx.margin, counterexample=cx,
                   falsification=found, time_s=time.perf_counter() - started)


def _fmt(x: float) -> str:
    return f"{x:.6g}"
