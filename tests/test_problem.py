"""HybridProblem: resolved once, with one wording, and taken by every entry point."""

from __future__ import annotations

import numpy as np
import pytest

import hybridlab
from hybridlab.identify import Target, fit_targets
from hybridlab.simulation.problem import HybridProblem, ProblemError
from hybridlab.verify import VerdictStatus, check_safety

BALL = "models/bouncing_ball.toml"


@pytest.fixture(scope="module")
def ball() -> hybridlab.CompiledModel:
    return hybridlab.compile_model(hybridlab.load_model(BALL))


@pytest.mark.parametrize("kwargs, message", [
    ({"initial": {"w": 1.0}}, "initial: unknown state 'w'; expected one of: h, v"),
    ({"params": {"G": 1.0}}, "params: unknown parameter 'G'; expected one of: g, e"),
    ({"inputs": {"G": (0, 1)}}, "inputs: unknown parameter 'G'; expected one of: g, e"),
    ({"mode": "rise"}, "mode: unknown mode 'rise'; expected one of: fall"),
    ({"scenario": "nope"}, "scenario: unknown scenario 'nope'; the model has: default, zeno"),
    ({"initial": {"h": (2.0, 1.0)}}, r"initial\['h'\] needs lo <= hi"),
    ({"params": {"e": "high"}}, r"params\['e'\] must be a number or a \(lo, hi\) pair"),
    ({"t_end": float("inf")}, "t_end and t_start must be finite"),
    ({"t_end": -1.0}, "t_end must be greater than t_start = 0"),
])
def test_every_entry_point_words_a_bad_argument_alike(ball, kwargs, message):
    kwargs = {"t_end": 1.0, **kwargs}
    errors = []
    for call in (lambda: HybridProblem.build(ball, **kwargs),
                 lambda: hybridlab.reach(ball, **kwargs),
                 lambda: check_safety(ball, safe="h <= 20", **kwargs)):
        with pytest.raises(ValueError, match=message) as info:
            call()
        errors.append(str(info.value))
    if "inputs" not in kwargs:
        with pytest.raises(ValueError, match=message) as info:
            hybridlab.simulate(ball, **kwargs)
        errors.append(str(info.value))
    assert len(set(errors)) == 1 and "\n" not in errors[0]


def test_the_scenario_supplies_defaults_and_arguments_override_them(ball):
    pb = HybridProblem.build(ball, scenario="benchmark", initial={"h": 3.0})
    assert pb.scenario == "benchmark" and pb.t_end == 50.0 and pb.mode == "fall"
    assert pb.initial == {"h": 3.0, "v": 0.0} and pb.parameters["e"] == 0.95
    assert not pb.uncertain and pb.dims == 0
    assert HybridProblem.build(pb) is pb
    later = HybridProblem.build(pb, t_end=5.0)
    assert later.t_end == 5.0 and later.initial == pb.initial and later.scenario == "benchmark"
    with pytest.raises(TypeError, match="unknown option"):
        HybridProblem.build(ball, t_end=1.0, rtoll=1e-9)


def test_simulate_takes_a_problem_and_refuses_a_set(ball):
    pb = HybridProblem.build(ball, t_end=2.0, params={"e": 0.8}, initial={"h": 5.0})
    direct = hybridlab.simulate(ball, 2.0, params={"e": 0.8}, initial={"h": 5.0})
    via = hybridlab.simulate(pb)
    assert np.array_equal(via.t, direct.t) and np.array_equal(via.y, direct.y)
    assert hybridlab.simulate(pb, t_end=1.0).t[-1] == 1.0
    with pytest.raises(ProblemError, match=r"simulate needs one point.*\(h, e\)"):
        hybridlab.simulate(pb.updated(initial={"h": (4.0, 5.0)}, params={"e": (0.7, 0.9)}))


def test_reach_and_check_take_a_problem(ball):
    pb = HybridProblem.build(ball, t_end=1.0, initial={"h": (5.0, 6.0)})
    direct = hybridlab.reach(ball, t_end=1.0, initial={"h": (5.0, 6.0)}, step=0.01)
    via = hybridlab.reach(pb, step=0.01)
    assert via.bounds == direct.bounds and len(via.sets) == len(direct.sets)
    verdict = check_safety(pb, safe="h <= 6.1")
    assert verdict.status is VerdictStatus.SAFE, verdict.reason
    assert check_safety(pb, safe="h <= 5.5").status is VerdictStatus.UNSAFE


def test_sweep_takes_a_point_problem_and_sweeps_over_it(ball):
    pb = HybridProblem.build(ball, t_end=3.0, params={"e": 0.5}, initial={"h": 5.0})
    via = hybridlab.sweep(pb, grid={"h": [2.0, 4.0]}, events=["bounce"], executor="serial")
    direct = hybridlab.sweep(ball, t_end=3.0, params={"e": 0.5}, grid={"h": [2.0, 4.0]},
                             events=["bounce"], executor="serial")
    assert via["count:bounce"].tolist() == direct["count:bounce"].tolist()
    assert via["t_final"].tolist() == direct["t_final"].tolist()
    with pytest.raises(ProblemError, match="sweep needs one point"):
        hybridlab.sweep(pb.updated(params={"e": (0.4, 0.6)}), grid={"h": [1.0]})


def test_a_fit_takes_a_problem():
    # the first apex, e^2 h0 with h0 = 10 m on the moon (g = 1.62): e = 0.8 at 6.4 m
    apex = Target("value", 6.4, 0.01, transition="bounce", at="h + v**2/(2*g)", index=0,
                  t_end=8.0)
    moon = HybridProblem.build(BALL, t_end=8.0, params={"g": 1.62})
    fit = fit_targets(moon, [apex], fit=["e"], initial_guess={"e": 0.6})
    assert fit.parameters["e"] == pytest.approx(0.8, abs=1e-3)
    assert fit_targets(moon, [apex], fit=["e"], initial_guess={"e": 0.6},
                       params={"g": 9.81}).parameters["e"] == pytest.approx(0.8, abs=1e-3)
