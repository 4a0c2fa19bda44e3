"""Where independent tasks run (in process, a pool, a Dask cluster) and how a model gets there.

Shared by :func:`hybridlab.sweep` (chunks of runs) and :func:`hybridlab.reach`
(pieces of a split initial set). Compiled models cannot be pickled, so worker
processes receive the declarative model as its canonical JSON text
(:func:`model_text`) and compile it themselves through :func:`compiled_for`,
which keeps a small per-process cache keyed by the model's content hash: a
worker compiles a model once however many tasks it runs. The cache holds
nothing a user can observe except speed, and is bounded.
"""

from __future__ import annotations

import concurrent.futures as cf
import hashlib
import os
import threading
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any

from hybridlab.errors import HybridlabError
from hybridlab.model.schema import Model
from hybridlab.symbolic.compile import CompiledModel, compile_model

__all__ = ["SERIAL_BELOW", "ExecutorError", "Placement", "check_executor", "compiled_for",
           "model_key", "model_text", "place"]

#: Jobs with fewer tasks than this run in process by default (a pool costs more).
SERIAL_BELOW = 4



class ExecutorError(HybridlabError, ValueError):
    """An ``executor`` argument that names no way to run tasks (one line).

    Examples
    --------
    >>> place("gpu", 3)
    Traceback (most recent call last):
    ...
    hybridlab.simulation.executors.ExecutorError: executor: expected an Executor, ... (got 'gpu')
    >>> issubclass(ExecutorError, ValueError)
    True
    """


_EXPECTED = "expected an Executor, a Client, an int or one of 'serial', 'threads', 'processes'"


@dataclass(frozen=True)
class Placement:
    """The executor chosen for a job.

    Attributes
    ----------
    executor : concurrent.futures.Executor or None
        ``None``: run serially in this process.
    owned : bool
        Created here, so the job shuts it down (:meth:`shutdown`).
    in_process : bool
        Tasks share this process (serial or threads): nothing is pickled.
    workers : int
        Parallel workers (for default chunk sizes).
    label : str
        What ran the job (``serial``, ``threads(2)``, ...), as a sweep reports it.

    Examples
    --------
    >>> placement = place("threads", 1)
    >>> placement.label, placement.owned, placement.in_process, placement.workers
    ('threads(1)', True, True, 1)
    >>> placement.shutdown()  # created by place(), so the job shuts it down
    >>> place(1, 5)  # one worker: serial, in this process
    Placement(executor=None, owned=False, in_process=True, workers=1, label='serial')
    """

    executor: cf.Executor | None
    owned: bool
    in_process: bool
    workers: int
    label: str

    def shutdown(self) -> None:
        """Shut the executor down if it was created here (a user's executor is left running)."""
        if self.owned and self.executor is not None:
            self.executor.shutdown(wait=True, cancel_futures=True)


def _cpus() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on every platform
        return os.cpu_count() or 1


def check_executor(executor: Any, error: type[Exception] = ExecutorError) -> None:
    """Raise ``error`` (one line) unless ``executor`` is a value :func:`place` accepts.

    Creates nothing: for checking an argument before expensive work.

    Examples
    --------
    >>> check_executor("threads")
    >>> try:
    ...     check_executor("gpu")
    ... except ValueError as exc:
    ...     print(exc)  # doctest: +ELLIPSIS
    executor: expected an Executor, a Client, an int or one of ... (got 'gpu')
    """
    if executor is None or isinstance(executor, cf.Executor):
        return
    if isinstance(executor, bool):
        raise error(f"executor: {_EXPECTED} (got {executor!r})")
    if isinstance(executor, int):
        if executor < 1:
            raise error(f"executor: a worker count must be at least 1 (got {executor})")
        return
    if isinstance(executor, str) and executor in ("serial", "threads", "processes"):
        return
    if callable(getattr(executor, "get_executor", None)):  # a distributed.Client
        return
    raise error(f"executor: {_EXPECTED} (got {executor!r})")


def place(executor: Any, n_tasks: int, error: type[Exception] = ExecutorError) -> Placement:
    """Resolve an ``executor`` argument for a job of ``n_tasks`` independent tasks.

    ``None`` (auto): serial below :data:`SERIAL_BELOW` tasks or on one core,
    else a process pool over every core; ``"serial"``, ``"threads"``,
    ``"processes"``; an int ``N`` (a process pool of ``N`` workers, 1 = serial);
    any :class:`concurrent.futures.Executor`; or a ``distributed.Client``
    (its ``get_executor()`` is used). A bad value raises ``error`` with one line.

    Examples
    --------
    >>> place("serial", 10).label
    'serial'
    >>> place(None, 2).executor is None
    True
    """
    check_executor(executor, error)
    cpus = _cpus()
    if executor is None:
        executor = "serial" if n_tasks < SERIAL_BELOW or cpus < 2 else "processes"
    if isinstance(executor, int):
        if executor == 1:
            return Placement(None, False, True, 1, "serial")
        pool = cf.ProcessPoolExecutor(max_workers=min(executor, max(n_tasks, 1)))
        return Placement(pool, True, False, executor, f"processes({executor})")
    if executor == "serial":
        return Placement(None, False, True, 1, "serial")
    if executor == "threads":
        n = min(cpus, max(n_tasks, 1))
        return Placement(cf.ThreadPoolExecutor(max_workers=n), True, True, n, f"threads({n})")
    if executor == "processes":
        n = min(cpus, max(n_tasks, 1))
        return Placement(cf.ProcessPoolExecutor(max_workers=n), True, False, n, f"processes({n})")
    if isinstance(executor, cf.ThreadPoolExecutor):
        n = getattr(executor, "_max_workers", cpus)
        return Placement(executor, False, True, n, f"{type(executor).__name__}")
    if isinstance(executor, cf.Executor):
        n = getattr(executor, "_max_workers", cpus)
        return Placement(executor, False, False, n, f"{type(executor).__name__}")
    # a distributed.Client (check_executor let it through), without importing distributed here
    n = cpus
    info = getattr(executor, "nthreads", None)
    if callable(info):
        try:
            n = max(1, sum(info().values()))
        except Exception:  # a client that cannot report its workers: assume local cores
            n = cpus
    return Placement(executor.get_executor(), False, False, n, f"dask({n})")


# ----- shipping a model to workers ----------------------------------------------------------

_CACHE_SIZE = 8
# A per-process cache (compiled model by content hash): see the module docstring.
_compiled_cache: OrderedDict[str, CompiledModel] = OrderedDict()
_cache_lock = threading.Lock()


def model_text(model: Model) -> str:
    """The canonical JSON text of a model, what workers receive.

    Examples
    --------
    >>> import hybridlab
    >>> ball = hybridlab.load_model("models/bouncing_ball.toml")
    >>> text = model_text(ball)
    >>> text[:24]
    '{"name":"bouncing_ball",'
    >>> hybridlab.Model.model_validate_json(text) == ball  # what a worker rebuilds
    True
    """
    return model.model_dump_json()


def model_key(text: str) -> str:
    """Content hash of a model's JSON text.

    Examples
    --------
    >>> import hybridlab
    >>> ball = hybridlab.load_model("models/bouncing_ball.toml")
    >>> copy = hybridlab.loads_model(hybridlab.dumps_model(ball))
    >>> model_key(model_text(ball)) == model_key(model_text(copy))
    True
    """
    return hashlib.sha256(text.encode()).hexdigest()


def compiled_for(text: str, key: str | None = None, compiled: CompiledModel | None = None,
                 model: Model | None = None) -> CompiledModel:
    """The compiled model of JSON ``text`` from this process's cache, compiling on a miss.

    On a miss, ``compiled`` (when given) is stored for ``key``; else ``model``
    (when given) is compiled, which reuses the compiled form it may already
    carry (and whatever a backend prepared for it, which forked workers then
    inherit); else the text is parsed and compiled.

    Examples
    --------
    >>> import hybridlab
    >>> text = model_text(hybridlab.load_model("models/bouncing_ball.toml"))
    >>> compiled = compiled_for(text)
    >>> compiled.model.name, compiled_for(text) is compiled  # the second call is a cache hit
    ('bouncing_ball', True)
    """
    key = key or model_key(text)
    with _cache_lock:
        hit = _compiled_cache.get(key)
        if hit is not None:
            _compiled_cache.move_to_end(key)
            return hit
    if compiled is None:
        compiled = compile_model(model if model is not None else Model.model_validate_json(text))
    fresh = compiled
    with _cache_lock:
        _compiled_cache[key] = fresh
        while len(_compiled_cache) > _CACHE_SIZE:
            _compiled_cache.popitem(last=False)
    return fresh
