"""The compiled run loop: flow, event location and the common jump logic in numba.

``run_kernel`` mirrors ``_Run.run`` of the reference engine (same order of
operations, same tolerances): integrate a mode step by step, scan the
monitors on each step's dense output, and at an event apply the event
iteration (priorities, resets, the no-immediate-retrigger and
boundary-leaving rules, schedules, Zeno tracking). Whatever it does not
handle (Filippov sliding, several switching surfaces at once, invariant
violations, zero-dwell cycles, failed steps, non-finite resets) makes it
return :data:`HANDOFF`; the caller then runs the reference engine, so the
two backends never differ in semantics.

Records grow by doubling: events ``EV`` (t, j, transition, source, target,
kind, grazing, pre..., post...), stored points ``PT`` (t, y...), steps
``ST`` (t_old, h, y_old..., coefficients...) and segments ``SG`` (mode, j,
first point, points, first step, steps).
"""

# ruff: noqa: SIM102 - kept line by line with the scipy / reference code it ports

from __future__ import annotations

import math

import numba
import numpy as np

from hybridlab.simulation.compiled.integrate import (
    N_COEF,
    N_K,
    dense_coefficients,
    dense_eval,
    initial_step,
    ptr,
    rk_step,
)
from hybridlab.simulation.compiled.locate import GUARD, INVARIANT, monitors_at, scan

__all__ = ["run_kernel", "COMPLETED", "ZENO", "MAX_EVENTS", "HANDOFF"]

COMPLETED, ZENO, MAX_EVENTS, HANDOFF = 0, 1, 2, 3
OP_FLOW, OP_SWITCH, OP_SWITCH_LIE, OP_RESET, OP_GUARD, OP_GUARD_LIE = 0, 3, 4, 5, 6, 7


@numba.njit(cache=True)
def _grow(a, n):
    if n < a.shape[0]:
        return a
    b = np.empty((2 * a.shape[0], a.shape[1]), dtype=a.dtype)
    b[:a.shape[0]] = a
    return b


@numba.njit(cache=True)
def _xtol(event_tol, t):
    return event_tol * max(1.0, abs(t))


@numba.njit(cache=True)
def _sched_index(period, phase, done, t):
    k = math.ceil((t - phase) / period - 1e-9)
    return max(k, done + 1, 0)


@numba.njit(cache=True)
def _zeno_record(ztimes, zcount, key, t, window, tol, resolution):
    """ZenoTracker.record; returns ``(zeno, ratio, accumulation_time)``."""
    w1 = window + 1
    c = zcount[key]
    if c >= w1:
        for i in range(w1 - 1):
            ztimes[key, i] = ztimes[key, i + 1]
        ztimes[key, w1 - 1] = t
    else:
        ztimes[key, c] = t
    zcount[key] = c + 1
    if c + 1 < w1:
        return False, 0.0, 0.0
    dwell = np.empty(window)
    for i in range(window):
        dwell[i] = ztimes[key, i + 1] - ztimes[key, i]
        if dwell[i] <= 0:
            return False, 0.0, 0.0
    ratios = dwell[1:] / dwell[:-1]
    if not (np.all(ratios < 1.0) and ratios.max() <= 1.5 * ratios.min()):
        return False, 0.0, 0.0
    r = np.mean(ratios[-3:])
    remaining = dwell[-1] * r / (1.0 - r)
    scale = max(1.0, abs(t))
    if remaining <= tol * scale or dwell[-1] <= resolution * scale:
        return True, r, t + remaining
    return False, 0.0, 0.0


@numba.njit(cache=True)
def _sdot(model, sg, t, x, p, sig, f, sv, sd, dummy, fg, k):
    model(OP_FLOW, fg, t, ptr(x), ptr(p), ptr(sig), ptr(dummy), ptr(f))
    model(OP_SWITCH_LIE, sg, t, ptr(x), ptr(p), ptr(sig), ptr(f), ptr(sd))
    return sd[k]


@numba.njit(cache=True)
def _resolve_one(model, fg, sg, affine, t, x, p, sig, k, f, sv, sd, dummy):
    """resolve_switches for one switch on its surface; False: it slides (hand off)."""
    previous = sig[k]
    sig[k] = 1.0
    d_plus = _sdot(model, sg, t, x, p, sig, f, sv, sd, dummy, fg, k)
    sig[k] = -1.0
    d_minus = _sdot(model, sg, t, x, p, sig, f, sv, sd, dummy, fg, k)
    sig[k] = previous
    leave = abs(d_plus - d_minus) <= 1e-14 * (abs(d_plus) + abs(d_minus))
    if not leave:
        if not affine:
            return False
        sig[k] = 0.0
        b = _sdot(model, sg, t, x, p, sig, f, sv, sd, dummy, fg, k)
        a = 0.5 * (d_plus - d_minus)
        eq = -b / a
        if abs(eq) > 1 + 1e-12:
            sig[k] = 1.0 if eq > 0 else -1.0
            return True
        if d_plus <= 0 <= d_minus and d_minus > d_plus:
            sig[k] = previous
            return False
    if d_plus > 0 and d_minus > 0:
        sig[k] = 1.0
    elif d_plus < 0 and d_minus < 0:
        sig[k] = -1.0
    else:
        sig[k] = 1.0 if previous >= 0 else -1.0
    return True


@numba.njit(cache=True)
def run_kernel(model, ints, reals, opts_i, opts_f, t, x, m, t_end, p, n_sig, ztimes, zcount,
               sched_done):
    """Run from ``(t, x, m)`` to ``t_end``; see the module docstring for the records.

    ``ints``: per mode flow/cond/switch group, invariant offset, invariants, switches,
    affine flag, outgoing pointer; the outgoing list; per transition target, guard
    group, monitored (0/1), scheduled (0/1), schedule enabled (0/1), reset group;
    per mode the first Zeno key of its switches. ``reals``: per transition period,
    phase. Returns the records and the final run state.
    """
    (fgs, cgs, sgs, inv_off, n_inv, n_sw, affine, out_ptr, out_list, tr_target, tr_guard,
     tr_monitored, tr_sched, tr_sched_on, tr_reset, sw_key, n_cond) = ints
    period, phase = reals
    method, samples, max_refine, max_events, max_iter, window = (
        opts_i[0], opts_i[1], opts_i[2], opts_i[3], opts_i[4], opts_i[5])
    rtol, atol, max_step, event_tol, event_atol, zeno_tol = (
        opts_f[0], opts_f[1], opts_f[2], opts_f[3], opts_f[4], opts_f[5])
    n = x.size
    n_tr = tr_target.size
    nk, nc = N_K[method], N_COEF[method]
    order_err = 4 if method == 0 else 7
    x = x.copy()
    sig = np.ones(max(n_sig, 1))
    dummy = np.zeros(max(n, 1))
    ws = (np.empty(n), np.empty(n), np.empty(max(np.max(n_cond), 1)),
          np.empty(max(np.max(n_cond), 1)), np.empty(max(n_sig, 1)), np.empty(max(n_sig, 1)),
          dummy)
    gv = np.empty(max(np.max(tr_monitored[n_tr:]) if n_tr else 1, 1))
    gd = np.empty(gv.size)
    mk = np.empty(0, dtype=np.int64)
    mref = np.empty(0, dtype=np.int64)
    mstart = np.empty(0, dtype=np.int64)
    hit_rows = np.empty(0, dtype=np.int64)
    hit_graz = np.zeros(0, dtype=np.bool_)
    hit_n = 0
    w_sw = max(n_sig, 1)
    EV = np.empty((64, 7 + 2 * n))
    PT = np.empty((256, 1 + n))
    ST = np.empty((256, 2 + n + nc * n))
    SG = np.empty((64, 6), dtype=np.int64)
    nev, npt, nst, nsg = 0, 0, 0, 0
    stats = np.zeros(4, dtype=np.int64)  # steps, refinements, events_located, segments
    info = np.zeros(4)
    j = 0
    h_last = -1.0
    K = np.empty((nk, n))
    coef = np.empty((nc, n))
    y_new = np.empty(n)
    f_new = np.empty(n)
    fcur = np.empty(n)
    tmp = np.empty(n)
    fired = np.zeros(max(n_tr, 1), dtype=np.bool_)
    fresh = np.zeros(max(n_tr, 1), dtype=np.bool_)
    grazing = np.zeros(max(n_tr, 1), dtype=np.bool_)
    code = COMPLETED
    last_t, last_x, last_m = t, x.copy(), m
    phase_ = 0  # 0: entry iteration, 1: main loop
    while True:
        # ---------------------------------------------------------------- event iteration
        if phase_ == 0 or phase_ == 2:
            if phase_ == 0:
                # enter_mode at the start
                ns = n_sw[m]
                if ns > 0:
                    for k in range(ns):
                        sig[k] = 1.0
                    model(OP_SWITCH, sgs[m], t, ptr(x), ptr(p), ptr(sig), ptr(dummy),
                          ptr(ws[4]))
                    tiny = -1
                    for k in range(ns):
                        if abs(ws[4][k]) <= event_atol:
                            if tiny >= 0:
                                code = HANDOFF
                                break
                            tiny = k
                        sig[k] = 1.0 if ws[4][k] >= 0 else -1.0
                    if code == HANDOFF:
                        break
                    if tiny >= 0 and not _resolve_one(model, fgs[m], sgs[m], affine[m], t, x,
                                                      p, sig, tiny, ws[1], ws[4], ws[5],
                                                      dummy):
                        code = HANDOFF
                        break
                fresh[:] = False
                grazing[:] = False
            # event_iteration(mode, t, x, fresh, grazing)
            fired[:] = False
            previous = -1
            settled = False
            stop = False
            for _ in range(max_iter):
                chosen = -1
                for oi in range(out_ptr[m], out_ptr[m + 1]):
                    tr = out_list[oi]
                    xt = _xtol(event_tol, t)
                    if tr_sched[tr] == 1:
                        if tr_sched_on[tr] == 0:
                            continue
                        kk = _sched_index(period[tr], phase[tr], sched_done[tr], t)
                        if abs(phase[tr] + kk * period[tr] - t) > 2 * xt:
                            continue
                        if tr_guard[tr] < 0:
                            chosen = tr
                            break
                    elif fresh[tr]:
                        chosen = tr
                        break
                    elif tr == previous:
                        continue
                    if tr_guard[tr] < 0:
                        code = HANDOFF
                        stop = True
                        break
                    # guard_state: G = min g_i and its slope
                    model(OP_FLOW, fgs[m], t, ptr(x), ptr(p), ptr(sig), ptr(dummy), ptr(fcur))
                    model(OP_GUARD, tr_guard[tr], t, ptr(x), ptr(p), ptr(sig), ptr(dummy),
                          ptr(gv))
                    model(OP_GUARD_LIE, tr_guard[tr], t, ptr(x), ptr(p), ptr(sig), ptr(fcur),
                          ptr(gd))
                    value, slope = gv[0], gd[0]
                    for q in range(1, tr_monitored[n_tr + tr]):
                        if gv[q] < value:
                            value, slope = gv[q], gd[q]
                    if tr_sched[tr] == 1:
                        if value >= 0:
                            chosen = tr
                            break
                        continue
                    band = 8 * xt * abs(slope) + event_atol
                    if value < -band:
                        continue
                    if not (value <= band and slope < 0):
                        chosen = tr
                        break
                if stop:
                    break
                if chosen < 0:
                    settled = True
                    break
                tmp[:] = x
                model(OP_RESET, tr_reset[chosen], t, ptr(tmp), ptr(p), ptr(sig), ptr(dummy),
                      ptr(y_new))
                for i in range(n):
                    if not np.isfinite(y_new[i]):
                        code = HANDOFF
                        stop = True
                if stop:
                    break
                j += 1
                target = tr_target[chosen]
                EV = _grow(EV, nev)
                EV[nev, 0] = t
                EV[nev, 1] = j
                EV[nev, 2] = chosen
                EV[nev, 3] = m
                EV[nev, 4] = target
                EV[nev, 5] = 0
                EV[nev, 6] = 1.0 if grazing[chosen] else 0.0
                EV[nev, 7:7 + n] = tmp
                EV[nev, 7 + n:7 + 2 * n] = y_new
                nev += 1
                x[:] = y_new
                if nev >= max_events:
                    code = MAX_EVENTS
                    stop = True
                    break
                fired[chosen] = True
                previous = chosen
                if tr_sched[chosen] == 1:
                    sched_done[chosen] = _sched_index(period[chosen], phase[chosen],
                                                      sched_done[chosen], t)
                else:
                    zeno, ratio, acc = _zeno_record(ztimes, zcount, chosen, t, window,
                                                    zeno_tol, 4 * event_tol)
                    if zeno:
                        last_t, last_m = t, target
                        last_x[:] = x
                        info[0], info[1], info[2], info[3] = chosen, zcount[chosen], ratio, acc
                        code = ZENO
                        stop = True
                        break
                m = target
                # enter_mode
                ns = n_sw[m]
                if ns > 0:
                    for k in range(ns):
                        sig[k] = 1.0
                    model(OP_SWITCH, sgs[m], t, ptr(x), ptr(p), ptr(sig), ptr(dummy),
                          ptr(ws[4]))
                    tiny = -1
                    for k in range(ns):
                        if abs(ws[4][k]) <= event_atol:
                            if tiny >= 0:
                                code = HANDOFF
                                stop = True
                            tiny = k
                        sig[k] = 1.0 if ws[4][k] >= 0 else -1.0
                    if stop:
                        break
                    if tiny >= 0 and not _resolve_one(model, fgs[m], sgs[m], affine[m], t, x,
                                                      p, sig, tiny, ws[1], ws[4], ws[5],
                                                      dummy):
                        code = HANDOFF
                        stop = True
                        break
                fresh[:] = False
            if stop:
                break
            if not settled:
                code = HANDOFF  # a zero-dwell cycle: the reference reports it
                break
            for oi in range(out_ptr[m], out_ptr[m + 1]):
                tr = out_list[oi]
                if tr_sched[tr] == 1 and tr_sched_on[tr] == 1 and not fired[tr]:
                    kk = _sched_index(period[tr], phase[tr], sched_done[tr], t)
                    if abs(phase[tr] + kk * period[tr] - t) <= 2 * _xtol(event_tol, t):
                        sched_done[tr] = kk
            last_t, last_m = t, m
            last_x[:] = x
            if phase_ == 2:
                # the invariant rows hit by this event, when no jump fired
                if not np.any(fired):
                    for r in range(hit_n):
                        if mk[hit_rows[r]] == INVARIANT:
                            model(OP_FLOW, fgs[m], t, ptr(x), ptr(p), ptr(sig), ptr(dummy),
                                  ptr(fcur))
                            row = mstart[hit_rows[r]]
                            model(1, cgs[m], t, ptr(x), ptr(p), ptr(sig), ptr(dummy),
                                  ptr(ws[2]))
                            model(2, cgs[m], t, ptr(x), ptr(p), ptr(sig), ptr(fcur),
                                  ptr(ws[3]))
                            if not (ws[3][row] >= 0 and ws[2][row] >= -event_atol):
                                code = HANDOFF
                                stop = True
                                break
                    if stop:
                        break
            phase_ = 1
        # ---------------------------------------------------------------- main loop
        if not t < t_end:
            break
        t_stop = t_end
        for oi in range(out_ptr[m], out_ptr[m + 1]):
            tr = out_list[oi]
            if tr_sched[tr] == 1 and tr_sched_on[tr] == 1:
                kk = _sched_index(period[tr], phase[tr], sched_done[tr], t)
                t_stop = min(t_stop, phase[tr] + kk * period[tr])
        if t_stop - t > _xtol(event_tol, t):
            # ------------------------------------------------------------ flow segment
            fg, cg, sg = fgs[m], cgs[m], sgs[m]
            M = 0
            for oi in range(out_ptr[m], out_ptr[m + 1]):
                if tr_monitored[out_list[oi]] == 1:
                    M += 1
            M += n_inv[m] + n_sw[m]
            mk = np.empty(M, dtype=np.int64)
            mref = np.empty(M, dtype=np.int64)
            mstart = np.empty(M, dtype=np.int64)
            mlen = np.empty(M, dtype=np.int64)
            r = 0
            row0 = 0
            for oi in range(out_ptr[m], out_ptr[m + 1]):
                tr = out_list[oi]
                if tr_monitored[tr] == 1:
                    mk[r], mref[r], mstart[r], mlen[r] = GUARD, tr, row0, tr_monitored[n_tr + tr]
                    row0 += tr_monitored[n_tr + tr]
                    r += 1
            for k in range(n_inv[m]):
                mk[r], mref[r], mstart[r], mlen[r] = INVARIANT, k, inv_off[m] + k, 1
                r += 1
            for k in range(n_sw[m]):
                mk[r], mref[r], mstart[r], mlen[r] = 2, k, 0, 1
                r += 1
            md = (fg, cg, sg, mk, mref, mstart, mlen)
            SG = _grow(SG, nsg)
            SG[nsg, 0], SG[nsg, 1], SG[nsg, 2], SG[nsg, 4] = m, j, npt, nst
            PT = _grow(PT, npt)
            PT[npt, 0] = t
            PT[npt, 1:] = x
            npt += 1
            armed = np.zeros(M, dtype=np.bool_)
            has_floor = np.zeros(M, dtype=np.bool_)
            floors = np.zeros(M)
            if M > 0:
                phi0 = np.empty((M, 1))
                dphi0 = np.empty((M, 1))
                monitors_at(model, md, p, sig, ws, t, x, phi0, dphi0, 0)
                for r in range(M):
                    armed[r] = phi0[r, 0] > event_atol
                    band = 16 * _xtol(event_tol, t) * abs(dphi0[r, 0]) + event_atol
                    if not (armed[r] or (mk[r] == GUARD and dphi0[r, 0] <= 0)):
                        has_floor[r] = True
                        floors[r] = min(phi0[r, 0], 0.0) - band
                    if mk[r] == INVARIANT and phi0[r, 0] < -band:
                        code = HANDOFF
                if code == HANDOFF:
                    break
            model(OP_FLOW, fg, t, ptr(x), ptr(p), ptr(sig), ptr(dummy), ptr(fcur))
            if h_last > 0:
                h_abs = min(h_last, t_stop - t)
            else:
                h_abs = initial_step(model, fg, t, x, fcur, t_stop, max_step, order_err, rtol,
                                     atol, p, sig, dummy)
            hit_n = 0
            hit_rows = np.empty(M, dtype=np.int64)
            while True:
                ok, t_new, h_abs, h = rk_step(model, method, fg, t, x, fcur, t_stop, h_abs,
                                              max_step, rtol, atol, p, sig, dummy, K, y_new,
                                              f_new, tmp)
                stats[0] += 1
                if not ok:
                    code = HANDOFF
                    break
                t_old = t
                h_last = t_new - t_old
                dense_coefficients(model, method, fg, t_old, h, x, y_new, f_new, p, sig,
                                   dummy, K, tmp, coef)
                step = (method, coef, t_old, h, x)
                nfire, rows, times, graz, armed = scan(
                    model, md, p, sig, ws, step, armed, has_floor, floors, t_old, t_new,
                    samples, max_refine, event_tol, event_atol, stats)
                for r in range(M):
                    if armed[r]:
                        has_floor[r] = False
                ST = _grow(ST, nst)
                ST[nst, 0] = t_old
                ST[nst, 1] = h
                ST[nst, 2:2 + n] = x
                for c in range(nc):
                    ST[nst, 2 + n + c * n:2 + n + (c + 1) * n] = coef[c]
                nst += 1
                PT = _grow(PT, npt)
                if nfire > 0:
                    t_event = times[0]
                    for i in range(1, nfire):
                        t_event = min(t_event, times[i])
                    dense_eval(method, coef, t_old, h, x, t_event, tmp)
                    t = t_event
                    x[:] = tmp
                    PT[npt, 0] = t
                    PT[npt, 1:] = x
                    npt += 1
                    hit_n = nfire
                    hit_rows[:nfire] = rows[:nfire]
                    hit_graz = graz
                    break
                PT[npt, 0] = t_new
                PT[npt, 1:] = y_new
                npt += 1
                t = t_new
                x[:] = y_new
                fcur[:] = f_new
                if t_new >= t_stop:
                    break
            SG[nsg, 3] = npt - SG[nsg, 2]
            SG[nsg, 5] = nst - SG[nsg, 4]
            nsg += 1
            if code == HANDOFF:
                break
            stats[3] += 1
            last_t, last_m = t, m
            last_x[:] = x
            if hit_n > 0:
                # ------------------------------------------------------------ handle
                fresh[:] = False
                grazing[:] = False
                n_switch_hit = 0
                for i in range(hit_n):
                    r = hit_rows[i]
                    if mk[r] == GUARD:
                        fresh[mref[r]] = True
                        if hit_graz[i]:
                            grazing[mref[r]] = True
                    elif mk[r] == 2:
                        n_switch_hit += 1
                if n_switch_hit > 1:
                    code = HANDOFF
                    break
                if n_switch_hit == 1:
                    for i in range(hit_n):
                        r = hit_rows[i]
                        if mk[r] == 2:
                            k = mref[r]
                            if not _resolve_one(model, fg, sg, affine[m], t, x, p, sig, k,
                                                ws[1], ws[4], ws[5], dummy):
                                code = HANDOFF
                                break
                            EV = _grow(EV, nev)
                            EV[nev, 0] = t
                            EV[nev, 1] = j
                            EV[nev, 2] = k
                            EV[nev, 3] = m
                            EV[nev, 4] = m
                            EV[nev, 5] = 1
                            EV[nev, 6] = 0.0
                            EV[nev, 7:7 + n] = x
                            EV[nev, 7 + n:7 + 2 * n] = x
                            nev += 1
                            if nev >= max_events:
                                code = MAX_EVENTS
                                break
                            key = sw_key[m * w_sw + k]
                            zeno, ratio, acc = _zeno_record(ztimes, zcount, key, t, window,
                                                            zeno_tol, 4 * event_tol)
                            if zeno:
                                info[0], info[1], info[2], info[3] = key, zcount[key], ratio, acc
                                code = ZENO
                                break
                    if code != COMPLETED:
                        break
                phase_ = 2
                continue
        t = t_stop
        due = False
        if not t < t_end:
            for oi in range(out_ptr[m], out_ptr[m + 1]):
                tr = out_list[oi]
                if tr_sched[tr] == 1 and tr_sched_on[tr] == 1:
                    kk = _sched_index(period[tr], phase[tr], sched_done[tr], t)
                    if abs(phase[tr] + kk * period[tr] - t) <= 2 * _xtol(event_tol, t):
                        due = True
        if t < t_end or due:
            fresh[:] = False
            grazing[:] = False
            phase_ = 2  # the event iteration without fresh guards
            hit_n = 0
            continue
    return (code, EV[:nev].copy(), PT[:npt].copy(), ST[:nst].copy(), SG[:nsg].copy(), stats,
            info, last_t, last_x, last_m, j, h_last)
