"""What runs in a worker: one chunk of runs, recorded as table rows.

Workers receive the declarative model as its canonical JSON text and compile
it themselves; compiled functions never cross a process boundary (a
:class:`Model` that has been compiled carries its compiled form privately, so
the text is sent rather than the object). The text, its hash and the bounded
per-process cache of compiled models live in :mod:`hybridlab.simulation.executors`
(shared with :func:`hybridlab.reach`).
"""

from __future__ import annotations

import dataclasses
import math
import threading
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from hybridlab.ensemble.observables import Count, Observable
from hybridlab.simulation.api import simulate
from hybridlab.simulation.executors import compiled_for, model_key, model_text
from hybridlab.simulation.observe import Observer

__all__ = ["ERROR", "Chunk", "compiled_for", "model_key", "model_text", "run_chunk"]

#: Status column value of a run that raised instead of returning a result.
ERROR = "ERROR"
#: the status of a run that Ctrl-C stopped before it finished
INTERRUPTED = "INTERRUPTED"


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

    Examples
    --------
    Two runs of the ball with their own restitution, on the reference engine; a chunk
    is plain data, pickled to a worker process:

    >>> import pickle
    >>> import hybridlab
    >>> from hybridlab.ensemble.observables import Count, Observable
    >>> text = model_text(hybridlab.load_model("models/bouncing_ball.toml"))
    >>> chunk = Chunk(text, model_key(text),
    ...               ((0, {"t_end": 3.0, "params": {"e": 0.5}}),
    ...                (1, {"t_end": 3.0, "params": {"e": 0.9}})),
    ...               {"backend": "reference"}, (Observable("h_end", "h"),),
    ...               (Count(("bounce",)),))
    >>> pickle.loads(pickle.dumps(chunk)) == chunk, [index for index, _ in chunk.runs]
    (True, [0, 1])
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
                if observer is None:  # run_chunk makes one when an observable has an expression
                    raise RuntimeError("no observer for the observables' expressions")
                if obs.reduction == "final":
                    value = float(observer.evaluate(result, [result.final.t])[row, 0])
                elif obs.reduction == "at":
                    at = obs.time
                    if at is None:  # Observable requires a time for "at"
                        raise RuntimeError("'at' without a time")
                    if not result.segments[0].t_start <= at <= result.final.t:
                        value = None
                    else:
                        value = float(observer.evaluate(result, [at])[row, 0])
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


def run_chunk(chunk: Chunk, stop: threading.Event | None = None
              ) -> list[tuple[int, tuple[Any, ...], Any]]:
    """Simulate every run of ``chunk``; a failing run becomes a row, never an exception.

    Returns ``(index, row, result_or_None)`` triples; ``row`` is
    ``(status, t_final, jumps, *counts, *observables, error)``. Once ``stop``
    is set (a sweep interrupted while this chunk runs in a thread, which Ctrl-C
    does not reach), no further run starts and the runs done so far are returned.

    Examples
    --------
    >>> import hybridlab
    >>> from hybridlab.ensemble.observables import Count, Observable
    >>> text = model_text(hybridlab.load_model("models/bouncing_ball.toml"))
    >>> chunk = Chunk(text, model_key(text),
    ...               ((0, {"t_end": 3.0, "params": {"e": 0.5}}),
    ...                (1, {"t_end": 3.0, "params": {"f": 0.5}})),
    ...               {"backend": "reference"}, (Observable("h_end", "h"),),
    ...               (Count(("bounce",)),))
    >>> (index, row, kept), (_, failed, _) = run_chunk(chunk)
    >>> row[:4], round(row[4], 6), row[5], kept  # status, t_final, jumps, bounces; h_end
    (('COMPLETED', 3.0, 2, 2), 0.403202, '', None)
    >>> failed  # the misspelt parameter: a row saying why, not an exception
    ('ERROR', nan, None, None, None, "ProblemError: params: unknown parameter 'f'; ...")
    """
    compiled = compiled_for(chunk.model, chunk.key)
    # (an Observable has exactly one of expression and function)
    texts = [o.expression for o in chunk.observables if o.expression is not None]
    observer = Observer(compiled, texts) if texts else None
    out: list[tuple[int, tuple[Any, ...], Any]] = []
    for index, run in chunk.runs:
        if stop is not None and stop.is_set():
            break
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
