"""The model's equations prepared for reachability: extended state, inputs, derivatives.

Reachability works on an *extended state* ``z``: the model's states, then one
state per uncertain constant parameter (zero flow: the value is unknown but
fixed), then time ``t`` (flow 1) when any flow, guard, invariant or reset
depends on it. The *inputs* ``u`` are the parameters that vary in time within
bounds (``inputs=``), then the sign symbols ``sigma_k`` of the mode's
discontinuities (see :mod:`hybridlab.symbolic.discontinuities`). Every other
parameter is substituted by its value.

Discrete variables are model states here, with the flow 0 in every mode: dimensions of the
sets that stay one point while their value is known (their initial value is one number,
and a reset to a constant or to known values keeps it one) and take the width of what a
reset assigns from continuous states (``level = x``). They are not split out of the sets
by value; a boolean guard ``armed`` is the row ``armed - 1/2 >= 0``. Where every way into a
mode gives one the same number, :mod:`~hybridlab.reachability.constants` substitutes it in
what that mode reads.

Everything here is derived once per :func:`reach` call from the sympy form;
model text is never evaluated.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import sympy as sp

from hybridlab.model.checks import TIME
from hybridlab.model.expressions import as_expression
from hybridlab.reachability.cubic import ThirdOrder
from hybridlab.reachability.derivatives import Derivatives, jacobian
from hybridlab.reachability.meanvalue import MeanValue
from hybridlab.symbolic.compile import CompiledModel
from hybridlab.symbolic.discontinuities import extract_switches
from hybridlab.symbolic.functions import _no_impulses
from hybridlab.symbolic.intervals import IntervalFunction
from hybridlab.symbolic.lagrange import mode_flow, model_equations
from hybridlab.symbolic.printing import numpy_function

__all__ = ["Rows", "ModeSystem", "ResetMap", "System", "build_system"]


def _lambdify(exprs: Sequence[sp.Expr], args: Sequence[Sequence[sp.Symbol]]):
    f = numpy_function([list(a) for a in args], exprs)

    def call(*values: np.ndarray) -> np.ndarray:
        return np.array(f(*values), dtype=float).reshape(len(exprs))

    return call


def _constant_gradient(exprs: Sequence[sp.Expr], syms: Sequence[sp.Symbol]) -> np.ndarray | None:
    """The matrix ``d expr_i / d sym_j`` when every expression is affine in ``syms``."""
    J = jacobian(exprs, syms)
    if any(d.free_symbols for d in J):
        return None
    return np.array(J.tolist(), dtype=float).reshape(len(exprs), len(syms))


class Rows:
    """Inequalities ``g_i(z) >= 0`` (guards, invariants, switching functions).

    Linear rows are bounded exactly through support functions, the others by the
    mean-value form over the zonotope (:class:`~hybridlab.reachability.meanvalue.MeanValue`),
    never wider than interval arithmetic over its interval hull: a guard such as
    ``x_ref - x_e <= v_p**2/2`` keeps the correlation of ``x_ref`` and ``x_e`` that the
    hull loses.

    Examples
    --------
    >>> from hybridlab.reachability.sets import Zonotope
    >>> x, y = sp.symbols("x y", real=True)
    >>> rows = Rows([x - 1, x * y], [x, y])
    >>> rows.linear.tolist(), rows.a[0].tolist(), float(rows.b[0])
    ([True, False], [1.0, 0.0], -1.0)
    >>> rows.range(Zonotope([2.0, 1.0], [[0.5, 0.0], [0.0, 0.5]])).round(9).tolist()
    [[0.5, 1.5], [0.75, 3.75]]
    """

    def __init__(self, exprs: Sequence[sp.Expr], zsyms: Sequence[sp.Symbol],
                 texts: Sequence[str] = ()) -> None:
        self.exprs = tuple(exprs)
        self.texts = tuple(texts) or tuple(str(e) for e in exprs)
        self.size = len(self.exprs)
        self.linear = np.zeros(self.size, dtype=bool)
        self.a = np.zeros((self.size, len(zsyms)))
        self.b = np.zeros(self.size)
        zero = dict.fromkeys(zsyms, 0)
        for i, e in enumerate(self.exprs):
            grad = _constant_gradient([e], zsyms)
            if grad is not None:
                self.linear[i] = True
                self.a[i] = grad[0]
                self.b[i] = float(e.xreplace(zero))
        self._interval: IntervalFunction | None = (IntervalFunction(self.exprs, zsyms)
                                                   if self.size else None)
        # the rows by kind, for range (run at every step)
        self._lin = np.flatnonzero(self.linear)
        self._a_lin, self._b_lin = self.a[self._lin], self.b[self._lin]
        self._abs_b_lin = np.abs(self._b_lin)
        self._nonlin = np.flatnonzero(~self.linear)
        self._zsyms = tuple(zsyms)
        self._mean: MeanValue | None = None  # built at the first nonlinear range

    def range(self, Z, box: np.ndarray | None = None) -> np.ndarray:
        """Enclosure ``(size, 2)`` of every row over the zonotope ``Z``."""
        out = np.empty((self.size, 2))
        if self.size == 0:
            return out
        G, c = Z.generators, Z.center
        lin = self._lin
        if lin.size:
            a = self._a_lin
            mid = a @ c + self._b_lin
            rad = np.abs(a @ G).sum(axis=1)
            slack = 1e-13 * (np.abs(mid) + rad + self._abs_b_lin) + 1e-300
            out[lin, 0] = mid - rad - slack
            out[lin, 1] = mid + rad + slack
        nonlin = self._nonlin
        if nonlin.size:
            box = Z.bounds() if box is None else box
            if self._interval is None:  # built whenever there are rows
                raise RuntimeError("rows without their interval function")
            lo, hi = self._interval(box[:, 0], box[:, 1])
            out[nonlin, 0] = lo[nonlin]
            out[nonlin, 1] = hi[nonlin]
            if Z.generators.shape[1] and np.any((lo[nonlin] < 0) & (hi[nonlin] > 0)):
                # a row in doubt over the hull: the mean-value form keeps the set's
                # correlations (it is intersected with the hull's enclosure)
                none = np.zeros(0)
                out[nonlin, 0], out[nonlin, 1] = self._mean_value()(Z, none, none, box)
        return out

    def affine_bounds(self, Z, box: np.ndarray | None = None
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(a, lo, hi)`` with ``g_i(z) - a_i . z`` in ``[lo_i, hi_i]`` for every row and
        every ``z`` in ``Z``: exact for linear rows (``lo = hi = b``), the mean-value form
        over ``Z``'s hull for the others (non-finite where it does not apply)."""
        a, lo, hi = self.a.copy(), self.b.copy(), self.b.copy()
        nonlin = self._nonlin
        if nonlin.size:
            a[nonlin], lo[nonlin], hi[nonlin] = self._mean_value().affine_bounds(
                Z, Z.bounds() if box is None else box)
        return a, lo, hi

    def _mean_value(self) -> MeanValue:
        """The mean-value form of the nonlinear rows (built at its first use)."""
        if self._mean is None:
            self._mean = MeanValue([self.exprs[i] for i in self._nonlin], self._zsyms, ())
        return self._mean


@dataclass(frozen=True, eq=False)
class ResetMap:
    """A transition's reset on the extended state: ``z+ = M z + r`` when affine.

    Examples
    --------
    The ball's bounce ``v+ = -e v`` is affine for a known ``e``; with ``e`` an uncertain
    constant (an extended state, which the reset keeps) it is not:

    >>> import hybridlab
    >>> c = hybridlab.compile_model(hybridlab.load_model("models/bouncing_ball.toml"))
    >>> bounce = build_system(c, c.parameter_vector(), {}, {}).resets[0]
    >>> bounce.matrix.tolist(), bounce.offset.tolist()
    ([[1.0, 0.0], [0.0, -0.8]], [0.0, 0.0])
    >>> uncertain = build_system(c, c.parameter_vector(), {"e": (0.7, 0.9)}, {}).resets[0]
    >>> uncertain.exprs, uncertain.matrix is None
    ((h, -e*v, e), True)
    >>> uncertain.value(np.array([0.0, -10.0, 0.8])).tolist()
    [0.0, 8.0, 0.8]
    """

    exprs: tuple[sp.Expr, ...]
    zsyms: tuple[sp.Symbol, ...]

    @cached_property
    def matrix(self) -> np.ndarray | None:
        return _constant_gradient(self.exprs, self.zsyms)

    @cached_property
    def offset(self) -> np.ndarray:
        zero = dict.fromkeys(self.zsyms, 0)
        return np.array([float(e.xreplace(zero)) for e in self.exprs])

    @cached_property
    def value(self):
        return _lambdify(self.exprs, [self.zsyms])

    @cached_property
    def jacobian_interval(self) -> IntervalFunction:
        jac = jacobian(self.exprs, self.zsyms)
        return IntervalFunction([_no_impulses(e) for e in jac], self.zsyms)


@dataclass(frozen=True, eq=False)
class ModeSystem:
    """The flow of one mode over ``w = (z, u)``: value, Jacobians, Hessian enclosure.

    Examples
    --------
    The thermostat heating, ``T' = -a (T - T_heat)`` with ``a = 0.1``, ``T_heat = 40``:

    >>> import hybridlab
    >>> c = hybridlab.compile_model(hybridlab.load_model("models/thermostat.toml"))
    >>> heat = build_system(c, c.parameter_vector(), {}, {}).modes["heat"]
    >>> z, u = np.array([20.0]), np.array([])
    >>> heat.value(z, u).tolist(), heat.jacobian(z, u).tolist()
    ([2.0], [[-0.1]])
    >>> heat.affine, heat.hessian is None, heat.invariants.texts
    (True, True, ('T <= T_high',))
    """

    name: str
    flow: tuple[sp.Expr, ...]
    zsyms: tuple[sp.Symbol, ...]
    usyms: tuple[sp.Symbol, ...]
    #: rows of the switching functions ``s_k``, aligned with the sigma inputs
    switches: Rows
    #: index of each switch's sigma in ``u``
    sigma_index: tuple[int, ...]
    invariants: Rows
    #: the derivatives taken so far, shared with the modes of the same system
    derivatives: Derivatives = field(default_factory=Derivatives, repr=False)

    @cached_property
    def wsyms(self) -> tuple[sp.Symbol, ...]:
        return self.zsyms + self.usyms

    @cached_property
    def value(self):
        return _lambdify(self.flow, [self.zsyms, self.usyms])

    @cached_property
    def _jac(self) -> sp.Matrix:
        return self.derivatives.jacobian(self.flow, self.wsyms)

    @cached_property
    def jacobian(self):
        """``(z, u) -> d f / d w``, shape ``(nz, nz + nu)``."""
        f = _lambdify(list(self._jac), [self.zsyms, self.usyms])
        shape = self._jac.shape
        return lambda z, u: f(z, u).reshape(shape)

    @cached_property
    def hessian(self) -> IntervalFunction | None:
        """Interval enclosure of every ``d2 f_i / dw_j dw_k``; ``None`` when ``f`` is affine."""
        jac, ws = self._jac, self.wsyms
        nz, nw = jac.shape
        entries: list[sp.Expr] = [sp.Integer(0)] * (nz * nw * nw)
        for i in range(nz):
            for j in range(nw):
                e = jac[i, j]
                free = e.free_symbols
                for k in range(j, nw):  # symmetric in j and k: each pair differentiated once
                    if ws[k] in free:
                        entries[(i * nw + j) * nw + k] = entries[(i * nw + k) * nw + j] = \
                            self.derivatives.of(e, ws[k])
        if all(e == 0 for e in entries):
            return None
        return IntervalFunction(entries, ws)

    @cached_property
    def third(self) -> ThirdOrder | None:
        """The third derivatives of the flow, for the third-order remainder
        (:mod:`~hybridlab.reachability.cubic`); ``None`` when all are zero."""
        return ThirdOrder.of(self._jac, self.wsyms, self.derivatives)

    @cached_property
    def affine(self) -> bool:
        """Whether the flow is affine in ``w``: every Jacobian entry is free of ``w``
        (a cheaper test than the Hessian, which large affine modes never need)."""
        w = set(self.wsyms)
        return not any(e.free_symbols & w for e in self._jac)

    @cached_property
    def flow_interval(self) -> IntervalFunction:
        """Interval enclosure of the flow ``f(z, u)`` over a box of ``w``."""
        return IntervalFunction([_no_impulses(e) for e in self.flow], self.wsyms)

    @cached_property
    def _slides(self) -> dict[int, ModeSystem | None]:
        return {}

    def sliding(self, k: int) -> ModeSystem | None:
        """The flow on the surface of switch ``k`` (Filippov's equivalent control), or ``None``.

        On the surface ``s_k = a z + b = 0`` of a linear switching function, with a flow
        affine in its sign, ``f = f0 + g sigma_k``, a Filippov solution that stays on the
        surface has ``a f = 0``, so ``sigma_k = -(a f0) / (a g)`` and the flow is
        ``f0 - g (a f0) / (a g)``: a smooth flow wherever ``a g != 0``. It is ``None`` for
        a nonlinear switching function or a flow not affine in ``sigma_k``. The returned
        mode has the same states, inputs, switches and invariants (``sigma_k`` stays an
        input the flow no longer reads).

        Examples
        --------
        A block held by friction under a force ``y`` that decays with the friction it meets
        (``v' = y - 2 sign(v)``, ``y' = -y - sign(v)``): on ``v = 0`` the friction is ``y/2``,
        so ``y' = -3 y / 2``:

        >>> v, y, s = sp.symbols("v y s", real=True)
        >>> mode = ModeSystem("stuck", (y - 2 * s, -y - s), (v, y), (s,),
        ...                   Rows([v], (v, y)), (0,), Rows([], (v, y)))
        >>> mode.sliding(0).flow
        (0, -3*y/2)
        """
        if k not in self._slides:
            self._slides[k] = self._sliding(k)
        return self._slides[k]

    def _surface_parts(self, k: int) -> tuple[list[sp.Expr], list[sp.Expr], sp.Expr,
                                              sp.Expr] | None:
        """``(f0, g, a f0, a g)`` of ``f = f0 + g sigma_k`` on switch ``k``'s surface."""
        if not self.switches.linear[k]:
            return None
        sigma = self.usyms[self.sigma_index[k]]
        g = [sp.diff(e, sigma) for e in self.flow]
        if any(sigma in gi.free_symbols for gi in g):
            return None
        f0 = [e.xreplace({sigma: 0}) for e in self.flow]
        # the surface's own coefficients (exact, as the model states them), not their floats
        coef = [sp.diff(self.switches.exprs[k], z) for z in self.zsyms]
        a_f0 = sp.Add(*[c * e for c, e in zip(coef, f0, strict=True) if c != 0])
        a_g = sp.Add(*[c * e for c, e in zip(coef, g, strict=True) if c != 0])
        if a_g == 0:
            return None
        return f0, g, a_f0, a_g

    def equivalent_control(self, k: int) -> sp.Expr | None:
        """``-(a f0) / (a g)``: the sign ``sigma_k`` that keeps a state on switch ``k``'s
        surface (``None`` where :meth:`sliding` is).

        Examples
        --------
        >>> v, y, s = sp.symbols("v y s", real=True)
        >>> mode = ModeSystem("stuck", (y - 2 * s, -y - s), (v, y), (s,),
        ...                   Rows([v], (v, y)), (0,), Rows([], (v, y)))
        >>> mode.equivalent_control(0)
        y/2
        """
        parts = self._surface_parts(k)
        return None if parts is None else -parts[2] / parts[3]

    def _sliding(self, k: int) -> ModeSystem | None:
        parts = self._surface_parts(k)
        if parts is None:
            return None
        f0, g, a_f0, a_g = parts
        slide = tuple(e0 - gi * a_f0 / a_g if gi != 0 else e0
                      for e0, gi in zip(f0, g, strict=True))
        return ModeSystem(name=f"{self.name} sliding on {self.switches.texts[k]} = 0",
                          flow=slide, zsyms=self.zsyms, usyms=self.usyms,
                          switches=self.switches, sigma_index=self.sigma_index,
                          invariants=self.invariants, derivatives=self.derivatives)

    def lie_exprs(self, rows: Rows) -> list[sp.Expr]:
        """The time derivatives of ``rows`` along this flow."""
        return [_no_impulses(sum((sp.diff(e, z) * f
                                  for z, f in zip(self.zsyms, self.flow, strict=True)),
                                 sp.Integer(0))) for e in rows.exprs]

    def lie(self, rows: Rows) -> IntervalFunction:
        """Interval enclosure of the time derivatives of ``rows`` along this flow."""
        return IntervalFunction(self.lie_exprs(rows), self.wsyms)


@dataclass(frozen=True, eq=False)
class System:
    """Everything :func:`hybridlab.reach` needs from the model, for one set of parameters.

    Examples
    --------
    The relay with a bounded disturbance amplitude: ``t`` is an extended state (the flow
    reads it), and each input box holds ``w0`` and the sign of ``x`` (free in ``[-1, 1]``):

    >>> import hybridlab
    >>> c = hybridlab.compile_model(hybridlab.load_model("models/relay_sliding.toml"))
    >>> system = build_system(c, c.parameter_vector(), {}, {"w0": (-0.5, 0.5)})
    >>> system.znames, system.time_index, system.modes["relay"].usyms
    (('x', 't'), 1, (w0, _rsigma0))
    >>> [bound.tolist() for bound in system.input_box("relay")]
    [[-0.5, -1.0], [0.5, 1.0]]
    """

    compiled: CompiledModel
    zsyms: tuple[sp.Symbol, ...]
    #: names of the extended states: model states, uncertain parameters, then ``t``
    znames: tuple[str, ...]
    n_states: int
    uncertain: Mapping[str, tuple[float, float]]
    inputs: Mapping[str, tuple[float, float]]
    timed: bool
    modes: Mapping[str, ModeSystem]
    guards: Mapping[int, Rows]
    resets: Mapping[int, ResetMap]
    #: point values substituted for the other parameters
    values: Mapping[sp.Symbol, float]

    @property
    def time_index(self) -> int | None:
        return len(self.zsyms) - 1 if self.timed else None

    def input_box(self, mode: str) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of ``u`` with every sigma free in ``[-1, 1]``."""
        m = self.modes[mode]
        lo = np.array([self.inputs[str(s)][0] for s in m.usyms[:len(self.inputs)]]
                      + [-1.0] * len(m.sigma_index))
        hi = np.array([self.inputs[str(s)][1] for s in m.usyms[:len(self.inputs)]]
                      + [1.0] * len(m.sigma_index))
        return lo, hi


def build_system(compiled: CompiledModel, values: np.ndarray,
                 uncertain: Mapping[str, tuple[float, float]],
                 inputs: Mapping[str, tuple[float, float]]) -> System:
    """Substitute parameters and build the extended-state form of every mode.

    Parameters
    ----------
    compiled : CompiledModel
    values : array
        Parameter values in declaration order (uncertain and input entries ignored).
    uncertain : mapping
        Uncertain constant parameters and their bounds.
    inputs : mapping
        Time-varying bounded inputs and their bounds.

    Examples
    --------
    >>> import hybridlab
    >>> c = hybridlab.compile_model(hybridlab.load_model("models/thermostat.toml"))
    >>> s = build_system(c, c.parameter_vector(), {"a": (0.09, 0.11)}, {})
    >>> s.znames, s.modes["heat"].affine
    (('T', 'a'), False)
    """
    sym = compiled.symbolic
    pmap = dict(zip(sym.parameter_names, sym.parameters, strict=True))
    fixed = {pmap[n]: float(v) for n, v in zip(sym.parameter_names, values, strict=True)
             if n not in uncertain and n not in inputs}
    usyms_in = tuple(pmap[n] for n in inputs)
    equations = model_equations(sym)

    def subs(e: sp.Expr) -> sp.Expr:
        # as_expression again: an expression that is one fixed parameter (a reset
        # ``x_e = p``) becomes that parameter's value, which xreplace leaves a float
        return as_expression(as_expression(e).xreplace(fixed))

    flows = {name: tuple(subs(e) for e in mode_flow(sym, name, equations))
             for name in sym.modes}
    guard_exprs = {tr.index: tuple(subs(r.expr) for r in tr.guard) for tr in sym.transitions}
    reset_exprs = {tr.index: tuple(subs(e) for e in tr.reset) for tr in sym.transitions}
    inv_exprs = {name: tuple(subs(r.expr) for r in m.invariants) for name, m in sym.modes.items()}
    everything = [e for f in flows.values() for e in f]
    everything += [e for g in guard_exprs.values() for e in g]
    everything += [e for r in reset_exprs.values() for e in r]
    everything += [e for i in inv_exprs.values() for e in i]
    timed = any(TIME in as_expression(e).free_symbols for e in everything)
    zsyms = tuple(sym.states) + tuple(pmap[n] for n in uncertain) + ((TIME,) if timed else ())
    znames = tuple(sym.state_names) + tuple(uncertain) + (("t",) if timed else ())
    extra_flow = (sp.Integer(0),) * len(uncertain) + ((sp.Integer(1),) if timed else ())
    extra_reset = tuple(pmap[n] for n in uncertain) + ((TIME,) if timed else ())

    modes = {}
    derivatives = Derivatives()  # the modes' rows repeat: each derivative taken once
    for name, m in sym.modes.items():
        smooth, switches = extract_switches(flows[name], prefix="_rsigma")
        usyms = usyms_in + tuple(s.symbol for s in switches)
        modes[name] = ModeSystem(
            name=name, flow=tuple(smooth) + extra_flow, zsyms=zsyms, usyms=usyms,
            switches=Rows([s.expr for s in switches], zsyms, [s.text for s in switches]),
            sigma_index=tuple(range(len(usyms_in), len(usyms))),
            invariants=Rows(inv_exprs[name], zsyms, [r.text for r in m.invariants]),
            derivatives=derivatives,
        )
    guards = {tr.index: Rows(guard_exprs[tr.index], zsyms, [r.text for r in tr.guard])
              for tr in sym.transitions}
    resets = {tr.index: ResetMap(reset_exprs[tr.index] + extra_reset, zsyms)
              for tr in sym.transitions}
    return System(compiled=compiled, zsyms=zsyms, znames=znames, n_states=len(sym.states),
                  uncertain=dict(uncertain), inputs=dict(inputs), timed=timed, modes=modes,
                  guards=guards, resets=resets, values=fixed)
