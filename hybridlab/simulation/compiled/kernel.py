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
    RunBuffers,
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
    borrowing,
    clock_at,
    gil_ensure_at,
    gil_release_at,
    interrupt_at,
    model_at,
    ptr,
)
from hybridlab.simulation.compiled.sliding import (
    OK,
    enter_mode,
    flag_index,
    flow_eq,
    rhs,
    switch_scratch,
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


@borrowing
def _zeno_record(ztimes, zcount, key, t, window, tol, resolution):
    """ZenoTracker.record; returns ``(zeno, ratio, accumulation_time)``.

    Written with scalars (no array of dwell times or ratios is made): it runs at every
    jump. The arithmetic is numpy's on those arrays, term by term: each dwell time is a
    difference of event times, each ratio a quotient of dwell times, and the mean of the
    last three ratios their sum from zero, divided by their count.
    """
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
    for i in range(window):
        if ztimes[key, i + 1] - ztimes[key, i] <= 0:
            return False, 0.0, 0.0
    shrinking = True
    low, high = np.inf, -np.inf
    n_mean = min(3, window - 1)
    total = 0.0
    for i in range(window - 1):
        ratio = (ztimes[key, i + 2] - ztimes[key, i + 1]) / (ztimes[key, i + 1] - ztimes[key, i])
        shrinking = shrinking and ratio < 1.0
        low, high = min(low, ratio), max(high, ratio)
        if i >= window - 1 - n_mean:
            total += ratio
    if not (shrinking and high <= 1.5 * low):
        return False, 0.0, 0.0
    r = total / n_mean
    last = ztimes[key, window] - ztimes[key, window - 1]
    remaining = last * r / (1.0 - r)
    scale = max(1.0, abs(t))
    if remaining <= tol * scale or last <= resolution * scale:
        return True, r, t + remaining
    return False, 0.0, 0.0


@borrowing
def _zeno_stop(ztimes, zcount, key, t, window, tol, resolution, info):
    """Record an event of Zeno key ``key``; True, with ``info`` (key, count, ratio,
    accumulation time) filled, when the events accumulate."""
    zeno, ratio, acc = _zeno_record(ztimes, zcount, key, t, window, tol, resolution)
    if zeno:
        info[0], info[1], info[2], info[3] = key, zcount[key], ratio, acc
    return zeno


@numba.njit(cache=True, inline="always")
def _fc(tables, m, slm, W, sl_buffer):
    """The flow context of mode ``m`` with the sliding set ``slm`` (see :mod:`.sliding`).

    Inlined: a call would count a reference to each of the tables' arrays on the way
    in and out, at every event. The sliding indices are a view of ``sl_buffer``, which
    the previous context's view shares: that context is dead once this one is made.
    """
    ns = tables.n_switches[m]
    c = 0
    for k in range(ns):
        if slm[k]:
            sl_buffer[c] = k
            c += 1
    sl = sl_buffer[:c]
    act = tables.active_list[tables.active_ptr[m]:tables.active_ptr[m + 1]]
    return FlowContext(tables.flow_group[m], tables.switch_group[m], tables.grad_group[m],
                       tables.dsigma_group[m], ns, sl, W, tables.slide_group[m],
                       tables.switch_free[m], act)


@numba.njit(cache=True, inline="always")
def _log(EV, nev, t, j, ref, source, target, kind, grazing, pre, post):
    """Record an event in row ``nev`` of ``EV``, which has room for it."""
    n = pre.size
    EV[nev, 0] = t
    EV[nev, 1] = j
    EV[nev, 2] = ref
    EV[nev, 3] = source
    EV[nev, 4] = target
    EV[nev, 5] = kind
    EV[nev, 6] = 1.0 if grazing else 0.0
    for i in range(n):
        EV[nev, 7 + i] = pre[i]
        EV[nev, 7 + n + i] = post[i]


#: how :func:`_steps` ends: the segment's steps are done (or stopped: see its code), the
#: records need room for one more step, the sampler's workspace must grow
_DONE, _ROOM, _RESAMPLE = 0, 1, 2


@borrowing
def _steps(model, box, md, p, ws, sw, bx, b, tr_guard, inv_group, flag, armed, has_floor,
           floors, bounded, opts_i, opts_f, t, t_stop, h_abs, h_last, ST, nst, PT, npt,
           hit_rows, watch, next_look):
    """A flow segment's integrator steps, from ``(t, b.x)`` with the flow ``b.f``.

    Each step is taken, its dense output formed, its monitors bounded or scanned, and
    it is recorded in ``ST`` and ``PT``; ``b.x`` and ``b.f`` move with it. The steps end
    at ``t_stop``, at the first step in which monitors fire (then ``b.x`` is the state at
    the event, the monitors are ``hit_rows[:hit_n]`` and ``b.hit_grazing[:hit_n]``), or with
    a code: ``HANDOFF``, a budget (:data:`STEP_LIMIT`, :data:`TIME_LIMIT`,
    :data:`INTERRUPTED`).

    It borrows every array (no reference is counted in the loop, which runs once per
    step) and allocates nothing: where the records are full (:data:`_ROOM`) or the
    sampler outgrows ``sw`` (:data:`_RESAMPLE`) it returns before the step changes
    anything, and the kernel grows the arrays and calls again, which retakes the same
    step. Returns ``(status, code, t, h_abs, h_last, nst, npt, hit_n, next_look)``.

    Its buffers come in ``b`` and its options in ``opts_i`` and ``opts_f`` (as
    :func:`run_kernel` has them): CPython passes a call of more than 30 arguments as a
    built tuple, which numba then types as a tuple of first-class functions, an
    experimental feature it warns about.
    """
    sig, x, fcur, K, y_new, f_new, tmp, scale, coef = (b.sig, b.x, b.f, b.stages, b.y_new,
                                                        b.f_new, b.tmp, b.scale, b.coef)
    stats, hit_graz, now = b.stats, b.hit_grazing, b.now
    method, samples, max_refine = opts_i[0], opts_i[1], opts_i[2]
    rtol, atol, max_step, event_tol, event_atol = (opts_f[0], opts_f[1], opts_f[2], opts_f[3],
                                                   opts_f[4])
    fc = md.context
    act = fc.active
    M = armed.size
    n = x.size
    nc = coef.shape[0]
    max_steps, clock_id, deadline = watch[0], np.int32(watch[3]), watch[4]
    timed = watch[2] != 0  # the clock is read only where the C library has one
    code = COMPLETED
    while True:
        if nst >= ST.shape[0] or npt >= PT.shape[0]:
            return _ROOM, code, t, h_abs, h_last, nst, npt, 0, next_look
        ok, t_new, h_next, h = rk_step(model, method, fc, t, x, fcur, t_stop, h_abs, max_step,
                                       rtol, atol, p, sig, K, y_new, f_new, tmp, scale)
        stats[0] += 1
        if not ok or flag[0] != 0:
            return _DONE, HANDOFF, t, h_next, h_last, nst, npt, 0, next_look
        t_old = t
        dense_coefficients(model, method, fc, t_old, h, x, y_new, f_new, p, sig, K, tmp, coef)
        step = DenseStep(method, coef, t_old, h, x, act)
        if bounded and quiet_step(box, md, p, sig, step, t_old, t_new, event_atol, armed, bx,
                                  tr_guard, inv_group):
            nfire = 0
            stats[4] += 1
        else:
            nfire = scan(model, md, p, sig, ws, sw, step, armed, has_floor, floors, t_old,
                         t_new, samples, max_refine, event_tol, event_atol, stats)
            if nfire == OUTGROWN:  # nothing changed but the step count
                stats[0] -= 1
                return _RESAMPLE, code, t, h_abs, h_last, nst, npt, 0, next_look
            for r in range(M):
                armed[r] = sw.armed[r]
        h_abs = h_next
        h_last = t_new - t_old
        if flag[0] != 0:
            return _DONE, HANDOFF, t, h_abs, h_last, nst, npt, 0, next_look
        for r in range(M):
            if armed[r]:
                has_floor[r] = False
        ST[nst, 0] = t_old
        ST[nst, 1] = h
        for i in range(n):
            ST[nst, 2 + i] = x[i]
        for c in range(nc):
            for i in range(n):
                ST[nst, 2 + n + c * n + i] = coef[c, i]
        nst += 1
        if nfire > 0:
            t_event = sw.at[0]
            for i in range(1, nfire):
                t_event = min(t_event, sw.at[i])
            dense_eval(method, coef, t_old, h, x, act, t_event, tmp)
            for i in range(n):
                x[i] = tmp[i]
            PT[npt, 0] = t_event
            for i in range(n):
                PT[npt, 1 + i] = x[i]
            npt += 1
            for i in range(nfire):
                hit_rows[i] = sw.rows[i]
                hit_graz[i] = sw.grazing[i]
            return _DONE, code, t_event, h_abs, h_last, nst, npt, nfire, next_look
        PT[npt, 0] = t_new
        for i in range(n):
            PT[npt, 1 + i] = y_new[i]
            x[i] = y_new[i]
            fcur[i] = f_new[i]
        npt += 1
        t = t_new
        if stats[0] >= max_steps:
            code = STEP_LIMIT
        elif stats[0] % _WATCH_EVERY == 0:
            now_ns = 0
            if timed:
                clock_at(watch[2])(clock_id, ptr(now))
                now_ns = now[0] * 1_000_000_000 + now[1]
            hit = 0
            if watch[1] != 0 and (not timed or now_ns >= next_look):
                next_look = now_ns + _LOOK_EVERY_NS
                held = gil_ensure_at(watch[5])()  # CPython's flag is read under the GIL
                hit = interrupt_at(watch[1])()
                gil_release_at(watch[6])(held)
            if hit != 0:
                code = INTERRUPTED
            elif deadline > 0 and now_ns >= deadline:
                code = TIME_LIMIT
        if t_new >= t_stop or code != COMPLETED:
            return _DONE, code, t, h_abs, h_last, nst, npt, 0, next_look


#: the run loop's state between two calls of :func:`_run` (``si``: integers, ``sf``: reals)
_S_ACTION, _S_MODE, _S_JUMPS, _S_NEV, _S_NPT, _S_NST, _S_NSG, _S_HITS, _S_CODE = range(9)
_S_LOOK, _S_PHASE, _S_PASS, _S_PREVIOUS, _S_M, _S_BOUNDED, _S_LAST_MODE, _S_NEED = range(9, 17)
_N_SI = 17
_F_T, _F_H_LAST, _F_H_ABS, _F_T_STOP, _F_LAST_T = range(5)
_N_SF = 5
#: where :func:`_run` resumes: at the start of an action, at a pass of the event iteration,
#: in a flow segment's steps
_AT_ACTION, _AT_PASS, _AT_STEPS = 0, 1, 2
#: how :func:`_run` returns: the run is over (its code says how), the records need room
#: (``EV`` for ``si[_S_NEED]`` rows, ``SG``, ``PT`` and ``ST`` for one more), the
#: sampler's workspace must grow
_OVER, _GROW, _GROW_SAMPLES = 0, 1, 2


@numba.njit(cache=True, inline="always")
def _fill(a, v):
    for i in range(a.size):
        a[i] = v


@numba.njit(cache=True, inline="always")
def _copy(dst, src):
    for i in range(src.size):
        dst[i] = src[i]


@numba.njit(cache=True, inline="always")
def _copy2(dst, src):
    for i in range(src.shape[0]):
        for k in range(src.shape[1]):
            dst[i, k] = src[i, k]


@borrowing
def _run(model_address, box_address, tables, reals, opts_i, opts_f, t_end, p, n_sig, ztimes,
         zcount, sched_done, watch, ws, bx, sw, EV, PT, ST, SG, b, cp, si, sf):
    """The run loop: event iterations and flow segments until the run ends or needs room.

    Everything it touches is borrowed from :func:`run_kernel`, which owns the arrays: no
    reference is counted while it runs, once per event and per step. Where a record or
    the sampler's workspace is full it returns (:data:`_GROW`, :data:`_GROW_SAMPLES`)
    before the event pass, segment or step that needs the room changes anything, with
    its state in ``si`` and ``sf``; the kernel grows the array and calls it again, and
    it resumes there (``si[_S_PHASE]``). :data:`_OVER`: the run ended with
    ``si[_S_CODE]``.

    The model's point and box functions come as addresses, as to :func:`run_kernel`.
    """
    model = model_at(model_address)
    box = model_at(box_address)
    cgs = tables.cond_group
    inv_off, n_inv, n_sw = tables.invariant_offset, tables.n_invariants, tables.n_switches
    affine, out_ptr, out_list = tables.affine, tables.out_ptr, tables.out_list
    tr_target, tr_guard, tr_monitored = tables.tr_target, tables.tr_guard, tables.tr_monitored
    tr_sched, tr_sched_on, tr_reset = (tables.tr_scheduled, tables.tr_schedule_on,
                                       tables.tr_reset)
    sw_key, tr_zkey, n_cond = tables.switch_zeno_key, tables.tr_zeno_key, tables.n_conditions
    inv_box = tables.invariant_box
    period, phase = reals
    method, max_events, max_iter, window, use_bounds = (opts_i[0], opts_i[3], opts_i[4],
                                                        opts_i[5], opts_i[6])
    rtol, atol, max_step, event_tol, event_atol, zeno_tol = (
        opts_f[0], opts_f[1], opts_f[2], opts_f[3], opts_f[4], opts_f[5])
    x, sig, slm, W, eqv, sl_buffer = b.x, b.sig, b.slm, b.workspace, b.eq, b.sliding
    gv, gd, table, floors_b, phi0_b, dphi0_b = (b.guard, b.guard_lie, b.table, b.floors,
                                                b.phi0, b.dphi0)
    hit_graz, coef, y_new, fcur = b.hit_grazing, b.coef, b.y_new, b.f
    tmp, fired, fresh, grazing = b.tmp, b.fired, b.fresh, b.grazing
    sw_hit, ex_hit, kinds, stats, info, last_x = (b.switch_hit, b.exit_hit, b.kinds, b.stats,
                                                  b.info, b.last_x)
    cp_i, cp_f, cp_x, cp_sig, cp_slm = cp.position, cp.times, cp.x, cp.sigma, cp.sliding
    cp_zt, cp_zc, cp_sd, cp_rows, cp_graz = (cp.zeno_times, cp.zeno_counts, cp.schedules_done,
                                             cp.rows, cp.grazing)
    flag = W[flag_index(x.size, n_sig):]
    dummy = W
    n = x.size
    n_tr = tr_target.size
    order_err = 4 if method == 0 else 7
    w_sw = max(n_sig, 1)
    action, m, j, nev, npt = si[_S_ACTION], si[_S_MODE], si[_S_JUMPS], si[_S_NEV], si[_S_NPT]
    nst, nsg, hit_n, code, next_look = (si[_S_NST], si[_S_NSG], si[_S_HITS], si[_S_CODE],
                                        si[_S_LOOK])
    resume, first_pass, previous, M = si[_S_PHASE], si[_S_PASS], si[_S_PREVIOUS], si[_S_M]
    bounded, last_m = si[_S_BOUNDED] != 0, si[_S_LAST_MODE]
    t, h_last, h_abs, t_stop, last_t = (sf[_F_T], sf[_F_H_LAST], sf[_F_H_ABS], sf[_F_T_STOP],
                                        sf[_F_LAST_T])
    status = _OVER
    need = 0
    mk, mref, mstart, mlen = table[0, :M], table[1, :M], table[2, :M], table[3, :M]
    hit_rows = table[4, :M]
    armed, has_floor, floors = b.flags[0, :M], b.flags[1, :M], floors_b[:M]
    fc = _fc(tables, m, slm, W, sl_buffer)
    md = Monitors(fc, cgs[m], mk, mref, mstart, mlen, n_cond[m])
    while True:
        if action != _FLOW and resume != _AT_STEPS:
            stop = False
            if resume == _AT_ACTION:
                if action == _HANDLE and nev + n_sw[m] >= EV.shape[0]:
                    status, need = _GROW, nev + n_sw[m]
                    break
                # -------------------------------------------------------- checkpoint
                cp_i[0] = R_HANDLE if action == _HANDLE else R_ITERATE
                cp_i[1], cp_i[2], cp_i[3], cp_i[4] = m, j, nev, nsg
                cp_f[0], cp_f[1] = t, h_last
                _copy(cp_x, x)
                _copy(cp_sig, sig)
                _copy(cp_slm, slm)
                _copy2(cp_zt, ztimes)
                _copy(cp_zc, zcount)
                _copy(cp_sd, sched_done)
                _fill(fresh, False)
                _fill(grazing, False)
                if action == _HANDLE:
                    cp_i[5] = hit_n
                    for i in range(hit_n):
                        cp_rows[i] = hit_rows[i]
                        cp_graz[i] = hit_graz[i]
                    # ---------------------------------------------------- handle
                    _fill(sw_hit, False)
                    _fill(ex_hit, False)
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
                        if update_switches(model, fc, affine[m], t, x, p, sig, slm, sw_hit,
                                           ex_hit, kinds, b.switch_reals, b.switch_flags,
                                           b.switch_index) != OK:
                            code = HANDOFF
                            break
                        fc = _fc(tables, m, slm, W, sl_buffer)
                        for k in range(n_sw[m]):
                            if kinds[k] == 0:
                                continue
                            _log(EV, nev, t, j, k, m, m, kinds[k], False, x, x)
                            nev += 1
                            if nev >= max_events:
                                code = MAX_EVENTS
                                stop = True
                                break
                            if _zeno_stop(ztimes, zcount, sw_key[m * w_sw + k], t, window,
                                          zeno_tol, ZENO_RESOLUTION * event_tol, info):
                                last_t, last_m = t, m
                                _copy(last_x, x)
                                code = ZENO
                                stop = True
                                break
                        if stop:
                            break
                # ------------------------------------------------------------ event iteration
                _fill(fired, False)
                previous = -1
                first_pass = 0
            settled = False
            for it in range(first_pass, max_iter):
                if nev >= EV.shape[0]:  # room for this pass's jump
                    status, need, first_pass = _GROW, nev, it
                    resume = _AT_PASS
                    stop = True
                    break
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
                _copy(tmp, x)
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
                _log(EV, nev, t, j, chosen, m, target, 0, grazing[chosen], tmp, y_new)
                nev += 1
                _copy(x, y_new)
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
                        _copy(last_x, x)
                        code = ZENO
                        stop = True
                        break
                m = target
                _fill(slm, False)
                fc = _fc(tables, m, slm, W, sl_buffer)
                if enter_mode(model, fc, affine[m], t, x, p, sig, slm, event_atol,
                              b.switch_reals, b.switch_flags, b.switch_index) != OK:
                    code = HANDOFF
                    stop = True
                    break
                fc = _fc(tables, m, slm, W, sl_buffer)
                _fill(fresh, False)
            if stop:
                break
            resume = _AT_ACTION
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
            _copy(last_x, x)
            any_fired = False
            for tr in range(fired.size):
                any_fired = any_fired or fired[tr]
            if action == _HANDLE and not any_fired:
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
        if resume != _AT_STEPS:
            if not t < t_end:
                break
            t_stop = t_end
            for oi in range(out_ptr[m], out_ptr[m + 1]):
                tr = out_list[oi]
                if tr_sched[tr] == 1 and tr_sched_on[tr] == 1:
                    kk = _sched_index(t, phase[tr], period[tr], sched_done[tr])
                    t_stop = min(t_stop, phase[tr] + kk * period[tr])
        if resume == _AT_STEPS or t_stop - t > xtol_at(event_tol, t):
            if resume != _AT_STEPS:
                # -------------------------------------------------------- flow segment
                if nsg >= SG.shape[0] or npt >= PT.shape[0]:
                    status = _GROW
                    break
                cp_i[0], cp_i[1], cp_i[2], cp_i[3], cp_i[4] = R_FLOW, m, j, nev, nsg
                cp_f[0], cp_f[1] = t, h_last
                _copy(cp_x, x)
                _copy(cp_sig, sig)
                _copy(cp_slm, slm)
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
                        mk[r], mref[r], mstart[r], mlen[r] = (GUARD, tr, row0,
                                                              tr_monitored[n_tr + tr])
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
                SG[nsg, 0], SG[nsg, 1], SG[nsg, 2], SG[nsg, 4] = m, j, npt, nst
                PT[npt, 0] = t
                for i in range(n):
                    PT[npt, 1 + i] = x[i]
                npt += 1
                armed, has_floor, floors = b.flags[0, :M], b.flags[1, :M], floors_b[:M]
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
                    h_abs = initial_step(model, fc, t, x, fcur, t_stop, max_step, order_err,
                                         rtol, atol, p, sig)
                hit_n = 0
                hit_rows = table[4, :M]
                for c in range(coef.shape[0]):  # the columns outside the active set stay zero
                    for i in range(n):
                        coef[c, i] = 0.0
            steps, code, t, h_abs, h_last, nst, npt, hit_n, next_look = _steps(
                model, box, md, p, ws, sw, bx, b, tr_guard, inv_box[m], flag, armed,
                has_floor, floors, bounded, opts_i, opts_f, t, t_stop, h_abs, h_last, ST, nst,
                PT, npt, hit_rows, watch, next_look)
            if steps != _DONE:
                status = _GROW if steps == _ROOM else _GROW_SAMPLES
                resume = _AT_STEPS
                break
            resume = _AT_ACTION
            SG[nsg, 3] = npt - SG[nsg, 2]
            SG[nsg, 5] = nst - SG[nsg, 4]
            nsg += 1
            if code == HANDOFF:
                break
            stats[3] += 1
            last_t, last_m = t, m
            _copy(last_x, x)
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
        break
    si[_S_ACTION], si[_S_MODE], si[_S_JUMPS], si[_S_NEV], si[_S_NPT] = action, m, j, nev, npt
    si[_S_NST], si[_S_NSG], si[_S_HITS], si[_S_CODE], si[_S_LOOK] = (nst, nsg, hit_n, code,
                                                                     next_look)
    si[_S_PHASE], si[_S_PASS], si[_S_PREVIOUS], si[_S_M] = resume, first_pass, previous, M
    si[_S_BOUNDED], si[_S_LAST_MODE], si[_S_NEED] = 1 if bounded else 0, last_m, need
    sf[_F_T], sf[_F_H_LAST], sf[_F_H_ABS], sf[_F_T_STOP], sf[_F_LAST_T] = (t, h_last, h_abs,
                                                                          t_stop, last_t)
    return status


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
    model = model_at(model_address)  # for entering the first mode; _run takes its own
    n_inv, n_sw, out_ptr, out_list = (tables.n_invariants, tables.n_switches, tables.out_ptr,
                                      tables.out_list)
    tr_target, tr_monitored, n_cond = tables.tr_target, tables.tr_monitored, tables.n_conditions
    method, samples = opts_i[0], opts_i[1]
    event_atol = opts_f[4]
    n = x.size
    n_tr = tr_target.size
    nk, nc = N_K[method], N_COEF[method]
    x = x.copy()
    ns = max(n_sig, 1)
    sig = np.ones(ns)
    slm = np.zeros(ns, dtype=np.bool_)
    W = workspace(n, n_sig)
    sl_buffer = np.empty(ns, dtype=np.int64)  # the sliding indices of the flow context
    n_cmax = max(np.max(n_cond), 1)
    ws = LocateWorkspace(np.empty(n), np.empty(n), np.empty(2 * n_cmax), np.empty(n_cmax),
                         np.empty(2 * ns), np.empty(ns), np.empty(ns))
    bx = box_workspace(n, n_cmax, ns)
    gv = np.empty(max(np.max(tr_monitored[n_tr:]) if n_tr else 1, 1))
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
    switch_reals, switch_flags, switch_index = switch_scratch(n, n_sig)
    b = RunBuffers(x, sig, slm, W, np.empty(ns), sl_buffer, gv, np.empty(gv.size),
                   np.empty((5, m_max), dtype=np.int64),  # kind, ref, start, length, hit rows
                   np.zeros((2, m_max), dtype=np.bool_),  # armed, has a floor
                   np.zeros(m_max), np.empty((m_max, 1)), np.empty((m_max, 1)),
                   np.zeros(m_max, dtype=np.bool_), np.empty((nk, n)), np.empty((nc, n)),
                   np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n),
                   np.zeros(max(n_tr, 1), dtype=np.bool_), np.zeros(max(n_tr, 1), dtype=np.bool_),
                   np.zeros(max(n_tr, 1), dtype=np.bool_), np.zeros(ns, dtype=np.bool_),
                   np.zeros(ns, dtype=np.bool_), np.zeros(ns, dtype=np.int64),
                   # steps, refinements, events_located, segments, steps proven quiet
                   np.zeros(5, dtype=np.int64), np.zeros(4), x.copy(),
                   np.zeros(2, dtype=np.int64), switch_reals, switch_flags, switch_index)
    EV = np.empty((64, 7 + 2 * n))
    PT = np.empty((256, 1 + n))
    ST = np.empty((256, 2 + n + nc * n))
    SG = np.empty((64, 6), dtype=np.int64)
    # checkpoint: kind, mode, j, events, segments, triggers; t, h_last; state; signs; ...
    # (its rows and grazing flags: buffers of which the first triggers count)
    cp = KernelCheckpoint(np.zeros(6, dtype=np.int64), np.zeros(2), x.copy(), sig.copy(),
                          slm.copy(), ztimes.copy(), zcount.copy(), sched_done.copy(),
                          np.zeros(m_max, dtype=np.int64), np.zeros(m_max, dtype=np.bool_))
    si = np.zeros(_N_SI, dtype=np.int64)
    sf = np.zeros(_N_SF)
    si[_S_ACTION], si[_S_MODE], si[_S_LAST_MODE], si[_S_CODE] = _ITERATE, m, m, COMPLETED
    sf[_F_T], sf[_F_H_LAST], sf[_F_LAST_T] = t, -1.0, t
    fc = _fc(tables, m, slm, W, sl_buffer)
    if enter_mode(model, fc, tables.affine[m], t, x, p, sig, slm, event_atol, b.switch_reals,
                  b.switch_flags, b.switch_index) != OK:
        cp.position[0] = R_START
        si[_S_CODE] = HANDOFF
    else:
        while True:
            status = _run(model_address, box_address, tables, reals, opts_i, opts_f, t_end, p,
                          n_sig, ztimes, zcount, sched_done, watch, ws, bx, sw, EV, PT, ST, SG,
                          b, cp, si, sf)
            if status == _OVER:
                break
            if status == _GROW_SAMPLES:
                sw = sample_workspace(m_max, 2 * sw.times.size)
                continue
            while si[_S_NEED] >= EV.shape[0]:
                EV = _grow(EV, si[_S_NEED])
            PT = _grow(PT, si[_S_NPT])
            ST = _grow(ST, si[_S_NST])
            SG = _grow(SG, si[_S_NSG])
    code = si[_S_CODE]
    if code == HANDOFF and cp.position[0] == R_FLOW:
        # a flow segment changes neither the Zeno history nor the schedules
        cp.zeno_times[:] = ztimes
        cp.zeno_counts[:] = zcount
        cp.schedules_done[:] = sched_done
    nev, npt, nst, nsg, hits = si[_S_NEV], si[_S_NPT], si[_S_NST], si[_S_NSG], cp.position[5]
    return KernelResult(code, EV[:nev].copy(), PT[:npt].copy(), ST[:nst].copy(),
                        SG[:nsg].copy(), b.stats, b.info, sf[_F_LAST_T], b.last_x,
                        si[_S_LAST_MODE], si[_S_JUMPS], sf[_F_H_LAST],
                        KernelCheckpoint(cp.position, cp.times, cp.x, cp.sigma, cp.sliding,
                                         cp.zeno_times, cp.zeno_counts, cp.schedules_done,
                                         cp.rows[:hits].copy(), cp.grazing[:hits].copy()))
