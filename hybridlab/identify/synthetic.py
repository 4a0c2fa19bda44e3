"""Synthetic experiments from known truths, for testing identification methods.

Every generator takes ``rng`` (a :class:`numpy.random.Generator` or a seed) and never
touches global random state. The imperfections are those of real test benches: force
noise and a low-velocity Stribeck hump for friction runs; gain noise, a pre-rolling
stiffness that flattens the low-frequency gain and a structural resonance for frequency
responses; a switching latency, timing jitter and time quantisation for sensor edges.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from hybridlab.identify.data import FrequencyData, FrictionData, SensorEvents
from hybridlab.identify.events import SensorMap, edges_from_result
from hybridlab.model.schema import Model
from hybridlab.simulation.api import simulate
from hybridlab.symbolic.compile import CompiledModel

__all__ = ["friction_runs", "frequency_response", "sensor_events"]


def _rng(rng: np.random.Generator | int | None) -> np.random.Generator:
    return rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)


def friction_runs(c: float, d: float, *, c_backward: float | None = None,
                  d_backward: float | None = None, speeds: np.ndarray | None = None,
                  stribeck_force: float | None = None, stribeck_velocity: float = 0.01,
                  noise: float = 0.2, rng: np.random.Generator | int | None = None
                  ) -> FrictionData:
    """Steady-state runs in both directions from ``F = c sign(v) + d v``.

    Parameters
    ----------
    c, d : float
        True Coulomb (N) and viscous (N s/m) coefficients (forward direction).
    c_backward, d_backward : float, optional
        Coefficients of the backward direction, for asymmetric friction (default: equal).
    speeds : array_like, optional
        Run speeds (m/s), used in both directions (default: 24 speeds from 2 mm/s to
        0.3 m/s, log-spaced so the low-velocity region is well sampled).
    stribeck_force : float, optional
        Static (breakaway) force; near rest the friction rises from ``c`` to it as
        ``exp(-(v / stribeck_velocity)^2)`` (default ``1.5 c``; 0 disables).
    stribeck_velocity : float
        Stribeck velocity (m/s).
    noise : float
        Standard deviation of the force noise (N).
    rng : numpy.random.Generator or int, optional

    Examples
    --------
    >>> data = friction_runs(17.41, 257.0, rng=1)
    >>> len(data.velocity), int(data.forward.sum())
    (48, 24)
    """
    g = _rng(rng)
    v = np.geomspace(0.002, 0.3, 24) if speeds is None else np.asarray(speeds, dtype=float)
    cb = c if c_backward is None else c_backward
    db = d if d_backward is None else d_backward
    fs = 1.5 * c if stribeck_force is None else stribeck_force
    hump = np.exp(-((v / stribeck_velocity) ** 2)) if fs else np.zeros_like(v)
    fwd = c + (fs - c) * hump + d * v if fs else c + d * v
    bwd = -(cb + (fs - cb) * hump + db * v) if fs else -(cb + db * v)
    velocity = np.concatenate([v, -v])
    force = np.concatenate([fwd, bwd]) + noise * g.standard_normal(2 * len(v))
    return FrictionData(velocity, force)


def frequency_response(m: float, d: float, *, f_low: float = 1.0, f_high: float = 1000.0,
                       n: int = 300, resonance_hz: float | None = 400.0,
                       damping_ratio: float = 0.05, prerolling_stiffness: float = 0.0,
                       dead_time: float = 0.0, noise_db: float = 0.2,
                       noise_deg: float = 1.0, rng: np.random.Generator | int | None = None
                       ) -> FrequencyData:
    """A measured-looking response of position over force from ``1 / (s (m s + d))``.

    The true plant is ``1 / (m s^2 + d s + k) * R(s) * exp(-s T)`` with the pre-rolling
    stiffness ``k`` (friction acting as a spring at tiny amplitudes, which flattens the
    gain at low frequency), a structural resonance ``R(s) = 1 / (1 + 2 zeta s/w_r +
    (s/w_r)^2)`` and a dead time ``T``.

    Parameters
    ----------
    m, d : float
        True mass (kg) and viscous coefficient (N s/m).
    f_low, f_high : float
        Frequency range (Hz), log-spaced with ``n`` points.
    resonance_hz : float or None
        Structural resonance (None: none).
    damping_ratio : float
        Its damping ratio.
    prerolling_stiffness : float
        ``k`` (N/m).
    dead_time : float
        ``T`` (s); affects only the phase.
    noise_db, noise_deg : float
        Standard deviations of the gain (dB) and phase (degree) noise.
    rng : numpy.random.Generator or int, optional

    Examples
    --------
    >>> data = frequency_response(3.5, 257.0, noise_db=0.0, resonance_hz=None)
    >>> bool(abs(data.magnitude_db[-1] + 20 * np.log10(3.5 * data.omega[-1] ** 2)) < 0.01)
    True
    """
    g = _rng(rng)
    f = np.geomspace(f_low, f_high, n)
    s = 2j * np.pi * f
    h = 1.0 / (m * s**2 + d * s + prerolling_stiffness)
    if resonance_hz:
        wr = 2 * np.pi * resonance_hz
        h = h / (1 + 2 * damping_ratio * s / wr + (s / wr) ** 2)
    h = h * np.exp(-s * dead_time)
    mag = 20 * np.log10(np.abs(h)) + noise_db * g.standard_normal(n)
    phase = np.degrees(np.unwrap(np.angle(h))) + noise_deg * g.standard_normal(n)
    return FrequencyData(f, mag, phase)


def sensor_events(model: Model | CompiledModel | str | Path, *, sensors: SensorMap,
                  scenario: str | None = None, params: Mapping[str, float] | None = None,
                  t_end: float | None = None, latency: float = 0.0, jitter: float = 0.0,
                  quantum: float = 0.0, rng: np.random.Generator | int | None = None,
                  **simulation_options: Any) -> SensorEvents:
    """Sensor edges from a simulation, as a data logger would record them.

    Each edge is delayed by ``latency`` plus Gaussian ``jitter`` (standard deviation, s)
    and its time rounded up to the next multiple of ``quantum`` (the logger's sample
    period). Edges whose delayed time passes ``t_end`` are dropped.

    Parameters
    ----------
    model : Model, CompiledModel, str or pathlib.Path
    sensors : mapping of str to (str, str)
        Sensor id -> (rising transition, falling transition).
    scenario, params, t_end
        Passed to :func:`hybridlab.simulate` (``params`` holds the true values).
    latency, jitter, quantum : float
        Sensor imperfections (s).
    rng : numpy.random.Generator or int, optional
    **simulation_options
        Further keyword arguments of :func:`hybridlab.simulate`.

    Examples
    --------
    >>> ev = sensor_events("models/thermostat.toml", sensors={"relay": ("turn_on", "turn_off")},
    ...                    t_end=2.0, latency=0.01, quantum=0.001, rng=0)
    >>> bool(np.allclose(ev.t / 0.001, np.round(ev.t / 0.001)))
    True
    """
    g = _rng(rng)
    result = simulate(model, t_end, scenario=scenario, params=params, **simulation_options)
    edges = edges_from_result(result, sensors)
    t = edges.t + latency + (jitter * g.standard_normal(len(edges)) if jitter else 0.0)
    if quantum:
        t = np.ceil(t / quantum - 1e-9) * quantum
    keep = t <= result.final.t
    return SensorEvents(tuple(np.array(edges.sensor, dtype=object)[keep]), t[keep],
                        tuple(np.array(edges.edge, dtype=object)[keep]))
