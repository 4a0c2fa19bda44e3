"""Discontinuous flows: crossings, Filippov sliding, stick-slip."""

from __future__ import annotations

import math

import numpy as np
import pytest

import hybridlab

pytestmark = pytest.mark.usefixtures("each_engine")


def test_sign_flow_settles_on_the_surface_with_a_handful_of_events(models_dir):
    result = hybridlab.simulate(models_dir / "relay_sliding.toml")
    assert result.status is hybridlab.Status.COMPLETED
    assert abs(result.final.state["x"]) < 1e-9
    assert len(result.events) <= 3
    assert result.events[0].kind == "slide_start"
    assert result.events[0].t == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(result(np.array([2.0, 3.0, 4.5]))[0], 0.0, atol=1e-9)


def test_coulomb_oscillator_loses_2c_over_k_per_half_swing_then_sticks(models_dir):
    result = hybridlab.simulate(models_dir / "friction_oscillator.toml", rtol=1e-12, atol=1e-12)
    kinds = [e.kind for e in result.events]
    assert kinds == ["crossing", "crossing", "crossing", "slide_start"]
    half = math.pi / 2  # sqrt(m / k) * pi
    np.testing.assert_allclose([e.t for e in result.events], half * np.arange(1, 5), atol=1e-9)
    np.testing.assert_allclose([e.pre["x"] for e in result.events], [-0.75, 0.5, -0.25, 0.0],
                               atol=1e-9)
    # stuck for good: |k x| <= c
    assert abs(result.final.state["x"]) < 1e-8 and abs(result.final.state["v"]) < 1e-12


def test_stiction_holds_inside_the_band(models_dir):
    # released at |k x| = 0.4 < c = 0.5: never moves
    result = hybridlab.simulate(models_dir / "friction_oscillator.toml", initial={"x": 0.1})
    assert [e.kind for e in result.events] == []
    assert result.final.state["x"] == 0.1 and result.final.state["v"] == 0.0


def test_two_surfaces_stick_and_break_away_at_the_analytic_instants():
    m = hybridlab.loads_model("""
name = "ramp"
parameters = { c = 0.5, rate = 0.2 }
states = { x = 0.0, v = 0.0, y = 0.0, w = 0.0 }
[modes.go]
flow = { x = "v", v = "rate*t - c*sign(v)", y = "w", w = "0.1*v - 0.3*sign(w) + 0.05*t" }
[initial]
mode = "go"
""")
    result = hybridlab.simulate(m, t_end=10.0)
    exits = [(e.transition, e.t) for e in result.events if e.kind == "slide_end"]
    assert exits[0] == ("sign(v)", pytest.approx(2.5, abs=1e-12))
    # w breaks away when 0.1 v(t) + 0.05 t = 0.3 with v = 0.1 (t^2 - 6.25) - 0.5 (t - 2.5)
    t_w = exits[1][1]
    v = 0.1 * (t_w**2 - 6.25) - 0.5 * (t_w - 2.5)
    assert 0.1 * v + 0.05 * t_w == pytest.approx(0.3, abs=1e-9)


def test_escape_from_sliding_under_a_large_disturbance(models_dir):
    result = hybridlab.simulate(models_dir / "relay_sliding.toml", scenario="escape")
    assert result.status is hybridlab.Status.COMPLETED
    assert all(e.kind in ("crossing", "slide_start", "slide_end") for e in result.events)
    # with |w| = 2 > k = 1 the state keeps crossing; far fewer events than a chattering solver
    assert 1 <= len(result.events) < 20


def test_abs_min_max_kinks_are_events_not_blind_integration():
    m = hybridlab.loads_model("""
name = "kinks"
states = { x = -1.0, y = 0.0 }
[modes.a]
flow = { x = "1", y = "abs(x) + max(x, 0.5) - min(x, -0.5)" }
[initial]
mode = "a"
""")
    result = hybridlab.simulate(m, t_end=2.0, rtol=1e-12, atol=1e-12)
    crossings = sorted(round(e.t, 9) for e in result.events)
    assert crossings == [0.5, 1.0, 1.5]
    # exact integral of the piecewise-linear right-hand side over x in [-1, 1]
    expected = 1.0 + (0.5 * 1.5 + (1 - 0.25) / 2) - ((0.25 - 1) / 2 - 0.5 * 1.5)
    assert result.final.state["y"] == pytest.approx(expected, abs=1e-10)
