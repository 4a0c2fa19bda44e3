"""Scalar interval arithmetic in numba, for the generated models' box functions.

Every function takes and returns intervals as ``(lo, hi)`` float pairs. The
result encloses every value the operation takes on its operand intervals
*and* what a floating-point evaluation of the same expression in any
association order returns: sums are widened by ``2**-46`` (64 units in the
last place) of their operands' magnitude, products, quotients and elementary
functions by that much of their own. A bound that is not finite (or NaN) on
input gives the whole real line, and so does an operand outside a function's
domain (``sqrt`` or ``log`` of an interval reaching below zero, a quotient by
an interval containing zero): the kernel then simply cannot prove anything
about that step (:mod:`.bounds`).

:mod:`.box_printer` writes calls to these functions; the Python reference
of the same arithmetic is :mod:`hybridlab.symbolic.intervals`.

Examples
--------
>>> lo, hi = i_mul(-1.0, 2.0, 3.0, 4.0)
>>> lo <= -4.0 and hi >= 8.0
True
>>> i_sqrt(-1.0, 4.0)
(-inf, inf)
"""

from __future__ import annotations

import math

import numba

__all__ = ["i_abs", "i_acos", "i_add", "i_asin", "i_atan", "i_const", "i_cos", "i_cosh",
           "i_div", "i_entire", "i_exp", "i_log", "i_max", "i_min", "i_mul", "i_neg", "i_pow",
           "i_powi", "i_sign", "i_sin", "i_sinh", "i_sqrt", "i_sub", "i_tanh"]

_WIDEN = 2.0 ** -46
_TINY = 1e-300
_INF = math.inf
_TWO_PI = 2.0 * math.pi
_SLACK = 1e-9  # how close to an extremum of sin/cos an end point counts as containing it


@numba.njit(inline="always")
def _ok(lo, hi):
    return abs(lo) < _INF and abs(hi) < _INF  # False for NaN too


@numba.njit(inline="always")
def _out(lo, hi, scale):
    if not (_ok(lo, hi) and scale < _INF):
        return -_INF, _INF
    d = _WIDEN * scale + _TINY
    return lo - d, hi + d


@numba.njit(inline="always")
def _own(lo, hi):
    """Widen by the result's own magnitude (products, quotients, functions)."""
    return _out(lo, hi, max(abs(lo), abs(hi)))


@numba.njit(cache=True)
def i_entire():
    """The whole real line: what an unsupported construct evaluates to."""
    return -_INF, _INF


@numba.njit(cache=True)
def i_const(c):
    """A constant, widened by its own rounding."""
    return _own(c, c)


@numba.njit(cache=True)
def i_add(al, ah, bl, bh):
    """``a + b``."""
    if not (_ok(al, ah) and _ok(bl, bh)):
        return -_INF, _INF
    return _out(al + bl, ah + bh, max(abs(al), abs(ah)) + max(abs(bl), abs(bh)))


@numba.njit(cache=True)
def i_neg(al, ah):
    """``-a`` (exact)."""
    return -ah, -al


@numba.njit(cache=True)
def i_sub(al, ah, bl, bh):
    """``a - b``."""
    return i_add(al, ah, -bh, -bl)


@numba.njit(cache=True)
def i_mul(al, ah, bl, bh):
    """``a * b``."""
    if not (_ok(al, ah) and _ok(bl, bh)):
        return -_INF, _INF
    p1, p2, p3, p4 = al * bl, al * bh, ah * bl, ah * bh
    return _own(min(p1, p2, p3, p4), max(p1, p2, p3, p4))


@numba.njit(cache=True)
def i_div(al, ah, bl, bh):
    """``a / b``; the whole line when ``b`` contains zero."""
    if not (_ok(al, ah) and _ok(bl, bh)) or (bl <= 0.0 <= bh):
        return -_INF, _INF
    q1, q2, q3, q4 = al / bl, al / bh, ah / bl, ah / bh
    return _own(min(q1, q2, q3, q4), max(q1, q2, q3, q4))


@numba.njit(cache=True)
def i_powi(al, ah, k):
    """``a ** k`` for an integer ``k``."""
    if not _ok(al, ah):
        return -_INF, _INF
    if k == 0:
        return 1.0, 1.0
    e = abs(k)
    if e % 2 == 1 or al >= 0.0:
        lo, hi = al ** e, ah ** e
    elif ah <= 0.0:
        lo, hi = ah ** e, al ** e
    else:
        lo, hi = 0.0, max(al ** e, ah ** e)
    lo, hi = _out(lo, hi, e * max(abs(lo), abs(hi)))
    if k < 0:
        return i_div(1.0, 1.0, lo, hi)
    return lo, hi


@numba.njit(cache=True)
def i_pow(al, ah, e):
    """``a ** e`` for a non-integer constant ``e`` (``a`` must stay positive)."""
    if not _ok(al, ah) or al < 0.0 or (al == 0.0 and e < 0.0):
        return -_INF, _INF
    u, v = al ** e, ah ** e
    return _own(min(u, v), max(u, v))


@numba.njit(cache=True)
def i_sqrt(al, ah):
    """``sqrt(a)``."""
    if not _ok(al, ah) or al < 0.0:
        return -_INF, _INF
    return _own(math.sqrt(al), math.sqrt(ah))


@numba.njit(cache=True)
def i_exp(al, ah):
    """``exp(a)``."""
    if not _ok(al, ah):
        return -_INF, _INF
    return _own(math.exp(al), math.exp(ah))


@numba.njit(cache=True)
def i_log(al, ah):
    """``log(a)``."""
    if not _ok(al, ah) or al <= 0.0:
        return -_INF, _INF
    return _own(math.log(al), math.log(ah))


@numba.njit(inline="always")
def _reaches(al, ah, at):
    """Whether ``[al, ah]`` contains ``at + 2 k pi`` for some integer ``k`` (generously)."""
    k = math.ceil((al - at) / _TWO_PI - _SLACK)
    return at + k * _TWO_PI <= ah + _SLACK * (1.0 + abs(ah))


@numba.njit(cache=True)
def i_sin(al, ah):
    """``sin(a)``."""
    if not _ok(al, ah):
        return -_INF, _INF
    if ah - al >= _TWO_PI:
        return _own(-1.0, 1.0)
    u, v = math.sin(al), math.sin(ah)
    lo, hi = min(u, v), max(u, v)
    if _reaches(al, ah, 0.5 * math.pi):
        hi = 1.0
    if _reaches(al, ah, -0.5 * math.pi):
        lo = -1.0
    return _out(lo, hi, 1.0)


@numba.njit(cache=True)
def i_cos(al, ah):
    """``cos(a)``."""
    if not _ok(al, ah):
        return -_INF, _INF
    if ah - al >= _TWO_PI:
        return _own(-1.0, 1.0)
    u, v = math.cos(al), math.cos(ah)
    lo, hi = min(u, v), max(u, v)
    if _reaches(al, ah, 0.0):
        hi = 1.0
    if _reaches(al, ah, math.pi):
        lo = -1.0
    return _out(lo, hi, 1.0)


@numba.njit(inline="always")
def _monotone(u, v):
    return _own(min(u, v), max(u, v))


@numba.njit(cache=True)
def i_atan(al, ah):
    """``atan(a)``."""
    if not _ok(al, ah):
        return -_INF, _INF
    return _monotone(math.atan(al), math.atan(ah))


@numba.njit(cache=True)
def i_tanh(al, ah):
    """``tanh(a)``."""
    if not _ok(al, ah):
        return -_INF, _INF
    return _monotone(math.tanh(al), math.tanh(ah))


@numba.njit(cache=True)
def i_sinh(al, ah):
    """``sinh(a)``."""
    if not _ok(al, ah):
        return -_INF, _INF
    return _monotone(math.sinh(al), math.sinh(ah))


@numba.njit(cache=True)
def i_cosh(al, ah):
    """``cosh(a)``."""
    if not _ok(al, ah):
        return -_INF, _INF
    u, v = math.cosh(al), math.cosh(ah)
    lo = 1.0 if al <= 0.0 <= ah else min(u, v)
    return _own(lo, max(u, v))


@numba.njit(cache=True)
def i_asin(al, ah):
    """``asin(a)`` (``a`` within ``[-1, 1]``)."""
    if not _ok(al, ah) or al < -1.0 or ah > 1.0:
        return -_INF, _INF
    return _monotone(math.asin(al), math.asin(ah))


@numba.njit(cache=True)
def i_acos(al, ah):
    """``acos(a)`` (``a`` within ``[-1, 1]``)."""
    if not _ok(al, ah) or al < -1.0 or ah > 1.0:
        return -_INF, _INF
    return _monotone(math.acos(al), math.acos(ah))


@numba.njit(cache=True)
def i_abs(al, ah):
    """``|a|`` (exact)."""
    if not _ok(al, ah):
        return -_INF, _INF
    if al >= 0.0:
        return al, ah
    if ah <= 0.0:
        return -ah, -al
    return 0.0, max(-al, ah)


@numba.njit(cache=True)
def i_sign(al, ah):
    """``sign(a)`` with ``sign(0) = 0`` (exact)."""
    if not _ok(al, ah):
        return -_INF, _INF
    if al > 0.0:
        return 1.0, 1.0
    if ah < 0.0:
        return -1.0, -1.0
    return (-1.0 if al < 0.0 else 0.0), (1.0 if ah > 0.0 else 0.0)


@numba.njit(cache=True)
def i_min(al, ah, bl, bh):
    """``min(a, b)`` (exact)."""
    if not (_ok(al, ah) and _ok(bl, bh)):
        return -_INF, _INF
    return min(al, bl), min(ah, bh)


@numba.njit(cache=True)
def i_max(al, ah, bl, bh):
    """``max(a, b)`` (exact)."""
    if not (_ok(al, ah) and _ok(bl, bh)):
        return -_INF, _INF
    return max(al, bl), max(ah, bh)
