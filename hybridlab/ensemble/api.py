"""The public entry points :func:`sweep` and :func:`simulate_many`."""

from __future__ import annotations

import concurrent.futures as cf
import dataclasses
import inspect
import math
import pickle
import threading
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from hybridlab.ensemble.errors import SweepError
from hybridlab.ensemble.executors import place
from hybridlab.ensemble.observables import parse_counts, parse_observables
from hybridlab.ensemble.progress import ProgressBar, progress_wanted
from hybridlab.ensemble.result import SweepResult
from hybridlab.ensemble.spec import RUN_KEYS, expand, normalise_run, sample_points
from hybridlab.ensemble.worker import (
    ERROR,
    INTERRUPTED,
    Chunk,
    compiled_for,
    model_key,
    model_text,
    run_chunk,
)
from hybridlab.model.loader import load_model
from hybridlab.model.schema import Model
from hybridlab.simulation.api import simulate
from hybridlab.simulation.observe import Observer
from hybridlab.simulation.options import SimulationOptions
from hybridlab.simulation.problem import HybridProblem
from hybridlab.symbolic.compile import CompiledModel

__all__ = ["simulate_many", "sweep"]

_KEEP = ("observables", "results")
_FIXED_COLUMNS = ("run", "status", "t_final", "jumps", "error")


def _simulate_option_names() -> set[str]:
    per_run = {"model", "t_end", "scenario", "params", "initial"}
    names = {n for n, p in inspect.signature(simulate).parameters.items()
             if p.kind is not inspect.Parameter.VAR_KEYWORD and n not in per_run}
    return names | set(SimulationOptions.__dataclass_fields__)


def _check_options(options: Mapping[str, Any]) -> None:
    unknown = sorted(set(options) - _simulate_option_names())
    if unknown:
        raise SweepError(f"unknown simulate option {unknown[0]!r}")
    fields = {k: v for k, v in options.items() if k in SimulationOptions.__dataclass_fields__}
    try:
        SimulationOptions(**fields)  # bad values fail here once, not in every run
    except (TypeError, ValueError) as exc:
        raise SweepError(f"simulate options: {exc}") from None


def _model_of(model: Model | CompiledModel | str | Path) -> tuple[Model, CompiledModel | None]:
    if isinstance(model, CompiledModel):
        return model.model, model
    if isinstance(model, str | Path):
        return load_model(model), None
    if isinstance(model, Model):
        return model, None
    raise SweepError(f"model: expected a Model, a CompiledModel or a path "
                     f"(got {type(model).__name__})")


def _check_horizon(model: Model, runs: Sequence[Mapping[str, Any]]) -> None:
    for k, run in enumerate(runs):
        scenario = run.get("scenario")
        if scenario is not None and scenario not in model.scenarios:
            raise SweepError(f"scenario: unknown scenario {scenario!r}; the model has: "
                             f"{', '.join(model.scenarios) or 'none'}")
        if run.get("t_end") is None and scenario is None and "default" not in model.scenarios:
            raise SweepError(f"t_end is required (run {k} has none and model {model.name!r} "
                             f"has no default scenario)")


def _default_chunksize(n_runs: int, workers: int) -> int:
    return max(1, min(256, math.ceil(n_runs / (8 * max(workers, 1)))))


def _execute(model_arg: Model | CompiledModel | str | Path, runs: list[dict[str, Any]],
             inputs: Sequence[str], input_rows: Sequence[tuple[Any, ...]], *, observe: Any,
             events: Any, executor: Any, chunksize: int | None, progress: bool | None,
             keep: str, options: Mapping[str, Any]) -> SweepResult:
    started = time.perf_counter()
    model, compiled = _model_of(model_arg)
    if keep not in _KEEP:
        raise SweepError(f"keep must be one of {', '.join(_KEEP)} (got {keep!r})")
    if chunksize is not None and (isinstance(chunksize, bool) or not isinstance(chunksize, int)
                                  or chunksize < 1):
        raise SweepError(f"chunksize must be a positive integer (got {chunksize!r})")
    _check_options(options)
    _check_horizon(model, runs)
    text = model_text(model)
    key = model_key(text)
    compiled = compiled_for(text, key, compiled, model)
    observables = parse_observables(observe)
    counts = parse_counts(events, [t.name for t in model.transitions])
    # (an Observable has exactly one of expression and function)
    texts = [o.expression for o in observables if o.expression is not None]
    if texts:
        Observer(compiled, texts)  # a bad expression fails here, once, naming its token
    columns = ("run", *inputs, "status", "t_final", "jumps", *(c.column for c in counts),
               *(o.name for o in observables), "error")
    duplicate = next((c for c in columns if columns.count(c) > 1), None)
    if duplicate is not None:
        raise SweepError(f"column {duplicate!r} appears twice: rename the observable or count")

    placement = place(executor, len(runs))
    if not placement.in_process:
        for obs in observables:
            if obs.function is not None:
                try:
                    pickle.dumps(obs.function)
                except Exception:
                    _shutdown(placement)
                    raise SweepError(
                        f"observe {obs.name!r}: the function cannot be pickled for worker "
                        f"processes (a lambda or closure): define it at module level or use "
                        f"executor='serial' or 'threads'") from None
    size = chunksize or _default_chunksize(len(runs), placement.workers)
    chunks = [Chunk(text, key, tuple((i, runs[i]) for i in range(lo, min(lo + size, len(runs)))),
                    dict(options), observables, counts, keep == "results")
              for lo in range(0, len(runs), size)]
    worker_rows: list[tuple[Any, ...] | None] = [None] * len(runs)
    results: list[Any] = [None] * len(runs)
    bar = ProgressBar(len(runs), enabled=progress_wanted(progress))

    def collect(chunk: Chunk, outcome: list[tuple[int, tuple[Any, ...], Any]] | None,
                problem: str = "") -> None:
        if outcome is None:  # the whole chunk was lost (a worker died): record, go on
            nothing = (None,) * (len(counts) + len(observables))
            outcome = [(i, (ERROR, math.nan, None, *nothing, problem), None)
                       for i, _ in chunk.runs]
        for index, row, result in outcome:
            worker_rows[index] = row
            if result is not None:
                results[index] = dataclasses.replace(result, compiled=compiled)
        bar.update(len(chunk.runs))

    interrupted = False
    try:
        if placement.executor is None:
            for chunk in chunks:
                collect(chunk, run_chunk(chunk))
        else:
            placement = _run_pooled(placement, chunks, collect)
    except KeyboardInterrupt:  # keep every finished run; the others say they did not run
        interrupted = True
    finally:
        bar.close()
        _shutdown(placement)
    blank = (None,) * (len(counts) + len(observables))
    finished = [row if row is not None else (INTERRUPTED, math.nan, None, *blank,
                                             "interrupted (Ctrl-C) before this run finished")
                for row in worker_rows]
    rows = tuple((i, *input_rows[i], *row) for i, row in enumerate(finished))
    return SweepResult(columns=columns, rows=rows, inputs=tuple(inputs),
                       results=tuple(results) if keep == "results" else None,
                       elapsed=time.perf_counter() - started, executor=placement.label,
                       interrupted=interrupted)


def _run_pooled(placement: Any, chunks: Sequence[Chunk], collect: Any) -> Any:
    """Run ``chunks`` on the placement's executor; returns the placement finally used.

    A process that dies (killed by the system, or a run that crashes it) breaks its
    whole pool: every chunk not finished by then fails with ``BrokenProcessPool``.
    When the pool is ours, those chunks run once more in a new pool, and what is lost
    again runs one chunk at a time, each in a pool of its own, so that only the chunk
    that kills its process is recorded as ``ERROR`` rows.
    """
    lost = _submit(placement.executor, chunks, collect, placement.in_process)
    if not (lost and placement.owned and isinstance(placement.executor, cf.ProcessPoolExecutor)):
        for chunk in lost:
            collect(chunk, None, "BrokenProcessPool: a worker process died during this run")
        return placement
    placement.executor.shutdown(wait=True, cancel_futures=True)
    placement = dataclasses.replace(
        placement, executor=cf.ProcessPoolExecutor(max_workers=placement.workers))
    for chunk in _submit(placement.executor, lost, collect):
        with cf.ProcessPoolExecutor(max_workers=1) as alone:
            for again in _submit(alone, [chunk], collect):
                collect(again, None, "BrokenProcessPool: the worker process died running "
                                     "this chunk of runs, three times")
    return placement


def _submit(executor: Any, chunks: Sequence[Chunk], collect: Any,
            in_process: bool = False) -> list[Chunk]:
    """Run ``chunks`` on ``executor``, collecting each outcome; the chunks a broken pool lost.

    Ctrl-C reaches this thread only. With ``in_process`` (threads of this process) it
    sets a stop event, so that the chunks running in the other threads start no further
    run, and every chunk that started is collected with the runs it finished, wherever the
    interrupt came (even between a submission and its bookkeeping); worker processes get
    Ctrl-C themselves.
    """
    stop = threading.Event()
    lost: list[Chunk] = []
    pending: dict[cf.Future, Chunk] = {}  # submitted, not collected yet
    threads = _ThreadedChunks(stop) if in_process else None
    try:
        for chunk in chunks:  # in the try: Ctrl-C may come while the first chunks run
            pending[executor.submit(threads.run, chunk) if threads is not None
                    else executor.submit(run_chunk, chunk)] = chunk
        for future in cf.as_completed(list(pending)):
            chunk = pending.pop(future)
            try:
                outcome = future.result()
            except cf.process.BrokenProcessPool:
                lost.append(chunk)
            except Exception as exc:
                text = " ".join(str(exc).split())
                collect(chunk, None, f"{type(exc).__name__}: {text}")
            else:
                collect(chunk, outcome)
                if threads is not None:  # interrupted before this, it is collected again:
                    threads.collected(chunk)  # its rows are set, not added, so no run is lost
    except KeyboardInterrupt:
        if threads is not None:  # the running chunks start no further run; keep what they did
            for future in pending:
                future.cancel()  # a chunk not started stays so
            for chunk, outcome in threads.finish():
                collect(chunk, outcome)
        raise
    return lost


class _ThreadedChunks:
    """The chunks of one sweep run in threads: each started chunk's outcome is kept here by
    its own thread, so an interrupted sweep can collect every chunk that started, including
    one whose future the interrupted thread never recorded."""

    def __init__(self, stop: threading.Event) -> None:
        self.stop = stop
        self._lock = threading.Lock()
        self._started: dict[int, tuple[Chunk, threading.Event]] = {}
        self._outcomes: dict[int, list[tuple[int, tuple[Any, ...], Any]]] = {}
        self._collected: set[int] = set()

    def run(self, chunk: Chunk) -> list[tuple[int, tuple[Any, ...], Any]]:
        """:func:`run_chunk` with the sweep's stop event; its outcome is kept."""
        done = threading.Event()
        with self._lock:
            self._started[id(chunk)] = (chunk, done)
        try:
            outcome = run_chunk(chunk, self.stop)
            with self._lock:
                self._outcomes[id(chunk)] = outcome
            return outcome
        finally:
            done.set()

    def collected(self, chunk: Chunk) -> None:
        """Note that ``chunk``'s outcome was collected the usual way."""
        with self._lock:
            self._collected.add(id(chunk))

    def finish(self) -> list[tuple[Chunk, list[tuple[int, tuple[Any, ...], Any]]]]:
        """Stop the chunks, wait for those that started and return each outcome not
        collected yet (a chunk whose thread failed has none)."""
        self.stop.set()
        with self._lock:
            started = list(self._started.items())
        out = []
        for key, (chunk, done) in started:
            done.wait()
            with self._lock:
                outcome = self._outcomes.get(key)
                fresh = key not in self._collected
                self._collected.add(key)
            if outcome is not None and fresh:
                out.append((chunk, outcome))
        return out


def _shutdown(placement: Any) -> None:
    if placement.owned and placement.executor is not None:
        placement.executor.shutdown(wait=True, cancel_futures=True)


def sweep(model: Model | CompiledModel | str | Path | HybridProblem, *,
          grid: Mapping[str, Sequence[float]] | None = None, samples: Any = None,
          params: Mapping[str, float] | None = None, initial: Mapping[str, float] | None = None,
          scenario: str | None = None, t_end: float | None = None, observe: Any = None,
          events: Any = None, executor: Any = None, chunksize: int | None = None,
          progress: bool | None = None, keep: str = "observables",
          **simulate_options: Any) -> SweepResult:
    """Simulate a model over a grid or a sample of parameters and initial states.

    Parameters
    ----------
    model : Model, CompiledModel, str, pathlib.Path or HybridProblem
        A problem (with point values) supplies the defaults of ``params``,
        ``initial``, ``scenario``, ``t_end``, the mode and the integrator settings.
    grid : mapping of str to sequence of float, optional
        A full factorial: ``{"e": [0.5, 0.8], "h": [1, 2, 3]}`` makes 6 runs. A
        name that is a state sets the initial state, a parameter the parameter.
    samples : optional
        Explicit points: a sequence of ``{name: value}`` mappings, a numpy
        structured array, or a ``(names, array)`` pair with one row per run.
        With ``grid`` too, every sample is combined with every grid point.
    params, initial : mapping of str to float, optional
        Fixed overrides under every run (a swept name may not appear here).
    scenario : str, optional
        Scenario supplying defaults (as in :func:`hybridlab.simulate`).
    t_end : float, optional
        Final time (default: the scenario's).
    observe : mapping or sequence, optional
        What to record per run: ``{"h_end": "h", "top": ("max", "h"),
        "h5": ("at", "h", 5.0), "custom": function}``; a plain sequence of
        expressions records their final values. See
        :class:`hybridlab.ensemble.Observable`.
    events : sequence of str or Count, optional
        Transitions whose jumps are counted (column ``count:NAME``); a
        :class:`hybridlab.ensemble.Count` counts several together and/or only
        after another transition first fired.
    executor : optional
        ``None`` (serial for a few runs, else a process pool over every core),
        ``"serial"``, ``"threads"``, ``"processes"``, a worker count, any
        :class:`concurrent.futures.Executor`, or a ``distributed.Client``.
    chunksize : int, optional
        Runs per task sent to a worker (default: about eight tasks per worker,
        at most 256 runs each).
    progress : bool, optional
        A progress bar on stderr; default: when stderr is a terminal and the
        ``CI`` environment variable is unset.
    keep : {"observables", "results"}
        ``"results"`` also keeps every :class:`hybridlab.SimulationResult`
        (:attr:`SweepResult.results`); the default keeps only the table.
    **simulate_options
        Passed to every :func:`hybridlab.simulate` call (``method``, ``rtol``,
        ``atol``, ``max_step``, ``mode``, any :class:`SimulationOptions`
        field, a ``backend`` where supported).

    Returns
    -------
    SweepResult
        One row per run, in grid order (the last grid name varies fastest).
        A run that raises is recorded with status ``ERROR`` and its message;
        it never stops the sweep.

    Raises
    ------
    SweepError
        Before any run: an unknown name, scenario, transition, option or
        observable, or a function observable that cannot be pickled.

    Examples
    --------
    >>> import hybridlab
    >>> table = hybridlab.sweep("models/bouncing_ball.toml", grid={"h": [5.0, 10.0]},
    ...                         t_end=1.0, observe={"top": ("max", "h"), "v_end": "v"})
    >>> table.columns
    ('run', 'h', 'status', 't_final', 'jumps', 'top', 'v_end', 'error')
    >>> [round(float(v), 6) for v in table["v_end"]]    # -g t before the first bounce
    [-9.81, -9.81]
    >>> table["top"].tolist()
    [5.0, 10.0]
    """
    if isinstance(model, HybridProblem):
        compiled, params, initial, scenario, t_end, simulate_options = _problem_defaults(
            model, grid, samples, params, initial, scenario, t_end, simulate_options)
        model = compiled
    resolved, _ = _model_of(model)
    runs, swept = expand(resolved, grid=grid, samples=samples, params=params, initial=initial,
                         scenario=scenario, t_end=t_end)
    input_rows = [tuple({**run.get("params", {}), **run.get("initial", {})}[n] for n in swept)
                  for run in runs]
    return _execute(resolved if not isinstance(model, CompiledModel) else model, runs, swept,
                    input_rows, observe=observe, events=events, executor=executor,
                    chunksize=chunksize, progress=progress, keep=keep, options=simulate_options)


def _problem_defaults(problem: HybridProblem, grid: Any, samples: Any,
                      params: Mapping[str, float] | None, initial: Mapping[str, float] | None,
                      scenario: str | None, t_end: float | None, options: Mapping[str, Any]
                      ) -> tuple[CompiledModel, dict[str, Any], dict[str, Any], str | None,
                                 float, dict[str, Any]]:
    """The problem's values as the defaults of a sweep's arguments (swept names excluded)."""
    base = problem.arguments("sweep")
    swept = set(grid or ()) | ({n for point in sample_points(samples) for n in point}
                               if samples is not None else set())

    def fixed(given: Mapping[str, Any] | None, own: Mapping[str, Any]) -> dict[str, Any]:
        return {**{k: v for k, v in own.items() if k not in swept}, **(given or {})}

    settings = {k: base[k] for k in ("mode", "t_start", "options")}
    return (problem.compiled, fixed(params, base["params"]), fixed(initial, base["initial"]),
            scenario or base["scenario"], t_end if t_end is not None else base["t_end"],
            {**settings, **options})


def simulate_many(model: Model | CompiledModel | str | Path,
                  runs: Sequence[Mapping[str, Any]], *, observe: Any = None, events: Any = None,
                  executor: Any = None, chunksize: int | None = None,
                  progress: bool | None = None, keep: str = "observables",
                  **simulate_options: Any) -> SweepResult:
    """Simulate a list of runs, each given as :func:`hybridlab.simulate` keyword arguments.

    Parameters
    ----------
    model : Model, CompiledModel, str or pathlib.Path
    runs : sequence of mapping
        Each may set ``params``, ``initial`` (mappings), ``t_end``,
        ``scenario`` and ``mode``.
    observe, events, executor, chunksize, progress, keep, **simulate_options
        As for :func:`sweep`.

    Returns
    -------
    SweepResult
        Input columns: every parameter and state set by some run (missing
        where a run does not set it), then ``t_end``, ``scenario``, ``mode``
        when some run sets them.

    Examples
    --------
    >>> import hybridlab
    >>> table = hybridlab.simulate_many("models/thermostat.toml", [
    ...     {"initial": {"T": 20.0}}, {"initial": {"T": 21.0}, "t_end": 5.0}],
    ...     events=["turn_off"], executor="serial")
    >>> table.columns[:4], table["t_final"].tolist()
    (('run', 'T', 't_end', 'status'), [60.0, 5.0])
    """
    resolved, _ = _model_of(model)
    if isinstance(runs, Mapping | str | bytes):
        raise SweepError("runs: expected a sequence of mappings")
    normal = [normalise_run(resolved, run, k) for k, run in enumerate(runs)]
    used_p = {n for run in normal for n in run.get("params", {})}
    used_x = {n for run in normal for n in run.get("initial", {})}
    inputs = [n for n in resolved.parameters if n in used_p]
    inputs += [n for n in resolved.states if n in used_x]
    extra = [k for k in RUN_KEYS[2:] if any(k in run for run in normal)]
    input_rows = [tuple({**run.get("params", {}), **run.get("initial", {})}.get(n)
                        for n in inputs) + tuple(run.get(k) for k in extra) for run in normal]
    return _execute(model if isinstance(model, CompiledModel) else resolved, normal,
                    [*inputs, *extra], input_rows, observe=observe, events=events,
                    executor=executor, chunksize=chunksize, progress=progress, keep=keep,
                    options=simulate_options)
