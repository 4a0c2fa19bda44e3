"""Declarative model objects: frozen pydantic v2 models that reject unknown keys.

A model file is a serialisation of :class:`Model`; the same object can be
built from Python. Structure is validated by pydantic; meaning (symbols,
references, relations) by :mod:`hybridlab.model.checks`, which runs as the
last validation step, so an invalid model object cannot exist.
"""

from __future__ import annotations

import numbers
from collections.abc import Mapping
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    GetJsonSchemaHandler,
    PrivateAttr,
    Strict,
    model_validator,
)
from pydantic.json_schema import JsonSchemaValue
from pydantic_core import CoreSchema, PydanticCustomError

__all__ = [
    "Parameter",
    "State",
    "Discrete",
    "Signal",
    "Mode",
    "Schedule",
    "Transition",
    "Initial",
    "Scenario",
    "Mechanics",
    "Model",
]


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False,
                              validate_default=True)

    def updated_copy(self, **changes: Any) -> Any:
        """Return a validated copy with ``changes`` applied (models are immutable)."""
        data = self.model_dump(round_trip=True)
        data.update(changes)
        return type(self).model_validate(data)


def _number_as(key: str) -> BeforeValidator:
    """Accept the TOML shorthand ``g = 9.81`` for ``g = { value = 9.81 }``."""

    def convert(value: Any) -> Any:
        if isinstance(value, int | float) and not isinstance(value, bool):
            return {key: value}
        return value

    return BeforeValidator(convert)


def _one_as_list(value: Any) -> Any:
    return [value] if isinstance(value, str) else value


class _Shorthand:
    """Publish ``anyOf: [shorthand, full form]`` in the JSON schema of a field.

    The validators accept a shorthand (``g = 9.81``, ``guard = "h <= 0"``) and turn it
    into the full form, so the validated object always holds the full form; this adds
    the shorthand to the published schema, which describes files as written.
    """

    def __init__(self, shorthand: JsonSchemaValue) -> None:
        self.shorthand = shorthand

    def __get_pydantic_json_schema__(
        self, core_schema: CoreSchema, handler: GetJsonSchemaHandler
    ) -> JsonSchemaValue:
        return {"anyOf": [self.shorthand, handler(core_schema)]}


def _plain_real(value: Any) -> Any:
    """Numbers that are no ``int``/``float`` (numpy scalars) as ``float``; booleans stay
    booleans, so the strict number types below refuse them (``true`` is no number)."""
    if isinstance(value, numbers.Real) and not isinstance(value, bool | int | float):
        try:
            return float(value)
        except (OverflowError, ValueError):
            return value
    return value


def _no_bool_or_text(value: Any) -> Any:
    """Refuse what the JSON schema's ``integer`` refuses but lax ``int`` would convert."""
    if isinstance(value, bool | str | bytes):
        raise PydanticCustomError("int_type", "Input should be a valid integer")
    return value


#: A number: int or float, never a boolean or a numeric string (as in the JSON schema).
Number = Annotated[float, Strict(), BeforeValidator(_plain_real)]
#: A value of a state or discrete variable as written: a number, or ``true``/``false``
#: (a boolean variable's value; it reads as 1 or 0).
Value = Number | Annotated[bool, Strict()]
PositiveNumber = Annotated[float, Strict(), Field(gt=0), BeforeValidator(_plain_real)]
#: An integer (a float with no fractional part is accepted, as JSON schema does).
Integer = Annotated[int, BeforeValidator(_no_bool_or_text)]
_EXPRESSION_SCHEMA: JsonSchemaValue = {"type": "string", "minLength": 1, "maxLength": 10_000}
Expression = Annotated[str, Field(min_length=1, max_length=10_000)]
#: One relation or a list of them; always a list once validated.
Relations = Annotated[list[Expression], BeforeValidator(_one_as_list),
                      _Shorthand(_EXPRESSION_SCHEMA)]


def _booleans_as_text(value: Any) -> Any:
    """``reset = { armed = true }``: a boolean written as a TOML value is ``"1"``/``"0"``."""
    if isinstance(value, Mapping):
        return {k: ("1" if v else "0") if isinstance(v, bool) else v for k, v in value.items()}
    return value


#: New values of a transition: expressions, or ``true``/``false`` for a boolean variable.
Resets = Annotated[dict[str, Expression], BeforeValidator(_booleans_as_text),
                   _Shorthand({"type": "object", "additionalProperties": {
                       "anyOf": [_EXPRESSION_SCHEMA, {"type": "boolean"}]}})]


class Parameter(_Frozen):
    """A named constant of the model; scenarios and calls may override it.

    Examples
    --------
    >>> Parameter(value=0.8, unit="1", description="coefficient of restitution").value
    0.8
    """

    value: Number
    unit: str = "1"
    description: str = ""


class State(_Frozen):
    """A continuous state with its initial value.

    ``flow`` is the default derivative, used by every mode that gives none
    (a clock ``"1"``, a held value ``"0"``).

    Examples
    --------
    >>> State(initial=10.0, unit="m").initial
    10.0
    """

    initial: Number
    unit: str = "1"
    flow: Expression | None = None
    description: str = ""


#: The types of discrete variables.
DiscreteType = Literal["bool", "int", "real"]


def _discrete_shorthand(value: Any) -> Any:
    """``count = 0`` / ``armed = false`` / ``level = 0.5`` for the full table, the type
    taken from the TOML value (integer, boolean, float)."""
    if isinstance(value, bool | int | float):
        value = {"value": value}
    if isinstance(value, Mapping) and "type" not in value and "value" in value:
        given = value["value"]
        kind = ("bool" if isinstance(given, bool) else "int" if isinstance(given, int)
                else "real")
        value = {**value, "type": kind}
    return value


def _type_optional(schema: dict[str, Any]) -> None:
    """In files ``type`` may be left out (the value's type is taken)."""
    schema["required"] = [key for key in schema.get("required", []) if key != "type"]


class Discrete(_Frozen):
    """A discrete variable: changed only by resets, never integrated.

    ``type`` is ``"bool"`` (the values 0 and 1, written ``false``/``true``),
    ``"int"`` or ``"real"``; a file may leave it out and let the value say
    (``count = 0`` is an integer, ``armed = false`` a boolean, ``level = 0.5`` a
    real). Whether the value fits the type is checked with the model.

    Examples
    --------
    >>> Discrete(value=3, type="int").value
    3
    >>> Discrete.model_validate(False).type, Discrete.model_validate(0.5).type
    ('bool', 'real')
    """

    model_config = ConfigDict(json_schema_extra=_type_optional)

    value: Number | Annotated[int, Strict()] | Annotated[bool, Strict()]
    type: DiscreteType = Field(description="bool, int or real; by default the type of the value "
                                           "as written (true/false, 3, 0.5)")
    unit: str = "1"
    description: str = ""

    @model_validator(mode="before")
    @classmethod
    def _shorthand(cls, value: Any) -> Any:
        return _discrete_shorthand(value)


class Signal(_Frozen):
    """An input signal: a table over time or an explicit function of time.

    Give exactly one of ``table`` (rows ``[t, value]``, times strictly increasing),
    ``file`` (a CSV file of such rows, relative to the model file; to the current folder
    for a model built in Python) or ``expr`` (an expression in ``t`` and the
    parameters). A table is interpolated linearly or holds the previous value
    (``interpolation = "previous"``); before its first row and after its last the end
    values hold. Flows, guards, invariants and resets use the signal's
    name like a definition (:mod:`hybridlab.model.signals`).

    Examples
    --------
    >>> Signal(table=[[0, 0.0], [1, 2.5]]).interpolation
    'linear'
    >>> Signal(expr="0.5*sin(2*t)").table is None
    True
    """

    table: list[Annotated[list[Number], Field(min_length=2, max_length=2)]] | None = None
    file: Annotated[str, Field(min_length=1)] | None = None
    expr: Expression | None = None
    interpolation: Literal["linear", "previous"] = "linear"
    unit: str = "1"
    description: str = ""


class Mode(_Frozen):
    """A discrete mode: a flow expression for every state, and invariants.

    States that a ``[mechanics]`` section governs need no flow here (a flow
    given here overrides the derived one in this mode). ``definitions`` are
    local to the mode: global definitions, mechanics forces, this mode's
    flows, invariants and the guards and resets of transitions leaving it may
    use them.

    Examples
    --------
    >>> Mode(flow={"h": "v", "v": "-g"}, invariant="h >= 0").invariant
    ['h >= 0']
    """

    flow: dict[str, Expression] = Field(default_factory=dict)
    invariant: Relations = Field(default_factory=list)
    definitions: dict[str, Expression] = Field(default_factory=dict)
    description: str = ""


class Mechanics(_Frozen):
    """A mechanical system whose flow hybridlab derives with Lagrange's equations.

    With generalised coordinates ``q`` and their velocities ``u`` (both
    declared states), ``L = kinetic - potential`` and the generalised
    non-conservative forces ``Q``, the flow is ``q' = u`` and ``u'`` solves
    ``d/dt(dL/du) - dL/dq = Q``. Forces may contain ``sign(...)`` (friction);
    they become switching surfaces like any discontinuous flow.

    Examples
    --------
    >>> Mechanics(coordinates=["phi"], velocities=["omega"], kinetic="J*omega**2/2",
    ...           potential="-m*g*l*cos(phi)", forces={"phi": "-b*omega"}).coordinates
    ['phi']
    """

    coordinates: list[str]
    velocities: list[str]
    kinetic: Expression
    potential: Expression = "0"
    forces: dict[str, Expression] = Field(default_factory=dict)
    description: str = ""


class Schedule(_Frozen):
    """Time-scheduled firing: at ``phase + k * period`` for k = 0, 1, 2, ...

    ``period``, ``phase`` and ``enabled`` are numbers or expressions of
    parameters (so a sampling rate can be a parameter). The period must be
    positive and finite and the phase finite; ``enabled`` switches the
    transition off for a run where it evaluates to zero.

    Examples
    --------
    >>> Schedule(period=0.001).phase
    0.0
    >>> Schedule(period="T_s", enabled="sampled").enabled
    'sampled'
    """

    period: Number | Expression
    phase: Number | Expression = 0.0
    enabled: Number | Expression = 1.0


class Transition(_Frozen):
    """A discrete jump from ``source`` to ``target``.

    ``source`` may be a list of modes or ``"*"`` (every mode), and ``target``
    may be ``"*"`` (stay in the source mode): one declaration then stands for
    a transition out of each of those modes, which is how a sensor that is
    watched in every mode is written.

    A transition fires at the first instant its guard (all inequalities)
    holds; a scheduled transition fires at its scheduled instants, when its
    guard (if any) holds. Among transitions enabled at the same instant the
    lowest ``priority`` number fires first; transitions without a priority
    come after all numbered ones, in declaration order.

    Examples
    --------
    >>> Transition(name="bounce", source="fall", target="fall", guard="h <= 0",
    ...            reset={"v": "-e*v"}, priority=1).guard
    ['h <= 0']
    """

    name: Annotated[str, Field(min_length=1)]
    source: str | list[str]
    target: str
    guard: Relations = Field(default_factory=list)
    reset: Resets = Field(default_factory=dict)
    priority: Integer | None = None
    schedule: Schedule | None = None
    description: str = ""


class Initial(_Frozen):
    """The initial discrete mode (initial state values live with the states).

    Examples
    --------
    >>> Initial(mode="fall")
    Initial(mode='fall')

    The mode must be one of the model's (checked when the model is validated):

    >>> from hybridlab.model.loader import loads_model
    >>> loads_model('name = "m"\\nstates = { x = 1.0 }\\nmodes.a.flow.x = "-x"\\n'
    ...             'initial = { mode = "b" }\\n')
    Traceback (most recent call last):
    ...
    hybridlab.errors.ModelError: <string>: initial.mode: initial mode is not a mode (token 'b')
    """

    mode: str


class Scenario(_Frozen):
    """A named run: horizon, parameter and initial-value overrides, solver settings.

    Examples
    --------
    >>> Scenario(t_end=10.0, parameters={"e": 0.5}).parameters
    {'e': 0.5}
    """

    t_end: Number
    t_start: Number = 0.0
    parameters: dict[str, Number] = Field(default_factory=dict)
    initial: dict[str, Value] = Field(default_factory=dict)
    mode: str | None = None
    method: str | None = None
    rtol: PositiveNumber | None = None
    atol: PositiveNumber | None = None
    max_step: PositiveNumber | None = None
    description: str = ""


#: ``g = 9.81`` or a Parameter table; always a Parameter once validated.
ParameterField = Annotated[Parameter, _number_as("value"), _Shorthand({"type": "number"})]
#: ``h = 10.0`` or a State table; always a State once validated.
StateField = Annotated[State, _number_as("initial"), _Shorthand({"type": "number"})]
#: ``count = 0``, ``armed = false`` or a Discrete table; always a Discrete once validated.
DiscreteField = Annotated[Discrete, _Shorthand({"type": ["number", "boolean"]})]


class Model(_Frozen):
    """A hybrid automaton.

    Build it from a TOML file with :func:`hybridlab.load_model` or directly:

    Examples
    --------
    >>> ball = Model(
    ...     name="ball",
    ...     parameters={"g": 9.81, "e": 0.8},
    ...     states={"h": 10.0, "v": 0.0},
    ...     modes={"fall": Mode(flow={"h": "v", "v": "-g"}, invariant=["h >= 0"])},
    ...     transitions=[Transition(name="bounce", source="fall", target="fall",
    ...                             guard="h <= 0", reset={"v": "-e*v"})],
    ...     initial=Initial(mode="fall"),
    ... )
    >>> ball.state_names
    ('h', 'v')
    """

    name: Annotated[str, Field(min_length=1)]
    description: str = ""
    parameters: dict[str, ParameterField] = Field(default_factory=dict)
    states: dict[str, StateField]
    discrete: dict[str, DiscreteField] = Field(default_factory=dict)
    signals: dict[str, Signal] = Field(default_factory=dict)
    definitions: dict[str, Expression] = Field(default_factory=dict)
    mechanics: Mechanics | None = None
    modes: dict[str, Mode]
    transitions: list[Transition] = Field(default_factory=list)
    initial: Initial
    scenarios: dict[str, Scenario] = Field(default_factory=dict)

    _symbolic: Any = PrivateAttr(default=None)
    _compiled: Any = PrivateAttr(default=None)
    _network: Any = PrivateAttr(default=None)

    def __eq__(self, other: object) -> bool:
        # compare the declared fields only: pydantic's default also compares the private
        # caches, so a compiled model would differ from a fresh copy of itself
        if not isinstance(other, BaseModel):
            return NotImplemented
        if type(other) is not type(self):
            return False
        return all(getattr(self, name) == getattr(other, name)
                   for name in type(self).model_fields)

    # no __hash__ here: pydantic still gives the frozen model its field hash (which
    # raises TypeError, as the fields hold dicts), exactly as before __eq__ was defined

    @model_validator(mode="after")
    def _check_meaning(self) -> Model:
        from hybridlab.model.checks import build_symbolic

        self._symbolic = build_symbolic(self)
        return self

    @property
    def state_names(self) -> tuple[str, ...]:
        """The order of state vectors: the states in declaration order, then the
        discrete variables (:attr:`discrete_names`)."""
        return (*self.states, *self.discrete)

    @property
    def discrete_names(self) -> tuple[str, ...]:
        """Discrete variable names in declaration order."""
        return tuple(self.discrete)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Parameter names in declaration order (the order of parameter vectors)."""
        return tuple(self.parameters)

    @property
    def network(self) -> Any:
        """The components the model was built from
        (:class:`hybridlab.model.compose.NetworkSummary`), or ``None`` for a flat file."""
        return self._network

    @property
    def symbolic(self) -> Any:
        """The parsed sympy form (:class:`hybridlab.model.checks.SymbolicModel`)."""
        return self._symbolic
