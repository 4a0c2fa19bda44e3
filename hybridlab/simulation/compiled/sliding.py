"""Filippov sliding in numba: a port of ``simulation/sliding.py`` and the engine's sign logic.

A *flow context* ``fc`` (:class:`~.layout.FlowContext`) describes the
current flow: the model groups of the flow, the switching functions, their
state gradient and the flow's sigma-Jacobian, the mode's number of switches
``m``, the sliding switches ``sl`` (an index array, usually empty), a
workspace ``W`` (see :func:`workspace`), the group of the fused sliding op
(flow, switch Lie derivatives, gradient and sigma-Jacobian in one call),
whether the switching functions are free of the signs, and the mode's
*active* states (an index array: those whose flow is not identically zero or
that a switching function reads; the integrator combines only these). With
``sl`` empty every function here is a plain flow call; while switches slide:

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
matrix, sliding on a flow that is not affine in sigma) set the workspace flag
(:func:`flag_index`) or return a non-zero status; the kernel then hands the
run to the reference.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from hybridlab.simulation.compiled.layout import FlowContext
from hybridlab.simulation.compiled.opcodes import (
    OP_FLOW,
    OP_SLIDE_PARTS,
    OP_SWITCH,
    OP_SWITCH_GRAD,
    OP_SWITCH_LIE,
)
from hybridlab.simulation.compiled.signatures import borrowing, ptr, ptr_at
from hybridlab.simulation.rules import EQUAL_SLOPES, EQUIVALENT_SIGN_SLACK

__all__ = ["workspace", "flag_index", "equivalent", "equivalent_signs", "flow_sliding",
           "flow_eq", "rhs", "enter_mode", "resolve", "update_switches",
           "switch_scratch", "OK",
           "NOT_AFFINE", "SINGULAR"]

OK, NOT_AFFINE, SINGULAR = 0, 1, 2


@numba.njit(cache=True, inline="always")
def _layout(n, ns):
    """Offsets in the flat workspace: sigma, base, lie, grad, A, b, sol, flag, parts, end.

    The first ``n`` entries are a scratch input for ops that read no flow. One
    flat array (instead of a tuple of arrays) keeps reference counting out of
    the right-hand side, which runs a dozen times per step.
    """
    o_sig = n
    o_base = o_sig + ns
    o_lie = o_base + ns
    o_grad = o_lie + ns
    o_a = o_grad + ns * n
    o_b = o_a + ns * ns
    o_sol = o_b + ns
    o_flag = o_sol + ns
    o_parts = o_flag + 1
    return o_sig, o_base, o_lie, o_grad, o_a, o_b, o_sol, o_flag, o_parts, \
        o_parts + n + ns + 2 * ns * n


@numba.njit(cache=True)
def workspace(n, n_sig):
    """The flat scratch array of a flow context (see :func:`_layout`)."""
    return np.zeros(_layout(n, max(n_sig, 1))[9])


@numba.njit(cache=True)
def flag_index(n, n_sig):
    """Where a failure (a singular sliding system) is flagged in the workspace."""
    return _layout(n, max(n_sig, 1))[7]


@numba.njit(cache=True, inline="always")
def _solve(W, oa, ob, k, out, oo):
    """Solve ``A y = b`` (``k x k`` row-major at ``W[oa:]``, ``b`` at ``W[ob:]``) into
    ``out[oo:oo + k]`` by partial pivoting (A and b are destroyed)."""
    for c in range(k):
        piv = c
        for r in range(c + 1, k):
            if abs(W[oa + r * k + c]) > abs(W[oa + piv * k + c]):
                piv = r
        if W[oa + piv * k + c] == 0.0 or not np.isfinite(W[oa + piv * k + c]):
            return False
        if piv != c:
            for q in range(k):
                W[oa + c * k + q], W[oa + piv * k + q] = W[oa + piv * k + q], W[oa + c * k + q]
            W[ob + c], W[ob + piv] = W[ob + piv], W[ob + c]
        for r in range(c + 1, k):
            factor = W[oa + r * k + c] / W[oa + c * k + c]
            for q in range(c, k):
                W[oa + r * k + q] -= factor * W[oa + c * k + q]
            W[ob + r] -= factor * W[ob + c]
    for c in range(k - 1, -1, -1):
        acc = W[ob + c]
        for q in range(c + 1, k):
            acc -= W[oa + c * k + q] * out[oo + q]
        out[oo + c] = acc / W[oa + c * k + c]
    return True


@numba.njit(cache=True, inline="always")
def equivalent_signs(model, fg_p, m, sl, act, W, t, x, p, sig, eq):
    """:func:`equivalent` on the unpacked flow context (for loops that bind it once)."""
    n = x.size
    o_sig, o_base, _, _, o_a, o_b, _, o_flag, o_parts, _ = _layout(n, sig.size)
    k = sl.size
    for i in range(sig.size):
        W[o_base + i] = sig[i]
    for a in range(k):
        W[o_base + sl[a]] = 0.0
    model(OP_SLIDE_PARTS, fg_p, t, ptr(x), ptr(p), ptr_at(W, o_base), ptr(W),
          ptr_at(W, o_parts))
    og, od = o_parts + n + m, o_parts + n + m + m * n
    for a in range(k):
        for c in range(k):
            acc = 0.0
            for q in range(act.size):  # grad s and F_sigma vanish outside the active set
                i = act[q]
                acc += W[og + sl[a] * n + i] * W[od + i * m + sl[c]]
            W[o_a + a * k + c] = acc
        W[o_b + a] = -W[o_parts + n + sl[a]]
    if not _solve(W, o_a, o_b, k, eq, 0):
        W[o_flag] = 1.0
        return False
    return True


@numba.njit(cache=True, inline="always")
def equivalent(model, fc, t, x, p, sig, eq):
    """Equivalent signs of the sliding switches ``fc.sliding`` at ``(t, x)`` into ``eq``.

    Leaves ``[f0 | ds/dt | grad s | F_sigma]`` at ``sigma_S = 0`` in the workspace.
    """
    return equivalent_signs(model, fc.slide_group, fc.n_switches, fc.sliding, fc.active,
                            fc.workspace, t, x, p, sig, eq)


@numba.njit(cache=True, inline="always")
def flow_sliding(model, pg, m, sl, act, W, t, x, p, sig, out, eq):
    """The flow with the equivalent signs of the sliding switches ``sl`` (see :func:`flow_eq`)."""
    ok = equivalent_signs(model, pg, m, sl, act, W, t, x, p, sig, eq)
    n = x.size
    o_sig, o_parts = n, _layout(n, sig.size)[8]
    for i in range(sig.size):
        W[o_sig + i] = sig[i]
    for a in range(sl.size):
        W[o_sig + sl[a]] = eq[a]
    od = o_parts + n + m + m * n
    for i in range(n):
        out[i] = W[o_parts + i]
    for q in range(act.size):  # affine in sigma: f(sigma) = f(sigma_S = 0) + F_sigma sigma_S
        i = act[q]
        acc = W[o_parts + i]
        for a in range(sl.size):
            acc += W[od + i * m + sl[a]] * eq[a]
        out[i] = acc
    return ok


@borrowing
def _flow_eq_sliding(model, fc, t, x, p, sig, out, eq):
    return flow_sliding(model, fc.slide_group, fc.n_switches, fc.sliding, fc.active,
                        fc.workspace, t, x, p, sig, out, eq)


@numba.njit(cache=True, inline="always")
def flow_eq(model, fc, t, x, p, sig, out, eq):
    """The flow with the equivalent signs (``eq`` receives them); False if singular."""
    if fc.sliding.size == 0:
        model(OP_FLOW, fc.flow_group, t, ptr(x), ptr(p), ptr(sig), ptr(fc.workspace), ptr(out))
        return True
    return _flow_eq_sliding(model, fc, t, x, p, sig, out, eq)


@numba.njit(cache=True, inline="always")
def _rhs_sliding(model, fc, t, x, p, sig, out):
    m, sl, W, act = fc.n_switches, fc.sliding, fc.workspace, fc.active
    n = x.size
    o_sig, _, o_lie, o_grad, o_a, o_b, o_sol, o_flag, o_parts, _ = _layout(n, sig.size)
    flow_sliding(model, fc.slide_group, m, sl, act, W, t, x, p, sig, out, W[o_sol:o_sol + sig.size])
    # remove the rounding-level drift off the sliding surfaces (as the reference does);
    # the gradients vanish outside the active set (it holds every state a switch reads)
    k = sl.size
    if fc.switch_free:
        # switching functions free of sigma: gradient and ds/dt as at sigma_S = 0
        og = o_parts + n + m
        for a in range(k):
            acc = W[o_parts + n + sl[a]]
            for i in range(n):
                W[o_grad + sl[a] * n + i] = W[og + sl[a] * n + i]
            for q in range(act.size):
                i = act[q]
                acc += W[og + sl[a] * n + i] * (out[i] - W[o_parts + i])
            W[o_lie + sl[a]] = acc
    else:
        model(OP_SWITCH_GRAD, fc.grad_group, t, ptr(x), ptr(p), ptr_at(W, o_sig), ptr(W),
              ptr_at(W, o_grad))
        model(OP_SWITCH_LIE, fc.switch_group, t, ptr(x), ptr(p), ptr_at(W, o_sig), ptr(out),
              ptr_at(W, o_lie))
    for a in range(k):
        for c in range(k):
            acc = 0.0
            for q in range(act.size):
                i = act[q]
                acc += W[o_grad + sl[a] * n + i] * W[o_grad + sl[c] * n + i]
            W[o_a + a * k + c] = acc
        W[o_b + a] = W[o_lie + sl[a]]
    if not _solve(W, o_a, o_b, k, W, o_sol):
        W[o_flag] = 1.0
        return
    for q in range(act.size):
        i = act[q]
        acc = 0.0
        for a in range(k):
            acc += W[o_grad + sl[a] * n + i] * W[o_sol + a]
        out[i] -= acc


@numba.njit(cache=True, inline="always")
def rhs(model, fc, t, x, p, sig, out):
    """The integrator's right-hand side: the flow, projected onto the sliding surfaces."""
    if fc.sliding.size == 0:
        model(OP_FLOW, fc.flow_group, t, ptr(x), ptr(p), ptr(sig), ptr(fc.workspace), ptr(out))
    else:
        _rhs_sliding(model, fc, t, x, p, sig, out)


@borrowing
def _sdot(model, fc, t, x, p, sigma, k, f, lie):
    fg, sg = fc.flow_group, fc.switch_group
    model(OP_FLOW, fg, t, ptr(x), ptr(p), ptr(sigma), ptr(fc.workspace), ptr(f))
    model(OP_SWITCH_LIE, sg, t, ptr(x), ptr(p), ptr(sigma), ptr(f), ptr(lie))
    return lie[k]


@borrowing
def _sides(model, fc, t, x, p, sig, k, f, lie, tmp):
    for i in range(sig.size):
        tmp[i] = sig[i]
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


@numba.njit(cache=True, inline="always")
def _active_into(slm, m, idx):
    """The sliding set's indices into ``idx``; returns their count."""
    c = 0
    for k in range(m):
        if slm[k]:
            idx[c] = k
            c += 1
    return c


#: the slots of the sign bookkeeping's real scratch (:func:`switch_scratch`), each as long
#: as the signs, after a state-sized one
_R_LIE, _R_TMP, _R_EQ, _R_PREVIOUS, _R_DP, _R_DM, _R_OLD, _R_EQ_OLD, _R_FORCED = range(9)
_N_REAL_SLOTS = 9
#: the slots of its flag scratch
_B_AT_SURFACE, _B_FORCED, _B_OLD_SLM = range(3)
_N_FLAG_SLOTS = 3


@numba.njit(cache=True)
def switch_scratch(n, n_sig):
    """The scratch of :func:`enter_mode`, :func:`update_switches` and :func:`resolve` for
    ``n`` states and ``n_sig`` switches: reals, flags and indices, allocated once per run
    (they run at every event of a mode with switches)."""
    ns = max(n_sig, 1)
    return (np.zeros(n + _N_REAL_SLOTS * ns), np.zeros(_N_FLAG_SLOTS * ns, dtype=np.bool_),
            np.zeros(ns, dtype=np.int64))


@numba.njit(cache=True, inline="always")
def _slot(a, n, ns, k):
    """Slot ``k`` of a scratch array: ``ns`` entries after ``n`` leading ones."""
    return a[n + k * ns:n + (k + 1) * ns]


@borrowing
def resolve(model, fc, affine, t, x, p, sig, at_surface, forced, forced_value, slm, reals,
            index):
    """``resolve_switches``: new signs into ``sig``, the sliding set into ``slm``; a status.

    ``reals`` and ``index`` are its scratch (:func:`switch_scratch`); it allocates nothing.
    """
    fg, sg, gg, dg, m, W = (fc.flow_group, fc.switch_group, fc.grad_group, fc.dsigma_group,
                             fc.n_switches, fc.workspace)
    n = x.size
    ns = sig.size
    f = reals[:n]
    lie, tmp, eq = _slot(reals, n, ns, _R_LIE), _slot(reals, n, ns, _R_TMP), _slot(reals, n, ns,
                                                                                  _R_EQ)
    previous = _slot(reals, n, ns, _R_PREVIOUS)
    for k in range(ns):
        previous[k] = sig[k]
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
            if abs(d_plus - d_minus) <= EQUAL_SLOPES * (abs(d_plus) + abs(d_minus)):
                _leave(sig, previous, slm, k, d_plus, d_minus)
    count = _active_into(slm, m, index)
    dp, dm = _slot(reals, n, ns, _R_DP), _slot(reals, n, ns, _R_DM)
    for _ in range(2 * count + 2):
        idx = index[:_active_into(slm, m, index)]
        if idx.size == 0:
            break
        if not affine:
            return NOT_AFFINE
        for a in range(idx.size):
            sig[idx[a]] = 0.0
        sub = FlowContext(fg, sg, gg, dg, m, idx, W, fc.slide_group, fc.switch_free, fc.active)
        if not equivalent(model, sub, t, x, p, sig, eq):
            return SINGULAR
        outside = False
        for a in range(idx.size):
            sig[idx[a]] = eq[a]
        for a in range(idx.size):
            if abs(eq[a]) > 1 + EQUIVALENT_SIGN_SLACK:
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


@borrowing
def enter_mode(model, fc, affine, t, x, p, sig, slm, event_atol, reals, flags, index):
    """Fresh signs for a mode's switches at ``(t, x)`` (``fc`` without sliding); its
    scratch is ``reals``, ``flags`` and ``index`` (:func:`switch_scratch`)."""
    m = fc.n_switches
    n = x.size
    ns = sig.size
    for k in range(slm.size):  # (element loops: a slice assignment needs numba's runtime)
        slm[k] = False
    if m == 0:
        return OK
    s = _slot(reals, n, ns, _R_OLD)
    at_surface, forced = _slot(flags, 0, ns, _B_AT_SURFACE), _slot(flags, 0, ns, _B_FORCED)
    for k in range(ns):
        at_surface[k] = False
        forced[k] = False
        sig[k] = 1.0
    model(OP_SWITCH, fc.switch_group, t, ptr(x), ptr(p), ptr(sig), ptr(fc.workspace), ptr(s))
    for k in range(m):
        at_surface[k] = abs(s[k]) <= event_atol
        sig[k] = 1.0 if s[k] >= 0 else -1.0
    return resolve(model, fc, affine, t, x, p, sig, at_surface, forced, sig, slm, reals, index)


@numba.njit(cache=True)
def _sign(v):
    return 0.0 if v == 0 else (1.0 if v > 0 else (-1.0 if v < 0 else v))


@borrowing
def update_switches(model, fc, affine, t, x, p, sig, slm, switches, exits, kinds, reals, flags,
                    index):
    """``_Run.update_switches`` without the logging: ``kinds[k]`` 1 crossing, 2 slide start,
    3 slide end for every switch hit; ``fc`` carries the sliding set before the event. Its
    scratch is ``reals``, ``flags`` and ``index`` (:func:`switch_scratch`)."""
    m = fc.n_switches
    sl = fc.sliding
    n = x.size
    ns = sig.size
    old = _slot(reals, n, ns, _R_OLD)
    for k in range(ns):
        old[k] = sig[k]
    if sl.size:
        eq = _slot(reals, n, ns, _R_EQ_OLD)
        if not equivalent(model, fc, t, x, p, sig, eq):
            return SINGULAR
        for a in range(sl.size):
            old[sl[a]] = eq[a]
    old_slm = _slot(flags, 0, ns, _B_OLD_SLM)
    forced, at_surface = _slot(flags, 0, ns, _B_FORCED), _slot(flags, 0, ns, _B_AT_SURFACE)
    forced_value = _slot(reals, n, ns, _R_FORCED)
    for k in range(ns):
        old_slm[k] = slm[k]
        forced[k] = False
        forced_value[k] = 0.0
        at_surface[k] = False
    for k in range(m):
        if exits[k]:
            forced[k] = True
            forced_value[k] = _sign(old[k])
        at_surface[k] = switches[k] or (old_slm[k] and not exits[k])
    status = resolve(model, fc, affine, t, x, p, sig, at_surface, forced, forced_value, slm,
                     reals, index)
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
