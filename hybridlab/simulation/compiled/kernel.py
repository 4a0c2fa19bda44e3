"""The compiled run loop: flow, event location, jumps and sliding in numba.

``run_kernel`` mirrors ``_Run.run`` of the reference engine (same order of
operations, same tolerances): integrate a mode step by step, scan the
monitors on each step's dense output, and at an event update the signs of
the switching surfaces (crossing, Filippov sliding with its joint active set,
sliding exits; :mod:`.sliding`) and apply the event iteration (priorities,
resets, the no-immediate-retrigger and boundary-leaving rules, schedules,
Zeno tracking).

What it does not handle (invariant violations, zero-dwell cycles, failed
steps, non-finite resets, singular or non-affine sliding) makes it return
:data:`HANDOFF` together with a *checkpoint*: the run state just before the
flow segment or the event in which the case arose (time, state, mode, jump
count, signs, sliding set, schedules, Zeno history, and the triggers of the
event). The caller continues from there on the reference engine, which
reproduces that segment or event and reports the case as it always does.

Records grow by doubling: events ``EV`` (t, j, transition or switch, source,
target, kind, grazing, pre..., post...; kind 0 jump, 1 crossing, 2
slide_start, 3 slide_end), stored points ``PT`` (t, y...), steps ``ST``
(t_old, h, y_old..., coefficients...) and segments ``SG`` (mode, j, first
point, points, first step, steps).
"""

# ruff: noqa: SIM102 - kept line by line with the scipy / reference code it ports

from __future__ import annotations

import numba
import numpy as np

from hybridlab.simulation.compiled.bounds import box_workspace, quiet_step
from hybridlab.simulation.compiled.integrate import (
    N_COEF,
    N_K,
    dense_coefficients,
    dense_eval,
    initial_step,
    rk_step,
)
from hybridlab.simulation.compiled.layout import (
    DenseStep,
    FlowContext,
    KernelCheckpoint,
    KernelResult,
    LocateWorkspace,
    Monitors,
)
from hybridlab.simulation.compiled.locate import (
    EXIT,
    GUARD,
    INVARIANT,
    OUTGROWN,
    SWITCH,
    monitors_at,
    sample_workspace,
    scan,
    xtol_at,
)
from hybridlab.simulation.compiled.opcodes import (
    OP_COND,
    OP_COND_LIE,
    OP_GUARD,
    OP_GUARD_LIE,
    OP_RESET,
)
from hybridlab.simulation.compiled.signatures import (
    clock_at,
    gil_ensure_at,
    gil_release_at,
    interrupt_at,
    model_at,
    ptr,
)
from hybridlab.simulation.compiled.sliding import (
    OK,
    active_indices,
    enter_mode,
    flag_index,
    flow_eq,
    rhs,
    update_switches,
    workspace,
)
from hybridlab.simulation.rules import (
    DUE_WIDTH,
    ENTRY_BAND,
    RETRIGGER_BAND,
    ZENO_RESOLUTION,
    schedule_index,
)

__all__ = ["run_kernel", "COMPLETED", "ZENO", "MAX_EVENTS", "HANDOFF", "STEP_LIMIT", "TIME_LIMIT",
           "INTERRUPTED", "R_START", "R_ITERATE",
           "R_HANDLE", "R_FLOW"]

COMPLETED, ZENO, MAX_EVENTS, HANDOFF = 0, 1, 2, 3
#: the run's budgets: ``max_steps`` integrator steps, the wall-clock deadline, Ctrl-C
STEP_LIMIT, TIME_LIMIT, INTERRUPTED = 4, 5, 6
#: steps between two looks at the clock and for Ctrl-C (each look costs tens of ns)
_WATCH_EVERY = 16
#: the least time between two looks for Ctrl-C: each takes the GIL for a moment, which
#: waits while another thread runs Python (CPython hands the GIL over within 5 ms)
_LOOK_EVERY_NS = 50_000_000
#: where a hand-off resumes: from the start, at an event iteration without fresh guards,
#: at the handling of a flow segment's triggers, at the start of a flow segment
R_START, R_ITERATE, R_HANDLE, R_FLOW = 0, 1, 2, 3
_ITERATE, _HANDLE, _FLOW = 0, 1, 2


@numba.njit(cache=True)
def _grow(a, n):
    if n < a.shape[0]:
        return a
    b = np.empty((2 * a.shape[0], a.shape[1]), dtype=a.dtype)
    b[:a.shape[0]] = a
    return b


#: :func:`hybridlab.simulation.rules.schedule_index`, compiled
_sched_index = numba.njit(cache=True)(schedule_index)


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
def _zeno_stop(ztimes, zcount, key, t, window, tol, resolution, info):
    """Record an event of Zeno key ``key``; True, with ``info`` (key, count, ratio,
    accumulation time) filled, when the events accumulate."""
    zeno, ratio, acc = _zeno_record(ztimes, zcount, key, t, window, tol, resolution)
    if zeno:
        info[0], info[1], info[2], info[3] = key, zcount[key], ratio, acc
    return zeno


@numba.njit(cache=True)
def _fc(tables, m, slm, W):
    """The flow context of mode ``m`` with the sliding set ``slm`` (see :mod:`.sliding`)."""
    ns = tables.n_switches[m]
    sl = active_indices(slm, ns)
    act = tables.active_list[tables.active_ptr[m]:tables.active_ptr[m + 1]]
    return FlowContext(tables.flow_group[m], tables.switch_group[m], tables.grad_group[m],
                       tables.dsigma_group[m], ns, sl, W, tables.slide_group[m],
                       tables.switch_free[m], act)


@numba.njit(cache=True)
def _log(EV, nev, t, j, ref, source, target, kind, grazing, pre, post):
    EV = _grow(EV, nev)
    n = pre.size
    EV[nev, 0] = t
    EV[nev, 1] = j
    EV[nev, 2] = ref
    EV[nev, 3] = source
    EV[nev, 4] = target
    EV[nev, 5] = kind
    EV[nev, 6] = 1.0 if grazing else 0.0
    EV[nev, 7:7 + n] = pre
    EV[nev, 7 + n:7 + 2 * n] = post
    return EV


@numba.njit(cache=True, nogil=True)
def run_kernel(model_address, box_address, tables, reals, opts_i, opts_f, t, x, m, t_end, p,
               n_sig, ztimes, zcount, sched_done, watch):
    """Run from ``(t, x, m)`` to ``t_end``; see the module docstring for the records.

    The kernel releases the GIL: runs in several threads go on in parallel.

    ``watch``: the step budget, the addresses of ``PyOS_InterruptOccurred`` (0:
    Ctrl-C is not looked for, as in a thread other than the main one, which never
    receives it) and ``clock_gettime``, the clock's id, the wall-clock deadline in
    its nanoseconds (0: none), and the addresses of ``PyGILState_Ensure`` and
    ``PyGILState_Release``, between which it looks for Ctrl-C. Every
    :data:`_WATCH_EVERY` steps the kernel looks at the clock, and for Ctrl-C when
    :data:`_LOOK_EVERY_NS` have passed since it last did (every time, without a
    clock), and stops with :data:`INTERRUPTED` or :data:`TIME_LIMIT`; after
    ``watch[0]`` steps it stops with :data:`STEP_LIMIT`.

    ``model_address`` and ``box_address`` are the addresses of the generated
    model's point and box functions (:mod:`.codegen`; ``cfunc.address``).

    ``tables``: the model's :class:`~.layout.ModelTables`. ``reals``: per
    transition period, phase. Returns the records, the final run state and the
    checkpoint (meaningful for :data:`HANDOFF`), as a :class:`~.layout.KernelResult`.
    """
    model, box = model_at(model_address), model_at(box_address)
    max_steps, interrupted, clock = watch[0], interrupt_at(watch[1]), clock_at(watch[2])
    clock_id, deadline = np.int32(watch[3]), watch[4]
    gil_ensure, gil_release = gil_ensure_at(watch[5]), gil_release_at(watch[6])
    timed = watch[2] != 0  # the clock is read only where the C library has one
    next_look = 0
    now = np.zeros(2, dtype=np.int64)
    cgs = tables.cond_group
    inv_off, n_inv, n_sw = tables.invariant_offset, tables.n_invariants, tables.n_switches
    affine, out_ptr, out_list = tables.affine, tables.out_ptr, tables.out_list
    tr_target, tr_guard, tr_monitored = tables.tr_target, tables.tr_guard, tables.tr_monitored
    tr_sched, tr_sched_on, tr_reset = (tables.tr_scheduled, tables.tr_schedule_on,
                                       tables.tr_reset)
    sw_key, tr_zkey, n_cond = tables.switch_zeno_key, tables.tr_zeno_key, tables.n_conditions
    inv_box = tables.invariant_box
    period, phase = reals
    method, samples, max_refine, max_events, max_iter, window, use_bounds = (
        opts_i[0], opts_i[1], opts_i[2], opts_i[3], opts_i[4], opts_i[5], opts_i[6])
    rtol, atol, max_step, event_tol, event_atol, zeno_tol = (
        opts_f[0], opts_f[1], opts_f[2], opts_f[3], opts_f[4], opts_f[5])
    n = x.size
    n_tr = tr_target.size
    nk, nc = N_K[method], N_COEF[method]
    order_err = 4 if method == 0 else 7
    x = x.copy()
    ns = max(n_sig, 1)
    sig = np.ones(ns)
    slm = np.zeros(ns, dtype=np.bool_)
    W = workspace(n, n_sig)
    flag = W[flag_index(n, n_sig):]
    dummy = W
    eqv = np.empty(ns)
    n_cmax = max(np.max(n_cond), 1)
    ws = LocateWorkspace(np.empty(n), np.empty(n), np.empty(2 * n_cmax), np.empty(n_cmax),
                         np.empty(2 * ns), np.empty(ns), np.empty(ns))
    bx = box_workspace(n, n_cmax, ns)
    gv = np.empty(max(np.max(tr_monitored[n_tr:]) if n_tr else 1, 1))
    gd = np.empty(gv.size)
    # the monitor table of a flow segment and its per-monitor state: views of buffers
    # sized for the mode with the most monitors (a segment starts at every event)
    m_max = 1
    for mm in range(n_inv.size):
        c = n_inv[mm] + n_sw[mm]
        for oi in range(out_ptr[mm], out_ptr[mm + 1]):
            if tr_monitored[out_list[oi]] == 1:
                c += 1
        m_max = max(m_max, c)
    sw = sample_workspace(m_max, 4 * (samples + 1))  # doubled when a step outgrows it
    table = np.empty((5, m_max), dtype=np.int64)  # kind, ref, start, length, hit rows
    mk, mref, mstart, mlen, hit_rows = table[0], table[1], table[2], table[3], table[4]
    flags = np.zeros((2, m_max), dtype=np.bool_)  # armed, has a floor
    floors_b = np.zeros(m_max)
    phi0_b = np.empty((m_max, 1))
    dphi0_b = np.empty((m_max, 1))
    hit_graz = np.zeros(0, dtype=np.bool_)
    rows = np.empty(0, dtype=np.int64)
    times = np.empty(0)
    graz = np.zeros(0, dtype=np.bool_)
    hit_n = 0
    w_sw = ns
    EV = np.empty((64, 7 + 2 * n))
    PT = np.empty((256, 1 + n))
    ST = np.empty((256, 2 + n + nc * n))
    SG = np.empty((64, 6), dtype=np.int64)
    nev, npt, nst, nsg = 0, 0, 0, 0
    # steps, refinements, events_located, segments, steps proven quiet (not sampled)
    stats = np.zeros(5, dtype=np.int64)
    info = np.zeros(4)
    j = 0
    h_last = -1.0
    K = np.empty((nk, n))
    coef = np.empty((nc, n))
    y_new = np.empty(n)
    f_new = np.empty(n)
    fcur = np.empty(n)
    tmp = np.empty(n)
    scale = np.empty(n)
    fired = np.zeros(max(n_tr, 1), dtype=np.bool_)
    fresh = np.zeros(max(n_tr, 1), dtype=np.bool_)
    grazing = np.zeros(max(n_tr, 1), dtype=np.bool_)
    sw_hit = np.zeros(ns, dtype=np.bool_)
    ex_hit = np.zeros(ns, dtype=np.bool_)
    kinds = np.zeros(ns, dtype=np.int64)
    # checkpoint: kind, mode, j, events, segments, triggers; t, h_last; state; signs; ...
    cp_i = np.zeros(6, dtype=np.int64)
    cp_f = np.zeros(2)
    cp_x = x.copy()
    cp_sig = sig.copy()
    cp_slm = slm.copy()
    cp_zt = ztimes.copy()
    cp_zc = zcount.copy()
    cp_sd = sched_done.copy()
    cp_rows = np.zeros(0, dtype=np.int64)
    cp_graz = np.zeros(0, dtype=np.bool_)
    code = COMPLETED
    last_t, last_x, last_m = t, x.copy(), m
    fc = _fc(tables, m, slm, W)
    if enter_mode(model, fc, affine[m], t, x, p, sig, slm, event_atol) != OK:
        code = HANDOFF
        cp_i[0] = R_START
        return KernelResult(code, EV[:0].copy(), PT[:0].copy(), ST[:0].copy(), SG[:0].copy(),
                            stats, info, last_t, last_x, last_m, j, h_last,
                            KernelCheckpoint(cp_i, cp_f, cp_x, cp_sig, cp_slm, cp_zt, cp_zc,
                                             cp_sd, cp_rows, cp_graz))
    fc = _fc(tables, m, slm, W)
    action = _ITERATE
    while True:
        if action != _FLOW:
            # ------------------------------------------------------------ checkpoint
            cp_i[0] = R_HANDLE if action == _HANDLE else R_ITERATE
            cp_i[1], cp_i[2], cp_i[3], cp_i[4] = m, j, nev, nsg
            cp_f[0], cp_f[1] = t, h_last
            cp_x[:] = x
            cp_sig[:] = sig
            cp_slm[:] = slm
            cp_zt[:] = ztimes
            cp_zc[:] = zcount
            cp_sd[:] = sched_done
            fresh[:] = False
            grazing[:] = False
            stop = False
            if action == _HANDLE:
                cp_i[5] = hit_n
                cp_rows = hit_rows[:hit_n].copy()
                cp_graz = hit_graz[:hit_n].copy()
                # ------------------------------------------------------------ handle
                sw_hit[:] = False
                ex_hit[:] = False
                any_switch = False
                for i in range(hit_n):
                    r = hit_rows[i]
                    if mk[r] == GUARD:
                        fresh[mref[r]] = True
                        if hit_graz[i]:
                            grazing[mref[r]] = True
                    elif mk[r] == SWITCH:
                        sw_hit[mref[r]] = True
                        any_switch = True
                    elif mk[r] == EXIT:
                        ex_hit[mref[r]] = True
                        any_switch = True
                if any_switch:
                    if update_switches(model, fc, affine[m], t, x, p, sig, slm, sw_hit, ex_hit,
                                       kinds) != OK:
                        code = HANDOFF
                        break
                    fc = _fc(tables, m, slm, W)
                    for k in range(n_sw[m]):
                        if kinds[k] == 0:
                            continue
                        EV = _log(EV, nev, t, j, k, m, m, kinds[k], False, x, x)
                        nev += 1
                        if nev >= max_events:
                            code = MAX_EVENTS
                            stop = True
                            break
                        if _zeno_stop(ztimes, zcount, sw_key[m * w_sw + k], t, window,
                                      zeno_tol, ZENO_RESOLUTION * event_tol, info):
                            last_t, last_m = t, m
                            last_x[:] = x
                            code = ZENO
                            stop = True
                            break
                    if stop:
                        break
            # ---------------------------------------------------------------- event iteration
            fired[:] = False
            previous = -1
            settled = False
            for _ in range(max_iter):
                chosen = -1
                flowing = False  # the (equivalent) flow at (t, x) is in fcur: once per pass
                for oi in range(out_ptr[m], out_ptr[m + 1]):
                    tr = out_list[oi]
                    xt = xtol_at(event_tol, t)
                    if tr_sched[tr] == 1:
                        if tr_sched_on[tr] == 0:
                            continue
                        kk = _sched_index(t, phase[tr], period[tr], sched_done[tr])
                        if abs(phase[tr] + kk * period[tr] - t) > DUE_WIDTH * xt:
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
                    # guard_state: G = min g_i and its slope along the (equivalent) flow
                    if not flowing:
                        if not flow_eq(model, fc, t, x, p, sig, fcur, eqv):
                            code = HANDOFF
                            stop = True
                            break
                        flowing = True
                    model(OP_GUARD, tr_guard[tr], t, ptr(x), ptr(p), ptr(sig), ptr(dummy),
                          ptr(gv))
                    model(OP_GUARD_LIE, tr_guard[tr], t, ptr(x), ptr(p), ptr(sig), ptr(fcur),
                          ptr(gd))
                    value, slope = gv[0], gd[0]
                    for q in range(1, tr_monitored[n_tr + tr]):
                        if gv[q] < value or not np.isfinite(gv[q]):
                            value, slope = gv[q], gd[q]
                    if not np.isfinite(value):
                        code = HANDOFF  # the reference engine names the undefined guard
                        stop = True
                        break
                    if not np.isfinite(slope):  # a vertical tangent: no time band
                        slope = 0.0 if slope != slope else slope
                        xt_slope = 0.0
                    else:
                        xt_slope = RETRIGGER_BAND * xt * abs(slope)
                    if tr_sched[tr] == 1:
                        if value >= 0:
                            chosen = tr
                            break
                        continue
                    band = xt_slope + event_atol
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
                EV = _log(EV, nev, t, j, chosen, m, target, 0, grazing[chosen], tmp, y_new)
                nev += 1
                x[:] = y_new
                if nev >= max_events:
                    code = MAX_EVENTS
                    stop = True
                    break
                fired[chosen] = True
                previous = chosen
                if tr_sched[chosen] == 1:
                    sched_done[chosen] = _sched_index(t, phase[chosen], period[chosen],
                                                      sched_done[chosen])
                else:
                    if _zeno_stop(ztimes, zcount, tr_zkey[chosen], t, window, zeno_tol,
                                  ZENO_RESOLUTION * event_tol, info):
                        last_t, last_m = t, target
                        last_x[:] = x
                        code = ZENO
                        stop = True
                        break
                m = target
                slm[:] = False
                fc = _fc(tables, m, slm, W)
                if enter_mode(model, fc, affine[m], t, x, p, sig, slm, event_atol) != OK:
                    code = HANDOFF
                    stop = True
                    break
                fc = _fc(tables, m, slm, W)
                fresh[:] = False
            if stop:
                break
            if not settled:
                code = HANDOFF  # a zero-dwell cycle: the reference reports it
                break
            for oi in range(out_ptr[m], out_ptr[m + 1]):
                tr = out_list[oi]
                if tr_sched[tr] == 1 and tr_sched_on[tr] == 1 and not fired[tr]:
                    kk = _sched_index(t, phase[tr], period[tr], sched_done[tr])
                    if abs(phase[tr] + kk * period[tr] - t) <= DUE_WIDTH * xtol_at(event_tol, t):
                        sched_done[tr] = kk
            last_t, last_m = t, m
            last_x[:] = x
            if action == _HANDLE and not np.any(fired):
                # an invariant reached without a jump: it must be touched and kept
                for r in range(hit_n):
                    if mk[hit_rows[r]] == INVARIANT:
                        if not flow_eq(model, fc, t, x, p, sig, fcur, eqv):
                            stop = True
                            break
                        row = mstart[hit_rows[r]]
                        model(OP_COND, cgs[m], t, ptr(x), ptr(p), ptr(sig), ptr(dummy),
                              ptr(ws.cond))
                        model(OP_COND_LIE, cgs[m], t, ptr(x), ptr(p), ptr(sig), ptr(fcur),
                              ptr(ws.cond_lie))
                        if not (ws.cond_lie[row] >= 0 and ws.cond[row] >= -event_atol):
                            stop = True
                            break
                if stop:
                    code = HANDOFF
                    break
            action = _FLOW
        # ---------------------------------------------------------------- main loop
        if not t < t_end:
            break
        t_stop = t_end
        for oi in range(out_ptr[m], out_ptr[m + 1]):
            tr = out_list[oi]
            if tr_sched[tr] == 1 and tr_sched_on[tr] == 1:
                kk = _sched_index(t, phase[tr], period[tr], sched_done[tr])
                t_stop = min(t_stop, phase[tr] + kk * period[tr])
        if t_stop - t > xtol_at(event_tol, t):
            # ------------------------------------------------------------ flow segment
            cp_i[0], cp_i[1], cp_i[2], cp_i[3], cp_i[4] = R_FLOW, m, j, nev, nsg
            cp_f[0], cp_f[1] = t, h_last
            cp_x[:] = x
            cp_sig[:] = sig
            cp_slm[:] = slm
            cg = cgs[m]
            M = 0
            for oi in range(out_ptr[m], out_ptr[m + 1]):
                if tr_monitored[out_list[oi]] == 1:
                    M += 1
            M += n_inv[m] + n_sw[m]
            mk, mref, mstart, mlen = table[0, :M], table[1, :M], table[2, :M], table[3, :M]
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
                mk[r], mref[r], mstart[r], mlen[r] = (EXIT if slm[k] else SWITCH), k, 0, 1
                r += 1
            md = Monitors(fc, cg, mk, mref, mstart, mlen, n_cond[m])
            bounded = use_bounds != 0 and M > 0
            SG = _grow(SG, nsg)
            SG[nsg, 0], SG[nsg, 1], SG[nsg, 2], SG[nsg, 4] = m, j, npt, nst
            PT = _grow(PT, npt)
            PT[npt, 0] = t
            PT[npt, 1:] = x
            npt += 1
            armed, has_floor, floors = flags[0, :M], flags[1, :M], floors_b[:M]
            for r in range(M):
                armed[r] = False
                has_floor[r] = False
                floors[r] = 0.0
            if M > 0:
                phi0, dphi0 = phi0_b[:M], dphi0_b[:M]
                flow_eq(model, fc, t, x, p, sig, ws.dx, ws.eq)
                monitors_at(model, md, p, sig, ws, t, x, ws.dx, phi0, dphi0, 0)
                for r in range(M):
                    armed[r] = phi0[r, 0] > event_atol
                    band = ENTRY_BAND * xtol_at(event_tol, t) * abs(dphi0[r, 0]) + event_atol
                    if not (armed[r] or (mk[r] == GUARD and dphi0[r, 0] <= 0)):
                        has_floor[r] = True
                        floors[r] = min(phi0[r, 0], 0.0) - band
                    if mk[r] == INVARIANT and phi0[r, 0] < -band:
                        code = HANDOFF
                if flag[0] != 0:
                    code = HANDOFF
                if code == HANDOFF:
                    break
            if M > 0 and fc.sliding.size == 0:
                for i in range(n):  # without sliding, flow_eq gave the flow itself
                    fcur[i] = ws.dx[i]
            else:
                rhs(model, fc, t, x, p, sig, fcur)
            for i in range(n):
                if not (np.isfinite(fcur[i]) and np.isfinite(x[i])):
                    code = HANDOFF  # the reference engine names the non-finite flow
            if code == HANDOFF:
                break
            if h_last > 0:
                h_abs = min(h_last, t_stop - t)
            else:
                h_abs = initial_step(model, fc, t, x, fcur, t_stop, max_step, order_err, rtol,
                                     atol, p, sig)
            hit_n = 0
            hit_rows = table[4, :M]
            coef[:] = 0.0  # the columns of states outside the active set stay zero
            act = fc.active
            while True:
                ok, t_new, h_abs, h = rk_step(model, method, fc, t, x, fcur, t_stop, h_abs,
                                              max_step, rtol, atol, p, sig, K, y_new, f_new,
                                              tmp, scale)
                stats[0] += 1
                if not ok or flag[0] != 0:
                    code = HANDOFF
                    break
                t_old = t
                h_last = t_new - t_old
                dense_coefficients(model, method, fc, t_old, h, x, y_new, f_new, p, sig, K,
                                   tmp, coef)
                step = DenseStep(method, coef, t_old, h, x, act)
                if bounded and quiet_step(box, md, p, sig, step, t_old, t_new, event_atol,
                                          armed, bx, tr_guard, inv_box[m]):
                    nfire = 0
                    stats[4] += 1
                else:
                    while True:
                        nfire = scan(model, md, p, sig, ws, sw, step, armed, has_floor,
                                     floors, t_old, t_new, samples, max_refine, event_tol,
                                     event_atol, stats)
                        if nfire != OUTGROWN:
                            break
                        sw = sample_workspace(m_max, 2 * sw.times.size)
                    armed[:] = sw.armed[:M]
                    rows, times, graz = sw.rows, sw.at, sw.grazing
                if flag[0] != 0:
                    code = HANDOFF
                    break
                for r in range(M):
                    if armed[r]:
                        has_floor[r] = False
                if nst >= ST.shape[0]:  # (a call per step would count references)
                    ST = _grow(ST, nst)
                ST[nst, 0] = t_old
                ST[nst, 1] = h
                ST[nst, 2:2 + n] = x
                for c in range(nc):
                    ST[nst, 2 + n + c * n:2 + n + (c + 1) * n] = coef[c]
                nst += 1
                if npt >= PT.shape[0]:
                    PT = _grow(PT, npt)
                if nfire > 0:
                    t_event = times[0]
                    for i in range(1, nfire):
                        t_event = min(t_event, times[i])
                    dense_eval(method, coef, t_old, h, x, act, t_event, tmp)
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
                if stats[0] >= max_steps:
                    code = STEP_LIMIT
                elif stats[0] % _WATCH_EVERY == 0:
                    now_ns = 0
                    if timed:
                        clock(clock_id, ptr(now))
                        now_ns = now[0] * 1_000_000_000 + now[1]
                    hit = 0
                    if watch[1] != 0 and (not timed or now_ns >= next_look):
                        next_look = now_ns + _LOOK_EVERY_NS
                        held = gil_ensure()  # CPython's flag is read under the GIL
                        hit = interrupted()
                        gil_release(held)
                    if hit != 0:
                        code = INTERRUPTED
                    elif deadline > 0 and now_ns >= deadline:
                        code = TIME_LIMIT
                if t_new >= t_stop or code != COMPLETED:
                    break
            SG[nsg, 3] = npt - SG[nsg, 2]
            SG[nsg, 5] = nst - SG[nsg, 4]
            nsg += 1
            if code == HANDOFF:
                break
            stats[3] += 1
            last_t, last_m = t, m
            last_x[:] = x
            if code != COMPLETED:
                break
            if hit_n > 0:
                action = _HANDLE
                continue
        t = t_stop
        due = False
        if not t < t_end:
            for oi in range(out_ptr[m], out_ptr[m + 1]):
                tr = out_list[oi]
                if tr_sched[tr] == 1 and tr_sched_on[tr] == 1:
                    kk = _sched_index(t, phase[tr], period[tr], sched_done[tr])
                    if abs(phase[tr] + kk * period[tr] - t) <= DUE_WIDTH * xtol_at(event_tol, t):
                        due = True
        if t < t_end or due:
            action = _ITERATE  # the event iteration without fresh guards
            hit_n = 0
            continue
    if code == HANDOFF and cp_i[0] == R_FLOW:
        # a flow segment changes neither the Zeno history nor the schedules
        cp_zt[:] = ztimes
        cp_zc[:] = zcount
        cp_sd[:] = sched_done
    return KernelResult(code, EV[:nev].copy(), PT[:npt].copy(), ST[:nst].copy(),
                        SG[:nsg].copy(), stats, info, last_t, last_x, last_m, j, h_last,
                        KernelCheckpoint(cp_i, cp_f, cp_x, cp_sig, cp_slm, cp_zt, cp_zc, cp_sd,
                                         cp_rows, cp_graz))
