"""Discrete variables that are constant in a mode, substituted into what the mode reads.

A discrete variable has no flow: its value changes only at jumps. If every way into a mode
gives it the same number (the initial value where the analysis starts, a constant that a
transition's reset assigns, or the constant it had in the transition's source when the
reset keeps it or computes it from constants), then every reachable state of the mode holds
that number. A trajectory generator's segment start velocity ``v_s`` is ``0`` in every
mode that holds a set point, so there ``x_ref = x_s + v_s tau + a_s tau^2 / 2`` is ``x_s``:
substituting the constants makes such a mode's flow affine where it was bilinear in
``(v_s, tau)``, and a guard ``v_s + a_s tau <= 0`` with a known ``a_s`` linear.

The constants are the least fixpoint of this propagation over the mode graph (each
variable's value in a mode only goes from unreached to one number to varying, so it ends
after a few passes). Every transition counts, whatever its guard, so the result holds for
every run. A variable read by a switching function (``sign(v_s)``) is never substituted:
a discontinuity at a constant argument keeps its set-valued sign.

The sets keep the variable's dimension; only the flows, invariants and guards of the mode,
and the resets of transitions leaving it, stop reading it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

import numpy as np
import sympy as sp

from hybridlab.reachability.sets import Zonotope
from hybridlab.reachability.system import ResetMap, Rows, System

__all__ = ["mode_constants", "with_constants"]

#: A two-gear model whose gain ``g`` is constant in each gear (the examples' model).
GEARS = """
name = "gears"
states = { x = 1.0 }
discrete = { g = { value = 1.0, type = "real" } }
[modes.low]
flow = { x = "-g*x" }
[modes.high]
flow = { x = "-g*x" }
[[transitions]]
name = "up"
source = "low"
target = "high"
guard = "x <= 0.5"
reset = { g = "3" }
[initial]
mode = "low"
"""

#: a variable's value in a mode when two ways in give it different values
_VARIES = None


def mode_constants(system: System, mode: str, initial: Zonotope) -> dict[str, dict[int, float]]:
    """For each mode reachable in the mode graph from ``mode``, the discrete variables that
    have one value in all its states (their index in the state, and the value).

    Parameters
    ----------
    system : System
    mode : str
        The initial mode.
    initial : Zonotope
        The initial set: a discrete variable starts constant where its width is zero.

    Examples
    --------
    A gain ``g`` that the shift into ``high`` sets to 3:

    >>> import hybridlab
    >>> from hybridlab.reachability.system import build_system
    >>> c = hybridlab.compile_model(hybridlab.loads_model(GEARS))
    >>> system = build_system(c, c.parameter_vector(), {}, {})
    >>> start = Zonotope(c.state_vector(), np.zeros((2, 0)))
    >>> mode_constants(system, "low", start)
    {'low': {1: 1.0}, 'high': {1: 3.0}}
    >>> wide = Zonotope(c.state_vector(), np.diag([0.0, 0.5]))   # g in [0.5, 1.5]
    >>> mode_constants(system, "low", wide)
    {'low': {}, 'high': {1: 3.0}}
    """
    names = system.znames
    discrete = system.compiled.symbolic.discrete
    switched: set[sp.Symbol] = set()
    for m in system.modes.values():
        for e in m.switches.exprs:
            switched |= e.free_symbols
    candidates = [i for i in range(system.n_states)
                  if names[i] in discrete and system.zsyms[i] not in switched]
    if not candidates:
        return {}
    G = initial.generators
    values: dict[str, dict[int, float | None]] = {mode: {
        i: float(initial.center[i]) if not np.any(G[i]) else _VARIES for i in candidates}}
    leaving: dict[str, list] = {}
    for tr in system.compiled.transitions:
        leaving.setdefault(tr.source, []).append(tr)
    pending = [mode]
    while pending:
        source = pending.pop()
        known = values[source]
        sub = {system.zsyms[i]: _number(v) for i, v in known.items() if v is not _VARIES}
        for tr in leaving.get(source, ()):
            exprs = system.resets[tr.index].exprs
            after: dict[int, float | None] = {}
            for i in candidates:
                e = exprs[i]
                if e == system.zsyms[i]:
                    after[i] = known[i]
                    continue
                e = e.xreplace(sub)
                after[i] = float(e) if e.is_number and e.is_finite else _VARIES
            target = values.get(tr.target)
            if target is None:
                values[tr.target] = after
                pending.append(tr.target)
                continue
            changed = False
            for i, v in after.items():
                if target[i] is not _VARIES and target[i] != v:
                    target[i] = _VARIES
                    changed = True
            if changed and tr.target not in pending:
                pending.append(tr.target)
    return {m: {i: v for i, v in vals.items() if v is not _VARIES}
            for m, vals in values.items()}


def with_constants(system: System, constants: Mapping[str, Mapping[int, float]]) -> System:
    """``system`` with each mode's constant discrete variables substituted into its flow,
    invariants and guards and into the resets of the transitions leaving it (a reset that
    keeps a variable keeps it: its entry stays the identity).

    Examples
    --------
    ``x' = -g x`` is bilinear in ``(g, x)``; with ``g`` known in each gear it is affine:

    >>> import hybridlab
    >>> from hybridlab.reachability.system import build_system
    >>> c = hybridlab.compile_model(hybridlab.loads_model(GEARS))
    >>> system = build_system(c, c.parameter_vector(), {}, {})
    >>> start = Zonotope(c.state_vector(), np.zeros((2, 0)))
    >>> known = with_constants(system, mode_constants(system, "low", start))
    >>> system.modes["high"].affine, known.modes["high"].affine, known.modes["high"].flow
    (False, True, (-3*x, 0))
    """
    if not any(constants.values()):
        return system
    zsyms = system.zsyms
    subs = {m: {zsyms[i]: _number(v) for i, v in vals.items()} for m, vals in constants.items()}
    modes = {}
    for name, m in system.modes.items():
        sub = subs.get(name)
        if not sub:
            modes[name] = m
            continue
        modes[name] = replace(
            m, flow=tuple(e.xreplace(sub) for e in m.flow),
            invariants=Rows([e.xreplace(sub) for e in m.invariants.exprs], zsyms,
                            m.invariants.texts))
    guards, resets = dict(system.guards), dict(system.resets)
    for tr in system.compiled.transitions:
        sub = subs.get(tr.source)
        if not sub:
            continue
        rows = system.guards[tr.index]
        guards[tr.index] = Rows([e.xreplace(sub) for e in rows.exprs], zsyms, rows.texts)
        exprs = system.resets[tr.index].exprs
        resets[tr.index] = ResetMap(tuple(e if e == z else e.xreplace(sub)
                                          for e, z in zip(exprs, zsyms, strict=True)), zsyms)
    return replace(system, modes=modes, guards=guards, resets=resets)


def _number(value: float) -> sp.Expr:
    """A constant as sympy keeps it exactly (an integer as ``Integer``, so ``0 * tau``
    vanishes)."""
    return sp.Integer(int(value)) if float(value).is_integer() else sp.Float(value)
