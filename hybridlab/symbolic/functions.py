"""Numeric functions compiled from sympy with common-subexpression elimination.

Every compiled function takes ``(t, x, p, sigma)``: time, the state vector,
the parameter vector and the vector of sign symbols of the current mode. The
same function evaluates one point (``x`` of shape ``(n,)``) or many points at
once (``t`` of shape ``(k,)``, ``x`` of shape ``(n, k)``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import sympy as sp

from hybridlab.symbolic.printing import numpy_function

__all__ = ["VectorFunction", "MatrixFunction", "LazyMatrixFunction"]

_EMPTY = np.empty(0)


def _no_impulses(expr: sp.Expr) -> sp.Expr:
    """Derivatives of sign() produce DiracDelta; between events they vanish."""
    return expr.replace(sp.DiracDelta, lambda *args: sp.Integer(0))


class VectorFunction:
    """``m`` expressions compiled into one numpy function.

    Parameters
    ----------
    exprs : sequence of sympy.Expr
        The expressions.
    t : sympy.Symbol
        Time.
    states, parameters, sigmas : sequence of sympy.Symbol
        Argument symbols, in vector order.

    Examples
    --------
    >>> t, x, k = sp.symbols("t x k", real=True)
    >>> f = VectorFunction([-k*x, k], t, [x], [k], [])
    >>> f(0.0, np.array([2.0]), np.array([3.0]), np.array([]))
    array([-6.,  3.])
    >>> f.batch(np.zeros(2), np.array([[1.0, 2.0]]), np.array([3.0]), np.array([]))
    array([[-3., -6.],
           [ 3.,  3.]])
    """

    def __init__(
        self,
        exprs: Sequence[sp.Expr],
        t: sp.Symbol,
        states: Sequence[sp.Symbol],
        parameters: Sequence[sp.Symbol],
        sigmas: Sequence[sp.Symbol],
        extra: Sequence[sp.Symbol] = (),
    ) -> None:
        self.exprs = tuple(_no_impulses(sp.Integer(0) + e) for e in exprs)
        self.size = len(self.exprs)
        args = [t, tuple(states), tuple(parameters), tuple(sigmas), tuple(extra)]
        self._fn = numpy_function(args, self.exprs)

    def __call__(self, t: float, x: np.ndarray, p: np.ndarray, sigma: np.ndarray,
                 extra: np.ndarray = _EMPTY) -> np.ndarray:
        """Evaluate at one point; returns shape ``(m,)``."""
        return np.array(self._fn(t, x, p, sigma, extra), dtype=float).reshape(self.size)

    def batch(self, t: np.ndarray, x: np.ndarray, p: np.ndarray, sigma: np.ndarray,
              extra: np.ndarray = _EMPTY) -> np.ndarray:
        """Evaluate at ``k`` points; ``x`` has shape ``(n, k)``; returns ``(m, k)``."""
        out = np.empty((self.size, np.shape(t)[0]))
        for i, value in enumerate(self._fn(t, x, p, sigma, extra)):
            out[i] = value
        return out


class MatrixFunction:
    """A sympy matrix compiled into a numpy function returning an ``(r, c)`` array.

    Examples
    --------
    >>> t, x = sp.symbols("t x", real=True)
    >>> J = MatrixFunction(sp.Matrix([[2*x]]), t, [x], [], [])
    >>> J(0.0, np.array([3.0]), np.array([]), np.array([]))
    array([[6.]])
    """

    def __init__(
        self,
        matrix: sp.Matrix,
        t: sp.Symbol,
        states: Sequence[sp.Symbol],
        parameters: Sequence[sp.Symbol],
        sigmas: Sequence[sp.Symbol],
    ) -> None:
        self.shape = matrix.shape
        self._flat = VectorFunction(list(matrix), t, states, parameters, sigmas)

    def __call__(self, t: float, x: np.ndarray, p: np.ndarray, sigma: np.ndarray) -> np.ndarray:
        return self._flat(t, x, p, sigma).reshape(self.shape)

    def batch(self, t: np.ndarray, x: np.ndarray, p: np.ndarray, sigma: np.ndarray) -> np.ndarray:
        """Evaluate at ``k`` points; returns ``(r, c, k)``."""
        return self._flat.batch(t, x, p, sigma).reshape(*self.shape, -1)


class LazyMatrixFunction:
    """A :class:`MatrixFunction` built on first use (a Jacobian only stiff methods need).

    Examples
    --------
    >>> t, x = sp.symbols("t x", real=True)
    >>> J = LazyMatrixFunction(lambda: sp.Matrix([[3*x]]), t, [x], [], [])
    >>> J(0.0, np.array([2.0]), np.array([]), np.array([]))
    array([[6.]])
    """

    def __init__(self, build, t: sp.Symbol, states: Sequence[sp.Symbol],
                 parameters: Sequence[sp.Symbol], sigmas: Sequence[sp.Symbol]) -> None:
        self._build = build
        self._args = (t, tuple(states), tuple(parameters), tuple(sigmas))
        self._fn: MatrixFunction | None = None

    def _compiled(self) -> MatrixFunction:
        if self._fn is None:
            self._fn = MatrixFunction(self._build(), *self._args)
        return self._fn

    def __call__(self, t: float, x: np.ndarray, p: np.ndarray, sigma: np.ndarray) -> np.ndarray:
        return self._compiled()(t, x, p, sigma)

    def batch(self, t: np.ndarray, x: np.ndarray, p: np.ndarray, sigma: np.ndarray) -> np.ndarray:
        return self._compiled().batch(t, x, p, sigma)
