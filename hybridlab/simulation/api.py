"""The public entry point :func:`simulate`."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from hybridlab.errors import SimulationError
from hybridlab.model.discrete import value_problem
from hybridlab.model.schema import Model
from hybridlab.simulation.compiled import use_compiled
from hybridlab.simulation.engine import run
from hybridlab.simulation.options import SimulationOptions
from hybridlab.simulation.problem import HybridProblem
from hybridlab.simulation.result import SimulationResult
from hybridlab.symbolic.compile import CompiledModel

__all__ = ["simulate"]


def simulate(
    model: Model | CompiledModel | str | Path | HybridProblem,
    t_end: float | None = None,
    *,
    scenario: str | None = None,
    params: Mapping[str, float] | None = None,
    initial: Mapping[str, float] | None = None,
    mode: str | None = None,
    t_start: float | None = None,
    method: str | None = None,
    rtol: float | None = None,
    atol: float | None = None,
    max_step: float | None = None,
    options: SimulationOptions | None = None,
    **option_overrides: Any,
) -> SimulationResult:
    """Simulate a hybrid automaton.

    Parameters
    ----------
    model : Model, CompiledModel, str, pathlib.Path or HybridProblem
        The model (a path is loaded with :func:`hybridlab.load_model`), or a
        problem whose values the other arguments override.
    t_end : float, optional
        Final time; defaults to the scenario's ``t_end``.
    scenario : str, optional
        A scenario of the model supplying defaults; ``"default"`` is used when
        the model has one and nothing else is given.
    params, initial : mapping of str to float, optional
        Parameter and initial-state overrides (on top of the scenario's).
    mode : str, optional
        Initial mode (default: the scenario's, else the model's).
    t_start : float, optional
        Initial time (default: the scenario's, else 0).
    method, rtol, atol, max_step : optional
        Integrator settings; see :class:`SimulationOptions`.
    options : SimulationOptions, optional
        All settings at once; keyword arguments override its fields.
    **option_overrides
        Any other :class:`SimulationOptions` field, e.g. ``zeno="error"`` or
        ``backend="reference"``.

    Returns
    -------
    SimulationResult

    Raises
    ------
    hybridlab.simulation.problem.ProblemError
        A ``ValueError`` for unknown names, a bad horizon or bad settings, or
        uncertain values (naming the argument).
    hybridlab.ZenoError
        Under ``zeno="error"`` when events accumulate.
    hybridlab.errors.SimulationError
        When a jump gives a bool or int discrete variable a value it cannot take.

    Examples
    --------
    >>> import hybridlab
    >>> ball = hybridlab.load_model("models/bouncing_ball.toml")
    >>> result = hybridlab.simulate(ball, t_end=3.0)
    >>> result.status.name, round(result.events[0].t, 9)
    ('COMPLETED', 1.427843123)
    >>> result.events[0].post["v"] > 0
    True
    """
    problem = HybridProblem.build(model, t_end, scenario=scenario, params=params,
                                  initial=initial, mode=mode, t_start=t_start, method=method,
                                  rtol=rtol, atol=atol, max_step=max_step, options=options,
                                  **option_overrides)
    problem.require_point("simulate")
    compiled, opts, t0, t_end, x0, p, mode = (problem.compiled, problem.options, problem.t_start,
                                               problem.t_end, problem.x0, problem.p0,
                                               problem.mode)
    if use_compiled(opts.backend):
        from hybridlab.simulation.compiled.backend import run as run_compiled

        result = run_compiled(compiled, t0=t0, x0=x0, mode=mode, t_end=t_end, p=p,
                              options=opts)
    else:
        result = run(compiled, t0=t0, x0=x0, mode=mode, t_end=t_end, p=p, options=opts)
        result.stats["backend"] = "reference"  # a fresh dict of this run
    check_jumps(compiled, result)
    return result


def check_jumps(compiled: CompiledModel, result: SimulationResult) -> None:
    """Raise :class:`SimulationError` naming the first jump of ``result`` that gave a bool
    or int discrete variable a value it cannot take (a reset such as ``count = "n/2"``
    whose value the model could not check when it loaded).

    Examples
    --------
    >>> import hybridlab
    >>> halve = hybridlab.model_from_dict({
    ...     "name": "halve", "states": {"x": 0.0}, "discrete": {"n": 5},
    ...     "modes": {"m": {"flow": {"x": "1"}}}, "initial": {"mode": "m"},
    ...     "transitions": [{"name": "tick", "source": "m", "target": "m",
    ...                      "schedule": {"period": 1.0, "phase": 1.0}, "reset": {"n": "n/2"}}]})
    >>> hybridlab.simulate(halve, t_end=2.0, backend="reference")
    Traceback (most recent call last):
    ...
    hybridlab.errors.SimulationError: transition 'tick' at t = 1 set 'n': an int variable takes whole numbers (got 2.5)
    """  # noqa: E501
    kinds = compiled.symbolic.discrete
    events = result.events
    if not len(events) or not any(kind != "real" for kind in kinds.values()):
        return
    post = events.post
    first: tuple[int, str, str] | None = None  # (event, variable, problem)
    for i, name in enumerate(result.state_names):
        if kinds.get(name, "real") == "real":
            continue
        for value in np.unique(post[:, i]):
            problem = value_problem(kinds[name], float(value))
            k = int(np.flatnonzero(post[:, i] == value)[0]) if problem else len(events)
            if problem and (first is None or k < first[0]):
                first = (k, name, problem)
    if first is not None:
        k, name, problem = first
        raise SimulationError(f"transition {events.transition[k]!r} at t = "
                              f"{events.t[k]:g} set {name!r}: {problem}")
