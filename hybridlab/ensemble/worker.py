"""What runs in a worker: one chunk of runs, recorded as table rows.

Workers receive the declarative model as its canonical JSON text and compile
it themselves; compiled functions never cross a process boundary (a
:class:`Model` that has been compiled carries its compiled form privately, so
the text is sent rather than the object).
Each process keeps a small cache of compiled models keyed by the model's
content hash, so a worker compiles a model once however many chunks it runs.
The cache is private to this module, holds nothing a user can observe except
speed, and is bounded.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import threading
from collections import OrderedDict
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from hybridlab.ensemble.observables import Count, Observable
from hybridlab.model.schema import Model
from hybridlab.simulation.api import simulate
from hybridlab.simulation.observe import Observer
from hybridlab.symbolic.compile import CompiledModel, compile_model

__all__ = ["ERROR", "Chunk", "compiled_for", "model_key", "model_text", "run_chunk"]

#: Status column value of a run that raised instead of returning a result.
ERROR = "ERROR"

_CACHE_SIZE = 8
# A per-process cache (compiled model by content hash): see the module docstring.
_compiled_cache: OrderedDict[str, CompiledModel] = OrderedDict()
_cache_lock = threading.Lock()


def model_text(model: Model) -> str:
    """The canonical JSON text of a model, what workers receive."""
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


@dataclass(frozen=True)
class Chunk:
    """A batch of runs for one worker call.

    Attributes
    ----------
    model : str
        The model's JSON text (:func:`model_text`).
    key : str
        ``model_key(model)``.
    runs : tuple of (int, mapping)
        Run index and its ``simulate`` keyword arguments.
    options : mapping
        Keyword arguments shared by every run (integrator settings, backend).
    observables, counts : tuples
        What to record.
    keep_results : bool
        Also return the :class:`SimulationResult` (without its compiled model,
        which the caller re-attaches).
    """

    model: str
    key: str
    runs: tuple[tuple[int, Mapping[str, Any]], ...]
    options: Mapping[str, Any]
    observables: tuple[Observable, ...]
    counts: tuple[Count, ...]
    keep_results: bool = False


def _one_line(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {' '.join(str(exc).split())}"


def _observe(result: Any, observer: Observer | None, observables: Sequence[Observable]
             ) -> tuple[list[Any], list[str]]:
    values: list[Any] = []
    problems: list[str] = []
    exprs = [o for o in observables if o.function is None]
    stored = None
    if observer is not None and any(o.reduction in ("min", "max") for o in exprs):
        try:
            stored = observer.evaluate(result)
        except Exception as exc:  # a mode without the definition: record, go on
            problems.append(f"observe: {_one_line(exc)}")
    k = 0
    for obs in observables:
        try:
            if obs.function is not None:
                value = float(obs.function(result))
            else:
                row = k
                k += 1
                if obs.reduction == "final":
                    value = float(observer.evaluate(result, [result.final.t])[row, 0])
                elif obs.reduction == "at":
                    if not result.segments[0].t_start <= obs.time <= result.final.t:
                        value = None
                    else:
                        value = float(observer.evaluate(result, [obs.time])[row, 0])
                elif stored is None:
                    value = None
                else:
                    reduce = np.max if obs.reduction == "max" else np.min
                    value = float(reduce(stored[row]))
        except Exception as exc:
            problems.append(f"observe {obs.name!r}: {_one_line(exc)}")
            value = None
        values.append(value)
    return values, problems


def run_chunk(chunk: Chunk) -> list[tuple[int, tuple[Any, ...], Any]]:
    """Simulate every run of ``chunk``; a failing run becomes a row, never an exception.

    Returns ``(index, row, result_or_None)`` triples; ``row`` is
    ``(status, t_final, jumps, *counts, *observables, error)``.
    """
    compiled = compiled_for(chunk.model, chunk.key)
    texts = [o.expression for o in chunk.observables if o.function is None]
    observer = Observer(compiled, texts) if texts else None
    out = []
    for index, run in chunk.runs:
        try:
            result = simulate(compiled, **run, **chunk.options)
        except Exception as exc:
            nothing = [None] * (len(chunk.counts) + len(chunk.observables))
            out.append((index, (ERROR, math.nan, None, *nothing, _one_line(exc)), None))
            continue
        jumps = result.jumps
        counts = [c.evaluate(jumps) for c in chunk.counts]
        values, problems = _observe(result, observer, chunk.observables)
        row = (result.status.name, float(result.final.t), len(jumps), *counts, *values,
               "; ".join(problems))
        kept = dataclasses.replace(result, compiled=None) if chunk.keep_results else None
        out.append((index, row, kept))
    return out
