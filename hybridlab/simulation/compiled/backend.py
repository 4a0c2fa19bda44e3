"""The compiled backend: generated model module, disk cache, kernel call, result.

A model is printed to Python source by :mod:`.codegen`, written once to the
cache directory (``$HYBRIDLAB_CACHE_DIR`` or ``~/.cache/hybridlab``) under a
name derived from the hash of the source and of the numba version, and
imported; its numba ``cfunc`` is compiled with ``cache=True``, so a second
process loads machine code from disk. The kernel (:mod:`.kernel`) is
compiled once per machine for every model.

:func:`run` calls the kernel and turns its records into the same
:class:`~hybridlab.simulation.result.SimulationResult` as the reference
engine. When the kernel hands off (an invariant violation, a zero-dwell
cycle, a failed step, ...), the reference engine continues the run from the
kernel's checkpoint (:func:`_hand_off`; ``result.stats["handoff"]`` says from
where); methods and models the kernel cannot run at all are run by the
reference engine from the start (``result.stats["fallback"]``).
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import stat
import sys
import tempfile
import threading
import time
import warnings
import weakref
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cache, partial
from itertools import accumulate, chain
from pathlib import Path
from types import ModuleType
from typing import Literal

import numba
import numpy as np

from hybridlab._files import replace_text
from hybridlab._numba_cache import refresh_cache, tell
from hybridlab.errors import ZenoError
from hybridlab.simulation import engine
from hybridlab.simulation.compiled.codegen import (
    ModelSource,
    UnsupportedModel,
    active_states,
    generate,
)
from hybridlab.simulation.compiled.integrate import METHOD_CODES
from hybridlab.simulation.compiled.kernel import (
    COMPLETED,
    HANDOFF,
    INTERRUPTED,
    MAX_EVENTS,
    R_FLOW,
    R_HANDLE,
    R_ITERATE,
    R_START,
    STEP_LIMIT,
    TIME_LIMIT,
    ZENO,
    run_kernel,
)
from hybridlab.simulation.compiled.layout import KernelResult, ModelTables
from hybridlab.simulation.compiled.signatures import watch_addresses
from hybridlab.simulation.location import Trigger
from hybridlab.simulation.options import SimulationOptions
from hybridlab.simulation.result import FinalState, SimulationResult, SimulationStats, Status
from hybridlab.simulation.tables import EventTable, SegmentTable
from hybridlab.simulation.zeno import ZenoVerdict
from hybridlab.symbolic.compile import CompiledModel

__all__ = ["cache_dir", "prepare", "run", "Prepared", "StepInterpolants"]


#: the modules whose numba functions and constants make up the kernel, relative to
#: ``hybridlab/simulation``
_KERNEL_SOURCES = ("compiled/signatures", "compiled/opcodes", "compiled/layout", "compiled/sliding",
                   "compiled/integrate", "compiled/locate", "compiled/bounds", "compiled/kernel",
                   "rules")


def _kernel_cache_path() -> Path:
    """The directory numba keeps the kernel's cached functions in.

    That is the source tree's ``__pycache__``, a folder under
    ``$NUMBA_CACHE_DIR`` when it is set, or numba's user-wide cache for a
    read-only install: numba's own choice, read off the kernel's dispatcher.
    """
    path = getattr(getattr(run_kernel, "_cache", None), "_cache_path", None)
    return Path(path) if path else Path(__file__).parent / "__pycache__"


# numba checks a cached function against its own source file only: after an edit of,
# say, locate.py or of a rule in rules.py it would load a stale kernel
refresh_cache(_kernel_cache_path(),
              [Path(__file__).parent.parent / f"{name}.py" for name in _KERNEL_SOURCES],
              "kernel-sources.sha256")


def cache_dir() -> Path:
    """Where generated model modules live: ``$HYBRIDLAB_CACHE_DIR`` or ``~/.cache/hybridlab``.

    Examples
    --------
    >>> cache_dir().name in ("hybridlab", os.environ.get("HYBRIDLAB_CACHE_DIR", "x")[-9:]) or True
    True
    """
    env = os.environ.get("HYBRIDLAB_CACHE_DIR")
    return Path(env) if env else Path.home() / ".cache" / "hybridlab"


class StepInterpolants(Sequence):
    """The dense output of a segment's steps, one callable per step (like scipy's).

    Examples
    --------
    >>> ST = np.array([[0.0, 1.0, 2.0, 1.0, 0.0, 0.0, 0.0]])  # y' = 1 from y = 2, RK45 form
    >>> StepInterpolants(0, 1, ST)[0](0.5)
    array([2.5])
    """

    __slots__ = ("method", "n", "rows")  # one per segment and run: no instance dict

    def __init__(self, method: int, n: int, rows: np.ndarray) -> None:
        self.method, self.n, self.rows = method, n, rows

    def __len__(self) -> int:
        return self.rows.shape[0]

    def __getitem__(self, i):  # noqa: ANN001 - Sequence protocol
        if isinstance(i, slice):
            return [self[k] for k in range(*i.indices(len(self)))]
        return _StepInterpolant(self.method, self.n, self.rows[i])

    def at_steps(self, steps: np.ndarray, t: np.ndarray) -> np.ndarray:
        """The states at times ``t``, each from the step of the same index; shape ``(n, k)``.

        One vectorised evaluation for any number of steps (the per-step callables
        give the same numbers, one step at a time).

        Examples
        --------
        >>> ST = np.array([[0.0, 1.0, 2.0, 1.0, 0.0, 0.0, 0.0],
        ...                [1.0, 1.0, 3.0, 1.0, 0.0, 0.0, 0.0]])
        >>> StepInterpolants(0, 1, ST).at_steps(np.array([0, 1]), np.array([0.5, 1.5]))
        array([[2.5, 3.5]])
        """
        rows = self.rows[steps]
        n = self.n
        x = ((t - rows[:, 0]) / rows[:, 1])[:, None]
        coef = rows[:, 2 + n:].reshape(rows.shape[0], -1, n)
        if self.method == METHOD_CODES["RK45"]:
            acc = np.zeros((rows.shape[0], n))
            pw = np.ones_like(x)
            for k in range(coef.shape[1]):
                pw = pw * x
                acc = acc + coef[:, k] * pw
            y = rows[:, 1:2] * acc + rows[:, 2:2 + n]
        else:
            y = np.zeros((rows.shape[0], n))
            for k in range(coef.shape[1]):
                y = (y + coef[:, -1 - k]) * (x if k % 2 == 0 else 1 - x)
            y = y + rows[:, 2:2 + n]
        return y.T


class _StepInterpolant:
    def __init__(self, method: int, n: int, row: np.ndarray) -> None:
        self.t_old, self.h = float(row[0]), float(row[1])
        self.t_min, self.t_max = sorted((self.t_old, self.t_old + self.h))
        self.y_old = row[2:2 + n]
        self.coef = row[2 + n:].reshape(-1, n)
        self.method = method

    def __call__(self, t: float | np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        x = ((t - self.t_old) / self.h)[..., None]
        if self.method == METHOD_CODES["RK45"]:
            acc = np.zeros(x.shape[:-1] + (self.y_old.size,))
            pw = np.ones_like(x)
            for c in self.coef:
                pw = pw * x
                acc = acc + c * pw
            y = self.h * acc + self.y_old
        else:
            y = np.zeros(x.shape[:-1] + (self.y_old.size,))
            for k, c in enumerate(self.coef[::-1]):
                y = (y + c) * (x if k % 2 == 0 else 1 - x)
            y = y + self.y_old
        return y.T


@dataclass(frozen=True)
class Prepared:
    """A model ready for the kernel: its module and static tables.

    Examples
    --------
    >>> import hybridlab
    >>> compiled = hybridlab.compile_model(hybridlab.load_model("models/thermostat.toml"))
    >>> prepared = prepare(compiled)  # loads the model's numba module (compiled once, cached)
    >>> prepared.mode_names, prepared.jump_labels, prepared.n_sig
    (('heat', 'cool'), ('turn_off', 'turn_on'), 0)
    >>> prepared.unscheduled is not None  # nothing scheduled: one set of tables for every run
    True
    """

    source: ModelSource
    module: ModuleType
    cache_hit: bool
    tables: ModelTables
    mode_names: tuple[str, ...]
    zeno_keys: tuple[str, ...]
    n_sig: int
    #: event labels: per transition its name, per mode its switches' texts
    jump_labels: tuple[str, ...] = ()
    switch_labels: tuple[tuple[str, ...], ...] = ()
    #: the kernel's schedule tables when no transition is scheduled (read only, shared by runs)
    unscheduled: tuple | None = None
    #: the scheduled transitions, and the schedule tables of the parameter vector last used
    scheduled: tuple = ()
    last_schedule: dict = field(default_factory=dict, compare=False)
    #: the kernel's compiled entry point for this model's argument types (see kernel_entry)
    entries: dict = field(default_factory=dict, compare=False)

    def kernel_entry(self, args: tuple) -> Callable:
        """The kernel's compiled entry point for these argument types.

        numba's dispatcher would type every argument on each call; the entry
        point compiled (or loaded from the cache) for these types is kept and
        called directly instead: the argument types of a model's runs never
        change. Compiling here, before the call, keeps the compilation out of
        a run's ``time_limit``.
        """
        entry = self.entries.get("kernel")
        if entry is None:
            types = tuple(map(run_kernel.typeof_pyval, args))
            if types not in run_kernel.overloads:
                if not any(_kernel_cache_path().glob("kernel.run_kernel-*.nbi")):
                    tell("compiling the simulation kernel: once per machine and version, "
                          "about 2-3 minutes")
                run_kernel.compile(types)  # (loads the disk cache, or compiles)
            # numba's CompileResult is a namedtuple made from a list of field names, which
            # its type hints do not declare
            entry = run_kernel.overloads[types].entry_point  # type: ignore[attr-defined]
            self.entries["kernel"] = entry
        return entry

    def schedule_tables(self, p: np.ndarray) -> tuple[tuple, tuple]:
        """The kernel's :class:`~.layout.ModelTables` and ``reals`` for parameters ``p``.

        Only the scheduled transitions are evaluated, and the tables of the
        last parameter vector are kept: runs of one model with the same
        parameters (a repeated call, a sweep over initial states) reuse them.
        """
        if self.unscheduled is not None:  # nothing depends on p: the tables made by prepare()
            return self.unscheduled
        key = p.tobytes()
        tables = self.last_schedule.get(key)
        if tables is None:
            n = max(len(self.jump_labels), 1)
            period, phase = np.ones(n), np.zeros(n)
            sched_on = np.zeros(n, dtype=np.int64)
            for tr in self.scheduled:
                sched = tr.period_and_phase(p)
                if sched is not None:
                    period[tr.index], phase[tr.index] = sched
                    sched_on[tr.index] = 1
            tables = (self.tables._replace(tr_schedule_on=sched_on), (period, phase))
            self.last_schedule.clear()
            self.last_schedule[key] = tables
        return tables


_PREPARED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # per-model memo
_SLOW: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # models too slow to compile


def _unsafe_reason(directory: Path) -> str | None:
    """Why ``directory`` cannot hold the cache (``None``: it can).

    numba unpickles the index files it finds there, so a folder that other users
    can write to would let them run code in this process.
    """
    try:
        directory.mkdir(parents=True, exist_ok=True, mode=0o700)
        info = directory.stat()
        probe = directory / f".probe-{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        return f"it cannot be written ({exc.strerror or exc})"
    if info.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        return "other users can write to it (numba loads code from its cache)"
    if hasattr(os, "getuid") and info.st_uid != os.getuid():
        return "it belongs to another user (numba loads code from its cache)"
    return None


@cache
def _fallback_cache() -> Path:
    """A private folder for this process, when the configured cache cannot be used."""
    return Path(tempfile.mkdtemp(prefix="hybridlab-cache-"))


def _usable_cache_dir() -> Path:
    """:func:`cache_dir`, or a private temporary folder (with a warning saying why)."""
    directory = cache_dir()
    reason = _unsafe_reason(directory)
    if reason is None:
        return directory
    where = ("$HYBRIDLAB_CACHE_DIR" if os.environ.get("HYBRIDLAB_CACHE_DIR")
             else "the default cache")
    fallback = _fallback_cache()
    warnings.warn(f"hybridlab: not using {where} {str(directory)!r}: {reason}; compiling into "
                  f"{str(fallback)!r} for this process (set HYBRIDLAB_CACHE_DIR to a private "
                  "folder to keep compiled models)", RuntimeWarning, stacklevel=4)
    return fallback


def _load(name: str, path: Path) -> ModuleType:
    """Import the generated module ``name`` from ``path``.

    It is registered in ``sys.modules`` before it runs: numba records the module of
    each function it caches and imports it by that name when it loads the cache in a
    later process (an unregistered module is recorded as ``<dynamic>``, which no later
    process can import).
    """
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise ImportError(f"cannot load {path}")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    return module


def _drop_entries(directory: Path, name: str) -> None:
    """Delete the cached source and numba's files of one generated module."""
    for stale in [directory / f"{name}.py", *(directory / "__pycache__").glob(f"{name}*")]:
        stale.unlink(missing_ok=True)


def _module_name(source: ModelSource) -> str:
    digest = hashlib.sha256((source.text + numba.__version__).encode()).hexdigest()[:20]
    return f"hybridlab_model_{digest}"


def _import(source: ModelSource) -> tuple[ModuleType, bool]:
    name = _module_name(source)
    if name in sys.modules:
        return sys.modules[name], True
    directory = _usable_cache_dir()
    path = directory / f"{name}.py"
    for attempt in range(2):
        if not path.exists() or path.read_text(errors="replace") != source.text:
            replace_text(path, source.text)
        try:
            module = _load(name, path)
            break
        except Exception:  # a damaged cache entry: compile afresh once, then give up
            if attempt:
                raise
            _drop_entries(directory, name)
    hit = bool(getattr(module.model, "cache_hits", 0))
    return module, hit


#: A model whose generated module is longer than this (and not compiled yet) runs on the
#: reference engine under ``backend="auto"``: numba's compile time grows faster than the
#: code (measured: 3,552 lines in 16 s; a ring of 200 distinct modes, 7,828 lines, in 116 s
#: against 9 s for the whole run on the reference engine).
MAX_AUTO_COMPILE_LINES = 6_000


class SlowToCompile(UnsupportedModel):
    """The model's generated code would take minutes to compile (see
    :data:`MAX_AUTO_COMPILE_LINES`)."""


def _compiled_before(name: str) -> bool:
    """Whether numba's cache already holds the generated module ``name``."""
    folder = cache_dir() / "__pycache__"
    return folder.is_dir() and any(folder.glob(f"{name}.model-*.nbi"))


def prepare(compiled: CompiledModel, max_lines: int | None = None) -> Prepared:
    """Generate, cache and load the compiled form of ``compiled`` (memoised per model).

    Raises
    ------
    UnsupportedModel
        When the model cannot be printed for numba.
    SlowToCompile
        When ``max_lines`` is given, the generated module is longer and it was not
        compiled before.

    Examples
    --------
    >>> import hybridlab
    >>> compiled = hybridlab.compile_model(hybridlab.load_model("models/thermostat.toml"))
    >>> prepared = prepare(compiled)
    >>> prepare(compiled) is prepared, prepared.module.__name__[:16]
    (True, 'hybridlab_model_')
    """
    if compiled in _PREPARED:
        return _PREPARED[compiled]
    if max_lines is not None and compiled in _SLOW:
        raise _SLOW[compiled]
    source = generate(compiled)
    lines = source.text.count("\n")
    if max_lines is not None and lines > max_lines and not _compiled_before(_module_name(source)):
        _SLOW[compiled] = SlowToCompile(
            f"its generated code has {lines} lines (more than {max_lines}), which numba would "
            "take minutes to compile; backend='compiled' compiles it anyway")
        raise _SLOW[compiled]
    name = _module_name(source)
    if name not in sys.modules and not _compiled_before(name):
        tell(f"compiling model {compiled.model.name!r} ({lines} lines of generated code): "
              "once per model")
    module, hit = _import(source)
    modes = list(compiled.modes.values())
    index = {name: i for i, name in enumerate(compiled.modes)}
    n_tr = len(compiled.transitions)
    n_sig = max((len(md.switches) for md in modes), default=0)
    # Zeno histories are kept per transition name and per switch text, as the reference does
    keys: dict[str, int] = {}
    tr_zkey = [keys.setdefault(tr.name, len(keys)) for tr in compiled.transitions]
    sw_key = np.zeros(len(modes) * max(n_sig, 1), dtype=np.int64)
    for m, md in enumerate(modes):
        for k, sw in enumerate(md.switches):
            sw_key[m * max(n_sig, 1) + k] = keys.setdefault(f"switch:{sw.text}", len(keys))
    out_ptr, out_list = [0], []
    for md in modes:
        out_list += [tr.index for tr in md.outgoing]
        out_ptr.append(len(out_list))
    monitored = np.zeros(2 * max(n_tr, 1), dtype=np.int64)
    for tr in compiled.transitions:
        if tr.guard is not None:
            monitored[max(n_tr, 1) + tr.index] = tr.guard.size
            monitored[tr.index] = int(not tr.scheduled)
    tables = ModelTables(*(np.ascontiguousarray(a, dtype=np.int64) for a in (
        source.flow_group, source.cond_group, source.switch_group, source.grad_group,
        source.dsigma_group,
        [md.invariant_offset for md in modes], [md.invariants.size for md in modes],
        [len(md.switches) for md in modes], [int(md.affine_in_sigma) for md in modes],
        out_ptr, out_list or [0], [index[tr.target] for tr in compiled.transitions] or [0],
        list(source.guard_group) or [0], monitored,
        [int(tr.scheduled) for tr in compiled.transitions] or [0],
        [0] * max(n_tr, 1), list(source.reset_group) or [0], sw_key, tr_zkey or [0],
        [md.conditions.size if md.conditions is not None else 0 for md in modes],
        source.slide_group, source.switch_free, *active_states(compiled),
        source.invariant_group)))
    unscheduled = None
    if all(tr.schedule is None for tr in compiled.transitions):
        # (not flagged read-only: numba would type, and compile, the kernel anew for that)
        unscheduled = (tables, (np.ones(max(n_tr, 1)), np.zeros(max(n_tr, 1))))
    prepared = Prepared(source, module, hit, tables, tuple(compiled.modes), tuple(keys), n_sig,
                        tuple(tr.name for tr in compiled.transitions),
                        tuple(tuple(sw.text for sw in md.switches) for md in modes), unscheduled,
                        tuple(tr for tr in compiled.transitions if tr.scheduled))
    _PREPARED[compiled] = prepared
    return prepared


def _fallback(compiled: CompiledModel, reason: str, **kw) -> SimulationResult:
    result = engine.run(compiled, **kw)
    stats: SimulationStats = {**result.stats, "backend": "reference", "fallback": reason}
    return SimulationResult(result.status, result.message, result.events, result.segments,
                            result.final, result.state_names, result.zeno_time, stats,
                            result.parameters, result.compiled)


def run(compiled: CompiledModel, *, t0: float, x0: np.ndarray, mode: str, t_end: float,
        p: np.ndarray, options: SimulationOptions) -> SimulationResult:
    """Simulate with the compiled kernel (see ``hybridlab.simulate``).

    Methods and models the kernel cannot run go to the reference engine, and
    ``result.stats["fallback"]`` says why.

    Examples
    --------
    >>> import hybridlab
    >>> from hybridlab.simulation.options import SimulationOptions
    >>> compiled = hybridlab.compile_model(hybridlab.load_model("models/bouncing_ball.toml"))
    >>> result = run(compiled, t0=0.0, x0=compiled.state_vector(), mode="fall", t_end=3.0,
    ...              p=compiled.parameter_vector(), options=SimulationOptions(method="LSODA"))
    >>> result.status.name, result.stats["backend"], result.stats["fallback"]
    ('COMPLETED', 'reference', 'method LSODA runs on the reference backend')
    """
    kw = {"t0": t0, "x0": x0, "mode": mode, "t_end": t_end, "p": p, "options": options}
    o = options
    if o.method not in METHOD_CODES:
        return _fallback(compiled, f"method {o.method} runs on the reference backend", **kw)
    if len(compiled.state_names) == 0:
        return _fallback(compiled, "a model without states", **kw)
    try:
        prep = prepare(compiled, MAX_AUTO_COMPILE_LINES if o.backend == "auto" else None)
    except SlowToCompile as exc:
        warnings.warn(f"hybridlab: the reference engine runs {compiled.model.name!r}: {exc}",
                      RuntimeWarning, stacklevel=3)
        return _fallback(compiled, f"slow to compile: {exc}", **kw)
    except UnsupportedModel as exc:
        return _fallback(compiled, f"unsupported model: {exc}", **kw)
    n_tr = len(compiled.transitions)
    tables, reals = prep.schedule_tables(np.ascontiguousarray(p, dtype=float))
    method = METHOD_CODES[o.method]
    opts_i = np.array([method, o.samples_per_step, o.max_refine, o.max_events,
                       o.max_event_iterations, o.zeno_window, int(o.prove_quiet_steps)],
                      dtype=np.int64)
    opts_f = np.array([o.rtol, o.atol, o.max_step, o.event_tol, o.event_atol, o.zeno_tol])
    n_keys = len(prep.zeno_keys)
    ztimes = np.zeros((max(n_keys, 1), o.zeno_window + 1))
    zcount = np.zeros(max(n_keys, 1), dtype=np.int64)
    sched_done = np.full(max(n_tr, 1), -1, dtype=np.int64)
    m0 = prep.mode_names.index(mode)
    deadline = engine.deadline_of(o)
    interrupt_address, clock_address, gil_ensure, gil_release = _watched()
    if deadline is not None and not clock_address:
        return _fallback(compiled, "time_limit needs clock_gettime, which this C library lacks",
                         **kw)
    if threading.current_thread() is not threading.main_thread():
        interrupt_address = 0  # only the main thread receives Ctrl-C
    watch = np.array([o.max_steps, interrupt_address, clock_address,
                      getattr(time, "CLOCK_MONOTONIC", 1), deadline or 0, gil_ensure,
                      gil_release], dtype=np.int64)
    # the generated functions by address (prep.module keeps them alive)
    args = (prep.module.model.address, prep.module.box.address, tables, reals, opts_i, opts_f,
            float(t0), np.ascontiguousarray(x0, dtype=float), m0, float(t_end),
            np.ascontiguousarray(p, dtype=float), prep.n_sig, ztimes, zcount, sched_done, watch)
    entry = prep.kernel_entry(args)  # (compiles the kernel on a cold cache)
    if deadline is not None:  # the limit counts the run, not the compilation
        deadline = engine.deadline_of(o)
        watch[4] = deadline or 0  # (not None: o.time_limit is set)
    out: KernelResult = entry(*args)
    if out.code == HANDOFF:
        return _hand_off(compiled, prep, o, out, p, float(t_end), {**kw, "deadline": deadline})
    return _result(compiled, prep, o, out.code, out.events, out.points, out.steps,
                   out.segments, out.stats, out.info, out.t, out.x, out.mode, out.jumps, p,
                   float(t_end))


@cache
def _watched() -> tuple[int, int, int, int]:
    """The addresses the kernel polls for Ctrl-C and the time (fixed for the process)."""
    return watch_addresses()


_ENTRIES: dict[int, Literal["iterate", "handle", "flow"]] = {
    R_ITERATE: "iterate", R_HANDLE: "handle", R_FLOW: "flow"}


def _hand_off(compiled: CompiledModel, prep: Prepared, o: SimulationOptions,
              out: KernelResult, p: np.ndarray, t_end: float, kw: dict) -> SimulationResult:
    """Continue a run on the reference engine from the kernel's checkpoint."""
    cp, kstats = out.checkpoint, out.stats
    kind, m, j, nev, nsg = (int(v) for v in cp.position[:5])
    if kind == R_START:
        return _fallback(compiled, "the kernel could not enter the initial mode", **kw)
    mode = prep.mode_names[m]
    events, segments = _records(compiled, prep, o, out.events[:nev], out.points, out.steps,
                                out.segments[:nsg])
    n_sw = len(compiled.modes[mode].switches)
    window = o.zeno_window + 1
    checkpoint = engine.Checkpoint(
        t=float(cp.times[0]), x=cp.x.copy(), mode=mode, entry=_ENTRIES[kind], jumps=j,
        events=list(events), segments=list(segments), sigma=cp.sigma[:n_sw].copy(),
        sliding=tuple(int(k) for k in np.nonzero(cp.sliding[:n_sw])[0]),
        schedules_done={i: int(v) for i, v in enumerate(cp.schedules_done)
                        if v >= 0 and i < len(compiled.transitions)},
        last_step=float(cp.times[1]) if cp.times[1] > 0 else None,
        zeno_history={name: (int(cp.zeno_counts[key]),
                             cp.zeno_times[key, :min(int(cp.zeno_counts[key]), window)].tolist())
                      for key, name in enumerate(prep.zeno_keys) if cp.zeno_counts[key]},
        stats={"steps": int(kstats[0]), "refinements": int(kstats[1]),
               "events_located": int(kstats[2]), "quiet_steps": int(kstats[4])},
        triggers=[Trigger(int(r), float(cp.times[0]), bool(g))
                  for r, g in zip(cp.rows, cp.grazing, strict=True)] if kind == R_HANDLE else [])
    result = engine.resume(compiled, checkpoint, p=p, options=o, t_end=t_end,
                           deadline=kw.get("deadline"))
    t_hand = float(cp.times[0])
    stats: SimulationStats = {**result.stats, "backend": "compiled",
                              "compiled_cache_hit": prep.cache_hit,
                              "handoff": f"the reference engine continued from t = {t_hand!r} "
                                         f"({_ENTRIES[kind]})"}
    return SimulationResult(result.status, result.message, result.events, result.segments,
                            result.final, result.state_names, result.zeno_time, stats,
                            result.parameters, result.compiled)


_KINDS = ("jump", "crossing", "slide_start", "slide_end")


class _SegmentSteps:
    """The dense output of each kernel segment, made when the segment is read."""

    __slots__ = ("method", "n", "rows", "first", "count")

    def __init__(self, method: int, n: int, rows: np.ndarray, first: np.ndarray,
                 count: np.ndarray) -> None:
        self.method, self.n, self.rows, self.first, self.count = method, n, rows, first, count

    def __getitem__(self, k: int) -> StepInterpolants | tuple:
        if k >= len(self.first):  # the one-point segment _records adds at the end of a run
            return ()
        s0 = int(self.first[k])
        return StepInterpolants(self.method, self.n, self.rows[s0:s0 + int(self.count[k])])

    def stepped(self, segments: np.ndarray) -> np.ndarray:
        """Whether each of ``segments`` has integrator steps (the last one may not)."""
        inside = segments < len(self.first)
        out = np.zeros(segments.size, dtype=bool)
        out[inside] = self.count[segments[inside]] > 0
        return out

    def at(self, segments: np.ndarray, steps: np.ndarray, t: np.ndarray) -> np.ndarray:
        """The states at ``t``, each from step ``steps[i]`` of segment ``segments[i]`` (all
        :meth:`stepped`); shape ``(n, len(t))``, one vectorised evaluation."""
        return StepInterpolants(self.method, self.n, self.rows).at_steps(
            self.first[segments] + steps, t)


def _event_columns(EV: np.ndarray, n: int, prep: Prepared) -> dict:
    """The columns of :meth:`EventTable.from_columns` from the kernel's event records."""
    meta = EV[:, 1:6].astype(np.int64)
    which, source, kind = meta[:, 1], meta[:, 2], meta[:, 4]
    # label codes into (transition names..., every mode's switch texts...)
    switches = prep.switch_labels
    offsets = np.fromiter(accumulate(map(len, switches[:-1]), initial=len(prep.jump_labels)),
                          np.int64, len(switches))
    return {"t": EV[:, 0], "j": meta[:, 0],
            "transition": np.where(kind == 0, which, offsets[source] + which),
            "labels": prep.jump_labels + tuple(chain.from_iterable(switches)),
            "source": source, "target": meta[:, 3], "modes": prep.mode_names, "kind": kind,
            "kinds": _KINDS, "grazing": EV[:, 6] != 0, "pre": EV[:, 7:7 + n],
            "post": EV[:, 7 + n:]}


def _records(compiled: CompiledModel, prep: Prepared, o: SimulationOptions, EV: np.ndarray,
             PT: np.ndarray, ST: np.ndarray, SG: np.ndarray,
             last: tuple[float, np.ndarray, int, int] | None = None
             ) -> tuple[EventTable, SegmentTable]:
    """Events and segments from the kernel's records, as tables that make each object when read.

    The events' columns are read from ``EV`` only when first needed. ``last``
    is where the run ended, ``(t, x, mode index, j)``; a one-point segment is
    added there unless the last segment ends there.
    """
    names = compiled.state_names
    n = len(names)
    events = EventTable.deferred(names, len(EV), partial(_event_columns, EV, n, prep))
    m = len(PT)
    mode, seg_j, first, count = SG[:, 0], SG[:, 1], SG[:, 2], SG[:, 3]
    extra = last is not None and bool(not len(SG) or PT[first[-1] + count[-1] - 1, 0] < last[0]
                                      or seg_j[-1] != last[3])
    # one copy of the points for the whole run; each segment holds views of it
    points = np.empty((1 + n, m + extra))
    points[:, :m] = PT.T
    if extra and last is not None:
        points[0, m], points[1:, m] = last[0], last[1]
        mode, seg_j = np.append(mode, last[2]), np.append(seg_j, last[3])
        first, count = np.append(first, m), np.append(count, 1)
    steps = _SegmentSteps(METHOD_CODES[o.method], n, ST, SG[:, 4], SG[:, 5])
    segments = SegmentTable.from_columns(mode=mode, modes=prep.mode_names, j=seg_j,
                                         times=points[0], states=points[1:], first=first,
                                         count=count, interpolants=steps)
    return events, segments


def _result(compiled: CompiledModel, prep: Prepared, o: SimulationOptions, code: int,
            EV: np.ndarray, PT: np.ndarray, ST: np.ndarray, SG: np.ndarray, kstats: np.ndarray,
            info: np.ndarray, last_t: float, last_x: np.ndarray, last_m: int, j: int,
            p: np.ndarray, t_end: float) -> SimulationResult:
    names = compiled.state_names
    modes = prep.mode_names
    if code == MAX_EVENTS and len(EV):
        # the run ends after the event it logged: in its target, in its post state (the
        # kernel stops before it moves there)
        columns = partial(_event_columns, EV, len(names), prep)
        last = EventTable.deferred(names, len(EV), columns)[-1]
        last_t, last_m, j = last.t, modes.index(last.target), last.j
        last_x = np.array([last.post[name] for name in names])
    t, x, mode = float(last_t), np.asarray(last_x), modes[int(last_m)]
    events, segments = _records(compiled, prep, o, EV, PT, ST, SG, (t, x, int(last_m), int(j)))
    zeno_time = None
    if code == COMPLETED:
        status, message = Status.COMPLETED, f"reached t_end = {t_end!r}"
    elif code == MAX_EVENTS:
        status, message = Status.MAX_EVENTS, f"{len(events)} events logged by t = {events[-1].t!r}"
    elif code == ZENO:
        label = prep.zeno_keys[int(info[0])]
        verdict = ZenoVerdict(label, int(info[1]), float(info[2]), float(info[3]))
        text = verdict.describe()
        if label.startswith("switch:"):
            text = f"the discontinuity {label[7:]} chatters: {text}"
        if o.zeno == "error":
            raise ZenoError(f"Zeno behaviour: {text}")
        status, message, zeno_time = Status.ZENO, text, float(info[3])
    elif code == STEP_LIMIT:
        status, message = Status.STEP_LIMIT, (f"{int(kstats[0])} integrator steps by t = {t!r} "
                                              f"(max_steps = {o.max_steps})")
    elif code == TIME_LIMIT:
        status, message = Status.TIME_LIMIT, f"time_limit = {o.time_limit!r} s reached at t = {t!r}"
    elif code == INTERRUPTED:
        status, message = Status.INTERRUPTED, f"interrupted at t = {t!r}"
    else:  # pragma: no cover - the kernel returns only the codes above
        raise RuntimeError(f"unknown kernel code {code}")
    stats: SimulationStats = {"steps": int(kstats[0]), "refinements": int(kstats[1]),
                              "events_located": int(kstats[2]), "segments": int(kstats[3]),
                              "quiet_steps": int(kstats[4]), "backend": "compiled",
                              "compiled_cache_hit": prep.cache_hit}
    final = FinalState(t, int(j), mode, dict(zip(names, map(float, x), strict=True)))
    parameters = dict(zip(compiled.parameter_names, map(float, p), strict=True))
    return SimulationResult(status, message, events, segments, final, names, zeno_time, stats,
                            parameters, compiled)

