"""The simulator against closed-form solutions (the core issue's acceptance list)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import hybridlab
from hybridlab import Status

G, H0 = 9.81, 10.0


pytestmark = pytest.mark.usefixtures("each_engine")


def ball_impacts(e: float, count: int) -> np.ndarray:
    """t_1 = sqrt(2 h0 / g), then each flight lasts 2 e^k v_1 / g."""
    t1 = math.sqrt(2 * H0 / G)
    v1 = G * t1
    times = [t1]
    for k in range(1, count):
        times.append(times[-1] + 2 * e**k * v1 / G)
    return np.array(times)


@pytest.mark.parametrize("method", ["DOP853", "RK45", "Radau"])
def test_ball_impact_times_match_closed_form_for_20_bounces(ball, method):
    result = hybridlab.simulate(ball, t_end=12.84, method=method, rtol=1e-10, atol=1e-12)
    times = np.array([e.t for e in result.jumps[:20]])
    assert times.size == 20
    np.testing.assert_allclose(times, ball_impacts(0.8, 20), rtol=0, atol=1e-9)


def test_ball_post_impact_velocity_is_reset_and_state_is_dense(ball):
    result = hybridlab.simulate(ball, t_end=3.0)
    first = result.jumps[0]
    assert first.post["v"] == pytest.approx(-0.8 * first.pre["v"], rel=1e-15)
    assert first.post["h"] == first.pre["h"]
    assert abs(first.pre["h"]) < 1e-9
    t = np.linspace(0, 1.4, 15)
    np.testing.assert_allclose(result(t)[0], H0 - G * t**2 / 2, atol=1e-9)
    # at the jump instant the post-jump state is returned, the pre-jump one with j=0
    assert result(first.t)[1] > 0 > result(first.t, j=0)[1]


def test_zeno_ball_stops_with_zeno_status_at_the_accumulation_time(ball):
    t_inf = math.sqrt(2 * H0 / G) * (1 + 2 * 0.8 / (1 - 0.8))
    assert t_inf == pytest.approx(12.8506, abs=1e-4)
    result = hybridlab.simulate(ball, scenario="zeno")
    assert result.status is Status.ZENO
    assert "accumulate" in result.message
    assert abs(result.final.t - t_inf) < 1e-3
    assert result.zeno_time == pytest.approx(t_inf, abs=1e-6)
    # never fell through the floor
    assert min(result.y[0]) > -1e-9
    assert result.final.state["h"] > -1e-9


@pytest.mark.parametrize("e", [0.3, 0.5, 0.9, 0.95])
def test_zeno_accumulation_time_for_several_restitutions(ball, e):
    t_inf = math.sqrt(2 * H0 / G) * (1 + 2 * e / (1 - e))
    result = hybridlab.simulate(ball, t_end=2 * t_inf, params={"e": e})
    assert result.status is Status.ZENO
    assert result.zeno_time == pytest.approx(t_inf, rel=1e-7)
    assert abs(result.final.t - t_inf) < 1e-3


def test_zeno_error_policy_raises(ball):
    with pytest.raises(hybridlab.ZenoError, match="accumulate"):
        hybridlab.simulate(ball, scenario="zeno", zeno="error")


def test_benchmark_ball_makes_44_bounces_by_t_50(ball):
    result = hybridlab.simulate(ball, scenario="benchmark")
    assert result.status is Status.COMPLETED
    assert len(result.jumps) == 44
    np.testing.assert_allclose([e.t for e in result.jumps], ball_impacts(0.95, 44), atol=1e-8)


def test_thermostat_switching_times_follow_the_exponential_solution(models_dir):
    model = hybridlab.load_model(models_dir / "thermostat.toml")
    result = hybridlab.simulate(model, t_end=30.0, rtol=1e-12, atol=1e-12)
    a, t_out, t_heat, low, high = 0.1, 10.0, 40.0, 18.0, 22.0
    on_time = math.log((low - t_heat) / (high - t_heat)) / a  # heating 18 -> 22
    off_time = math.log((high - t_out) / (low - t_out)) / a  # cooling 22 -> 18
    first = math.log((20.0 - t_heat) / (high - t_heat)) / a  # heating 20 -> 22
    expected = [first]
    while len(expected) < len(result.jumps):
        expected.append(expected[-1] + (off_time if len(expected) % 2 else on_time))
    assert len(result.jumps) >= 8
    np.testing.assert_allclose([e.t for e in result.jumps], expected, rtol=0, atol=1e-9)
    assert [e.transition for e in result.jumps[:3]] == ["turn_off", "turn_on", "turn_off"]


@pytest.mark.parametrize("method", ["Radau", "BDF", "LSODA"])
def test_stiff_methods_locate_thermostat_switches(models_dir, method):
    model = hybridlab.load_model(models_dir / "thermostat.toml")
    result = hybridlab.simulate(model, t_end=8.0, method=method, rtol=1e-10, atol=1e-10)
    first = math.log((20.0 - 40.0) / (22.0 - 40.0)) / 0.1
    assert result.jumps[0].t == pytest.approx(first, abs=1e-6)
    assert len(result.jumps) == 3
