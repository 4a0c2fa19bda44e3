"""Event location on a step's samples: floors before re-arming, coinciding monitors."""

from __future__ import annotations

import numpy as np

import hybridlab
from hybridlab.simulation import location
from hybridlab.simulation.location import first_trigger, hermite_minimum_until, sample_step


def _samples(fn, slope, t0: float, t1: float):
    def batch(tau):
        return np.atleast_2d(fn(tau)), np.atleast_2d(slope(tau))

    return sample_step(t0, t1, batch, 2, 6, 1e-12)


def _counted(fn):
    calls = []

    def counted(t: float) -> float:
        calls.append(t)
        return float(fn(t))

    return counted, calls


def test_the_cubic_minimum_before_an_instant():
    # 1 - 4 s + 4 s^2 on [0, 1]: its minimum 0 at s = 1/2, so on [0, 1/4] it is the end value
    assert hermite_minimum_until(1.0, 1.0, 1.0, -4.0, 4.0, 1.0) == 0.0
    assert hermite_minimum_until(1.0, 1.0, 1.0, -4.0, 4.0, 0.25) == 0.25
    assert hermite_minimum_until(1.0, 1.0, 1.0, -4.0, 4.0, 0.0) == 1.0


def test_a_flight_inside_one_interval_is_searched_once():
    # a ball's height right after its bounce: up and back through the floor inside the first
    # sample interval; the floor only counts before it rises, so one search finds the landing
    def fn(t):
        return t * (1.0 - t)

    tau, phi, dphi, _ = _samples(fn, lambda t: 1.0 - 2.0 * t, 0.0, 2.5)
    value, calls = _counted(fn)
    trigger, armed = first_trigger(0, tau, phi[0], dphi[0], False, value, 1e-12, 1e-12,
                                   floor=-1e-12)
    assert trigger is not None and abs(trigger.t - 1.0) <= 1e-12 and fn(trigger.t) <= 0
    assert armed and not trigger.grazing
    located = len(calls)
    # the same search, told of the event another monitor located there: no search of its own
    value, calls = _counted(fn)
    again, _ = first_trigger(0, tau, phi[0], dphi[0], False, value, 1e-12, 1e-12,
                             floor=-1e-12, located=(trigger.t, 8e-12))
    assert again == location.Trigger(0, trigger.t, False)
    assert len(calls) <= 3 < located


def test_sinking_below_the_floor_before_rising_still_fires():
    # starts on its boundary, dips below the floor, then rises and falls again: the dip fires
    def fn(t):
        return -0.01 * np.sin(np.pi * t) * (t < 1.0) + (t - 1.0) * (3.0 - t) * (t >= 1.0)

    def slope(t):
        return (-0.01 * np.pi * np.cos(np.pi * t) * (t < 1.0)
                + (4.0 - 2.0 * t) * (t >= 1.0))

    tau, phi, dphi, _ = _samples(fn, slope, 0.0, 3.5)
    trigger, armed = first_trigger(0, tau, phi[0], dphi[0], False, lambda t: float(fn(t)),
                                   1e-12, 1e-12, floor=-1e-6)
    assert trigger is not None and trigger.t < 0.01 and not armed
    assert fn(trigger.t) <= -1e-6


def test_a_guard_and_its_complement_invariant_are_located_once(monkeypatch, models_dir):
    # the ball's guard h <= 0 and invariant h >= 0 reach zero together at every bounce: one
    # root search per bounce, on the engine that defines the semantics
    searches = []
    brentq = location.brentq

    def counted(*args, **kwargs):
        searches.append(args[1:3])
        return brentq(*args, **kwargs)

    monkeypatch.setattr(location, "brentq", counted)
    ball = hybridlab.load_model(models_dir / "bouncing_ball.toml")
    result = hybridlab.simulate(ball, t_end=10.0, params={"e": 0.7}, backend="reference")
    assert result.status.name == "ZENO" and len(result.jumps) > 20
    assert len(searches) == len(result.jumps)
