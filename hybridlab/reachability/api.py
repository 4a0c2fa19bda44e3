"""The public entry point :func:`reach`."""

from __future__ import annotations

import time as _time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from hybridlab.errors import HybridlabError
from hybridlab.model.expressions import as_expression
from hybridlab.model.schema import Model
from hybridlab.reachability.bisection import bisect
from hybridlab.reachability.constants import mode_constants, with_constants
from hybridlab.reachability.hybrid import run_analysis
from hybridlab.reachability.options import ReachOptions
from hybridlab.reachability.result import ReachResult, merge_results
from hybridlab.reachability.sets import Box, Polytope, Zonotope, as_zonotope
from hybridlab.reachability.spec import Spec
from hybridlab.reachability.system import System, build_system
from hybridlab.reachability.worker import Piece, run_piece
from hybridlab.simulation.executors import (
    check_executor,
    compiled_for,
    model_key,
    model_text,
    place,
)
from hybridlab.simulation.problem import HybridProblem, ProblemError
from hybridlab.symbolic.compile import CompiledModel

__all__ = ["PreparedReach", "ReachError", "check_observed", "default_step", "prepare_reach",
           "reach", "reach_prepared", "shared_memory"]


class ReachError(HybridlabError, ValueError):
    """A reachability problem is ill-posed (bad initial set, bounds or names).

    Examples
    --------
    >>> reach("models/thermostat.toml", initial={"X": (19.0, 21.0)}, t_end=1.0)
    Traceback (most recent call last):
    ...
    hybridlab.reachability.api.ReachError: initial: unknown state 'X'; expected one of: T
    """


def reach(
    model: Model | CompiledModel | str | Path | HybridProblem,
    *,
    initial: Mapping[str, float | tuple[float, float]] | Box | Zonotope | Polytope | None = None,
    t_end: float | None = None,
    mode: str | None = None,
    scenario: str | None = None,
    params: Mapping[str, float | tuple[float, float]] | None = None,
    inputs: Mapping[str, tuple[float, float]] | None = None,
    options: ReachOptions | None = None,
    executor: Any = None,
    stop_unproved: Sequence[Spec] = (),
    **option_overrides: Any,
) -> ReachResult:
    """Sets of states reachable from a set of initial states, sound in dense time.

    Parameters
    ----------
    model : Model, CompiledModel, str, pathlib.Path or HybridProblem
        The hybrid automaton (a path is loaded with :func:`hybridlab.load_model`),
        or a problem whose values the other arguments override.
    initial : mapping or set, optional
        A box given per state (a number or a ``(lo, hi)`` pair; states not named
        start at their scenario/model initial value), or a :class:`Box`,
        :class:`Zonotope` or :class:`Polytope` over all states in model order.
    t_end : float, optional
        Horizon; defaults to the scenario's ``t_end``.
    mode : str, optional
        Initial mode (default: the scenario's, else the model's).
    scenario : str, optional
        Scenario supplying parameter values, initial values, ``t_start`` and
        ``t_end`` (``"default"`` when the model has one).
    params : mapping, optional
        Parameter values; a ``(lo, hi)`` pair makes the parameter an uncertain
        *constant* (an extra state with zero flow).
    inputs : mapping, optional
        Parameters that vary arbitrarily in time within ``(lo, hi)``
        (bounded inputs; they may appear in flows only).
    options : ReachOptions, optional
        Settings; keyword arguments override its fields (``step=0.01``,
        ``max_jumps=10``, ...).
    executor : optional
        Where the pieces of a split initial set (``split > 1`` or ``"auto"``, a
        round of pieces at a time) are analysed:
        ``None`` or ``"serial"`` (in this process, one after another),
        ``"threads"``, ``"processes"``, an int ``N`` (a process pool of ``N``
        workers), any :class:`concurrent.futures.Executor` or a
        ``distributed.Client``, as for :func:`hybridlab.sweep`. The result is
        the same whatever runs it (sets merged in piece order).
    stop_unproved : sequence of Spec, optional
        Specs (:func:`~hybridlab.reachability.spec.as_specs`) whose first
        flowpipe set that does not prove them ends the analysis, incomplete,
        with the reason: a proof attempt that gives up as soon as it cannot
        succeed.

    Returns
    -------
    ReachResult

    Raises
    ------
    ReachError
        For unknown names, malformed intervals or sets, a bad horizon or a bad
        ``executor``.

    Examples
    --------
    >>> import hybridlab
    >>> result = hybridlab.reach("models/bouncing_ball.toml", initial={"h": (9.0, 10.0)},
    ...                          t_end=2.0, step=0.01)
    >>> result.complete, sorted(result.reachable_modes)
    (True, ['fall'])
    >>> lo, hi = result.bounds["h"]
    >>> bool(hi >= 10.0 and hi < 10.01 and lo <= 0.0)
    True
    """
    check_executor(executor, ReachError)
    try:
        problem = HybridProblem.build(model, t_end, scenario=scenario, params=params,
                                      initial=initial, mode=mode, inputs=inputs)
    except ProblemError as exc:
        raise ReachError(str(exc)) from None
    return reach_prepared(prepare_reach(problem), options=options, executor=executor,
                          stop_unproved=stop_unproved, **option_overrides)


@dataclass(frozen=True, eq=False)
class PreparedReach:
    """A problem's equations prepared for reachability, for any number of analyses: the
    extended system (its modes keep the derivatives they take, so analyses after the
    first take none), the initial set over states, uncertain parameters and time, and
    the problem's values.

    Examples
    --------
    >>> from hybridlab.simulation.problem import HybridProblem
    >>> prepared = prepare_reach(HybridProblem.build("models/thermostat.toml", 1.0,
    ...                                              initial={"T": (19.0, 21.0)}))
    >>> prepared.mode, prepared.initial.bounds().round(9).tolist(), prepared.t_end
    ('heat', [[19.0, 21.0]], 1.0)
    """

    compiled: CompiledModel
    system: System
    mode: str
    initial: Zonotope
    t_start: float
    t_end: float
    p: np.ndarray
    uncertain: dict[str, tuple[float, float]]
    bounded: dict[str, tuple[float, float]]


def prepare_reach(problem: HybridProblem) -> PreparedReach:
    """``problem`` prepared for :func:`reach_prepared`; a :class:`ReachError` for an input
    outside the flows or a schedule set by an uncertain parameter.

    Examples
    --------
    >>> import hybridlab
    >>> from hybridlab.simulation.problem import HybridProblem
    >>> problem = HybridProblem.build("models/thermostat.toml", 1.0, initial={"T": (19.0, 21.0)})
    >>> prepared = prepare_reach(problem)
    >>> [reach_prepared(prepared, step=step).complete for step in (0.1, 0.05)]
    [True, True]
    """
    compiled, p, mode = problem.compiled, problem.p0, problem.mode
    t0, t_end = problem.t_start, problem.t_end
    uncertain, bounded = dict(problem.param_box), dict(problem.input_box)
    pnames = compiled.parameter_names

    symbolic = compiled.symbolic
    psym = dict(zip(pnames, symbolic.parameters, strict=True))
    for name in bounded:
        for tr in symbolic.transitions:
            where = [("guard", [r.expr for r in tr.guard]), ("reset", list(tr.reset)),
                     ("schedule", [e for e in (tr.period, tr.phase, tr.enabled)
                                   if e is not None])]
            for part, exprs in where:
                if any(psym[name] in as_expression(e).free_symbols for e in exprs):
                    raise ReachError(f"input {name!r} appears in the {part} of transition "
                                     f"{tr.name!r}; inputs may appear in flows only")
        for mode_name, m in symbolic.modes.items():
            if any(psym[name] in r.expr.free_symbols for r in m.invariants):
                raise ReachError(f"input {name!r} appears in the invariant of mode "
                                 f"{mode_name!r}; inputs may appear in flows only")
    for name in uncertain:
        for tr in symbolic.transitions:
            if any(psym[name] in as_expression(e).free_symbols
                   for e in (tr.period, tr.phase, tr.enabled) if e is not None):
                raise ReachError(f"uncertain parameter {name!r} sets the schedule of "
                                 f"transition {tr.name!r}; scheduled instants must be known")
    system = build_system(compiled, p, uncertain, bounded)

    n = len(compiled.state_names)
    if problem.initial_set is not None:
        X0 = as_zonotope(problem.initial_set)
    else:
        lo, hi = problem.x0.copy(), problem.x0.copy()
        for name, (a, b) in problem.state_box.items():
            i = compiled.state_names.index(name)
            lo[i], hi[i] = a, b
        X0 = Box(lo, hi).to_zonotope()

    # extended initial set: states x uncertain parameters x time
    extra_lo = [u[0] for u in uncertain.values()] + ([t0] if system.timed else [])
    extra_hi = [u[1] for u in uncertain.values()] + ([t0] if system.timed else [])
    if extra_lo:
        E = Box(extra_lo, extra_hi).to_zonotope()
        G = np.zeros((n + E.dim, X0.generators.shape[1] + E.generators.shape[1]))
        G[:n, :X0.generators.shape[1]] = X0.generators
        G[n:, X0.generators.shape[1]:] = E.generators
        P0 = Zonotope(np.r_[X0.center, E.center], G)
    else:
        P0 = X0

    # discrete variables constant in a mode stop being read there (pieces of P0 keep them)
    system = with_constants(system, mode_constants(system, mode, P0))
    return PreparedReach(compiled, system, mode, P0, t0, t_end, p, uncertain, bounded)


def reach_prepared(prepared: PreparedReach, options: ReachOptions | None = None,
                   executor: Any = None, stop_unproved: Sequence[Spec] = (),
                   **option_overrides: Any) -> ReachResult:
    """:func:`reach` of a prepared problem (the arguments as there): the analyses of one
    problem share its system and the derivatives its modes have taken.

    Examples
    --------
    >>> import hybridlab
    >>> from hybridlab.simulation.problem import HybridProblem
    >>> prepared = prepare_reach(HybridProblem.build("models/bouncing_ball.toml", 1.0,
    ...                                              initial={"h": (9.0, 10.0)}))
    >>> reach_prepared(prepared, step=0.01).bounds["h"][1] >= 10.0
    True
    """
    check_executor(executor, ReachError)
    compiled, system, mode, P0 = (prepared.compiled, prepared.system, prepared.mode,
                                  prepared.initial)
    t0, t_end, p = prepared.t_start, prepared.t_end, prepared.p
    uncertain, bounded = prepared.uncertain, prepared.bounded
    opts = (options or ReachOptions()).updated(**option_overrides)
    check_observed(compiled, opts.observed)
    if opts.step is None:
        opts = opts.updated(step=default_step(system, t_end - t0, opts.dwell))
    if opts.time_budget is not None and opts.deadline is None:
        opts = opts.updated(deadline=_time.time() + float(opts.time_budget))
    stop = tuple(stop_unproved)
    if opts.split == 1:
        return run_analysis(system, opts, mode, P0, t0, t_end, p, stop)
    pieces = [P0] if opts.split == "auto" else _split(P0, int(opts.split))
    if len(pieces) == 1 and opts.split != "auto":
        return run_analysis(system, opts, mode, pieces[0], t0, t_end, p, stop)
    workers = opts.max_pieces if opts.split == "auto" else len(pieces)
    placement = place("serial" if executor is None else executor, workers, ReachError)

    def analyse(pieces: list[Zonotope], held: int = 0) -> list[ReachResult]:
        share = shared_memory(opts, held, len(pieces))
        if placement.executor is None or len(pieces) == 1:
            return [run_analysis(system, share, mode, piece, t0, t_end, p, stop)
                    for piece in pieces]
        if placement.in_process:  # threads share the system: nothing is pickled
            return _gather([placement.executor.submit(run_analysis, system, share, mode,
                                                      piece, t0, t_end, p, stop)
                            for piece in pieces])
        return _gather([placement.executor.submit(run_piece, task) for task in
                        _tasks(compiled, p, uncertain, bounded, share, mode,
                               pieces, t0, t_end, stop)])

    try:
        if opts.split == "auto":
            return bisect(analyse, P0, opts.max_pieces, opts.deadline)
        return merge_results(analyse(pieces))
    finally:
        placement.shutdown()


def shared_memory(options: ReachOptions, held: int, analyses: int) -> ReachOptions:
    """``options`` for one of ``analyses`` analyses run together that share ``max_memory``
    with sets of ``held`` bytes kept already: each may keep an equal part of what is left.

    Examples
    --------
    >>> opts = ReachOptions(max_memory=2.0)
    >>> shared_memory(opts, 0, 1) is opts
    True
    >>> shared_memory(opts, 2**30, 2).memory_held  # 1 GiB left, half of it for each
    1.5
    """
    if held == 0 and analyses == 1:
        return options
    free = max(0.0, options.max_memory - options.memory_held - held / 2**30)
    return options.updated(memory_held=options.max_memory - free / analyses)


def check_observed(compiled: CompiledModel, names: Sequence[str]) -> None:
    """Raise :class:`ReachError` for a name in ``observed`` that the model does not have.

    Examples
    --------
    >>> import hybridlab
    >>> ball = hybridlab.compile_model(hybridlab.load_model("models/bouncing_ball.toml"))
    >>> check_observed(ball, ["h", "e"])
    >>> try:
    ...     check_observed(ball, ["height"])
    ... except ReachError as exc:
    ...     print(exc)
    observed: unknown name 'height'; expected a state or parameter of the model
    """
    known = {*compiled.state_names, *compiled.parameter_names, "t"}
    unknown = [name for name in names if name not in known]
    if unknown:
        raise ReachError(f"observed: unknown name {unknown[0]!r}; expected a state or "
                         f"parameter of the model")


_DEFAULT_STEPS = 400     # steps over the horizon by default
_MAX_TURN = 0.5          # radians per step of a lightly damped oscillation, by default
_MAX_DEFAULT_STEPS = 4000
_STEPS_PER_DWELL = 16
_MAX_DWELL_STEPS = 40000


def default_step(system: System, horizon: float, dwell: float | None = None) -> float:
    """The step when none is given: ``horizon / 400``, shortened so that no lightly damped
    oscillation of an affine mode (eigenvalue with ``|Im| >= |Re|``) turns more than half
    a radian per step (but not below ``horizon / 4000``), and so that a typical ``dwell``
    between jumps, when known, has 16 steps (but not below ``horizon / 40000``).

    A step's flowpipe is the convex hull of its end sets plus a correction; where a
    mode turns by radians in a step the hull no longer follows it, and each oscillating
    mode's phase is boxed apart from the others'. On the 48-state building (modes up to
    90 rad/s, horizon 20) this gives 0.0056 instead of 0.05. A set that crosses a guard is
    joined over the steps of the crossing; with steps long against the dwell, the sets
    entering each mode grow from cycle to cycle instead of settling into a fixpoint (the
    two rooms, a jump every 0.68 min: SAFE in 170 s at a step of 0.05; UNKNOWN after 10 min
    at 0.1, the entry sets having grown until a bound failed; no answer in 7 min at 0.15 or
    0.45).

    Examples
    --------
    >>> import numpy as np
    >>> from hybridlab import compile_model, load_model
    >>> from hybridlab.reachability.system import build_system
    >>> compiled = compile_model(load_model("models/thermostat.toml"))
    >>> system = build_system(compiled, compiled.parameter_vector(), {}, {})
    >>> default_step(system, 40.0)
    0.1
    """
    step = horizon / _DEFAULT_STEPS
    turn = 0.0
    for m in system.modes.values():
        if not m.affine:
            continue
        nz = len(m.zsyms)
        A = m.jacobian(np.zeros(nz), np.zeros(len(m.usyms)))[:, :nz]
        if not np.all(np.isfinite(A)):
            continue
        lam = np.linalg.eigvals(A)
        light = np.abs(lam.imag) >= np.abs(lam.real)
        if light.any():
            turn = max(turn, float(np.max(np.abs(lam.imag[light]))))
    if turn > 0.0:
        step = max(min(step, _MAX_TURN / turn), horizon / _MAX_DEFAULT_STEPS)
    if dwell is not None:
        step = max(min(step, dwell / _STEPS_PER_DWELL), horizon / _MAX_DWELL_STEPS)
    return step


def _gather(futures: list[Any]) -> list[ReachResult]:
    """The futures' results in submission order (the serial order)."""
    return [future.result() for future in futures]


def _tasks(compiled: CompiledModel, p: np.ndarray,
           uncertain: Mapping[str, tuple[float, float]],
           bounded: Mapping[str, tuple[float, float]], opts: ReachOptions, mode: str,
           pieces: list[Zonotope], t0: float, t_end: float,
           stop: tuple[Spec, ...]) -> list[Piece]:
    """The pieces as picklable tasks for worker processes (the model as JSON text)."""
    text = model_text(compiled.model)
    key = model_key(text)
    compiled_for(text, key, compiled)  # forked workers inherit this process's compiled model
    return [Piece(text, key, p, dict(uncertain), dict(bounded), opts, mode, piece, t0, t_end,
                  stop) for piece in pieces]


_MAX_PIECES = 4096


def _split(Z: Zonotope, k: int) -> list[Zonotope]:
    """``Z`` cut into ``k`` equal pieces along each generator (their union is ``Z``)."""
    G = Z.compact().generators
    m = G.shape[1]
    if k ** m > _MAX_PIECES:
        raise ReachError(f"split={k} over {m} uncertain directions gives {k ** m} pieces; "
                         f"at most {_MAX_PIECES} are allowed")
    offsets = -1.0 + (2.0 * np.arange(k) + 1.0) / k   # centres of the k sub-intervals of [-1, 1]
    pieces = []
    for idx in np.ndindex(*([k] * m)):
        shift = G @ offsets[list(idx)] if m else np.zeros(Z.dim)
        pieces.append(Zonotope(Z.center + shift, G / k))
    return pieces
