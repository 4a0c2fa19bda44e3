"""Rigorous enclosures in ball arithmetic (Arb, through python-flint).

Arb represents every real number as a ball ``[m +- r]`` and rounds every
operation so that the exact result lies in the computed ball (Johansson, "Arb: a
C library for ball arithmetic", ACM Communications in Computer Algebra, 2013).
Its matrix exponential (scaling and squaring of a Taylor sum with a rigorous
tail bound) encloses ``e^{M}`` for every matrix in the input balls, at any
norm of ``M``: this is what lets a stiff mode take a step that is long
compared with its fastest time constant. Arb runs at the precision of the
shared python-flint context (53 bits unless a caller changed it); a wider
ball, never a wrong one, is the price of a lower precision.

Results come back as a pair of float arrays ``(mid, rad)`` with the exact
value inside ``[mid - rad, mid + rad]`` entry by entry.

Examples
--------
>>> import numpy as np
>>> mid, rad = expm_enclosure(np.array([[-2000.0, 0.0], [1999.0, -1.0]]), 0.5)
>>> bool(abs(mid[1, 1] - np.exp(-0.5)) <= rad[1, 1] + 1e-16 and rad.max() < 1e-12)
True
"""

from __future__ import annotations

import math

import numpy as np
from flint import arb, arb_mat

__all__ = ["to_arb", "enclosure", "expm_enclosure", "expm_power_enclosure", "inverse_enclosure",
           "scalar_bounds"]


def to_arb(M: np.ndarray) -> arb_mat:
    """The float matrix ``M`` as an exact Arb matrix (doubles are exact balls).

    Examples
    --------
    >>> to_arb(np.eye(2)).nrows()
    2
    """
    return arb_mat(np.atleast_2d(np.asarray(M, dtype=float)).tolist())


def scalar_bounds(x: arb) -> tuple[float, float]:
    """Floats ``lo <= x <= hi`` for every point of the ball ``x``.

    Examples
    --------
    >>> lo, hi = scalar_bounds(arb(1) / 3)
    >>> lo < 1 / 3 < hi
    True
    """
    if not x.is_finite():
        return -math.inf, math.inf
    lo = math.nextafter(float(x.lower()), -math.inf)
    hi = math.nextafter(float(x.upper()), math.inf)
    return lo, hi


def enclosure(X: arb_mat) -> tuple[np.ndarray, np.ndarray]:
    """``(mid, rad)`` float arrays whose boxes contain the Arb matrix ``X``.

    Examples
    --------
    >>> mid, rad = enclosure(arb_mat([[arb(1) / 3]]))
    >>> bool(abs(mid[0, 0] - 1 / 3) <= rad[0, 0] < 1e-15)
    True
    """
    shape = (X.nrows(), X.ncols())
    entries = X.entries()
    # each end rounded to the nearest float, then moved outward (as scalar_bounds does;
    # a ball that is not finite has an infinite or NaN end, caught below)
    lo = np.nextafter([float(x.lower()) for x in entries], -np.inf).reshape(shape)
    hi = np.nextafter([float(x.upper()) for x in entries], np.inf).reshape(shape)
    mid = 0.5 * lo + 0.5 * hi
    rad = np.nextafter(np.maximum(hi - mid, mid - lo), np.inf)
    bad = ~np.isfinite(mid) | ~np.isfinite(rad)
    mid[bad] = 0.0
    rad[bad] = np.inf
    return mid, rad


def expm_enclosure(M: np.ndarray, r: float) -> tuple[np.ndarray, np.ndarray]:
    """``(mid, rad)`` enclosing ``e^{M r}`` exactly (up to the ball radii).

    Examples
    --------
    >>> mid, rad = expm_enclosure(np.array([[0.0, 1.0], [0.0, 0.0]]), 2.0)
    >>> mid.tolist(), bool(rad.max() < 1e-15)
    ([[1.0, 2.0], [0.0, 1.0]], True)
    """
    return enclosure((to_arb(M) * arb(float(r))).exp())


def expm_power_enclosure(M: np.ndarray, r: float, k: int) -> tuple[np.ndarray, np.ndarray]:
    """``(mid, rad)`` enclosing ``(e^{M r})^k = e^{M k r}`` (``k r`` formed exactly in Arb).

    Examples
    --------
    >>> mid, rad = expm_power_enclosure(np.array([[-1.0]]), 0.1, 30)
    >>> bool(abs(mid[0, 0] - np.exp(-3.0)) <= rad[0, 0] + 1e-16), bool(rad.max() < 1e-15)
    (True, True)
    """
    return enclosure((to_arb(M) * (arb(float(r)) * int(k))).exp())


def inverse_enclosure(M: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """``(mid, rad)`` enclosing ``M^{-1}``, or ``None`` when ball arithmetic cannot
    certify an inverse (singular or too ill-conditioned a matrix).

    Examples
    --------
    >>> mid, rad = inverse_enclosure(np.array([[2.0, 0.0], [0.0, 4.0]]))
    >>> mid.tolist(), bool(rad.max() < 1e-15)
    ([[0.5, 0.0], [0.0, 0.25]], True)
    >>> inverse_enclosure(np.zeros((2, 2))) is None
    True
    """
    try:
        mid, rad = enclosure(to_arb(M).inv())
    except (ZeroDivisionError, ValueError):
        return None
    return (mid, rad) if np.all(np.isfinite(rad)) else None
