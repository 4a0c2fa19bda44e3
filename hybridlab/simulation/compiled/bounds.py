"""Steps proven quiet by interval bounds: the sampler skipped where it cannot find anything.

Before sampling a step's monitors, the kernel encloses the step: the dense
output's range per state (:func:`state_box`, an interval evaluation of the
interpolant over ``[0, 1]``), the time interval, and from them the range of
every condition and switching function (the generated model's box ops,
:mod:`.box_printer`). When every monitor's lower bound is above the
tolerance, no point of the dense output can bring it down to zero, so the
sampler and the location search would find nothing: :func:`quiet_step`
says so, and the kernel moves on with every monitor armed.

This is exact, not an approximation. The location search only reports a
monitor at a time where its computed value reaches the tolerance (every
report rests on an evaluation of the monitor on the dense output, see
:mod:`.locate`), and the bounds enclose every such evaluation, rounding
included (:mod:`hybridlab.symbolic.interval_arithmetic`). A monitor that is
disarmed and proven above the tolerance is the same case: the sampler would re-arm it and find
nothing. Steps with a sliding exit are never skipped (the equivalent signs
have no interval version), nor are steps with a disarmed monitor that may stay
below the tolerance: there the sampler's own cubic estimate decides when the
monitor re-arms.
"""

from __future__ import annotations

import numba
import numpy as np

from hybridlab.simulation.compiled.integrate import RK45
from hybridlab.simulation.compiled.layout import BoxWorkspace
from hybridlab.simulation.compiled.locate import GUARD, INVARIANT, SWITCH
from hybridlab.simulation.compiled.opcodes import OP_GUARD_BOX, OP_INV_BOX, OP_SWITCH_BOX
from hybridlab.simulation.compiled.signatures import borrowing, ptr
from hybridlab.symbolic.interval_arithmetic import TINY, WIDEN

__all__ = ["state_box", "quiet_step", "box_workspace"]


@numba.njit(cache=True)
def box_workspace(n, n_cond, n_sig):
    """Buffers for :func:`quiet_step`: states ``[lo | hi]``, time, and the bounds of a
    guard's rows, of the invariants and of the switching functions."""
    return BoxWorkspace(np.empty(2 * n), np.empty(2), np.empty(2 * max(n_cond, 1)),
                        np.empty(2 * max(n_cond, 1)), np.empty(2 * max(n_sig, 1)))


@borrowing
def state_box(method, coef, h, y_old, act, box):
    """The range of every state over the step into ``box = [lo | hi]``.

    The interpolant is evaluated in interval arithmetic with its abscissa
    ``x`` (and ``1 - x``) ranging over ``[0, 1]``, in the nested form the
    sampler evaluates (:func:`.locate._batch`). The bounds are widened by 64
    units in the last place of the sum of the terms' magnitudes, which covers
    the rounding of any evaluation of the interpolant. States outside the
    active set keep their value exactly.

    Examples
    --------
    >>> coef = np.array([[1.0], [0.0], [0.0], [0.0]])  # RK45 form of y' = 1
    >>> box = np.empty(2)
    >>> state_box(0, coef, 0.5, np.array([2.0]), np.array([0]), box)
    >>> bool(box[0] <= 2.0 and 2.5 <= box[1] < 2.5 + 1e-12)
    True
    """
    n = y_old.size
    nco = coef.shape[0]
    for q in range(n):
        box[q] = y_old[q]
        box[n + q] = y_old[q]
    for a in range(act.size):
        q = act[a]
        lo = 0.0
        hi = 0.0
        mag = 0.0
        for k in range(nco):
            c = coef[nco - 1 - k, q]
            lo += c
            hi += c
            mag += abs(c)
            # times x (or 1 - x) in [0, 1]
            lo = min(lo, 0.0)
            hi = max(hi, 0.0)
        if method == RK45:  # y_old + h * (the polynomial)
            lo, hi = min(h * lo, h * hi), max(h * lo, h * hi)
            mag *= abs(h)
        d = WIDEN * (mag + abs(y_old[q])) + TINY
        box[q] = y_old[q] + lo - d
        box[n + q] = y_old[q] + hi + d


@borrowing
def quiet_step(box_model, md, p, sig, step, t0, t1, tol, armed, bx, guard_group, inv_group):
    """Whether no monitor can reach ``tol`` on ``[t0, t1]`` of the step (then arm them all).

    ``box_model`` is the generated model's box function; ``md`` and ``step``
    are the monitor table and step tuple of :func:`.locate.scan`; ``bx``
    comes from :func:`box_workspace`; ``guard_group`` is the box group of each
    transition's guard and ``inv_group`` that of the mode's invariants. The
    monitors are bounded one by one and the first that cannot be proven ends
    the attempt.
    """
    mk, mref, mlen = md.kind, md.ref, md.length
    box, tb, gb, ib, sb = bx.states, bx.time, bx.guard, bx.invariants, bx.switches
    m = md.context.n_switches
    sg = md.context.switch_group
    for r in range(mk.size):
        # a sliding exit has no enclosure
        if mk[r] != GUARD and mk[r] != INVARIANT and mk[r] != SWITCH:
            return False
        if mk[r] == SWITCH and sig[mref[r]] == 0.0:
            return False
    state_box(step.method, step.coef, step.h, step.y_old, step.active, box)
    tb[0] = t0 - (WIDEN * abs(t0) + TINY)
    tb[1] = t1 + (WIDEN * abs(t1) + TINY)
    invariants = switches = False
    for r in range(mk.size):
        kind = mk[r]
        if kind == GUARD:
            # the guard's value is max_i(-g_i): above -g_i's lower bound for every row i
            box_model(OP_GUARD_BOX, guard_group[mref[r]], t0, ptr(box), ptr(p), ptr(sig),
                      ptr(tb), ptr(gb))
            lo = -np.inf
            for q in range(mlen[r]):
                lo = max(lo, -gb[mlen[r] + q])
        elif kind == INVARIANT:
            if not invariants:
                box_model(OP_INV_BOX, inv_group, t0, ptr(box), ptr(p), ptr(sig), ptr(tb),
                          ptr(ib))
                invariants = True
            lo = ib[mref[r]]
        else:
            if not switches:
                box_model(OP_SWITCH_BOX, sg, t0, ptr(box), ptr(p), ptr(sig), ptr(tb),
                          ptr(sb))
                switches = True
            s = sig[mref[r]]
            lo = s * sb[mref[r]] if s > 0 else s * sb[m + mref[r]]
        if not lo > tol:
            return False
    for r in range(mk.size):
        armed[r] = True
    return True
