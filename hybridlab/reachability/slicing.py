"""Discrete outputs that nothing reads, left out of the analysis.

A light barrier's output ``S_1`` is set and cleared by the barrier's own transitions, which
never change the mode. When no flow, invariant, schedule, other guard or other reset reads
it, those transitions change nothing the rest of the system sees: following each of them
only multiplies the branches of the analysis (each crossing at an uncertain instant is a
branch that may or may not have jumped). Such a variable is *unread*; the transitions that
write nothing else and keep the mode are left out, and the variable's dimension starts
with the hull of every value it can hold (its initial values and the constants its
transitions assign), where it stays. Every trajectory's value is inside it at every
instant, so the result stays sound for any question about it; it is only less precise.

The set is the greatest fixpoint of: a discrete variable is unread when it is not
observed (a spec reads it), only transitions that keep the mode and write nothing but unread
variables write it, each assigning a constant, and nothing reads it other than the guards
and resets of those transitions.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import sympy as sp

from hybridlab.reachability.system import System

__all__ = ["Slice", "unread_outputs"]


@dataclass(frozen=True)
class Slice:
    """Which transitions are left out and the hull each unread variable starts with.

    Attributes
    ----------
    transitions : frozenset of int
        Indices of the transitions left out.
    hulls : dict of int to (float, float)
        For each unread variable's index in the state, the hull of the constants its
        transitions assign (its initial values are joined in by :meth:`widen`).

    Examples
    --------
    >>> cut = Slice(frozenset({0, 1}), {2: (0.0, 1.0)})
    >>> lo, hi = cut.widen(np.array([0.0, 1.0, 0.0]), np.array([0.5, 1.0, 0.0]))
    >>> lo.tolist(), hi.tolist()
    ([0.0, 1.0, 0.0], [0.5, 1.0, 1.0])
    """

    transitions: frozenset[int]
    hulls: dict[int, tuple[float, float]]

    def widen(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The bounds ``lo``, ``hi`` of an initial set with every unread variable's
        dimension widened to its hull."""
        lo, hi = lo.copy(), hi.copy()
        for i, (a, b) in self.hulls.items():
            lo[i], hi[i] = min(lo[i], a), max(hi[i], b)
        return lo, hi


def _writes(exprs: tuple[sp.Expr, ...], zsyms: tuple[sp.Symbol, ...], n: int) -> set[int]:
    return {i for i in range(n) if exprs[i] != zsyms[i]}


def unread_outputs(system: System, observed: Iterable[str] = ()) -> Slice:
    """The unread discrete variables of ``system`` and the transitions that only write them.

    Parameters
    ----------
    system : System
    observed : iterable of str
        Names of variables the caller reads from the result (a spec's): never unread.

    Examples
    --------
    A light barrier whose output ``seen`` nothing reads: its two transitions are left out,
    and ``seen`` starts in ``[0, 1]``:

    >>> import hybridlab
    >>> from hybridlab.reachability.system import build_system
    >>> c = hybridlab.compile_model(hybridlab.load_model("models/barrier_follower.toml"))
    >>> system = build_system(c, c.parameter_vector(), {}, {})
    >>> cut = unread_outputs(system)
    >>> sorted(c.transitions[i].name for i in cut.transitions)
    ['off', 'on']
    >>> [(system.znames[i], hull) for i, hull in cut.hulls.items()]
    [('seen', (0.0, 1.0))]
    >>> unread_outputs(system, observed=["seen"]).transitions
    frozenset()
    """
    compiled = system.compiled
    sym = compiled.symbolic
    n = system.n_states
    zsyms = system.zsyms
    names = system.znames
    observed = set(observed)
    unread = {i for i in range(n) if names[i] in sym.discrete and names[i] not in observed}
    transitions = compiled.transitions
    writes = {tr.index: _writes(system.resets[tr.index].exprs, zsyms, n) for tr in transitions}
    always: set[sp.Symbol] = set()  # read whatever is left out
    for mode in system.modes.values():
        for e in (*mode.flow, *mode.invariants.exprs):
            always |= e.free_symbols
    while True:
        kept_out = {tr.index for tr in transitions
                    if tr.source == tr.target and writes[tr.index] <= unread}
        read = set(always)
        for tr in transitions:
            if tr.index in kept_out:
                continue
            read |= {s for e in system.guards[tr.index].exprs for s in e.free_symbols}
            exprs = system.resets[tr.index].exprs
            read |= {s for i in writes[tr.index] for s in exprs[i].free_symbols}
        hulls: dict[int, tuple[float, float]] = {}
        for i in sorted(unread):
            if zsyms[i] in read:
                continue
            writers = [k for k, w in writes.items() if i in w]
            values = [system.resets[k].exprs[i] for k in writers]
            if all(k in kept_out and v.is_number for k, v in zip(writers, values, strict=True)):
                numbers = [float(v) for v in values]
                hulls[i] = (min(numbers, default=np.inf), max(numbers, default=-np.inf))
        if set(hulls) == unread:
            return Slice(frozenset(kept_out), hulls)
        unread = set(hulls)
