"""Compilation of a checked model into numeric functions, once per model."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import sympy as sp

from hybridlab.errors import ModelError
from hybridlab.model.checks import TIME, SymbolicModel, schedule_values
from hybridlab.model.discrete import value_problem
from hybridlab.model.schema import Model
from hybridlab.symbolic.discontinuities import Switch, extract_switches
from hybridlab.symbolic.functions import LazyMatrixFunction, MatrixFunction, VectorFunction
from hybridlab.symbolic.lagrange import LagrangeEquations, mode_flow, model_equations

__all__ = ["ScalarFields", "CompiledMode", "CompiledTransition", "CompiledModel", "compile_model"]


class ScalarFields:
    """Functions ``h_i(t, x)`` with their time derivative along a flow.

    ``derivative`` returns ``dh/dt = dh/dt|_x + grad_x h . f``, the Lie
    derivative, given the flow value ``f`` at the same point.

    Examples
    --------
    The bouncing ball's energy ``g h + v^2/2`` and its rate along the flow ``(v, -g)``:

    >>> from hybridlab.model.loader import load_model
    >>> sym = load_model("models/bouncing_ball.toml").symbolic
    >>> energy = ScalarFields([sym.definitions["energy"]], sym)
    >>> x, p, no_sigma = np.array([10.0, -2.0]), np.array([9.81, 0.8]), np.array([])
    >>> energy.size, energy.values(0.0, x, p, no_sigma), energy.gradient(0.0, x, p, no_sigma)
    (1, array([100.1]), array([[ 9.81, -2.  ]]))
    >>> energy.derivative(0.0, x, p, no_sigma, np.array([-2.0, -9.81]))  # conserved
    array([0.])
    """

    def __init__(self, exprs: Sequence[sp.Expr], sym: SymbolicModel,
                 sigmas: Sequence[sp.Symbol] = ()) -> None:
        exprs = list(exprs)
        args = (TIME, sym.states, sym.parameters, sigmas)
        self.size = len(exprs)
        self.values = VectorFunction(exprs, *args)
        grad = sp.Matrix([[sp.diff(e, s) for s in sym.states] for e in exprs]) if exprs else \
            sp.zeros(0, len(sym.states))
        self._dx = LazyMatrixFunction(lambda: grad, *args)  # only sliding needs the gradient
        # the Lie derivative compiled directly, with the flow value as an input: only the
        # states each function depends on cost anything
        flow = [sp.Symbol(f"_f{i}", real=True) for i in range(len(sym.states))]
        lie = [sp.diff(e, TIME) + sum(grad[i, j] * flow[j] for j in range(len(flow)))
               for i, e in enumerate(exprs)]
        self._lie = VectorFunction(lie, *args, extra=flow)

    def gradient(self, t: float, x: np.ndarray, p: np.ndarray, sigma: np.ndarray) -> np.ndarray:
        """``d h_i / d x_j`` at one point, shape ``(m, n)``."""
        return self._dx(t, x, p, sigma)

    def gradient_batch(self, t: np.ndarray, x: np.ndarray, p: np.ndarray,
                       sigma: np.ndarray) -> np.ndarray:
        """``d h_i / d x_j`` at ``k`` points, shape ``(m, n, k)``."""
        return self._dx.batch(t, x, p, sigma)

    def derivative(self, t: float, x: np.ndarray, p: np.ndarray, sigma: np.ndarray,
                   f: np.ndarray) -> np.ndarray:
        """Lie derivative at one point; ``f`` is the flow there."""
        return self._lie(t, x, p, sigma, f)

    def batch_derivative(self, t: np.ndarray, x: np.ndarray, p: np.ndarray, sigma: np.ndarray,
                         f: np.ndarray) -> np.ndarray:
        """Lie derivative at ``k`` points; ``x`` and ``f`` have shape ``(n, k)``."""
        return self._lie.batch(t, x, p, sigma, f)


@dataclass(frozen=True, eq=False)
class CompiledTransition:
    """A transition as numeric functions; see :class:`hybridlab.Transition`.

    Examples
    --------
    >>> from hybridlab.model.loader import load_model
    >>> ball = compile_model(load_model("models/bouncing_ball.toml"))
    >>> bounce = ball.transitions[0]
    >>> bounce.name, bounce.guard_texts, bounce.scheduled, bounce.order_key
    ('bounce', ('h <= 0',), False, (False, 1, 0))
    >>> p, no_sigma = ball.parameter_vector(), np.array([])
    >>> bounce.reset(0.0, np.array([0.0, -14.0]), p, no_sigma)  # v := -e*v
    array([ 0. , 11.2])

    A scheduled transition has a period and phase instead of a guard:

    >>> sample = compile_model(load_model("models/sampled_control.toml")).transitions[0]
    >>> sample.guard is None, sample.period_and_phase(np.array([2.0, 0.1]))
    (True, (0.1, 0.0))
    """

    index: int
    name: str
    source: str
    target: str
    priority: int | None
    schedule: VectorFunction | None
    guard: ScalarFields | None
    guard_texts: tuple[str, ...]
    reset: VectorFunction
    declared: int = 0

    @property
    def scheduled(self) -> bool:
        """Whether this transition fires at scheduled instants."""
        return self.schedule is not None

    def period_and_phase(self, p: np.ndarray) -> tuple[float, float] | None:
        """The schedule for parameters ``p``; ``None`` when disabled (``enabled`` is zero).

        Raises
        ------
        ModelError
            When the period is not positive and finite, or the phase not finite, for ``p``.
        """
        if self.schedule is None:
            return None
        with np.errstate(all="ignore"):
            period, phase, enabled = map(float, self.schedule(0.0, np.empty(0), p, np.empty(0)))
        problem = schedule_values(period, phase, enabled)
        if problem is not None:
            field, message = problem.split(": ", 1)
            raise ModelError(f"{message} for this run's parameters",
                             key=f"transitions[{self.declared}].schedule.{field}",
                             token=self.name)
        if enabled == 0:
            return None
        return period, phase

    @property
    def order_key(self) -> tuple[int, int, int]:
        """Firing precedence: numbered priorities first, then declaration order."""
        return (self.priority is None, self.priority or 0, self.index)


@dataclass(frozen=True, eq=False)
class CompiledMode:
    """A mode as numeric functions.

    ``flow(t, x, p, sigma)`` is smooth: the discontinuities are the
    ``switches``, whose signs ``sigma`` the simulator supplies.

    Examples
    --------
    The friction oscillator's flow ``(v, (F - k x - c sign(v) - d v)/m)`` on either side
    of its switch ``sign(v)``:

    >>> from hybridlab.model.loader import load_model
    >>> osc = compile_model(load_model("models/friction_oscillator.toml"))
    >>> move = osc.modes["move"]
    >>> [s.text for s in move.switches], move.invariant_texts, move.affine_in_sigma
    (['sign(v)'], (), True)
    >>> x, p = osc.state_vector(), osc.parameter_vector()  # x = 1, v = 0; k = 4, c = 0.5
    >>> move.flow(0.0, x, p, np.array([1.0])), move.flow(0.0, x, p, np.array([-1.0]))
    (array([ 0. , -4.5]), array([ 0. , -3.5]))
    >>> move.jacobian(0.0, x, p, np.array([1.0]))
    array([[ 0.,  1.],
           [-4., -0.]])
    """

    name: str
    switches: tuple[Switch, ...]
    flow: VectorFunction
    jacobian: MatrixFunction | LazyMatrixFunction
    flow_dsigma: MatrixFunction | None
    affine_in_sigma: bool
    switch_fields: ScalarFields
    invariants: ScalarFields
    invariant_texts: tuple[str, ...]
    outgoing: tuple[CompiledTransition, ...] = field(default=())
    #: every guard inequality of the unscheduled outgoing transitions, then every invariant,
    #: compiled as one function so the simulator evaluates them in a single call
    conditions: ScalarFields | None = None
    guard_rows: Mapping[int, slice] = field(default_factory=dict)

    @property
    def invariant_offset(self) -> int:
        """Row of the first invariant in :attr:`conditions` (after every guard row)."""
        return sum(sl.stop - sl.start for sl in self.guard_rows.values())


@dataclass(frozen=True, eq=False)
class CompiledModel:
    """Everything the simulator needs, compiled once per model.

    Obtain it with :func:`compile_model`; parameters and initial values are
    vectors supplied at call time, so overrides never recompile.

    Examples
    --------
    >>> from hybridlab.model.loader import load_model
    >>> ball = compile_model(load_model("models/bouncing_ball.toml"))
    >>> ball.state_names, ball.parameter_names, list(ball.modes)
    (('h', 'v'), ('g', 'e'), ['fall'])
    >>> ball.parameter_vector({"e": 0.5}), ball.state_vector({"h": 2.0})
    (array([9.81, 0.5 ]), array([2., 0.]))
    >>> ball.parameter_vector({"k": 1.0})
    Traceback (most recent call last):
    ...
    ValueError: unknown parameter 'k'; expected one of: g, e
    >>> compile_model(ball.model) is ball  # cached on the model
    True
    """

    model: Model
    symbolic: SymbolicModel
    modes: Mapping[str, CompiledMode]
    transitions: tuple[CompiledTransition, ...]

    @property
    def state_names(self) -> tuple[str, ...]:
        return self.symbolic.state_names

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return self.symbolic.parameter_names

    def parameter_vector(self, overrides: Mapping[str, float] | None = None) -> np.ndarray:
        """Default parameter values with ``overrides`` applied, in declaration order."""
        values = {name: p.value for name, p in self.model.parameters.items()}
        return self._vector(values, overrides, "parameter", self.parameter_names)

    def state_vector(self, overrides: Mapping[str, float] | None = None) -> np.ndarray:
        """Initial state values with ``overrides`` applied, in declaration order (the
        discrete variables last).

        Examples
        --------
        >>> from hybridlab.model import loads_model
        >>> m = compile_model(loads_model('''
        ... name = "count"
        ... states = { x = 0.0 }
        ... discrete = { n = 2, on = true }
        ... modes.m.flow.x = "n"
        ... initial.mode = "m"
        ... '''))
        >>> m.state_vector(), m.state_vector({"n": 5, "on": False})
        (array([0., 2., 1.]), array([0., 5., 0.]))
        >>> m.state_vector({"n": 1.5})
        Traceback (most recent call last):
        ...
        ValueError: state 'n': an int variable takes whole numbers (got 1.5)
        """
        values: dict[str, float] = {name: s.initial for name, s in self.model.states.items()}
        values.update({name: float(d.value) for name, d in self.model.discrete.items()})
        for given, value in (overrides or {}).items():
            name = self.symbolic.qualified(given)
            kind = self.symbolic.discrete.get(name)
            if kind is not None and (problem := value_problem(kind, value)) is not None:
                raise ValueError(f"state {name!r}: {problem}")
        return self._vector(values, overrides, "state", self.state_names)

    def _vector(self, values: dict[str, float], overrides: Mapping[str, float] | None,
                kind: str, order: tuple[str, ...]) -> np.ndarray:
        for given, value in (overrides or {}).items():
            name = self.symbolic.qualified(given)  # a unique unqualified name of a component
            if name not in values:
                known = ", ".join(order)
                raise ValueError(f"unknown {kind} {name!r}; expected one of: {known}")
            value = float(value)
            if not np.isfinite(value):
                raise ValueError(f"{kind} {name!r} must be finite (got {value!r})")
            values[name] = value
        return np.array([values[name] for name in order], dtype=float)


def _affine_in(exprs: Sequence[sp.Expr], symbols: Sequence[sp.Symbol]) -> bool:
    """Whether every second derivative in ``symbols`` is zero.

    A first derivative free of every symbol has none to differentiate, so only the others
    are differentiated again: linear, not quadratic, in the number of symbols (a signal's
    table makes one per breakpoint).

    Examples
    --------
    >>> a, b, x = sp.symbols("a b x", real=True)
    >>> _affine_in([a*x + b], [a, b]), _affine_in([a*b], [a, b])
    (True, False)
    """
    wanted = set(symbols)
    for e in exprs:
        for a in symbols:
            first = sp.diff(e, a)
            if not first.free_symbols.isdisjoint(wanted) and \
                    any(sp.diff(first, b) != 0 for b in symbols):
                return False
    return True


def _compile_mode(sym: SymbolicModel, name: str, equations: LagrangeEquations | None,
                  cache: dict) -> CompiledMode:
    """Compile one mode; modes with the same flow share its compiled functions."""
    mode = sym.modes[name]
    flow = mode_flow(sym, name, equations)
    key = ("flow", flow)
    if key not in cache:
        smooth, switches = extract_switches(flow, prefix="_sigma")
        sigmas = [s.symbol for s in switches]
        args = (TIME, sym.states, sym.parameters, sigmas)
        flow_matrix = sp.Matrix(smooth)
        cache[key] = {
            "switches": switches,
            "flow": VectorFunction(smooth, *args),
            "jacobian": LazyMatrixFunction(lambda m=flow_matrix: m.jacobian(sym.states), *args),
            "flow_dsigma": MatrixFunction(flow_matrix.jacobian(sigmas), *args) if sigmas else None,
            "affine_in_sigma": _affine_in(smooth, sigmas),
            "switch_fields": ScalarFields([s.expr for s in switches], sym, sigmas),
        }
    invariant_exprs = tuple(rel.expr for rel in mode.invariants)
    inv_key = ("invariants", invariant_exprs)
    if inv_key not in cache:
        cache[inv_key] = ScalarFields(invariant_exprs, sym)
    return CompiledMode(name=name, invariants=cache[inv_key],
                        invariant_texts=tuple(rel.text for rel in mode.invariants),
                        **cache[key])


def _compile_transition(sym: SymbolicModel, index: int, cache: dict) -> CompiledTransition:
    """Compile one transition; identical guards and resets (a transition declared for
    several modes) share their compiled functions through ``cache``."""
    tr = sym.transitions[index]
    guard_exprs = tuple(rel.expr for rel in tr.guard)
    guard_key = ("guard", guard_exprs)
    if guard_exprs and guard_key not in cache:
        cache[guard_key] = ScalarFields(guard_exprs, sym)
    reset_key = ("reset", tr.reset)
    if reset_key not in cache:
        cache[reset_key] = VectorFunction(tr.reset, TIME, sym.states, sym.parameters, ())
    return CompiledTransition(
        index=tr.index, name=tr.name, source=tr.source, target=tr.target,
        priority=tr.priority,
        schedule=(VectorFunction([tr.period, tr.phase, tr.enabled], TIME, (), sym.parameters, ())
                  if tr.period is not None else None),
        guard=cache[guard_key] if guard_exprs else None,
        guard_texts=tuple(rel.text for rel in tr.guard),
        reset=cache[reset_key],
        declared=tr.declared,
    )


def compile_model(model: Model) -> CompiledModel:
    """Compile ``model`` (or return the compiled form cached on it).

    Parameters
    ----------
    model : Model
        A checked model.

    Returns
    -------
    CompiledModel

    Examples
    --------
    >>> from hybridlab.model import loads_model
    >>> m = loads_model('''
    ... name = "decay"
    ... states = { x = 1.0 }
    ... [modes.on]
    ... flow = { x = "-x" }
    ... [initial]
    ... mode = "on"
    ... ''')
    >>> compiled = compile_model(m)
    >>> compiled.modes["on"].flow(0.0, np.array([2.0]), np.array([]), np.array([]))
    array([-2.])
    """
    if not isinstance(model, Model):
        raise TypeError(f"model must be a hybridlab.Model (got {type(model).__name__})")
    if model._compiled is not None:
        return model._compiled
    sym = model.symbolic
    if sym is None:
        raise ModelError("model has not been checked")
    cache: dict = {}
    transitions = tuple(_compile_transition(sym, i, cache) for i in range(len(sym.transitions)))
    equations = model_equations(sym)
    modes = {}
    for name in sym.modes:
        compiled = _compile_mode(sym, name, equations, cache)
        outgoing = tuple(sorted((tr for tr in transitions if tr.source == name),
                                key=lambda tr: tr.order_key))
        exprs: list[sp.Expr] = []
        guard_rows: dict[int, slice] = {}
        for tr in outgoing:
            if tr.guard is not None and not tr.scheduled:
                rels = sym.transitions[tr.index].guard
                guard_rows[tr.index] = slice(len(exprs), len(exprs) + len(rels))
                exprs.extend(rel.expr for rel in rels)
        exprs.extend(rel.expr for rel in sym.modes[name].invariants)
        cond_key = ("conditions", tuple(exprs))
        if exprs and cond_key not in cache:
            cache[cond_key] = ScalarFields(exprs, sym)
        conditions = cache[cond_key] if exprs else None
        modes[name] = CompiledMode(**{**compiled.__dict__, "outgoing": outgoing,
                                      "conditions": conditions, "guard_rows": guard_rows})
    result = CompiledModel(model=model, symbolic=sym, modes=modes, transitions=transitions)
    model._compiled = result
    return result
