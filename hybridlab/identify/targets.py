"""Published or measured summary quantities of a model's responses: :class:`Target`.

A target is one number that a simulation of an experiment should reproduce, with its
uncertainty: how many times a signal crosses a level, the mean time between such
crossings (a period), the value of an expression at them, or the overshoot or settling
time of a step. :func:`hybridlab.identify.fit_targets` adjusts model parameters until
the simulated quantities match. Targets are built in Python or read from TOML/JSON with
:func:`read_targets`::

    [[targets]]
    name = "crossings, nominal friction"
    kind = "count"
    observable = "phi"
    value = 63
    tolerance = 1
    scenario = "free_drop_nominal"

The experiment of a target is its ``scenario`` plus ``params`` / ``initial`` overrides
and an optional ``t_end``; targets with the same experiment share one simulation.
"""

from __future__ import annotations

import json
import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from hybridlab._files import read_bounded
from hybridlab.identify.errors import TargetError
from hybridlab.identify.summary import (
    Crossings,
    continuous_count,
    level_crossings,
    refined_step_metrics,
)
from hybridlab.simulation.observe import Observer
from hybridlab.simulation.result import SimulationResult
from hybridlab.symbolic.compile import CompiledModel

__all__ = ["KINDS", "MAX_SAMPLES", "Target", "read_targets", "target_statistic"]

#: The kinds of target and what they measure.
KINDS = {
    "count": "number of events (continuous surrogate: crossings plus a fraction)",
    "interval": "mean time between consecutive events (s)",
    "value": "value of the expression `at` at the events (one event by `index`, else the mean)",
    "overshoot": "overshoot of a step of `observable` (percent of the step)",
    "settling_time": "time to enter the band +-`band` around the final value for good (s)",
}
_EVENT_KINDS = ("count", "interval", "value")
#: The most samples a target's signal is evaluated at (``t_end / dt``): 10 million, 80 MB.
MAX_SAMPLES = 10_000_000
#: A count of N means the continuous count lies in (N, N + 1]: its standard deviation.
COUNT_QUANTUM_SD = 1.0 / math.sqrt(12.0)


@dataclass(frozen=True)
class Target:
    """One summary quantity of one experiment, with its uncertainty.

    Parameters
    ----------
    kind : {"count", "interval", "value", "overshoot", "settling_time"}
        What is measured (see :data:`KINDS`).
    value : float
        The published or measured number.
    tolerance : float
        Its standard uncertainty; the residual is ``(simulated - value) / tolerance``.
        For a count, the quantisation ``1/sqrt(12)`` is added in quadrature.
    observable : str, optional
        Event kinds: the expression whose crossings of ``level`` are the events. Step
        kinds: the expression whose step response is measured.
    transition : str, optional
        Event kinds, instead of ``observable``: the events are the jumps through this
        transition (their count is integer-valued except where ``t_end`` cuts it).
    level : float
        The level crossed (event kinds with ``observable``).
    direction : {0, 1, -1}
        Count only upward (+1) or downward (-1) crossings; 0 counts both. The period of
        an oscillation is the ``interval`` of crossings in one direction.
    at : str, optional
        Kind ``value``: the expression evaluated at the events (post-jump at jumps).
    index : int, optional
        Kind ``value``: which event (0 the first, -1 the last); default the mean.
    start, final : float or str
        Step kinds: initial and final value of the step, numbers or expressions
        (``start`` evaluated at the first instant, ``final`` at the last).
    band : float
        Kind ``settling_time``: the settling band as a fraction of the step.
    scenario : str, optional
        The experiment's scenario.
    params, initial : mapping of str to float
        Parameter and initial-state overrides on top of the scenario's (e.g. a lighter
        load); fitted parameters override ``params``.
    t_end : float, optional
        Horizon (default: the scenario's).
    dt : float, optional
        Sampling step for crossings and step metrics (default: the span / 50000).
    name : str
        A label for tables.

    Examples
    --------
    >>> Target("count", 63, 1.0, observable="phi", scenario="free_drop_nominal").label
    'count of phi crossings [free_drop_nominal]'
    >>> Target("count", 63, 0.0, observable="phi")
    Traceback (most recent call last):
    ...
    hybridlab.identify.errors.TargetError: tolerance: must be a positive number (got 0.0)
    """

    kind: str
    value: float
    tolerance: float
    observable: str | None = None
    transition: str | None = None
    level: float = 0.0
    direction: int = 0
    at: str | None = None
    index: int | None = None
    start: float | str = 0.0
    final: float | str | None = None
    band: float = 0.02
    scenario: str | None = None
    params: Mapping[str, float] = field(default_factory=dict)
    initial: Mapping[str, float] = field(default_factory=dict)
    t_end: float | None = None
    dt: float | None = None
    name: str = ""

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise TargetError(f"must be one of {', '.join(KINDS)} (got {self.kind!r})",
                              key="kind")
        for key in ("value", "tolerance", "level", "band"):
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, int | float) \
                    or not math.isfinite(value):
                raise TargetError(f"must be a finite number (got {value!r})", key=key)
        if not self.tolerance > 0:
            raise TargetError(f"must be a positive number (got {self.tolerance!r})",
                              key="tolerance")
        if self.direction not in (-1, 0, 1):
            raise TargetError(f"must be -1, 0 or 1 (got {self.direction!r})", key="direction")
        for key in ("t_end", "dt"):
            value = getattr(self, key)
            if value is not None and not (isinstance(value, int | float) and value > 0
                                          and math.isfinite(value)):
                raise TargetError(f"must be a positive finite number (got {value!r})", key=key)
        if self.kind in _EVENT_KINDS:
            if (self.observable is None) == (self.transition is None):
                raise TargetError(f"a {self.kind!r} target needs exactly one of observable "
                                  "and transition", key="observable")
            if self.kind == "value" and not self.at:
                raise TargetError("a 'value' target needs the expression to evaluate",
                                  key="at")
        else:
            if not self.observable:
                raise TargetError(f"a {self.kind!r} target needs the observable whose step "
                                  "is measured", key="observable")
            if self.final is None:
                raise TargetError(f"a {self.kind!r} target needs the final value of the step",
                                  key="final")
            if not 0 < self.band < 1:
                raise TargetError(f"must lie in (0, 1) (got {self.band!r})", key="band")
        for key in ("params", "initial"):
            mapping = getattr(self, key)
            if not isinstance(mapping, Mapping) or not all(
                    isinstance(v, int | float) and not isinstance(v, bool)
                    for v in mapping.values()):
                raise TargetError(f"must map names to numbers (got {mapping!r})", key=key)
            object.__setattr__(self, key, {str(k): float(v) for k, v in mapping.items()})

    @property
    def label(self) -> str:
        """``name``, or a description built from the kind and the experiment."""
        if self.name:
            return self.name
        what = (f"{self.observable} crossings" if self.observable and self.kind in _EVENT_KINDS
                else self.transition or self.observable)
        if self.kind == "value":
            what = f"{self.at} at {what}"
        where = ", ".join([self.scenario or "default",
                           *(f"{k}={v:g}" for k, v in self.params.items())])
        return f"{self.kind} of {what} [{where}]"

    @property
    def sigma(self) -> float:
        """The residual's scale: ``tolerance``, for counts combined with the quantisation."""
        if self.kind == "count":
            return math.hypot(self.tolerance, COUNT_QUANTUM_SD)
        return float(self.tolerance)

    @property
    def reference(self) -> float:
        """What the continuous statistic is compared with: a count ``N`` by ``N + 1/2``."""
        return self.value + 0.5 if self.kind == "count" else float(self.value)

    def experiment(self) -> tuple[Any, ...]:
        """A hashable key: targets with equal keys share one simulation."""
        return (self.scenario, tuple(sorted(self.params.items())),
                tuple(sorted(self.initial.items())), self.t_end)

    def as_dict(self) -> dict[str, Any]:
        """The target's fields without the defaults (the file format of :func:`read_targets`)."""
        out = {}
        for f in fields(self):
            value = getattr(self, f.name)
            default = f.default_factory() if callable(f.default_factory) else f.default
            if f.name in ("kind", "value", "tolerance") or value != default:
                out[f.name] = dict(value) if isinstance(value, Mapping) else value
        return out


def read_targets(path: str | Path) -> tuple[Target, ...]:
    """Read targets from a TOML or JSON file with a top-level ``targets`` list.

    Raises
    ------
    TargetError
        Unreadable file, unknown or missing keys, bad values; the message names the file
        and the key (``targets[1].tolerance``).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "targets.toml"
    >>> _ = path.write_text('''
    ... [[targets]]
    ... kind = "value"
    ... value = 6.4
    ... tolerance = 0.01
    ... transition = "bounce"
    ... at = "h + v**2/(2*g)"
    ... index = 0
    ...
    ... [[targets]]
    ... kind = "count"
    ... value = 5
    ... tolerance = 1.0
    ... transition = "bounce"
    ... t_end = 8.0
    ... ''')
    >>> [t.label for t in read_targets(path)]
    ['value of h + v**2/(2*g) at bounce [default]', 'count of bounce [default]']
    >>> _ = path.write_text('[[targets]]\\nkind = "count"\\nvalue = 5\\n')
    >>> read_targets(path)
    Traceback (most recent call last):
    ...
    hybridlab.identify.errors.TargetError: ...targets.toml: targets[0]: missing key 'tolerance'
    """
    path = Path(path)
    source = str(path)
    try:
        text = read_bounded(path).decode("utf-8")
    except OSError as exc:
        raise TargetError(f"cannot read: {exc.strerror or exc}", source=source) from None
    except UnicodeDecodeError:
        raise TargetError("not UTF-8 text", source=source) from None
    try:
        data = json.loads(text) if path.suffix.lower() == ".json" else tomllib.loads(text)
    except (json.JSONDecodeError, tomllib.TOMLDecodeError) as exc:
        raise TargetError(f"not valid {path.suffix.lstrip('.').upper() or 'TOML'}: {exc}",
                          source=source) from None
    rows = data.get("targets") if isinstance(data, dict) else None
    if not isinstance(rows, list) or not rows:
        raise TargetError("needs a non-empty list 'targets' of tables", key="targets",
                          source=source)
    allowed = {f.name for f in fields(Target)}
    out = []
    for i, row in enumerate(rows):
        key = f"targets[{i}]"
        if not isinstance(row, dict):
            raise TargetError("must be a table", key=key, source=source)
        unknown = sorted(set(row) - allowed)
        if unknown:
            raise TargetError(f"unknown key {unknown[0]!r} (known: {', '.join(sorted(allowed))})",
                              key=key, source=source)
        missing = [k for k in ("kind", "value", "tolerance") if k not in row]
        if missing:
            raise TargetError(f"missing key {missing[0]!r}", key=key, source=source)
        try:
            out.append(Target(**row))
        except TargetError as exc:
            raise TargetError(exc.message, key=f"{key}.{exc.key}" if exc.key else key,
                              source=source) from None
    return tuple(out)


class _Observers:
    """Compiled expressions of a model, each compiled once and reused."""

    def __init__(self, compiled: CompiledModel) -> None:
        self.compiled = compiled
        self._cache: dict[str, Observer] = {}

    def values(self, text: str, result: SimulationResult, t: np.ndarray) -> np.ndarray:
        if text in result.state_names:
            return np.asarray(result(t), dtype=float).reshape(len(result.state_names), -1)[
                result.state_names.index(text)]
        if text not in self._cache:
            self._cache[text] = Observer(self.compiled, [text])
        return np.asarray(self._cache[text].evaluate(result, t), dtype=float)[0]

    def scalar(self, spec: float | str, result: SimulationResult, t: float) -> float:
        if isinstance(spec, int | float):
            return float(spec)
        return float(self.values(spec, result, np.array([t]))[0])


def _sample_times(target: Target, result: SimulationResult) -> np.ndarray:
    t0, t1 = float(result.t[0]), float(result.t[-1])
    dt = target.dt or (t1 - t0) / 50000
    if (t1 - t0) / dt > MAX_SAMPLES:
        raise TargetError(f"{t1 - t0:g} s at dt = {dt:g} s needs {(t1 - t0) / dt:.3g} samples; "
                          f"at most {MAX_SAMPLES}", key="dt")
    n = max(int(math.ceil((t1 - t0) / dt)), 2)
    return np.linspace(t0, t1, n + 1)


def _events(target: Target, result: SimulationResult, observers: _Observers) -> Crossings:
    if target.transition is not None:
        t = np.asarray(result.jumps.where(transition=target.transition).t, dtype=float)
        return Crossings(t, np.ones(len(t), dtype=int), np.full(len(t) + 1, np.nan),
                         float(result.t[0]), float(result.t[-1]))
    if target.observable is None:  # Target checks it has exactly one of the two
        raise TargetError(f"a {target.kind!r} target needs exactly one of observable and "
                          "transition", key="observable")
    t = _sample_times(target, result)
    crossings = level_crossings(t, observers.values(target.observable, result, t),
                                target.level)
    if target.direction == 0:
        return crossings
    keep = crossings.direction == target.direction
    # the amplitude fraction is defined for crossings in both directions only
    return Crossings(crossings.t[keep], crossings.direction[keep],
                     np.full(int(keep.sum()) + 1, np.nan), crossings.t_start, crossings.t_end)


def target_statistic(target: Target, result: SimulationResult,
                     observers: _Observers | CompiledModel) -> tuple[float, float]:
    """The simulated quantity of ``target``: ``(continuous, reported)``.

    ``continuous`` enters the residual; ``reported`` is what a measurement would show
    (the integer count for counts, otherwise the same number). NaN when the quantity
    does not exist (fewer than two events for an interval, no event for a value).

    Examples
    --------
    >>> import hybridlab
    >>> ball = hybridlab.compile_model(hybridlab.load_model("models/bouncing_ball.toml"))
    >>> result = hybridlab.simulate(ball, t_end=5.0)
    >>> count = Target("count", 2, 1.0, transition="bounce")  # at 1.428 s and 3.712 s
    >>> target_statistic(count, result, ball)
    (2.0, 2.0)
    >>> first = Target("value", 0.0, 1.0, transition="bounce", at="v", index=0)
    >>> round(target_statistic(first, result, ball)[0], 4)  # e sqrt(2 g h0) = 0.8 * 14.007
    11.2057
    """
    if isinstance(observers, CompiledModel):
        observers = _Observers(observers)
    if target.kind in _EVENT_KINDS:
        events = _events(target, result, observers)
        times = events.t
        if target.kind == "count":
            n = float(len(times))
            if target.transition is not None:
                return n, n  # integer-valued: no amplitude to interpolate
            return continuous_count(events), n
        if target.kind == "interval":
            value = float(np.mean(np.diff(times))) if len(times) >= 2 else math.nan
            return value, value
        if len(times) == 0 or (target.index is not None
                               and not -len(times) <= target.index < len(times)):
            return math.nan, math.nan
        values = observers.values(str(target.at), result, times)
        value = float(np.mean(values) if target.index is None else values[target.index])
        return value, value
    t = _sample_times(target, result)
    y = observers.values(str(target.observable), result, t)
    start = observers.scalar(target.start, result, float(t[0]))
    final = observers.scalar(target.final, result, float(t[-1]))  # type: ignore[arg-type]
    if start == final:
        return math.nan, math.nan
    metrics = refined_step_metrics(t, y, start, final, target.band)
    value = metrics.overshoot_pct if target.kind == "overshoot" else metrics.settling_time
    return value, value
