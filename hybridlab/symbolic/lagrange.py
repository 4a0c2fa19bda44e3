"""Equations of motion from a Lagrangian, derived in sympy.

For generalised coordinates ``q``, velocities ``u = q'``, ``L = T - V`` and
generalised non-conservative forces ``Q``::

    d/dt (dL/du_i) - dL/dq_i = Q_i
    <=>  M(q, u, t) u' = Q + dL/dq - (d2L/du dq) u - d2L/du dt

with the mass matrix ``M_ij = d2L / du_i du_j``. The accelerations are
obtained by solving this linear system symbolically (LU), once per model;
the forces enter as placeholders and are substituted mode by mode.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import sympy as sp

from hybridlab.errors import CompilationError
from hybridlab.model.checks import TIME, SymbolicModel

__all__ = ["LagrangeEquations", "lagrange_equations", "mode_flow"]


@dataclass(frozen=True)
class LagrangeEquations:
    """Mass matrix, right-hand side and solved accelerations of a Lagrangian system.

    Attributes
    ----------
    mass_matrix : sympy.Matrix
    rhs : sympy.Matrix
        ``M u' = rhs``; contains the force placeholders ``forces``.
    accelerations : tuple of sympy.Expr
        ``u'`` as functions of ``t, q, u`` and the placeholders.
    forces : tuple of sympy.Symbol
        One placeholder per coordinate.

    Examples
    --------
    A cart of mass ``m`` on a spring ``k``, without solving for the acceleration:

    >>> x, u, a, m, k = sp.symbols("x u a m k", real=True)
    >>> eq = lagrange_equations(m*u**2/2, k*x**2/2, [x], [u], solve=False)
    >>> eq.mass_matrix, eq.rhs, eq.forces, eq.accelerations
    (Matrix([[m]]), Matrix([[_Q0 - k*x]]), (_Q0,), ())
    >>> eq.residuals([a])  # m a = Q - k x
    [-_Q0 + a*m + k*x]
    """

    mass_matrix: sp.Matrix
    rhs: sp.Matrix
    accelerations: tuple[sp.Expr, ...]
    forces: tuple[sp.Symbol, ...]

    def residuals(self, accelerations: Sequence[sp.Expr]) -> list[sp.Expr]:
        """``M a - rhs`` for given acceleration symbols ``a``: zero on the solution."""
        a = sp.Matrix(list(accelerations))
        return list(self.mass_matrix * a - self.rhs)


def lagrange_equations(kinetic: sp.Expr, potential: sp.Expr, coordinates: Sequence[sp.Symbol],
                       velocities: Sequence[sp.Symbol], t: sp.Symbol = TIME,
                       solve: bool = True) -> LagrangeEquations:
    """Derive the equations of motion.

    Parameters
    ----------
    kinetic, potential : sympy.Expr
        Kinetic and potential energy in terms of ``coordinates`` and ``velocities``.
    coordinates, velocities : sequence of sympy.Symbol
    t : sympy.Symbol
        Time (energies may depend on it explicitly).
    solve : bool
        Also solve for the accelerations.

    Raises
    ------
    CompilationError
        If the mass matrix is singular.

    Examples
    --------
    A pendulum of length ``l`` and mass ``m``:

    >>> phi, w, m, g, l = sp.symbols("phi w m g l", positive=True)
    >>> eq = lagrange_equations(m*l**2*w**2/2, -m*g*l*sp.cos(phi), [phi], [w])
    >>> sp.expand(eq.accelerations[0])
    _Q0/(l**2*m) - g*sin(phi)/l
    """
    q, u = list(coordinates), list(velocities)
    n = len(q)
    lagrangian = kinetic - potential
    forces = tuple(sp.Symbol(f"_Q{i}", real=True) for i in range(n))
    d_du = [sp.diff(lagrangian, ui) for ui in u]
    mass = sp.Matrix(n, n, lambda i, j: sp.diff(d_du[i], u[j]))
    rhs = sp.Matrix([
        forces[i] + sp.diff(lagrangian, q[i])
        - sum(sp.diff(d_du[i], q[j]) * u[j] for j in range(n)) - sp.diff(d_du[i], t)
        for i in range(n)
    ])
    if mass.has(*forces):
        raise CompilationError("the kinetic energy must not depend on the forces")
    accelerations: tuple[sp.Expr, ...] = ()
    if solve:
        if _singular(mass.det()):
            raise CompilationError("mechanics: the mass matrix d2T/du2 is singular; check that "
                                   "the kinetic energy involves every velocity")
        accelerations = tuple(mass.LUsolve(rhs))
    return LagrangeEquations(mass, rhs, accelerations, forces)


def _singular(det: sp.Expr) -> bool:
    """Whether a mass matrix's determinant is identically zero.

    It is not when it is nonzero at one point: every symbol is given a distinct rational
    value and the determinant evaluated to 30 and to 60 digits; two values that agree to ten
    digits are the value, not rounding noise of a cancellation. Only when they do not (or
    the value is zero) is the determinant simplified, which for a Lagrangian in
    trigonometric coordinates can take seconds.

    Examples
    --------
    >>> a, b = sp.symbols("a b", positive=True)
    >>> _singular(a*b*sp.cos(a)**2 + a*b*sp.sin(a)**2), _singular(sp.cos(a)**2 + sp.sin(a)**2 - 1)
    (False, True)
    """
    symbols = sorted(det.free_symbols, key=str)
    point = {s: sp.Rational(2 * k + 3, 7 * k + 11) for k, s in enumerate(symbols)}
    at = det.xreplace(point)
    coarse, fine = at.evalf(30), at.evalf(60)
    if fine.is_number and fine.is_finite and fine != 0 and coarse.is_number \
            and abs(coarse - fine) <= sp.Float("1e-10", 60) * abs(fine):
        return False
    return bool(sp.simplify(det) == 0)


def model_equations(sym: SymbolicModel) -> LagrangeEquations | None:
    """The equations of motion of a model's ``[mechanics]`` (``None`` without one).

    Examples
    --------
    >>> from hybridlab.model.loader import loads_model
    >>> sym = loads_model('''
    ... name = "pendulum"
    ... parameters = { m = 1.0, l = 0.5, g = 9.81 }
    ... states = { phi = 0.1, omega = 0.0 }
    ... [mechanics]
    ... coordinates = ["phi"]
    ... velocities = ["omega"]
    ... kinetic = "m*l**2*omega**2/2"
    ... potential = "-m*g*l*cos(phi)"
    ... [modes.swing]
    ... [initial]
    ... mode = "swing"
    ... ''').symbolic
    >>> sp.expand(model_equations(sym).accelerations[0])
    _Q0/(l**2*m) - g*sin(phi)/l
    """
    mech = sym.mechanics
    if mech is None:
        return None
    return lagrange_equations(mech.kinetic, mech.potential,
                              [sym.states[i] for i in mech.coordinates],
                              [sym.states[i] for i in mech.velocities])


def mode_flow(sym: SymbolicModel, mode_name: str,
              equations: LagrangeEquations | None) -> tuple[sp.Expr, ...]:
    """The full flow of a mode: its own expressions plus the derived mechanics.

    A flow the mode states explicitly wins over the derived one.

    Examples
    --------
    A damped pendulum whose ``swing`` mode states no flow of its own:

    >>> from hybridlab.model.loader import loads_model
    >>> sym = loads_model('''
    ... name = "pendulum"
    ... parameters = { m = 1.0, l = 0.5, g = 9.81, b = 0.1 }
    ... states = { phi = 0.1, omega = 0.0 }
    ... modes.swing = {}
    ... initial.mode = "swing"
    ... [mechanics]
    ... coordinates = ["phi"]
    ... velocities = ["omega"]
    ... kinetic = "m*l**2*omega**2/2"
    ... potential = "-m*g*l*cos(phi)"
    ... forces = { phi = "-b*omega" }
    ... ''').symbolic
    >>> mech = sym.mechanics
    >>> eq = lagrange_equations(mech.kinetic, mech.potential, [sym.states[0]], [sym.states[1]])
    >>> mode_flow(sym, "swing", eq)
    (omega, (-b*omega - g*l*m*sin(phi))/(l**2*m))
    """
    mode = sym.modes[mode_name]
    flow = list(mode.flow)
    mech = sym.mechanics
    if mech is not None and equations is not None:
        forces = dict(zip(equations.forces, mode.forces, strict=True))
        for k, (iq, iu) in enumerate(zip(mech.coordinates, mech.velocities, strict=True)):
            if flow[iq] is None:
                flow[iq] = sym.states[iu]
            if flow[iu] is None:
                flow[iu] = equations.accelerations[k].xreplace(forces)
    missing = [sym.state_names[i] for i, f in enumerate(flow) if f is None]
    if missing:  # the model layer guarantees this cannot happen
        raise CompilationError(f"mode {mode_name!r}: no flow for {', '.join(missing)}")
    return tuple(flow)
