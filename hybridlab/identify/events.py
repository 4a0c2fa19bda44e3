"""Model parameters from sensor events: match simulated and measured edge sequences.

Discrete sensors (light barriers, end switches) report only *edges*: a sensor id, a time
and whether it switched on (``rising``) or off (``falling``). Given a model whose
transitions reproduce those edges (``sensors`` maps each sensor id to its
``(rising, falling)`` transition names), :func:`fit_events` adjusts chosen parameters
until the simulated edge sequence matches the measured one.

The objective is built from *two-sensor passages*: two consecutive edges of the same
kind (both rising or both falling) from the two sensors of ``pair``, less than
``max_pair_gap`` apart. A passage has a time (the midpoint) and a rate ``1/dt``; with the
sensors ``d_s`` apart, ``d_s/dt`` is the tangential velocity of the reference paper's
eq. (7). Sequences are compared as functions of the passage index ``k``:

* rates, for every measured passage: ``(rate_sim[k] - rate_meas[k]) / scale`` where a
  passage the simulation lacks counts with rate 0. Passages vanish when the motion no
  longer reaches the sensors, so the rate of the last ones is small and the residual
  changes little when the count changes: a continuous surrogate of the integer count;
* times, over the common prefix, after removing their mean offset (a constant sensor
  latency), scaled by the median measured passage spacing and weighted by
  ``time_weight``;
* one residual for surplus simulated passages: the root sum of squares of their rates,
  counted only where the measurement was still recording (earlier than ``t_end`` minus
  two passage spacings), so that a truncated record is not penalised.

The simulation runs two passage spacings past ``t_end`` so that a slightly slower model
does not lose its last passage to the horizon. The residual vector has a fixed length,
so :func:`scipy.optimize.least_squares` (trust region, finite differences with a
relative step of ``diff_step``) can minimise it; ``method="nelder-mead"`` minimises the
sum of squares without derivatives instead. ``max_evaluations`` caps the number of
simulations in either case.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from hybridlab.errors import HybridlabError
from hybridlab.identify._optimise import BudgetSpent, ParameterSpace, minimise_residuals
from hybridlab.identify._report import axes, format_table
from hybridlab.identify.data import SensorEvents
from hybridlab.identify.errors import DataError
from hybridlab.model.schema import Model
from hybridlab.simulation.api import simulate
from hybridlab.simulation.problem import HybridProblem, as_compiled
from hybridlab.simulation.result import SimulationResult
from hybridlab.symbolic.compile import CompiledModel

__all__ = ["SensorMap", "Passages", "EventFit", "edges_from_result", "passages", "fit_events"]

#: Sensor id -> (name of the transition of its rising edge, of its falling edge).
SensorMap = Mapping[str, tuple[str, str]]
_METHODS = ("least_squares", "nelder-mead")


@dataclass(frozen=True)
class Passages:
    """Two-sensor passages derived from an edge sequence.

    Attributes
    ----------
    t : numpy.ndarray
        Midpoints of the two edges (s).
    rate : numpy.ndarray
        ``1 / dt`` of each passage (1/s); times the sensor distance it is a speed.
    direction : numpy.ndarray
        +1 when the first sensor of the pair switched first, -1 otherwise.

    Examples
    --------
    Sensors 0.1 m apart, passed at 2 m/s: both edges 0.05 s apart, rate 20/s:

    >>> events = SensorEvents(["1", "2", "1", "2"], [0.50, 0.55, 0.75, 0.80],
    ...                       ["rising", "rising", "falling", "falling"])
    >>> p = passages(events, ("1", "2"), max_pair_gap=0.2)
    >>> len(p), p.t.round(3).tolist(), p.rate.round(6).tolist(), p.direction.tolist()
    (2, [0.525, 0.775], [20.0, 20.0], [1, 1])
    >>> 0.1 * p.rate.round(6)  # the speed, with the sensor distance
    array([2., 2.])
    """

    t: np.ndarray
    rate: np.ndarray
    direction: np.ndarray

    def __len__(self) -> int:
        return len(self.t)


def edges_from_result(result: SimulationResult, sensors: SensorMap) -> SensorEvents:
    """The sensor edges of a simulation: its jumps through the transitions of ``sensors``.

    Examples
    --------
    >>> import hybridlab
    >>> res = hybridlab.simulate("models/thermostat.toml", t_end=2.0)
    >>> edges = edges_from_result(res, {"relay": ("turn_on", "turn_off")})
    >>> len(edges) > 0 and set(edges.edge) <= {"rising", "falling"}
    True
    """
    lookup = {}
    for sensor, (rising, falling) in sensors.items():
        lookup[rising] = (sensor, "rising")
        lookup[falling] = (sensor, "falling")
    # columns of the event table: no Event object is made (this runs once per fit evaluation)
    hits = result.jumps.where(transition=list(lookup))
    names = hits.transition
    return SensorEvents(tuple(lookup[name][0] for name in names),
                        np.asarray(hits.t, dtype=float), tuple(lookup[name][1] for name in names))


def passages(events: SensorEvents, pair: tuple[str, str], max_pair_gap: float) -> Passages:
    """Pair consecutive same-kind edges of the two sensors of ``pair`` into passages.

    Parameters
    ----------
    events : SensorEvents
    pair : (str, str)
        The two sensor ids.
    max_pair_gap : float
        Two edges further apart than this (s) are not a passage.

    Examples
    --------
    >>> ev = SensorEvents(["2", "1", "2", "1", "1"], [0.100, 0.104, 0.120, 0.124, 0.9],
    ...                   ["rising", "rising", "falling", "falling", "rising"])
    >>> p = passages(ev, ("1", "2"), max_pair_gap=0.2)
    >>> p.rate.round(3).tolist(), p.direction.tolist()
    ([250.0, 250.0], [-1, -1])
    """
    a, b = pair
    keep = [i for i, s in enumerate(events.sensor) if s in (a, b)]
    t = events.t[keep]
    sensor = [events.sensor[i] for i in keep]
    edge = [events.edge[i] for i in keep]
    mid, rate, direction = [], [], []
    i = 0
    while i + 1 < len(t):
        gap = t[i + 1] - t[i]
        if sensor[i] != sensor[i + 1] and edge[i] == edge[i + 1] and 0 < gap <= max_pair_gap:
            mid.append(0.5 * (t[i] + t[i + 1]))
            rate.append(1.0 / gap)
            direction.append(1 if sensor[i] == a else -1)
            i += 2
        else:
            i += 1
    return Passages(np.array(mid, dtype=float), np.array(rate, dtype=float),
                    np.array(direction, dtype=int))


@dataclass(frozen=True)
class EventFit:
    """Result of :func:`fit_events`.

    Attributes
    ----------
    parameters : dict of str to float
        The estimates.
    uncertainties : dict of str to float
        Standard errors from the Jacobian at the solution (NaN for ``nelder-mead``).
    initial : dict of str to float
        Where the optimiser started.
    cost : float
        Half the sum of squared residuals at the estimate.
    n_evaluations : int
        Simulations run.
    success : bool
        Whether the optimiser reported convergence within the budget.
    message : str
        The optimiser's message.
    measured, simulated : Passages
        Passages of the data and of the model at the estimate.
    n_edges_measured, n_edges_simulated : int
        Edge counts over the record (simulated edges after ``t_end`` are not counted).
    time_offset : float
        Mean measured minus simulated passage time: an estimate of the sensor latency (s).
    sensor_distance : float or None
        When known, rates are reported as speeds ``sensor_distance * rate`` (m/s).

    Examples
    --------
    A cart passes two sensors at 1.0 and 1.1 m (on, then off 0.5 m later); the fit of
    its speed ``v`` (2 m/s in truth) from 1.9 is stopped after four simulations:

    >>> import hybridlab
    >>> cart = hybridlab.loads_model('''
    ... name = "cart"
    ... parameters = { v = 1.0 }
    ... states = { x = 0.0 }
    ... modes = { a.flow.x = "v", b.flow.x = "v", c.flow.x = "v", d.flow.x = "v", e.flow.x = "v" }
    ... transitions = [
    ...   { name = "on1", source = "a", target = "b", guard = "x >= 1.0" },
    ...   { name = "on2", source = "b", target = "c", guard = "x >= 1.1" },
    ...   { name = "off1", source = "c", target = "d", guard = "x >= 1.5" },
    ...   { name = "off2", source = "d", target = "e", guard = "x >= 1.6" },
    ... ]
    ... initial = { mode = "a" }
    ... ''')
    >>> sensors = {"1": ("on1", "off1"), "2": ("on2", "off2")}
    >>> measured = SensorEvents(["1", "2", "1", "2"], [0.50, 0.55, 0.75, 0.80],
    ...                         ["rising", "rising", "falling", "falling"])
    >>> fit = fit_events(cart, measured, fit=["v"], sensors=sensors, t_end=1.0,
    ...                  initial_guess={"v": 1.9}, max_evaluations=4, sensor_distance=0.1,
    ...                  simulation_options={"backend": "reference"})
    >>> fit.success, fit.message
    (False, 'stopped after max_evaluations = 4 simulations')
    >>> print(f"v = {fit.parameters['v']:.3f} +- {fit.uncertainties['v']:.3f} m/s")
    v = 2.005 +- 0.003 m/s
    >>> len(fit.measured), len(fit.simulated), fit.n_edges_simulated
    (2, 2, 4)
    >>> (fit.sensor_distance * fit.simulated.rate).round(3).tolist()  # passage speeds
    [2.005, 2.005]
    """

    parameters: dict[str, float]
    uncertainties: dict[str, float]
    initial: dict[str, float]
    cost: float
    n_evaluations: int
    success: bool
    message: str
    measured: Passages
    simulated: Passages
    n_edges_measured: int
    n_edges_simulated: int
    time_offset: float
    sensor_distance: float | None = None
    extra: dict[str, Any] = field(default_factory=dict)

    def table(self) -> str:
        """A text table of the estimates and of the match."""
        rows = [[name, value, self.uncertainties[name], self.initial[name]]
                for name, value in self.parameters.items()]
        text = format_table(["parameter", "estimate", "se", "initial"], rows)
        n = min(len(self.measured), len(self.simulated))
        rms = (float(np.sqrt(np.mean((self.simulated.rate[:n] - self.measured.rate[:n]) ** 2)))
               if n else float("nan"))
        return (f"{text}\npassages: measured {len(self.measured)}, simulated "
                f"{len(self.simulated)}; edges: measured {self.n_edges_measured}, simulated "
                f"{self.n_edges_simulated}; rate rms {rms:.4g} 1/s; time offset "
                f"{1e3 * self.time_offset:.3g} ms; {self.n_evaluations} simulations; "
                f"{self.message}")

    def as_dict(self) -> dict[str, Any]:
        """A JSON-ready summary (``parameters`` maps each fitted name to its value)."""
        return {"method": "events", "parameters": dict(self.parameters),
                "uncertainties": dict(self.uncertainties), "initial": dict(self.initial),
                "cost": self.cost, "n_evaluations": self.n_evaluations,
                "success": self.success, "message": self.message,
                "passages_measured": len(self.measured),
                "passages_simulated": len(self.simulated),
                "edges_measured": self.n_edges_measured,
                "edges_simulated": self.n_edges_simulated, "time_offset_s": self.time_offset,
                "measured_rate": self.measured.rate.tolist(),
                "simulated_rate": self.simulated.rate.tolist()}

    def plot(self, ax: Any = None) -> Any:
        """Passage speed (or rate) against passage index, measured and fitted."""
        ax = axes(ax)
        scale = self.sensor_distance or 1.0
        unit = "speed d_s/dt [m/s]" if self.sensor_distance else "rate 1/dt [1/s]"
        ax.plot(np.arange(len(self.measured)), scale * self.measured.rate, "o", ms=3,
                label="measured")
        ax.plot(np.arange(len(self.simulated)), scale * self.simulated.rate, "-", lw=1,
                label="model at the estimate")
        ax.set(xlabel="passage index k", ylabel=unit, title="two-sensor passages")
        ax.legend(fontsize="small")
        return ax


def _check_sensors(sensors: SensorMap, compiled: CompiledModel) -> dict[str, tuple[str, str]]:
    if not isinstance(sensors, Mapping) or len(sensors) < 2:
        raise ValueError("sensors must map at least two sensor ids to (rising, falling) "
                         f"transition names (got {sensors!r})")
    names = {t.name for t in compiled.model.transitions}
    out = {}
    for sensor, value in sensors.items():
        if isinstance(value, str) or len(value) != 2:
            raise ValueError(f"sensors[{sensor!r}] must be a pair (rising, falling) of "
                             f"transition names (got {value!r})")
        for name in value:
            if name not in names:
                raise ValueError(f"sensors[{sensor!r}]: the model has no transition {name!r}")
        out[str(sensor)] = (str(value[0]), str(value[1]))
    return out


def fit_events(
    model: Model | CompiledModel | str | Path | HybridProblem,
    events: SensorEvents,
    *,
    fit: Sequence[str],
    sensors: SensorMap,
    scenario: str | None = None,
    params: Mapping[str, float] | None = None,
    initial_guess: Mapping[str, float] | None = None,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    t_end: float | None = None,
    pair: tuple[str, str] | None = None,
    max_pair_gap: float = 0.2,
    time_weight: float = 0.1,
    sensor_distance: float | str | None = None,
    method: str = "least_squares",
    max_evaluations: int = 30,
    diff_step: float = 1e-3,
    xtol: float = 1e-3,
    simulation_options: Mapping[str, object] | None = None,
) -> EventFit:
    """Estimate model parameters from measured sensor edges.

    Parameters
    ----------
    model : Model, CompiledModel, str, pathlib.Path or HybridProblem
        The model; its transitions named in ``sensors`` produce the edges. A
        problem (with point values) supplies ``scenario``, ``params`` and the
        integrator settings.
    events : SensorEvents
        The measured edges.
    fit : sequence of str
        Names of the parameters to estimate.
    sensors : mapping of str to (str, str)
        Sensor id -> (rising transition, falling transition), e.g.
        ``{"1": ("s1_on", "s1_off"), "2": ("s2_on", "s2_off")}``.
    scenario : str, optional
        Scenario supplying the experiment (initial state, parameters, ``t_end``).
    params : mapping, optional
        Further fixed parameter overrides.
    initial_guess : mapping, optional
        Starting values of the fitted parameters (default: the model's values).
    bounds : mapping of str to (float, float), optional
        Per-parameter bounds; by default each parameter keeps the sign of its start value.
    t_end : float, optional
        End of the measurement record (default: the scenario's ``t_end``).
    pair : (str, str), optional
        The two sensors forming passages (default: the first two of ``sensors``).
    max_pair_gap : float
        Largest time between the two edges of a passage (s).
    time_weight : float
        Weight of the passage-time residuals relative to the rate residuals.
    sensor_distance : float or str, optional
        Distance between the two sensors, or the name of the model parameter holding it;
        only used to report speeds.
    method : {"least_squares", "nelder-mead"}
        Optimiser.
    max_evaluations : int
        Most simulations to run.
    diff_step : float
        Relative finite-difference step of ``least_squares``.
    xtol : float
        Stop when a step changes the parameters by less than this (relative); also the
        simplex size tolerance of ``nelder-mead``.
    simulation_options : mapping, optional
        Extra keyword arguments of :func:`hybridlab.simulate` (e.g. ``rtol``).

    Returns
    -------
    EventFit

    Raises
    ------
    DataError
        No events, fewer than two passages, or sensors the mapping does not know.
    ValueError
        Unknown parameter, transition or method, or a bad setting.

    Examples
    --------
    A cart passes two sensors at 1.0 and 1.1 m (on, then off 0.5 m later); the measured
    edges are 0.05 s apart, so its speed is 2 m/s:

    >>> import hybridlab
    >>> cart = hybridlab.loads_model('''
    ... name = "cart"
    ... parameters = { v = 1.0 }
    ... states = { x = 0.0 }
    ... modes = { a.flow.x = "v", b.flow.x = "v", c.flow.x = "v", d.flow.x = "v", e.flow.x = "v" }
    ... transitions = [
    ...   { name = "on1", source = "a", target = "b", guard = "x >= 1.0" },
    ...   { name = "on2", source = "b", target = "c", guard = "x >= 1.1" },
    ...   { name = "off1", source = "c", target = "d", guard = "x >= 1.5" },
    ...   { name = "off2", source = "d", target = "e", guard = "x >= 1.6" },
    ... ]
    ... initial = { mode = "a" }
    ... ''')
    >>> sensors = {"1": ("on1", "off1"), "2": ("on2", "off2")}
    >>> measured = SensorEvents(["1", "2", "1", "2"], [0.50, 0.55, 0.75, 0.80],
    ...                         ["rising", "rising", "falling", "falling"])
    >>> fit = fit_events(cart, measured, fit=["v"], sensors=sensors, t_end=1.0,
    ...                  initial_guess={"v": 1.8}, max_evaluations=6,
    ...                  simulation_options={"backend": "reference"})
    >>> round(fit.parameters["v"], 3), fit.n_edges_simulated, round(fit.cost, 6)
    (2.0, 4, 0.0)
    """
    if isinstance(model, HybridProblem):  # its scenario, parameters and settings
        base = model.arguments("fit_events")
        scenario = scenario or base["scenario"]
        params = {**base["params"], **(params or {})}
        simulation_options = {"options": base["options"], **(simulation_options or {})}
    compiled = as_compiled(model)
    if not isinstance(events, SensorEvents):
        raise TypeError(f"events must be SensorEvents (got {type(events).__name__})")
    if len(events) == 0:
        raise DataError("contains no events", column="t", source=events.source)
    sensor_map = _check_sensors(sensors, compiled)
    unknown = sorted(set(events.sensor) - set(sensor_map))
    if unknown:
        raise DataError(f"has sensor id(s) {', '.join(map(repr, unknown))} that the sensors "
                        f"mapping does not name (it has {', '.join(sensor_map)})",
                        column="sensor", source=events.source)
    given = tuple(pair) if pair is not None else tuple(list(sensor_map)[:2])
    if len(given) != 2 or given[0] == given[1] or not set(given) <= set(sensor_map):
        raise ValueError(f"pair must name two different sensors of the mapping (got {given!r})")
    pair = (given[0], given[1])
    if isinstance(fit, str):
        fit = [n.strip() for n in fit.split(",") if n.strip()]
    fit = list(fit)
    if not fit:
        raise ValueError("fit must name at least one parameter")
    names = compiled.parameter_names
    for name in fit:
        if name not in names:
            raise ValueError(f"fit: the model has no parameter {name!r}")
    if method not in _METHODS:
        raise ValueError(f"method must be one of {', '.join(_METHODS)} (got {method!r})")
    if not (isinstance(max_evaluations, int) and max_evaluations >= len(fit) + 2):
        raise ValueError(f"max_evaluations must be an integer >= {len(fit) + 2} "
                         f"(got {max_evaluations!r})")
    if not max_pair_gap > 0:
        raise ValueError(f"max_pair_gap must be positive (got {max_pair_gap!r})")

    spec = compiled.model
    sc = spec.scenarios.get(scenario) if scenario is not None else None
    if scenario is not None and sc is None:
        raise ValueError(f"unknown scenario {scenario!r}; the model has: "
                         f"{', '.join(spec.scenarios) or 'none'}")
    record_end = float(t_end if t_end is not None else (sc.t_end if sc else np.nan))
    if not math.isfinite(record_end):
        raise ValueError("t_end is required when no scenario gives it")
    if events.t[-1] > record_end:
        raise DataError(f"has edges after t_end = {record_end:g} s (last at "
                        f"{events.t[-1]:g} s): pass a larger t_end", column="t",
                        source=events.source)
    fixed = {**(sc.parameters if sc else {}), **(params or {})}
    base = dict(zip(names, compiled.parameter_vector(fixed), strict=True))
    start = {n: float((initial_guess or {}).get(n, base[n])) for n in fit}
    space = ParameterSpace.around(fit, start, bounds)
    lo, hi = space.bounds()
    distance = (base[sensor_distance] if isinstance(sensor_distance, str)
                and sensor_distance in base else sensor_distance)
    if isinstance(distance, str):
        raise ValueError(f"sensor_distance: the model has no parameter {distance!r}")

    measured = passages(events, pair, max_pair_gap)
    if len(measured) < 2:
        raise DataError(f"yields {len(measured)} two-sensor passage(s) of sensors {pair} "
                        f"(edges of both sensors, same kind, at most max_pair_gap = "
                        f"{max_pair_gap:g} s apart); at least 2 are needed", column="t",
                        source=events.source)
    spacing = float(np.median(np.diff(measured.t)))
    margin = 2 * spacing
    rate_scale = float(np.median(measured.rate))
    n_m = len(measured)
    # (their values are checked by simulate)
    options: dict[str, Any] = dict(simulation_options or {})
    cache: dict[tuple[float, ...], tuple[np.ndarray, Passages, int]] = {}
    count = [0]
    limit = [max_evaluations]  # lowered while optimising to keep simulations for the errors

    def run(theta: np.ndarray) -> tuple[np.ndarray, Passages, int]:
        key = tuple(np.round(theta, 12))
        if key in cache:
            return cache[key]
        if count[0] >= limit[0]:
            raise BudgetSpent
        count[0] += 1
        values = dict(zip(fit, space.values(theta).tolist(), strict=True))
        try:
            result = simulate(compiled, record_end + margin, scenario=scenario,
                              params={**fixed, **values}, **options)
            edges = edges_from_result(result, sensor_map)
        except (HybridlabError, ValueError, ArithmeticError):
            edges = SensorEvents((), np.empty(0), ())
        sim = passages(edges, pair, max_pair_gap)
        n_edges = int(np.sum(edges.t <= record_end))
        k = min(n_m, len(sim))
        # matched passages: error of rate^2 (kinetic energy, nearly linear in friction
        # coefficients) weighted by 1/(2 rate^3) so that it equals the gap error, whose
        # timing noise is the same for every passage, in units of the median gap;
        # missing passages: their measured rate relative to the median rate
        rm = measured.rate
        r_rate = -rm / rate_scale
        r_rate[:k] = (sim.rate[:k] ** 2 - rm[:k] ** 2) / (2 * rm[:k] ** 3) * rate_scale
        r_time = np.zeros(n_m)
        if k:
            dt = measured.t[:k] - sim.t[:k]
            r_time[:k] = time_weight * (dt - dt.mean()) / spacing
        extra = sim.rate[n_m:][sim.t[n_m:] < record_end - margin]
        r_extra = np.array([np.sqrt(np.sum(extra**2)) / rate_scale])
        out = (np.concatenate([r_rate, r_time, r_extra]), sim, n_edges)
        cache[key] = out
        return out

    theta0 = space.theta0()
    limit[0] = max_evaluations - (len(fit) if method == "least_squares" else 0)
    success, message, jac, x_opt = minimise_residuals(
        lambda th: run(th)[0], theta0, lo, hi, method=method, max_evaluations=max_evaluations,
        xtol=xtol, diff_step=diff_step, ftol=1e-6,
        budget_text=f"stopped after max_evaluations = {max_evaluations} simulations")
    # the best point evaluated (the optimiser's answer, or the best so far when stopped)
    best = np.array(min(cache, key=lambda k: float(cache[k][0] @ cache[k][0])))
    residual, sim, n_edges = cache[tuple(np.round(best, 12))]
    dof = max(len(residual) - len(fit), 1)
    se = np.full(len(fit), np.nan)
    limit[0] = max_evaluations
    if method == "least_squares":
        try:
            if jac is None or not np.allclose(x_opt, best):
                jac = np.empty((len(residual), len(fit)))
                for i in range(len(fit)):
                    h = diff_step * max(abs(best[i]), 1.0)  # as least_squares' relative step
                    probe = best.copy()
                    probe[i] += h
                    jac[:, i] = (run(probe)[0] - residual) / h
            cov = float(residual @ residual) / dof * np.linalg.pinv(jac.T @ jac)
            se = np.sqrt(np.clip(np.diag(cov), 0, None)) * space.derivative(best)
        except BudgetSpent:
            pass
    k = min(n_m, len(sim))
    offset = float(np.mean(measured.t[:k] - sim.t[:k])) if k else float("nan")
    return EventFit(
        parameters=dict(zip(fit, space.values(best).tolist(), strict=True)),
        uncertainties={n: float(e) for n, e in zip(fit, se, strict=True)},
        initial=start, cost=0.5 * float(residual @ residual), n_evaluations=count[0],
        success=success, message=message, measured=measured, simulated=sim,
        n_edges_measured=len(events), n_edges_simulated=n_edges, time_offset=offset,
        sensor_distance=None if distance is None else float(distance))
