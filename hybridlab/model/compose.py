"""The product of a network of components: one flat model in qualified names.

Every instance's parameters, states and definitions are renamed ``instance.name`` (with
``qualify = "shared"`` only the names several instances declare; the others, and the
transitions whose names one template declares, keep their own); an input is replaced by
the variable it is connected to; the product's modes are every
combination of the components' modes, named ``instance.mode|instance.mode|...``; each
unlabelled transition of a component is a transition of the product
(``instance.transition``), and the transitions that share a synchronisation label fire
together as one transition, ``label(instance.transition, ...)``, whose guard is the
conjunction of theirs and whose reset is the union of theirs. The result is the data of
a flat model file, validated by :class:`~hybridlab.model.schema.Model` like any other.
"""

from __future__ import annotations

import graphlib
import itertools
import math
from collections import Counter
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from typing import Any

from hybridlab.errors import ExpressionError, ModelError
from hybridlab.model.discrete import value_problem, written
from hybridlab.model.expressions import check_name, names_in, rename
from hybridlab.model.names import SEPARATOR, match_modes, mode_target
from hybridlab.model.network import Instance, Network, SyncTransition, Template

__all__ = ["MAX_PRODUCT_MODES", "MAX_PRODUCT_TRANSITIONS", "Component", "NetworkSummary",
           "SourcedTemplate", "check_template", "compose"]

#: The most modes a product may have (the product of the components' mode counts).
MAX_PRODUCT_MODES = 4096
#: The most transitions a product may have (synchronised combinations included).
MAX_PRODUCT_TRANSITIONS = 4096


@dataclass(frozen=True)
class SourcedTemplate:
    """A template with the file that declares it (named in its errors).

    Examples
    --------
    >>> from hybridlab.model.schema import Initial, Mode
    >>> tpl = Template(states={"x": 1.0}, modes={"m": Mode(flow={"x": "-x"})},
    ...                initial=Initial(mode="m"))
    >>> SourcedTemplate(tpl, "lib.toml").source
    'lib.toml'
    """

    template: Template
    source: str


@dataclass(frozen=True)
class Component:
    """One instance of a network as ``hybridlab check`` shows it.

    Examples
    --------
    >>> Component("room1", "room", "rooms.toml", {"T_other": "room2.T"}, {"start": "start1"})
    ... # doctest: +ELLIPSIS
    Component(name='room1', template='room', ...)
    """

    name: str
    template: str
    source: str
    connections: Mapping[str, str]
    labels: Mapping[str, str]


@dataclass(frozen=True)
class NetworkSummary:
    """The components a model was built from: instances, connections and labels.

    Examples
    --------
    >>> from hybridlab.model.loader import load_model
    >>> net = load_model("models/two_rooms.toml").network
    >>> [c.name for c in net.components], sorted(net.labels)[:2]
    (['room1', 'room2', 'heater'], ['start1', 'start2'])
    >>> net.labels["start1"]
    ('room1.turn_on', 'heater.grant1')
    """

    components: tuple[Component, ...]
    labels: Mapping[str, tuple[str, ...]]

    def describe(self) -> list[str]:
        """Lines that show the network (instances, templates, connections, labels)."""
        lines = [f"  instances ({len(self.components)}):"]
        for c in self.components:
            lines.append(f"    {c.name}: template {c.template!r} from {c.source}")
        connections = [f"{c.name}.{i} <- {target}" for c in self.components
                       for i, target in c.connections.items()]
        lines.append(f"  connections ({len(connections)}): {', '.join(connections) or '-'}")
        lines.append(f"  labels ({len(self.labels)}):")
        lines.extend(f"    {label}: {', '.join(users)}" for label, users in self.labels.items())
        return lines


def _fail(message: str, key: str, token: str = "", source: str = "") -> ModelError:
    return ModelError(message, key=key, token=token, source=source)


def _sources(tr: SyncTransition) -> list[str] | None:
    """The source modes of a transition; ``None`` for every mode."""
    if tr.source == "*":
        return None
    return [tr.source] if isinstance(tr.source, str) else list(tr.source)


def _local_names(tpl: Template) -> set[str]:
    return {name for mode in tpl.modes.values() for name in mode.definitions}


def check_template(name: str, tpl: Template, source: str) -> None:
    """Check a template as an automaton of its own (its inputs read as parameters).

    Raises
    ------
    ModelError
        Naming ``source`` and the key under ``templates.NAME``.

    Examples
    --------
    >>> from hybridlab.model.schema import Initial, Mode
    >>> tpl = Template(states={"x": 1.0}, modes={"m": Mode(flow={"x": "-k*x"})},
    ...                initial=Initial(mode="m"))
    >>> check_template("decay", tpl, "lib.toml")
    Traceback (most recent call last):
    ...
    hybridlab.errors.ModelError: lib.toml: templates.decay.modes.m.flow.x: unknown symbol ...
    """
    from hybridlab.model.loader import model_from_dict

    key = f"templates.{name}"
    try:
        check_name(name)
    except ExpressionError as exc:
        raise _fail(exc.message, key, exc.token, source) from None
    declared = {*tpl.parameters, *tpl.states, *tpl.discrete, *tpl.definitions,
                *_local_names(tpl)}
    for i, inp in enumerate(tpl.inputs):
        try:
            check_name(inp)
        except ExpressionError as exc:
            raise _fail(exc.message, f"{key}.inputs[{i}]", exc.token, source) from None
        if inp in declared or tpl.inputs.index(inp) != i:
            raise _fail("input name already declared in the template", f"{key}.inputs[{i}]",
                        inp, source)
    for mode in tpl.modes:
        if SEPARATOR in mode:
            raise _fail(f"a component's mode name may not contain {SEPARATOR!r}",
                        f"{key}.modes", mode, source)
    data = tpl.model_dump(round_trip=True, exclude={"inputs"})
    data["name"] = name
    data["parameters"] = {**data["parameters"], **{i: {"value": 1.0} for i in tpl.inputs}}
    if not tpl.states and not tpl.discrete:  # a controller: checked with a constant state
        unused = next(f"unused{k}" for k in itertools.count()
                      if f"unused{k}" not in declared and f"unused{k}" not in tpl.inputs)
        data["states"] = {unused: {"initial": 0.0, "flow": "0"}}
    for tr in data["transitions"]:
        if tr.pop("label", None) is not None and not tr["guard"] and tr["schedule"] is None:
            tr["guard"] = ["0 <= 1"]  # a partner's guard decides; checked in the product
    try:
        model_from_dict(data, source=source)
    except ModelError as exc:
        raise _fail(exc.message, f"{key}.{exc.key}" if exc.key else key, exc.token,
                    source) from None


@dataclass
class _Part:
    """An instance ready for the product: its template and its renaming."""

    name: str
    template_name: str
    tpl: Template
    names: dict[str, str]  # template name -> product name

    def q(self, text: str) -> str:
        return rename(text, self.names)

    def mode(self, mode: str) -> str:
        return f"{self.name}.{mode}"


class _Builder:
    def __init__(self, network: Network, templates: Mapping[str, SourcedTemplate],
                 source: str) -> None:
        self.network = network
        self.templates = templates
        self.source = source
        self.parts: dict[str, _Part] = {}
        self.short: set[str] = set()  # transitions named as declared in the product

    def fail(self, message: str, key: str, token: str = "") -> ModelError:
        return _fail(message, key, token, self.source)

    # ----- instances ----------------------------------------------------------------------
    def instance(self, name: str, inst: Instance) -> _Part:
        key = f"instances.{name}"
        try:
            check_name(name)
        except ExpressionError as exc:
            raise self.fail(exc.message, key, exc.token) from None
        if inst.template not in self.templates:
            known = ", ".join(self.templates) or "none"
            raise self.fail(f"instance of an unknown template; the templates are: {known}",
                            f"{key}.template", inst.template)
        tpl = self.templates[inst.template].template
        t = inst.template
        template_labels = {tr.label for tr in tpl.transitions if tr.label is not None}
        declared: tuple[tuple[str, Collection[str], str], ...] = (
            ("parameters", tpl.parameters, "declares no parameter of this name"),
            ("initial", {*tpl.states, *tpl.discrete},
             "declares no state or discrete variable of this name"),
            ("connect", tpl.inputs, "declares no input of this name"),
            ("labels", template_labels, "has no transition with this label"))
        for section, allowed, what in declared:
            for given in getattr(inst, section):
                if given not in allowed:
                    raise self.fail(f"template {t!r} {what}", f"{key}.{section}.{given}", given)
        for given, value in inst.initial.items():
            kind = tpl.discrete[given].type if given in tpl.discrete else "real"
            if (problem := value_problem(kind, value)) is not None:
                raise self.fail(f"{problem} (instance {name!r} of template {t!r})",
                                f"{key}.initial.{given}", written(value))
        if inst.mode is not None and inst.mode not in tpl.modes:
            raise self.fail(f"template {t!r} has no mode of this name", f"{key}.mode", inst.mode)
        for i in tpl.inputs:
            if i not in inst.connect:
                raise self.fail(f"input {i!r} of template {t!r} is not connected",
                                f"{key}.connect", i)
        own = [*tpl.parameters, *tpl.states, *tpl.discrete, *tpl.definitions,
               *sorted(_local_names(tpl))]
        names = {n: f"{name}.{n}" for n in own}
        return _Part(name, t, tpl, names)

    def unqualify(self) -> None:
        """``qualify = "shared"``: the names only one instance declares keep their own."""
        if self.network.qualify == "always":
            return
        owners = Counter(n for part in self.parts.values() for n in part.names)
        for part in self.parts.values():
            part.names.update({n: n for n in part.names if owners[n] == 1})
        transitions = Counter(tr.name for part in self.parts.values()
                              for tr in part.tpl.transitions)
        self.short = {tr.name for part in self.parts.values() for tr in part.tpl.transitions
                      if transitions[tr.name] == 1}

    def connect(self) -> None:
        """Check every connection's target and map each input to it."""
        for name, inst in self.network.instances.items():
            part = self.parts[name]
            for i, target in inst.connect.items():
                key = f"instances.{name}.connect.{i}"
                other, _, var = target.partition(".")
                where = f"instance {name!r} of template {part.template_name!r}"
                if other not in self.parts:
                    raise self.fail(f"connection to a missing instance ({where})", key, target)
                tpl = self.parts[other].tpl
                if var in tpl.inputs:
                    raise self.fail(f"connection to an input of {other!r}; connect to the "
                                    f"variable that input reads ({where})", key, target)
                if var not in {*tpl.states, *tpl.discrete, *tpl.parameters, *tpl.definitions}:
                    raise self.fail(f"connection to a missing variable: template "
                                    f"{self.parts[other].template_name!r} of {other!r} has no "
                                    f"state, parameter or definition {var!r} ({where})",
                                    key, target)
                part.names[i] = self.parts[other].names[var]

    def instantaneous_cycles(self) -> None:
        """Reject connections through definitions that read each other in a cycle."""
        uses: dict[str, set[str]] = {}
        via: dict[tuple[str, str], str] = {}  # (definition, definition) -> connection key
        for name, part in self.parts.items():
            inputs = set(part.tpl.inputs)
            for d, text in part.tpl.definitions.items():
                node = part.names[d]
                uses[node] = set()
                for used in names_in(text):
                    if used in part.tpl.definitions:
                        uses[node].add(part.names[used])
                    elif used in inputs:
                        target = part.names[used]
                        uses[node].add(target)
                        via[(node, target)] = f"instances.{name}.connect.{used}"
        try:
            graphlib.TopologicalSorter(uses).prepare()
        except graphlib.CycleError as exc:
            cycle = exc.args[1]  # each depends on the one before it
            pairs = list(zip(cycle[1:], cycle, strict=False))
            key = next(via[p] for p in pairs if p in via)
            name = key.split(".")[1]
            raise self.fail(f"connections form an instantaneous cycle of definitions (instance "
                            f"{name!r} of template {self.parts[name].template_name!r})", key,
                            " -> ".join(reversed(cycle))) from None

    # ----- the product --------------------------------------------------------------------
    def product(self) -> dict[str, Any]:
        net = self.network
        if not net.instances:
            raise self.fail("a model needs at least one instance", "instances")
        for name, inst in net.instances.items():
            self.parts[name] = self.instance(name, inst)
        self.unqualify()
        self.connect()
        self.instantaneous_cycles()
        parts = list(self.parts.values())
        count = math.prod(len(p.tpl.modes) for p in parts)
        if count > MAX_PRODUCT_MODES:
            raise self.fail(f"the product has {count} modes (at most {MAX_PRODUCT_MODES}); "
                            "use fewer or smaller components", "instances", str(count))
        data: dict[str, Any] = {"name": net.name, "description": net.description,
                                "parameters": {}, "states": {}, "discrete": {},
                                "definitions": {}}
        for part, inst in zip(parts, net.instances.values(), strict=True):
            for p, par in part.tpl.parameters.items():
                data["parameters"][part.names[p]] = {
                    **par.model_dump(), "value": inst.parameters.get(p, par.value)}
            for s, state in part.tpl.states.items():
                entry = {**state.model_dump(exclude_none=True),
                         "initial": inst.initial.get(s, state.initial)}
                if state.flow is not None:
                    entry["flow"] = part.q(state.flow)
                data["states"][part.names[s]] = entry
            for d, var in part.tpl.discrete.items():
                data["discrete"][part.names[d]] = {**var.model_dump(),
                                                   "value": inst.initial.get(d, var.value)}
            for d, text in part.tpl.definitions.items():
                data["definitions"][part.names[d]] = part.q(text)
        mechanics = self.mechanics(parts)
        if mechanics is not None:
            data["mechanics"] = mechanics
        initial = SEPARATOR.join(p.mode(inst.mode or p.tpl.initial.mode)
                                 for p, inst in zip(parts, net.instances.values(), strict=True))
        modes = self.modes(parts)
        starts = [initial, *(sc.mode for sc in net.scenarios.values() if sc.mode in modes)]
        data["modes"], data["transitions"] = _reachable(modes, self.transitions(parts), starts)
        data["initial"] = {"mode": initial}
        data["scenarios"] = {k: v.model_dump(round_trip=True) for k, v in net.scenarios.items()}
        return data

    @staticmethod
    def mechanics(parts: list[_Part]) -> dict[str, Any] | None:
        """The components' Lagrangian systems as one (their energies add up)."""
        with_mech = [p for p in parts if p.tpl.mechanics is not None]
        if not with_mech:
            return None
        out: dict[str, Any] = {"coordinates": [], "velocities": [], "forces": {}}
        kinetic, potential = [], []
        for p in with_mech:
            if (mech := p.tpl.mechanics) is None:
                continue
            out["coordinates"] += [p.names[c] for c in mech.coordinates]
            out["velocities"] += [p.names[v] for v in mech.velocities]
            kinetic.append(f"({p.q(mech.kinetic)})")
            potential.append(f"({p.q(mech.potential)})")
            out["forces"].update({p.names[c]: p.q(f) for c, f in mech.forces.items()})
        out["kinetic"] = " + ".join(kinetic)
        out["potential"] = " + ".join(potential)
        return out

    @staticmethod
    def modes(parts: list[_Part]) -> dict[str, Any]:
        modes: dict[str, Any] = {}
        for combo in itertools.product(*(list(p.tpl.modes.items()) for p in parts)):
            flow: dict[str, str] = {}
            invariant: list[str] = []
            local: dict[str, str] = {}
            for p, (_, mode) in zip(parts, combo, strict=True):
                flow.update({p.names[s]: p.q(text) for s, text in mode.flow.items()})
                invariant += [p.q(text) for text in mode.invariant]
                local.update({p.names[d]: p.q(text) for d, text in mode.definitions.items()})
            name = SEPARATOR.join(p.mode(m) for p, (m, _) in zip(parts, combo, strict=True))
            modes[name] = {"flow": flow, "invariant": invariant, "definitions": local}
        return modes

    def label_of(self, part: _Part, tr: SyncTransition) -> str | None:
        if tr.label is None:
            return None
        return self.network.instances[part.name].labels.get(tr.label, tr.label)

    def users(self, parts: list[_Part]) -> dict[str, list[_Part]]:
        """Each label with the instances that use it, in declaration order."""
        users: dict[str, list[_Part]] = {}
        for p in parts:
            for tr in p.tpl.transitions:
                label = self.label_of(p, tr)
                if label is not None and p not in users.setdefault(label, []):
                    users[label].append(p)
        for label, who in users.items():
            if len(who) < 2:
                p = who[0]
                renamed = next((k for k, v in self.network.instances[p.name].labels.items()
                                if v == label), None)
                key = (f"instances.{p.name}.labels.{renamed}" if renamed is not None
                       else f"instances.{p.name}.template")
                raise self.fail(f"label {label!r} of template {p.template_name!r} is used by "
                                f"instance {p.name!r} only; a label synchronises transitions "
                                "of two or more instances", key, label)
        return users

    def transitions(self, parts: list[_Part]) -> list[dict[str, Any]]:
        users = self.users(parts)
        out: list[dict[str, Any]] = []
        done: set[str] = set()
        for p in parts:
            for tr in p.tpl.transitions:
                label = self.label_of(p, tr)
                if label is None:
                    out.append(self.joint(None, [(p, tr)]))
                elif label not in done:
                    done.add(label)
                    options = [[(u, t) for t in u.tpl.transitions if self.label_of(u, t) == label]
                               for u in users[label]]
                    for combo in itertools.product(*options):
                        out.append(self.joint(label, list(combo)))
                if len(out) > MAX_PRODUCT_TRANSITIONS:
                    raise self.fail(f"the product has more than {MAX_PRODUCT_TRANSITIONS} "
                                    "transitions; use fewer or smaller components",
                                    "instances", str(len(out)))
        return out

    def joint(self, label: str | None, members: list[tuple[_Part, SyncTransition]]
              ) -> dict[str, Any]:
        """One product transition: a component's own, or the members of a label's event."""
        names = [tr.name if tr.name in self.short else f"{p.name}.{tr.name}"
                 for p, tr in members]
        name = names[0] if label is None else f"{label}({', '.join(names)})"
        choices = [[p.mode(s) for s in sources] for p, tr in members
                   if (sources := _sources(tr)) is not None]
        patterns = [SEPARATOR.join(c) for c in itertools.product(*choices)] if choices else []
        targets = [p.mode(tr.target) for p, tr in members if tr.target != "*"]
        scheduled = [(p, tr) for p, tr in members if tr.schedule is not None]
        if len(scheduled) > 1:
            raise self.fail(f"label {label!r} joins {len(scheduled)} scheduled transitions; at "
                            "most one may have a schedule",
                            f"instances.{scheduled[1][0].name}.template", ", ".join(names))
        guard = [p.q(g) for p, tr in members for g in tr.guard]
        if not guard and not scheduled:
            raise self.fail(f"label {label!r} joins transitions that have neither a guard nor "
                            "a schedule", f"instances.{members[0][0].name}.template",
                            ", ".join(names))
        priorities = [tr.priority for _, tr in members if tr.priority is not None]
        out: dict[str, Any] = {
            "name": name,
            "source": patterns[0] if len(patterns) == 1 else (patterns or "*"),
            "target": SEPARATOR.join(targets) if targets else "*",
            "guard": guard,
            "reset": {p.names[s]: p.q(text) for p, tr in members for s, text in tr.reset.items()},
        }
        if priorities:
            out["priority"] = min(priorities)
        if scheduled:
            p, tr = scheduled[0]
            schedule = tr.schedule.model_dump() if tr.schedule is not None else {}
            out["schedule"] = {k: p.q(v) if isinstance(v, str) else v
                               for k, v in schedule.items()}
        return out

    def summary(self) -> NetworkSummary:
        parts = list(self.parts.values())
        labels: dict[str, tuple[str, ...]] = {}
        for p in parts:
            for tr in p.tpl.transitions:
                label = self.label_of(p, tr)
                if label is not None:
                    labels[label] = (*labels.get(label, ()), f"{p.name}.{tr.name}")
        return NetworkSummary(
            components=tuple(Component(p.name, p.template_name,
                                       self.templates[p.template_name].source,
                                       dict(self.network.instances[p.name].connect),
                                       dict(self.network.instances[p.name].labels))
                             for p in parts),
            labels=labels)


def _patterns(tr: Mapping[str, Any]) -> list[str]:
    source = tr["source"]
    return [source] if isinstance(source, str) else list(source)


def _reachable(modes: dict[str, Any], transitions: list[dict[str, Any]], starts: list[str]
               ) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """The modes the transitions can reach from ``starts`` (guards aside), and the
    transitions restricted to them: the other combinations of the components' modes
    (room 1 heated while the heater is idle) can never be entered."""
    sources = [None if tr["source"] == "*" else
               [frozenset(p.split(SEPARATOR)) for p in _patterns(tr)] for tr in transitions]
    seen = dict.fromkeys(starts)
    stack = list(seen)
    while stack:
        mode = stack.pop()
        parts = frozenset(mode.split(SEPARATOR))
        for tr, patterns in zip(transitions, sources, strict=True):
            if patterns is None or any(p <= parts for p in patterns):
                target = mode_target(mode, tr["target"])
                if target in modes and target not in seen:
                    seen[target] = None
                    stack.append(target)
    kept = [m for m in modes if m in seen]
    out = []
    for tr in transitions:
        if tr["source"] != "*":
            live = [p for p in _patterns(tr) if match_modes(p, kept)]
            if not live:
                continue  # it leaves only modes that are never entered
            tr = {**tr, "source": live[0] if len(live) == 1 else live}
        out.append(tr)
    return {m: modes[m] for m in kept}, out


def compose(network: Network, templates: Mapping[str, SourcedTemplate],
            source: str) -> tuple[dict[str, Any], NetworkSummary]:
    """The data of the flat product model of ``network``, and a summary of the network.

    ``templates`` are the templates the network may instantiate (its own and imported
    ones), each already checked with :func:`check_template`.

    Raises
    ------
    ModelError
        One line naming ``source``, the instance's key and the token.

    Examples
    --------
    >>> from hybridlab.model.schema import Initial, Mode
    >>> tank = Template(parameters={"k": 0.5}, inputs=["inflow"], states={"h": 1.0},
    ...                 modes={"on": Mode(flow={"h": "inflow - k*h"})},
    ...                 initial=Initial(mode="on"))
    >>> net = Network(name="tanks", instances={
    ...     "a": Instance(template="tank", connect={"inflow": "b.k"}),
    ...     "b": Instance(template="tank", connect={"inflow": "a.h"}, parameters={"k": 0.2})})
    >>> data, summary = compose(net, {"tank": SourcedTemplate(tank, "tanks.toml")}, "tanks.toml")
    >>> data["modes"]
    {'a.on|b.on': {'flow': {'a.h': 'b.k - a.k*a.h', 'b.h': 'a.h - b.k*b.h'}, 'invariant': [], \
'definitions': {}}}
    >>> data["parameters"]["b.k"]["value"]
    0.2
    """
    builder = _Builder(network, templates, source)
    return builder.product(), builder.summary()
