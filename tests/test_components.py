"""Models built from components: the product, its names, its events, flatten, bad input."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from strategies import ROOT

import hybridlab
from hybridlab import ModelError, load_model, loads_model
from hybridlab.cli import main
from hybridlab.reachability.spec import parse_spec
from hybridlab.simulation.problem import HybridProblem, ProblemError

MODELS = ROOT / "models"


def _events(model: hybridlab.Model | Path, t_end: float) -> list[tuple[float, str, str, str]]:
    result = hybridlab.simulate(model, t_end=t_end, backend="reference")
    assert result.status.name == "COMPLETED"
    return [(e.t, e.transition, e.source, e.target) for e in result.jumps]


def _same_events(a: list[tuple[float, str, str, str]],
                 b: list[tuple[float, str, str, str]]) -> None:
    assert len(a) == len(b) and a
    for x, y in zip(a, b, strict=True):
        assert abs(x[0] - y[0]) <= 1e-10 and x[1:] == y[1:]


@pytest.fixture(scope="module")
def rooms() -> hybridlab.Model:
    return load_model(MODELS / "two_rooms.toml")


@pytest.fixture(scope="module")
def room_events(rooms: hybridlab.Model) -> list[tuple[float, str, str, str]]:
    return _events(rooms, 100.0)


# ----------------------------------------------------------------------------------------
# the product


def test_two_rooms_product_names_and_synchronised_events(
        rooms: hybridlab.Model, room_events: list[tuple[float, str, str, str]]) -> None:
    assert rooms.state_names == ("room1.T", "room2.T", "heater.on_time")
    assert rooms.parameters["room2.a"].value == 0.07 and rooms.parameters["room1.a"].value == 0.05
    # only the modes the heater's rule lets the rooms enter: it heats one room at a time
    assert list(rooms.modes) == ["room1.off|room2.off|heater.idle",
                                 "room1.off|room2.on|heater.heat2",
                                 "room1.on|room2.off|heater.heat1"]
    # the connection: room 1 exchanges heat with room 2's temperature
    assert "room2.T" in rooms.modes["room1.off|room2.off|heater.idle"].flow["room1.T"]
    # each synchronised transition is one event naming the components' transitions
    t, name, source, target = room_events[0]
    assert (t, name) == (0.0, "start2(room2.turn_on, heater.grant2)")
    assert (source, target) == ("room1.off|room2.off|heater.idle",
                                "room1.off|room2.on|heater.heat2")
    assert {e[1] for e in room_events} == {tr.name for tr in rooms.transitions}


def test_hand_written_product_has_the_same_events(
        room_events: list[tuple[float, str, str, str]]) -> None:
    _same_events(room_events, _events(load_model(MODELS / "two_rooms_flat.toml"), 100.0))


def test_flatten_writes_a_model_with_the_same_events(
        tmp_path: Path, room_events: list[tuple[float, str, str, str]],
        capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "flat.toml"
    assert main(["flatten", str(MODELS / "two_rooms.toml"), "-o", str(out)]) == 0
    assert "3 modes, 4 transitions" in capsys.readouterr().out
    flat = load_model(out)
    assert flat.network is None and "[instances" not in out.read_text(encoding="utf-8")
    _same_events(room_events, _events(flat, 100.0))


def test_platoon_imports_its_vehicles_and_reads_the_car_ahead() -> None:
    platoon = load_model(MODELS / "platoon.toml")
    assert [c.template for c in platoon.network.components] == ["leader", "follower",
                                                                "follower"]
    assert platoon.network.components[1].source.endswith("components/vehicles.toml")
    assert platoon.definitions["car2.gap"] == "car1.x - car2.x - car2.L"
    result = hybridlab.simulate(platoon, t_end=30.0, backend="reference")
    assert [e.transition for e in result.jumps] == [
        "lead.slow_down", "car2.emergency", "car2.recover", "lead.speed_up"]
    assert result.jumps[1].target == "lead.slow|car1.follow|car2.brake"
    gap = result.state("car1.x") - result.state("car2.x") - 4.5
    assert gap.min() > 9.0


def test_platoon_and_its_hand_written_product_have_the_same_events() -> None:
    _same_events(_events(load_model(MODELS / "platoon.toml"), 60.0),
                 _events(load_model(MODELS / "platoon_flat.toml"), 60.0))


# ----------------------------------------------------------------------------------------
# names: qualified, and unqualified where unique


def test_unique_names_may_be_written_unqualified(
        rooms: hybridlab.Model, capsys: pytest.CaptureFixture[str]) -> None:
    assert rooms.symbolic.aliases == {"on_time": "heater.on_time"}
    problem = HybridProblem.build(rooms, t_end=1.0, initial={"on_time": 5.0},
                                            params={"room1.b": 2.0})
    assert problem.initial["heater.on_time"] == 5.0 and problem.parameters["room1.b"] == 2.0
    assert list(parse_spec("room1.on: room1.T <= 23", rooms).rows) == [
        "room1.on|room2.off|heater.heat1"]
    assert parse_spec("on_time <= 100", rooms).rows
    with pytest.raises(ValueError, match="several components have this name; write one of: "
                                         "room1.T, room2.T"):
        parse_spec("T <= 30", rooms)
    assert main(["simulate", str(MODELS / "two_rooms.toml"), "--t-end", "1",
                 "--init", "on_time=3", "--set", "room2.a=0.06", "--backend", "reference"]) == 0
    assert "heater.on_time=4" in capsys.readouterr().out  # from 3, heating for 1 minute
    with pytest.raises(ProblemError, match="'a' is the parameter of several components; write "
                                           "one of: room1.a, room2.a"):
        HybridProblem.build(rooms, t_end=1.0, params={"a": 0.1})
    # a product mode named by the components' modes that identify it
    assert HybridProblem.build(rooms, t_end=1.0, mode="room1.on").mode == (
        "room1.on|room2.off|heater.heat1")


def test_a_components_unique_mode_may_be_written_without_its_instance(
        rooms: hybridlab.Model) -> None:
    # heat1 is the heater's only: it stands for heater.heat1; on is both rooms'
    assert list(parse_spec("heat1: room1.T <= 23", rooms).rows) == [
        "room1.on|room2.off|heater.heat1"]
    assert HybridProblem.build(rooms, t_end=1.0, mode="heat2").mode == (
        "room1.off|room2.on|heater.heat2")
    with pytest.raises(ValueError, match="unknown mode"):
        parse_spec("on: room1.T <= 23", rooms)


SHARED = """
name = "pair"
qualify = "shared"

[templates.lag]
parameters = { k = 1.0 }
inputs = ["u"]
states = { y = 0.0 }
modes.run.flow = { y = "k*(u - y)" }
initial.mode = "run"

[templates.source]
parameters = { level = 2.0 }
states = { s = 0.0 }
definitions = { out = "level + s" }
modes.low.flow = { s = "0" }
modes.high.flow = { s = "0" }
initial.mode = "low"

[[templates.source.transitions]]
name = "raise"
source = "low"
target = "high"
guard = "t >= 1"
reset = { s = "1" }

[instances.a]
template = "lag"
connect = { u = "src.out" }

[instances.b]
template = "lag"
connect = { u = "a.y" }

[instances.src]
template = "source"
"""


def test_shared_qualification_keeps_the_names_one_instance_declares() -> None:
    model = loads_model(SHARED)
    # y and k are declared by both lags; s, level, out and raise by the source only
    assert model.state_names == ("a.y", "b.y", "s")
    assert model.parameter_names == ("a.k", "b.k", "level")
    assert model.modes["a.run|b.run|src.low"].flow["a.y"] == "a.k*(out - a.y)"
    assert [tr.name for tr in model.transitions] == ["raise"]
    result = hybridlab.simulate(model, t_end=2.0, backend="reference")
    assert [(e.t, e.transition, e.target) for e in result.jumps] == [
        (1.0, "raise", "a.run|b.run|src.high")]
    assert loads_model(SHARED.replace('qualify = "shared"', "")).state_names == (
        "a.y", "b.y", "src.s")


def test_check_shows_the_network(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["check", str(MODELS / "two_rooms.toml")]) == 0
    out = capsys.readouterr().out
    assert "room1: template 'room'" in out
    assert "room1.T_other <- room2.T" in out
    assert "start1: room1.turn_on, heater.grant1" in out


# ----------------------------------------------------------------------------------------
# bad input: one line naming the file, the template, the instance and the key

TANK = """
name = "tanks"

[templates.tank]
parameters = { k = 0.5, q = 1.0 }
inputs = ["inflow"]
states = { h = 1.0 }
definitions = { outflow = "k*h", supply = "q + 0.1*inflow" }
modes.fill.flow = { h = "inflow - outflow" }
modes.drain.flow = { h = "-outflow" }
initial.mode = "fill"

[[templates.tank.transitions]]
name = "full"
source = "fill"
target = "drain"
guard = "h >= 2"
label = "swap"

[[templates.tank.transitions]]
name = "empty"
source = "drain"
target = "fill"
guard = "h <= 1"

[instances.a]
template = "tank"
connect = { inflow = "b.outflow" }

[instances.b]
template = "tank"
connect = { inflow = "a.q" }
"""


def _error(text: str) -> str:
    with pytest.raises(ModelError) as info:
        loads_model(text, source="tanks.toml")
    message = str(info.value)
    assert "\n" not in message
    return message


def test_the_tank_network_loads() -> None:
    tanks = loads_model(TANK)
    assert [tr.name for tr in tanks.transitions] == ["swap(a.full, b.full)", "a.empty",
                                                     "b.empty"]


@pytest.mark.parametrize(("change", "message"), [
    (('"b.outflow"', '"b.volume"'),
     "tanks.toml: instances.a.connect.inflow: connection to a missing variable: template "
     "'tank' of 'b' has no state, parameter or definition 'volume' (instance 'a' of template "
     "'tank') (token 'b.volume')"),
    (('"a.q"', '"c.q"'),
     "tanks.toml: instances.b.connect.inflow: connection to a missing instance (instance 'b' "
     "of template 'tank') (token 'c.q')"),
    (('connect = { inflow = "b.outflow" }',
      'connect = { inflow = "b.outflow" }\nlabels = { swap = "a_swap" }'),
     "tanks.toml: instances.a.labels.swap: label 'a_swap' of template 'tank' is used by "
     "instance 'a' only; a label synchronises transitions of two or more instances "
     "(token 'a_swap')"),
    ((('"a.q"', '"a.supply"'), ('"b.outflow"', '"b.supply"')),
     "tanks.toml: instances.b.connect.inflow: connections form an instantaneous cycle of "
     "definitions (instance 'b' of template 'tank') (token 'a.supply -> b.supply -> "
     "a.supply')"),
    (('template = "tank"\nconnect = { inflow = "a.q" }', 'template = "tnak"'),
     "tanks.toml: instances.b.template: instance of an unknown template; the templates are: "
     "tank (token 'tnak')"),
    (('connect = { inflow = "b.outflow" }', 'connect = { inflow = "b.outflow" }\n'
                                             'parameters = { kk = 1.0 }'),
     "tanks.toml: instances.a.parameters.kk: template 'tank' declares no parameter of this "
     "name (token 'kk')"),
    (('connect = { inflow = "b.outflow" }', ''),
     "tanks.toml: instances.a.connect: input 'inflow' of template 'tank' is not connected "
     "(token 'inflow')"),
    (('"inflow - outflow"', '"inflow - outflw"'),
     "tanks.toml: templates.tank.modes.fill.flow.h: unknown symbol (token 'outflw')"),
])
def test_bad_networks_are_one_line_errors(change: tuple[Any, ...], message: str) -> None:
    text = TANK
    for old, new in change if isinstance(change[0], tuple) else [change]:
        assert old in text
        text = text.replace(old, new, 1)
    assert _error(text) == message


def test_imports_are_relative_and_a_cycle_is_an_error(tmp_path: Path) -> None:
    lib = tmp_path / "lib"
    lib.mkdir()
    template = TANK[TANK.index("[templates.tank]"):TANK.index("[instances.a]")]
    (lib / "tank.toml").write_text('name = "lib"\n' + template.replace(
        'label = "swap"\n', ''), encoding="utf-8")
    (tmp_path / "net.toml").write_text(
        'name = "net"\nimports = ["lib/tank.toml"]\n[instances.a]\ntemplate = "tank"\n'
        'connect = { inflow = "a.q" }\n', encoding="utf-8")
    net = load_model(tmp_path / "net.toml")
    assert net.network.components[0].source.endswith("lib/tank.toml")
    (lib / "a.toml").write_text('name = "a"\nimports = ["b.toml"]\n', encoding="utf-8")
    (lib / "b.toml").write_text('name = "b"\nimports = ["a.toml"]\n', encoding="utf-8")
    (tmp_path / "cycle.toml").write_text(
        'name = "c"\nimports = ["lib/a.toml"]\n[instances.a]\ntemplate = "tank"\n',
        encoding="utf-8")
    with pytest.raises(ModelError) as info:
        load_model(tmp_path / "cycle.toml")
    lib_a, lib_b = str(tmp_path / "lib" / "a.toml"), str(tmp_path / "lib" / "b.toml")
    assert str(info.value) == (f"{lib_b}: imports[0]: import cycle (token "
                               f"'{lib_a} -> {lib_b} -> {lib_a}')")


def test_a_flat_mode_may_hold_the_separator_in_its_name():
    """A flat model's mode named like a product (``a|b``) is its own target, not parts."""
    model = hybridlab.loads_model('''
name = "flat"
states = { x = 1.0 }
[modes."a|b"]
flow = { x = "-x" }
[[transitions]]
name = "again"
source = "a|b"
target = "a|b"
guard = "x <= 0.5"
reset = { x = "1" }
[initial]
mode = "a|b"
''')
    compiled = hybridlab.compile_model(model)
    assert [(tr.source, tr.target) for tr in compiled.transitions] == [("a|b", "a|b")]
