"""Declarative objects of a model built from components: templates, instances, a network.

A network file declares automaton *templates* (or imports them from component
libraries) and *instances* of them; loading it builds the product, one flat
:class:`~hybridlab.model.schema.Model` (:mod:`hybridlab.model.compose`). These
classes only describe the file; the checks of meaning run when the product is built.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from hybridlab.model.schema import (
    DiscreteField,
    Expression,
    Initial,
    Mechanics,
    Mode,
    Number,
    ParameterField,
    Scenario,
    StateField,
    Transition,
    Value,
    _Frozen,
)

__all__ = ["SyncTransition", "Template", "Instance", "Network"]


class SyncTransition(Transition):
    """A transition of a template; a ``label`` synchronises it with other components.

    Transitions with the same label in different instances fire together, as one
    event, and only when every instance that uses the label has one of them enabled.
    A labelled transition may leave out its guard when its partners' guards decide.

    Examples
    --------
    >>> SyncTransition(name="turn_on", source="off", target="on", guard="T <= T_low",
    ...                label="start").label
    'start'
    """

    label: Annotated[str, Field(min_length=1)] | None = None


class Template(_Frozen):
    """An automaton to instantiate: the keys of a flat model less ``name`` and
    ``scenarios``, plus the ``inputs`` it reads from other instances. A template may
    have no states (a controller that only switches modes).

    Examples
    --------
    >>> room = Template(parameters={"a": 0.1}, inputs=["T_other"], states={"T": 20.0},
    ...                 modes={"off": Mode(flow={"T": "-a*(T - T_other)"})},
    ...                 initial=Initial(mode="off"))
    >>> room.inputs, room.states["T"].initial
    (['T_other'], 20.0)
    """

    description: str = ""
    parameters: dict[str, ParameterField] = Field(default_factory=dict)
    inputs: list[str] = Field(default_factory=list)
    states: dict[str, StateField] = Field(default_factory=dict)
    discrete: dict[str, DiscreteField] = Field(default_factory=dict)
    definitions: dict[str, Expression] = Field(default_factory=dict)
    mechanics: Mechanics | None = None
    modes: dict[str, Mode]
    transitions: list[SyncTransition] = Field(default_factory=list)
    initial: Initial


class Instance(_Frozen):
    """A component: a template with its own parameter values, initial values and mode,
    its inputs connected to other instances' variables, and its labels renamed.

    Examples
    --------
    >>> Instance(template="room", parameters={"a": 0.2}, connect={"T_other": "room2.T"},
    ...          labels={"start": "start1"}).connect
    {'T_other': 'room2.T'}
    """

    template: Annotated[str, Field(min_length=1)]
    description: str = ""
    parameters: dict[str, Number] = Field(default_factory=dict)
    initial: dict[str, Value] = Field(default_factory=dict)
    mode: str | None = None
    connect: dict[str, str] = Field(default_factory=dict)
    labels: dict[str, str] = Field(default_factory=dict)


class Network(_Frozen):
    """A model file built from components, or a component library (no instances).

    ``qualify`` says how the product names the components' variables and transitions:
    ``"always"`` as ``instance.name``; ``"shared"`` only the names that several
    instances declare, the others as declared (a flat model split into components
    keeps its names). Product modes are always ``instance.mode|...``.

    Examples
    --------
    >>> Network(name="lib", templates={"room": Template(
    ...     states={"T": 20.0}, modes={"off": Mode(flow={"T": "-T"})},
    ...     initial=Initial(mode="off"))}).instances
    {}
    """

    name: Annotated[str, Field(min_length=1)]
    description: str = ""
    qualify: Literal["always", "shared"] = Field(
        "always", description="always: every name of a component is instance.name; shared: "
                              "only the names that several instances declare")
    imports: list[str] = Field(default_factory=list)
    templates: dict[str, Template] = Field(default_factory=dict)
    instances: dict[str, Instance] = Field(default_factory=dict)
    scenarios: dict[str, Scenario] = Field(default_factory=dict)
