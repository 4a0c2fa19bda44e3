"""Event location on the dense output, in numba: a port of ``simulation/location.py``.

Monitors of the current mode are evaluated at points of one step's dense
output through the generated model function. ``sample_step``,
``first_trigger`` and the root finders follow the reference module line by
line (Brent's ``brentq`` and the bounded Brent minimiser of
``scipy.optimize.minimize_scalar`` are ported), so both backends fire the
same monitors at the same instants.
"""

# ruff: noqa: SIM108, SIM109 - kept line by line with the scipy / reference code it ports

from __future__ import annotations

import math

import numba
import numpy as np

from hybridlab.simulation.compiled.integrate import RK45, dense_eval_at
from hybridlab.simulation.compiled.layout import Probe, SampleWorkspace
from hybridlab.simulation.compiled.opcodes import (
    OP_COND,
    OP_COND_BOTH,
    OP_SWITCH,
    OP_SWITCH_BOTH,
)
from hybridlab.simulation.compiled.signatures import borrowing, counted, ptr
from hybridlab.simulation.compiled.sliding import equivalent_signs
from hybridlab.simulation.rules import (
    CHECK_AT,
    CLUSTER_WIDTH,
    LOCATE_ITERATIONS,
    LOCATE_STEP,
    MINIMUM_WIDTH,
    event_time_tolerance,
)

__all__ = ["monitors_at", "monitor_value", "sample_step", "sample_workspace", "scan", "xtol_at",
           "GUARD", "INVARIANT", "SWITCH", "EXIT", "OUTGROWN"]

GUARD, INVARIANT, SWITCH, EXIT = 0, 1, 2, 3
#: what :func:`scan` returns when the step's samples outgrow the workspace
OUTGROWN = -1
_EPS = np.finfo(np.float64).eps
#: :func:`hybridlab.simulation.rules.event_time_tolerance`, compiled
xtol_at = numba.njit(cache=True, inline="always")(event_time_tolerance)


@numba.njit(cache=True)
def _position(sl, k):
    for a in range(sl.size):
        if sl[a] == k:
            return a
    return 0


@numba.njit(cache=True, inline="always")
def monitors_at(model, md, p, sig, ws, t, x, f, phi, dphi, col):
    """Every monitor's value and slope at ``(t, x)`` into column ``col``.

    ``f`` is the state's time derivative the slopes are taken along: the
    flow at the start of a segment, the derivative of the dense output at
    the samples of a step (:func:`_batch`). While switches slide, the
    equivalent signs must be in ``ws.eq`` already. The slope of a sliding
    exit (``1 - |sigma_eq|``) is left at zero here; :func:`_batch` replaces
    it by finite differences over the batch, as the reference engine does.
    """
    cg, mk, mref, mstart, mlen, nc = (md.cond_group, md.kind, md.ref, md.start, md.length,
                                      md.n_conditions)
    cv, sv, eqv = ws.cond, ws.switch, ws.eq
    sg, m, sl = md.context.switch_group, md.context.n_switches, md.context.sliding
    # values and Lie derivatives in one call each: cv = [g | dg/dt], sv = [s | ds/dt]
    if cg >= 0:
        model(OP_COND_BOTH, cg, t, ptr(x), ptr(p), ptr(sig), ptr(f), ptr(cv))
    if sg >= 0:
        model(OP_SWITCH_BOTH, sg, t, ptr(x), ptr(p), ptr(sig), ptr(f), ptr(sv))
    for r in range(mk.size):
        phi[r, col], dphi[r, col] = _column(mk[r], mref[r], mstart[r], mlen[r], nc, m,
                                            _position(sl, mref[r]), ptr(cv), ptr(sv),
                                            ptr(sig), ptr(eqv))


@numba.njit(cache=True, inline="always")
def _column(kind, ref, start, length, nc, m, pos, cv, sv, sig, eqv):
    """One monitor's value and slope from the fused model outputs (raw pointers, so the
    sampler's inner loop binds no array): ``cv = [g | dg/dt]``, ``sv = [s | ds/dt]``."""
    if kind == GUARD:
        i = start
        for q in range(start + 1, start + length):
            if cv[q] < cv[i]:
                i = q
        return -cv[i], -cv[nc + i]
    if kind == INVARIANT:
        return cv[start], cv[nc + start]
    if kind == SWITCH:
        return sig[ref] * sv[ref], sig[ref] * sv[m + ref]
    return 1.0 - abs(eqv[pos]), 0.0  # the slope of a sliding exit: see _batch


@numba.njit(cache=True, inline="always")
def probe(md, p, sig, ws, step, r):
    """What :func:`probe_value` needs of monitor ``r`` in this step: scalars and raw pointers.

    The root finders evaluate one monitor dozens of times. Passing them the
    tuples of arrays would bind every array again at each evaluation, and
    numba counts references on each binding (atomically); a probe holds no
    array, so an evaluation costs the arithmetic and the model call only.
    The arrays it points into (the step's coefficients and start, the
    workspace) outlive every use of the probe.
    """
    fc, coef, y_old, act = md.context, step.coef, step.y_old, step.active
    sl, W, ref = fc.sliding, fc.workspace, md.ref[r]
    pos = 0
    for a in range(sl.size):
        if sl[a] == ref:
            pos = a
    return Probe(md.kind[r], ref, md.start[r], md.length[r], md.cond_group, fc.switch_group,
                 md.n_conditions, fc.slide_group, fc.n_switches, step.method, step.t_old,
                 step.h, y_old.size, coef.shape[0], act.size, sl.size, W.size, p.size, sig.size,
                 pos, ptr(ws.x), ptr(p), ptr(sig), ptr(ws.cond), ptr(ws.switch), ptr(ws.eq),
                 ptr(W), ptr(coef), ptr(y_old), ptr(act), ptr(sl))


@counted
def _exit_value(model, pr, t):
    """A sliding exit's value ``1 - |sigma_eq|`` at the probed state (not inlined: the
    equivalent-sign solve is large, and :func:`probe_value` is inlined in every root finder).

    Reference counted (``numba.carray`` needs it), and said so explicitly
    (:data:`~.signatures.counted`): the root finders that call it are borrowing.
    """
    # arrays over the same memory without a reference count (numba.carray)
    eqv = numba.carray(pr.eq, pr.n_signs)
    equivalent_signs(model, pr.slide_group, pr.n_switches, numba.carray(pr.sliding, pr.n_sliding),
                     numba.carray(pr.active, pr.n_active), numba.carray(pr.work, pr.n_work), t,
                     numba.carray(pr.x, pr.n), numba.carray(pr.p, pr.n_params),
                     numba.carray(pr.sig, pr.n_signs), eqv)
    return 1.0 - abs(eqv[pr.position])


@numba.njit(cache=True, inline="always")
def probe_value(model, pr, t):
    """The probed monitor's value at time ``t`` of the step (the root finders' inner loop)."""
    kind, ref, start, length = pr.kind, pr.ref, pr.start, pr.length
    xs, p, sig, W = pr.x, pr.p, pr.sig, pr.work
    dense_eval_at(pr.method, pr.coef, pr.t_old, pr.h, pr.y_old, pr.active, pr.n, pr.n_coef,
                  pr.n_active, t, xs)
    if kind == SWITCH:
        sv = pr.switch
        model(OP_SWITCH, pr.switch_group, t, xs, p, sig, W, sv)
        return sig[ref] * sv[ref]
    if kind == EXIT:
        return _exit_value(model, pr, t)
    cv = pr.cond
    model(OP_COND, pr.cond_group, t, xs, p, sig, W, cv)
    if kind == INVARIANT:
        return cv[start]
    best = cv[start]
    for q in range(start + 1, start + length):
        if cv[q] < best:
            best = cv[q]
    return -best


@numba.njit(cache=True, inline="always")
def monitor_value(model, md, p, sig, ws, step, r, t):
    """One monitor's value at time ``t`` of the step (see :func:`probe`)."""
    return probe_value(model, probe(md, p, sig, ws, step, r), t)


@borrowing
def _batch(model, md, p, sig, ws, step, times, T, PHI, DPHI, n0):
    """Monitor values and slopes at ``times`` of the step into columns ``n0...``.

    This is the sampler's inner loop, so it is written out by hand with every
    array bound once before the loop: binding an array inside the loop (a
    tuple unpacked, an inlined call's parameters) costs a reference-count
    pair per point that numba cannot prune. It computes what
    :func:`monitors_at` does, along the dense output's own derivative.
    """
    method, coef, t_old, h, y_old, act = (step.method, step.coef, step.t_old, step.h,
                                          step.y_old, step.active)
    cg, mk, mref, mstart, mlen, nc = (md.cond_group, md.kind, md.ref, md.start, md.length,
                                      md.n_conditions)
    xs, xd, cv, sv, eqv = ws.x, ws.dx, ws.cond, ws.switch, ws.eq
    fc = md.context
    sg, m, pg, sl, W = (fc.switch_group, fc.n_switches, fc.slide_group, fc.sliding,
                        fc.workspace)
    n = y_old.size
    ns = sl.size
    nm = mk.size
    nco = coef.shape[0]
    pcv, psv, psig, peqv = ptr(cv), ptr(sv), ptr(sig), ptr(eqv)
    for i in range(times.size):
        t = times[i]
        T[n0 + i] = t
        # the interpolant (integrate.dense_eval) and its derivative, written out
        x = (t - t_old) / h
        for q in range(n):
            xs[q] = y_old[q]
            xd[q] = 0.0
        for a in range(act.size):
            q = act[a]
            acc = 0.0
            dacc = 0.0
            if method == RK45:
                pw = 1.0
                for j in range(nco):
                    dacc += (j + 1) * coef[j, q] * pw
                    pw *= x
                    acc += coef[j, q] * pw
                xs[q] = h * acc + y_old[q]
                xd[q] = dacc
            else:
                for k in range(nco):
                    acc += coef[nco - 1 - k, q]
                    if k % 2 == 0:
                        dacc = dacc * x + acc
                        acc *= x
                    else:
                        dacc = dacc * (1 - x) - acc
                        acc *= 1 - x
                xs[q] = acc + y_old[q]
                xd[q] = dacc / h
        if ns:
            equivalent_signs(model, pg, m, sl, act, W, t, xs, p, sig, eqv)
        if cg >= 0:
            model(OP_COND_BOTH, cg, t, ptr(xs), ptr(p), ptr(sig), ptr(xd), ptr(cv))
        if sg >= 0:
            model(OP_SWITCH_BOTH, sg, t, ptr(xs), ptr(p), ptr(sig), ptr(xd), ptr(sv))
        col = n0 + i
        for r in range(nm):
            pos = 0  # where a sliding exit's switch sits in the sliding set
            if mk[r] == EXIT:
                for a in range(ns):
                    if sl[a] == mref[r]:
                        pos = a
            PHI[r, col], DPHI[r, col] = _column(mk[r], mref[r], mstart[r], mlen[r], nc, m,
                                                pos, pcv, psv, psig, peqv)
    nt = times.size
    if nt < 2:
        return
    for r in range(mk.size):
        if mk[r] != EXIT:
            continue
        # numpy.gradient(values, times) over the batch, in batch order
        v = PHI[r, n0:n0 + nt]
        DPHI[r, n0] = (v[1] - v[0]) / (times[1] - times[0])
        DPHI[r, n0 + nt - 1] = (v[nt - 1] - v[nt - 2]) / (times[nt - 1] - times[nt - 2])
        for i in range(1, nt - 1):
            dx1 = times[i] - times[i - 1]
            dx2 = times[i + 1] - times[i]
            a = -dx2 / (dx1 * (dx1 + dx2))
            b = (dx2 - dx1) / (dx1 * dx2)
            c = dx1 / (dx2 * (dx1 + dx2))
            DPHI[r, n0 + i] = a * v[i - 1] + b * v[i] + c * v[i + 1]


@numba.njit(cache=True)
def sample_workspace(m_max, capacity):
    """A :class:`~.layout.SampleWorkspace` for ``capacity`` samples per step and at most
    ``m_max`` monitors in a mode."""
    c = capacity
    m = max(m_max, 1)
    return SampleWorkspace(
        np.empty(c), np.empty((m, c)), np.empty((m, c)), np.empty(c),
        np.empty(c, dtype=np.int64), np.empty(c, dtype=np.int64), np.empty(c, dtype=np.int64),
        np.empty(c, dtype=np.int64), np.empty(c), np.zeros(c, dtype=np.bool_),
        np.empty(c, dtype=np.int64), np.empty(c), np.empty(m * c), np.empty(m * c),
        np.empty(m, dtype=np.int64), np.empty(m), np.zeros(m, dtype=np.bool_), np.empty(m),
        np.zeros(m, dtype=np.bool_), np.empty(m, dtype=np.int64), np.zeros(m, dtype=np.bool_),
        np.empty(c), np.empty(c), np.empty(c), np.empty(c), np.empty(c),
        np.empty(c, dtype=np.int64))


@borrowing
def _stable_order(keys, n, order):
    """The permutation that sorts ``keys[:n]``, into ``order[:n]``: stable, so equal keys
    keep their order, as numpy's mergesort (by insertion: the samples come nearly sorted)."""
    for i in range(n):
        j = i
        while j > 0 and keys[order[j - 1]] > keys[i]:
            order[j] = order[j - 1]
            j -= 1
        order[j] = i


@numba.njit(cache=True)
def _sgn(v):
    return 0.0 if v == 0 else (1.0 if v > 0 else (-1.0 if v < 0 else v))


@borrowing
def sample_step(model, md, p, sig, ws, sw, step, t0, t1, samples, max_refine, tol):
    """Samples of every monitor on ``[t0, t1]``, refined until resolved (see location.py).

    Returns ``(k, refinements)``: the ``k`` samples sorted by time, without repeats, are in
    ``sw.sorted_times[:k]`` and, read as ``(monitors, k)``, ``sw.sorted_values`` and
    ``sw.sorted_slopes``; ``k`` is :data:`OUTGROWN` where they would not fit in ``sw``.
    """
    M = md.kind.size
    cap = sw.times.size
    if samples + 1 > cap:
        return OUTGROWN, 0
    T, PHI, DPHI = sw.times, sw.values, sw.slopes
    grid = sw.grid[:samples + 1]
    delta = (t1 - t0) / samples
    for i in range(samples + 1):
        grid[i] = i * delta + t0
    grid[samples] = t1
    _batch(model, md, p, sig, ws, step, grid, T, PHI, DPHI, 0)
    nk = samples + 1
    a_idx, b_idx = sw.left[:samples], sw.right[:samples]
    for k in range(samples):
        a_idx[k], b_idx[k] = k, k + 1
    ahead = False  # the next level's ends are in next_left/next_right
    refinements = 0
    q = CHECK_AT
    for level in range(max_refine + 1):
        K = a_idx.size
        if M == 0 or K == 0:
            break
        if nk + K > cap:
            return OUTGROWN, 0
        c_t = sw.middle[:K]
        for k in range(K):
            c_t[k] = T[a_idx[k]] + q * (T[b_idx[k]] - T[a_idx[k]])
        _batch(model, md, p, sig, ws, step, c_t, T, PHI, DPHI, nk)
        c0 = nk
        nk += K
        if level == max_refine:
            break
        split = sw.split[:K]
        for k in range(K):  # (element loops: a slice assignment needs numba's runtime)
            split[k] = False
        for k in range(K):
            a, b, c = a_idx[k], b_idx[k], c0 + k
            h = T[b] - T[a]
            for r in range(M):
                fa, fb, da, db = PHI[r, a], PHI[r, b], DPHI[r, a], DPHI[r, b]
                k1 = h * da
                k2 = 3.0 * (fb - fa) - h * (2.0 * da + db)
                k3 = 2.0 * (fa - fb) + h * (da + db)
                predicted = fa + q * (k1 + q * (k2 + q * k3))
                slope = (k1 + q * (2.0 * k2 + 3.0 * q * k3)) / (h if h > 0 else 1.0)
                fc, dc = PHI[r, c], DPHI[r, c]
                err = max(abs(fc - predicted), 0.25 * h * abs(dc - slope))
                scale = max(abs(fa), abs(fc), abs(fb))
                lo = min(abs(fa), abs(fc), abs(fb))
                change = _sgn(fa) != _sgn(fc) or _sgn(fc) != _sgn(fb)
                near = lo <= 4.0 * err + tol or change
                if err > 0.05 * scale + tol and near:
                    split[k] = True
                    break
        ns = 0
        for k in range(K):
            if split[k]:
                ns += 1
        if ns == 0:
            break
        refinements += ns
        if 2 * ns > cap:
            return OUTGROWN, 0
        if ahead:
            na, nb = sw.left[:2 * ns], sw.right[:2 * ns]
        else:
            na, nb = sw.next_left[:2 * ns], sw.next_right[:2 * ns]
        ahead = not ahead
        i = 0
        for k in range(K):
            if split[k]:
                na[i] = a_idx[k]
                nb[i] = c0 + k
                na[ns + i] = c0 + k
                nb[ns + i] = b_idx[k]
                i += 1
        a_idx, b_idx = na, nb
    order = sw.order
    _stable_order(T, nk, order)
    k = 1 if nk > 0 else 0
    for i in range(1, nk):  # equal times: the first in this order is kept
        if T[order[i]] != T[order[i - 1]]:
            k += 1
    t_out = sw.sorted_times
    v_out = sw.sorted_values[:M * k].reshape((M, k))
    d_out = sw.sorted_slopes[:M * k].reshape((M, k))
    c = 0
    for i in range(nk):
        if i > 0 and T[order[i]] == T[order[i - 1]]:
            continue
        j = order[i]
        t_out[c] = T[j]
        for r in range(M):
            v_out[r, c] = PHI[r, j]
            d_out[r, c] = DPHI[r, j]
        c += 1
    return k, refinements


@numba.njit(cache=True, inline="always")
def _cubic(h, fa, fb, da, db):
    """The cubic ``fa + c1 s + c2 s^2 + c3 s^3`` through the ends' values and slopes on
    ``s`` in [0, 1], and the roots ``r1, r2`` of its derivative (``nan`` where there is
    none), by the cancellation-free form of the quadratic formula (location.py)."""
    c1 = h * da
    c2 = 3.0 * (fb - fa) - h * (2.0 * da + db)
    c3 = 2.0 * (fa - fb) + h * (da + db)
    a, b, c = 3.0 * c3, 2.0 * c2, c1
    disc = b * b - 4.0 * a * c
    sq = math.sqrt(disc) if disc >= 0 else np.nan
    qq = -0.5 * (b + (1.0 if b >= 0 else -1.0) * sq)
    r1 = qq / a if a != 0 else np.nan
    if qq != 0:
        r2 = c / qq
    elif b != 0:
        r2 = -c / b
    else:
        r2 = np.nan
    return c1, c2, c3, r1, r2


@numba.njit(cache=True)
def _extremes(h, fa, fb, da, db):
    """Minimum and maximum of the cubic Hermite interpolant on [0, 1] (location.py)."""
    c0 = fa
    c1, c2, c3, r1, r2 = _cubic(h, fa, fb, da, db)
    # candidates s = 0, 1, r1, r2 (scalars: this runs for every monitor and interval)
    v_min = v_max = c0
    s_min = s_max = 0.0
    for i in range(1, 4):
        if i == 1:
            si = 1.0
        elif i == 2:
            si = r1 if (np.isfinite(r1) and 0 < r1 < 1) else 0.0
        else:
            si = r2 if (np.isfinite(r2) and 0 < r2 < 1) else 0.0
        v = c0 + si * (c1 + si * (c2 + si * c3))
        if v < v_min:
            v_min, s_min = v, si
        if v > v_max:
            v_max, s_max = v, si
    return v_min, s_min, v_max, s_max


@numba.njit(cache=True)
def _minimum_until(h, fa, fb, da, db, s_end):
    """``hermite_minimum_until`` of location.py: the cubic's minimum on ``[0, s_end]``."""
    c1, c2, c3, r1, r2 = _cubic(h, fa, fb, da, db)
    best = fa
    for i in range(3):
        si = s_end if i == 0 else (r1 if i == 1 else r2)
        if np.isfinite(si) and 0 < si <= s_end:
            best = min(best, fa + si * (c1 + si * (c2 + si * c3)))
    return best


@numba.njit(cache=True, inline="always")
def _above(h, fa, fb, da, db, tol):
    """Whether the cubic of :func:`_extremes` stays above ``tol`` on the whole interval.

    Its Bernstein control points are ``fa, fa + h da / 3, fb - h db / 3, fb``
    and the cubic lies in their convex hull; the margin covers the rounding
    of :func:`_extremes`, so this never skips an interval whose computed
    minimum would reach ``tol``. Most monitors are far from zero in most
    steps, and this spares them the cubic's roots.
    """
    b1 = fa + h * da / 3.0
    b2 = fb - h * db / 3.0
    margin = 16.0 * _EPS * (abs(fa) + abs(fb) + abs(h * da) + abs(h * db))
    return min(fa, fb, b1, b2) - margin > tol


@borrowing
def _brentq(model, md, p, sig, ws, step, r, level, xa, xb, xtol, rtol, maxiter):
    pr = probe(md, p, sig, ws, step, r)
    xpre, xcur = xa, xb
    xblk, fblk, spre, scur = 0.0, 0.0, 0.0, 0.0
    fpre = probe_value(model, pr, xpre) - level
    fcur = probe_value(model, pr, xcur) - level
    if fpre == 0:
        return xpre
    if fcur == 0:
        return xcur
    for _ in range(maxiter):
        if fpre != 0 and fcur != 0 and (fpre < 0) != (fcur < 0):
            xblk, fblk = xpre, fpre
            spre = scur = xcur - xpre
        if abs(fblk) < abs(fcur):
            xpre, xcur, xblk = xcur, xblk, xcur
            fpre, fcur, fblk = fcur, fblk, fcur
        delta = (xtol + rtol * abs(xcur)) / 2
        sbis = (xblk - xcur) / 2
        if fcur == 0 or abs(sbis) < delta:
            return xcur
        if abs(spre) > delta and abs(fcur) < abs(fpre):
            if xpre == xblk:
                stry = -fcur * (xcur - xpre) / (fcur - fpre)
            else:
                dpre = (fpre - fcur) / (xpre - xcur)
                dblk = (fblk - fcur) / (xblk - xcur)
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
            if 2 * abs(stry) < min(abs(spre), 3 * abs(sbis) - delta):
                spre, scur = scur, stry
            else:
                spre, scur = sbis, sbis
        else:
            spre, scur = sbis, sbis
        xpre, fpre = xcur, fcur
        if abs(scur) > delta:
            xcur += scur
        else:
            xcur += delta if sbis > 0 else -delta
        fcur = probe_value(model, pr, xcur) - level
    return xcur


@borrowing
def _locate(model, md, p, sig, ws, step, r, level, lo, hi, f_hi, xtol):
    """``locate_crossing``: the first time within ``xtol`` at which the monitor holds."""
    pr = probe(md, p, sig, ws, step, r)
    if f_hi == 0.0 or hi - lo <= xtol:
        return hi
    root = _brentq(model, md, p, sig, ws, step, r, level, lo, hi, LOCATE_STEP * xtol, 4 * _EPS,
                   LOCATE_ITERATIONS)
    for j in range(3):
        cand = root + j * LOCATE_STEP * xtol
        if cand >= hi:
            return hi
        if probe_value(model, pr, cand) - level <= 0:
            return cand
    lo2 = max(lo, root - 2 * LOCATE_STEP * xtol)
    if probe_value(model, pr, lo2) - level > 0:
        lo = lo2
    for _ in range(LOCATE_ITERATIONS):
        if hi - lo <= xtol:
            break
        mid = 0.5 * (lo + hi)
        if probe_value(model, pr, mid) - level > 0:
            lo = mid
        else:
            hi = mid
    return hi


@borrowing
def _fminbound(model, md, p, sig, ws, step, r, level, x1, x2, xatol):
    """scipy's bounded Brent minimiser (``minimize_scalar(method="bounded")``)."""
    pr = probe(md, p, sig, ws, step, r)
    sqrt_eps = math.sqrt(2.2e-16)
    golden_mean = 0.5 * (3.0 - math.sqrt(5.0))
    a, b = x1, x2
    fulc = a + golden_mean * (b - a)
    nfc, xf = fulc, fulc
    rat = e = 0.0
    x = xf
    fx = probe_value(model, pr, x) - level
    num = 1
    ffulc = fnfc = fx
    xm = 0.5 * (a + b)
    tol1 = sqrt_eps * abs(xf) + xatol / 3.0
    tol2 = 2.0 * tol1
    while abs(xf - xm) > (tol2 - 0.5 * (b - a)):
        golden = True
        if abs(e) > tol1:
            golden = False
            rr = (xf - nfc) * (fx - ffulc)
            qq = (xf - fulc) * (fx - fnfc)
            pp = (xf - fulc) * qq - (xf - nfc) * rr
            qq = 2.0 * (qq - rr)
            if qq > 0.0:
                pp = -pp
            qq = abs(qq)
            rr = e
            e = rat
            if abs(pp) < abs(0.5 * qq * rr) and pp > qq * (a - xf) and pp < qq * (b - xf):
                rat = (pp + 0.0) / qq
                x = xf + rat
                if (x - a) < tol2 or (b - x) < tol2:
                    si = _sgn(xm - xf) + (1.0 if xm - xf == 0 else 0.0)
                    rat = tol1 * si
            else:
                golden = True
        if golden:
            e = a - xf if xf >= xm else b - xf
            rat = golden_mean * e
        si = _sgn(rat) + (1.0 if rat == 0 else 0.0)
        x = xf + si * max(abs(rat), tol1)
        fu = probe_value(model, pr, x) - level
        num += 1
        if fu <= fx:
            if x >= xf:
                a = xf
            else:
                b = xf
            fulc, ffulc = nfc, fnfc
            nfc, fnfc = xf, fx
            xf, fx = x, fu
        else:
            if x < xf:
                a = x
            else:
                b = x
            if fu <= fnfc or nfc == xf:
                fulc, ffulc = nfc, fnfc
                nfc, fnfc = x, fu
            elif fu <= ffulc or fulc == xf or fulc == nfc:
                fulc, ffulc = x, fu
        xm = 0.5 * (a + b)
        tol1 = sqrt_eps * abs(xf) + xatol / 3.0
        tol2 = 2.0 * tol1
        if num >= 500:
            break
    return xf, fx


@borrowing
def _search(model, md, p, sig, ws, step, r, cand, tau, phi, lo_val, lo_s, t_from, level,
            xtol, tol):
    """First time the monitor reaches ``level`` in the candidate intervals (location.py)."""
    pr = probe(md, p, sig, ws, step, r)
    for k in cand:
        a = max(tau[k], t_from)
        b = tau[k + 1]
        if a != tau[k]:
            f_a = probe_value(model, pr, a) - level
        else:
            f_a = phi[k] - level
        f_b = phi[k + 1] - level
        if f_a <= 0:
            return True, a, True
        if f_b <= 0 and not (0.0 < lo_s[k] < 1.0 and lo_val[k] < phi[k + 1]):
            t_min, f_min = b, f_b
        else:
            xatol = max(xtol, MINIMUM_WIDTH * max(abs(a), abs(b), 1.0))
            t_min, f_min = _fminbound(model, md, p, sig, ws, step, r, level, a, b, xatol)
            guess = a + lo_s[k] * (b - a)
            f_guess = probe_value(model, pr, guess) - level
            if f_guess < f_min:
                t_min, f_min = guess, f_guess
            if f_b <= 0 and f_b < f_min:
                t_min, f_min = b, f_b
        if f_min <= 0:
            t_hit = _locate(model, md, p, sig, ws, step, r, level, a, t_min, f_min, xtol)
            return True, t_hit, (f_min >= -tol and f_b > tol)
        if f_min <= tol:
            return True, t_min, True
    return False, 0.0, False


@borrowing
def _first_trigger(model, md, p, sig, ws, sw, step, r, tau, phi, dphi, armed, xtol, tol,
                   has_floor, floor, t_event, width):
    """``first_trigger`` of location.py: ``(found, t, grazing, armed_after)``; ``t_event`` is
    the event located so far in the step (``inf``: none), ``width`` the cluster width."""
    pr = probe(md, p, sig, ws, step, r)
    K = tau.size - 1
    lo_val, lo_s, hi_val, hi_s = sw.low[:K], sw.low_at[:K], sw.high[:K], sw.high_at[:K]
    lower = sw.lower[:K]
    # a disarmed monitor re-arms at the latest in the first interval that ends above tol; the
    # intervals after it are searched like an armed monitor's
    searched = armed
    for k in range(K):
        h = tau[k + 1] - tau[k]
        if searched and _above(h, phi[k], phi[k + 1], dphi[k], dphi[k + 1], tol):
            # no candidate here (see _above): the extrema are never read
            lo_val[k], lo_s[k], hi_val[k], hi_s[k] = phi[k], 0.0, phi[k], 0.0
        else:
            lo_val[k], lo_s[k], hi_val[k], hi_s[k] = _extremes(h, phi[k], phi[k + 1], dphi[k],
                                                               dphi[k + 1])
        lower[k] = min(phi[k], phi[k + 1], lo_val[k])
        if max(phi[k], phi[k + 1]) > tol:
            searched = True
    start = 0
    t_from = tau[0]
    if not armed:
        # where it re-arms: the first instant it is above tol (an interval whose cubic
        # promises more than the function gives does not re-arm it)
        rearmed = False
        start = K
        for k in range(K):
            if max(phi[k], phi[k + 1], hi_val[k]) <= tol:
                continue
            peak = tau[k] + hi_s[k] * (tau[k + 1] - tau[k])
            if phi[k] > tol:
                t_from, start = tau[k], k
            elif (hi_val[k] > tol and hi_s[k] < 1.0
                  and probe_value(model, pr, peak) > tol):
                t_from, start = peak, k
            elif phi[k + 1] > tol:
                t_from, start = tau[k + 1], k + 1
            else:
                continue
            rearmed = True
            break
        if has_floor:  # before it re-arms, sinking below the floor fires it
            n = 0
            cand = sw.candidates
            for k in range(start):
                if lower[k] <= floor:
                    cand[n] = k
                    n += 1
            if rearmed and start < K and t_from > tau[start]:
                k = start  # re-armed inside this interval: only the part before counts
                h = tau[k + 1] - tau[k]
                if _minimum_until(h, phi[k], phi[k + 1], dphi[k], dphi[k + 1],
                                  (t_from - tau[k]) / h) <= floor:
                    cand[n] = k
                    n += 1
            found, t_hit, graz = _search(model, md, p, sig, ws, step, r, cand[:n], tau, phi,
                                         lo_val, lo_s, tau[0], floor, xtol, 0.0)
            if found and (not rearmed or t_hit <= t_from):
                return True, t_hit, graz, False
        if not rearmed:
            return False, 0.0, False, False
        if start >= K:
            return False, 0.0, False, phi[K] > tol
        if (np.isfinite(t_event) and t_from <= t_event - width
                and probe_value(model, pr, t_event) <= 0 < probe_value(model, pr, t_event - width)):
            return True, t_event, False, True
    n = 0
    cand = sw.candidates
    for k in range(start, K):
        if lower[k] <= tol:
            cand[n] = k
            n += 1
    found, t_hit, graz = _search(model, md, p, sig, ws, step, r, cand[:n], tau, phi, lo_val,
                                 lo_s, t_from, 0.0, xtol, tol)
    return found, t_hit, graz, True


@borrowing
def scan(model, md, p, sig, ws, sw, step, armed, has_floor, floors, t0, t1, samples,
         max_refine, event_tol, tol, stats):
    """``_Run.scan``: the earliest cluster of monitors reaching zero in ``[t0, t1]``.

    Returns ``n``, the number of monitors that fire (0: none), whose rows, times and
    grazing flags are ``sw.rows[:n]``, ``sw.at[:n]`` and ``sw.grazing[:n]``; whether each
    monitor is armed after the step is in ``sw.armed``. :data:`OUTGROWN` (nothing else
    changed): the step's samples need a larger workspace.
    """
    M = armed.size
    if M == 0:
        return 0
    new_armed, rows, times, graz = sw.armed[:M], sw.rows[:M], sw.at[:M], sw.grazing[:M]
    k, refinements = sample_step(model, md, p, sig, ws, sw, step, t0, t1, samples,
                                 max_refine, tol)
    if k == OUTGROWN:
        return OUTGROWN
    tau = sw.sorted_times[:k]
    phi = sw.sorted_values[:M * k].reshape((M, k))
    dphi = sw.sorted_slopes[:M * k].reshape((M, k))
    for r in range(M):  # (element loops: a slice assignment needs numba's runtime)
        new_armed[r] = armed[r]
        graz[r] = False
    stats[1] += refinements
    xtol = xtol_at(event_tol, min(abs(t0), abs(t1)))
    width = CLUSTER_WIDTH * xtol
    K = tau.size - 1
    starts, use = sw.starts[:M], sw.searched[:M]
    for r in range(M):
        starts[r] = np.inf
        use[r] = False
    for r in range(M):
        first = -1
        sinking = False
        rising = False
        for k in range(K):
            h = tau[k + 1] - tau[k]
            if armed[r] and _above(h, phi[r, k], phi[r, k + 1], dphi[r, k], dphi[r, k + 1], tol):
                continue  # the cubic cannot come down to tol here: no candidate
            if not armed[r] and max(phi[r, k], phi[r, k + 1]) > tol:
                rising = True  # the monitor re-arms in this step: it is examined
                break
            lv, _, hv, _ = _extremes(h, phi[r, k], phi[r, k + 1], dphi[r, k], dphi[r, k + 1])
            lower = min(phi[r, k], phi[r, k + 1], lv)
            upper = max(phi[r, k], phi[r, k + 1], hv)
            if armed[r]:
                if lower <= tol:
                    first = k
                    break
            else:
                if has_floor[r] and lower <= floors[r]:
                    sinking = True
                if upper > tol:
                    rising = True
                if sinking or rising:
                    break  # either makes the monitor examined: no need to look further
        if armed[r]:
            if first >= 0:
                starts[r] = tau[first]
                use[r] = True
        elif sinking or rising:
            starts[r] = t0
            use[r] = True
    order = sw.rank
    _stable_order(starts, M, order)
    n = 0
    earliest = np.inf
    for oi in range(M):
        r = order[oi]
        if not use[r]:
            continue
        if starts[r] > earliest + width:
            new_armed[r] = armed[r]
            continue
        if np.isfinite(earliest) and armed[r]:
            at = monitor_value(model, md, p, sig, ws, step, r, earliest)
            before = monitor_value(model, md, p, sig, ws, step, r, earliest - width)
            if at <= 0 < before:
                rows[n], times[n], graz[n] = r, earliest, False
                n += 1
                continue
        found, t_hit, g, arm = _first_trigger(model, md, p, sig, ws, sw, step, r, tau, phi[r],
                                              dphi[r], armed[r], xtol, tol, has_floor[r],
                                              floors[r], earliest, width)
        new_armed[r] = arm
        if found:
            rows[n], times[n], graz[n] = r, t_hit, g
            n += 1
            earliest = min(earliest, t_hit)
    if n == 0:
        return 0
    m = 0
    for i in range(n):
        if times[i] <= earliest + width:
            rows[m], times[m], graz[m] = rows[i], times[i], graz[i]
            m += 1
    stats[2] += m
    return m
