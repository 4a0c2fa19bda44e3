"""The public entry point :func:`simulate`."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from hybridlab.model.schema import Model
from hybridlab.simulation.compiled import use_compiled
from hybridlab.simulation.engine import run
from hybridlab.simulation.options import SimulationOptions
from hybridlab.simulation.resolve import as_compiled, scenario_of
from hybridlab.simulation.result import SimulationResult
from hybridlab.symbolic.compile import CompiledModel

__all__ = ["simulate"]

_DEFAULTS = SimulationOptions()  # frozen: shared by every call that passes no options


def simulate(
    model: Model | CompiledModel | str | Path,
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
    **option_overrides: object,
) -> SimulationResult:
    """Simulate a hybrid automaton.

    Parameters
    ----------
    model : Model, CompiledModel, str or pathlib.Path
        The model (a path is loaded with :func:`hybridlab.load_model`).
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
    ValueError
        For unknown names, a bad horizon or bad settings (naming the argument).
    hybridlab.ZenoError
        Under ``zeno="error"`` when events accumulate.

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
    compiled = as_compiled(model)
    spec = compiled.model
    sc = scenario_of(spec, scenario)
    if t_end is None:
        if sc is None:
            others = ", ".join(spec.scenarios)
            hint = f"; pass one of its scenarios ({others})" if others else ""
            raise ValueError(f"t_end is required: give t_end or a scenario{hint}")
        t_end = sc.t_end
    t0 = t_start if t_start is not None else (sc.t_start if sc else 0.0)
    if not (np.isfinite(float(t_end)) and np.isfinite(float(t0))):
        raise ValueError(f"t_end and t_start must be finite (got t_end={t_end!r}, t_start={t0!r})")
    if not float(t_end) > float(t0):
        raise ValueError(f"t_end must be greater than t_start (got t_end={t_end!r}, "
                         f"t_start={t0!r})")
    p = compiled.parameter_vector({**(sc.parameters if sc else {}), **(params or {})})
    x0 = compiled.state_vector({**(sc.initial if sc else {}), **(initial or {})})
    mode = mode or (sc.mode if sc and sc.mode else spec.initial.mode)
    if mode not in spec.modes:
        raise ValueError(f"unknown mode {mode!r}; the model has: {', '.join(spec.modes)}")
    settings = dict(option_overrides)
    for name, value in (("method", method), ("rtol", rtol), ("atol", atol),
                        ("max_step", max_step)):
        if value is None and sc is not None:
            value = getattr(sc, name)
        if value is not None:
            settings[name] = value
    base = options or _DEFAULTS
    unknown = set(settings) - set(SimulationOptions.__dataclass_fields__)
    if unknown:
        raise TypeError(f"simulate() got unknown option(s): {', '.join(sorted(unknown))}")
    opts = SimulationOptions(**{**base.__dict__, **settings})
    if (float(t_end) - float(t0)) / opts.max_step > opts.max_steps:
        raise ValueError(f"max_step = {opts.max_step!r} needs more than max_steps = "
                         f"{opts.max_steps} steps to reach t_end = {t_end!r}: raise max_step "
                         "or max_steps")
    if use_compiled(opts.backend):
        from hybridlab.simulation.compiled.backend import run as run_compiled

        return run_compiled(compiled, t0=float(t0), x0=x0, mode=mode, t_end=float(t_end), p=p,
                            options=opts)
    result = run(compiled, t0=float(t0), x0=x0, mode=mode, t_end=float(t_end), p=p,
                 options=opts)
    result.stats["backend"] = "reference"  # a fresh dict of this run
    return result
