"""Import SpaceEx models (XML + ``.cfg``) as hybridlab models and verification problems.

SpaceEx's format is the interchange format of SpaceEx, Hylaa, JuliaReach and HyST.
:func:`load_spaceex` reads a model file, flattens its network (``<bind>``/``<map>``),
builds the parallel composition of its automata (product of locations, synchronisation
on shared labels), translates every constraint through a token whitelist into
hybridlab's expression language, and reads the ``.cfg`` (initial set, forbidden set,
time horizon, sampling time, iteration bound). The result is a :class:`SpaceExProblem`
whose ``model`` is an ordinary :class:`hybridlab.Model`.

Semantics (see ``docs/spaceex.md``): SpaceEx transitions are *may* transitions; the
imported model keeps every guard as written, and hybridlab's simulator takes a
transition at the first instant its guard holds. Each hybridlab run is therefore one of
the runs of the SpaceEx automaton (when the invariants allow the jump), so a simulated
counterexample is a counterexample of the SpaceEx model too.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NoReturn

import numpy as np
import sympy as sp

from hybridlab._files import read_bounded
from hybridlab.errors import ExpressionError
from hybridlab.io._sxcfg import cfg_number, parse_cfg
from hybridlab.io._sxexpr import Atom, parse_conjunction, split_disjunction
from hybridlab.io._sxflatten import Instance, flatten
from hybridlab.io._sxxml import (
    BaseComponent,
    NetworkComponent,
    SpaceExError,
    read_components,
)
from hybridlab.model.expressions import check_name
from hybridlab.model.loader import model_from_dict
from hybridlab.model.schema import Model

__all__ = ["SpaceExError", "SpaceExOptions", "ConstraintSet", "SpaceExProblem",
           "SpaceExImport", "load_spaceex", "loads_spaceex", "import_spaceex", "read_spaceex"]

_MAX_MODES = 2000


@dataclass(frozen=True)
class ConstraintSet:
    """A conjunction of inequalities over the model's states, optionally in some modes.

    Used for the forbidden sets and for an initial set that is not a box.

    Attributes
    ----------
    relations : tuple of str
        The inequalities in hybridlab syntax (``"x >= 10.7"``); an equality of the
        SpaceEx text appears as two inequalities.
    A, b : numpy.ndarray or None
        ``A x <= b`` over the states in model order when every inequality is linear
        (strict ones are closed), else ``None``.
    modes : frozenset of str or None
        The modes the set is restricted to (from ``loc(...) == name``); ``None`` is all.

    Examples
    --------
    >>> s = ConstraintSet(("x >= 1",), np.array([[-1.0]]), np.array([-1.0]))
    >>> s.contains(np.array([2.0])), s.contains(np.array([0.0]))
    (True, False)
    """

    relations: tuple[str, ...]
    A: np.ndarray | None = None
    b: np.ndarray | None = None
    modes: frozenset[str] | None = None

    def contains(self, x: np.ndarray, mode: str | None = None) -> bool:
        """Whether the state ``x`` (model order) lies in the set (linear sets only)."""
        if self.A is None or self.b is None:
            raise ValueError("contains: the set is not linear")
        if mode is not None and self.modes is not None and mode not in self.modes:
            return False
        return bool(np.all(self.A @ np.asarray(x, float) <= self.b + 1e-12))

    def to_polytope(self) -> Any:
        """The set as a ``hybridlab.reachability.sets.Polytope`` (linear sets only)."""
        from hybridlab.reachability.sets import Polytope

        if self.A is None or self.b is None:
            raise ValueError("to_polytope: the set is not linear")
        return Polytope(self.A, self.b)


@dataclass(frozen=True)
class SpaceExOptions:
    """Analysis settings from the ``.cfg``.

    Attributes
    ----------
    time_step : float or None
        ``sampling-time``: SpaceEx's time step, used as the reachability time step.
    max_jumps : int or None
        ``iter-max`` (or ``max-iterations``): SpaceEx's bound on discrete iterations,
        used as the bound on jumps; ``None`` when absent or negative (unbounded).
    scenario : str
        SpaceEx's algorithm (``supp``, ``stc``, ``phaver``); informative only.
    output_variables : tuple of str
        hybridlab names of ``output-variables``.
    settings : dict of str to str
        Every key of the ``.cfg`` as written.

    Examples
    --------
    >>> p = load_spaceex("models/spaceex/bouncing_ball.xml",
    ...                  "models/spaceex/bouncing_ball.cfg")
    >>> opts = p.options
    >>> opts.time_step, opts.max_jumps, opts.scenario, opts.output_variables
    (0.05, 10, 'supp', ('x', 'v'))
    >>> opts.settings["directions"]
    'oct'
    >>> SpaceExOptions().max_jumps is None  # no .cfg: unbounded
    True
    """

    time_step: float | None = None
    max_jumps: int | None = None
    scenario: str = ""
    output_variables: tuple[str, ...] = ()
    settings: Mapping[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class SpaceExProblem:
    """A SpaceEx model with its configuration, ready for ``simulate``/``reach``/verification.

    Attributes
    ----------
    model : hybridlab.Model
        The automaton; states start at the centre of the initial set, the initial mode
        is the first initial location, scenario ``default`` has the time horizon.
    initial : dict of str to (float, float), or ConstraintSet
        The initial set: per-state intervals when it is a box, else the linear
        constraints ``A x <= b``.
    initial_modes : tuple of str
        Every initial mode (all locations of an automaton whose location the ``.cfg``
        leaves open).
    params : dict of str to float or (float, float)
        Constants fixed or bounded by the ``initially`` constraint (an interval is an
        uncertain constant parameter).
    inputs : dict of str to (float, float)
        Variables with no flow, bounded by the invariants: inputs that vary in time
        within bounds (model parameters valued at the midpoint).
    forbidden : tuple of ConstraintSet
        The ``forbidden`` set, one entry per disjunct.
    t_end : float or None
        ``time-horizon``.
    options : SpaceExOptions
    source : tuple of str
        The model file and, if given, the ``.cfg``.
    renamed : dict of str to str
        SpaceEx names that had to change (``t`` is hybridlab's time symbol, dots of
        hierarchical names become ``_``).

    Examples
    --------
    >>> p = load_spaceex("models/spaceex/bouncing_ball.xml",
    ...                  "models/spaceex/bouncing_ball.cfg")
    >>> p.model.state_names, p.model.parameters["c"].value, p.initial_modes
    (('x', 'v'), 0.75, ('always',))
    >>> p.initial, p.t_end
    ({'x': (10.0, 10.2), 'v': (0.0, 0.0)}, 20.0)
    >>> p.forbidden[0].relations, p.params, p.inputs, p.renamed
    (('x >= 10.25',), {}, {}, {})
    """

    model: Model
    initial: Mapping[str, tuple[float, float]] | ConstraintSet
    initial_modes: tuple[str, ...]
    params: Mapping[str, float | tuple[float, float]]
    inputs: Mapping[str, tuple[float, float]]
    forbidden: tuple[ConstraintSet, ...]
    t_end: float | None
    options: SpaceExOptions
    source: tuple[str, ...]
    renamed: Mapping[str, str]

    def safe_specs(self) -> tuple[Any, ...]:
        """The forbidden set as ``hybridlab.verify.Avoid`` regions (one per disjunct).

        Examples
        --------
        >>> p = load_spaceex("models/spaceex/bouncing_ball.xml",
        ...                  "models/spaceex/bouncing_ball.cfg")
        >>> [a.name for a in p.safe_specs()]
        ['forbidden: x >= 10.25']
        """
        from hybridlab.reachability.spec import Avoid

        out = []
        for f in self.forbidden:
            if f.A is None:
                raise ValueError(f"safe_specs: forbidden set {' and '.join(f.relations)!r} is "
                                 "not linear")
            modes = tuple(sorted(f.modes)) if f.modes is not None else None
            out.append(Avoid(polytope=(f.A, f.b), modes=modes,
                             name="forbidden: " + " and ".join(f.relations)))
        return tuple(out)

    def reach_kwargs(self) -> dict[str, Any]:
        """Keyword arguments for ``hybridlab.reach`` / ``hybridlab.verify.check_safety``.

        The initial set, mode (the first initial mode), horizon, uncertain constants,
        inputs, and the ``.cfg``'s sampling time and iteration bound as ``step`` and
        ``max_jumps``.

        Examples
        --------
        >>> p = load_spaceex("models/spaceex/bouncing_ball.xml",
        ...                  "models/spaceex/bouncing_ball.cfg")
        >>> sorted(p.reach_kwargs())
        ['initial', 'max_jumps', 'mode', 'step', 't_end']
        """
        initial: Any = self.initial
        if isinstance(initial, ConstraintSet):
            initial = initial.to_polytope()
        out: dict[str, Any] = {"initial": initial, "mode": self.initial_modes[0]}
        if self.t_end is not None:
            out["t_end"] = self.t_end
        uncertain = {k: v for k, v in self.params.items() if isinstance(v, tuple)}
        if uncertain:
            out["params"] = uncertain
        if self.inputs:
            out["inputs"] = dict(self.inputs)
        if self.options.time_step is not None:
            out["step"] = self.options.time_step
        if self.options.max_jumps is not None:
            out["max_jumps"] = self.options.max_jumps
        return out


# ---------------------------------------------------------------------------- names

def _hybrid_name(raw: str, taken: set[str]) -> str:
    """A hybridlab name for a SpaceEx name: dots become ``_``, reserved names get ``_``."""
    base = "".join(ch if ch.isalnum() or ch == "_" else "_" for ch in raw.replace(".", "_"))
    if not base or not base.isascii() or not base[0].isalpha():
        base = "v" + base
    name = base
    while True:
        try:
            check_name(name)
        except ExpressionError:
            name += "_"
            continue
        if name in taken:
            name += "_"
            continue
        break
    taken.add(name)
    return name


# ---------------------------------------------------------------------------- parsing

@dataclass
class _Ctx:
    source: str
    cfg_source: str
    names: dict[str, str]  # global SpaceEx name -> hybridlab name (for the cfg)
    symbols: dict[str, sp.Expr]
    states: list[str]
    constants: list[str]


def _fail(source: str, key: str, message: str, token: str = "") -> NoReturn:
    raise SpaceExError(message, key=key, token=token, source=source)


def _atoms(text: str, names: Mapping[str, str], symbols: Mapping[str, sp.Expr], source: str,
           key: str, **kw: bool) -> list[Atom]:
    try:
        return parse_conjunction(text, names, symbols, **kw)
    except ExpressionError as exc:
        _fail(source, key, exc.message, exc.token)


def _relations(atoms: list[Atom], source: str, key: str) -> list[str]:
    out = []
    for a in atoms:
        if a.op == ":=":
            _fail(source, key, "':=' is only allowed in assignments", ":=")
        if a.op == "==":
            out += [f"{a.lhs.text} <= {a.rhs.text}", f"{a.lhs.text} >= {a.rhs.text}"]
        else:
            out.append(f"{a.lhs.text} {a.op} {a.rhs.text}")
    return out


#: a component transition: source and target location ids, synchronisation label (``""``:
#: none), guard relations, reset (variable -> expression), urgent (asap), XML path
_Transition = tuple[str, str, str, list[str], dict[str, str], bool, str]


@dataclass
class _Automaton:
    inst: Instance
    names: dict[str, str]
    flows: dict[str, dict[str, str]]  # location id -> state -> rhs
    invariants: dict[str, list[Atom]]
    transitions: list[_Transition]


def _automaton(inst: Instance, names: dict[str, str], ctx: _Ctx) -> _Automaton:
    src, sym = ctx.source, ctx.symbols
    flows: dict[str, dict[str, str]] = {}
    invariants: dict[str, list[Atom]] = {}
    for lid, loc in inst.base.locations.items():
        flow: dict[str, str] = {}
        for a in _atoms(loc.flow, names, sym, src, loc.path + "/flow", allow_prime=True):
            var = a.lhs.primed
            if var is None or a.op != "==" or a.rhs.primed is not None:
                _fail(src, loc.path + "/flow", "a flow must be a conjunction of x' == expr "
                      "(differential inclusions are not supported)", a.text)
            if var in ctx.constants:
                if a.rhs.expr != 0:
                    _fail(src, loc.path + "/flow", "a constant can only have the flow 0",
                          a.text)
                continue
            if var in flow:
                _fail(src, loc.path + "/flow", "two flows for one variable", a.text)
            flow[var] = a.rhs.text
        flows[lid] = flow
        invariants[lid] = _atoms(loc.invariant, names, sym, src, loc.path + "/invariant")
    transitions = []
    for tr in inst.base.transitions:
        guard = _relations(_atoms(tr.guard, names, sym, src, tr.path + "/guard"), src,
                           tr.path + "/guard")
        reset: dict[str, str] = {}
        for a in _atoms(tr.assignment, names, sym, src, tr.path + "/assignment",
                        allow_prime=True):
            var = a.lhs.primed if a.op == "==" else a.lhs.text if a.op == ":=" else None
            if var is None or var not in ctx.states or a.rhs.primed is not None:
                _fail(src, tr.path + "/assignment", "an assignment must be x' == expr or "
                      "x := expr for a variable x (non-deterministic resets are not "
                      "supported)", a.text)
            if var in reset:
                _fail(src, tr.path + "/assignment", "two assignments to one variable", a.text)
            reset[var] = a.rhs.text
        label = inst.labels.get(tr.label, "") if tr.label else ""
        transitions.append((tr.source, tr.target, label, guard, reset, tr.asap, tr.path))
    return _Automaton(inst, names, flows, invariants, transitions)


# ---------------------------------------------------------------------------- the cfg sets

def _linear_rows(atoms: list[Atom], ctx: _Ctx, values: Mapping[str, float], key: str
                 ) -> tuple[list[np.ndarray], list[float], bool]:
    """Rows ``a . x <= b`` of atoms over the states; ``linear`` is False if one is not."""
    state_syms = [ctx.symbols[s] for s in ctx.states]
    subs = {ctx.symbols[p]: v for p, v in values.items()}
    rows: list[np.ndarray] = []
    rhs: list[float] = []
    linear = True
    for a in atoms:
        if a.lhs.expr is None or a.rhs.expr is None:
            continue
        diff = sp.expand((a.lhs.expr - a.rhs.expr).subs(subs))
        unknown = diff.free_symbols - set(state_syms)
        if unknown:
            _fail(ctx.cfg_source, key, "constraint uses a constant whose value is not fixed",
                  str(sorted(map(str, unknown))[0]))
        signs = {"<=": [1.0], "<": [1.0], ">=": [-1.0], ">": [-1.0], "==": [1.0, -1.0]}
        if a.op not in signs:
            _fail(ctx.cfg_source, key, "only comparisons are allowed here", a.op)
        try:
            poly = sp.Poly(diff, *state_syms)
            ok = poly.total_degree() <= 1
        except sp.PolynomialError:
            ok = False
        if not ok:
            linear = False
            continue
        coeffs = np.array([float(diff.coeff(s)) for s in state_syms])
        const = float(diff.subs({s: 0 for s in state_syms}))
        for sign in signs[a.op]:
            rows.append(sign * coeffs)
            rhs.append(-sign * const)
    return rows, rhs, linear


def _loc_atoms(atoms: list[Atom], autos: list[_Automaton], system: str, ctx: _Ctx, key: str
               ) -> dict[int, str]:
    """``loc(X) == name`` atoms -> automaton index -> location id."""
    out: dict[int, str] = {}
    multi = [i for i, a in enumerate(autos) if len(a.inst.base.locations) > 1]
    for a in atoms:
        side, other = (a.lhs, a.rhs) if a.lhs.loc is not None else (a.rhs, a.lhs)
        if side.loc is None:
            continue
        arg = side.loc
        hits = [i for i, au in enumerate(autos)
                if arg and (au.inst.name == arg or au.inst.name.endswith("." + arg))]
        if not hits and (not arg or arg == system) and len(autos) == 1:
            hits = [0]
        if not hits and not arg and len(multi) == 1:
            hits = multi
        if len(hits) != 1:
            _fail(ctx.cfg_source, key, "loc(...) names no single automaton of the system",
                  f"loc({arg})")
        i = hits[0]
        by_name = {loc.name: lid for lid, loc in autos[i].inst.base.locations.items()}
        if other.bare not in by_name:
            _fail(ctx.cfg_source, key, f"automaton '{autos[i].inst.name}' has no location of "
                  "this name", other.bare or "")
        lid = by_name[other.bare]
        if out.get(i, lid) != lid:
            _fail(ctx.cfg_source, key, "two different locations for one automaton",
                  other.bare or "")
        out[i] = lid
    return out


# ---------------------------------------------------------------------------- product

def _mode_name(autos: list[_Automaton], combo: tuple[str, ...]) -> str:
    parts = [a.inst.base.locations[lid].name for a, lid in zip(autos, combo, strict=True)
             if len(a.inst.base.locations) > 1]
    return ".".join(parts) if parts else autos[0].inst.base.locations[combo[0]].name


def _product(autos: list[_Automaton], starts: list[tuple[str, ...]], ctx: _Ctx
             ) -> tuple[dict[tuple[str, ...], str], list[dict[str, Any]]]:
    alphabets = [set(a.inst.labels.values()) for a in autos]
    modes: dict[tuple[str, ...], str] = {}
    queue = list(starts)
    edges: list[tuple[tuple[str, ...], tuple[str, ...], str, list[str], dict[str, str],
                      bool, str]] = []
    seen = set(queue)
    while queue:
        combo = queue.pop(0)
        if len(seen) > _MAX_MODES:
            _fail(ctx.source, "component", f"the product has more than {_MAX_MODES} "
                  "locations", str(len(seen)))
        moves: list[tuple[list[tuple[int, _Transition]], str]] = []
        for i, au in enumerate(autos):
            for tr in au.transitions:
                src, _, label, _, _, _, _ = tr
                if src != combo[i]:
                    continue
                parts = [j for j, alpha in enumerate(alphabets) if label and label in alpha]
                if label and parts[0] != i:
                    continue  # generated from the first participant
                if not label or len(parts) == 1:
                    moves.append(([(i, tr)], label))
                    continue
                options = [[(j, t) for t in autos[j].transitions
                            if t[0] == combo[j] and t[2] == label] for j in parts[1:]]
                for rest in itertools.product(*options):
                    moves.append(([(i, tr), *rest], label))
        for moved, label in moves:
            target = list(combo)
            guard: list[str] = []
            reset: dict[str, str] = {}
            asap = False
            for j, (_, dst, _, g, r, a, path) in moved:
                target[j] = dst
                guard += g
                asap |= a
                for var, rhs in r.items():
                    if var in reset:
                        _fail(ctx.source, path + "/assignment", "two synchronised "
                              "transitions assign the same variable", var)
                    reset[var] = rhs
            tgt = tuple(target)
            edges.append((combo, tgt, label, guard, reset, asap, moved[0][1][6]))
            if tgt not in seen:
                seen.add(tgt)
                queue.append(tgt)
    for combo in sorted(seen, key=lambda c: (c not in starts, starts.index(c)
                                             if c in starts else 0, c)):
        name = _mode_name(autos, combo)
        while name in modes.values():
            name += "_"
        modes[combo] = name
    transitions = []
    used: dict[str, int] = {}
    for combo, tgt, label, guard, reset, _asap, _path in edges:
        base = label.replace(".", "_") if label else "tau"
        used[base] = used.get(base, 0) + 1
        name = base if used[base] == 1 else f"{base}_{used[base]}"
        item: dict[str, Any] = {"name": name, "source": modes[combo], "target": modes[tgt],
                                "guard": guard or ["0 <= 0"]}
        if reset:
            item["reset"] = reset
        transitions.append(item)
    return modes, transitions


# ---------------------------------------------------------------------------- main

def _default_system(components: dict[str, BaseComponent | NetworkComponent]) -> str:
    bound = {b.component for c in components.values() if isinstance(c, NetworkComponent)
             for b in c.binds}
    roots = [cid for cid in components if cid not in bound]
    return roots[-1] if roots else list(components)[-1]


@dataclass(frozen=True)
class SpaceExImport:
    """What an import built on the way to its product, for writing it as components.

    Attributes
    ----------
    problem : SpaceExProblem
        What :func:`loads_spaceex` returns.
    system : str
        The component imported.
    automata : list
        One parsed automaton per base instance, in the network's order, its expressions
        in the product's (global hybridlab) names.
    fixed : dict of (str, str) to str
        (instance path, formal) -> the product parameter a number of a ``<map>`` became.
    values : dict of str to float
        Every product parameter's value (constants, numbers of maps, inputs' midpoints).
    starts : list of tuple of str
        The initial location ids, one tuple per initial product mode, the first the model's.
    modes : dict of tuple of str to str
        Location ids per automaton -> product mode name.

    Examples
    --------
    >>> import pathlib
    >>> imp = import_spaceex(pathlib.Path("models/spaceex/two_rooms.xml").read_bytes())
    >>> len(imp.automata), imp.problem.model.name == imp.system
    (3, True)
    """

    problem: SpaceExProblem
    system: str
    automata: list[_Automaton]
    fixed: Mapping[tuple[str, str], str]
    values: Mapping[str, float]
    starts: list[tuple[str, ...]]
    modes: Mapping[tuple[str, ...], str]


def loads_spaceex(xml: str | bytes, cfg: str | None = None, *, source: str = "<string>",
                  cfg_source: str = "<cfg>", system: str | None = None) -> SpaceExProblem:
    """Import SpaceEx model text (and ``.cfg`` text); see :func:`load_spaceex`.

    Examples
    --------
    >>> xml = '''<sspaceex version="0.2" math="SpaceEx"><component id="clock">
    ...   <param name="t" type="real" local="false" d1="1" d2="1" dynamics="any"/>
    ...   <location id="1" name="run"><invariant>t &lt;= 2</invariant>
    ...     <flow>t' == 1</flow></location></component></sspaceex>'''
    >>> p = loads_spaceex(xml, 'initially = "t == 0"\\ntime-horizon = 2')
    >>> p.model.state_names, p.renamed, p.t_end
    (('t_',), {'t': 't_'}, 2.0)
    """
    return import_spaceex(xml, cfg, source=source, cfg_source=cfg_source,
                          system=system).problem


def import_spaceex(xml: str | bytes, cfg: str | None = None, *, source: str = "<string>",
                   cfg_source: str = "<cfg>", system: str | None = None) -> SpaceExImport:
    """:func:`loads_spaceex` with what it built on the way (see :class:`SpaceExImport`).

    Examples
    --------
    >>> import pathlib
    >>> imp = import_spaceex(pathlib.Path("models/spaceex/bouncing_ball.xml").read_bytes())
    >>> imp.system, [a.inst.name for a in imp.automata], imp.fixed[("ball_1", "g")]
    ('system', ['ball_1'], 'g')
    """
    data = xml.encode("utf-8") if isinstance(xml, str) else xml
    components = read_components(data, source)
    settings = parse_cfg(cfg, cfg_source) if cfg is not None else {}
    system = system or settings.get("system", "").strip() or _default_system(components)
    instances = flatten(components, system, source)

    # global variables and constants, in order of appearance
    dynamics: dict[str, set[str]] = {}
    numeric: dict[str, set[float]] = {}
    for inst in instances:
        for formal, ref in inst.vars.items():
            if isinstance(ref, float):
                numeric.setdefault(formal, set()).add(ref)
            else:
                dynamics.setdefault(ref, set()).add(inst.base.params[formal].dynamics)
    taken: set[str] = set()
    names = {g: _hybrid_name(g, taken) for g in dynamics}
    renamed = {g: h for g, h in names.items() if g != h}
    fixed: dict[tuple[str, str], str] = {}
    param_values: dict[str, float] = {}
    for inst in instances:
        for formal, ref in inst.vars.items():
            if not isinstance(ref, float):
                continue
            # one parameter per formal name when every instance fixes it to the same number
            shared = len(numeric[formal]) == 1 and formal not in dynamics
            key = formal if shared else f"{inst.name}.{formal}"
            existing = [h for (_, f), h in fixed.items() if shared and f == formal]
            hname = existing[0] if existing else _hybrid_name(key, taken)
            fixed[(inst.name, formal)] = hname
            param_values[hname] = ref
    constants = [names[g] for g, d in dynamics.items() if d == {"const"}]
    states = [names[g] for g, d in dynamics.items() if d != {"const"}]
    symbols: dict[str, sp.Expr] = {h: sp.Symbol(h, real=True) for h in taken}
    ctx = _Ctx(source, cfg_source, names, symbols, states, constants)

    autos = []
    for inst in instances:
        local = {f: (fixed[(inst.name, f)] if isinstance(r, float) else names[r])
                 for f, r in inst.vars.items()}
        autos.append(_automaton(inst, local, ctx))

    # inputs: non-constant variables that no location gives a flow
    has_flow = {v for a in autos for f in a.flows.values() for v in f}
    input_names = [s for s in states if s not in has_flow]
    for a in autos:
        for _, _, _, _, reset, _, path in a.transitions:
            for var in reset:
                if var in input_names:
                    _fail(source, path + "/assignment", "an input (a variable without flow) "
                          "cannot be assigned", var)
    states = [s for s in states if s not in input_names]
    ctx.states = states

    # the cfg: initially
    params: dict[str, float | tuple[float, float]] = {}
    init_atoms = _atoms(settings.get("initially", ""), names, symbols, cfg_source,
                        "initially", allow_loc=True)
    loc_init = _loc_atoms(init_atoms, autos, system, ctx, "initially")
    lo_p: dict[str, float] = {}
    hi_p: dict[str, float] = {}
    state_atoms = []
    state_set = {symbols[s] for s in states}
    for atom in init_atoms:
        if atom.lhs.expr is None or atom.rhs.expr is None:
            continue
        free = (atom.lhs.expr - atom.rhs.expr).free_symbols
        if free & state_set or not free:
            state_atoms.append(atom)
            continue
        _constant_bound(atom, ctx, lo_p, hi_p)
    for c in constants:
        if c in lo_p and c in hi_p:
            params[c] = lo_p[c] if lo_p[c] == hi_p[c] else (lo_p[c], hi_p[c])
        elif c in lo_p or c in hi_p:
            _fail(cfg_source, "initially", "constant is bounded on one side only", c)
        else:
            _fail(cfg_source, "initially", "constant has no value (map it to a number in a "
                  "<bind> or give 'c == value' in the initially set)", c)
    point = {c: (v if isinstance(v, float) else 0.5 * (v[0] + v[1])) for c, v in params.items()}
    point.update(param_values)
    initial, centre = _initial_set(state_atoms, ctx, point, settings)

    # inputs: bounds from the invariants
    inputs = _input_bounds(autos, input_names, ctx, point)
    point.update({u: 0.5 * (lo + hi) for u, (lo, hi) in inputs.items()})

    starts_per = [[loc_init[i]] if i in loc_init else list(a.inst.base.locations)
                  for i, a in enumerate(autos)]
    starts = [tuple(c) for c in itertools.product(*starts_per)]
    modes, transitions = _product(autos, starts, ctx)
    mode_dicts = _mode_dicts(autos, modes, states, input_names, ctx)

    forbidden = _forbidden(settings.get("forbidden", ""), autos, modes, system, ctx, point)
    t_end = cfg_number(settings, "time-horizon", cfg_source)
    step = cfg_number(settings, "sampling-time", cfg_source)
    iters = None
    for key in ("iter-max", "max-iterations"):
        value = cfg_number(settings, key, cfg_source, integer=True, positive=False)
        if value is not None:
            iters = int(value) if value >= 0 else None
    outputs = tuple(names.get(v.strip(), v.strip())
                    for v in settings.get("output-variables", "").split(",") if v.strip())
    options = SpaceExOptions(step, iters, settings.get("scenario", "").strip(), outputs,
                             dict(settings))

    data_model: dict[str, Any] = {
        "name": Path(source).stem if source.endswith(".xml") else system,
        "description": f"imported from SpaceEx ({Path(source).name}, component '{system}')",
        "parameters": {p: {"value": v} for p, v in point.items()},
        "states": {s: {"initial": centre[s]} for s in states},
        "modes": mode_dicts,
        "transitions": transitions,
        "initial": {"mode": modes[starts[0]]},
    }
    if t_end is not None:
        data_model["scenarios"] = {"default": {"t_end": t_end}}
    model = model_from_dict(data_model, source=source)
    problem = SpaceExProblem(model, initial, tuple(modes[s] for s in starts),
                             {c: v for c, v in params.items()}, inputs, forbidden, t_end,
                             options, (source,) if cfg is None else (source, cfg_source),
                             renamed)
    return SpaceExImport(problem, system, autos, fixed, point, starts, modes)


def _constant_bound(a: Atom, ctx: _Ctx, lo: dict[str, float], hi: dict[str, float]) -> None:
    diff = sp.expand(a.lhs.expr - a.rhs.expr)  # type: ignore[operator]  # both parsed
    free = sorted(diff.free_symbols, key=str)
    if len(free) != 1 or str(free[0]) not in ctx.constants:
        _fail(ctx.cfg_source, "initially", "a constraint on constants must bound one constant",
              a.text)
    c = free[0]
    coef = diff.coeff(c)
    if not coef.is_number or coef == 0 or sp.expand(diff - coef * c).free_symbols:
        _fail(ctx.cfg_source, "initially", "a constraint on constants must be linear", a.text)
    value = float(-(diff - coef * c) / coef)
    op = a.op
    if float(coef) < 0:
        op = {"<=": ">=", "<": ">", ">=": "<=", ">": "<", "==": "=="}[op]
    name = str(c)
    if op in ("==", ">=", ">"):
        lo[name] = max(lo.get(name, -np.inf), value)
    if op in ("==", "<=", "<"):
        hi[name] = min(hi.get(name, np.inf), value)
    if lo.get(name, -np.inf) > hi.get(name, np.inf):
        _fail(ctx.cfg_source, "initially", "the constraints on this constant are "
              "contradictory", name)


def _initial_set(atoms: list[Atom], ctx: _Ctx, point: Mapping[str, float],
                 settings: Mapping[str, str]
                 ) -> tuple[dict[str, tuple[float, float]] | ConstraintSet, dict[str, float]]:
    n = len(ctx.states)
    if "initially" not in settings:  # no cfg set: every state at 0
        return {s: (0.0, 0.0) for s in ctx.states}, dict.fromkeys(ctx.states, 0.0)
    rows, rhs, linear = _linear_rows(atoms, ctx, point, "initially")
    if not linear:
        _fail(ctx.cfg_source, "initially", "the initial set must be given by linear "
              "constraints", next(a.text for a in atoms))
    A = np.array(rows, float).reshape(-1, n)
    b = np.array(rhs, float)
    lo, hi = _bounds_lp(A, b, ctx)
    if np.all(np.count_nonzero(A, axis=1) <= 1):
        box = {s: (float(lo[i]) + 0.0, float(hi[i]) + 0.0) for i, s in enumerate(ctx.states)}
        centre = {s: 0.5 * (lo_ + hi_) for s, (lo_, hi_) in box.items()}
        return box, centre
    relations = tuple(r for a in atoms for r in _relations([a], ctx.cfg_source, "initially"))
    centre_vec = _chebyshev_centre(A, b)
    return (ConstraintSet(relations, A, b),
            {s: float(centre_vec[i]) for i, s in enumerate(ctx.states)})


def _bounds_lp(A: np.ndarray, b: np.ndarray, ctx: _Ctx) -> tuple[np.ndarray, np.ndarray]:
    if np.all(np.count_nonzero(A, axis=1) <= 1):  # bounds on single variables: no LP
        return _axis_bounds(A, b, ctx)
    from scipy.optimize import linprog

    n = A.shape[1]
    lo, hi = np.empty(n), np.empty(n)
    for i in range(n):
        for sign, out in ((1.0, lo), (-1.0, hi)):
            c = np.zeros(n)
            c[i] = sign
            res = linprog(c, A_ub=A if len(A) else None, b_ub=b if len(A) else None,
                          bounds=[(None, None)] * n, method="highs")
            if res.status == 2:
                _fail(ctx.cfg_source, "initially", "the initial set is empty")
            if res.status == 3:
                _fail(ctx.cfg_source, "initially", "the initial set is unbounded in this "
                      "variable (constrain it)", ctx.states[i])
            out[i] = sign * res.fun
    return lo, hi


def _axis_bounds(A: np.ndarray, b: np.ndarray, ctx: _Ctx) -> tuple[np.ndarray, np.ndarray]:
    """The box of rows ``a_i x_j <= b`` that each constrain one variable (what an LP over
    them gives, with the same errors)."""
    n = A.shape[1]
    lo, hi = np.full(n, -np.inf), np.full(n, np.inf)
    for row, rhs in zip(A, b, strict=True):
        nonzero = np.flatnonzero(row)
        if not nonzero.size:
            if rhs < 0:  # 0 <= rhs fails
                _fail(ctx.cfg_source, "initially", "the initial set is empty")
            continue
        j = int(nonzero[0])
        if row[j] > 0:
            hi[j] = min(hi[j], rhs / row[j])
        else:
            lo[j] = max(lo[j], rhs / row[j])
    if np.any(lo > hi):
        _fail(ctx.cfg_source, "initially", "the initial set is empty")
    for j in range(n):
        if not (np.isfinite(lo[j]) and np.isfinite(hi[j])):
            _fail(ctx.cfg_source, "initially", "the initial set is unbounded in this "
                  "variable (constrain it)", ctx.states[j])
    return lo, hi


def _chebyshev_centre(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    from scipy.optimize import linprog

    n = A.shape[1]
    norms = np.linalg.norm(A, axis=1)
    c = np.zeros(n + 1)
    c[-1] = -1.0
    res = linprog(c, A_ub=np.hstack([A, norms[:, None]]), b_ub=b,
                  bounds=[(None, None)] * n + [(0, None)], method="highs")
    return np.asarray(res.x[:n])


def _input_bounds(autos: list[_Automaton], inputs: list[str], ctx: _Ctx,
                  point: Mapping[str, float]) -> dict[str, tuple[float, float]]:
    """Bounds of each input over all invariants that bound it by numbers (the hull)."""
    out: dict[str, tuple[float, float]] = {}
    for u in inputs:
        sym = ctx.symbols[u]
        subs = {ctx.symbols[p]: v for p, v in point.items()}
        lo, hi = np.inf, -np.inf
        for a in autos:
            for lid, atoms in a.invariants.items():
                l_, h_ = -np.inf, np.inf
                for atom in atoms:
                    if atom.lhs.expr is None or atom.rhs.expr is None:
                        continue
                    diff = sp.expand((atom.lhs.expr - atom.rhs.expr).subs(subs))
                    if sym not in diff.free_symbols:
                        continue
                    coef = diff.coeff(sym)
                    rest = diff - coef * sym
                    if rest.free_symbols or not coef.is_number or coef == 0:
                        _fail(ctx.source, a.inst.base.locations[lid].path + "/invariant",
                              "an input (a variable without flow) may only be bounded by "
                              "numbers", atom.text)
                    v = float(-rest / coef)
                    op = atom.op if float(coef) > 0 else {"<=": ">=", "<": ">", ">=": "<=",
                                                          ">": "<", "==": "=="}[atom.op]
                    if op in ("==", ">=", ">"):
                        l_ = max(l_, v)
                    if op in ("==", "<=", "<"):
                        h_ = min(h_, v)
                if np.isfinite(l_) and np.isfinite(h_):
                    lo, hi = min(lo, l_), max(hi, h_)
        if not (np.isfinite(lo) and np.isfinite(hi)):
            _fail(ctx.source, "component", "variable has no flow and no numeric bounds in the "
                  "invariants (give it a flow x' == expr, or bound it as an input)", u)
        out[u] = (float(lo), float(hi))
    return out


def _mode_dicts(autos: list[_Automaton], modes: Mapping[tuple[str, ...], str],
                states: list[str], inputs: list[str], ctx: _Ctx) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for combo, name in modes.items():
        flow: dict[str, str] = {}
        invariant: list[str] = []
        for a, lid in zip(autos, combo, strict=True):
            loc = a.inst.base.locations[lid]
            for var, rhs in a.flows[lid].items():
                if var in flow:
                    _fail(ctx.source, loc.path + "/flow", "two automata give a flow for the "
                          "same variable", var)
                flow[var] = rhs
            atoms = [at for at in a.invariants[lid]
                     if not ({ctx.symbols[u] for u in inputs}
                             & (at.lhs.expr - at.rhs.expr).free_symbols)]  # type: ignore[operator]
            invariant += _relations(atoms, ctx.source, loc.path + "/invariant")
        for s in states:
            if s not in flow:
                _fail(ctx.source, "component", f"variable has no flow in location '{name}' "
                      "(SpaceEx leaves it free there; hybridlab needs x' == expr)", s)
        entry: dict[str, Any] = {"flow": {s: flow[s] for s in states}}
        if invariant:
            entry["invariant"] = invariant
        out[name] = entry
    return out


def _forbidden(text: str, autos: list[_Automaton], modes: Mapping[tuple[str, ...], str],
               system: str, ctx: _Ctx, point: Mapping[str, float]) -> tuple[ConstraintSet, ...]:
    if not text.strip():
        return ()
    try:
        parts = split_disjunction(text)
    except ExpressionError as exc:
        _fail(ctx.cfg_source, "forbidden", exc.message, exc.token)
    out = []
    for part in parts:
        atoms = _atoms(part, ctx.names, ctx.symbols, ctx.cfg_source, "forbidden",
                       allow_loc=True)
        locs = _loc_atoms(atoms, autos, system, ctx, "forbidden")
        allowed = None
        if locs:
            allowed = frozenset(name for combo, name in modes.items()
                                if all(combo[i] == lid for i, lid in locs.items()))
        plain = [a for a in atoms if a.lhs.loc is None and a.rhs.loc is None]
        rows, rhs, linear = _linear_rows(plain, ctx, point, "forbidden")
        relations = tuple(_relations(plain, ctx.cfg_source, "forbidden"))
        n = len(ctx.states)
        A = np.array(rows, float).reshape(-1, n) if linear else None
        b = np.array(rhs, float) if linear else None
        out.append(ConstraintSet(relations, A, b, allowed))
    return tuple(out)


def load_spaceex(path: str | Path, cfg: str | Path | None = None, *,
                 system: str | None = None) -> SpaceExProblem:
    """Import a SpaceEx model file and, optionally, its ``.cfg``.

    Parameters
    ----------
    path : str or Path
        The SpaceEx XML model (``.xml``).
    cfg : str or Path, optional
        The configuration file. Without one, the system is the component no other
        component binds (the last such), every state starts at 0 and constants must be
        bound to numbers in the XML.
    system : str, optional
        The component to import; overrides the ``.cfg``'s ``system``.

    Returns
    -------
    SpaceExProblem

    Raises
    ------
    SpaceExError
        One line naming the file, the element (or ``.cfg`` key) and the token.

    Examples
    --------
    >>> import hybridlab
    >>> p = load_spaceex("models/spaceex/bouncing_ball.xml",
    ...                  "models/spaceex/bouncing_ball.cfg")
    >>> p.initial, p.t_end
    ({'x': (10.0, 10.2), 'v': (0.0, 0.0)}, 20.0)
    >>> r = hybridlab.simulate(p.model, 2.0)
    >>> round(float(r.final.state["x"]), 6)  # 10.1 - t**2/2
    8.1
    """
    data, cfg_text = read_spaceex(path, cfg)
    return loads_spaceex(data, cfg_text, source=str(path),
                         cfg_source=str(cfg) if cfg is not None else "<cfg>", system=system)


def read_spaceex(path: str | Path, cfg: str | Path | None = None) -> tuple[bytes, str | None]:
    """The bytes of a SpaceEx model file and the text of its ``.cfg`` (``None`` without one).

    Raises
    ------
    SpaceExError
        Naming the file that cannot be read.

    Examples
    --------
    >>> read_spaceex("models/spaceex/ball.xml")
    Traceback (most recent call last):
    ...
    hybridlab.io._sxxml.SpaceExError: models/spaceex/ball.xml: cannot read file: No such file ...
    """
    try:
        data = read_bounded(path)
    except OSError as exc:
        raise SpaceExError(f"cannot read file: {exc.strerror}", source=str(path)) from None
    cfg_text = None
    if cfg is not None:
        try:
            cfg_text = read_bounded(cfg).decode("utf-8")
        except OSError as exc:
            raise SpaceExError(f"cannot read file: {exc.strerror}", source=str(cfg)) from None
        except UnicodeDecodeError:
            raise SpaceExError("file is not UTF-8 text", source=str(cfg)) from None
    return data, cfg_text
