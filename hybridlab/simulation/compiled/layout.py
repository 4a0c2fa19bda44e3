"""The tables the kernel reads a model from, by name.

:class:`ModelTables` holds, as int64 arrays, everything the kernel needs to know about a
model's modes and transitions beyond its generated functions: which function group
computes what, the outgoing transitions of each mode, the guards, schedules and resets,
the Zeno keys, the states each mode integrates. It is a ``namedtuple`` defined in an
importable module, which numba passes by value and caches on disk.

Per mode ``m``: ``flow_group[m]``, ``cond_group[m]``, ``switch_group[m]``,
``grad_group[m]``, ``dsigma_group[m]``, ``slide_group[m]``, ``invariant_box[m]``
(function groups, :mod:`.opcodes`); ``invariant_offset[m]`` and ``n_invariants[m]``
(its invariant rows among its condition rows, ``n_conditions[m]`` in all);
``n_switches[m]``; ``affine[m]`` (its flow is affine in the sign symbols);
``switch_free[m]`` (its switching functions do not depend on the signs); its outgoing
transitions ``out_list[out_ptr[m]:out_ptr[m + 1]]``; the states it integrates
``active_list[active_ptr[m]:active_ptr[m + 1]]``; the Zeno key of its switch ``k`` at
``switch_zeno_key[m * max(n_sig, 1) + k]``.

Per transition ``i``: ``tr_target[i]``, ``tr_guard[i]`` (its guard's group, -1 for
none), ``tr_reset[i]``, ``tr_scheduled[i]`` and ``tr_schedule_on[i]`` (0/1: time-triggered,
and enabled for this run's parameters), ``tr_zeno_key[i]``, and ``tr_monitored``: 1 at
``i`` if its guard is watched during flows, its number of guard rows at
``max(n_tr, 1) + i``. :class:`ModelTables` shows a model's tables.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["BoxWorkspace", "DenseStep", "FlowContext", "KernelCheckpoint", "KernelResult",
           "LocateWorkspace", "ModelTables", "Monitors", "Probe", "RunBuffers", "SampleWorkspace"]


class ModelTables(NamedTuple):
    """A model's modes and transitions as the kernel reads them (see the module docstring).

    Examples
    --------
    >>> import hybridlab
    >>> from hybridlab.simulation.compiled.backend import prepare
    >>> compiled = hybridlab.compile_model(hybridlab.load_model("models/thermostat.toml"))
    >>> tables = prepare(compiled).tables
    >>> tables.out_list[tables.out_ptr[0]:tables.out_ptr[1]].tolist(), tables.tr_target.tolist()
    ([0], [1, 0])
    >>> tables.n_invariants.tolist(), tables.tr_scheduled.tolist()
    ([1, 1], [0, 0])
    """

    flow_group: np.ndarray
    cond_group: np.ndarray
    switch_group: np.ndarray
    grad_group: np.ndarray
    dsigma_group: np.ndarray
    invariant_offset: np.ndarray
    n_invariants: np.ndarray
    n_switches: np.ndarray
    affine: np.ndarray
    out_ptr: np.ndarray
    out_list: np.ndarray
    tr_target: np.ndarray
    tr_guard: np.ndarray
    tr_monitored: np.ndarray
    tr_scheduled: np.ndarray
    tr_schedule_on: np.ndarray
    tr_reset: np.ndarray
    switch_zeno_key: np.ndarray
    tr_zeno_key: np.ndarray
    n_conditions: np.ndarray
    slide_group: np.ndarray
    switch_free: np.ndarray
    active_ptr: np.ndarray
    active_list: np.ndarray
    invariant_box: np.ndarray


class KernelCheckpoint(NamedTuple):
    """Where a run stopped for the reference engine to continue it (code ``HANDOFF``).

    ``position``: where the run resumes (``R_START``, ``R_ITERATE``, ``R_HANDLE`` or
    ``R_FLOW`` of :mod:`.kernel`), the mode, the jump counter, and how many event and
    segment records hold; ``times``: the time and the integrator's last step size (0:
    none); ``x``; ``sigma`` and ``sliding`` (the signs and the sliding mask);
    ``zeno_times``, ``zeno_counts``; ``schedules_done``; ``rows`` and ``grazing``: the
    monitors that ended the last flow segment (``R_HANDLE``).

    Examples
    --------
    >>> KernelCheckpoint._fields[:3]
    ('position', 'times', 'x')
    """

    position: np.ndarray
    times: np.ndarray
    x: np.ndarray
    sigma: np.ndarray
    sliding: np.ndarray
    zeno_times: np.ndarray
    zeno_counts: np.ndarray
    schedules_done: np.ndarray
    rows: np.ndarray
    grazing: np.ndarray


class KernelResult(NamedTuple):
    """What the kernel returns: its status code, the records, the end state, a checkpoint.

    ``events``, ``points``, ``steps``, ``segments``: the record tables (their columns in
    :mod:`.kernel`); ``stats``: steps, refinements, events located, segments, steps proven
    quiet; ``info``: the details of a ``ZENO`` or ``MAX_EVENTS`` stop; ``t``, ``x``,
    ``mode``, ``jumps``, ``last_step``: the run's last state.

    Examples
    --------
    >>> KernelResult._fields[-6:]
    ('t', 'x', 'mode', 'jumps', 'last_step', 'checkpoint')
    """

    code: int
    events: np.ndarray
    points: np.ndarray
    steps: np.ndarray
    segments: np.ndarray
    stats: np.ndarray
    info: np.ndarray
    t: float
    x: np.ndarray
    mode: int
    jumps: int
    last_step: float
    checkpoint: KernelCheckpoint


class RunBuffers(NamedTuple):
    """The run loop's buffers, allocated once per run by the kernel and borrowed by its loop.

    The state, the signs and the sliding set; the sliding workspace, the equivalent signs
    and the sliding indices; a guard's rows and their slopes; the monitor table (kind,
    reference, first row, rows, hit rows), its flags (armed, has a floor), floors and
    first values and slopes; the hit monitors' grazing flags; the integrator's stages,
    dense-output coefficients, new state and flow, current flow and scratch; the event
    iteration's flags per transition (fired, fresh, grazing) and per switch (hit, exit
    hit, kind of event); the statistics, the stop details, the last state and the clock;
    the sign bookkeeping's scratch (reals, flags, indices: :func:`.sliding.switch_scratch`).

    Examples
    --------
    >>> RunBuffers._fields[:3]
    ('x', 'sig', 'slm')
    """

    x: np.ndarray
    sig: np.ndarray
    slm: np.ndarray
    workspace: np.ndarray
    eq: np.ndarray
    sliding: np.ndarray
    guard: np.ndarray
    guard_lie: np.ndarray
    table: np.ndarray
    flags: np.ndarray
    floors: np.ndarray
    phi0: np.ndarray
    dphi0: np.ndarray
    hit_grazing: np.ndarray
    stages: np.ndarray
    coef: np.ndarray
    y_new: np.ndarray
    f_new: np.ndarray
    f: np.ndarray
    tmp: np.ndarray
    scale: np.ndarray
    fired: np.ndarray
    fresh: np.ndarray
    grazing: np.ndarray
    switch_hit: np.ndarray
    exit_hit: np.ndarray
    kinds: np.ndarray
    stats: np.ndarray
    info: np.ndarray
    last_x: np.ndarray
    now: np.ndarray
    switch_reals: np.ndarray
    switch_flags: np.ndarray
    switch_index: np.ndarray


# ----- the kernel's own records (built inside the kernel, passed between its stages) ----------
class FlowContext(NamedTuple):
    """How the kernel evaluates the current mode's flow (:mod:`.sliding`).

    The mode's function groups (flow, switching functions, their gradient, the flow's
    sigma-Jacobian, the fused sliding parts), its number of switches, the indices of
    the switches it slides on, the workspace, whether its switching functions are free of
    the signs, and the states it integrates.

    Examples
    --------
    >>> FlowContext._fields[4:6]
    ('n_switches', 'sliding')
    """

    flow_group: int
    switch_group: int
    grad_group: int
    dsigma_group: int
    n_switches: int
    sliding: np.ndarray
    workspace: np.ndarray
    slide_group: int
    switch_free: int
    active: np.ndarray


class Monitors(NamedTuple):
    """The monitors of a flow segment (:mod:`.locate`): one row per guard, invariant,
    switching function or sliding exit, with its kind, its reference (transition,
    invariant or switch), its first condition row and number of rows.

    Examples
    --------
    >>> Monitors._fields
    ('context', 'cond_group', 'kind', 'ref', 'start', 'length', 'n_conditions')
    """

    context: FlowContext
    cond_group: int
    kind: np.ndarray
    ref: np.ndarray
    start: np.ndarray
    length: np.ndarray
    n_conditions: int


class LocateWorkspace(NamedTuple):
    """Buffers of event location: a state and its derivative, condition values and Lie
    derivatives, switch values and Lie derivatives, equivalent signs.

    Examples
    --------
    >>> LocateWorkspace._fields[:2]
    ('x', 'dx')
    """

    x: np.ndarray
    dx: np.ndarray
    cond: np.ndarray
    cond_lie: np.ndarray
    switch: np.ndarray
    switch_lie: np.ndarray
    eq: np.ndarray


class DenseStep(NamedTuple):
    """A step's dense output (:func:`.integrate.dense_eval`): the method, its coefficients,
    the step's start time, size and state, and the states it integrates.

    Examples
    --------
    >>> DenseStep._fields
    ('method', 'coef', 't_old', 'h', 'y_old', 'active')
    """

    method: int
    coef: np.ndarray
    t_old: float
    h: float
    y_old: np.ndarray
    active: np.ndarray


class BoxWorkspace(NamedTuple):
    """Buffers of a quiet-step proof (:mod:`.bounds`): the states' box ``[lo | hi]``, the
    time interval, and the bounds of a guard's rows, of the invariants and of the
    switching functions.

    Examples
    --------
    >>> BoxWorkspace._fields
    ('states', 'time', 'guard', 'invariants', 'switches')
    """

    states: np.ndarray
    time: np.ndarray
    guard: np.ndarray
    invariants: np.ndarray
    switches: np.ndarray


class Probe(NamedTuple):
    """One monitor on one step, as the root finders evaluate it (:func:`.locate.probe`):
    numbers and pointers only, no array, so an evaluation binds nothing that numba
    counts references of.

    Examples
    --------
    >>> len(Probe._fields), Probe._fields[:4]
    (31, ('kind', 'ref', 'start', 'length'))
    """

    kind: int
    ref: int
    start: int
    length: int
    cond_group: int
    switch_group: int
    n_conditions: int
    slide_group: int
    n_switches: int
    method: int
    t_old: float
    h: float
    n: int
    n_coef: int
    n_active: int
    n_sliding: int
    n_work: int
    n_params: int
    n_signs: int
    position: int
    x: object
    p: object
    sig: object
    cond: object
    switch: object
    eq: object
    work: object
    coef: object
    y_old: object
    active: object
    sliding: object


class SampleWorkspace(NamedTuple):
    """Buffers of the sampler and the trigger search (:mod:`.locate`) for ``capacity``
    samples per step and the mode with the most monitors, so that scanning a step neither
    allocates nor counts references. A step refined past the capacity makes the kernel
    double it and scan the step again.

    The sample times, monitor values and slopes (in order of evaluation); the uniform
    grid; the intervals' ends, twice (the current ones and the next level's), their
    midpoints and which of them split; the samples' order by time; the sorted times,
    values and slopes without repeats (values and slopes flat, read as ``(monitors,
    samples)``); per monitor the rows, times and grazing flags of the monitors that fire,
    the instants their search starts, whether it is searched, their order and whether
    each is armed after the step; per interval of one monitor its cubic's minimum and
    where it is, its maximum and where it is, its lower bound, and the candidate intervals.

    Examples
    --------
    >>> SampleWorkspace._fields[:3]
    ('times', 'values', 'slopes')
    """

    times: np.ndarray
    values: np.ndarray
    slopes: np.ndarray
    grid: np.ndarray
    left: np.ndarray
    right: np.ndarray
    next_left: np.ndarray
    next_right: np.ndarray
    middle: np.ndarray
    split: np.ndarray
    order: np.ndarray
    sorted_times: np.ndarray
    sorted_values: np.ndarray
    sorted_slopes: np.ndarray
    rows: np.ndarray
    at: np.ndarray
    grazing: np.ndarray
    starts: np.ndarray
    searched: np.ndarray
    rank: np.ndarray
    armed: np.ndarray
    low: np.ndarray
    low_at: np.ndarray
    high: np.ndarray
    high_at: np.ndarray
    lower: np.ndarray
    candidates: np.ndarray
