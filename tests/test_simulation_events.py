"""Event semantics: paired crossings, priorities, cascades, re-triggering, grazing, invariants."""

from __future__ import annotations

import math

import numpy as np
import pytest

import hybridlab
from hybridlab import Status

pytestmark = pytest.mark.usefixtures("each_engine")


def model(text: str) -> hybridlab.Model:
    return hybridlab.loads_model(text, source="<test>")


FAST_GUARD = """
name = "fast_guard"
parameters = { omega = 40.0 }
states = { x = 0.0, n = 0.0 }
[modes.a]
flow = { x = "1", n = "0" }
[[transitions]]
name = "enter"
source = "a"
target = "a"
guard = "sin(omega*x) >= 0.5"
reset = { n = "n + 1" }
[initial]
mode = "a"
"""


@pytest.mark.parametrize("omega", [7.0, 40.0, 123.0, 400.0])
def test_fast_oscillating_guard_finds_every_paired_crossing(omega):
    # x' = 1 is integrated in a handful of huge steps, so the guard enters and leaves its
    # region many times inside one step; every entry must be found, at the exact instant.
    result = hybridlab.simulate(model(FAST_GUARD), t_end=10.0, params={"omega": omega})
    entries = [(math.pi / 6 + 2 * math.pi * k) / omega for k in range(int(10 * omega))]
    entries = [t for t in entries if t < 10.0]
    # without interior refinement the sampled endpoints alone would miss entries
    coarse = hybridlab.simulate(model(FAST_GUARD), t_end=10.0, params={"omega": omega},
                                max_refine=0, samples_per_step=1)
    if omega >= 40:
        assert len(coarse.jumps) < len(entries)
    times = [e.t for e in result.jumps]
    assert len(times) == len(entries)
    np.testing.assert_allclose(times, entries, rtol=0, atol=1e-10)
    assert result.final.state["n"] == len(entries)


PRIORITY = """
name = "priority"
states = { x = 0.0, y = 0.0, order = 0.0 }
[modes.a]
flow = { x = "1", y = "1", order = "0" }
[[transitions]]
name = "second"
source = "a"
target = "a"
guard = "y >= 1"
reset = { y = "0", order = "order*10 + 2" }
priority = 2
[[transitions]]
name = "first"
source = "a"
target = "a"
guard = "x >= 1"
reset = { x = "0", order = "order*10 + 1" }
priority = 1
"""


def test_simultaneous_guards_fire_in_priority_order():
    result = hybridlab.simulate(model(PRIORITY + '[initial]\nmode = "a"\n'), t_end=2.5)
    assert [(e.transition, e.j) for e in result.jumps] == [
        ("first", 1), ("second", 2), ("first", 3), ("second", 4)]
    assert [e.t for e in result.jumps] == pytest.approx([1.0, 1.0, 2.0, 2.0], abs=1e-12)
    assert result.final.state["order"] == 1212.0


def test_priority_chooses_between_targets_and_unnumbered_come_last():
    text = """
name = "choice"
states = { x = 0.0 }
[modes.a]
flow = { x = "1" }
[modes.b]
flow = { x = "0" }
[modes.c]
flow = { x = "0" }
[[transitions]]
name = "to_b"
source = "a"
target = "b"
guard = "x >= 1"
[[transitions]]
name = "to_c"
source = "a"
target = "c"
guard = "x >= 1"
priority = 5
[initial]
mode = "a"
"""
    result = hybridlab.simulate(model(text), t_end=2.0)
    assert [e.transition for e in result.jumps] == ["to_c"]
    assert result.final.mode == "c"


def test_zero_dwell_cycle_is_reported_as_zeno_not_a_hang():
    text = """
name = "ping_pong"
states = { x = 0.0 }
[modes.a]
flow = { x = "1" }
[modes.b]
flow = { x = "1" }
[[transitions]]
name = "ab"
source = "a"
target = "b"
guard = "x >= 1"
[[transitions]]
name = "ba"
source = "b"
target = "a"
guard = "x >= 1"
[initial]
mode = "a"
"""
    result = hybridlab.simulate(model(text), t_end=5.0, max_event_iterations=50)
    assert result.status is Status.ZENO
    assert "zero-dwell" in result.message
    assert result.final.t == pytest.approx(1.0)


def test_self_loop_does_not_retrigger_right_after_its_reset():
    # the guard still holds after the reset; the transition fires once per entry
    text = """
name = "latch"
states = { x = 0.0, n = 0.0 }
[modes.a]
flow = { x = "1", n = "0" }
[[transitions]]
name = "count"
source = "a"
target = "a"
guard = "x >= 1"
reset = { n = "n + 1" }
[initial]
mode = "a"
"""
    result = hybridlab.simulate(model(text), t_end=3.0)
    assert result.status is Status.COMPLETED
    assert [e.t for e in result.jumps] == pytest.approx([1.0])


def test_guard_true_at_start_fires_immediately():
    text = """
name = "start"
states = { x = 5.0 }
[modes.a]
flow = { x = "1" }
[modes.b]
flow = { x = "-1" }
[[transitions]]
name = "go"
source = "a"
target = "b"
guard = "x >= 1"
[initial]
mode = "a"
"""
    result = hybridlab.simulate(model(text), t_end=1.0)
    assert [(e.t, e.transition) for e in result.jumps] == [(0.0, "go")]
    assert result.final.state["x"] == pytest.approx(4.0)


def test_invariant_violation_without_enabled_transition_stops_loudly():
    text = """
name = "blocked"
states = { x = 0.0 }
[modes.a]
flow = { x = "1" }
invariant = "x <= 1"
[initial]
mode = "a"
"""
    result = hybridlab.simulate(model(text), t_end=5.0)
    assert result.status is Status.INVARIANT_VIOLATED
    assert "x <= 1" in result.message
    assert result.final.t == pytest.approx(1.0, abs=1e-12)


def test_grazing_contact_fires_and_is_reported():
    # x = (t - 1)^2 touches the guard x <= 0 tangentially at t = 1
    text = """
name = "graze"
states = { x = 1.0, n = 0.0 }
[modes.a]
flow = { x = "2*(t - 1)", n = "0" }
[[transitions]]
name = "touch"
source = "a"
target = "a"
guard = "x <= 0"
reset = { n = "n + 1" }
[initial]
mode = "a"
"""
    result = hybridlab.simulate(model(text), t_end=3.0)
    assert len(result.jumps) == 1
    assert result.jumps[0].grazing
    # a tangential root is ill-conditioned: located to sqrt(rounding), not to 1e-12
    assert result.jumps[0].t == pytest.approx(1.0, abs=1e-6)


def test_near_miss_does_not_fire():
    text = """
name = "miss"
states = { x = 1.0 }
[modes.a]
flow = { x = "2*(t - 1)" }
[modes.b]
flow = { x = "0" }
[[transitions]]
name = "touch"
source = "a"
target = "b"
guard = "x <= -1e-6"
[initial]
mode = "a"
"""
    result = hybridlab.simulate(model(text), t_end=3.0)
    assert result.jumps == ()


def test_conjunction_guard_needs_every_inequality():
    text = """
name = "both"
states = { x = 0.0, y = 0.0 }
[modes.a]
flow = { x = "1", y = "2" }
[modes.b]
flow = { x = "0", y = "0" }
[[transitions]]
name = "go"
source = "a"
target = "b"
guard = ["x >= 1", "y >= 3"]
[initial]
mode = "a"
"""
    result = hybridlab.simulate(model(text), t_end=3.0)
    assert result.jumps[0].t == pytest.approx(1.5, abs=1e-12)


def test_sampled_controller_fires_at_exact_times_and_matches_difference_equation(models_dir):
    result = hybridlab.simulate(models_dir / "sampled_control.toml")
    times = np.array([e.t for e in result.jumps])
    np.testing.assert_allclose(times, np.arange(21) * 0.1, atol=1e-12)
    pre_x = np.array([e.pre["x"] for e in result.jumps])
    np.testing.assert_allclose(pre_x, 0.8 ** np.arange(21), rtol=1e-12)


def test_scheduled_and_state_events_interleave():
    text = """
name = "mixed"
states = { x = 0.0, k = 0.0 }
[modes.a]
flow = { x = "1", k = "0" }
[[transitions]]
name = "tick"
source = "a"
target = "a"
schedule = { period = 0.25 }
reset = { k = "k + 1" }
[[transitions]]
name = "wrap"
source = "a"
target = "a"
guard = "x >= 0.6"
reset = { x = "0" }
[initial]
mode = "a"
"""
    result = hybridlab.simulate(model(text), t_end=1.3)
    names = [(round(e.t, 9), e.transition) for e in result.jumps]
    assert names == [(0.0, "tick"), (0.25, "tick"), (0.5, "tick"), (0.6, "wrap"), (0.75, "tick"),
                     (1.0, "tick"), (1.2, "wrap"), (1.25, "tick")]


STICKY_BALL = """
name = "sticky_ball"
parameters = { g = 9.81, e = 0.0 }
states = { h = 1.0, v = 0.0 }
[modes.fall]
flow = { h = "v", v = "-g" }
invariant = "h >= 0"
[[transitions]]
name = "bounce"
source = "fall"
target = "fall"
guard = "h <= 0"
reset = { v = "-e*v" }
[initial]
mode = "fall"
"""


@pytest.mark.parametrize("backend", ["reference", "auto"])
@pytest.mark.parametrize("e", [0.0, 1e-3, 0.01, 0.05, 0.1, 0.3])
def test_a_reset_onto_its_guard_against_the_invariant_is_zeno_never_a_fall(e, backend):
    # after the reset the state sits on the guard and the flow leaves the invariant: the
    # automaton can only jump again at once (e = 0) or after ever shorter flights
    result = hybridlab.simulate(model(STICKY_BALL), t_end=5.0, params={"e": e},
                                backend=backend)
    assert result.status is Status.ZENO, result.message
    t1 = math.sqrt(2 / 9.81)
    t_acc = t1 * (1 + 2 * e / (1 - e))  # the flights' geometric series
    assert result.zeno_time == pytest.approx(t_acc, rel=1e-5)
    ts = np.linspace(0.0, result.final.t, 2001)
    assert result(ts)[0].min() >= -1e-9  # never through the floor
    assert result.final.t <= t_acc * (1 + 1e-5)


def test_a_mode_named_like_the_wildcard_is_refused():
    text = STICKY_BALL.replace("[modes.fall]", '[modes."*"]').replace('"fall"', '"*"')
    with pytest.raises(hybridlab.ModelError, match=r"modes: .*'\*'.*token '\*'"):
        model(text)


SAMPLER = """
name = "sampler"
parameters = { T = 0.0, on = 1.0 }
states = { x = 1.0, n = 0.0 }
[modes.a]
flow = { x = "-x", n = "0" }
[[transitions]]
name = "tick"
source = "a"
target = "a"
reset = { n = "n + 1" }
schedule = { period = "1/T", enabled = "on" }
[initial]
mode = "a"
"""


def test_a_schedule_period_that_is_not_finite_is_a_load_error():
    with pytest.raises(hybridlab.ModelError,
                       match=r"transitions\[0\]\.schedule\.period: must be positive and finite "
                             r".*token '1/T'"):
        model(SAMPLER)
    for period in ("0", "-0.5", "T - 1"):
        with pytest.raises(hybridlab.ModelError, match="schedule.period: must be positive"):
            model(SAMPLER.replace('"1/T"', f'"{period}"'))
    with pytest.raises(hybridlab.ModelError, match="schedule.phase: must be finite"):
        model(SAMPLER.replace('"1/T"', '"1", phase = "1/T"'))


@pytest.mark.parametrize("backend", ["reference", "auto"])
def test_a_schedule_period_invalid_for_a_run_is_an_error_and_enabled_switches_it_off(backend):
    sampler = model(SAMPLER.replace("T = 0.0", "T = 4.0"))
    result = hybridlab.simulate(sampler, t_end=1.0, backend=backend)
    assert [ev.t for ev in result.jumps] == pytest.approx([0.0, 0.25, 0.5, 0.75, 1.0])
    with pytest.raises(hybridlab.ModelError, match=r"schedule\.period: must be positive .*run"):
        hybridlab.simulate(sampler, t_end=1.0, params={"T": 0.0}, backend=backend)
    off = hybridlab.simulate(sampler, t_end=1.0, params={"T": 0.0, "on": 0.0}, backend=backend)
    assert off.status is Status.COMPLETED and not off.jumps
