"""Parameters from sensor edges: passages, recovery of the bearing friction, bad data, CLI.

The recovery test fits two parameters over a 20 s free drop (the full run lasts about
42 s) with a budget of 12 simulations (about 25 s), loosened integrator tolerances and
a start 50 % off the truth.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pytest

import hybridlab
from hybridlab.cli.identify import add_parser as add_identify_parser
from hybridlab.identify import DataError, SensorEvents, fit_events, passages, write_csv
from hybridlab.identify.synthetic import sensor_events

MODEL = Path(__file__).resolve().parents[1] / "models" / "trolley.toml"
SENSORS = {"1": ("s1_on", "s1_off"), "2": ("s2_on", "s2_off")}
TRUTH = {"a_b": 0.020, "b_b": 0.0034}
FAST = {"rtol": 1e-6, "atol": 1e-8, "samples_per_step": 4}


@pytest.fixture(scope="module")
def compiled() -> hybridlab.CompiledModel:
    return hybridlab.compile_model(hybridlab.load_model(MODEL))


def test_passages_pair_same_kind_edges_of_the_two_sensors() -> None:
    ev = SensorEvents(["2", "1", "2", "1", "1", "1", "2"],
                      [0.100, 0.104, 0.120, 0.125, 0.5, 0.9, 0.902],
                      ["rising", "rising", "falling", "falling", "falling", "rising", "rising"])
    p = passages(ev, ("1", "2"), max_pair_gap=0.2)
    assert p.rate == pytest.approx([250.0, 200.0, 500.0])
    assert p.direction.tolist() == [-1, -1, 1]
    assert p.t == pytest.approx([0.102, 0.1225, 0.901])


def test_recovers_bearing_friction_within_10_percent(compiled) -> None:
    events = sensor_events(compiled, sensors=SENSORS, scenario="free_drop", params=TRUTH,
                           t_end=20.0, latency=1 / 1650, jitter=2e-5, quantum=5e-5, rng=0)
    assert len(events) > 100
    fit = fit_events(compiled, events, fit=["a_b", "b_b"], sensors=SENSORS,
                     scenario="free_drop", t_end=20.0, initial_guess={"a_b": 0.03, "b_b": 0.005},
                     sensor_distance="d_s", max_evaluations=12, simulation_options=FAST)
    errors = {n: fit.parameters[n] / TRUTH[n] - 1 for n in TRUTH}
    assert all(abs(e) < 0.10 for e in errors.values()), errors
    assert fit.n_evaluations <= 12
    assert len(fit.simulated) == len(fit.measured)
    assert all(np.isfinite(v) and v > 0 for v in fit.uncertainties.values())
    # the constant latency shows up as the time offset, not as a parameter error
    assert abs(fit.time_offset - 1 / 1650) < 2e-3
    assert "a_b" in fit.table()
    assert set(fit.as_dict()["parameters"]) == {"a_b", "b_b"}


def test_no_events(compiled) -> None:
    with pytest.raises(DataError, match="no events"):
        fit_events(compiled, SensorEvents((), [], ()), fit=["a_b"], sensors=SENSORS,
                   scenario="free_drop")


def test_too_few_passages(compiled) -> None:
    ev = SensorEvents(["1", "1"], [0.1, 0.2], ["rising", "falling"])
    with pytest.raises(DataError, match="0 two-sensor passage"):
        fit_events(compiled, ev, fit=["a_b"], sensors=SENSORS, scenario="free_drop")


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"fit": ["nope"]}, ValueError, "no parameter 'nope'"),
        ({"sensors": {"1": ("s1_on", "s1_off"), "2": ("s2_on", "missing")}}, ValueError,
         "no transition 'missing'"),
        ({"sensors": {"1": ("s1_on", "s1_off"), "3": ("s2_on", "s2_off")}}, DataError,
         "column 'sensor'.*'2'"),
        ({"method": "magic"}, ValueError, "method must be"),
        ({"t_end": 0.2}, DataError, "edges after t_end"),
        ({"scenario": "nope"}, ValueError, "unknown scenario"),
    ],
)
def test_user_errors(compiled, kwargs, error, match) -> None:
    ev = SensorEvents(["2", "1", "2", "1"] * 2, [0.28, 0.29, 0.30, 0.31, 0.87, 0.875, 0.89, 0.895],
                      ["rising", "rising", "falling", "falling"] * 2)
    settings = {"fit": ["a_b"], "sensors": SENSORS, "scenario": "free_drop", **kwargs}
    with pytest.raises(error, match=match):
        fit_events(compiled, ev, **settings)


def test_edge_column_is_validated(tmp_path) -> None:
    from hybridlab.identify import read_events_csv

    path = tmp_path / "ev.csv"
    path.write_text("sensor,t,edge\n1,0.1,up\n")
    with pytest.raises(DataError, match="column 'edge'.*'up'"):
        read_events_csv(path)


def test_cli_events_end_to_end(compiled, tmp_path, capsys) -> None:
    events = sensor_events(compiled, sensors=SENSORS, scenario="free_drop", t_end=4.0, rng=1)
    path = tmp_path / "edges.csv"
    write_csv(path, {"sensor": events.sensor, "t": events.t.tolist(), "edge": events.edge})
    parser = argparse.ArgumentParser()
    add_identify_parser(parser.add_subparsers(dest="command"))
    out = tmp_path / "fit.json"
    args = parser.parse_args([
        "identify", "events", str(MODEL), str(path), "--scenario", "free_drop",
        "--fit", "a_b", "--sensor", "1=s1_on,s1_off", "--sensor", "2=s2_on,s2_off",
        "--t-end", "4", "--initial", "a_b=0.025", "--max-evaluations", "5",
        "--sensor-distance", "d_s", "--out", str(out)])
    assert args.run(args) == 0
    assert "a_b" in capsys.readouterr().out
    payload = json.loads(out.read_text())
    assert list(payload["parameters"]) == ["a_b"]
    assert payload["parameters"]["a_b"] == pytest.approx(0.020, rel=0.15)
    bad = parser.parse_args(["identify", "events", str(MODEL), str(path), "--scenario",
                             "free_drop", "--fit", "a_b", "--sensor", "1=s1_on"])
    with pytest.raises(ValueError, match="--sensor"):
        bad.run(bad)
