"""A SpaceEx network as hybridlab components: one template per base component, one
instance per bind.

The import (:func:`hybridlab.io.spaceex.import_spaceex`) resolves the network and
builds its product; this module writes the same network as a components file, whose
product hybridlab's components loader builds (:mod:`hybridlab.model.compose`). A global
variable belongs to the instance that gives it its flow (its state there); the other
instances read it through an input connected to it. A constant of one value is a
parameter of each instance that uses it; an uncertain constant (an interval) or a
variable without flow (an input bounded by the invariants) is one parameter, of the
first instance that uses it, read by the others (so instances of one component that
differ in this get a template each).
SpaceEx labels become synchronisation labels; a label only one automaton uses leaves
its transitions unlabelled, as in SpaceEx.

Where the components format cannot say what the product says, the file stays the
product, with a one-line note saying why (:attr:`SpaceExComponents.note`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from hybridlab.errors import ModelError
from hybridlab.io._sxexpr import Atom
from hybridlab.io._sxheader import problem_header
from hybridlab.io.spaceex import (
    ConstraintSet,
    SpaceExImport,
    SpaceExProblem,
    _Automaton,
    _hybrid_name,
    _relations,
    import_spaceex,
    read_spaceex,
)
from hybridlab.model.expressions import rename
from hybridlab.model.loader import _toml_key, _toml_value, dumps_model, model_from_dict
from hybridlab.model.names import SEPARATOR, match_modes, mode_target
from hybridlab.model.schema import Model

__all__ = ["SpaceExComponents", "spaceex_components", "loads_spaceex_components"]


class _Flat(Exception):
    """The network cannot be written as components; the message says why."""


@dataclass(frozen=True)
class SpaceExComponents:
    """A SpaceEx network written as a hybridlab components file.

    Attributes
    ----------
    problem : SpaceExProblem
        The import as :func:`~hybridlab.io.load_spaceex` returns it (its ``model`` is
        the flat product).
    document : dict or None
        The components file's data (``templates``, ``instances``, ...); ``None`` when
        the file is the flat product.
    note : str
        Why the file is the flat product (``""`` when it is components).
    names : dict of str to str
        The product's names of ``problem.model`` (``x1``) -> the components' (``room1.T``).
    modes : dict of str to str
        The product's mode names of ``problem.model`` -> the components'.
    renamed : dict of str to str
        SpaceEx names (the ``.cfg``'s) -> the components' names, where the instance's
        name for it differs (``T1`` -> ``room1.T``).

    Examples
    --------
    >>> c = spaceex_components("models/spaceex/two_rooms.xml", "models/spaceex/two_rooms.cfg")
    >>> list(c.document["templates"]), list(c.document["instances"])
    (['room', 'heater'], ['room1', 'room2', 'heater'])
    >>> c.names["T1"], c.modes["off.off.idle"]
    ('room1.T', 'room1.off|room2.off|heater.idle')
    >>> c.model().state_names
    ('room1.T', 'room2.T', 'heater.on_time')
    """

    problem: SpaceExProblem
    document: Mapping[str, Any] | None
    note: str
    names: Mapping[str, str]
    modes: Mapping[str, str]
    renamed: Mapping[str, str]

    def model(self) -> Model:
        """The model the written file loads as (the components' product, or the flat one)."""
        if self.document is None:
            return self.problem.model
        return model_from_dict(self.document, source=self.problem.source[0])

    def text(self) -> str:
        """The file: comments with what a model file cannot hold, then the TOML."""
        if self.document is None:
            note = f"# {self.note}\n" if self.note else ""
            return problem_header(self.problem) + "\n" + note + dumps_model(self.problem.model)
        header = problem_header(_renamed(self.problem, self.names, self.modes, self.renamed))
        return header + "\n" + _dumps_network(self.document)


def spaceex_components(path: str | Path, cfg: str | Path | None = None, *,
                       system: str | None = None) -> SpaceExComponents:
    """Import a SpaceEx network as components (see :func:`~hybridlab.io.load_spaceex`).

    A system of one automaton stays a flat model: a template and its one instance would
    only add the instance's name to every name.

    Examples
    --------
    >>> c = spaceex_components("models/spaceex/bouncing_ball.xml")
    >>> c.document is None, c.note
    (True, 'one automaton: written as a flat model')
    """
    xml, cfg_text = read_spaceex(path, cfg)
    return loads_spaceex_components(xml, cfg_text, source=str(path),
                                    cfg_source=str(cfg) if cfg is not None else "<cfg>",
                                    system=system)


def loads_spaceex_components(xml: str | bytes, cfg: str | None = None, *,
                             source: str = "<string>", cfg_source: str = "<cfg>",
                             system: str | None = None) -> SpaceExComponents:
    """:func:`spaceex_components` from the text of the files.

    Examples
    --------
    >>> xml = '''<sspaceex><component id="clock">
    ...   <param name="c" type="real" local="false" d1="1" d2="1" dynamics="any"/>
    ...   <location id="1" name="run"><flow>c' == 1</flow></location></component>
    ...   <component id="net">
    ...   <param name="c" type="real" local="false" d1="1" d2="1" dynamics="any"/>
    ...   <bind component="clock" as="a"><map key="c">c</map></bind>
    ...   <bind component="clock" as="b"/></component></sspaceex>'''
    >>> c = loads_spaceex_components(xml)
    >>> c.document["instances"], c.names
    ({'a': {'template': 'clock'}, 'b': {'template': 'clock'}}, {'c': 'a.c', 'b_c': 'b.c'})
    """
    imp = import_spaceex(xml, cfg, source=source, cfg_source=cfg_source, system=system)
    problem = imp.problem
    if len(imp.automata) == 1:
        return SpaceExComponents(problem, None, "one automaton: written as a flat model", {}, {},
                                 {})
    try:
        writer = _Writer(imp, source, cfg_source)
        document, names, modes = writer.document()
        try:
            product = model_from_dict(document, source=source)
        except ModelError as exc:  # a rule of components this writer does not foresee
            raise _Flat(f"the components do not load ({exc.message})") from None
        _same_product(problem.model, product, names, modes)
    except _Flat as exc:
        return SpaceExComponents(problem, None, f"written as the product: {exc}", {}, {},
                                 {})
    spaceex = {v: k for k, v in problem.renamed.items()}
    renamed = {spaceex.get(flat, flat): q for flat, q in names.items()
               if flat in writer.globals and q.rsplit(".", 1)[1] != spaceex.get(flat, flat)}
    return SpaceExComponents(problem, document, "", names, modes, renamed)


# ---------------------------------------------------------------------------- the writer

@dataclass
class _Role:
    """What a formal parameter of one instance is in its template."""

    kind: str  # "state", "parameter" or "input"
    flat: str  # the product's name of the global it stands for
    bound: bool  # an input of the import (a variable without flow, bounded)


class _Writer:
    def __init__(self, imp: SpaceExImport, source: str, cfg_source: str) -> None:
        self.imp = imp
        self.source = source
        self.cfg_source = cfg_source
        self.autos = imp.automata
        self.model = imp.problem.model
        self.inst_names: list[str] = []
        self.tnames: list[dict[str, str]] = []  # per automaton: formal -> template name
        self.globals: set[str] = set()  # the product's names of SpaceEx variables
        taken: set[str] = set()
        for a in self.autos:
            self.inst_names.append(_hybrid_name(a.inst.name, taken))
            local: set[str] = set()
            self.tnames.append({f: _hybrid_name(f, local) for f in a.names})

    # ----- who owns what ------------------------------------------------------------------
    def owners(self) -> dict[str, int]:
        """Each global of the product -> the automaton that declares it."""
        owner: dict[str, int] = {}
        states = set(self.model.state_names)
        for i, a in enumerate(self.autos):
            name = a.inst.name
            flows = [set(f) for f in a.flows.values()]
            owned: set[str] = set().union(*flows)
            partial = sorted(v for v in owned if any(v not in f for f in flows))
            if partial:
                var = partial[0]
                raise _Flat(f"'{name}' gives '{var}' a flow in some of its locations only")
            for var in owned & states:
                if var in owner:
                    raise _Flat(f"'{self.autos[owner[var]].inst.name}' and '{name}' both give "
                                f"'{var}' a flow")
                owner[var] = i
        for i, a in enumerate(self.autos):
            for _, _, _, _, reset, _, _ in a.transitions:
                for var in reset:
                    if owner.get(var) != i:
                        raise _Flat(f"'{a.inst.name}' assigns '{var}', whose flow another "
                                    "component gives (a component resets only its own states)")
            for flat in a.names.values():  # constants and inputs: the first user's
                if flat not in states:
                    owner.setdefault(flat, i)
        return owner

    def roles(self, i: int, owner: Mapping[str, int]) -> dict[str, _Role]:
        a = self.autos[i]
        problem = self.imp.problem
        bounded = set(problem.inputs)
        # one value: a parameter of each instance, as if the binds had mapped it to the number
        shared = bounded | {c for c, v in problem.params.items() if isinstance(v, tuple)}
        out = {}
        for formal, flat in a.names.items():
            kind = "input"
            if (isinstance(a.inst.vars[formal], float) or owner.get(flat) == i
                    or (flat not in self.model.states and flat not in shared)):
                kind = "state" if flat in self.model.states else "parameter"
            out[formal] = _Role(kind, flat, flat in bounded)
        return out

    def label_roles(self) -> list[dict[str, str | None]]:
        """Per automaton: formal label -> the synchronisation label, ``None`` if unlabelled."""
        users: dict[str, list[int]] = {}
        for i, a in enumerate(self.autos):
            for _, _, label, *_ in a.transitions:
                if label and i not in users.setdefault(label, []):
                    users[label].append(i)
        for label, who in users.items():
            blocking = [a.inst.name for i, a in enumerate(self.autos)
                        if label in a.inst.labels.values() and i not in who]
            if blocking:
                raise _Flat(f"label '{label}' is declared by '{blocking[0]}', which has no "
                            "transition with it (it blocks the others')")
        taken: set[str] = set()
        names = {label: _label_name(label, taken) for label, who in users.items()
                 if len(who) > 1}
        self.first_user = {label: who[0] for label, who in users.items()}
        return [{f: names.get(g) for f, g in a.inst.labels.items()} for a in self.autos]

    def check_order(self, i: int, labels: Mapping[str, str | None]) -> None:
        """The product tries simultaneous transitions in the order the flat import does.

        The flat product lists a mode's transitions automaton by automaton in the order
        of the XML, a synchronised one with the first automaton that uses its label; the
        components' product lists a label's transitions together, where it first occurs.
        """
        a = self.autos[i]
        first: dict[str, int] = {}
        keys: dict[str, list[int]] = {}
        for k, (src, _, label, *_) in enumerate(a.transitions):
            key = k
            if label and labels.get(_formal_label(a, label)) is not None:
                if self.first_user[label] != i:
                    continue
                key = first.setdefault(label, k)
            keys.setdefault(src, []).append(key)
        for src, seq in keys.items():
            if seq != sorted(seq):
                raise _Flat(f"'{a.inst.name}' in location "
                            f"'{a.inst.base.locations[src].name}' would try simultaneous "
                            "transitions in another order")

    # ----- templates ----------------------------------------------------------------------
    def template(self, i: int, roles: Mapping[str, _Role], labels: Mapping[str, str | None],
                 keep_guard: set[int]) -> dict[str, Any]:
        a = self.autos[i]
        base = a.inst.base
        tnames = self.tnames[i]
        local: dict[str, str] = {}  # the product's names -> the template's
        for f, r in roles.items():
            local.setdefault(r.flat, tnames[f])

        def q(text: str) -> str:
            return rename(text, local)

        bounded = {a.names[f] for f, r in roles.items() if r.bound}
        values = self.imp.values
        tpl: dict[str, Any] = {}
        params = {tnames[f]: values[r.flat] for f, r in roles.items() if r.kind == "parameter"}
        inputs = [tnames[f] for f, r in roles.items() if r.kind == "input"]
        if params:
            tpl["parameters"] = params
        if inputs:
            tpl["inputs"] = inputs
        tpl["states"] = {tnames[f]: self.model.states[r.flat].initial
                         for f, r in roles.items() if r.kind == "state"}
        modes: dict[str, Any] = {}
        self.mode_names = _location_names(a)
        for lid, loc in base.locations.items():
            entry: dict[str, Any] = {"flow": {local[v]: q(rhs) for v, rhs in a.flows[lid].items()}}
            atoms = [at for at in a.invariants[lid]  # less the inputs' bounds, as flat
                     if not bounded & set(map(str, _free(at)))]
            invariant = [q(r) for r in _relations(atoms, self.source, loc.path + "/invariant")]
            if invariant:
                entry["invariant"] = invariant
            modes[self.mode_names[lid]] = entry
        tpl["modes"] = modes
        transitions = []
        used: dict[str, int] = {}
        for k, (tr, (src, dst, _, guard, reset, _, _)) in enumerate(
                zip(base.transitions, a.transitions, strict=True)):
            stem = tr.label.replace(".", "_") if tr.label else "tau"
            used[stem] = used.get(stem, 0) + 1
            item: dict[str, Any] = {
                "name": stem if used[stem] == 1 else f"{stem}_{used[stem]}",
                "source": self.mode_names[src], "target": self.mode_names[dst]}
            synced = bool(tr.label) and labels.get(tr.label) is not None
            if guard or not synced or k in keep_guard:
                item["guard"] = [q(g) for g in guard] or ["0 <= 0"]
            if reset:
                item["reset"] = {local[v]: q(rhs) for v, rhs in reset.items()}
            if synced:
                item["label"] = tr.label
            transitions.append(item)
        if transitions:
            tpl["transitions"] = transitions
        tpl["initial"] = {"mode": self.mode_names[self.imp.starts[0][i]]}
        return tpl

    def document(self) -> tuple[dict[str, Any], dict[str, str], dict[str, str]]:
        owner = self.owners()
        labels = self.label_roles()
        roles = [self.roles(i, owner) for i in range(len(self.autos))]
        for i, lab in enumerate(labels):
            self.check_order(i, lab)
        names: dict[str, str] = {}
        for i, rs in enumerate(roles):
            tnames = self.tnames[i]
            for f, r in rs.items():
                if r.kind != "input" and r.flat not in names:
                    names[r.flat] = f"{self.inst_names[i]}.{tnames[f]}"
                if not isinstance(self.autos[i].inst.vars[f], float):
                    self.globals.add(r.flat)
        empty = self.unguarded()
        templates: dict[str, dict[str, Any]] = {}
        shapes: dict[str, tuple[str, str]] = {}  # template -> (base component, shape)
        instances: dict[str, dict[str, Any]] = {}
        taken_t: set[str] = set()
        for i, a in enumerate(self.autos):
            tpl = self.template(i, roles[i], labels[i], empty.get(i, set()))
            shape = (a.inst.base.id, _shape(tpl))
            found = next((t for t, other in shapes.items() if other == shape), None)
            inst: dict[str, Any] = {"template": found}
            if found is None:
                found = _hybrid_name(a.inst.base.id, taken_t)
                templates[found] = tpl
                shapes[found] = shape
                inst["template"] = found
            else:
                _differences(templates[found], tpl, inst)
            renamed = {f: g for f, g in labels[i].items() if g is not None and g != f}
            if renamed:
                inst["labels"] = renamed
            connect = {}
            for f, r in roles[i].items():
                if r.kind == "input":
                    connect[self.tnames[i][f]] = names[r.flat]
            if connect:
                inst["connect"] = connect
            instances[self.inst_names[i]] = inst
        problem = self.imp.problem
        doc: dict[str, Any] = {"name": self.model.name, "description": self.model.description,
                               "templates": templates, "instances": instances}
        if problem.t_end is not None:
            doc["scenarios"] = {"default": {"t_end": problem.t_end}}
        modes = {flat: SEPARATOR.join(
            f"{self.inst_names[i]}.{_location_names(self.autos[i])[lid]}"
            for i, lid in enumerate(combo)) for combo, flat in self.imp.modes.items()}
        return doc, names, modes

    def unguarded(self) -> dict[int, set[int]]:
        """Transitions that keep an empty guard (``0 <= 0``): those whose partners in
        some synchronisation have no guard either (an event needs one)."""
        empty: dict[str, list[tuple[int, int]]] = {}
        users: dict[str, set[int]] = {}
        for i, a in enumerate(self.autos):
            for k, (_, _, label, guard, *_) in enumerate(a.transitions):
                if label:
                    users.setdefault(label, set()).add(i)
                    if not guard:
                        empty.setdefault(label, []).append((i, k))
        out: dict[int, set[int]] = {}
        for label, pairs in empty.items():
            if {i for i, _ in pairs} == users[label]:
                for i, k in pairs:
                    out.setdefault(i, set()).add(k)
        return out


def _free(atom: Atom) -> set[Any]:
    """The symbols of a relation."""
    return set((atom.lhs.expr - atom.rhs.expr).free_symbols)  # type: ignore[operator]


def _formal_label(a: _Automaton, label: str) -> str:
    return next(f for f, g in a.inst.labels.items() if g == label)


def _label_name(label: str, taken: set[str]) -> str:
    name = label.replace(".", "_")
    while name in taken:
        name += "_"
    taken.add(name)
    return name


def _location_names(a: _Automaton) -> dict[str, str]:
    out: dict[str, str] = {}
    for lid, loc in a.inst.base.locations.items():
        if SEPARATOR in loc.name:
            raise _Flat(f"location '{loc.name}' of '{a.inst.base.id}' has a '{SEPARATOR}' in "
                        "its name")
        name = loc.name
        while name in out.values():
            name += "_"
        out[lid] = name
    return out


def _shape(tpl: Mapping[str, Any]) -> Any:
    """A template less its values (parameters, initial values and mode): what instances
    of one template share."""
    out = dict(tpl)
    out["parameters"] = sorted(tpl.get("parameters", {}))
    out["states"] = sorted(tpl["states"])
    out.pop("initial")
    return repr(sorted(out.items(), key=lambda kv: kv[0]))


def _differences(tpl: Mapping[str, Any], mine: Mapping[str, Any], inst: dict[str, Any]) -> None:
    """The values an instance gives that differ from its template's."""
    params = {k: v for k, v in mine.get("parameters", {}).items()
              if tpl["parameters"][k] != v}
    initial = {k: v for k, v in mine["states"].items() if tpl["states"][k] != v}
    if params:
        inst["parameters"] = params
    if initial:
        inst["initial"] = initial
    if mine["initial"] != tpl["initial"]:
        inst["mode"] = mine["initial"]["mode"]


# ---------------------------------------------------------------------------- checks, text

def _same_product(flat: Model, product: Model, names: Mapping[str, str],
                  modes: Mapping[str, str]) -> None:
    """The components' product has the flat product's modes, and from each mode the same
    transitions in the same order (guards and resets come from the same XML)."""
    if {names[s] for s in flat.state_names} != set(product.state_names):
        raise _Flat("the components' product has other states")
    missing = [m for m in flat.modes if modes[m] not in product.modes]
    if missing:
        raise _Flat(f"mode '{missing[0]}' is reached only from another initial location")

    def moves(model: Model, mode: str) -> list[tuple[str, int]]:
        names = list(model.modes)
        out = []
        for tr in model.transitions:
            patterns = [tr.source] if isinstance(tr.source, str) else tr.source
            if tr.source == "*" or any(mode in match_modes(p, names) for p in patterns):
                out.append((mode_target(mode, tr.target), len(tr.reset)))
        return out

    for m in flat.modes:
        expected = [(modes[t], n) for t, n in moves(flat, m)]
        if expected != moves(product, modes[m]):
            raise _Flat(f"the transitions from mode '{m}' differ in the components' product")


def _renamed(problem: SpaceExProblem, names: Mapping[str, str], modes: Mapping[str, str],
             renamed: Mapping[str, str]) -> SpaceExProblem:
    """The problem's sets and names in the components' names (for the header)."""

    def relations(cs: ConstraintSet) -> ConstraintSet:
        kept = None if cs.modes is None else frozenset(modes[m] for m in cs.modes)
        return replace(cs, relations=tuple(rename(r, names) for r in cs.relations), modes=kept)

    initial: Any = problem.initial
    if isinstance(initial, ConstraintSet):
        initial = relations(initial)
    else:
        initial = {names.get(k, k): v for k, v in initial.items()}
    return replace(problem, initial=initial,
                   initial_modes=tuple(modes[m] for m in problem.initial_modes),
                   params={names.get(k, k): v for k, v in problem.params.items()},
                   inputs={names.get(k, k): v for k, v in problem.inputs.items()},
                   forbidden=tuple(relations(f) for f in problem.forbidden),
                   renamed=renamed)


def _dumps_network(doc: Mapping[str, Any]) -> str:
    lines = [f"name = {_toml_value(doc['name'])}"]
    if doc.get("description"):
        lines.append(f"description = {_toml_value(doc['description'])}")
    for name, tpl in doc["templates"].items():
        head = f"templates.{_toml_key(name)}"
        lines.append(f"\n[{head}]")
        for key in ("parameters", "inputs", "states", "initial"):
            if key in tpl:
                lines.append(f"{key} = {_toml_value(tpl[key])}")
        for mode, entry in tpl["modes"].items():
            lines.extend(f"modes.{_toml_key(mode)}.{k} = {_toml_value(v)}"
                         for k, v in entry.items())
        if tpl.get("transitions"):  # one line each, as a table would show them
            lines.append("transitions = [")
            lines.extend(f"  {_toml_value(tr)}," for tr in tpl["transitions"])
            lines.append("]")
    for name, inst in doc["instances"].items():
        lines.append(f"\n[instances.{_toml_key(name)}]")
        lines.extend(f"{k} = {_toml_value(v)}" for k, v in inst.items())
    for name, sc in doc.get("scenarios", {}).items():
        lines.append(f"\n[scenarios.{_toml_key(name)}]")
        lines.extend(f"{k} = {_toml_value(v)}" for k, v in sc.items())
    return "\n".join(lines) + "\n"

