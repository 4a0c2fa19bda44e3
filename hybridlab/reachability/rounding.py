"""Error bounds for floating-point arithmetic on sets (IEEE double, round to nearest).

The flowpipes are computed in plain numpy arithmetic; these bounds turn the
rounding of each operation into a box that is added to the result, so the
computed set contains the exact one (the standard a-priori bounds of Higham,
*Accuracy and Stability of Numerical Algorithms*, 2002, ch. 3):

* a dot product of length ``k`` computed in any order is within
  ``gamma(k) * sum |a_i| |b_i|`` of the exact value, ``gamma(k) = k u / (1 - k u)``
  with the unit roundoff ``u = 2**-53``; a matrix product is bounded row by row;
* a sum of ``k`` non-negative terms is within ``(k - 1) u`` of its exact value
  (relative), which :func:`up` covers (``k`` up to 1024 unless it is told more).

The unit roundoff :data:`U` and :data:`TINY` are the rounding policy's
(:mod:`hybridlab.symbolic.interval_arithmetic`). Underflow adds at most
``k * 2**-1074`` to a dot product; :data:`TINY` covers it
for the dimensions used here. Overflow produces ``inf``, which the set classes
refuse as non-finite, so it never passes silently.

Examples
--------
>>> import numpy as np
>>> A = np.array([[0.1, 0.2], [0.3, 0.4]])
>>> x = np.array([1.0, 3.0])
>>> err = product_error(np.abs(A), np.abs(x))
>>> bool(np.all(err > 0) and np.all(err < 1e-15))
True
"""

from __future__ import annotations

import functools
import math

import numpy as np

from hybridlab.symbolic.interval_arithmetic import TINY, U

__all__ = ["U", "TINY", "SLACK", "PRODUCT_SLACK", "gamma", "product_error", "up"]

SLACK = 1e-12
"""The relative slack added to a bound computed by a short chain of float operations, times
the magnitudes it is computed from: ``gamma(k) <= SLACK`` for chains of up to 9,000
roundings (``gamma(9000) = 9.99e-13``), where the chains it covers (a row's bounds from its
support values, a cut's limit, a series tail, a remainder's last products) have a few
dozen. Added with :data:`TINY`, which covers underflow."""

PRODUCT_SLACK = 1e-10
"""The relative slack of a sum of products over a set's generators (a Jacobian's or a
Hessian's form over a zonotope), times the sum of the products' magnitudes:
``gamma(k) <= PRODUCT_SLACK`` for sums of up to 900,000 terms added one after another. The
longest sums here, a Hessian's form over 1,140 generators, are formed in blocks of 256
columns whose entries are short dot products, summed pairwise by numpy."""


@functools.lru_cache(maxsize=4096)
def gamma(k: int) -> float:
    """``k u / (1 - k u)``, rounded up: the relative error bound of ``k`` roundings.

    Examples
    --------
    >>> gamma(2) > 2 * U
    True
    """
    ku = k * U
    return math.nextafter(ku / (1.0 - ku), math.inf)


def up(x: np.ndarray | float, terms: int = 1024) -> np.ndarray:
    """``x`` enlarged to cover the rounding of a sum of ``terms`` non-negative terms.

    Examples
    --------
    >>> bool(up(1.0) > 1.0), bool(up(1.0) < 1.0 + 1e-12)
    (True, True)
    """
    factor = _UP_1024 if terms <= 1024 else 1.0 + gamma(terms)
    out = np.asarray(x, dtype=float) * factor
    out += TINY
    return out


_UP_1024 = 1.0 + gamma(1024)


def product_error(abs_left: np.ndarray, abs_right: np.ndarray) -> np.ndarray:
    """Bound of ``|fl(L @ R) - L @ R|`` from ``|L|`` and ``|R|``.

    ``abs_right`` may be a vector or a matrix; for a matrix the result bounds
    each column. The bound is itself computed with non-negative products and
    enlarged by :func:`up`, so it is not rounded below its exact value.

    Examples
    --------
    >>> product_error(np.ones((2, 2)), np.ones(2)).shape
    (2,)
    """
    k = abs_left.shape[-1] + 2
    return up(gamma(k) * up(abs_left @ abs_right, k), k)
