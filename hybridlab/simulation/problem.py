"""A hybrid problem: a model with everything a run or an analysis needs, resolved once.

:class:`HybridProblem` takes a model (a :class:`~hybridlab.model.schema.Model`, a
:class:`~hybridlab.symbolic.compile.CompiledModel` or a path), a scenario, a horizon,
the initial mode, parameter and initial values (numbers, or ``(lo, hi)`` intervals for
uncertain ones), bounded inputs and the integrator settings, and checks them all at
once, with one wording for every error. :func:`hybridlab.simulate`,
:func:`hybridlab.reach`, :func:`hybridlab.verify.check_safety`,
:func:`hybridlab.sweep` and the fits accept one in place of the model.

Defaults come from the scenario (``"default"`` when the model has one and none is
named): its parameters, initial values, mode, ``t_start``, ``t_end`` and integrator
settings. Explicit arguments override the scenario, and the scenario's integrator
settings override ``options``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from hybridlab.errors import HybridlabError
from hybridlab.model.discrete import value_problem
from hybridlab.model.loader import load_model
from hybridlab.model.names import match_modes, spellings
from hybridlab.model.schema import Model, Scenario
from hybridlab.simulation.options import SimulationOptions
from hybridlab.symbolic.compile import CompiledModel, compile_model

__all__ = ["HybridProblem", "ProblemError", "as_compiled", "interval", "scenario_of"]

#: integrator settings a scenario may carry (and ``simulate`` takes as keywords)
_SCENARIO_SETTINGS = ("method", "rtol", "atol", "max_step")


class ProblemError(HybridlabError, ValueError):
    """An argument of a problem is wrong: one line naming the argument and the value.

    Examples
    --------
    >>> HybridProblem.build("models/bouncing_ball.toml", t_end=1.0, params={"k": 1.0})
    Traceback (most recent call last):
    ...
    hybridlab.simulation.problem.ProblemError: params: unknown parameter 'k'; expected one of: g, e
    >>> issubclass(ProblemError, ValueError)
    True
    """


def as_compiled(model: Model | CompiledModel | str | Path | HybridProblem) -> CompiledModel:
    """The compiled model of a Model, a CompiledModel (returned as is), a problem or a path.

    Examples
    --------
    >>> compiled = as_compiled("models/bouncing_ball.toml")
    >>> as_compiled(compiled) is compiled, compiled.model.name
    (True, 'bouncing_ball')
    """
    if isinstance(model, CompiledModel):
        return model
    if isinstance(model, HybridProblem):
        return model.compiled
    if isinstance(model, str | Path):
        model = load_model(model)
    if not isinstance(model, Model):
        raise TypeError(f"model must be a Model, CompiledModel, HybridProblem or path (got "
                        f"{type(model).__name__})")
    return compile_model(model)


def scenario_of(spec: Model, scenario: str | None) -> Scenario | None:
    """The named scenario, the model's ``"default"`` one when unnamed, else None.

    Examples
    --------
    >>> ball = load_model("models/bouncing_ball.toml")
    >>> scenario_of(ball, None) is ball.scenarios.get("default")
    True
    >>> scenario_of(ball, "nope")
    Traceback (most recent call last):
    ...
    hybridlab.simulation.problem.ProblemError: scenario: unknown scenario 'nope'; the model has: ...
    """
    if scenario is None and "default" in spec.scenarios:
        scenario = "default"
    if scenario is None:
        return None
    if scenario not in spec.scenarios:
        known = ", ".join(spec.scenarios) or "none"
        raise ProblemError(f"scenario: unknown scenario {scenario!r}; the model has: {known}")
    return spec.scenarios[scenario]


def interval(value: Any, what: str) -> tuple[float, float]:
    """A number (a point) or a ``(lo, hi)`` pair as a finite interval.

    Examples
    --------
    >>> interval(2, "params['g']"), interval((1, 3.5), "initial['h']")
    ((2.0, 2.0), (1.0, 3.5))
    >>> interval((3, 1), "initial['h']")
    Traceback (most recent call last):
    ...
    hybridlab.simulation.problem.ProblemError: initial['h'] needs lo <= hi (got (3, 1))
    """
    if isinstance(value, int | float | np.floating | np.integer) and not isinstance(value, bool):
        lo = hi = float(value)
    else:
        try:
            lo, hi = (float(v) for v in value)
        except (TypeError, ValueError):
            raise ProblemError(f"{what} must be a number or a (lo, hi) pair (got {value!r})"
                               ) from None
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ProblemError(f"{what} must be finite (got {value!r})")
    if lo > hi:
        raise ProblemError(f"{what} needs lo <= hi (got {value!r})")
    return lo, hi


def _unknown(what: str, kind: str, name: str, names: tuple[str, ...]) -> ProblemError:
    same = spellings(name, names)
    if len(same) > 1:  # the unqualified name of several components' variables
        return ProblemError(f"{what}: {name!r} is the {kind} of several components; write "
                            f"one of: {', '.join(same)}")
    return ProblemError(f"{what}: unknown {kind} {name!r}; expected one of: "
                        f"{', '.join(names) or 'none'}")


@dataclass(frozen=True)
class HybridProblem:
    """A model with its horizon, mode, values and settings, resolved and checked once.

    Build one with :meth:`build`; :meth:`updated` gives a changed copy, checked again.

    Attributes
    ----------
    compiled : CompiledModel
    mode : str
        Initial mode.
    t_start, t_end : float
    x0 : numpy.ndarray
        Initial state in model order (intervals and sets at their centre).
    p0 : numpy.ndarray
        Parameter vector (intervals at their centre).
    state_box : mapping of str to (lo, hi)
        Initial states given as intervals with ``lo < hi``.
    param_box : mapping of str to (lo, hi)
        Uncertain constant parameters.
    input_box : mapping of str to (lo, hi)
        Parameters that vary in time within bounds (inputs).
    options : SimulationOptions
        Integrator settings (the scenario's included).
    scenario : str or None
        The scenario that supplied defaults.
    initial_set : Box, Zonotope, Polytope or None
        The initial set, when given as a set over all states.

    Examples
    --------
    >>> pb = HybridProblem.build("models/bouncing_ball.toml", t_end=2.0,
    ...                          initial={"h": (5.0, 10.0)}, params={"e": 0.8})
    >>> pb.mode, pb.t_end, pb.initial["h"], pb.parameters["e"], pb.uncertain
    ('fall', 2.0, 7.5, 0.8, True)
    >>> pb.updated(initial={"h": 6.0}).uncertain
    False
    >>> HybridProblem.build("models/bouncing_ball.toml", t_end=2.0, mode="rise")
    Traceback (most recent call last):
    ...
    hybridlab.simulation.problem.ProblemError: mode: unknown mode 'rise'; expected one of: fall
    """

    compiled: CompiledModel = field(repr=False)
    mode: str
    t_start: float
    t_end: float
    x0: np.ndarray
    p0: np.ndarray
    state_box: Mapping[str, tuple[float, float]]
    param_box: Mapping[str, tuple[float, float]]
    input_box: Mapping[str, tuple[float, float]]
    options: SimulationOptions
    scenario: str | None = None
    initial_set: Any = None
    request: Mapping[str, Any] = field(default_factory=dict, repr=False, compare=False)

    @classmethod
    def build(cls, model: Model | CompiledModel | str | Path | HybridProblem,
              t_end: float | None = None, *, scenario: str | None = None,
              params: Mapping[str, float | tuple[float, float]] | None = None,
              initial: Mapping[str, float | tuple[float, float]] | Any = None,
              mode: str | None = None, t_start: float | None = None,
              inputs: Mapping[str, tuple[float, float]] | None = None,
              options: SimulationOptions | None = None,
              **option_overrides: Any) -> HybridProblem:
        """Resolve and check a problem.

        Parameters
        ----------
        model : Model, CompiledModel, path or HybridProblem
            A problem is returned as is when nothing else is given, else updated.
        t_end : float, optional
            Horizon (default: the scenario's).
        scenario : str, optional
            The scenario supplying defaults (``"default"`` when the model has one).
        params : mapping, optional
            Parameter values; a ``(lo, hi)`` pair with ``lo < hi`` is an uncertain
            constant.
        initial : mapping or set, optional
            Initial values per state (a number or a ``(lo, hi)`` pair), or a
            ``Box``/``Zonotope``/``Polytope`` over all states.
        mode : str, optional
            Initial mode (default: the scenario's, else the model's).
        t_start : float, optional
            Initial time (default: the scenario's, else 0).
        inputs : mapping, optional
            Parameters that vary in time within ``(lo, hi)``.
        options : SimulationOptions, optional
            Integrator settings; ``**option_overrides`` (``rtol=1e-9``,
            ``backend="reference"``, ...) override its fields.

        Raises
        ------
        ProblemError
            For an unknown name, scenario or mode, a bad interval or horizon; the
            message names the argument.
        TypeError
            For an unknown option name or a model of the wrong type.
        """
        option_overrides = {k: v for k, v in option_overrides.items() if v is not None}
        given = dict(t_end=t_end, scenario=scenario, params=params, initial=initial, mode=mode,
                     t_start=t_start, inputs=inputs, options=options, **option_overrides)
        changed = {k: v for k, v in given.items() if v is not None}
        if isinstance(model, HybridProblem):
            return model.updated(**changed) if changed else model
        compiled = as_compiled(model)
        spec = compiled.model
        sc = scenario_of(spec, scenario)
        t0 = float(t_start) if t_start is not None else (float(sc.t_start) if sc else 0.0)
        if t_end is None:
            if sc is None:
                others = ", ".join(spec.scenarios)
                hint = f" (the model's scenarios: {others})" if others else ""
                raise ProblemError(f"t_end is required: give t_end or a scenario{hint}")
            t_end = sc.t_end
        t1 = float(t_end)
        if not (math.isfinite(t0) and math.isfinite(t1)):
            raise ProblemError(f"t_end and t_start must be finite (got t_end={t_end!r}, "
                               f"t_start={t0!r})")
        if not t1 > t0:
            raise ProblemError(f"t_end must be greater than t_start = {t0:g} (got "
                               f"t_end={t_end!r})")
        mode = mode or (sc.mode if sc is not None and sc.mode else spec.initial.mode)
        if len(matched := match_modes(mode, list(spec.modes))) == 1:
            mode = matched[0]  # a product mode named by some of its components' modes
        if mode not in spec.modes:
            raise _unknown("mode", "mode", mode, tuple(spec.modes))
        fixed_p, param_box, input_box = _parameters(compiled, sc, params, inputs)
        fixed_x, state_box, initial_set = _initial(compiled, sc, initial)
        opts = _settings(sc, options, option_overrides)
        if (t1 - t0) / opts.max_step > opts.max_steps:
            raise ProblemError(f"max_step = {opts.max_step!r} needs more than max_steps = "
                               f"{opts.max_steps} steps to reach t_end = {t1!r}: raise "
                               "max_step or max_steps")
        request = {"model": compiled, **{k: v for k, v in given.items() if v is not None}}
        return cls(compiled=compiled, mode=mode, t_start=t0, t_end=t1,
                   x0=_vector(compiled.state_vector, fixed_x),
                   p0=_vector(compiled.parameter_vector, fixed_p), state_box=state_box,
                   param_box=param_box, input_box=input_box, options=opts,
                   scenario=None if sc is None else _name_of(spec, sc),
                   initial_set=initial_set, request=request)

    def updated(self, **changes: Any) -> HybridProblem:
        """A copy with some arguments of :meth:`build` changed, checked again.

        Examples
        --------
        >>> pb = HybridProblem.build("models/bouncing_ball.toml", t_end=2.0)
        >>> pb.updated(t_end=3.0, params={"e": 0.5}).parameters["e"]
        0.5
        """
        request = {**self.request, **changes}
        return HybridProblem.build(**request)

    # ----- views --------------------------------------------------------------------------
    @property
    def model(self) -> Model:
        """The declarative model."""
        return self.compiled.model

    @property
    def initial(self) -> dict[str, float]:
        """Every state's initial value (intervals and sets at their centre)."""
        return dict(zip(self.compiled.state_names, map(float, self.x0), strict=True))

    @property
    def parameters(self) -> dict[str, float]:
        """Every parameter's value (intervals at their centre)."""
        return dict(zip(self.compiled.parameter_names, map(float, self.p0), strict=True))

    @property
    def uncertain(self) -> bool:
        """Whether some initial value or parameter is a set rather than a point."""
        return bool(self.state_box or self.param_box or self.input_box
                    or self.initial_set is not None)

    @property
    def dims(self) -> int:
        """Number of uncertain coordinates (set generators, box sides, parameters, inputs)."""
        return (self._set_dims() + len(self.state_box) + len(self.param_box)
                + len(self.input_box))

    def _set_dims(self) -> int:
        s = self.initial_set
        if s is None:
            return 0
        if hasattr(s, "generators"):
            return int(np.asarray(s.generators).shape[1])
        return len(self.compiled.state_names)

    def point(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """Map ``u`` in the unit cube of :attr:`dims` to ``(x0, p)``; ``None`` outside a
        polytope set.

        Examples
        --------
        >>> pb = HybridProblem.build("models/bouncing_ball.toml", t_end=2.0,
        ...                          initial={"h": (5.0, 10.0)})
        >>> x, p = pb.point([1.0])
        >>> float(x[0])
        10.0
        """
        u = np.asarray(u, dtype=float)
        x = self.x0.copy()
        p = self.p0.copy()
        k = 0
        s = self.initial_set
        if s is not None:
            m = self._set_dims()
            w = u[:m]
            if hasattr(s, "generators"):
                x = np.asarray(s.center, dtype=float) + np.asarray(s.generators) @ (2 * w - 1)
            else:
                lo, hi = np.asarray(s.bounds(), dtype=float).T
                x = lo + w * (hi - lo)
                if hasattr(s, "A") and not bool(np.all(s.contains_points(x[None, :]))):
                    return None
            k = m
        names = self.compiled.state_names
        for name, (lo, hi) in self.state_box.items():
            x[names.index(name)] = lo + u[k] * (hi - lo)
            k += 1
        pnames = self.compiled.parameter_names
        for box in (self.param_box, self.input_box):
            for name, (lo, hi) in box.items():
                p[pnames.index(name)] = lo + u[k] * (hi - lo)
                k += 1
        return x, p

    def arguments(self, what: str) -> dict[str, Any]:
        """This point problem as :func:`hybridlab.simulate` keyword arguments (for the
        entry points that build their own runs: sweeps and fits); ``what`` names the
        caller in the error for a problem with uncertain values.

        Examples
        --------
        >>> pb = HybridProblem.build("models/bouncing_ball.toml", t_end=2.0, params={"e": 0.8})
        >>> args = pb.arguments("sweep")
        >>> args["params"], args["t_end"], args["mode"], args["scenario"]
        ({'e': 0.8}, 2.0, 'fall', 'default')
        """
        self.require_point(what)
        return {"scenario": self.scenario, "params": dict(self.request.get("params") or {}),
                "initial": dict(self.request.get("initial") or {}), "t_end": self.t_end,
                "mode": self.mode, "t_start": self.t_start, "options": self.options}

    def require_point(self, what: str) -> None:
        """Raise :class:`ProblemError` if the problem has uncertain values (``what`` needs
        one point)."""
        if not self.uncertain:
            return
        names = [*self.state_box, *self.param_box, *self.input_box]
        if self.initial_set is not None:
            names.insert(0, "the initial set")
        raise ProblemError(f"{what} needs one point, but the problem has uncertain values "
                           f"({', '.join(names)}); give numbers, or use sweep, falsify or "
                           "reach for sets")


def _name_of(spec: Model, sc: Scenario) -> str:
    return next(name for name, s in spec.scenarios.items() if s is sc)


def _qualified(compiled: CompiledModel, values: Mapping[str, Any] | None) -> dict[str, Any]:
    """``values`` keyed by declared names: a component's name given without its qualifier
    (``T_out`` for ``room1.T_out``, where unique) becomes the qualified name."""
    return {compiled.symbolic.qualified(name): value for name, value in (values or {}).items()}


def _vector(convert: Any, values: Mapping[str, float]) -> np.ndarray:
    try:
        return np.asarray(convert(values), dtype=float)
    except ValueError as exc:  # a value the model cannot take (not finite, ...)
        raise ProblemError(str(exc)) from None


def _parameters(compiled: CompiledModel, sc: Scenario | None,
                params: Mapping[str, Any] | None, inputs: Mapping[str, Any] | None
                ) -> tuple[dict[str, float], dict[str, tuple[float, float]],
                           dict[str, tuple[float, float]]]:
    pnames = compiled.parameter_names
    fixed: dict[str, float] = _qualified(compiled, sc.parameters) if sc is not None else {}
    box: dict[str, tuple[float, float]] = {}
    params, inputs = _qualified(compiled, params), _qualified(compiled, inputs)
    for name, value in params.items():
        if name not in pnames:
            raise _unknown("params", "parameter", name, pnames)
        lo, hi = interval(value, f"params[{name!r}]")
        fixed[name] = 0.5 * (lo + hi)
        if hi > lo:
            box[name] = (lo, hi)
    bounded: dict[str, tuple[float, float]] = {}
    for name, value in inputs.items():
        if name not in pnames:
            raise _unknown("inputs", "parameter", name, pnames)
        if params and name in params:
            raise ProblemError(f"inputs: {name!r} is also given in params; give it once")
        if isinstance(value, int | float):
            raise ProblemError(f"inputs[{name!r}] must be a (lo, hi) pair (got {value!r})")
        lo, hi = interval(value, f"inputs[{name!r}]")
        fixed[name] = 0.5 * (lo + hi)
        bounded[name] = (lo, hi)
    return fixed, box, bounded


def _initial(compiled: CompiledModel, sc: Scenario | None, initial: Any
             ) -> tuple[dict[str, float], dict[str, tuple[float, float]], Any]:
    snames = compiled.state_names
    fixed: dict[str, float] = _qualified(compiled, sc.initial) if sc is not None else {}
    box: dict[str, tuple[float, float]] = {}
    if initial is None or isinstance(initial, Mapping):
        for name, value in _qualified(compiled, initial).items():
            if name not in snames:
                raise _unknown("initial", "state", name, snames)
            if isinstance(value, bool):  # the value of a bool variable, read as 0 or 1
                problem = value_problem(compiled.symbolic.discrete.get(name, "real"), value)
                if problem is not None:
                    raise ProblemError(f"initial[{name!r}]: {problem}")
                value = float(value)
            lo, hi = interval(value, f"initial[{name!r}]")
            fixed[name] = 0.5 * (lo + hi)
            if hi > lo and name in compiled.symbolic.discrete:
                raise ProblemError(f"initial[{name!r}]: a discrete variable takes one value "
                                   f"(got the interval {lo!r} to {hi!r}); run once per value")
            if hi > lo:
                box[name] = (lo, hi)
        return fixed, box, None
    if hasattr(initial, "bounds") and hasattr(initial, "contains_points"):
        bounds = np.asarray(initial.bounds(), dtype=float)
        if bounds.shape != (len(snames), 2):
            raise ProblemError(f"initial: a set must be over all {len(snames)} states "
                               f"({', '.join(snames)}); got bounds of shape {bounds.shape}")
        fixed.update(zip(snames, bounds.mean(axis=1), strict=True))
        return fixed, box, initial
    raise ProblemError(f"initial must be a mapping of state names to values or (lo, hi), or "
                       f"a Box/Zonotope/Polytope (got {type(initial).__name__})")


def _settings(sc: Scenario | None, options: SimulationOptions | None,
              overrides: Mapping[str, Any]) -> SimulationOptions:
    known = SimulationOptions.__dataclass_fields__
    unknown = sorted(set(overrides) - set(known))
    if unknown:
        raise TypeError(f"unknown option(s): {', '.join(unknown)}")
    settings = dict(overrides)
    if sc is not None:
        for name in _SCENARIO_SETTINGS:
            if settings.get(name) is None and getattr(sc, name) is not None:
                settings[name] = getattr(sc, name)
    if options is None:  # one construction (each checks every field)
        return SimulationOptions(**settings)
    return dataclasses.replace(options, **settings) if settings else options
