"""A reachability step for any mode: conservative linearisation (Althoff, Stursberg, Buss 2008).

In each step the flow ``z' = f(z, u)`` is linearised at ``w* = (z*, u*)`` (the
centre of the current set advanced by half a step, and the centre of the input
box)::

    f(z, u) = f(w*) + A (z - z*) + B (u - u*) + L,

and the affine system is advanced by :func:`~hybridlab.reachability.linear.affine_step`
with the time-varying input ``B (u - u*) + L``. The Lagrange remainder ``L``
is bounded over the step's own enclosure ``H`` (an a-posteriori check): its
``i``-th entry is at most ``1/2 sum_jk |d2 f_i / dw_j dw_k| |dw_j| |dw_k|``,
with the Hessian entries (derived by sympy) enclosed by interval arithmetic
over the interval hull of ``H`` and the input box. The step starts from a guess
of ``L``; if the bound over the resulting ``H`` exceeds the guess, the guess is
enlarged and the step repeated. Once it holds, every trajectory of the true
system stays in ``H`` (the linearised inclusion with that ``L`` contains the
true flow wherever ``H`` does). For affine flows the Hessian is zero and one
pass suffices, so affine modes are exactly the Girard/Althoff linear method.

Why conservative linearisation rather than Taylor models: the sets stay
zonotopes end to end (guards, resets, clustering and the linear case share one
representation), the cost per step is a handful of small matrix products, and
the sympy Hessians are exact; the price is a remainder that grows with the
set's size, which the time step and the initial set's width control.

Discontinuous flows: each ``sigma_k`` (the sign of a switching function
``s_k``, see :mod:`hybridlab.symbolic.discontinuities`) is held at +-1 when
``s_k`` has that sign over the whole step enclosure ``H`` (checked after the
step, which is then repeated with ``sigma_k`` free if the check fails), and is
otherwise a free input in ``[-1, 1]``: the Filippov set-valued flow on the
surface lies in that convex hull when the flow is affine in the ``sigma``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from hybridlab.reachability.chain import AffineChain, Ahead
from hybridlab.reachability.lifting import ClockLift
from hybridlab.reachability.linear import Propagator, StepError, affine_step
from hybridlab.reachability.meanvalue import MeanValue
from hybridlab.reachability.modal import eigenbasis
from hybridlab.reachability.options import ReachOptions
from hybridlab.reachability.rounding import PRODUCT_SLACK, SLACK
from hybridlab.reachability.sets import Zonotope
from hybridlab.reachability.surfaces import SurfaceSteps, signs_box
from hybridlab.reachability.system import ModeSystem, System
from hybridlab.reachability.taylor import TaylorError, TaylorFlowpipe, TaylorSet, bend

__all__ = ["FlowStepper", "RemainderError", "TAYLOR_APPLIES", "remainder_bound"]

TAYLOR_APPLIES = ", or take Taylor models (flowpipe='taylor'), which apply to this mode"
"""Appended to a linearisation's failure in a mode Taylor models apply to."""


class RemainderError(StepError):
    """A nonlinear mode's set is too wide for its linearisation: the remainder does not
    settle, or overflows. A smaller step, or the initial set split into pieces, helps.

    Examples
    --------
    >>> issubclass(RemainderError, StepError)
    True
    """

_SETTLED_CHAIN = 64
"""Steps after which a chain with a free sign runs on through a short stretch where the
sign is known (:meth:`FlowStepper._covers`)."""


class FlowStepper(SurfaceSteps):
    """Steps of one mode's flow; keeps the propagator cache and the remainder guess.

    Examples
    --------
    >>> import hybridlab
    >>> from hybridlab.reachability.system import build_system
    >>> c = hybridlab.compile_model(hybridlab.load_model("models/thermostat.toml"))
    >>> system = build_system(c, c.parameter_vector(), {}, {})
    >>> stepper = FlowStepper(system, "heat", ReachOptions())
    >>> P1, H = stepper.step(Zonotope([20.0], [[0.1]]), 0.1)
    >>> exact_hi = 40 - (40 - 20.1) * np.exp(-0.1 * 0.1)   # T' = -0.1 (T - 40) from 20.1
    >>> lo, hi = H.bounds()[0]
    >>> bool(lo <= 19.9 and exact_hi <= hi < exact_hi + 2e-3)
    True
    """

    def __init__(self, system: System, mode: str, options: ReachOptions,
                 flow: ModeSystem | None = None) -> None:
        self.system = system
        # the mode's flow, or the one of a phase of it (reachability.phases)
        self.mode: ModeSystem = system.modes[mode] if flow is None else flow
        self.options = options
        n_in = len(system.inputs)
        lo, hi = system.input_box(mode)
        self.input_lo, self.input_hi = lo[:n_in], hi[:n_in]
        self.n_sigma = len(self.mode.sigma_index)
        self._props: dict[tuple[bytes, bytes, float], Propagator] = {}
        # the remainder guess of each flow (the mode's, and its sliding flows')
        self._remainders: dict[str, np.ndarray] = {}
        self._rates: MeanValue | None = None
        self._equivalent: dict[int, MeanValue] = {}
        self._approach: tuple[Zonotope, np.ndarray] | None = None
        self._affine_A: np.ndarray | None = None
        self._reduction_basis: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._basis_sought = False  # an affine mode's eigenbasis is sought once
        # an affine mode is stepped by an AffineChain while its signs keep the ranges the
        # chain was built with (each known, or free: an input in [-1, 1]); the chain
        # continues while it is handed back its own last end set and a known sign holds
        # over every step's set
        self._chain: AffineChain | None = None
        self._chain_end: Zonotope | None = None
        self._chain_signs = np.zeros((0, 2))
        # the chain's last flowpipe set: its generators are Phi^k times the first set's, in
        # the same order, which a run of them joined at a guard (sweep_hull) relies on
        self._chain_set: Zonotope | None = None
        # a mode affine but for its clocks' monomials steps lifted (reachability.lifting);
        # its chain's sets are projected back on the mode's states
        self._clock_lift: ClockLift | None = None
        self._lift_sought = False
        self._chain_project: Callable[[Zonotope], Zonotope] | None = None
        # with flowpipe="taylor", a nonlinear mode's Taylor model continues while the
        # stepper is handed back the zonotope of its own last end set (see _taylor_step)
        self._taylor: TaylorFlowpipe | None = None
        self._taylor_sought = False
        self._taylor_set: TaylorSet | None = None
        self._taylor_end: Zonotope | None = None
        # the zonotope the Taylor model started from, and where the last one bent most
        self._taylor_origin: Zonotope | None = None
        self._failed_bend: tuple[Zonotope, np.ndarray] | None = None

    def reduce(self, Z: Zonotope, order: float) -> Zonotope:
        """``Z`` reduced to ``order``; for an affine mode, boxed in its eigenvector basis
        (where the flow contracts, so a box mapped and boxed again does not grow), except
        a chain's own sets (see :mod:`.chain`)."""
        chain = self._chain
        if chain is not None and (Z is self._chain_end or Z is self._chain_set):
            return Z  # a chain's set: its size is bounded, and reducing it would wrap
        if chain is not None and Z is chain.first[1]:
            # the chain's first flowpipe set: the chain maps its own reduction, never this
            # one, so it is boxed along the axes, where its bounds stay exact
            return Z.reduce(order)
        if self._taylor_end is not None and Z is self._taylor_end:
            return Z  # a Taylor model's end set: few generators, and the model goes on
        return Z.reduce(order, self._basis())

    def _basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        if self._affine_A is not None:
            self._reduction_basis = eigenbasis(self._affine_A)
            self._affine_A = None  # computed (or found missing) once
        return self._reduction_basis

    def reset(self) -> None:
        """Forget the remainder guess and the affine chain (a new flowpipe starts)."""
        self._remainders.clear()
        self._chain = None
        self._taylor_set = self._taylor_end = None
        self._taylor_origin = self._failed_bend = None

    def _sigma_signs(self, Z: Zonotope) -> np.ndarray:
        """+1/-1 where the switching function has that sign over ``Z``, 0 where free."""
        if self.n_sigma == 0:
            return np.zeros(0)
        rng = self.mode.switches.range(Z)
        return np.where(rng[:, 0] > 0, 1.0, np.where(rng[:, 1] < 0, -1.0, 0.0))

    def sign_ranges(self, Z: Zonotope) -> np.ndarray:
        """Ranges ``(n_sigma, 2)`` of the signs over ``Z``: ``+-1`` where the switching
        function has that sign, ``[-1, 1]`` where it may be 0."""
        return signs_box(self._sigma_signs(Z))

    def _propagator(self, A: np.ndarray, c: np.ndarray, r: float) -> Propagator:
        key = (A.tobytes(), c.tobytes(), r)
        prop = self._props.get(key)
        if prop is None:
            if len(self._props) > 512:
                self._props.clear()
            prop = Propagator.build(A, c, r, self.options.taylor_terms)
            self._props[key] = prop
        return prop

    def chain_for(self, P: Zonotope, r: float) -> AffineChain | None:
        """The affine chain that continues from ``P`` in steps of ``r``, if there is one."""
        chain = self._chain
        if chain is not None and P is self._chain_end and chain.prop.r == r and not chain.worn:
            return chain
        return None

    def quiet_chain(self, P: Zonotope, r: float) -> AffineChain | None:
        """:meth:`chain_for` where the chain's steps need no check of their own and are
        over the mode's states: none of its signs is held known (a held sign is checked
        over each step's set) and it is not lifted."""
        held = self._chain_signs[:, 0] == self._chain_signs[:, 1]
        if np.any(held) or self._chain_project is not None:
            return None
        return self.chain_for(P, r)

    def _lift(self) -> ClockLift | None:
        """The mode's lift to an affine flow over its clocks' monomials, if it has one."""
        if not self._lift_sought:
            self._lift_sought = True
            self._clock_lift = ClockLift.of(self.mode) if self.options.lift_clocks else None
        return self._clock_lift

    def skip(self, chain: AffineChain, ahead: Ahead, taken: int) -> Zonotope:
        """Take ``taken`` steps of ``chain`` looked ahead (:meth:`AffineChain.ahead`);
        returns the end set, from which :meth:`step` continues the chain."""
        self._chain_end = chain.skip(ahead, taken)
        return self._chain_end

    def step(self, P: Zonotope, r: float) -> tuple[Zonotope, Zonotope]:
        """``(P_next, H)`` from ``P`` over a step of length ``r``.

        Raises
        ------
        StepError
            When the remainder does not settle within ``options.remainder_iterations``
            (the set or the step is too large for the linearisation).
        """
        chain = self.chain_for(P, r)
        if self.n_sigma == 0 and chain is not None:
            return self._advance(chain)
        taylor = self._taylor_flowpipe()
        if taylor is not None:
            return self._taylor_step(taylor, P, r)
        if self.n_sigma == 0:
            return self._step_with(P, r, np.zeros((0, 2)), self.mode)
        sig = signs_box(self._sigma_signs(P))
        on_surface = self._surface_step(P, r, sig)
        if on_surface is not None:
            return on_surface
        stepped = None
        ranges = self._chain_signs
        if chain is not None and self._covers(chain, ranges, sig, P):
            stepped = self._advance(chain)
            held = ranges[:, 0] == ranges[:, 1]
            if np.any(held & (self._sigma_signs(stepped[1]) != ranges[:, 0])):
                self._chain, stepped = None, None  # a known sign breaks within the step
            else:
                sig = ranges
        if stepped is None:
            P_next, H, sig = self._settled(P, r, sig, self.mode)
        else:
            P_next, H = stepped
        return self._attractive_cut(P, P_next, H, sig, sig[:, 0] < sig[:, 1], r)

    def span(self, P: Zonotope, length: float) -> Zonotope:
        """Every state reached from ``P`` within ``length``: the set of one step of that
        length, taken aside, so the flowpipe's own next step is the one it would have been
        (the affine chain it continues, the remainder guess and the bounds it carries are
        left as they were).

        A run of steps joined this way keeps the correlations the flow gives its states,
        whatever the layouts of the run's own sets.

        Raises
        ------
        StepError
            As :meth:`step` does.

        Examples
        --------
        >>> import hybridlab
        >>> from hybridlab.reachability.system import build_system
        >>> c = hybridlab.compile_model(hybridlab.load_model("models/thermostat.toml"))
        >>> stepper = FlowStepper(build_system(c, c.parameter_vector(), {}, {}), "heat",
        ...                       ReachOptions())
        >>> whole = stepper.span(Zonotope([20.0], [[0.1]]), 0.3)
        >>> P1, H1 = stepper.step(Zonotope([20.0], [[0.1]]), 0.1)
        >>> bool(whole.bounds()[0, 1] >= H1.bounds()[0, 1])
        True
        """
        kept = (self._chain, self._chain_end, self._chain_set, self._chain_signs,
                self._chain_project, self._approach, self._taylor_set, self._taylor_end,
                self._taylor_origin, self._failed_bend,
                {name: r.copy() for name, r in self._remainders.items()})
        try:
            return self.step(P, length)[1]
        finally:
            (self._chain, self._chain_end, self._chain_set, self._chain_signs,
             self._chain_project, self._approach, self._taylor_set, self._taylor_end,
             self._taylor_origin, self._failed_bend, self._remainders) = kept

    def _covers(self, chain: AffineChain, ranges: np.ndarray, sig: np.ndarray,
                P: Zonotope) -> bool:
        """Whether ``chain``, built for the sign ``ranges``, continues over ``P``, whose
        signs are ``sig``: each range must contain ``sig``'s (a free sign covers a known
        one, soundly). A sign known over ``P`` but free in the chain keeps the chain only
        when the chain has run :data:`_SETTLED_CHAIN` steps (its input sum is large, and a
        new chain would start from that large set) and ``P`` lies within its own width of
        the surface (it will straddle it again soon; a set that moves away is better
        served by a chain of the known sign)."""
        if not bool(np.all((ranges[:, 0] <= sig[:, 0]) & (sig[:, 1] <= ranges[:, 1]))):
            return False
        newly = (sig[:, 0] == sig[:, 1]) & (ranges[:, 0] < ranges[:, 1])
        if not np.any(newly):
            return True
        if chain.steps < _SETTLED_CHAIN:
            return False
        rng = self.mode.switches.range(P)[newly]
        return bool(np.all(np.minimum(np.abs(rng[:, 0]), np.abs(rng[:, 1]))
                           < rng[:, 1] - rng[:, 0]))

    def _advance(self, chain: AffineChain) -> tuple[Zonotope, Zonotope]:
        """The next step of the affine chain."""
        X, H = chain.advance()
        project = self._chain_project
        if project is not None:  # a lifted chain: its sets over the mode's states
            X, H = project(X), project(H)
        self._chain_end, self._chain_set = X, H
        return X, H

    def _taylor_flowpipe(self) -> TaylorFlowpipe | None:
        """The mode's Taylor-model flowpipe when ``flowpipe="taylor"`` was asked for."""
        return self.taylor_model() if self.options.flowpipe == "taylor" else None

    def taylor_model(self) -> TaylorFlowpipe | None:
        """The mode's Taylor-model flowpipe if Taylor models apply to it: a nonlinear flow
        without switching functions, without time-varying inputs, and built from
        operations Taylor models support; else ``None``."""
        if self._taylor_sought:
            return self._taylor
        self._taylor_sought = True
        m = self.mode
        if self.n_sigma or m.affine or any(e.free_symbols & set(m.usyms) for e in m.flow):
            return None
        try:
            self._taylor = TaylorFlowpipe(m.flow, m.zsyms, self.options.taylor_order)
        except TaylorError:
            return None  # an operation Taylor models do not support: linearisation
        return self._taylor

    def _taylor_step(self, taylor: TaylorFlowpipe, P: Zonotope, r: float
                     ) -> tuple[Zonotope, Zonotope]:
        """A Taylor-model step: from the model kept since the last step when ``P`` is
        that step's end set (the hybrid layer hands it back unchanged), else from ``P``."""
        X = self._taylor_set
        if X is None or P is not self._taylor_end:
            X = taylor.start(P)
            self._taylor_origin = P
        try:
            X, P_next, H = taylor.step(X, r)
        except TaylorError as exc:
            self._failed_bend = self._bend_of(X)
            self._taylor_set = self._taylor_end = None
            raise RemainderError(f"mode {self.mode.name!r}: Taylor model: {exc}") from exc
        self._taylor_set, self._taylor_end = X, P_next
        return P_next, H

    def bent_direction(self, origin: Zonotope) -> np.ndarray | None:
        """The generator of ``origin`` along which the current Taylor model (or the one
        whose step just failed) bends most (:func:`~hybridlab.reachability.taylor.bend`),
        if that model started from ``origin`` itself; else ``None``."""
        found = (self._bend_of(self._taylor_set) if self._taylor_set is not None
                 else self._failed_bend)
        if found is None or found[0] is not origin:
            return None
        return found[1]

    def _bend_of(self, X: TaylorSet) -> tuple[Zonotope, np.ndarray] | None:
        origin, taylor = self._taylor_origin, self._taylor
        if origin is None or taylor is None:
            return None
        score = bend(X)
        if not (score.size and np.all(np.isfinite(score)) and np.max(score) > 0):
            return None
        kept, _ = taylor.axes(origin)
        return origin, kept[:, int(np.argmax(score))]

    def _step_with(self, P: Zonotope, r: float, sig: np.ndarray, m: ModeSystem
                   ) -> tuple[Zonotope, Zonotope]:
        """A step of the flow ``m`` with the signs ``sigma_k`` in the ranges ``sig[k]``."""
        own = m is self.mode
        project = None
        lift = self._lift() if own else None
        lifted = None if lift is None else lift.lift(P)
        if lift is not None and lifted is not None:  # affine over (z, clock monomials)
            P, m, project = lifted, lift.flow, lift.project
        u_lo = np.r_[self.input_lo, sig[:, 0]]
        u_hi = np.r_[self.input_hi, sig[:, 1]]
        u_mid = 0.5 * (u_lo + u_hi)
        u_rad = 0.5 * (u_hi - u_lo)
        nz = P.dim
        # affine flows are linearised at 0, so A and c are the same bits every step
        z_star = (np.zeros(nz) if m.affine
                  else P.center + 0.5 * r * m.value(P.center, u_mid))
        f_star = m.value(z_star, u_mid)
        J = m.jacobian(z_star, u_mid)
        A, B = J[:, :nz], J[:, nz:]
        c = f_star - A @ z_star
        if not (np.all(np.isfinite(A)) and np.all(np.isfinite(c)) and np.all(np.isfinite(B))):
            at = dict(zip(self.system.znames, z_star[:len(self.system.znames)].round(6).tolist(),
                          strict=True))
            raise StepError(f"mode {m.name!r}: the flow or its Jacobian is not finite at {at}")
        prop = self._propagator(A, c, r)
        B_in = B[:, u_rad > 0] * u_rad[u_rad > 0]
        if m.affine and m is self.mode and not self._basis_sought:
            self._affine_A = A
            self._basis_sought = True
        if m.affine:
            W = Zonotope(np.zeros(nz), B_in) if B_in.size else None
            # a chain needs the same input at every step: each sign known or free (a
            # surface rule's partial range is the rule's own step)
            whole = bool(np.all(np.isin(sig, (-1.0, 1.0))))
            if not whole or self.options.bloat or not own:
                P_next, H = affine_step(P, prop, W, self.options.bloat)
                return (P_next, H) if project is None else (project(P_next), project(H))
            self._chain = AffineChain(prop, P, W, self.options.order)
            self._chain_project = project
            P_next, H = self._chain.first
            if project is not None:
                P_next, H = project(P_next), project(H)
            self._chain_end, self._chain_signs = P_next, sig.copy()
            return P_next, H
        remainder = self._remainders.setdefault(m.name, np.zeros(nz))
        guess = remainder.copy()
        for _ in range(self.options.remainder_iterations):
            W = Zonotope(np.zeros(nz), np.hstack([B_in, np.diag(guess)]))
            P_next, H = affine_step(P, prop, W, self.options.bloat)
            bound = self._remainder_bound(m, H, z_star, u_lo, u_hi, u_mid)
            if np.all(bound <= guess):
                remainder[:] = 1.05 * bound
                return P_next, H
            guess = np.maximum(guess, 1.5 * bound + 1e-15)
        raise RemainderError(f"mode {m.name!r}: the linearisation remainder did not settle in "
                        f"{self.options.remainder_iterations} iterations (bound "
                        f"{np.max(bound):.3g}); lower `step` or shrink the initial set"
                        f"{self._taylor_hint()}")

    def _taylor_hint(self) -> str:
        """The note of a linearisation's failure that Taylor models apply to the mode (the
        verdict tries them on that note)."""
        return ("" if self.options.flowpipe == "taylor" or self.taylor_model() is None
                else TAYLOR_APPLIES)

    def _remainder_bound(self, m: ModeSystem, H: Zonotope, z_star: np.ndarray, u_lo: np.ndarray,
                         u_hi: np.ndarray, u_mid: np.ndarray) -> np.ndarray:
        bound = remainder_bound(m, H, z_star, u_lo, u_hi, u_mid)
        if not np.all(np.isfinite(bound)):
            raise RemainderError(f"mode {m.name!r}: the linearisation remainder overflows "
                            "(the set has blown up); lower `step` or shrink the initial set"
                            f"{self._taylor_hint()}")
        return bound


def remainder_bound(m: ModeSystem, H: Zonotope, z_star: np.ndarray, u_lo: np.ndarray,
                    u_hi: np.ndarray, u_mid: np.ndarray) -> np.ndarray:
    """A bound of ``|f(w) - f(w*) - J(w*) (w - w*)|`` per row, for ``w`` in ``H`` times the
    input box ``[u_lo, u_hi]`` and ``w* = (z_star, u_mid)``: the least of the second-order
    Lagrange bound over the box, the same with the set's correlations
    (:func:`_quadratic_bound`) and the third-order one (:mod:`~hybridlab.reachability.cubic`).
    Non-finite where the set has blown up.

    Raises
    ------
    RemainderError
        Where the Hessian is unbounded over the set.

    Examples
    --------
    ``x' = x^2`` linearised at 1 over ``[0.5, 1.5]``: the remainder is ``(x - 1)^2 <= 0.25``.

    >>> import sympy as sp
    >>> from hybridlab.reachability.system import Rows
    >>> x = sp.Symbol("x", real=True)
    >>> m = ModeSystem("m", (x**2,), (x,), (), Rows([], (x,)), (), Rows([], (x,)))
    >>> none = np.zeros(0)
    >>> remainder_bound(m, Zonotope([1.0], [[0.5]]), np.array([1.0]), none, none, none)
    array([0.25])
    """
    box = H.bounds()
    lo = np.r_[np.minimum(box[:, 0], z_star), u_lo]
    hi = np.r_[np.maximum(box[:, 1], z_star), u_hi]
    w_star = np.r_[z_star, u_mid]
    delta = np.maximum(np.abs(lo - w_star), np.abs(hi - w_star))
    hessian = m.hessian
    if hessian is None:  # None only for an affine flow, which has no remainder to bound
        raise RuntimeError(f"mode {m.name!r}: a remainder bound without a Hessian")
    h_lo, h_hi = hessian(lo, hi)
    nw = w_star.size
    mag = np.maximum(np.abs(h_lo), np.abs(h_hi)).reshape(H.dim, nw, nw)
    if not np.all(np.isfinite(mag)):  # a set too wide for its linearisation, as a rule
        raise RemainderError(f"mode {m.name!r}: the Hessian is unbounded over the set "
                             f"(a division by a range containing zero?)")
    D = _deviations(H, z_star, 0.5 * (u_hi - u_lo))
    with np.errstate(over="ignore", invalid="ignore"):
        bound = 0.5 * np.einsum("ijk,j,k->i", mag, delta, delta)
        bound = np.minimum(bound, _quadratic_bound(
            h_lo.reshape(H.dim, nw, nw), h_hi.reshape(H.dim, nw, nw), D, delta))
        third = m.third
        if third is not None:  # one order further: the Hessian at w* and a cubic term
            p_lo, p_hi = hessian(w_star, w_star)
            cubic = _quadratic_bound(p_lo.reshape(H.dim, nw, nw),
                                     p_hi.reshape(H.dim, nw, nw), D, delta)
            cubic = cubic + third.bound(lo, hi, D, delta, H.dim)
            bound = np.where(cubic < bound, cubic, bound)
        return np.nextafter(bound * (1 + SLACK), np.inf)


def _deviations(H: Zonotope, z_star: np.ndarray, u_rad: np.ndarray) -> np.ndarray:
    """``D`` with ``w - w* = D beta`` (``|beta| <= 1``) over ``H`` and the input box: the
    set's generators, its centre's offset from ``z*`` and the input radii."""
    nz, n_gen = H.generators.shape
    D = np.zeros((nz + u_rad.size, n_gen + 1 + u_rad.size))
    D[:nz, :n_gen] = H.generators
    D[:nz, n_gen] = H.center - z_star
    D[nz:, n_gen + 1:] = np.diag(u_rad)
    return D[:, np.any(D != 0, axis=0)]


def _quadratic_bound(h_lo: np.ndarray, h_hi: np.ndarray, D: np.ndarray,
                     delta: np.ndarray) -> np.ndarray:
    """The Lagrange remainder ``1/2 d' Hess_i d`` bounded over the zonotope, not its box.

    With ``d = w - w*`` over ``H`` and the input box, ``d = D beta`` (``|beta_j| <= 1``,
    :func:`_deviations`), and each Hessian
    entry in ``[mid - rad, mid + rad]`` over the box, ``d' Hess_i d`` is at most
    ``sum |D' mid_i D| + |d|' rad_i |d|`` in magnitude (``|d| <= delta``). The box bound
    ``sum |Hess_i| delta delta`` is never smaller, and much larger where ``d``'s entries are
    correlated so that they cancel (a stiff controller's ``x_ref - x``). The products are
    rounded up by :data:`~.rounding.PRODUCT_SLACK` of the products of magnitudes.

    The form's sum is quadratic in the number of generators; where a step set has many,
    it is taken over a reduced zonotope (:func:`_form_generators`).
    """
    nz, nw, _ = h_lo.shape
    mid = 0.5 * (h_lo + h_hi)
    rad = np.nextafter(np.maximum(h_hi - mid, mid - h_lo), np.inf)
    bound = 0.5 * np.einsum("ijk,j,k->i", rad, delta, delta)
    rows = np.flatnonzero(np.any(mid != 0, axis=(1, 2)))
    if rows.size == 0:
        return bound
    used = np.flatnonzero(np.any(mid[rows] != 0, axis=(0, 1)))
    D = _form_generators(D[used])
    mass = np.abs(D).sum(axis=1)  # the products' magnitudes sum to mass' |M| mass
    for i in rows:
        M = mid[i][np.ix_(used, used)]
        # d' M d = d' (M + M')/2 d: the symmetric part's form has half the distinct entries
        quad = _form_abs_sum(0.5 * (M + M.T), D) + PRODUCT_SLACK * float(mass @ np.abs(M) @ mass)
        bound[i] += 0.5 * quad
    return np.nextafter(bound, np.inf)


FORM_ORDER = 40
"""Generators per variable the Lagrange remainder's quadratic form is summed over at most
(:func:`_form_generators`)."""

def _form_generators(D: np.ndarray) -> np.ndarray:
    """Generators ``E`` of a zonotope that holds every ``D beta`` (``|beta| <= 1``), for
    the quadratic form's sum: ``D`` without its zero columns where it has at most
    :data:`FORM_ORDER` columns per row, else that zonotope reduced to that order (Girard's
    box of its smallest generators, rounded up). The form's bound over ``E`` holds over
    ``D``, since every ``D beta`` is an ``E gamma``.

    The sum is quadratic in the number of columns (a step set may have over a thousand,
    of which the Hessian's few variables see most as tiny): on the nonlinear steps of a
    19-state cart with a pendulum, the reduced sum is at most 1.7 % larger (median 1e-6)
    for a twentieth of the cost. Generators all alike in size lose more (600 random ones
    in three variables: 73 %); a flowpipe's rarely are.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> D = np.hstack([rng.normal(size=(2, 60)), 1e-6 * rng.normal(size=(2, 900))])
    >>> S = np.array([[1.0, 0.5], [0.5, -2.0]])
    >>> E = _form_generators(D)
    >>> E.shape, bool(_form_abs_sum(S, D) <= _form_abs_sum(S, E) <= 1.001 * _form_abs_sum(S, D))
    ((2, 80), True)
    """
    D = D[:, np.any(D != 0, axis=0)]
    n, g = D.shape
    if g <= FORM_ORDER * n:
        return D
    return Zonotope(np.zeros(n), D).reduce(FORM_ORDER).generators


_BLOCK = 256
"""Columns per block of :func:`_form_abs_sum` (a block pair's products stay in cache)."""


def _form_abs_sum(S: np.ndarray, D: np.ndarray) -> float:
    """``sum_jk |(D' S D)_jk|`` for a symmetric ``S``: the blocks on and above the
    diagonal, those above counted twice, so no ``g x g`` matrix is formed at once.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> D = rng.standard_normal((3, 600))
    >>> S = np.array([[1.0, 2.0, 0.0], [2.0, -1.0, 0.5], [0.0, 0.5, 3.0]])
    >>> whole = float(np.abs(D.T @ S @ D).sum())
    >>> bool(abs(_form_abs_sum(S, D) - whole) <= 1e-12 * whole)
    True
    """
    P = S @ D
    g = D.shape[1]
    total = 0.0
    for start in range(0, g, _BLOCK):
        block = P[:, start:start + _BLOCK].T
        total += float(np.abs(block @ D[:, start:start + _BLOCK]).sum())
        if start + _BLOCK < g:
            total += 2.0 * float(np.abs(block @ D[:, start + _BLOCK:]).sum())
    return total
