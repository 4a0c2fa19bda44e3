"""The plain scipy trolley of the benchmarks agrees with hybridlab's reference backend.

``benchmarks/scipy_trolley.py`` is the baseline the trolley benchmarks time
hybridlab against; these tests keep it an implementation of the same model.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

import hybridlab
from hybridlab.model.names import match_modes

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCH))

import scipy_trolley  # noqa: E402
import trolley_check  # noqa: E402


@pytest.fixture(scope="module")
def compiled() -> hybridlab.CompiledModel:
    return hybridlab.compile_model(hybridlab.load_model(scipy_trolley.MODEL))


def test_hand_derived_flow_equals_hybridlab_flow(compiled):
    tr = scipy_trolley.Trolley.from_model("free_drop")
    [hold] = match_modes("hold", list(compiled.modes))  # the product mode with logic.hold
    mode = compiled.modes[hold]
    names = compiled.state_names
    p = compiled.parameter_vector(compiled.model.scenarios["free_drop"].parameters)
    rng = np.random.default_rng(7)
    for _ in range(20):
        x, v, phi, omega, z, x_ref, v_ref = rng.uniform(-2, 2, 7)
        s_v, s_w = rng.choice([-1.0, 1.0], 2)
        state = np.zeros(len(names))
        for name, value in (("x", x), ("v", v), ("phi", phi), ("omega", omega), ("z", z),
                            ("x_s", x_ref), ("v_s", v_ref)):
            state[names.index(name)] = value
        sigma = np.array([s_v if sw.text == "sign(v)" else s_w for sw in mode.switches])
        theirs = mode.flow(0.0, state, p, sigma)[[names.index(n) for n in
                                                   ("x", "v", "phi", "omega", "z")]]
        ours = scipy_trolley.rhs_values(tr, 0.0, np.array([x, v, phi, omega, z]), x_ref,
                                        v_ref, s_v, s_w)
        np.testing.assert_allclose(ours, theirs, rtol=1e-12, atol=1e-9)


def test_stop_and_return_events_agree_with_hybridlab(compiled):
    agreement = trolley_check.check("stop_and_return", compiled)
    counts = agreement.counts
    for name in ("detect", "stop", "turn", "arrive"):
        assert counts[name] == (1, 1)
    assert counts["s1_on"][0] >= 10
    assert agreement.observable_dt() <= 1e-7
    assert agreement.friction_dt() <= trolley_check.FRICTION_TOL


def test_free_drop_events_agree_with_hybridlab(compiled):
    agreement = trolley_check.check("free_drop", compiled, t_end=8.0)
    # the pendulum swings through both sensors about twice a second
    assert agreement.counts["s1_on"][0] >= 14
    assert agreement.counts["crossing sign(omega)"][0] >= 14
    assert agreement.counts["slide_start sign(v)"][0] >= 20
    assert agreement.observable_dt() <= 1e-7


def test_check_reports_a_disagreement(compiled):
    with pytest.raises(RuntimeError, match="event times differ"):
        trolley_check.check("stop_and_return", compiled, t_end=2.0, rtol=1e-4, atol=1e-6,
                            observable_tol=1e-12)


def test_compare_pairs_events_by_name():
    a = [(1.0, "s1_on"), (2.0, "s1_off"), (2.5, "slide_start sign(v)"),
         (2.6, "slide_start sign(v)")]
    b = [(1.0 + 1e-9, "s1_on"), (2.0, "s1_off"), (2.5, "slide_start sign(v)"), (3.0, "stop")]
    agreement = trolley_check.compare(a, b)
    assert agreement.mismatched() == ["stop"]  # the repeated slide_start is dropped
    assert math.isclose(agreement.observable_dt(), 1e-9, rel_tol=1e-6)


def test_fig14_point_matches_hybridlab(compiled):
    hold = 3.0
    ours = scipy_trolley.fig14_point(0.25, 1.0, hold)
    result = hybridlab.simulate(compiled, params={"profile": 1.0, "p_1": 0.25, "a_max": 1.0},
                                t_end=12.0 + hold, **trolley_check.reference_backend())
    arrive = next(e.t for e in result.jumps if e.transition == "arrive")
    theirs = sum(1 for e in result.jumps if e.transition in ("s1_on", "s1_off")
                 and e.t > arrive)
    assert ours == theirs > 0


def test_unsupported_options_are_refused():
    with pytest.raises(ValueError, match="sampled"):
        scipy_trolley.Trolley.from_model("default", {"sampled": 1.0})
    with pytest.raises(ValueError, match="profile"):
        scipy_trolley.Trolley.from_model("tracking")
