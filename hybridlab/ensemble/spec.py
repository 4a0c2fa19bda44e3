"""Which runs a sweep makes: grid expansion, samples, and name resolution."""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from hybridlab.ensemble.errors import SweepError
from hybridlab.model.schema import Model

__all__ = ["RUN_KEYS", "expand", "normalise_run", "resolve_names", "sample_points"]

#: Keys a run of :func:`hybridlab.simulate_many` may set (``simulate`` keyword arguments).
RUN_KEYS = ("params", "initial", "t_end", "scenario", "mode")


def _number(value: Any, where: str) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise SweepError(f"{where}: {value!r} is not a number") from None
    if not math.isfinite(number):
        raise SweepError(f"{where}: {value!r} is not a finite number")
    return number


def resolve_names(model: Model, values: Mapping[str, Any], argument: str
                  ) -> tuple[dict[str, float], dict[str, float]]:
    """Split ``{name: value}`` into parameter and initial-state overrides.

    A model name is either a state or a parameter (model files forbid a name
    in two sections), so the split is unambiguous.

    Examples
    --------
    >>> import hybridlab
    >>> ball = hybridlab.load_model("models/bouncing_ball.toml")
    >>> resolve_names(ball, {"e": 0.5, "h": 2.0}, "grid")
    ({'e': 0.5}, {'h': 2.0})
    >>> resolve_names(ball, {"hh": 1.0}, "grid")
    Traceback (most recent call last):
    ...
    hybridlab.ensemble.errors.SweepError: grid: 'hh' is neither a parameter nor a state ... h, v)
    """
    params: dict[str, float] = {}
    initial: dict[str, float] = {}
    for name, value in values.items():
        if name in model.parameters:
            params[name] = _number(value, f"{argument} {name!r}")
        elif name in model.state_names:  # a discrete variable's start too
            initial[name] = _number(value, f"{argument} {name!r}")
        else:
            raise SweepError(
                f"{argument}: {name!r} is neither a parameter nor a state of model "
                f"{model.name!r} (parameters: {', '.join(model.parameters) or '-'}; "
                f"states: {', '.join(model.state_names)})")
    return params, initial


#: The most runs one sweep may request: a grid or sample set past it is refused before
#: anything is allocated (a grid of 10**9 points would need gigabytes first).
MAX_RUNS = 1_000_000


def check_run_count(count: int, what: str) -> None:
    """Refuse a request of more than :data:`MAX_RUNS` runs, naming what asked for them."""
    if count > MAX_RUNS:
        raise SweepError(f"{what}: {count} runs requested; a sweep may have at most "
                         f"{MAX_RUNS} (split it, or sample instead of a full grid)")


def _grid_points(grid: Mapping[str, Any]) -> list[dict[str, float]]:
    names = list(grid)
    sizes = [np.size(grid[name]) for name in names]
    check_run_count(int(np.prod(sizes, dtype=float)) if sizes else 0, "grid")
    axes = []
    for name in names:
        values = np.atleast_1d(np.asarray(grid[name], dtype=object))
        if values.ndim != 1 or values.size == 0:
            raise SweepError(f"grid {name!r}: expected a non-empty 1-D sequence of values")
        axes.append([_number(v, f"grid {name!r}") for v in values])
    return [dict(zip(names, combo, strict=True)) for combo in itertools.product(*axes)]


def sample_points(samples: Any) -> list[dict[str, float]]:
    """The points of ``samples`` (mappings, a structured array or a ``(names, array)`` pair).

    Examples
    --------
    >>> sample_points((["e", "h"], [[0.5, 1.0], [0.7, 2.0]]))
    [{'e': 0.5, 'h': 1.0}, {'e': 0.7, 'h': 2.0}]
    """
    if isinstance(samples, np.ndarray) and samples.dtype.names:
        names = list(samples.dtype.names)
        return [{n: _number(row[n], f"samples {n!r}") for n in names} for row in samples]
    if (isinstance(samples, tuple) and len(samples) == 2 and not isinstance(samples[0], Mapping)
            and all(isinstance(n, str) for n in samples[0])):
        names = list(samples[0])
        table = np.asarray(samples[1], dtype=float)
        if table.ndim != 2 or table.shape[1] != len(names):
            raise SweepError(f"samples: a ({len(names)} names, array) pair needs an array of "
                             f"shape (runs, {len(names)}) (got shape {table.shape})")
        return [dict(zip(names, map(float, row), strict=True)) for row in table]
    if isinstance(samples, Mapping | str | bytes):
        raise SweepError("samples: expected a sequence of {name: value} mappings, a structured "
                         "array or a (names, 2-D array) pair")
    out = []
    for k, sample in enumerate(samples):
        if not isinstance(sample, Mapping):
            raise SweepError(f"samples[{k}]: expected a mapping of name to value "
                             f"(got {type(sample).__name__})")
        out.append({str(n): _number(v, f"samples[{k}] {n!r}") for n, v in sample.items()})
    return out


def expand(model: Model, *, grid: Mapping[str, Any] | None, samples: Any,
           params: Mapping[str, float] | None, initial: Mapping[str, float] | None,
           scenario: str | None, t_end: float | None) -> tuple[list[dict[str, Any]], list[str]]:
    """The runs of a sweep as ``simulate`` keyword mappings, and the swept names.

    ``grid`` is a full factorial; with ``samples`` too, every sample is
    combined with every grid point. ``params`` and ``initial`` are fixed
    overrides under every run; a swept name may not appear in them.

    Examples
    --------
    >>> import hybridlab
    >>> ball = hybridlab.load_model("models/bouncing_ball.toml")
    >>> runs, swept = expand(ball, grid={"e": [0.5, 0.9], "h": [1.0, 2.0]}, samples=None,
    ...                      params=None, initial=None, scenario=None, t_end=3.0)
    >>> swept, len(runs), runs[1]
    (['e', 'h'], 4, {'params': {'e': 0.5}, 'initial': {'h': 2.0}, 't_end': 3.0})
    """
    if grid is not None and not isinstance(grid, Mapping):
        raise SweepError("grid: expected a mapping {name: values}")
    if grid:
        resolve_names(model, dict.fromkeys(grid, 0.0), "grid")  # names first: a clear message
    points = _grid_points(grid) if grid else [{}]
    if samples is not None:
        sampled = sample_points(samples)
        check_run_count(len(sampled) * len(points), "samples times grid")
        points = [{**s, **g} for s in sampled for g in points]
        clash = set(grid or ()) & {n for s in sampled for n in s}
        if clash:
            raise SweepError(f"grid and samples both set {sorted(clash)[0]!r}")
    swept = list(dict.fromkeys(n for p in points for n in p))
    base_params, base_initial = resolve_names(model, {**(params or {}), **(initial or {})},
                                              "params/initial")
    for name in swept:
        if name in base_params or name in base_initial:
            raise SweepError(f"{name!r} is swept and also given as a fixed value")
    runs = []
    for point in points:
        p, x = resolve_names(model, point, "samples")
        run: dict[str, Any] = {}
        if base_params or p:
            run["params"] = {**base_params, **p}
        if base_initial or x:
            run["initial"] = {**base_initial, **x}
        if t_end is not None:
            run["t_end"] = _number(t_end, "t_end")
        if scenario is not None:
            run["scenario"] = scenario
        runs.append(run)
    return runs, swept


def normalise_run(model: Model, run: Mapping[str, Any], k: int) -> dict[str, Any]:
    """Check one run of :func:`simulate_many` and return it as ``simulate`` keywords.

    Examples
    --------
    >>> import hybridlab
    >>> ball = hybridlab.load_model("models/bouncing_ball.toml")
    >>> normalise_run(ball, {"params": {"e": 0.5}, "t_end": 2}, 0)
    {'params': {'e': 0.5}, 't_end': 2.0}
    >>> normalise_run(ball, {"param": {"e": 0.5}}, 3)
    Traceback (most recent call last):
    ...
    hybridlab.ensemble.errors.SweepError: runs[3]: unknown key 'param'; a run may set params, ...
    """
    if not isinstance(run, Mapping):
        raise SweepError(f"runs[{k}]: expected a mapping (got {type(run).__name__})")
    out: dict[str, Any] = {}
    for key, value in run.items():
        if key not in RUN_KEYS:
            raise SweepError(f"runs[{k}]: unknown key {key!r}; a run may set "
                             f"{', '.join(RUN_KEYS)}")
        if key in ("params", "initial"):
            if not isinstance(value, Mapping):
                raise SweepError(f"runs[{k}].{key}: expected a mapping of name to value")
            known = model.parameters if key == "params" else model.state_names
            kind = "parameter" if key == "params" else "state"
            for name in value:
                if name not in known:
                    raise SweepError(f"runs[{k}].{key}: unknown {kind} {name!r} of model "
                                     f"{model.name!r}")
            out[key] = {n: _number(v, f"runs[{k}].{key} {n!r}") for n, v in value.items()}
        elif key == "t_end":
            out[key] = _number(value, f"runs[{k}].t_end")
        elif value is not None:
            out[key] = str(value)
    return out
