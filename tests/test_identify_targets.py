"""Parameters from summary quantities (event counts, periods, values at events, steps).

The closed forms come from the Coulomb-damped oscillator ``models/friction_oscillator.toml``
(m = 1, k = 4, x0 = 1, d = 0): the angular frequency is ``sqrt(k/m)`` whatever the
friction, each half swing loses ``2 c / k`` of amplitude, so the number of zero crossings
is ``ceil(k x0 / (2 c)) - 1`` and the continuous count is exactly ``k x0 / (2 c)``; the
speed at the first crossing is ``sqrt(k x0^2 - 2 c x0)`` (energy).
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np
import pytest

import hybridlab
from hybridlab.cli.identify import add_parser as add_identify_parser
from hybridlab.identify import Target, TargetError, fit_targets, read_targets
from hybridlab.identify.summary import continuous_count, level_crossings
from hybridlab.identify.targets import target_statistic

ROOT = Path(__file__).resolve().parents[1]
OSCILLATOR = ROOT / "models" / "friction_oscillator.toml"
TROLLEY = ROOT / "models" / "trolley.toml"


@pytest.fixture(scope="module")
def oscillator() -> hybridlab.CompiledModel:
    return hybridlab.compile_model(hybridlab.load_model(OSCILLATOR))


@pytest.fixture(scope="module")
def trolley() -> hybridlab.CompiledModel:
    return hybridlab.compile_model(hybridlab.load_model(TROLLEY))


def _count(compiled, c: float) -> tuple[float, float]:
    result = hybridlab.simulate(compiled, t_end=20.0, params={"c": c})
    return target_statistic(Target("count", 0, 1.0, observable="x"), result, compiled)


@pytest.mark.parametrize("c", [0.3, 0.45, 0.7])
def test_continuous_count_is_the_closed_form(oscillator, c) -> None:
    continuous, integer = _count(oscillator, c)
    assert integer == math.ceil(4.0 / (2 * c)) - 1
    assert continuous == pytest.approx(4.0 / (2 * c), abs=2e-3)


def test_continuous_count_has_no_jump_where_the_integer_count_does(oscillator) -> None:
    # k x0 / (2 c) = 4 at c = 0.5: four crossings just below, three just above
    below, above = _count(oscillator, 0.5 - 1e-3), _count(oscillator, 0.5 + 1e-3)
    assert (below[1], above[1]) == (4.0, 3.0)
    assert below[0] - above[0] == pytest.approx(4.0 / (1 - 2e-3) - 4.0 / (1 + 2e-3), abs=2e-3)


def test_cut_off_count_uses_the_time_fraction() -> None:
    t = np.linspace(0.0, 2.25, 22501)  # sin(2 pi t): crossings at 0.5, 1, 1.5, 2
    c = level_crossings(t, np.sin(2 * np.pi * t))
    assert len(c) == 4
    assert continuous_count(c) == pytest.approx(4.5, abs=1e-3)


def test_recovers_stiffness_and_friction_from_period_and_first_speed(oscillator) -> None:
    truth = {"k": 4.0, "c": 0.45}
    targets = [
        # turning points (v = 0 downwards) are exactly pi/2 apart; zero crossings of x are not
        Target("interval", math.pi, 0.001, observable="v", direction=-1, t_end=20.0),
        Target("value", -math.sqrt(4.0 - 2 * 0.45), 0.001, observable="x", at="v", index=0,
               t_end=20.0),
        Target("count", 4, 0.5, observable="x", t_end=20.0),
    ]
    fit = fit_targets(oscillator, targets, fit=["k", "c"], initial_guess={"k": 6.0, "c": 0.22},
                      max_evaluations=30)
    assert fit.parameters["k"] == pytest.approx(truth["k"], rel=2e-3)
    assert fit.parameters["c"] == pytest.approx(truth["c"], rel=2e-2)
    assert fit.simulated[2] == 4.0  # the integer count matches
    assert fit.simulated_initial[2] == math.ceil(6.0 / 0.44) - 1  # 13 at the start
    assert all(0 < u < 0.05 for u in fit.uncertainties.values())
    assert np.all(np.abs(fit.residuals) < 1.5)
    assert fit.singular_values.shape == (2,) and fit.condition < 1e3
    assert set(fit.as_dict()["parameters"]) == {"k", "c"}
    assert "residual/sigma" in fit.table()


def test_count_alone_converges_from_a_start_with_a_different_count(oscillator) -> None:
    # start: c = 0.15 gives 13 crossings; the target is 5 (c in (1/3, 0.4])
    target = Target("count", 5, 0.1, observable="x", t_end=20.0)
    fit = fit_targets(oscillator, [target], fit=["c"], initial_guess={"c": 0.15},
                      max_evaluations=20)
    assert fit.simulated_initial == (13.0,)
    assert fit.simulated == (5.0,)
    assert 1 / 3 <= fit.parameters["c"] < 0.4
    assert fit.continuous[0] == pytest.approx(5.5, abs=0.05)


def test_two_parameters_one_quantity_is_flagged_as_not_identifiable(oscillator) -> None:
    # the count depends on k / c only: the Jacobian has rank 1
    target = Target("count", 4, 0.5, observable="x", t_end=20.0)
    fit = fit_targets(oscillator, [target], fit=["k", "c"], max_evaluations=8)
    assert all(math.isnan(u) for u in fit.uncertainties.values())
    assert fit.condition == math.inf or fit.condition > 1e8
    # the weakest direction is k and c changing together (relative changes)
    assert fit.weakest["k"] == pytest.approx(fit.weakest["c"], abs=0.05)


#: A Coulomb-damped oscillator passing two point sensors 10 mm apart (fast to simulate).
SENSED = """
name = "sensed_oscillator"
parameters = { k = 4.0, c = 0.1, p1 = 0.0, p2 = 0.01, w = 0.02 }
[states]
x = { initial = 1.0 }
v = { initial = 0.0 }
S1 = { initial = 0.0, flow = "0" }
S2 = { initial = 0.0, flow = "0" }
[modes.move]
flow = { x = "v", v = "-k*x - c*sign(v)" }
[[transitions]]
name = "s1_on"
source = "move"
target = "move"
guard = ["S1 <= 0.5", "abs(x - p1) <= w"]
reset = { S1 = "1" }
[[transitions]]
name = "s1_off"
source = "move"
target = "move"
guard = ["S1 >= 0.5", "abs(x - p1) >= w"]
reset = { S1 = "0" }
[[transitions]]
name = "s2_on"
source = "move"
target = "move"
guard = ["S2 <= 0.5", "abs(x - p2) <= w"]
reset = { S2 = "1" }
[[transitions]]
name = "s2_off"
source = "move"
target = "move"
guard = ["S2 >= 0.5", "abs(x - p2) >= w"]
reset = { S2 = "0" }
[initial]
mode = "move"
[scenarios.drop]
t_end = 12.0
"""


def test_nelder_mead_option_of_fit_events_recovers_a_parameter(tmp_path) -> None:
    from hybridlab.identify import fit_events
    from hybridlab.identify.synthetic import sensor_events

    path = tmp_path / "sensed.toml"
    path.write_text(SENSED)
    model = hybridlab.compile_model(hybridlab.load_model(path))
    sensors = {"1": ("s1_on", "s1_off"), "2": ("s2_on", "s2_off")}
    events = sensor_events(model, sensors=sensors, scenario="drop", rng=3, jitter=1e-5)
    fit = fit_events(model, events, fit=["c"], sensors=sensors, scenario="drop",
                     initial_guess={"c": 0.13}, method="nelder-mead", max_evaluations=25,
                     max_pair_gap=0.1)
    assert fit.parameters["c"] == pytest.approx(0.1, rel=0.02)
    assert math.isnan(fit.uncertainties["c"])  # no Jacobian with nelder-mead
    assert fit.n_evaluations <= 25
    assert len(fit.simulated) == len(fit.measured) >= 10


def test_trolley_drive_gain_from_the_table_iv_step(trolley) -> None:
    targets = [
        Target("overshoot", 5.9, 0.3, observable="x", final="x_s", scenario="step"),
        Target("settling_time", 0.067, 0.003, observable="x", final="x_s", scenario="step"),
    ]
    fit = fit_targets(trolley, targets, fit=["K_u"], initial_guess={"K_u": 3.0},
                      max_evaluations=15)
    assert fit.parameters["K_u"] == pytest.approx(7.4, rel=0.02)
    assert 0.05 < fit.uncertainties["K_u"] < 0.5
    assert fit.simulated[0] == pytest.approx(5.9, abs=0.1)
    assert fit.simulated_initial[0] > 15  # K_u = 3 overshoots by about 20 %


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"kind": "mean"}, "kind: must be one of"),
        ({"tolerance": -1.0}, "tolerance: must be a positive"),
        ({"value": float("nan")}, "value: must be a finite"),
        ({"observable": None}, "exactly one of observable and transition"),
        ({"transition": "bounce"}, "exactly one of observable and transition"),
        ({"direction": 2}, "direction: must be -1, 0 or 1"),
        ({"kind": "value"}, "at: a 'value' target needs"),
        ({"kind": "overshoot"}, "final: a 'overshoot' target needs"),
        ({"params": {"c": "x"}}, "params: must map names to numbers"),
    ],
)
def test_bad_targets_get_one_line_errors(kwargs, match) -> None:
    settings = {"kind": "count", "value": 4, "tolerance": 1.0, "observable": "x", **kwargs}
    with pytest.raises(TargetError, match=match) as info:
        Target(**settings)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"fit": ["nope"]}, "no parameter 'nope'"),
        ({"targets": [Target("count", 4, 1.0, observable="x", scenario="nope")]},
         "unknown scenario 'nope'"),
        ({"targets": [Target("count", 4, 1.0, transition="nope", t_end=1.0)]},
         "no transition 'nope'"),
        ({"method": "magic"}, "method must be"),
        ({"bounds": {"c": (1.0, 2.0)}}, r"bounds\['c'\]"),
        ({"initial_guess": {"k": 1.0}}, "not a fitted parameter"),
    ],
)
def test_fit_targets_user_errors(oscillator, kwargs, match) -> None:
    settings = {"targets": [Target("count", 4, 1.0, observable="x", t_end=5.0)], "fit": ["c"],
                **kwargs}
    with pytest.raises(ValueError, match=match):
        fit_targets(oscillator, **settings)


def test_read_targets_toml_and_json(tmp_path) -> None:
    toml = tmp_path / "t.toml"
    toml.write_text('[[targets]]\nkind = "count"\nobservable = "x"\nvalue = 4\ntolerance = 1\n'
                    'params = { c = 0.45 }\n')
    (target,) = read_targets(toml)
    assert target.params == {"c": 0.45}
    js = tmp_path / "t.json"
    js.write_text(json.dumps({"targets": [target.as_dict()]}))
    assert read_targets(js) == (target,)
    toml.write_text('[[targets]]\nkind = "count"\nobservable = "x"\nvalue = 4\ntolerance = 1\n'
                    'colour = 3\n')
    with pytest.raises(TargetError, match=r"t.toml: targets\[0\]: unknown key 'colour'"):
        read_targets(toml)
    toml.write_text('[[targets]]\nkind = "count"\nobservable = "x"\nvalue = 4\ntolerance = 0\n')
    with pytest.raises(TargetError, match=r"targets\[0\].tolerance: must be a positive"):
        read_targets(toml)
    toml.write_text("targets = 3\n")
    with pytest.raises(TargetError, match="non-empty list 'targets'"):
        read_targets(toml)


def test_cli_targets_end_to_end(tmp_path, capsys) -> None:
    path = tmp_path / "targets.toml"
    path.write_text('[[targets]]\nkind = "count"\nobservable = "x"\nvalue = 5\n'
                    'tolerance = 0.1\nt_end = 20\n')
    parser = argparse.ArgumentParser()
    add_identify_parser(parser.add_subparsers(dest="command"))
    out = tmp_path / "fit.json"
    args = parser.parse_args(["identify", "targets", str(OSCILLATOR), str(path), "--fit", "c",
                              "--initial", "c=0.3", "--max-evaluations", "12",
                              "--out", str(out)])
    assert args.run(args) == 0
    assert "residual/sigma" in capsys.readouterr().out
    payload = json.loads(out.read_text())
    assert 1 / 3 <= payload["parameters"]["c"] < 0.4
    assert payload["targets"][0]["simulated"] == 5


@pytest.mark.parametrize(("target", "message"), [
    (dict(observable="hh", t_end=5.0), r"targets\[0\]\.observable: unknown symbol \(token 'hh'\)"),
    (dict(observable="h", t_end=5.0, dt=1e-9), r"targets\[0\]\.dt: .* needs 5e\+09 samples"),
    (dict(observable="h + sqrt(", t_end=5.0), r"targets\[0\]\.observable: syntax error"),
])
def test_targets_that_cannot_be_measured_fail_before_any_simulation(target, message):
    from hybridlab.identify import Target, fit_targets

    with pytest.raises(ValueError, match=message):
        fit_targets("models/bouncing_ball.toml", [Target("count", 3, 1.0, **target)], fit=["e"])


def test_a_target_horizon_must_be_finite():
    from hybridlab.identify import Target
    from hybridlab.identify.errors import TargetError

    with pytest.raises(TargetError, match="t_end: must be a positive finite number"):
        Target("count", 3, 1.0, observable="h", t_end=float("inf"))
