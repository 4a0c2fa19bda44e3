"""Python source of one model's numeric functions, for numba.

Every flow, condition row (guards, then invariants), switching function,
their Lie derivatives, every reset and every transition guard is printed
from its sympy expression (with common-subexpression elimination) into the
body of a single scalar-loop function::

    model(op, group, t, x, p, sigma, f, out)

``op`` selects the kind of function (:mod:`.opcodes`), ``group`` which
one (modes and transitions that share a function share a group). The *box*
ops (:data:`OP_GUARD_BOX`, :data:`OP_INV_BOX`, :data:`OP_SWITCH_BOX`) enclose
a transition's guard rows, a mode's invariants and its switching functions
over a box: ``x`` then holds the states' lower bounds followed by their upper
bounds, ``f`` the time interval, and ``out`` receives lower bounds followed by
upper bounds (:mod:`.box_printer`). They are a second function, ``box``, so
that ``model`` stays as small as it is without them. All array
arguments are raw ``float64`` pointers, so the kernel of
:mod:`hybridlab.simulation.compiled.kernel` is compiled once for every model
and calls the model through one first-class function pointer. The source is
written from sympy expressions only; model text never reaches ``eval``.
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import sympy as sp

from hybridlab.model.checks import TIME
from hybridlab.simulation.compiled import interval_ops
from hybridlab.simulation.compiled.box_printer import box_body
from hybridlab.simulation.compiled.opcodes import (
    N_OPS,
    OP_COND,
    OP_COND_BOTH,
    OP_COND_LIE,
    OP_FLOW,
    OP_FLOW_DSIGMA,
    OP_GUARD,
    OP_GUARD_BOX,
    OP_GUARD_LIE,
    OP_INV_BOX,
    OP_RESET,
    OP_SLIDE_PARTS,
    OP_SWITCH,
    OP_SWITCH_BOTH,
    OP_SWITCH_BOX,
    OP_SWITCH_GRAD,
    OP_SWITCH_LIE,
)
from hybridlab.symbolic import interval_arithmetic, interval_machine
from hybridlab.symbolic.compile import CompiledModel
from hybridlab.symbolic.printing import PrintError, lower, scalar_printer

__all__ = ["ModelSource", "UnsupportedModel", "generate", "active_states"]

_BOX_OF = {OP_GUARD_BOX: OP_GUARD, OP_SWITCH_BOX: OP_SWITCH}
_BOX_OPS = (OP_GUARD_BOX, OP_INV_BOX, OP_SWITCH_BOX)
#: the generated module's name hashes its text: this digest makes it change with the
#: interval functions it calls (numba checks a cached function against its own file only)
_INTERVAL_DIGEST = hashlib.sha256(b"".join(
    Path(path).read_bytes() for path in (interval_ops.__file__, interval_arithmetic.__file__,
                                         interval_machine.__file__)
)).hexdigest()[:16]


class UnsupportedModel(Exception):
    """The model uses something the printer cannot turn into numba code.

    The compiled backend then runs the model on the reference engine (the reason is in
    ``result.stats["fallback"]``). So it does for a model too long to compile quickly
    under ``backend="auto"`` (:class:`~.backend.SlowToCompile`, a subclass).

    Examples
    --------
    >>> import os, tempfile
    >>> from unittest import mock
    >>> import hybridlab
    >>> from hybridlab.simulation.compiled.backend import prepare
    >>> compiled = hybridlab.compile_model(hybridlab.load_model("models/thermostat.toml"))
    >>> with (tempfile.TemporaryDirectory() as empty,  # a cache where nothing was compiled
    ...       mock.patch.dict(os.environ, {"HYBRIDLAB_CACHE_DIR": empty})):
    ...     try:
    ...         prepare(compiled, max_lines=50)
    ...     except UnsupportedModel as exc:
    ...         print(f"{type(exc).__name__}: {exc}")
    SlowToCompile: its generated code has ... lines (more than 50), which numba would take ...
    """


@dataclass(frozen=True)
class ModelSource:
    """The generated source and the group tables the kernel needs.

    Attributes
    ----------
    text : str
        Python source of a module defining ``model``.
    flow_group, cond_group, switch_group : tuple of int
        Per mode (in ``compiled.modes`` order): the group of its flow,
        conditions (-1: none) and switching functions (-1: none).
    grad_group, dsigma_group, slide_group : tuple of int
        Per mode: the group of the switching functions' state gradient, of
        the flow's sigma-Jacobian and of the fused sliding op (-1: the mode
        has no switch).
    switch_free : tuple of int
        Per mode: 1 when its switching functions do not depend on the signs
        (their gradient and time derivative are the same for every sigma).
    invariant_group : tuple of int
        Per mode: the group of its invariants' box op (-1: none).
    reset_group, guard_group : tuple of int
        Per transition: the group of its reset and of its guard (-1: none).

    Examples
    --------
    >>> import hybridlab
    >>> source = generate(hybridlab.compile_model(
    ...     hybridlab.load_model("models/relay_sliding.toml")))
    >>> source.flow_group, source.switch_group, source.slide_group, source.switch_free
    ((0,), (0,), (0,), (1,))
    >>> source.reset_group, source.guard_group  # no transitions
    ((), ())
    >>> source.text.count("@numba.cfunc(")  # the point ops' function and the box ops'
    2
    """

    text: str
    flow_group: tuple[int, ...]
    cond_group: tuple[int, ...]
    switch_group: tuple[int, ...]
    reset_group: tuple[int, ...]
    guard_group: tuple[int, ...]
    grad_group: tuple[int, ...] = ()
    dsigma_group: tuple[int, ...] = ()
    slide_group: tuple[int, ...] = ()
    switch_free: tuple[int, ...] = ()
    invariant_group: tuple[int, ...] = ()


def _body(exprs: Sequence[sp.Expr], names: dict[sp.Symbol, str], indent: str) -> list[str]:
    """Assignments ``out[i] = ...`` of ``exprs`` after CSE, reading only the symbols used."""
    local = {s: _local(s, names) for s in names}
    try:
        low = lower(exprs, local)
        reads = [f"{indent}{local[s]} = {names[s]}"
                 for s in sorted(low.used, key=local.__getitem__)]
        return reads + low.statements(scalar_printer(low.names, sign="_sign"), indent,
                                      "out[{i}] = {value}")
    except PrintError as exc:
        raise UnsupportedModel(str(exc)) from None


def _box_symbols(names: dict[sp.Symbol, str], n: int) -> dict[sp.Symbol, tuple[str, str]]:
    """Where a box op reads each symbol's bounds: states ``x[i]`` and ``x[n + i]``, time
    ``f[0]`` and ``f[1]``; parameters and signs are points."""
    out = {}
    for s, text in names.items():
        if text == "t":
            out[s] = ("f[0]", "f[1]")
        elif text.startswith("x["):
            out[s] = (text, f"x[{n + int(text[2:-1])}]")
        else:
            out[s] = (text, text)
    return out


def _local(sym: sp.Symbol, names: dict[sp.Symbol, str]) -> str:
    return "_v_" + names[sym].replace("[", "").replace("]", "")


class _Groups:
    """Unique expression tuples, each one branch of one op."""

    def __init__(self) -> None:
        self.keys: dict[tuple, int] = {}
        self.bodies: list[tuple[tuple[sp.Expr, ...], dict]] = []

    def add(self, exprs: Sequence[sp.Expr], names: dict,
            lie: tuple[_Groups, Sequence[sp.Expr], dict] | None = None) -> int:
        """The group of ``exprs``; a new group also adds its Lie derivative to ``lie``."""
        key = tuple(exprs)
        if key not in self.keys:
            self.keys[key] = len(self.bodies)
            self.bodies.append((key, names))
            if lie is not None:  # same index as its value group
                lie[0].bodies.append((tuple(lie[1]), lie[2]))
        return self.keys[key]


def generate(compiled: CompiledModel) -> ModelSource:
    """Print the numeric functions of ``compiled`` as one numba-ready module.

    Raises
    ------
    UnsupportedModel
        When an expression cannot be printed (the caller falls back to the
        reference backend).

    Examples
    --------
    >>> import hybridlab
    >>> src = generate(hybridlab.compile_model(hybridlab.load_model("models/thermostat.toml")))
    >>> src.flow_group, src.cond_group
    ((0, 1), (0, 1))
    >>> "def model(op, group, t, x, p, sigma, f, out):" in src.text
    True
    """
    sym = compiled.symbolic
    base: dict[sp.Symbol, str] = {TIME: "t"}
    base.update({s: f"x[{i}]" for i, s in enumerate(sym.states)})
    base.update({s: f"p[{i}]" for i, s in enumerate(sym.parameters)})
    flow_syms = [sp.Symbol(f"_f{i}", real=True) for i in range(len(sym.states))]
    with_f = {**base, **{s: f"f[{i}]" for i, s in enumerate(flow_syms)}}
    ops = [_Groups() for _ in range(N_OPS)]
    flow_g, cond_g, switch_g, grad_g, dsig_g, slide_g, free, inv_g = ([] for _ in range(8))
    for mode in compiled.modes.values():
        sig = {s.symbol: f"sigma[{k}]" for k, s in enumerate(mode.switches)}
        flow_g.append(ops[OP_FLOW].add(mode.flow.exprs, {**base, **sig}))
        if mode.conditions is not None and mode.conditions.size:
            cond_g.append(ops[OP_COND].add(
                mode.conditions.values.exprs, base,
                (ops[OP_COND_LIE], mode.conditions._lie.exprs, with_f)))
        else:
            cond_g.append(-1)
        inv_g.append(ops[OP_INV_BOX].add(mode.invariants.values.exprs, base)
                     if mode.invariants.size else -1)
        if mode.switches:
            switch_g.append(ops[OP_SWITCH].add(
                mode.switch_fields.values.exprs, {**base, **sig},
                (ops[OP_SWITCH_LIE], mode.switch_fields._lie.exprs, {**with_f, **sig})))
            sigmas = [s.symbol for s in mode.switches]
            grad = [sp.diff(e, x) for e in mode.switch_fields.values.exprs for x in sym.states]
            dsig = [sp.diff(e, s) for e in mode.flow.exprs for s in sigmas]
            grad_g.append(ops[OP_SWITCH_GRAD].add(grad, {**base, **sig}))
            dsig_g.append(ops[OP_FLOW_DSIGMA].add(dsig, {**base, **sig}))
            along = dict(zip(flow_syms, mode.flow.exprs, strict=True))
            lie = [e.xreplace(along) for e in mode.switch_fields._lie.exprs]
            slide_g.append(ops[OP_SLIDE_PARTS].add(
                [*mode.flow.exprs, *lie, *grad, *dsig], {**base, **sig}))
            free.append(int(not any(e.free_symbols & set(sigmas)
                                    for e in mode.switch_fields.values.exprs)))
        else:
            switch_g.append(-1)
            grad_g.append(-1)
            dsig_g.append(-1)
            slide_g.append(-1)
            free.append(1)
    reset_g, guard_g = [], []
    for tr in compiled.transitions:
        reset_g.append(ops[OP_RESET].add(tr.reset.exprs, base))
        if tr.guard is not None:
            guard_g.append(ops[OP_GUARD].add(tr.guard.values.exprs, base,
                                             (ops[OP_GUARD_LIE], tr.guard._lie.exprs, with_f)))
        else:
            guard_g.append(-1)
    for both, (values, lies) in ((OP_COND_BOTH, (OP_COND, OP_COND_LIE)),
                                  (OP_SWITCH_BOTH, (OP_SWITCH, OP_SWITCH_LIE))):
        for (v_exprs, _), (l_exprs, l_names) in zip(ops[values].bodies, ops[lies].bodies,
                                                    strict=True):
            ops[both].bodies.append(((*v_exprs, *l_exprs), l_names))
    for box, values in _BOX_OF.items():
        ops[box].bodies = list(ops[values].bodies)
    lines = [
        '"""Generated by hybridlab.simulation.compiled.codegen; do not edit."""',
        "import math",
        "",
        "import numba",
        "",
        f"from hybridlab.simulation.compiled import interval_ops as _iv  # {_INTERVAL_DIGEST}",
        "from hybridlab.simulation.compiled.signatures import MODEL_SIGNATURE",
        "",
        "",
        "@numba.njit(inline='always')",
        "def _sign(v):",
        "    return 0.0 if v == 0 else math.copysign(1.0, v)",
    ]
    n = len(sym.states)
    for function, wanted in (("model", lambda op: op not in _BOX_OPS),
                             ("box", _BOX_OPS.__contains__)):
        # two functions: the point ops stay as small as they were without the box ops
        lines += ["", "", "@numba.cfunc(MODEL_SIGNATURE, cache=True, error_model='numpy')",
                  f"def {function}(op, group, t, x, p, sigma, f, out):"]
        first_op = True
        for op, groups in enumerate(ops):
            if not groups.bodies or not wanted(op):
                continue
            lines.append(f"    {'if' if first_op else 'elif'} op == {op}:")
            first_op = False
            for g, (exprs, names) in enumerate(groups.bodies):
                lines.append(f"        {'if' if g == 0 else 'elif'} group == {g}:")
                if op in _BOX_OPS:
                    body = box_body(exprs, _box_symbols(names, n), " " * 12)
                else:
                    body = _body(exprs, names, " " * 12)
                lines.extend(body or ["            pass"])
        if first_op:
            lines.append("    pass")
    return ModelSource("\n".join(lines) + "\n", tuple(flow_g), tuple(cond_g), tuple(switch_g),
                       tuple(reset_g), tuple(guard_g), tuple(grad_g), tuple(dsig_g),
                       tuple(slide_g), tuple(free), tuple(inv_g))


def active_states(compiled: CompiledModel) -> tuple[list[int], list[int]]:
    """Per mode, the states the integrator must combine: ``(pointer, list)``.

    A state is *active* in a mode when its flow there is not identically
    zero or a switching function of the mode reads it (the sliding
    projection moves along the switches' gradients). The others keep their
    value through every step, which the kernel uses to skip them; scipy's
    error norm still divides by the full state count, so the steps are the
    same.

    Examples
    --------
    >>> import hybridlab
    >>> compiled = hybridlab.compile_model(hybridlab.load_model("models/thermostat.toml"))
    >>> pointer, states = active_states(compiled)
    >>> len(pointer) == len(compiled.modes) + 1
    True
    """
    states = compiled.symbolic.states
    pointer, listed = [0], []
    for mode in compiled.modes.values():
        read = set()
        for e in mode.switch_fields.values.exprs:
            read |= e.free_symbols
        listed += [i for i, (s, e) in enumerate(zip(states, mode.flow.exprs, strict=True))
                   if e != 0 or s in read]
        pointer.append(len(listed))
    return pointer, listed
