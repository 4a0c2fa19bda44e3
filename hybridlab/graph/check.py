"""Static checks of the mode graph: dead modes, guards that never hold, zero-dwell cycles.

The checks read guards, invariants, resets and schedules; flows are never
used. Each check is a feasibility question about a conjunction of
inequalities, answered by :func:`hybridlab.graph.feasibility.decide` (an LP when
every row is affine, interval branch and prune otherwise). Parameters take
the model's values and, separately, each scenario's: a transition "never
fires" only when that is proved for every parameter set, and a mode is dead
only when no parameter set reaches it from its initial mode.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from enum import StrEnum

import networkx as nx
import sympy as sp

from hybridlab.errors import ModelError
from hybridlab.graph.feasibility import Decision, Feasibility, decide
from hybridlab.model.checks import SymbolicModel, SymbolicTransition
from hybridlab.model.schema import Model

__all__ = [
    "Severity",
    "Finding",
    "TransitionCheck",
    "CycleCheck",
    "GraphReport",
    "check_mode_graph",
]

#: The label of the parameter set made of the model's own values.
MODEL_VALUES = "model values"
#: A question over at most this many boolean variables is answered once per combination
#: of their values (0 or 1); over more, each is bounded to [0, 1] instead.
MAX_FLAG_COMBINATIONS = 4


class Severity(StrEnum):
    """How serious a finding is; ``error > warning > info``.

    Examples
    --------
    >>> Severity("warning"), Severity.WARNING.rank
    (<Severity.WARNING: 'warning'>, 1)
    >>> max([Severity.INFO, Severity.ERROR, Severity.WARNING], key=lambda s: s.rank)
    <Severity.ERROR: 'error'>
    """

    INFO = "info"
    WARNING = "warning"
    ERROR = "error"

    @property
    def rank(self) -> int:
        """0 for info, 1 for warning, 2 for error."""
        return ("info", "warning", "error").index(self.value)


@dataclass(frozen=True)
class Finding:
    """One line of the report.

    Attributes
    ----------
    severity : Severity
        ``error`` (a guard that never fires, a reset that always leaves the
        target invariant, an invariant that never holds), ``warning`` (a dead
        mode, a zero-dwell cycle proved possible) or ``info`` (sink modes,
        undecided checks, disabled schedules).
    kind : str
        A short code: ``never-fires``, ``reset-violates-invariant``,
        ``empty-invariant``, ``dead-mode``, ``zero-dwell-cycle``, ``sink-mode``,
        ``undecided``, ``schedule-disabled``, ``cycles-truncated``.
    subject : str
        The transition, mode or cycle the finding is about.
    message : str
        One line naming the transition or mode.

    Examples
    --------
    >>> finding = Finding(Severity.WARNING, "dead-mode", "b",
    ...                   "mode 'b' is unreachable from the initial mode 'a'")
    >>> print(finding)
    warning: [dead-mode] mode 'b' is unreachable from the initial mode 'a'
    >>> finding.severity.rank >= Severity.WARNING.rank  # what makes a report not ok
    True
    """

    severity: Severity
    kind: str
    subject: str
    message: str

    def __str__(self) -> str:
        return f"{self.severity.value}: [{self.kind}] {self.message}"


@dataclass(frozen=True)
class TransitionCheck:
    """The verdicts for one transition edge (one source mode of a declared transition).

    ``guard`` answers "can the guard hold inside the source invariant?";
    ``reset`` answers "can a state where it fires be reset into the target
    invariant?" (``None`` when the target has no invariant or the guard never
    holds). Verdicts combine the parameter sets: possible if possible for one,
    impossible if impossible for all.

    Examples
    --------
    >>> import hybridlab
    >>> model = hybridlab.loads_model('''
    ... name = "demo"
    ... states = { x = 0.0 }
    ... modes.a = { flow = { x = "1" }, invariant = "x <= 1" }
    ... modes.b = { flow = { x = "-1" }, invariant = "x >= 5" }
    ... transitions = [{ name = "go", source = "a", target = "b", guard = "x >= 1" }]
    ... initial = { mode = "a" }
    ... ''')
    >>> check = check_mode_graph(model).transitions[0]  # fires at x = 1, but b needs x >= 5
    >>> check.name, check.guard.value, check.reset.value, check.method
    ('go', 'possible', 'impossible', 'lp')
    """

    name: str
    source: str
    target: str
    guard: Feasibility
    reset: Feasibility | None
    scheduled: bool
    schedule_disabled: bool
    method: str
    reason: str = ""


@dataclass(frozen=True)
class CycleCheck:
    """Whether a cycle of transitions can fire round at a single instant.

    ``parameter_set`` names the parameter set under which the verdict
    ``possible`` was proved (the model's values or a scenario).

    Examples
    --------
    Two guards that hold together at ``x = 0`` can chatter without time passing:

    >>> import hybridlab
    >>> model = hybridlab.loads_model('''
    ... name = "chatter"
    ... states = { x = 0.0 }
    ... modes.a = { flow = { x = "1" } }
    ... modes.b = { flow = { x = "-1" } }
    ... transitions = [
    ...   { name = "up", source = "a", target = "b", guard = "x >= 0" },
    ...   { name = "down", source = "b", target = "a", guard = "x <= 0" },
    ... ]
    ... initial = { mode = "a" }
    ... ''')
    >>> cycle = check_mode_graph(model).cycles[0]
    >>> cycle.text, cycle.verdict.value, cycle.parameter_set
    ('up -> down (a -> b -> a)', 'possible', 'model values')
    """

    transitions: tuple[str, ...]
    modes: tuple[str, ...]
    verdict: Feasibility
    method: str
    parameter_set: str | None = None
    reason: str = ""

    @property
    def text(self) -> str:
        """``"a -> b"`` over the transitions, then the modes in parentheses."""
        path = " -> ".join(self.transitions)
        return f"{path} ({' -> '.join([*self.modes, self.modes[0]])})"


@dataclass(frozen=True)
class GraphReport:
    """The result of :func:`check_mode_graph`.

    Attributes
    ----------
    model : str
        The model name.
    parameter_sets : tuple of str
        The parameter sets checked (``"model values"`` and scenario names).
    reachable : mapping of str to tuple of str
        For each parameter set, the modes reachable from its initial mode
        through transitions not proved impossible.
    dead_modes : tuple of str
        Modes no parameter set reaches.
    sink_modes : tuple of str
        Modes without outgoing transitions.
    transitions : tuple of TransitionCheck
    cycles : tuple of CycleCheck
        Every cycle examined (the zero-dwell candidates).
    findings : tuple of Finding
        Sorted by severity, errors first.
    cycles_truncated : bool
        Whether enumeration stopped at ``max_cycles``.

    Examples
    --------
    >>> import hybridlab
    >>> report = check_mode_graph(hybridlab.load_model("models/thermostat.toml"))
    >>> report.ok, report.dead_modes, [c.verdict.value for c in report.cycles]
    (True, (), ['impossible'])
    """

    model: str
    parameter_sets: tuple[str, ...]
    reachable: Mapping[str, tuple[str, ...]]
    dead_modes: tuple[str, ...]
    sink_modes: tuple[str, ...]
    transitions: tuple[TransitionCheck, ...]
    cycles: tuple[CycleCheck, ...]
    findings: tuple[Finding, ...]
    cycles_truncated: bool = False

    @property
    def ok(self) -> bool:
        """True when no finding is a warning or an error."""
        return all(f.severity is Severity.INFO for f in self.findings)

    def count(self, severity: Severity) -> int:
        """The number of findings of ``severity``."""
        return sum(f.severity is severity for f in self.findings)

    def summary(self) -> str:
        """One line: counts of findings, modes, transitions and cycles checked."""
        counts = ", ".join(f"{self.count(s)} {s.value}" + ("s" if self.count(s) != 1 else "")
                           for s in (Severity.ERROR, Severity.WARNING, Severity.INFO))
        sizes = ", ".join(_count(n, what) for n, what in (
            (len(self.transitions), "transition edge"), (len(self.cycles), "cycle"),
            (len(self.parameter_sets), "parameter set")))
        return f"{self.model}: {counts}; {sizes} checked"

    def __str__(self) -> str:
        return "\n".join([*(str(f) for f in self.findings), self.summary()])


@dataclass(frozen=True)
class _ParameterSet:
    label: str
    values: Mapping[sp.Symbol, float]
    initial_mode: str

    def where(self) -> str:
        return "the model's parameter values" if self.label == MODEL_VALUES else (
            f"scenario {self.label!r}")


def _parameter_sets(model: Model, sym: SymbolicModel,
                    scenarios: Sequence[str] | None) -> list[_ParameterSet]:
    symbols = dict(zip(sym.parameter_names, sym.parameters, strict=True))
    base = {symbols[n]: float(p.value) for n, p in model.parameters.items()}
    sets = []
    if not scenarios:  # None: every scenario too; an empty sequence: the model's values only
        sets.append(_ParameterSet(MODEL_VALUES, base, model.initial.mode))
        scenarios = list(model.scenarios) if scenarios is None else []
    for name in scenarios:
        if name not in model.scenarios:
            known = ", ".join(model.scenarios) or "none"
            raise ModelError(f"unknown scenario; expected one of: {known}", key="scenarios",
                             token=name)
        scenario = model.scenarios[name]
        values = {**base, **{symbols[k]: float(v) for k, v in scenario.parameters.items()}}
        sets.append(_ParameterSet(name, values, scenario.mode or model.initial.mode))
    return sets


@dataclass(frozen=True)
class _Edge:
    """A transition edge's parts, parameters still symbolic."""

    tr: SymbolicTransition
    guard: tuple[sp.Expr, ...]
    source_invariant: tuple[sp.Expr, ...]
    target_invariant: tuple[sp.Expr, ...]
    reset: Mapping[sp.Symbol, sp.Expr]
    parameters: frozenset[sp.Symbol]
    content: tuple = field(compare=False)


def _edges(sym: SymbolicModel) -> list[_Edge]:
    inv = {name: tuple(r.expr for r in mode.invariants) for name, mode in sym.modes.items()}
    params = set(sym.parameters)
    out = []
    for tr in sym.transitions:
        guard = tuple(r.expr for r in tr.guard)
        reset = {s: e for s, e in zip(sym.states, tr.reset, strict=True) if e != s}
        parts = (guard, inv[tr.source], inv[tr.target], tuple(sorted(reset.items(), key=str)))
        used = set()
        for expr in (*guard, *inv[tr.source], *inv[tr.target], *reset.values()):
            used |= expr.free_symbols & params
        if tr.period is not None:
            used |= (tr.period.free_symbols | tr.phase.free_symbols
                     | tr.enabled.free_symbols) & params
        out.append(_Edge(tr, guard, inv[tr.source], inv[tr.target], reset, frozenset(used),
                         (parts, str(tr.period), str(tr.enabled))))
    return out


class _Checker:
    def __init__(self, sym: SymbolicModel, tol: float, max_boxes: int, rounds: int) -> None:
        self.sym = sym
        self.rounds = rounds
        self.tol = tol
        self.max_boxes = max_boxes
        self.decisions: dict[tuple, Decision] = {}
        self.memo: dict[tuple, object] = {}
        self.flags = frozenset(s for s, name in zip(sym.states, sym.state_names, strict=True)
                               if sym.discrete.get(name) == "bool")

    def decide(self, rows: Sequence[sp.Expr]) -> Decision:
        key = tuple(rows)
        if key not in self.decisions:
            self.decisions[key] = self._decide(list(rows))
        return self.decisions[key]

    def _decide(self, rows: list[sp.Expr]) -> Decision:
        """Decide ``rows``; a boolean variable takes its values 0 and 1 only (a guard
        ``armed`` after a reset ``armed = 1 - armed`` is not one half)."""
        flags = sorted(self.flags & set().union(*(r.free_symbols for r in rows)), key=str)
        if not flags:
            return decide(rows, tol=self.tol, max_boxes=self.max_boxes)
        if len(flags) > MAX_FLAG_COMBINATIONS:
            bounds = [row for f in flags for row in (f, 1 - f)]
            return decide(rows + bounds, tol=self.tol, max_boxes=self.max_boxes)
        cases = [decide([r.xreplace(dict(zip(flags, values, strict=True))) for r in rows],
                        tol=self.tol, max_boxes=self.max_boxes)
                 for values in itertools.product((sp.Integer(0), sp.Integer(1)),
                                                 repeat=len(flags))]
        verdict = _combine([c.verdict for c in cases])
        chosen = next((c for c in cases if c.verdict is verdict), cases[0])
        return Decision(verdict, chosen.method, chosen.margin, chosen.reason)

    @staticmethod
    def _key(edges: Sequence[_Edge], ps: _ParameterSet) -> tuple:
        used = frozenset().union(*(e.parameters for e in edges))
        return (tuple(e.content for e in edges),
                tuple(sorted((str(p), ps.values[p]) for p in used)))

    def edge(self, edge: _Edge, ps: _ParameterSet) -> tuple[Decision, Decision | None, bool]:
        """(guard decision, reset decision, schedule disabled) under ``ps``."""
        key = ("edge", *self._key([edge], ps))
        if key not in self.memo:
            self.memo[key] = self._edge(edge, ps)
        return self.memo[key]  # type: ignore[return-value]

    def _edge(self, edge: _Edge, ps: _ParameterSet) -> tuple[Decision, Decision | None, bool]:
        values = {p: sp.Float(v) for p, v in ps.values.items()}
        disabled = False
        if edge.tr.period is not None:
            try:
                disabled = float(edge.tr.enabled.xreplace(values)) == 0
            except (TypeError, ValueError):
                disabled = False
        base = [e.xreplace(values) for e in (*edge.source_invariant, *edge.guard)]
        guard = self.decide(base)
        reset = None
        if edge.target_invariant and guard.verdict is not Feasibility.IMPOSSIBLE:
            image = {s: e.xreplace(values) for s, e in edge.reset.items()}
            after = [e.xreplace(values).xreplace(image) for e in edge.target_invariant]
            reset = self.decide(base + after)
        return guard, reset, disabled

    def numeric(self, edge: _Edge, ps: _ParameterSet
                ) -> tuple[tuple[sp.Expr, ...], dict[sp.Symbol, sp.Expr]]:
        """The source invariant and guard rows, and the reset, with ``ps`` substituted."""
        key = ("numeric", edge.tr.index, ps.label)
        if key not in self.memo:
            values = {p: sp.Float(v) for p, v in ps.values.items()}
            rows = tuple(e.xreplace(values) for e in (*edge.source_invariant, *edge.guard))
            reset = {s: e.xreplace(values) for s, e in edge.reset.items()}
            self.memo[key] = (rows, reset)
        return self.memo[key]  # type: ignore[return-value]

    def cycle(self, edges: Sequence[_Edge], ps: _ParameterSet) -> Decision:
        key = ("cycle", *self._key(edges, ps))
        if key not in self.memo:
            self.memo[key] = self._cycle(edges, ps)
        return self.memo[key]  # type: ignore[return-value]

    def _cycle(self, edges: Sequence[_Edge], ps: _ParameterSet) -> Decision:
        # one set of variables (the state when the cycle starts, and t); the state after
        # each jump is the composition of the resets so far
        current: dict[sp.Symbol, sp.Expr] = {}
        rows: list[sp.Expr] = []
        for edge in [*edges] * self.rounds:
            rows.extend(expr.xreplace(current) for expr in self.numeric(edge, ps)[0])
            composed = dict(current)
            for s, e in self.numeric(edge, ps)[1].items():
                composed[s] = e.xreplace(current)
            current = composed
        # back in the first mode, with the first transition enabled again
        rows.extend(expr.xreplace(current) for expr in self.numeric(edges[0], ps)[0])
        return self.decide(rows)


def _combine(verdicts: Sequence[Feasibility]) -> Feasibility:
    if any(v is Feasibility.POSSIBLE for v in verdicts):
        return Feasibility.POSSIBLE
    if verdicts and all(v is Feasibility.IMPOSSIBLE for v in verdicts):
        return Feasibility.IMPOSSIBLE
    return Feasibility.UNDECIDED


def _cycles(edges: Sequence[_Edge], modes: Sequence[str], max_length: int
            ) -> Iterator[tuple[_Edge, ...]]:
    """Zero-dwell candidates: simple cycles of the mode graph (one edge choice per step),
    and cycles of two or more distinct self-loops of one mode."""
    unscheduled = [e for e in edges if e.tr.period is None]
    graph = nx.DiGraph()
    graph.add_nodes_from(modes)
    between: dict[tuple[str, str], list[_Edge]] = {}
    for e in unscheduled:
        between.setdefault((e.tr.source, e.tr.target), []).append(e)
        if e.tr.source != e.tr.target:
            graph.add_edge(e.tr.source, e.tr.target)
    for nodes in nx.simple_cycles(graph, length_bound=max_length):
        steps = [between[(a, b)] for a, b in zip(nodes, [*nodes[1:], nodes[0]], strict=True)]
        yield from itertools.product(*steps)
    for mode in modes:
        loops = between.get((mode, mode), [])
        if len(loops) < 2:
            continue  # a single self-loop is not re-enabled at the instant it fired
        complete = nx.complete_graph(len(loops), create_using=nx.DiGraph)
        for order in nx.simple_cycles(complete, length_bound=max_length):
            if len(order) >= 2:
                yield tuple(loops[i] for i in order)


def _count(n: int, what: str) -> str:
    return f"{n} {what}" + ("" if n == 1 else "s")


def _rotate(names: tuple[str, ...]) -> tuple[str, ...]:
    return min(names[i:] + names[:i] for i in range(len(names)))


def _list(items: Sequence[str], limit: int = 4) -> str:
    shown = ", ".join(repr(i) for i in items[:limit])
    return shown + (f" and {len(items) - limit} more" if len(items) > limit else "")


def check_mode_graph(model: Model, *, scenarios: Sequence[str] | None = None,
                     max_cycle_length: int = 8, max_cycles: int = 5000, tol: float = 1e-9,
                     max_boxes: int = 128, rounds: int = 2) -> GraphReport:
    """Check the mode graph of ``model`` statically (flows are not used).

    Parameters
    ----------
    model : Model
        The model.
    scenarios : sequence of str, optional
        The scenarios whose parameter values and initial modes are checked.
        By default the model's own values and every scenario; a non-empty
        sequence checks exactly those scenarios, an empty one only the
        model's own values.
    max_cycle_length : int
        Longest cycle (in transitions) examined for zero-dwell firing.
    max_cycles : int
        Stop enumerating cycles after this many (the report says so).
    tol : float
        Feasibility tolerance (see :func:`hybridlab.graph.feasibility.decide`).
    max_boxes : int
        Interval boxes per nonlinear feasibility question.
    rounds : int
        How many times in a row a cycle must be able to fire round at one
        instant to count as a zero-dwell cycle (then its first transition must
        be enabled again). Impossible for 1 round implies impossible for more;
        2 rounds rule out cycles that a latched flag lets through only once.

    Returns
    -------
    GraphReport

    Raises
    ------
    ModelError
        For an unknown scenario name.

    Examples
    --------
    >>> import hybridlab
    >>> model = hybridlab.loads_model('''
    ... name = "demo"
    ... states = { x = 0.0 }
    ... modes.a = { flow = { x = "1" }, invariant = "x <= 1" }
    ... modes.b = { flow = { x = "-1" } }
    ... modes.c = { flow = { x = "0" } }
    ... transitions = [{ name = "go", source = "a", target = "b", guard = "x >= 2" }]
    ... initial = { mode = "a" }
    ... ''')
    >>> for finding in check_mode_graph(model).findings:
    ...     print(finding)
    error: [never-fires] transition 'go' (a -> b) never fires: its guard contradicts the invariant of 'a' [lp]
    warning: [dead-mode] mode 'b' is unreachable from the initial mode 'a' (only through transitions that never fire)
    warning: [dead-mode] mode 'c' is unreachable from the initial mode 'a'
    info: [sink-mode] mode 'b' has no outgoing transitions
    info: [sink-mode] mode 'c' has no outgoing transitions
    """  # noqa: E501
    if max_cycle_length < 1:
        raise ValueError(f"max_cycle_length must be at least 1 (got {max_cycle_length})")
    if rounds < 1:
        raise ValueError(f"rounds must be at least 1 (got {rounds})")
    sym = model.symbolic
    sets = _parameter_sets(model, sym, scenarios)
    checker = _Checker(sym, tol, max_boxes, rounds)
    edges = _edges(sym)
    modes = list(sym.modes)
    findings: list[Finding] = []

    # ----- modes whose invariant never holds
    empty_modes = set()
    for name, mode in sym.modes.items():
        if not mode.invariants:
            continue
        decisions = [checker.decide([r.expr.xreplace({p: sp.Float(v) for p, v in ps.values.items()})
                                     for r in mode.invariants]) for ps in sets]
        if _combine([d.verdict for d in decisions]) is Feasibility.IMPOSSIBLE:
            empty_modes.add(name)
            findings.append(Finding(Severity.ERROR, "empty-invariant", name,
                                    f"mode {name!r}: its invariant can never hold "
                                    f"[{decisions[0].method}]"))

    # ----- transitions
    checks: list[TransitionCheck] = []
    usable: dict[str, set[int]] = {ps.label: set() for ps in sets}
    for edge in edges:
        results = [checker.edge(edge, ps) for ps in sets]
        for ps, (g, r, off) in zip(sets, results, strict=True):
            if not off and g.verdict is not Feasibility.IMPOSSIBLE and (
                    r is None or r.verdict is not Feasibility.IMPOSSIBLE):
                usable[ps.label].add(edge.tr.index)
        guard = _combine([g.verdict for g, _, _ in results])
        resets = [r.verdict for g, r, _ in results if r is not None]
        reset = _combine(resets) if resets else None
        live = [(g, r) for g, r, _ in results if g.verdict is not Feasibility.IMPOSSIBLE]
        method = (live[0][1] or live[0][0]).method if live else results[0][0].method
        reason = next((d.reason for g, r, _ in results for d in (g, r) if d and d.reason), "")
        checks.append(TransitionCheck(
            name=edge.tr.name, source=edge.tr.source, target=edge.tr.target, guard=guard,
            reset=reset, scheduled=edge.tr.period is not None,
            schedule_disabled=all(off for _, _, off in results), method=method, reason=reason))
    findings.extend(_transition_findings(checks, sym, empty_modes))

    # ----- reachability
    reachable: dict[str, tuple[str, ...]] = {}
    structural = nx.MultiDiGraph()
    structural.add_nodes_from(modes)
    structural.add_edges_from((e.tr.source, e.tr.target) for e in edges)
    for ps in sets:
        graph = nx.DiGraph()
        graph.add_nodes_from(modes)
        graph.add_edges_from((e.tr.source, e.tr.target) for e in edges
                             if e.tr.index in usable[ps.label])
        seen = nx.descendants(graph, ps.initial_mode) | {ps.initial_mode}
        reachable[ps.label] = tuple(m for m in modes if m in seen)
    initial_modes = sorted({ps.initial_mode for ps in sets}, key=modes.index)
    reached = set().union(*(set(r) for r in reachable.values()))
    dead = tuple(m for m in modes if m not in reached)
    for mode in dead:
        where = ("the initial mode " + repr(initial_modes[0]) if len(initial_modes) == 1
                 else "the initial modes " + _list(initial_modes))
        only = any(nx.has_path(structural, s, mode) for s in initial_modes)
        note = " (only through transitions that never fire)" if only else ""
        findings.append(Finding(Severity.WARNING, "dead-mode", mode,
                                f"mode {mode!r} is unreachable from {where}{note}"))

    # ----- zero-dwell cycles
    cycles: list[CycleCheck] = []
    truncated = False
    for count, found in enumerate(_cycles(edges, modes, max_cycle_length)):
        if count >= max_cycles:
            truncated = True
            break
        start = min(range(len(found)), key=lambda i: found[i].tr.index)
        chain = found[start:] + found[:start]  # starts at the first declared transition
        verdicts = []
        witness = None
        decision = None
        for ps in sets:
            decision = checker.cycle(chain, ps)
            verdicts.append(decision.verdict)
            if decision.verdict is Feasibility.POSSIBLE:
                witness = ps
                break
        verdict = _combine(verdicts)
        cycles.append(CycleCheck(
            transitions=tuple(e.tr.name for e in chain),
            modes=tuple(e.tr.source for e in chain), verdict=verdict,
            method=decision.method if decision else "none",
            parameter_set=witness.label if witness else None,
            reason=decision.reason if decision else ""))
    findings.extend(_cycle_findings(cycles, sets))
    if truncated:
        findings.append(Finding(Severity.INFO, "cycles-truncated", model.name,
                                f"cycle enumeration stopped at {max_cycles} cycles "
                                "(max_cycles); the remaining cycles were not checked"))

    # ----- sinks
    sinks = tuple(m for m in modes if structural.out_degree(m) == 0)
    findings.extend(Finding(Severity.INFO, "sink-mode", m,
                            f"mode {m!r} has no outgoing transitions") for m in sinks)
    findings.sort(key=lambda f: -f.severity.rank)
    return GraphReport(
        model=model.name, parameter_sets=tuple(ps.label for ps in sets), reachable=reachable,
        dead_modes=dead, sink_modes=sinks, transitions=tuple(checks), cycles=tuple(cycles),
        findings=tuple(findings), cycles_truncated=truncated)


def _transition_findings(checks: Sequence[TransitionCheck], sym: SymbolicModel,
                         empty_modes: set[str]) -> list[Finding]:
    groups: dict[tuple[str, str], list[TransitionCheck]] = {}
    for c in checks:
        if c.source in empty_modes:
            continue  # already reported: nothing fires from a mode that cannot be occupied
        if c.guard is Feasibility.IMPOSSIBLE:
            groups.setdefault(("never-fires", c.name), []).append(c)
        elif c.reset is Feasibility.IMPOSSIBLE and c.target not in empty_modes:
            groups.setdefault(("reset-violates-invariant", c.name), []).append(c)
        elif Feasibility.UNDECIDED in (c.guard, c.reset):
            groups.setdefault(("undecided", c.name), []).append(c)
        elif c.scheduled and c.schedule_disabled:
            groups.setdefault(("schedule-disabled", c.name), []).append(c)
    out = []
    for (kind, name), group in groups.items():
        first = group[0]
        edge = (f"({first.source} -> {first.target})" if len(group) == 1
                else f"(from {len(group)} source modes: {_list([c.source for c in group])})")
        if kind == "never-fires":
            has_inv = bool(sym.modes[first.source].invariants)
            why = (f"its guard contradicts the invariant of {first.source!r}" if has_inv
                   and len(group) == 1 else "its guard can never hold" if not has_inv
                   else "its guard contradicts the source invariant")
            out.append(Finding(Severity.ERROR, kind, name,
                               f"transition {name!r} {edge} never fires: {why} [{first.method}]"))
        elif kind == "reset-violates-invariant":
            out.append(Finding(Severity.ERROR, kind, name,
                               f"transition {name!r} {edge}: every state it fires from is reset "
                               f"outside the invariant of {first.target!r} [{first.method}]"))
        elif kind == "undecided":
            what = ("whether its guard can hold" if first.guard is Feasibility.UNDECIDED else
                    f"whether its reset can land inside the invariant of {first.target!r}")
            out.append(Finding(Severity.INFO, kind, name,
                               f"transition {name!r} {edge}: undecided {what} ({first.reason})"))
        else:
            out.append(Finding(Severity.INFO, kind, name,
                               f"transition {name!r} {edge}: schedule disabled (period <= 0) "
                               "for every parameter set checked"))
    return out


def _cycle_findings(cycles: Sequence[CycleCheck], sets: Sequence[_ParameterSet]
                    ) -> list[Finding]:
    labels = {ps.label: ps for ps in sets}
    groups: dict[tuple[Feasibility, tuple[str, ...]], list[CycleCheck]] = {}
    for c in cycles:
        if c.verdict is not Feasibility.IMPOSSIBLE:
            groups.setdefault((c.verdict, _rotate(c.transitions)), []).append(c)
    out = []
    for (verdict, names), group in groups.items():
        first = group[0]
        where = (first.text if len(group) == 1 else
                 f"{' -> '.join(names)} (in {len(group)} places, first {first.text})")
        if verdict is Feasibility.POSSIBLE:
            ps = labels[first.parameter_set] if first.parameter_set else None
            under = f", {ps.where()}" if ps else ""
            out.append(Finding(Severity.WARNING, "zero-dwell-cycle", " -> ".join(names),
                               f"zero-dwell cycle {where} can fire round at one instant "
                               f"[{first.method}{under}]"))
        else:
            out.append(Finding(Severity.INFO, "undecided", " -> ".join(names),
                               f"cycle {where}: undecided whether it can fire with zero dwell "
                               f"({first.reason})"))
    return out
