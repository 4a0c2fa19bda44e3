"""Falsification: search the initial set for a simulated trajectory that violates a spec.

Cheap and incomplete by design: a violation it finds is real (a concrete,
replayable simulation), but finding none proves nothing. The search

1. simulates from the centre, the corners (all of them up to ``max_corner_dims``
   uncertain dimensions, a random subset beyond) and Latin-hypercube samples of
   the uncertain initial states, uncertain parameters and inputs;
2. evaluates every spec's margin along the dense trajectory of each run: on the
   stored points and three interior points of every integrator step, then the
   lowest local minima are refined with a bounded scalar minimiser on the dense
   output, and the first violation instant is located by a root finder;
3. if nothing is violated, minimises each spec's margin locally (scipy
   ``minimize``, Powell, bounded to the uncertain box) from its best sample.
   :class:`FalsificationSearch` runs the two stages separately, so that a
   caller can prove the specs in between and skip the second.

Time-varying inputs are only tried as *constants* within their bounds (each
sample draws one constant value per input); a violation that needs a varying
input can be missed.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from hybridlab.reachability.margins import SpecMargin, sample_trajectory, trajectory_margin
from hybridlab.reachability.options import FalsifyOptions
from hybridlab.reachability.spec import Spec
from hybridlab.simulation.options import SimulationOptions
from hybridlab.simulation.problem import HybridProblem
from hybridlab.simulation.result import SimulationResult, Status
from hybridlab.symbolic.compile import CompiledModel
from hybridlab.symbolic.functions import VectorFunction

__all__ = ["FalsifyOptions", "Counterexample", "SpecMargin", "Falsification", "falsify",
           "FalsificationSearch", "run_point", "trajectory_margin"]

_REFERENCE_STEPS = 200
"""Integrator steps a falsification run may take on the reference engine, and ..."""
_REFERENCE_TOTAL_STEPS = 600
"""... the steps all of them may take, before the search moves to the compiled kernel
(whose loading costs about as much as 600 reference steps, and compiling a model not yet
in the cache much more). Counted in steps, not seconds, so that which engine runs which
simulation is deterministic."""
_REFERENCE_PROJECTED_STEPS = 1200
"""The search also moves once the runs still planned in its stage, at the steps of the
last run, would take the total past this (a stage of 21 runs of 110 steps moves after its
first run, not its sixth)."""


def run_point(problem: HybridProblem, x0: np.ndarray, p: np.ndarray,
              options: SimulationOptions | None = None) -> SimulationResult:
    """Simulate ``problem`` from ``x0`` with parameter vector ``p`` (deterministic), with
    ``options`` in place of the problem's if given.

    Examples
    --------
    >>> pb = HybridProblem.build("models/bouncing_ball.toml", initial={"h": (5.0, 10.0)},
    ...                          t_end=2.0)
    >>> result = run_point(pb, np.array([10.0, 0.0]), pb.p0,
    ...                    replace(pb.options, backend="reference"))
    >>> result.status.name, len(result.jumps), round(result.final.state["h"], 6)
    ('COMPLETED', 1, 4.805708)
    """
    return _simulate(problem.compiled, problem.mode, problem.t_start, problem.t_end,
                     options or problem.options,
                     dict(zip(problem.compiled.state_names, map(float, x0), strict=True)),
                     dict(zip(problem.compiled.parameter_names, map(float, p), strict=True)))


def _reference_first(problem: HybridProblem) -> bool:
    """Whether short runs should go to the reference engine: under ``backend="auto"``,
    while loading the compiled kernel would still cost its time, and when ``max_step``
    allows a run of ``_REFERENCE_STEPS`` steps."""
    import sys

    options = problem.options
    return (options.backend == "auto"
            and "hybridlab.simulation.compiled.backend" not in sys.modules
            and (problem.t_end - problem.t_start) / options.max_step <= _REFERENCE_STEPS)


def _simulate(compiled: CompiledModel, mode: str, t_start: float, t_end: float,
              options: SimulationOptions, initial: Mapping[str, float],
              params: Mapping[str, float]) -> SimulationResult:
    from hybridlab.simulation.api import simulate  # the engines load with the first run

    # every setting explicit, so a scenario of the model cannot change the run on replay
    return simulate(compiled, t_end, params=params, initial=initial, mode=mode, t_start=t_start,
                    method=options.method, rtol=options.rtol, atol=options.atol,
                    max_step=options.max_step, options=options)


# ------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Counterexample:
    """A simulated trajectory from the initial set that violates a spec.

    Attributes
    ----------
    spec : str
        The violated spec.
    t : float
        The first instant the spec is violated (located by a root finder on the
        dense output; the start time if the initial state already violates it).
    mode : str
        The mode at ``t``.
    state : mapping of str to float
        The state at ``t``.
    margin : float
        The most negative margin along the run (``< 0``; ``<= 0`` for a region).
    t_worst : float
        Where that margin is reached (refined by a bounded minimiser).
    initial : mapping of str to float
        The initial state (every state).
    parameters : mapping of str to float
        Every parameter value of the run (uncertain ones and inputs included).
    inputs : mapping of str to float
        The constant value chosen for each time-varying input.
    initial_mode : str
    t_start, t_end : float
    options : SimulationOptions

    Examples
    --------
    >>> from hybridlab.reachability.spec import parse_spec
    >>> pb = HybridProblem.build("models/thermostat.toml", initial={"T": (19.0, 21.0)},
    ...                          t_end=1.0)
    >>> cx = falsify(pb, [parse_spec("T <= 20.5", pb.compiled)]).counterexample
    >>> cx.spec, cx.initial, cx.mode, round(cx.t, 6), round(cx.state["T"], 6)
    ('T <= 20.5', {'T': 20.0}, 'heat', 0.253178, 20.5)
    >>> round(cx.margin, 6), round(cx.t_worst, 6)  # T reaches 21.903252 at t_end
    (-1.403252, 1.0)
    >>> replayed = cx.replay()  # the same run again
    >>> round(float(replayed(cx.t)[0]), 6)
    20.5
    """

    spec: str
    t: float
    mode: str
    state: Mapping[str, float]
    margin: float
    t_worst: float
    initial: Mapping[str, float]
    parameters: Mapping[str, float]
    inputs: Mapping[str, float]
    initial_mode: str
    t_start: float
    t_end: float
    options: SimulationOptions = field(repr=False)
    compiled: CompiledModel = field(repr=False, compare=False)

    def replay(self) -> SimulationResult:
        """Simulate this counterexample again (deterministic: the same run, bit for bit)."""
        return _simulate(self.compiled, self.initial_mode, self.t_start, self.t_end,
                         self.options, self.initial, self.parameters)

    def as_dict(self) -> dict[str, Any]:
        """A JSON-ready mapping."""
        return {"spec": self.spec, "t": self.t, "mode": self.mode, "state": dict(self.state),
                "margin": self.margin, "t_worst": self.t_worst, "initial": dict(self.initial),
                "parameters": dict(self.parameters), "inputs": dict(self.inputs),
                "initial_mode": self.initial_mode, "t_start": self.t_start, "t_end": self.t_end}


@dataclass(frozen=True)
class Falsification:
    """What the falsification search found.

    Attributes
    ----------
    counterexample : Counterexample or None
    margins : mapping of str to float
        Per spec, the lowest margin over every simulated run (``inf`` if the
        spec never applied).
    runs : int
        Simulations spent.
    incomplete_runs : int
        Runs that stopped before ``t_end`` (Zeno, invariant violation, failure).
    time_s : float
    most_jumps : int
        The most jumps in one simulated run.

    Examples
    --------
    The centre and the two corners of the initial heights; the fastest impact, from
    ``h = 10``, is at ``v = -14.007``:

    >>> from hybridlab.reachability.spec import parse_spec
    >>> pb = HybridProblem.build("models/bouncing_ball.toml", initial={"h": (5.0, 10.0)},
    ...                          t_end=2.0)
    >>> found = falsify(pb, [parse_spec("v >= -15", pb.compiled)],
    ...                 FalsifyOptions(samples=0, local_evals=0))
    >>> found.counterexample, found.runs, found.incomplete_runs, found.most_jumps
    (None, 3, 0, 1)
    >>> round(found.margins["v >= -15"], 6)
    0.992859
    """

    counterexample: Counterexample | None
    margins: Mapping[str, float]
    runs: int
    incomplete_runs: int
    time_s: float
    most_jumps: int = 0


class _Margins:
    """Compiled rows of each spec, per mode."""

    def __init__(self, compiled: CompiledModel, specs: Sequence[Spec]) -> None:
        sym = compiled.symbolic
        from hybridlab.model.checks import TIME

        self.specs = tuple(specs)
        self.fns: list[dict[str, VectorFunction]] = []
        cache: dict[tuple, VectorFunction] = {}
        for spec in self.specs:
            per_mode = {}
            for mode, rows in spec.rows.items():
                if rows not in cache:
                    cache[rows] = VectorFunction(rows, TIME, sym.states, sym.parameters, ())
                per_mode[mode] = cache[rows]
            self.fns.append(per_mode)


class _Found(Exception):
    def __init__(self, u: np.ndarray, evaluated: Any) -> None:
        self.u = u
        self.evaluated = evaluated


class FalsificationSearch:
    """The falsification search in its two stages: sampling, then local search.

    :func:`falsify` runs both. A caller that can prove safety in between (the
    verdict runs the flowpipes after sampling) calls :meth:`local` only when the
    proof fails, so a spec that is proved never pays for the local search.

    Parameters
    ----------
    problem : HybridProblem
    specs : sequence of Spec
    options : FalsifyOptions, optional

    Examples
    --------
    >>> from hybridlab.reachability.spec import parse_spec
    >>> pb = HybridProblem.build("models/bouncing_ball.toml", initial={"h": (5.0, 10.0)},
    ...                          t_end=2.0)
    >>> search = FalsificationSearch(pb, [parse_spec("h <= 10.5", pb.compiled)])
    >>> found = search.sample()
    >>> found.counterexample is None, found.runs
    (True, 19)
    >>> search.local().runs > found.runs
    True
    """

    def __init__(self, problem: HybridProblem, specs: Sequence[Spec],
                 options: FalsifyOptions | None = None) -> None:
        self.problem = problem
        self.specs = tuple(specs)
        self.options = options or FalsifyOptions()
        self._fns: list[dict[str, VectorFunction]] | None = None  # built on the first run
        self._rng = np.random.default_rng(self.options.seed)
        self._lowest = {s.text: math.inf for s in self.specs}
        self._best_u: list[list[tuple[float, np.ndarray]]] = [[] for _ in self.specs]
        self._runs = 0
        self._incomplete = 0
        self._most_jumps = 0
        self._time = 0.0
        self._found: Falsification | None = None
        # short runs go to the reference engine while they stay short, so a small model
        # is falsified without loading the compiled kernel (only under backend="auto",
        # and only while this process has not loaded the kernel anyway)
        self._reference_steps = 0 if _reference_first(problem) else None
        self._planned = 0  # runs still planned in the current stage, after the current one

    def _margin_functions(self) -> list[dict[str, VectorFunction]]:
        """The specs' rows compiled per mode (on the first run: a verdict proved without
        simulation never needs them)."""
        if self._fns is None:
            self._fns = _Margins(self.problem.compiled, self.specs).fns
        return self._fns

    def sample(self) -> Falsification:
        """Simulate the centre, the corners and the Latin-hypercube samples."""
        return self._timed(self._sample)

    def local(self) -> Falsification:
        """Minimise each spec's margin locally from its best samples (after :meth:`sample`)."""
        return self._timed(self._local)

    def _timed(self, stage) -> Falsification:  # noqa: ANN001 - one of the two stages
        if self._found is not None and self._found.counterexample is not None:
            return self._found
        started = time.perf_counter()
        cx = stage()
        self._time += time.perf_counter() - started
        self._found = Falsification(cx, dict(self._lowest), self._runs, self._incomplete,
                                    self._time, self._most_jumps)
        return self._found

    def _sample(self) -> Counterexample | None:
        plan = _sample_plan(self.problem.dims, self.options, self._rng)
        for i, u in enumerate(plan):
            self._planned = len(plan) - i - 1  # runs after this one
            evaluated = self._evaluate(u)
            if evaluated is not None and any(m.violation_t is not None for m in evaluated[0]):
                return self._counterexample(u, evaluated)
        return None

    def _local(self) -> Counterexample | None:
        d = self.problem.dims
        if not (d and self.options.local_evals):
            return None
        self._planned = self.options.local_evals
        for i in range(len(self.specs)):
            starts = sorted(self._best_u[i], key=lambda item: item[0])[:self.options.local_starts]
            for _, u0 in starts:
                found = _local_search(i, u0, d, self.options.local_evals, self._evaluate)
                if found is not None:
                    return self._counterexample(*found)
        return None

    def _evaluate(self, u: np.ndarray
                  ) -> tuple[list[SpecMargin], SimulationResult, np.ndarray] | None:
        point = self.problem.point(u)
        if point is None:
            return None
        x0, p = point
        result = self._run(x0, p)
        self._runs += 1
        self._most_jumps = max(self._most_jumps, len(result.jumps))
        if not result.status.ok:
            self._incomplete += 1
        samples = sample_trajectory(result)  # once for every spec
        out = [trajectory_margin(result, s, fns, p, samples)
               for s, fns in zip(self.specs, self._margin_functions(), strict=True)]
        for i, m in enumerate(out):
            self._lowest[m.spec] = min(self._lowest[m.spec], m.margin)
            if np.isfinite(m.margin):
                self._best_u[i].append((m.margin, u))
        return out, result, p

    def _run(self, x0: np.ndarray, p: np.ndarray) -> SimulationResult:
        if self._reference_steps is not None:
            options = self.problem.options
            short = replace(options, backend="reference",
                            max_steps=min(options.max_steps, _REFERENCE_STEPS))
            result = run_point(self.problem, x0, p, short)
            steps = int(result.stats.get("steps", 0))
            self._reference_steps += steps
            projected = self._reference_steps + steps * self._planned
            if (self._reference_steps > _REFERENCE_TOTAL_STEPS
                    or projected > _REFERENCE_PROJECTED_STEPS):
                self._reference_steps = None  # from the next run on: the compiled kernel
            if result.status is not Status.STEP_LIMIT or options.max_steps <= _REFERENCE_STEPS:
                return result
            self._reference_steps = None
        return run_point(self.problem, x0, p)

    def _counterexample(self, u: np.ndarray, evaluated: Any) -> Counterexample:
        out, result, p = evaluated
        m = next(m for m in out if m.violation_t is not None)
        problem = self.problem
        names = problem.compiled.state_names
        pnames = problem.compiled.parameter_names
        x0, _ = problem.point(u)  # type: ignore[misc]
        return Counterexample(
            spec=m.spec, t=float(m.violation_t), mode=str(m.violation_mode),
            state=dict(zip(names, map(float, m.violation_state), strict=True)),
            margin=float(m.margin), t_worst=float(m.t),
            initial=dict(zip(names, map(float, x0), strict=True)),
            parameters=dict(zip(pnames, map(float, p), strict=True)),
            inputs={k: float(p[pnames.index(k)]) for k in problem.input_box},
            initial_mode=problem.mode, t_start=problem.t_start, t_end=problem.t_end,
            options=replace(problem.options, backend=str(result.stats["backend"])),
            compiled=problem.compiled)


def falsify(problem: HybridProblem, specs: Sequence[Spec],
            options: FalsifyOptions | None = None) -> Falsification:
    """Search the uncertain initial set, parameters and inputs for a violation.

    Parameters
    ----------
    problem : HybridProblem
    specs : sequence of Spec
    options : FalsifyOptions, optional

    Returns
    -------
    Falsification
        With the first counterexample found (the worst violation of the run
        that found it), or ``None`` and the lowest margins seen.

    Examples
    --------
    >>> from hybridlab.reachability.spec import parse_spec
    >>> pb = HybridProblem.build("models/bouncing_ball.toml", initial={"h": (5.0, 10.0)},
    ...                          t_end=2.0)
    >>> found = falsify(pb, [parse_spec("h <= 9", pb.compiled)])
    >>> cx = found.counterexample
    >>> cx.t, cx.initial["h"], cx.margin
    (0.0, 10.0, -1.0)
    >>> bool(np.array_equal(cx.replay().y, cx.replay().y))
    True
    """
    search = FalsificationSearch(problem, specs, options)
    found = search.sample()
    return found if found.counterexample is not None else search.local()


def _sample_plan(d: int, options: FalsifyOptions, rng: np.random.Generator) -> list[np.ndarray]:
    plan = [np.full(d, 0.5)]
    if d == 0:
        return plan
    if d <= options.max_corner_dims:
        grid = np.array(np.meshgrid(*[[0.0, 1.0]] * d, indexing="ij")).reshape(d, -1).T
        plan += list(grid)
    else:
        plan += list(rng.integers(0, 2, size=(options.corners, d)).astype(float))
    if options.samples:
        plan += list(latin_hypercube(options.samples, d, rng))
    return plan


def latin_hypercube(n: int, d: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` points in ``[0, 1)^d``, one in each of the ``n`` strata of every coordinate.

    McKay, Beckman and Conover's design: per coordinate a random permutation of the
    strata and a uniform position inside each (what ``scipy.stats.qmc.LatinHypercube``
    draws, without importing ``scipy.stats``, which costs 0.7 s at start-up).

    Examples
    --------
    >>> u = latin_hypercube(4, 2, np.random.default_rng(0))
    >>> sorted(np.floor(u[:, 0] * 4).astype(int).tolist())
    [0, 1, 2, 3]
    """
    strata = np.argsort(rng.random((d, n)), axis=1).T
    return (strata + rng.random((n, d))) / n


def _local_search(i: int, u0: np.ndarray, d: int, budget: int, evaluate) -> tuple | None:
    """Powell on spec ``i``'s minimum margin, bounded to the unit cube; stops at a violation."""

    def objective(u: np.ndarray) -> float:
        u = np.clip(u, 0.0, 1.0)
        evaluated = evaluate(u)
        if evaluated is None:
            return math.inf
        m = evaluated[0][i]
        if any(mm.violation_t is not None for mm in evaluated[0]):
            raise _Found(u.copy(), evaluated)
        return m.margin if np.isfinite(m.margin) else math.inf

    try:
        from scipy import optimize

        optimize.minimize(objective, u0, method="Powell", bounds=[(0.0, 1.0)] * d,
                          options={"maxfev": budget, "xtol": 1e-6, "ftol": 1e-9})
    except _Found as found:
        return found.u, found.evaluated
    return None
