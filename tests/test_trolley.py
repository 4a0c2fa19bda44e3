"""The trolley model (models/trolley.toml) against the paper and the issue's acceptance list."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import hybridlab
from hybridlab.analysis import count_crossings, step_metrics
from hybridlab.model.names import match_modes
from hybridlab.symbolic.lagrange import lagrange_equations

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def trolley():
    return hybridlab.compile_model(hybridlab.load_model(ROOT / "models" / "trolley.toml"))


def hold(compiled: hybridlab.CompiledModel) -> str:
    """The product mode in which the manoeuvre logic holds the set point."""
    [mode] = match_modes("hold", list(compiled.modes))
    return mode


def test_point_mass_pendulum_on_a_cart_gives_the_papers_eqs_9_and_10():
    x, v, phi, w, m_c, m_l, l, g = sp.symbols("x v phi omega m_C m_L l g", real=True)
    xdd, pdd, f_in, f_f, m_f = sp.symbols("xdd pdd F_in F_f M_f", real=True)
    # m_C is the paper's lumped mass (block plus pendulum), so the block alone is m_C - m_L
    kinetic = ((m_c - m_l) * v**2
               + m_l * ((v + l * sp.cos(phi) * w) ** 2 + (l * sp.sin(phi) * w) ** 2)) / 2
    eq = lagrange_equations(kinetic, -m_l * g * l * sp.cos(phi), [x, phi], [v, w])
    residual = [r.xreplace({eq.forces[0]: f_in - f_f, eq.forces[1]: -m_f})
                for r in eq.residuals([xdd, pdd])]
    eq9 = f_f + m_c * xdd + m_l * l * (pdd * sp.cos(phi) - w**2 * sp.sin(phi)) - f_in
    eq10 = m_l * l * sp.cos(phi) * xdd + m_l * l**2 * pdd + m_l * g * l * sp.sin(phi) + m_f
    assert sp.simplify(residual[0] - eq9) == 0
    assert sp.simplify(residual[1] - eq10) == 0


def test_the_core_has_no_trolley_code():
    for path in (ROOT / "hybridlab").rglob("*.py"):
        text = path.read_text().lower()
        for word in ("trolley", "ball-screw", "photoelectric", "x_tip", "stop_and_return"):
            assert word not in text, f"{path} mentions {word!r}"


@pytest.mark.parametrize(("params", "paper"), [({"a_b": 0.04, "b_b": 0.0}, 63), ({}, 83)])
def test_free_drop_crossing_counts_within_3_of_the_paper(trolley, params, paper):
    result = hybridlab.simulate(trolley, scenario="free_drop", params=params)
    assert result.status is hybridlab.Status.COMPLETED
    _, y = result.sample(1e-4)
    crossings = count_crossings(y[result.state_names.index("phi")])
    assert abs(crossings - paper) <= 3
    # the pendulum has come to rest (stuck by bearing friction) before the end
    assert abs(result.final.state["omega"]) < 1e-9


def test_sensor_edges_are_located_to_1e_9_s(trolley):
    result = hybridlab.simulate(trolley, scenario="free_drop", t_end=6.0)
    edges = [e for e in result.jumps if e.transition in ("s1_on", "s1_off", "s2_on", "s2_off")]
    assert len(edges) > 20
    for e in edges:
        p = "p_1" if e.transition.startswith("s1") else "p_2"
        before, after = result.observe(f"abs(x_tip - {p}) - w", [e.t - 1e-9, e.t + 1e-9])
        if e.transition.endswith("_on"):
            assert before > 0 >= after or abs(after) < 1e-12
        else:
            assert before < 0 <= after or abs(after) < 1e-12


def test_stop_and_return_ends_within_half_a_millimetre_of_the_recorded_position(trolley):
    result = hybridlab.simulate(trolley, t_end=4.0)
    sensors = {"s1_on", "s1_off", "s2_on", "s2_off", "detect"}
    names = [e.transition for e in result.jumps if e.transition not in sensors]
    assert names[:2] == ["start_stop_return", "cruise"]
    assert "stop" in names and names[-1] == "arrive"
    stop = next(e for e in result.jumps if e.transition == "stop")
    # the reset recorded the cart position at the sensor event
    assert stop.post["x_e"] == stop.pre["x"]
    tip = result.observe("x_tip - p_1 + w", [stop.t])[0]
    assert abs(tip) < 1e-9
    assert abs(result.final.state["x"] - stop.post["x_e"]) < 0.5e-3
    assert result.final.mode == hold(trolley)


@pytest.mark.parametrize(("phi0", "moves"), [(0.004, False), (0.007, True)])
def test_pendulum_released_inside_the_stiction_band_never_moves(trolley, phi0, moves):
    # |m g l_c sin(phi0)| < a_b = 0.02 N m  <=>  |phi0| < 0.0054 rad
    result = hybridlab.simulate(trolley, scenario="free_drop", t_end=3.0,
                                initial={"phi": phi0})
    phi = result.y[result.state_names.index("phi")]
    if moves:
        assert np.ptp(phi) > 1e-3
    else:
        assert np.all(phi == phi0)
        assert np.all(result.y[result.state_names.index("omega")] == 0.0)


def test_step_response_matches_table_iv(trolley):
    result = hybridlab.simulate(trolley, scenario="step")
    t, y = result.sample(1e-5)
    metrics = step_metrics(t, y[0], 0.0, 0.01)
    assert metrics.overshoot_pct == pytest.approx(5.9, abs=0.5)
    assert metrics.settling_time == pytest.approx(0.067, abs=0.005)


def test_sampled_controller_converges_to_the_continuous_one(trolley):
    t = np.linspace(0, 0.2, 401)
    cont = hybridlab.simulate(trolley, scenario="step", t_end=0.2)(t)[0]
    errors = []
    for period in (2e-3, 1e-3, 2.5e-4):
        samp = hybridlab.simulate(trolley, scenario="step", t_end=0.2,
                                  params={"sampled": 1.0, "T_s": period})
        samples = [e.t for e in samp.jumps if e.transition == "sample"]
        assert len(samples) == round(0.2 / period) + 1
        np.testing.assert_allclose(samples, np.arange(len(samples)) * period, atol=1e-12)
        errors.append(np.max(np.abs(samp(t)[0] - cont)))
    # a zero-order hold adds about half a period of delay: the error shrinks with the period
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 0.1e-3 and errors[1] < 0.5e-3


def test_profiles_reach_the_target_distance(trolley):
    second = hybridlab.simulate(trolley, scenario="tracking")
    fourth = hybridlab.simulate(trolley, scenario="jerk_limited")
    for result in (second, fourth):
        assert result.final.mode == hold(trolley)
        assert result.final.state["x_s"] == pytest.approx(0.3, abs=1e-9)
        assert result.final.state["x"] == pytest.approx(0.3, abs=1e-4)
    modes = [m for _, _, m in fourth.mode_trace() if "logic.p4" in m]
    visited = [m for i, m in enumerate(modes) if i == 0 or m != modes[i - 1]]
    assert visited == [m for k in range(1, 8) for m in match_modes(f"p4_{k}", list(trolley.modes))]


def test_sensor_latency_delays_the_stop_by_exactly_the_latency(trolley):
    latency = 1 / 1650  # the sensors' switching frequency
    result = hybridlab.simulate(trolley, t_end=1.5, params={"latency": latency})
    detect = next(e for e in result.jumps if e.transition == "detect")
    stop = next(e for e in result.jumps if e.transition == "stop")
    assert stop.t - detect.t == pytest.approx(latency, abs=1e-12)
    # the recorded position is the cart's position when the delayed event arrives
    assert stop.post["x_e"] == stop.pre["x"] > detect.pre["x"]


def test_the_components_give_the_events_of_the_flat_model(trolley):
    # tests/data/trolley_flat.toml: the same model written by hand as one automaton
    flat = hybridlab.load_model(ROOT / "tests" / "data" / "trolley_flat.toml")
    assert trolley.model.network is not None and flat.network is None
    assert len(trolley.model.states) == len(flat.states) == 6  # integrated states
    runs = [hybridlab.simulate(m, t_end=2.5) for m in (trolley, flat)]
    composed, written = ([(e.t, e.transition, e.source, e.target) for e in r.jumps]
                         for r in runs)
    assert len(composed) == len(written) > 20
    assert [e[1] for e in composed] == [e[1] for e in written]
    assert "arrive" in [e[1] for e in composed]
    for ours, theirs in zip(composed, written, strict=True):
        assert abs(ours[0] - theirs[0]) <= 1e-10
        assert match_modes(theirs[2], [ours[2]]) == [ours[2]]
        assert match_modes(theirs[3], [ours[3]]) == [ours[3]]


def test_the_linearised_trolley_follows_the_trolley_through_its_stop_and_return(trolley):
    # models/trolley_linear.toml: the same controller, sensors, logic and friction laws, the
    # plant linearised about the pendulum's downward rest (the swing stays below 0.3 rad)
    linear = hybridlab.load_model(ROOT / "models" / "trolley_linear.toml")
    runs = [hybridlab.simulate(m, t_end=2.5) for m in (trolley, linear)]
    names = [[e.transition for e in r.jumps] for r in runs]
    assert names[0] == names[1] and "arrive" in names[0]
    grid = np.linspace(0.0, 2.5, 501)
    full, lin = (r.observe(["x", "phi"], grid) for r in runs)
    assert np.abs(full[0] - lin[0]).max() < 3e-4        # m, over a 0.3 m move
    assert np.abs(full[1] - lin[1]).max() < 0.01        # rad, over a 0.27 rad swing
    assert np.abs(full[1]).max() > 0.25
