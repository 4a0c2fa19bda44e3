"""Explicit Runge-Kutta steps (RK45, DOP853) with dense output, in numba.

A line-by-line port of scipy's ``RungeKutta._step_impl`` and dense output
(same coefficients, same step-size control, same error norms), so that
``rtol``/``atol`` mean exactly what they mean for the reference backend and
both backends take the same steps. The right-hand side is
:func:`.sliding.rhs` of a flow context ``fc`` (the plain flow, or the
projected equivalent flow while switches slide).
"""

# ruff: noqa: SIM108 - kept line by line with the scipy / reference code it ports

from __future__ import annotations

import numba
import numpy as np
from scipy.integrate._ivp import dop853_coefficients as _dop
from scipy.integrate._ivp.rk import RK45 as _RK45

from hybridlab.simulation.compiled.signatures import borrowing, counted, ptr, ptr_at
from hybridlab.simulation.compiled.sliding import OP_FLOW, rhs

__all__ = ["RK45", "DOP853", "METHOD_CODES", "ptr", "rk_step", "dense_coefficients",
           "dense_eval", "dense_eval_at", "initial_step"]

RK45, DOP853 = 0, 1
#: method name -> kernel code
METHOD_CODES = {"RK45": RK45, "DOP853": DOP853}

_SAFETY, _MIN_FACTOR, _MAX_FACTOR = 0.9, 0.2, 10.0

_RK_A = np.ascontiguousarray(_RK45.A, dtype=np.float64)
_RK_B = np.ascontiguousarray(_RK45.B, dtype=np.float64)
_RK_C = np.ascontiguousarray(_RK45.C, dtype=np.float64)
_RK_E = np.ascontiguousarray(_RK45.E, dtype=np.float64)
_RK_P = np.ascontiguousarray(_RK45.P, dtype=np.float64)
_DP_N = _dop.N_STAGES
_DP_A = np.ascontiguousarray(_dop.A, dtype=np.float64)
_DP_B = np.ascontiguousarray(_dop.B, dtype=np.float64)
_DP_C = np.ascontiguousarray(_dop.C, dtype=np.float64)
_DP_E3 = np.ascontiguousarray(_dop.E3, dtype=np.float64)
_DP_E5 = np.ascontiguousarray(_dop.E5, dtype=np.float64)
_DP_D = np.ascontiguousarray(_dop.D, dtype=np.float64)

#: stages (rows of K) and dense-output coefficient rows per method
N_K = (_RK_A.shape[0] + 1, _dop.N_STAGES_EXTENDED)
N_COEF = (_RK_P.shape[1], _dop.INTERPOLATOR_POWER)


def _nonzero(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The nonzero entries of a coefficient table, row by row in column order.

    Returns ``(start, column, value)``: row ``s`` holds ``value[q]`` at
    ``column[q]`` for ``q`` in ``start[s]:start[s + 1]``. A weighted sum of
    stages over these entries adds the same terms in the same order as over
    the whole row, less the exact zeros (about a third of the tables), so its
    result is bit for bit the same: a sum that starts at +0.0 is unchanged by
    adding a zero product.

    Examples
    --------
    >>> _nonzero(np.array([[0.0, 0.0], [0.5, 0.0], [0.25, 2.0]]))
    (array([0, 0, 1, 3]), array([0, 0, 1]), array([0.5 , 0.25, 2.  ]))
    """
    rows = np.atleast_2d(np.asarray(rows, dtype=np.float64))
    start: list[int] = [0]
    columns: list[int] = []
    for row in rows:
        columns.extend(np.flatnonzero(row))
        start.append(len(columns))
    column = np.array(columns, dtype=np.int64)
    value = rows[np.repeat(np.arange(rows.shape[0]), np.diff(start)), column]
    return np.array(start, dtype=np.int64), column, np.ascontiguousarray(value)


# the tables in that form: stage rows (A), solution weights (B), interpolant columns (P.T,
# D). The error sums keep every stage: a non-finite stage (say, the flow at the new state)
# must make the error NaN and the step rejected, as in scipy, even where its weight is zero.
_RK_AS, _RK_AC, _RK_AV = _nonzero(_RK_A)
_, _RK_BC, _RK_BV = _nonzero(_RK_B)
_RK_PS, _RK_PC, _RK_PV = _nonzero(_RK_P.T)
_DP_AS, _DP_AC, _DP_AV = _nonzero(_DP_A)
_, _DP_BC, _DP_BV = _nonzero(_DP_B)
_DP_DS, _DP_DC, _DP_DV = _nonzero(_DP_D)


@numba.njit(cache=True)
def _rms(v: np.ndarray) -> float:
    return np.linalg.norm(v) / v.size ** 0.5


@counted
def initial_step(model, fc, t0, y0, f0, t_bound, max_step, order, rtol, atol, p, sig):
    """scipy's ``select_initial_step``."""
    interval = abs(t_bound - t0)
    if interval == 0.0:
        return 0.0
    scale = atol + np.abs(y0) * rtol
    d0 = _rms(y0 / scale)
    d1 = _rms(f0 / scale)
    if d0 < 1e-5 or d1 < 1e-5:
        h0 = 1e-6
    else:
        h0 = 0.01 * d0 / d1
    h0 = min(h0, interval)
    y1 = y0 + h0 * f0
    f1 = np.empty_like(y0)
    rhs(model, fc, t0 + h0, y1, p, sig, f1)
    d2 = _rms((f1 - f0) / scale) / h0
    if (d1 <= 1e-15 and d2 <= 1e-15) or d2 != d2:  # NaN: the probe left the flow's domain
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / (order + 1))
    return min(100 * h0, h1, interval, max_step)


@borrowing
def _stages(model, method, fc, t, y, f, h, p, sig, K, y_new, f_new, tmp):
    """One Runge-Kutta step (``rk_step``): stages into ``K``, result into y_new, f_new.

    Only the states of the flow context's active set ``fc.active`` are combined:
    the others have a flow that is identically zero in this mode, so their
    stages are exact zeros and their values stay as they are.
    """
    act = fc.active
    if method == RK45:
        a_start, a_col, a_val, b_col, b_val, C = _RK_AS, _RK_AC, _RK_AV, _RK_BC, _RK_BV, _RK_C
        ns = _RK_A.shape[0]
    else:
        a_start, a_col, a_val, b_col, b_val, C = _DP_AS, _DP_AC, _DP_AV, _DP_BC, _DP_BV, _DP_C
        ns = _DP_N
    n = y.size
    for i in range(n):  # element loops: a slice assignment may allocate (see borrowing)
        K[0, i] = f[i]
        tmp[i] = y[i]
    fg, W, plain = fc.flow_group, fc.workspace, fc.sliding.size == 0
    for s in range(1, ns):
        for a in range(act.size):
            i = act[a]
            acc = 0.0
            for q in range(a_start[s], a_start[s + 1]):  # the nonzero A[s, r], r < s
                acc += K[a_col[q], i] * a_val[q]
            tmp[i] = y[i] + acc * h
        if plain:  # the flow straight into row s of K: no row view, no flow context to unpack
            model(OP_FLOW, fg, t + C[s] * h, ptr(tmp), ptr(p), ptr(sig), ptr(W),
                  ptr_at(K, s * n))
        else:
            rhs(model, fc, t + C[s] * h, tmp, p, sig, K[s])
    for i in range(n):
        y_new[i] = y[i]
    for a in range(act.size):
        i = act[a]
        acc = 0.0
        for q in range(b_col.size):
            acc += K[b_col[q], i] * b_val[q]
        y_new[i] = y[i] + h * acc
    rhs(model, fc, t + h, y_new, p, sig, f_new)
    for i in range(n):
        K[ns, i] = f_new[i]


@borrowing
def _error_norm(method, K, h, scale, act, n):
    """scipy's error norm over all ``n`` states; the inactive ones contribute exact zeros."""
    if method == RK45:
        E = _RK_E
        acc = 0.0
        for a in range(act.size):
            i = act[a]
            e = 0.0
            for r in range(E.size):
                e += K[r, i] * E[r]
            v = e * h / scale[i]
            acc += v * v
        return np.sqrt(acc) / n ** 0.5
    e5n = 0.0
    e3n = 0.0
    for a in range(act.size):
        i = act[a]
        e5 = 0.0
        e3 = 0.0
        for r in range(_DP_N + 1):
            e5 += K[r, i] * _DP_E5[r]
            e3 += K[r, i] * _DP_E3[r]
        e5 /= scale[i]
        e3 /= scale[i]
        e5n += e5 * e5
        e3n += e3 * e3
    if e5n == 0 and e3n == 0:
        return 0.0
    denom = e5n + 0.01 * e3n
    return abs(h) * e5n / np.sqrt(denom * n)


@borrowing
def rk_step(model, method, fc, t, y, f, t_bound, h_abs_in, max_step, rtol, atol, p, sig, K,
            y_new, f_new, tmp, scale):
    """scipy's ``_step_impl``; returns ``(ok, t_new, h_abs_next, h)`` (``scale``: scratch of
    the state's size)."""
    order_err = 4 if method == RK45 else 7
    exponent = -1.0 / (order_err + 1)
    min_step = 10 * abs(np.nextafter(t, np.inf) - t)
    if h_abs_in > max_step:
        h_abs = max_step
    elif not h_abs_in >= min_step:  # also a NaN step
        h_abs = min_step
    else:
        h_abs = h_abs_in
    rejected = False
    n = y.size
    act = fc.active
    while True:
        if h_abs < min_step:
            return False, t, h_abs, 0.0
        h = h_abs
        t_new = t + h
        if t_new - t_bound > 0:
            t_new = t_bound
        h = t_new - t
        h_abs = abs(h)
        _stages(model, method, fc, t, y, f, h, p, sig, K, y_new, f_new, tmp)
        for a in range(act.size):
            i = act[a]
            scale[i] = atol + max(abs(y[i]), abs(y_new[i])) * rtol
        err = _error_norm(method, K, h, scale, act, n)
        if err < 1:
            if err == 0:
                factor = _MAX_FACTOR
            else:
                factor = min(_MAX_FACTOR, _SAFETY * err ** exponent)
            if rejected:
                factor = min(1.0, factor)
            h_abs *= factor
            return True, t_new, h_abs, h
        # a non-finite stage gives a NaN error: shrink as far as allowed (scipy's max() does
        # the same by argument order); the step then fails below min_step, never loops
        h_abs *= _MIN_FACTOR if err != err else max(_MIN_FACTOR, _SAFETY * err ** exponent)
        rejected = True


@borrowing
def dense_coefficients(model, method, fc, t_old, h, y_old, y, f, p, sig, K, tmp, coef):
    """Interpolant of the last step into ``coef`` (``Q.T`` for RK45, ``F`` for DOP853).

    Only the columns of the active states ``fc.active`` are written; the caller
    zeroes ``coef`` when the active set changes, so the others stay zero.
    """
    act = fc.active
    if method == RK45:
        for j in range(_RK_PS.size - 1):
            for a in range(act.size):
                i = act[a]
                acc = 0.0
                for q in range(_RK_PS[j], _RK_PS[j + 1]):  # the nonzero P[r, j]
                    acc += K[_RK_PC[q], i] * _RK_PV[q]
                coef[j, i] = acc
        return
    n = y.size
    for i in range(n):
        tmp[i] = y_old[i]
    fg, W, plain = fc.flow_group, fc.workspace, fc.sliding.size == 0
    for s in range(_DP_N + 1, K.shape[0]):
        for a in range(act.size):
            i = act[a]
            acc = 0.0
            for q in range(_DP_AS[s], _DP_AS[s + 1]):
                acc += K[_DP_AC[q], i] * _DP_AV[q]
            tmp[i] = y_old[i] + acc * h
        if plain:
            model(OP_FLOW, fg, t_old + _DP_C[s] * h, ptr(tmp), ptr(p), ptr(sig), ptr(W),
                  ptr_at(K, s * n))
        else:
            rhs(model, fc, t_old + _DP_C[s] * h, tmp, p, sig, K[s])
    for a in range(act.size):
        i = act[a]
        dy = y[i] - y_old[i]
        coef[0, i] = dy
        coef[1, i] = h * K[0, i] - dy
        coef[2, i] = 2 * dy - h * (f[i] + K[0, i])
        for j in range(_DP_D.shape[0]):
            acc = 0.0
            for q in range(_DP_DS[j], _DP_DS[j + 1]):
                acc += _DP_DV[q] * K[_DP_DC[q], i]
            coef[3 + j, i] = h * acc


@numba.njit(cache=True, inline="always")
def dense_eval_at(method, coef, t_old, h, y_old, act, n, nco, nact, t, out):
    """:func:`dense_eval` on raw pointers (``coef`` row-major ``nco x n``): no array is bound,
    so a loop calling it pays no reference counting."""
    x = (t - t_old) / h
    for i in range(n):
        out[i] = y_old[i]
    for a in range(nact):
        i = act[a]
        acc = 0.0
        if method == RK45:
            pw = 1.0
            for j in range(nco):
                pw *= x
                acc += coef[j * n + i] * pw
            out[i] = h * acc + y_old[i]
        else:
            for k in range(nco):
                acc += coef[(nco - 1 - k) * n + i]
                if k % 2 == 0:
                    acc *= x
                else:
                    acc *= 1 - x
            out[i] = acc + y_old[i]


@numba.njit(cache=True, inline="always")
def dense_eval(method, coef, t_old, h, y_old, act, t, out):
    """The step's interpolant at ``t`` into ``out`` (inactive states: ``y_old``)."""
    dense_eval_at(method, ptr(coef), t_old, h, ptr(y_old), ptr(act), y_old.size, coef.shape[0],
                  act.size, t, ptr(out))
