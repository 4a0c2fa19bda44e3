"""Meaning checks of a model, producing its sympy form.

Every expression is parsed here with the whitelist parser; the first problem
raises :class:`~hybridlab.errors.ModelError` naming the key path and token.
"""

from __future__ import annotations

import graphlib
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import sympy as sp

from hybridlab.errors import ExpressionError, ModelError
from hybridlab.model.discrete import value_problem, written
from hybridlab.model.expressions import (
    MAX_TREE_NODES,
    Inequality,
    check_qualified_name,
    parse_expression,
    parse_relation,
    tree_size,
)
from hybridlab.model.names import aliases as unqualified_aliases
from hybridlab.model.names import match_modes, mode_target
from hybridlab.model.signals import check_table, lower_table, read_csv_table

if TYPE_CHECKING:
    from hybridlab.model.schema import Model

__all__ = [
    "SymbolicMechanics",
    "SymbolicMode",
    "SymbolicTransition",
    "SymbolicModel",
    "build_symbolic",
    "TIME",
]

#: The reserved time symbol.
TIME = sp.Symbol("t", real=True)


@dataclass(frozen=True)
class SymbolicMechanics:
    """The ``[mechanics]`` section in sympy form (indices are state positions).

    Examples
    --------
    >>> from hybridlab.model.loader import loads_model
    >>> pendulum = loads_model('''
    ... name = "pendulum"
    ... parameters = { m = 1.0, l = 0.5, g = 9.81, b = 0.1 }
    ... states = { phi = 0.1, omega = 0.0 }
    ... modes.swing = {}
    ... initial.mode = "swing"
    ... [mechanics]
    ... coordinates = ["phi"]
    ... velocities = ["omega"]
    ... kinetic = "m*l**2*omega**2/2"
    ... potential = "-m*g*l*cos(phi)"
    ... forces = { phi = "-b*omega" }
    ... ''')
    >>> mech = pendulum.symbolic.mechanics
    >>> mech.coordinates, mech.velocities, mech.kinetic, mech.potential
    ((0,), (1,), l**2*m*omega**2/2, -g*l*m*cos(phi))
    >>> pendulum.symbolic.modes["swing"].flow  # derived from the energies when compiled
    (None, None)
    """

    coordinates: tuple[int, ...]
    velocities: tuple[int, ...]
    kinetic: sp.Expr
    potential: sp.Expr


@dataclass(frozen=True)
class SymbolicMode:
    """A mode in sympy form.

    ``flow[i]`` is the derivative of state ``i``, or ``None`` where the
    ``[mechanics]`` section derives it; ``forces[k]`` is the generalised force
    on coordinate ``k`` in this mode.

    Examples
    --------
    >>> from hybridlab.model.loader import load_model
    >>> fall = load_model("models/bouncing_ball.toml").symbolic.modes["fall"]
    >>> fall.name, fall.flow, [rel.text for rel in fall.invariants]
    ('fall', (v, -g), ['h >= 0'])

    A mode-local definition is substituted by :meth:`scoped`:

    >>> from hybridlab.model.loader import loads_model
    >>> sym = loads_model('''
    ... name = "tank"
    ... parameters = { q = 0.5 }
    ... states = { h = 1.0 }
    ... modes.fill = { flow = { h = "q - out" }, definitions = { out = "0.1*h" } }
    ... modes.drain = { flow = { h = "-out" }, definitions = { out = "0.3*h" } }
    ... initial.mode = "fill"
    ... ''').symbolic
    >>> sym.modes["fill"].flow, sym.modes["drain"].local
    ((-0.1*h + q,), {'out': 0.3*h})
    >>> sym.modes["drain"].scoped(2 * sym.namespace()["out"], sym.local_names)
    0.6*h
    """

    name: str
    flow: tuple[sp.Expr | None, ...]
    invariants: tuple[Inequality, ...]
    forces: tuple[sp.Expr, ...] = ()
    local: Mapping[str, sp.Expr] = field(default_factory=dict)

    def scoped(self, expr: sp.Expr, all_local: frozenset[str]) -> sp.Expr:
        """``expr`` with this mode's local definitions substituted.

        Raises
        ------
        ModelError
            If ``expr`` uses a local definition this mode does not have.
        """
        return _ModeScope(self.name, dict(self.local), set(all_local)).apply(expr, "")


@dataclass(frozen=True)
class SymbolicTransition:
    """A transition in sympy form; ``reset[i]`` is the new value of state ``i``.

    Examples
    --------
    >>> from hybridlab.model.loader import load_model
    >>> bounce = load_model("models/bouncing_ball.toml").symbolic.transitions[0]
    >>> bounce.name, bounce.source, bounce.target, bounce.reset, bounce.priority
    ('bounce', 'fall', 'fall', (h, -e*v), 1)
    >>> bounce.guard[0].text, bounce.guard[0].expr  # a guard holds where expr >= 0
    ('h <= 0', -h)
    >>> load_model("models/sampled_control.toml").symbolic.transitions[0].period
    T
    """

    index: int
    name: str
    source: str
    target: str
    guard: tuple[Inequality, ...]
    reset: tuple[sp.Expr, ...]
    priority: int | None
    period: sp.Expr | None
    phase: sp.Expr
    declared: int = 0
    enabled: sp.Expr = sp.Integer(1)


@dataclass(frozen=True)
class SymbolicModel:
    """The sympy form of a :class:`~hybridlab.model.schema.Model`.

    Definitions and input signals (:attr:`signals`) are substituted everywhere, so every
    expression is over states, parameters and ``t`` only. The discrete variables come last among the
    states, each with the flow 0 in every mode; :attr:`discrete` gives their types.

    Examples
    --------
    >>> from hybridlab.model.loader import load_model
    >>> sym = load_model("models/bouncing_ball.toml").symbolic
    >>> sym.state_names, sym.parameters, sym.definitions
    (('h', 'v'), (g, e), {'energy': g*h + 0.5*v**2})
    >>> list(sym.modes), len(sym.transitions), sym.mechanics is None
    (['fall'], 1, True)
    >>> sym.namespace()["energy"].diff(sym.states[1])
    1.0*v
    """

    state_names: tuple[str, ...]
    parameter_names: tuple[str, ...]
    states: tuple[sp.Symbol, ...]
    parameters: tuple[sp.Symbol, ...]
    definitions: Mapping[str, sp.Expr]
    modes: Mapping[str, SymbolicMode]
    transitions: tuple[SymbolicTransition, ...]
    mechanics: SymbolicMechanics | None = None
    local_names: frozenset[str] = frozenset()
    aliases: Mapping[str, str] = field(default_factory=dict)
    discrete: Mapping[str, str] = field(default_factory=dict)
    signals: Mapping[str, sp.Expr] = field(default_factory=dict)

    @property
    def continuous(self) -> int:
        """How many states are integrated (the first ones; the discrete variables follow).

        Examples
        --------
        >>> from hybridlab.model.loader import loads_model
        >>> sym = loads_model('''
        ... name = "counter"
        ... states = { x = 0.0 }
        ... discrete = { count = 0, armed = false }
        ... modes.m.flow.x = "1"
        ... initial.mode = "m"
        ... [[transitions]]
        ... name = "tick"
        ... source = "m"
        ... target = "m"
        ... guard = "x >= 1"
        ... reset = { x = "0", count = "count + 1" }
        ... ''').symbolic
        >>> sym.state_names, sym.continuous, sym.discrete
        (('x', 'count', 'armed'), 1, {'count': 'int', 'armed': 'bool'})
        >>> sym.modes["m"].flow
        (1, 0, 0)
        """
        return len(self.state_names) - len(self.discrete)

    @property
    def time(self) -> sp.Symbol:
        """The time symbol ``t``."""
        return TIME

    def namespace(self) -> dict[str, sp.Expr]:
        """Every name an expression may use, mapped to its sympy form.

        Mode-local definitions appear as placeholders; substitute them with
        :meth:`SymbolicMode.scoped`.
        """
        names: dict[str, sp.Expr] = {"t": TIME}
        names.update(zip(self.parameter_names, self.parameters, strict=True))
        names.update(zip(self.state_names, self.states, strict=True))
        names.update(self.signals)
        names.update({n: _local_symbol(n) for n in self.local_names})
        names.update(self.definitions)
        names.update({alias: names[full] for alias, full in self.aliases.items()})
        return names

    def qualified(self, name: str) -> str:
        """The declared name ``name`` stands for: itself, or the qualified name of which
        it is the unique unqualified spelling (:func:`hybridlab.model.names.aliases`).

        Examples
        --------
        >>> from hybridlab.model.loader import load_model
        >>> sym = load_model("models/two_rooms.toml").symbolic
        >>> sym.qualified("on_time"), sym.qualified("room1.T"), sym.qualified("T")
        ('heater.on_time', 'room1.T', 'T')
        """
        return self.aliases.get(name, name)


def _fail(message: str, key: str, token: str = "") -> ModelError:
    return ModelError(message, key=key, token=token)


def _parse(text: str, names: Mapping[str, sp.Expr], key: str) -> sp.Expr:
    try:
        return parse_expression(text, names)
    except ExpressionError as exc:
        raise _fail(exc.message, key, exc.token) from None


def _relations(text: str, names: Mapping[str, sp.Expr], key: str,
               flags: frozenset[sp.Symbol] = frozenset()) -> tuple[Inequality, ...]:
    try:
        return tuple(parse_relation(text, names, flags=flags))
    except ExpressionError as exc:
        raise _fail(exc.message, key, exc.token) from None


def _declared_names(model: Model) -> set[str]:
    """Check every declared name; return the names of mode-local definitions."""
    seen: dict[str, str] = {}
    for section in ("parameters", "states", "discrete", "signals", "definitions"):
        for name in getattr(model, section):
            try:
                check_qualified_name(name)
            except ExpressionError as exc:
                raise _fail(exc.message, f"{section}.{name}", exc.token) from None
            if name in seen:
                raise _fail(f"name already declared in [{seen[name]}]", f"{section}.{name}", name)
            seen[name] = section
    local: set[str] = set()
    for mode_name, mode in model.modes.items():
        for name in mode.definitions:
            key = f"modes.{mode_name}.definitions.{name}"
            try:
                check_qualified_name(name)
            except ExpressionError as exc:
                raise _fail(exc.message, key, exc.token) from None
            if name in seen:
                raise _fail(f"name already declared in [{seen[name]}]", key, name)
            local.add(name)
    return local


def _definitions(texts: Mapping[str, str], base: dict[str, sp.Expr],
                 prefix: str, aliases: Mapping[str, str] | None = None) -> dict[str, sp.Expr]:
    """Parse definitions in dependency order; a cycle is an error."""
    placeholders = {name: sp.Symbol(f"_def_{name}", real=True) for name in texts}
    names = {**base, **placeholders}
    names.update({alias: placeholders[full] for alias, full in (aliases or {}).items()
                  if full in placeholders})
    uses: dict[str, list[str]] = {}
    raw: dict[str, sp.Expr] = {}
    for name, text in texts.items():
        expr = _parse(text, names, f"{prefix}.{name}")
        raw[name] = expr
        uses[name] = [other for other, symbol in placeholders.items() if expr.has(symbol)]
    try:
        order = list(graphlib.TopologicalSorter(uses).static_order())
    except graphlib.CycleError as exc:
        cycle = exc.args[1]  # each name used by the next; the first name again at the end
        raise _fail("definitions refer to each other in a cycle", f"{prefix}.{cycle[1]}",
                    " -> ".join(cycle)) from None
    resolved: dict[str, sp.Expr] = {}
    sizes: dict[sp.Basic, float] = {}
    for name in order:
        resolved[name] = raw[name].xreplace({placeholders[k]: v for k, v in resolved.items()})
        size = tree_size(resolved[name], sizes)
        if size > MAX_TREE_NODES:
            raise _fail(f"definition too large: {size:.3g} operations with the definitions it "
                        f"uses substituted (at most {MAX_TREE_NODES}); use fewer nested "
                        "definitions", f"{prefix}.{name}", name)
    return {name: resolved[name] for name in texts}


def _signals(model: Model, names: Mapping[str, sp.Expr]) -> dict[str, sp.Expr]:
    """Each input signal as an expression in ``t`` (and the parameters, for ``expr``)."""
    out: dict[str, sp.Expr] = {}
    for name, signal in model.signals.items():
        key = f"signals.{name}"
        given = [f for f in ("table", "file", "expr") if getattr(signal, f) is not None]
        if len(given) != 1:
            raise _fail("a signal needs exactly one of table, file, expr", key,
                        ", ".join(given) or name)
        if signal.expr is not None:
            out[name] = _parse(signal.expr, names, f"{key}.expr")
            continue
        rows = (signal.table if signal.table is not None
                else read_csv_table(Path(signal.file or ""), f"{key}.file"))
        problem = check_table(rows)  # a file's rows are checked as it is read
        if problem is not None:
            raise _fail(problem, f"{key}.table", name)
        out[name] = lower_table(rows, signal.interpolation, TIME)
    return out


def _schedule_value(value: float | str, parameters: Mapping[str, sp.Expr], key: str) -> sp.Expr:
    if isinstance(value, int | float):
        return sp.Float(value)
    return _parse(value, parameters, key)


def schedule_values(period: float, phase: float, enabled: float) -> str | None:
    """What is wrong with a schedule's values for one run, or ``None`` (also when disabled).

    The one rule for every reader of schedules: disabled when ``enabled`` is zero, else the
    period must be positive and finite and the phase finite.

    Examples
    --------
    >>> schedule_values(0.1, 0.0, 1.0) is None, schedule_values(0.0, 0.0, 0.0) is None
    (True, True)
    >>> schedule_values(float("inf"), 0.0, 1.0)
    'period: must be positive and finite (got inf)'
    """
    def got(value: float) -> str:
        return "an infinite or undefined value" if math.isnan(value) else repr(value)

    if enabled == 0:
        return None
    if not math.isfinite(enabled):
        return f"enabled: must be finite (got {got(enabled)})"
    if not (math.isfinite(period) and period > 0):
        return f"period: must be positive and finite (got {got(period)})"
    if not math.isfinite(phase):
        return f"phase: must be finite (got {got(phase)})"
    return None


def schedule_problem(period: sp.Expr, phase: sp.Expr, enabled: sp.Expr,
                     values: Mapping[sp.Symbol, sp.Expr], key: str,
                     texts: Mapping[str, object]) -> None:
    """Raise :class:`ModelError` when a schedule is invalid for the parameter ``values``."""
    numbers = []
    for expr in (period, phase, enabled):
        value = expr.xreplace(values)
        try:
            numbers.append(float(value) if value.is_real is not False else math.nan)
        except TypeError:  # not a number: a complex or undefined value
            numbers.append(math.nan)
    problem = schedule_values(*numbers)
    if problem is not None:
        field, message = problem.split(": ", 1)
        raise _fail(f"{message} with the parameters' values", f"{key}.{field}",
                    str(texts[field]))


def _local_symbol(name: str) -> sp.Symbol:
    return sp.Symbol(f"_local_{name}", real=True)


class _ModeScope:
    """Substitutes a mode's local definitions; a missing one is an error."""

    def __init__(self, mode_name: str, local: dict[str, sp.Expr], all_local: set[str],
                 flags: frozenset[sp.Symbol] = frozenset()) -> None:
        self.mode_name = mode_name
        self.flags = flags
        self.mapping = {_local_symbol(n): e for n, e in local.items()}
        self.missing = {_local_symbol(n): n for n in all_local if n not in local}

    def relations(self, texts: list[str], names: Mapping[str, sp.Expr],
                  key: str) -> tuple[Inequality, ...]:
        """Parse a list of relation texts (``key[i]``) in this mode's scope."""
        out: list[Inequality] = []
        for i, text in enumerate(texts):
            k = f"{key}[{i}]"
            out.extend(Inequality(self.apply(r.expr, k), r.strict, r.text)
                       for r in _relations(text, names, k, self.flags))
        return tuple(out)

    def apply(self, expr: sp.Expr, key: str) -> sp.Expr:
        expr = expr.xreplace(self.mapping)
        for symbol, name in self.missing.items():
            if expr.has(symbol):
                raise _fail(f"{name!r} is defined in other modes but not in mode "
                            f"{self.mode_name!r}", key, name)
        return expr


def _mechanics(model: Model, names: Mapping[str, sp.Expr]) -> SymbolicMechanics | None:
    mech = model.mechanics
    if mech is None:
        return None
    state_names = list(model.states)
    for role in ("coordinates", "velocities"):
        for i, name in enumerate(getattr(mech, role)):
            if name not in model.states:
                raise _fail(f"mechanics {role} must be declared states", f"mechanics.{role}[{i}]",
                            name)
    if len(mech.coordinates) != len(mech.velocities):
        raise _fail("mechanics needs one velocity per coordinate", "mechanics.velocities",
                    str(len(mech.velocities)))
    if not mech.coordinates:
        raise _fail("mechanics needs at least one coordinate", "mechanics.coordinates")
    all_names = [*mech.coordinates, *mech.velocities]
    duplicate = next((n for n in all_names if all_names.count(n) > 1), None)
    if duplicate:
        raise _fail("a state is used twice in mechanics", "mechanics", duplicate)
    for coordinate in mech.forces:
        if coordinate not in mech.coordinates:
            raise _fail("force on an unknown coordinate", f"mechanics.forces.{coordinate}",
                        coordinate)
    global_names = {k: v for k, v in names.items() if not str(k).startswith("_")}
    kinetic = _parse(mech.kinetic, global_names, "mechanics.kinetic")
    potential = _parse(mech.potential, global_names, "mechanics.potential")
    for key, expr in (("mechanics.kinetic", kinetic), ("mechanics.potential", potential)):
        local = sorted(str(s)[len("_local_"):] for s in expr.free_symbols
                       if str(s).startswith("_local_"))
        if local:
            raise _fail("the energies cannot depend on mode-local definitions (use them in "
                        "mechanics.forces)", key, local[0])
    return SymbolicMechanics(
        coordinates=tuple(state_names.index(n) for n in mech.coordinates),
        velocities=tuple(state_names.index(n) for n in mech.velocities),
        kinetic=kinetic, potential=potential,
    )


def build_symbolic(model: Model) -> SymbolicModel:
    """Check the meaning of ``model`` and return its sympy form.

    Raises
    ------
    ModelError
        The first problem found, with key path and token.

    Examples
    --------
    A :class:`~hybridlab.model.schema.Model` runs it when validated and keeps the result
    as ``model.symbolic``:

    >>> from hybridlab.model.loader import load_model
    >>> ball = load_model("models/bouncing_ball.toml")
    >>> sym = build_symbolic(ball)
    >>> sym == ball.symbolic, sym.modes["fall"].flow
    (True, (v, -g))
    """
    all_local = _declared_names(model)
    kinds = _discrete_kinds(model)
    state_names = (*model.states, *model.discrete)
    parameter_names = tuple(model.parameters)
    states = tuple(sp.Symbol(n, real=True) for n in state_names)
    parameters = tuple(sp.Symbol(n, real=True) for n in parameter_names)
    base: dict[str, sp.Expr] = {"t": TIME}
    base.update(zip(parameter_names, parameters, strict=True))
    base.update(zip(state_names, states, strict=True))
    signals = _signals(model, {"t": TIME, **dict(zip(parameter_names, parameters, strict=True))})
    base_with_local = {**base, **signals, **{n: _local_symbol(n) for n in all_local}}
    aliases = unqualified_aliases([*parameter_names, *state_names, *model.definitions,
                                   *sorted(all_local)])
    flags = frozenset(base[n] for n, kind in kinds.items() if kind == "bool")
    integers = {base[n]: sp.Symbol(n, integer=True) for n, kind in kinds.items()
                if kind != "real"}
    base_with_local.update({alias: base_with_local[full] for alias, full in aliases.items()
                            if full in base_with_local})
    definitions = _definitions(model.definitions, base_with_local, "definitions", aliases)
    names = {**base_with_local, **definitions}
    names.update({alias: definitions[full] for alias, full in aliases.items()
                  if full in definitions})
    if not state_names:
        raise _fail("a model needs at least one state", "states")
    if not model.modes:
        raise _fail("a model needs at least one mode", "modes")
    mechanics = _mechanics(model, {**base, **definitions})
    mech_states = set()
    if model.mechanics is not None:
        mech_states = {*model.mechanics.coordinates, *model.mechanics.velocities}
    force_texts = model.mechanics.forces if model.mechanics else {}

    modes: dict[str, SymbolicMode] = {}
    scopes: dict[str, _ModeScope] = {}
    for mode_name, mode in model.modes.items():
        key = f"modes.{mode_name}"
        if mode_name in ("*", ""):
            raise _fail("'*' stands for every mode in a transition; a mode may not be named "
                        "'*' or ''", "modes", mode_name)
        local = _definitions(mode.definitions, names, f"{key}.definitions")
        scope = _ModeScope(mode_name, local, all_local, flags)
        scopes[mode_name] = scope
        for state in mode.flow:
            if state in kinds:
                raise _fail("a discrete variable has no flow: it changes only in resets",
                            f"{key}.flow.{state}", state)
            if state not in model.states:
                raise _fail("flow given for an unknown state", f"{key}.flow.{state}", state)
        missing = [s for s in model.states if s not in mode.flow and s not in mech_states
                   and model.states[s].flow is None]
        if missing:
            raise _fail(f"state {missing[0]!r} has no flow in mode {mode_name!r}",
                        f"{key}.flow", missing[0])
        flow_texts = {s: (mode.flow[s], f"{key}.flow.{s}") for s in mode.flow}
        for s in model.states:
            if (s not in flow_texts and s not in mech_states
                    and (state_flow := model.states[s].flow) is not None):
                flow_texts[s] = (state_flow, f"states.{s}.flow")
        flow = tuple(
            scope.apply(_parse(flow_texts[s][0], names, flow_texts[s][1]), flow_texts[s][1])
            if s in flow_texts else None
            for s in model.states
        ) + (sp.Integer(0),) * len(kinds)
        invariants = scope.relations(mode.invariant, names, f"{key}.invariant")
        forces = tuple(
            scope.apply(_parse(force_texts[c], names, f"mechanics.forces.{c}"),
                        f"mechanics.forces.{c}") if c in force_texts else sp.Integer(0)
            for c in (model.mechanics.coordinates if model.mechanics else ())
        )
        modes[mode_name] = SymbolicMode(mode_name, flow, invariants, forces, local)

    transitions: list[SymbolicTransition] = []
    seen_names: set[str] = set()
    parameter_names_map = dict(zip(parameter_names, parameters, strict=True))
    for declared, tr in enumerate(model.transitions):
        key = f"transitions[{declared}]"
        if tr.name in seen_names:
            raise _fail("transition name used twice", f"{key}.name", tr.name)
        seen_names.add(tr.name)
        patterns = list(model.modes) if tr.source == "*" else (
            [tr.source] if isinstance(tr.source, str) else list(tr.source))
        if not patterns:
            raise _fail("a transition needs at least one source mode", f"{key}.source")
        sources: list[str] = []
        for i, pattern in enumerate(patterns):
            matched = match_modes(pattern, list(model.modes))
            if not matched:
                where = f"{key}.source" if isinstance(tr.source, str) else f"{key}.source[{i}]"
                raise _fail("transition source is not a mode", where, pattern)
            sources.extend(m for m in matched if m not in sources)
        for source in sources:
            if mode_target(source, tr.target) not in model.modes:
                raise _fail("transition target is not a mode", f"{key}.target", tr.target)
        if not tr.guard and tr.schedule is None:
            raise _fail("a transition needs a guard or a schedule", f"{key}.guard", tr.name)
        for state in tr.reset:
            if state not in model.states and state not in kinds:
                raise _fail("reset of an unknown state", f"{key}.reset.{state}", state)
        period = phase = None
        enabled: sp.Expr = sp.Integer(1)
        if tr.schedule is not None:
            period, phase, enabled = (
                _schedule_value(value, parameter_names_map, f"{key}.schedule.{field}")
                for field, value in (("period", tr.schedule.period),
                                     ("phase", tr.schedule.phase),
                                     ("enabled", tr.schedule.enabled)))
            defaults = {parameter_names_map[n]: sp.Float(f.value)
                        for n, f in model.parameters.items()}
            schedule_problem(period, phase, enabled, defaults, f"{key}.schedule",
                             dict(tr.schedule))
        for source in sources:
            scope = scopes[source]
            guard = scope.relations(tr.guard, names, f"{key}.guard")
            reset = tuple(
                scope.apply(_parse(tr.reset[s], names, f"{key}.reset.{s}"), f"{key}.reset.{s}")
                if s in tr.reset else sym
                for s, sym in zip(state_names, states, strict=True)
            )
            for s, expr in zip(state_names, reset, strict=True):
                if s in tr.reset and s in kinds:
                    _check_reset(kinds[s], expr, integers, f"{key}.reset.{s}", tr.reset[s])
            transitions.append(SymbolicTransition(
                index=len(transitions), name=tr.name, source=source,
                target=mode_target(source, tr.target),
                guard=guard, reset=reset, priority=tr.priority,
                period=period, phase=phase if phase is not None else sp.Integer(0),
                enabled=enabled,
                declared=declared,
            ))

    if model.initial.mode not in model.modes:
        raise _fail("initial mode is not a mode", "initial.mode", model.initial.mode)
    for scenario_name, scenario in model.scenarios.items():
        key = f"scenarios.{scenario_name}"
        for p in scenario.parameters:
            if aliases.get(p, p) not in model.parameters:
                raise _fail("unknown parameter", f"{key}.parameters.{p}", p)
        for s, value in scenario.initial.items():
            name = aliases.get(s, s)
            if name not in model.states and name not in kinds:
                raise _fail("unknown state", f"{key}.initial.{s}", s)
            problem = value_problem(kinds.get(name, "real"), value)
            if problem is not None:
                raise _fail(problem, f"{key}.initial.{s}", written(value))
        if scenario.mode is not None and len(match_modes(scenario.mode, list(model.modes))) != 1:
            raise _fail("scenario mode is not a mode", f"{key}.mode", scenario.mode)
        if scenario.t_end <= scenario.t_start:
            raise _fail("t_end must be greater than t_start", f"{key}.t_end",
                        str(scenario.t_end))

    return SymbolicModel(
        state_names=state_names,
        parameter_names=parameter_names,
        states=states,
        parameters=parameters,
        definitions=definitions,
        modes=modes,
        transitions=tuple(transitions),
        mechanics=mechanics,
        local_names=frozenset(all_local),
        aliases=aliases,
        discrete=kinds,
        signals=signals,
    )


def _discrete_kinds(model: Model) -> dict[str, str]:
    """Each discrete variable's type, its value checked against it."""
    for name, var in model.discrete.items():
        problem = value_problem(var.type, var.value)
        if problem is not None:
            raise _fail(problem, f"discrete.{name}.value", written(var.value))
    return {name: var.type for name, var in model.discrete.items()}


def _check_reset(kind: str, expr: sp.Expr, integers: Mapping[sp.Symbol, sp.Symbol], key: str,
                 text: str) -> None:
    """Refuse a reset of a bool or int variable whose value is known not to fit: a number
    that does not, or an expression that can never be a whole number. Other values are
    checked when the jump happens (:mod:`hybridlab.model.discrete`)."""
    if kind == "real":
        return
    problem = None
    if expr.is_number:
        if expr.is_real:
            problem = value_problem(kind, float(expr))
    elif expr.xreplace(integers).is_integer is False:
        problem = f"this reset never gives a whole number, as the {kind} variable needs"
    if problem is not None:
        raise _fail(problem, key, text)
