"""Filippov sliding in numba: a port of ``simulation/sliding.py`` and the engine's sign logic.

A *flow context* ``fc = (fg, sg, gg, dg, m, sl, W, pg, free)`` describes the
current flow: the model groups of the flow, the switching functions, their
state gradient and the flow's sigma-Jacobian, the mode's number of switches
``m``, the sliding switches ``sl`` (an index array, usually empty), a
workspace ``W`` (see :func:`workspace`), the group of the fused sliding op
(flow, switch Lie derivatives, gradient and sigma-Jacobian in one call) and
whether the switching functions are free of the signs. With ``sl`` empty every function here is a
plain flow call; while switches slide:

* :func:`equivalent` solves ``grad s_S . (f0 + F_sigma sigma_S) = 0`` for the
  equivalent signs (the reference's ``equivalent_sigma``);
* :func:`flow_eq` is the flow with those signs (what monitors, guards and
  invariants see; the reference's ``sigma_at``), formed as ``f0 + F_sigma
  sigma_S`` from the same call (exact for flows affine in sigma, the only
  ones that slide);
* :func:`rhs` is what the integrator sees: that flow projected onto the
  tangent space of the sliding surfaces (the reference's ``_Run.flow``);
* :func:`enter_mode`, :func:`resolve` and :func:`update_switches` port the
  sign bookkeeping and the joint active-set iteration of ``resolve_switches``.

Failures the reference reports by raising (a singular equivalent-dynamics
matrix, sliding on a flow that is not affine in sigma) set ``W[-1][0]`` or
return a non-zero status; the kernel then hands the run to the reference.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from hybridlab.simulation.compiled.signatures import ptr

__all__ = ["workspace", "equivalent", "flow_eq", "rhs", "enter_mode", "resolve",
           "update_switches", "OK", "NOT_AFFINE", "SINGULAR"]

OP_FLOW, OP_SWITCH, OP_SWITCH_LIE, OP_SWITCH_GRAD, OP_FLOW_DSIGMA, OP_SLIDE_PARTS = \
    0, 3, 4, 8, 9, 10
OK, NOT_AFFINE, SINGULAR = 0, 1, 2
_EQ_SLACK = 1e-12


@numba.njit(cache=True)
def workspace(n, n_sig):
    """Scratch arrays: dummy, sigma, base, f0, lie, grad, dsigma, A, b, eq, sol, flag, parts."""
    ns = max(n_sig, 1)
    return (np.zeros(max(n, 1)), np.empty(ns), np.empty(ns), np.empty(n), np.empty(ns),
            np.empty(ns * n), np.empty(n * ns), np.empty(ns * ns), np.empty(ns), np.empty(ns),
            np.empty(ns), np.zeros(1), np.empty(n + ns + 2 * ns * n))


@numba.njit(cache=True)
def _solve(A, b, k, out):
    """Solve the ``k x k`` row-major system ``A out = b`` (partial pivoting; A, b destroyed)."""
    for c in range(k):
        piv = c
        for r in range(c + 1, k):
            if abs(A[r * k + c]) > abs(A[piv * k + c]):
                piv = r
        if A[piv * k + c] == 0.0 or not np.isfinite(A[piv * k + c]):
            return False
        if piv != c:
            for q in range(k):
                A[c * k + q], A[piv * k + q] = A[piv * k + q], A[c * k + q]
            b[c], b[piv] = b[piv], b[c]
        for r in range(c + 1, k):
            factor = A[r * k + c] / A[c * k + c]
            for q in range(c, k):
                A[r * k + q] -= factor * A[c * k + q]
            b[r] -= factor * b[c]
    for c in range(k - 1, -1, -1):
        acc = b[c]
        for q in range(c + 1, k):
            acc -= A[c * k + q] * out[q]
        out[c] = acc / A[c * k + c]
    return True


@numba.njit(cache=True)
def equivalent(model, fc, t, x, p, sig, eq):
    """Equivalent signs of the sliding switches ``fc[5]`` at ``(t, x)`` into ``eq``.

    Leaves ``[f0 | ds/dt | grad s | F_sigma]`` at ``sigma_S = 0`` in ``W[12]``.
    """
    m, sl, W = fc[4], fc[5], fc[6]
    base, A, b, parts = W[2], W[7], W[8], W[12]
    n = x.size
    k = sl.size
    base[:] = sig
    for a in range(k):
        base[sl[a]] = 0.0
    model(OP_SLIDE_PARTS, fc[7], t, ptr(x), ptr(p), ptr(base), ptr(W[0]), ptr(parts))
    og, od = n + m, n + m + m * n
    for a in range(k):
        for c in range(k):
            acc = 0.0
            for i in range(n):
                acc += parts[og + sl[a] * n + i] * parts[od + i * m + sl[c]]
            A[a * k + c] = acc
        b[a] = -parts[n + sl[a]]
    if not _solve(A, b, k, eq):
        W[11][0] = 1.0
        return False
    return True


@numba.njit(cache=True)
def _flow_sliding(model, fc, t, x, p, sig, out, eq):
    m, sl, W = fc[4], fc[5], fc[6]
    ok = equivalent(model, fc, t, x, p, sig, eq)
    sgw, parts = W[1], W[12]
    sgw[:] = sig
    for a in range(sl.size):
        sgw[sl[a]] = eq[a]
    n = x.size
    od = n + m + m * n
    for i in range(n):  # affine in sigma: f(sigma) = f(sigma_S = 0) + F_sigma sigma_S
        acc = parts[i]
        for a in range(sl.size):
            acc += parts[od + i * m + sl[a]] * eq[a]
        out[i] = acc
    return ok


@numba.njit(cache=True, inline="always")
def flow_eq(model, fc, t, x, p, sig, out, eq):
    """The flow with the equivalent signs (``eq`` receives them); False if singular."""
    if fc[5].size == 0:
        model(OP_FLOW, fc[0], t, ptr(x), ptr(p), ptr(sig), ptr(fc[6][0]), ptr(out))
        return True
    return _flow_sliding(model, fc, t, x, p, sig, out, eq)


@numba.njit(cache=True)
def _rhs_sliding(model, fc, t, x, p, sig, out):
    m, sl, W = fc[4], fc[5], fc[6]
    dummy, sgw, lie, grad, A, b, eq, sol, parts = (W[0], W[1], W[4], W[5], W[7], W[8], W[9],
                                                   W[10], W[12])
    _flow_sliding(model, fc, t, x, p, sig, out, eq)
    # remove the rounding-level drift off the sliding surfaces (as the reference does)
    n = x.size
    k = sl.size
    if fc[8]:
        # switching functions free of sigma: gradient and ds/dt as at sigma_S = 0
        og = n + m
        for a in range(k):
            acc = parts[n + sl[a]]
            for i in range(n):
                grad[sl[a] * n + i] = parts[og + sl[a] * n + i]
                acc += parts[og + sl[a] * n + i] * (out[i] - parts[i])
            lie[sl[a]] = acc
    else:
        model(OP_SWITCH_GRAD, fc[2], t, ptr(x), ptr(p), ptr(sgw), ptr(dummy), ptr(grad))
        model(OP_SWITCH_LIE, fc[1], t, ptr(x), ptr(p), ptr(sgw), ptr(out), ptr(lie))
    for a in range(k):
        for c in range(k):
            acc = 0.0
            for i in range(n):
                acc += grad[sl[a] * n + i] * grad[sl[c] * n + i]
            A[a * k + c] = acc
        b[a] = lie[sl[a]]
    if not _solve(A, b, k, sol):
        W[11][0] = 1.0
        return
    for i in range(n):
        acc = 0.0
        for a in range(k):
            acc += grad[sl[a] * n + i] * sol[a]
        out[i] -= acc


@numba.njit(cache=True, inline="always")
def rhs(model, fc, t, x, p, sig, out):
    """The integrator's right-hand side: the flow, projected onto the sliding surfaces."""
    if fc[5].size == 0:
        model(OP_FLOW, fc[0], t, ptr(x), ptr(p), ptr(sig), ptr(fc[6][0]), ptr(out))
    else:
        _rhs_sliding(model, fc, t, x, p, sig, out)


@numba.njit(cache=True)
def _sdot(model, fc, t, x, p, sigma, k, f, lie):
    fg, sg = fc[0], fc[1]
    dummy = fc[6][0]
    model(OP_FLOW, fg, t, ptr(x), ptr(p), ptr(sigma), ptr(dummy), ptr(f))
    model(OP_SWITCH_LIE, sg, t, ptr(x), ptr(p), ptr(sigma), ptr(f), ptr(lie))
    return lie[k]


@numba.njit(cache=True)
def _sides(model, fc, t, x, p, sig, k, f, lie, tmp):
    tmp[:] = sig
    tmp[k] = 1.0
    d_plus = _sdot(model, fc, t, x, p, tmp, k, f, lie)
    tmp[k] = -1.0
    d_minus = _sdot(model, fc, t, x, p, tmp, k, f, lie)
    return d_plus, d_minus


@numba.njit(cache=True)
def _leave(sig, previous, slm, k, d_plus, d_minus):
    slm[k] = False
    if d_plus > 0 and d_minus > 0:
        sig[k] = 1.0
    elif d_plus < 0 and d_minus < 0:
        sig[k] = -1.0
    else:  # repelling or tangential: keep going the way the state came
        sig[k] = 1.0 if previous[k] >= 0 else -1.0


@numba.njit(cache=True)
def _indices(slm, m):
    c = 0
    for k in range(m):
        if slm[k]:
            c += 1
    idx = np.empty(c, dtype=np.int64)
    c = 0
    for k in range(m):
        if slm[k]:
            idx[c] = k
            c += 1
    return idx


@numba.njit(cache=True)
def resolve(model, fc, affine, t, x, p, sig, at_surface, forced, forced_value, slm):
    """``resolve_switches``: new signs into ``sig``, the sliding set into ``slm``; a status."""
    fg, sg, gg, dg, m, W = fc[0], fc[1], fc[2], fc[3], fc[4], fc[6]
    n = x.size
    f = np.empty(n)
    lie = np.empty(sig.size)
    tmp = np.empty(sig.size)
    eq = np.empty(sig.size)
    previous = sig.copy()
    for k in range(m):
        slm[k] = False
        if forced[k]:
            sig[k] = forced_value[k]
        elif at_surface[k]:
            slm[k] = True
    # a surface whose flow does not depend on its sign (abs, min, max) is crossed
    for k in range(m):
        if slm[k]:
            d_plus, d_minus = _sides(model, fc, t, x, p, sig, k, f, lie, tmp)
            if abs(d_plus - d_minus) <= 1e-14 * (abs(d_plus) + abs(d_minus)):
                _leave(sig, previous, slm, k, d_plus, d_minus)
    count = _indices(slm, m).size
    dp = np.empty(m)
    dm = np.empty(m)
    for _ in range(2 * count + 2):
        idx = _indices(slm, m)
        if idx.size == 0:
            break
        if not affine:
            return NOT_AFFINE
        for a in range(idx.size):
            sig[idx[a]] = 0.0
        if not equivalent(model, (fg, sg, gg, dg, m, idx, W, fc[7], fc[8]), t, x, p, sig, eq):
            return SINGULAR
        outside = False
        for a in range(idx.size):
            sig[idx[a]] = eq[a]
        for a in range(idx.size):
            if abs(eq[a]) > 1 + _EQ_SLACK:
                sig[idx[a]] = math.copysign(1.0, sig[idx[a]])
                slm[idx[a]] = False
                outside = True
        if outside:
            continue
        for a in range(idx.size):
            dp[a], dm[a] = _sides(model, fc, t, x, p, sig, idx[a], f, lie, tmp)
        repelling = False
        for a in range(idx.size):
            if not (dp[a] <= 0 <= dm[a] and dm[a] > dp[a]):
                repelling = True
                _leave(sig, previous, slm, idx[a], dp[a], dm[a])
        if not repelling:
            break
    return OK


@numba.njit(cache=True)
def enter_mode(model, fc, affine, t, x, p, sig, slm, event_atol):
    """Fresh signs for a mode's switches at ``(t, x)`` (``fc`` without sliding)."""
    m = fc[4]
    slm[:] = False
    if m == 0:
        return OK
    s = np.empty(sig.size)
    at_surface = np.zeros(sig.size, dtype=np.bool_)
    forced = np.zeros(sig.size, dtype=np.bool_)
    sig[:] = 1.0
    model(OP_SWITCH, fc[1], t, ptr(x), ptr(p), ptr(sig), ptr(fc[6][0]), ptr(s))
    for k in range(m):
        at_surface[k] = abs(s[k]) <= event_atol
        sig[k] = 1.0 if s[k] >= 0 else -1.0
    return resolve(model, fc, affine, t, x, p, sig, at_surface, forced, sig, slm)


@numba.njit(cache=True)
def _sign(v):
    return 0.0 if v == 0 else (1.0 if v > 0 else (-1.0 if v < 0 else v))


@numba.njit(cache=True)
def update_switches(model, fc, affine, t, x, p, sig, slm, switches, exits, kinds):
    """``_Run.update_switches`` without the logging: ``kinds[k]`` 1 crossing, 2 slide start,
    3 slide end for every switch hit; ``fc`` carries the sliding set before the event."""
    m = fc[4]
    sl = fc[5]
    old = sig.copy()
    if sl.size:
        eq = np.empty(sig.size)
        if not equivalent(model, fc, t, x, p, sig, eq):
            return SINGULAR
        for a in range(sl.size):
            old[sl[a]] = eq[a]
    old_slm = slm.copy()
    forced = np.zeros(sig.size, dtype=np.bool_)
    forced_value = np.zeros(sig.size)
    at_surface = np.zeros(sig.size, dtype=np.bool_)
    for k in range(m):
        if exits[k]:
            forced[k] = True
            forced_value[k] = _sign(old[k])
        at_surface[k] = switches[k] or (old_slm[k] and not exits[k])
    status = resolve(model, fc, affine, t, x, p, sig, at_surface, forced, forced_value, slm)
    if status != OK:
        return status
    for k in range(m):
        kinds[k] = 0
        if switches[k] or exits[k]:
            if slm[k] and not old_slm[k]:
                kinds[k] = 2
            elif old_slm[k] and not slm[k]:
                kinds[k] = 3
            else:
                kinds[k] = 1
    return OK
