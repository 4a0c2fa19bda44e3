"""The one interval arithmetic: scalar operations on ``(lo, hi)`` pairs and their rounding.

Every enclosure hybridlab computes rests on these functions: the reachability
enclosures and the mode graph's checks call them from Python
(:mod:`hybridlab.symbolic.intervals`), and the compiled simulator's
quiet-step proofs call the same functions compiled by numba
(:mod:`hybridlab.simulation.compiled.interval_ops`). They use plain floats and
``math`` only, raise nothing and never call a function outside its domain,
so both can run them.

**Semantics.** An operation returns the hull of its values at the points
of its operands' domain: ``sqrt([-1, 4])`` is ``[0, 2]``. An operand
wholly outside the domain (``sqrt([-2, -1])``) gives the *empty* pair
``(nan, nan)``, and an empty operand gives empty. Infinite ends are kept
(``[1, inf) + 1`` is ``[2, inf)``); a quotient by an interval containing
zero, and ``tan`` across a pole, are the whole line.

**Rounding policy.** IEEE double precision, round to nearest, unit
roundoff :data:`U` ``= 2**-53``. Every finite end that is not exact is
moved outward by :data:`WIDEN` ``= 2**-46`` (64 units in the last place)
times a magnitude, plus :data:`TINY` for underflow:

* a sum's end by the sum of the magnitudes of the operand ends that
  produced it;
* a product's, quotient's, power's or elementary function's end by its own
  magnitude (an integer power ``k`` by ``|k|`` times it);
* negation, ``abs``, ``sign``, ``min``, ``max`` and Heaviside are exact.

Elementary functions come from the C library (``math``), assumed accurate to
a few units in the last place, far inside the widening. The widening covers
more than the exact result of each operation: a floating-point evaluation
of the same expression in any association order of its sums and products
stays inside too (every float operation is monotone in its operands, so the
extremes are at the ends, where the widening accumulates along the chain at
least 64 ulps of every term). That is what the compiled simulator needs:
its enclosures must hold the values its point functions compute. A result
that overflows has the largest finite magnitude it is known to exceed
as its finite end.

Examples
--------
>>> lo, hi = i_add(0.1, 0.1, 0.2, 0.2)
>>> lo < 0.1 + 0.2 < hi and hi - lo < 1e-14
True
>>> i_sqrt(-1.0, 4.0)[0]
0.0
>>> i_sqrt(-2.0, -1.0)  # empty
(nan, nan)
>>> i_mul(1.0, math.inf, 2.0, 3.0)[1]
inf
"""

from __future__ import annotations

import math

__all__ = ["BIG", "TINY", "U", "WIDEN", "i_abs", "i_acos", "i_add", "i_asin", "i_atan",
           "i_atan2", "i_bound", "i_const", "i_cos", "i_cosh", "i_div", "i_empty", "i_entire",
           "i_exp", "i_heaviside", "i_log", "i_max", "i_min", "i_mul", "i_neg", "i_point",
           "i_pow", "i_powi", "i_recip", "i_rpow", "i_sign", "i_sin", "i_sinh", "i_sqrt",
           "i_sub", "i_tan", "i_tanh", "is_empty", "lower", "upper"]

U = 2.0 ** -53
"""Unit roundoff of IEEE double precision, round to nearest."""

WIDEN = 2.0 ** -46
"""Relative widening of a rounded end: 64 units in the last place (``128 U``)."""

TINY = 1e-300
"""Absolute widening that covers gradual underflow."""

BIG = 1e308
"""The finite end of a result that overflowed: its exact value is known to exceed it."""

_INF = math.inf
_NAN = math.nan
_EXP_MAX = 709.78  # exp(x) is finite below log(largest float) = 709.7827...
_HALF_BIG = 8e307  # below exp(709.78) / 2: what sinh and cosh exceed beyond _EXP_MAX
_TWO_PI = 2.0 * math.pi
_SLACK = 1e-9  # how close to an extremum of sin and cos an end counts as reaching it


def lower(v: float, scale: float) -> float:
    """A lower bound of an exact value rounded to ``v``, given the magnitude ``scale``.

    Examples
    --------
    >>> lower(1.0, 1.0) < 1.0, lower(-math.inf, math.inf), lower(math.inf, 1.0)
    (True, -inf, 1e+308)
    """
    if v == _INF:
        return BIG
    return v - (WIDEN * scale + TINY)


def upper(v: float, scale: float) -> float:
    """An upper bound of an exact value rounded to ``v`` (see :func:`lower`).

    Examples
    --------
    >>> upper(1.0, 1.0) > 1.0, upper(math.inf, math.inf), upper(-math.inf, 1.0)
    (True, inf, -1e+308)
    """
    if v == -_INF:
        return -BIG
    return v + (WIDEN * scale + TINY)


def is_empty(lo: float, hi: float) -> bool:
    """Whether ``(lo, hi)`` is the empty interval (a NaN end, or ``lo > hi``).

    Examples
    --------
    >>> is_empty(*i_empty()), is_empty(0.0, 0.0)
    (True, False)
    """
    return not lo <= hi


def _own(lo: float, hi: float) -> tuple[float, float]:
    """Both ends widened by their own magnitude."""
    return lower(lo, abs(lo)), upper(hi, abs(hi))


def i_empty() -> tuple[float, float]:
    """The empty interval: an operand outside a function's domain.

    Examples
    --------
    >>> is_empty(*i_empty())
    True
    """
    return _NAN, _NAN


def i_entire() -> tuple[float, float]:
    """The whole real line.

    Examples
    --------
    >>> i_entire()
    (-inf, inf)
    """
    return -_INF, _INF


def i_bound(lo: float, hi: float) -> tuple[float, float]:
    """The interval itself, or the whole line when it is empty (a bound that proves nothing).

    Examples
    --------
    >>> i_bound(math.nan, math.nan)
    (-inf, inf)
    """
    if is_empty(lo, hi):
        return -_INF, _INF
    return lo, hi


def i_point(c: float) -> tuple[float, float]:
    """An exactly represented constant (an integer, a dyadic number).

    Examples
    --------
    >>> i_point(2.0)
    (2.0, 2.0)
    """
    return c, c


def i_const(c: float) -> tuple[float, float]:
    """A constant rounded to the float ``c`` (``1/3``, ``pi``), widened by its rounding.

    Examples
    --------
    >>> lo, hi = i_const(1 / 3)
    >>> lo < 1 / 3 < hi
    True
    """
    return _own(c, c)


def i_add(al: float, ah: float, bl: float, bh: float) -> tuple[float, float]:
    """``a + b``.

    Examples
    --------
    >>> lo, hi = i_add(1.0, 2.0, 3.0, math.inf)
    >>> 3.9 < lo < 4.0, hi
    (True, inf)
    """
    if is_empty(al, ah) or is_empty(bl, bh):
        return _NAN, _NAN
    return lower(al + bl, abs(al) + abs(bl)), upper(ah + bh, abs(ah) + abs(bh))


def i_neg(al: float, ah: float) -> tuple[float, float]:
    """``-a`` (exact).

    Examples
    --------
    >>> i_neg(1.0, 2.0)
    (-2.0, -1.0)
    """
    return -ah, -al


def i_sub(al: float, ah: float, bl: float, bh: float) -> tuple[float, float]:
    """``a - b``.

    Examples
    --------
    >>> lo, hi = i_sub(1.0, 2.0, 1.0, 2.0)
    >>> -1.0 - 1e-13 < lo < -1.0 and 1.0 < hi < 1.0 + 1e-13
    True
    """
    return i_add(al, ah, -bh, -bl)


def _times(a: float, b: float) -> float:
    """``a * b`` of two interval ends: ``0 * inf`` is 0, an end is only a bound."""
    if a == 0.0 or b == 0.0:
        return 0.0
    return a * b


def i_mul(al: float, ah: float, bl: float, bh: float) -> tuple[float, float]:
    """``a * b``.

    Examples
    --------
    >>> lo, hi = i_mul(-1.0, 2.0, 3.0, 4.0)
    >>> lo <= -4.0 and hi >= 8.0
    True
    """
    if is_empty(al, ah) or is_empty(bl, bh):
        return _NAN, _NAN
    p1, p2, p3, p4 = _times(al, bl), _times(al, bh), _times(ah, bl), _times(ah, bh)
    return _own(min(p1, p2, p3, p4), max(p1, p2, p3, p4))


def i_recip(al: float, ah: float) -> tuple[float, float]:
    """``1 / a``; the whole line when ``a`` contains zero.

    Examples
    --------
    >>> i_recip(-1.0, 1.0)
    (-inf, inf)
    >>> i_recip(2.0, math.inf)[0]
    0.0
    """
    if is_empty(al, ah):
        return _NAN, _NAN
    if al <= 0.0 <= ah:
        return -_INF, _INF
    lo, hi = _own(1.0 / ah, 1.0 / al)
    if ah == _INF:  # 1 / inf is exactly the bound 0
        lo = 0.0
    if al == -_INF:
        hi = 0.0
    return lo, hi


def i_div(al: float, ah: float, bl: float, bh: float) -> tuple[float, float]:
    """``a / b``; the whole line when ``b`` contains zero, unless ``a`` is 0: then 0 (with
    its rounding), the quotient wherever it is defined.

    Examples
    --------
    >>> lo, hi = i_div(1.0, 1.0, 3.0, 3.0)
    >>> lo < 1 / 3 < hi
    True
    >>> i_div(1.0, 2.0, -1.0, 1.0), i_div(0.0, 0.0, -1.0, 1.0)
    ((-inf, inf), (-1e-300, 1e-300))
    """
    rl, rh = i_recip(bl, bh)
    return i_mul(al, ah, rl, rh)


def _power(x: float, k: int) -> float:
    """``x ** k`` for ``k >= 1`` by repeated squaring (overflows to inf, never raises)."""
    result = 1.0
    while k > 0:
        if k & 1:
            result *= x
        k >>= 1
        if k:
            x *= x
    return result


def i_powi(al: float, ah: float, k: int) -> tuple[float, float]:
    """``a ** k`` for an integer ``k``.

    Examples
    --------
    >>> lo, hi = i_powi(-2.0, 1.0, 2)
    >>> lo, 4.0 <= hi < 4.0 + 1e-12
    (0.0, True)
    """
    if is_empty(al, ah):
        return _NAN, _NAN
    if k == 0:
        return 1.0, 1.0
    e = abs(k)
    if e % 2 == 1 or al >= 0.0:
        lo, hi = _power(al, e), _power(ah, e)
    elif ah <= 0.0:
        lo, hi = _power(ah, e), _power(al, e)
    else:
        lo, hi = 0.0, max(_power(al, e), _power(ah, e))
    lo, hi = lower(lo, e * abs(lo)), upper(hi, e * abs(hi))
    if e % 2 == 0:
        lo = max(lo, 0.0)
    if k < 0:
        return i_recip(lo, hi)
    return lo, hi


def _real_power(x: float, e: float) -> float:
    """``x ** e`` for ``x >= 0`` and a non-integer ``e`` (inf past the largest float)."""
    if x == 0.0:
        return 0.0 if e > 0.0 else _INF
    if x == _INF:
        return _INF if e > 0.0 else 0.0
    if e * math.log(x) > _EXP_MAX:
        return _INF
    return x ** e


def _power_end(x: float, e: float, v: float, down: bool) -> float:
    """An end of ``x ** e``, widened also for the rounding of the exponent ``e`` itself."""
    if x == 0.0 or v == _INF or v == 0.0:
        return lower(v, 0.0) if down else upper(v, 0.0)
    scale = abs(v) * (1.0 + abs(e * math.log(x)))
    return lower(v, scale) if down else upper(v, scale)


def i_pow(al: float, ah: float, e: float) -> tuple[float, float]:
    """``a ** e`` for a non-integer constant ``e``: real for ``a >= 0`` (``a > 0`` if ``e < 0``).

    Examples
    --------
    >>> lo, hi = i_pow(-1.0, 4.0, 1.5)
    >>> lo, 8.0 <= hi < 8.0 + 1e-12
    (0.0, True)
    """
    if not math.isfinite(e):  # not a real power function: no bound
        return -_INF, _INF
    if is_empty(al, ah) or ah < 0.0 or (ah == 0.0 and e < 0.0):
        return _NAN, _NAN
    xl = max(al, 0.0)
    u, v = _real_power(xl, e), _real_power(ah, e)
    if e > 0.0:
        return max(_power_end(xl, e, u, True), 0.0), _power_end(ah, e, v, False)
    return max(_power_end(ah, e, v, True), 0.0), _power_end(xl, e, u, False)


def i_rpow(bl: float, bh: float, el: float, eh: float) -> tuple[float, float]:
    """``b ** e`` for a variable exponent, ``exp(e log b)``; the whole line unless ``b > 0``
    (a negative base has real powers at integer exponents).

    Examples
    --------
    >>> lo, hi = i_rpow(2.0, 2.0, 0.5, 3.0)
    >>> lo <= math.sqrt(2.0) and hi >= 8.0
    True
    >>> i_rpow(-1.0, 2.0, 2.0, 3.0)  # (-1) ** 3 is real: no bound from exp(e log b)
    (-inf, inf)
    """
    if is_empty(bl, bh) or is_empty(el, eh):
        return _NAN, _NAN
    if bl <= 0.0:
        return -_INF, _INF
    ll, lh = i_log(bl, bh)
    pl, ph = i_mul(el, eh, ll, lh)
    return i_exp(pl, ph)


def i_sqrt(al: float, ah: float) -> tuple[float, float]:
    """``sqrt(a)`` on ``a >= 0``.

    Examples
    --------
    >>> lo, hi = i_sqrt(-1.0, 4.0)
    >>> lo, 2.0 <= hi < 2.0 + 1e-12
    (0.0, True)
    """
    if is_empty(al, ah) or ah < 0.0:
        return _NAN, _NAN
    lo, hi = _own(math.sqrt(max(al, 0.0)), math.sqrt(ah))
    return max(lo, 0.0), hi


def _exp(x: float) -> float:
    return _INF if x > _EXP_MAX else math.exp(x)


def i_exp(al: float, ah: float) -> tuple[float, float]:
    """``exp(a)``.

    Examples
    --------
    >>> i_exp(-math.inf, 0.0)[0], i_exp(0.0, 800.0)[1]
    (0.0, inf)
    """
    if is_empty(al, ah):
        return _NAN, _NAN
    lo, hi = _own(_exp(al), _exp(ah))
    return max(lo, 0.0), hi


def i_log(al: float, ah: float) -> tuple[float, float]:
    """``log(a)`` on ``a > 0``.

    Examples
    --------
    >>> lo, hi = i_log(0.0, 1.0)
    >>> lo, 0.0 < hi < 1e-299
    (-inf, True)
    """
    if is_empty(al, ah) or ah <= 0.0:
        return _NAN, _NAN
    hi = upper(math.log(ah), abs(math.log(ah)))
    if al <= 0.0:
        return -_INF, hi
    return lower(math.log(al), abs(math.log(al))), hi


def _reaches(al: float, ah: float, at: float) -> bool:
    """Whether ``[al, ah]`` contains ``at + 2 k pi`` for some integer ``k`` (generously)."""
    k = math.ceil((al - at) / _TWO_PI - _SLACK)
    return at + k * _TWO_PI <= ah + _SLACK * (1.0 + abs(ah))


def _periodic(al: float, ah: float, u: float, v: float, top: float,
              bottom: float) -> tuple[float, float]:
    """``sin`` or ``cos`` from its values ``u, v`` at the ends and the phases of its extrema."""
    lo, hi = _own(min(u, v), max(u, v))
    if _reaches(al, ah, top):
        hi = 1.0
    if _reaches(al, ah, bottom):
        lo = -1.0
    return max(lo, -1.0), min(hi, 1.0)


def _bounded_wave(al: float, ah: float) -> bool:
    return math.isfinite(al) and math.isfinite(ah) and ah - al < _TWO_PI


def i_sin(al: float, ah: float) -> tuple[float, float]:
    """``sin(a)``.

    Examples
    --------
    >>> i_sin(1.0, 2.0)[1]  # pi / 2 inside
    1.0
    """
    if is_empty(al, ah):
        return _NAN, _NAN
    if not _bounded_wave(al, ah):
        return -1.0, 1.0
    return _periodic(al, ah, math.sin(al), math.sin(ah), 0.5 * math.pi, -0.5 * math.pi)


def i_cos(al: float, ah: float) -> tuple[float, float]:
    """``cos(a)``.

    Examples
    --------
    >>> i_cos(3.0, 3.3)[0]  # pi inside
    -1.0
    """
    if is_empty(al, ah):
        return _NAN, _NAN
    if not _bounded_wave(al, ah):
        return -1.0, 1.0
    return _periodic(al, ah, math.cos(al), math.cos(ah), 0.0, math.pi)


def i_tan(al: float, ah: float) -> tuple[float, float]:
    """``tan(a)``; the whole line across a pole.

    Examples
    --------
    >>> i_tan(1.0, 2.0)  # across the pole at pi / 2
    (-inf, inf)
    """
    if is_empty(al, ah):
        return _NAN, _NAN
    if not (math.isfinite(al) and math.isfinite(ah)) or ah - al >= math.pi:
        return -_INF, _INF
    if _reaches(al, ah, 0.5 * math.pi) or _reaches(al, ah, -0.5 * math.pi):
        return -_INF, _INF
    return _own(math.tan(al), math.tan(ah))


def i_atan(al: float, ah: float) -> tuple[float, float]:
    """``atan(a)``.

    Examples
    --------
    >>> lo, hi = i_atan(-math.inf, 0.0)
    >>> lo <= -0.5 * math.pi and hi >= 0.0
    True
    """
    if is_empty(al, ah):
        return _NAN, _NAN
    return _own(math.atan(al), math.atan(ah))


def i_tanh(al: float, ah: float) -> tuple[float, float]:
    """``tanh(a)``.

    Examples
    --------
    >>> i_tanh(-math.inf, math.inf)
    (-1.0, 1.0)
    """
    if is_empty(al, ah):
        return _NAN, _NAN
    lo, hi = _own(math.tanh(al), math.tanh(ah))
    return max(lo, -1.0), min(hi, 1.0)


def _sinh(x: float) -> float:
    if abs(x) > _EXP_MAX:
        return math.copysign(_INF, x)
    return math.sinh(x)


def _huge(lo: float, hi: float) -> tuple[float, float]:
    """Finite ends for a sinh or cosh that overflowed (its magnitude exceeds ``_HALF_BIG``)."""
    if lo == _INF:
        lo = _HALF_BIG
    if hi == -_INF:
        hi = -_HALF_BIG
    return lo, hi


def i_sinh(al: float, ah: float) -> tuple[float, float]:
    """``sinh(a)``.

    Examples
    --------
    >>> lo, hi = i_sinh(800.0, 900.0)  # beyond the largest float
    >>> lo > 1e307, hi
    (True, inf)
    """
    if is_empty(al, ah):
        return _NAN, _NAN
    lo, hi = _huge(_sinh(al), _sinh(ah))
    return _own(lo, hi)


def i_cosh(al: float, ah: float) -> tuple[float, float]:
    """``cosh(a)``.

    Examples
    --------
    >>> i_cosh(-1.0, 2.0)[0]
    1.0
    """
    if is_empty(al, ah):
        return _NAN, _NAN
    near = 0.0 if al <= 0.0 <= ah else min(abs(al), abs(ah))
    far = max(abs(al), abs(ah))
    lo, hi = _huge(abs(_sinh(near)) if near > _EXP_MAX else math.cosh(near),
                   _INF if far > _EXP_MAX else math.cosh(far))
    lo, hi = _own(lo, hi)
    return max(lo, 1.0), hi


def _in_unit(al: float, ah: float) -> bool:
    return not (is_empty(al, ah) or ah < -1.0 or al > 1.0)


def i_asin(al: float, ah: float) -> tuple[float, float]:
    """``asin(a)`` on ``[-1, 1]``.

    Examples
    --------
    >>> lo, hi = i_asin(0.5, 3.0)  # defined on [0.5, 1]
    >>> hi >= 0.5 * math.pi
    True
    """
    if not _in_unit(al, ah):
        return _NAN, _NAN
    return _own(math.asin(max(al, -1.0)), math.asin(min(ah, 1.0)))


def i_acos(al: float, ah: float) -> tuple[float, float]:
    """``acos(a)`` on ``[-1, 1]``.

    Examples
    --------
    >>> lo, hi = i_acos(-1.0, 1.0)
    >>> lo, hi >= math.pi
    (0.0, True)
    """
    if not _in_unit(al, ah):
        return _NAN, _NAN
    lo, hi = _own(math.acos(min(ah, 1.0)), math.acos(max(al, -1.0)))
    return max(lo, 0.0), hi


def i_atan2(yl: float, yh: float, xl: float, xh: float) -> tuple[float, float]:
    """``atan2(y, x)``: continuous off the negative ``x`` axis, else ``[-pi, pi]``.

    Examples
    --------
    >>> lo, hi = i_atan2(1.0, 1.0, 0.0, 0.0)  # the positive y axis
    >>> lo <= 0.5 * math.pi <= hi
    True
    """
    if is_empty(yl, yh) or is_empty(xl, xh):
        return _NAN, _NAN
    if xl > 0.0:  # right half-plane: atan(y / x)
        ql, qh = i_div(yl, yh, xl, xh)
        return i_atan(ql, qh)
    if yl > 0.0 or yh < 0.0:  # upper or lower half-plane: pi/2 - atan(x / y) (- pi below)
        ql, qh = i_div(xl, xh, yl, yh)
        al, ah = i_atan(ql, qh)
        half_l, half_h = i_const(0.5 * math.pi)
        rl, rh = i_sub(half_l, half_h, al, ah)
        if yh < 0.0:
            pl, ph = i_const(math.pi)
            return i_sub(rl, rh, pl, ph)
        return rl, rh
    return lower(-math.pi, math.pi), upper(math.pi, math.pi)


def i_abs(al: float, ah: float) -> tuple[float, float]:
    """``|a|`` (exact).

    Examples
    --------
    >>> i_abs(-3.0, 2.0)
    (0.0, 3.0)
    """
    if is_empty(al, ah):
        return _NAN, _NAN
    if al >= 0.0:
        return al, ah
    if ah <= 0.0:
        return -ah, -al
    return 0.0, max(-al, ah)


def i_sign(al: float, ah: float) -> tuple[float, float]:
    """``sign(a)`` with ``sign(0) = 0`` (exact).

    Examples
    --------
    >>> i_sign(-1.0, 0.0)
    (-1.0, 0.0)
    """
    if is_empty(al, ah):
        return _NAN, _NAN
    lo = -1.0 if al < 0.0 else (0.0 if al == 0.0 else 1.0)
    hi = 1.0 if ah > 0.0 else (0.0 if ah == 0.0 else -1.0)
    return lo, hi


def i_heaviside(al: float, ah: float) -> tuple[float, float]:
    """The step function, 0 below zero and 1 above; at zero anything in ``[0, 1]`` (exact).

    Examples
    --------
    >>> i_heaviside(-1.0, 0.0)
    (0.0, 1.0)
    """
    if is_empty(al, ah):
        return _NAN, _NAN
    return (0.0 if al <= 0.0 else 1.0), (1.0 if ah >= 0.0 else 0.0)


def i_min(al: float, ah: float, bl: float, bh: float) -> tuple[float, float]:
    """``min(a, b)`` (exact).

    Examples
    --------
    >>> i_min(0.0, 3.0, 1.0, 2.0)
    (0.0, 2.0)
    """
    if is_empty(al, ah) or is_empty(bl, bh):
        return _NAN, _NAN
    return min(al, bl), min(ah, bh)


def i_max(al: float, ah: float, bl: float, bh: float) -> tuple[float, float]:
    """``max(a, b)`` (exact).

    Examples
    --------
    >>> i_max(0.0, 3.0, 1.0, 2.0)
    (1.0, 3.0)
    """
    if is_empty(al, ah) or is_empty(bl, bh):
        return _NAN, _NAN
    return max(al, bl), max(ah, bh)
