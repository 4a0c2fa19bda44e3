"""Discrete variables: declared in ``[discrete]``, changed only by resets, never integrated."""

from __future__ import annotations

import numpy as np
import pytest

import hybridlab
from hybridlab.cli.check import summary
from hybridlab.errors import ModelError, SimulationError
from hybridlab.graph import check_mode_graph
from hybridlab.model.loader import dumps_model, loads_model
from hybridlab.simulation.problem import ProblemError

#: A clock that arms a trigger; each firing toggles the flag, counts and latches the clock.
LATCH = """
name = "latch"
states = { x = 0.0 }
discrete = { armed = false, count = 0, level = { value = 0, type = "real" } }
modes.wait = { flow = { x = "1" } }
modes.fire = { flow = { x = "1" } }
initial = { mode = "wait" }
[[transitions]]
name = "go"
source = "wait"
target = "fire"
guard = "x >= 1 and armed"
reset = { armed = "1 - armed", count = "count + 1", level = "x" }
[[transitions]]
name = "back"
source = "fire"
target = "wait"
guard = "not armed"
[[transitions]]
name = "arm"
source = "wait"
target = "wait"
guard = "x >= 2"
reset = { armed = true, x = "0" }
"""


def latch(**replace: str) -> str:
    text = LATCH
    for old, new in replace.items():
        text = text.replace(old, new)
    return text


@pytest.fixture(scope="module")
def model() -> hybridlab.Model:
    return loads_model(LATCH)


@pytest.mark.parametrize("backend", ["reference", "compiled"])
def test_discrete_variables_change_only_at_jumps(model: hybridlab.Model, backend: str) -> None:
    result = hybridlab.simulate(model, t_end=7.5, backend=backend)
    # arm at 2, 4, 6 (x back to 0); go and back at 3, 5, 7 (x = 1, armed toggled off)
    assert [e.transition for e in result.events] == ["arm", "go", "back"] * 3
    assert result.final.state == pytest.approx({"x": 1.5, "armed": 0.0, "count": 3.0,
                                                "level": 1.0})
    count = result(np.array([2.5, 3.5, 5.5]))[result.state_names.index("count")]
    assert count.tolist() == [0.0, 1.0, 2.0]
    assert result.state("count")[-1] == 3.0


def test_a_model_with_discrete_variables_round_trips_and_summarises() -> None:
    model = loads_model(LATCH)
    assert model.state_names == ("x", "armed", "count", "level")
    assert {n: d.type for n, d in model.discrete.items()} == {
        "armed": "bool", "count": "int", "level": "real"}
    assert loads_model(dumps_model(model)) == model
    lines = summary(model).splitlines()
    assert "  states: 1 continuous, 3 discrete" in lines
    assert "    discrete: armed (bool), count (int), level (real)" in lines


@pytest.mark.parametrize(("edit", "message"), [
    ({'modes.fire = { flow = { x = "1" } }': 'modes.fire = { flow = { x = "1", count = "1" } }'},
     "modes.fire.flow.count: a discrete variable has no flow: it changes only in resets "
     "(token 'count')"),
    ({"states = { x = 0.0 }": "states = { x = 0.0, count = 1.0 }"},
     "discrete.count: name already declared in [states] (token 'count')"),
    ({'count = 0': 'count = { value = 0.5, type = "int" }'},
     "discrete.count.value: an int variable takes whole numbers (got 0.5) (token '0.5')"),
    ({'reset = { armed = true, x = "0" }': 'reset = { armed = "2", x = "0" }'},
     "transitions[2].reset.armed: a bool variable takes 0 or 1, false or true (got 2.0) "
     "(token '2')"),
    ({'count = "count + 1"': 'count = "count + 0.5"'},
     "transitions[0].reset.count: this reset never gives a whole number, as the int variable "
     "needs (token 'count + 0.5')"),
])
def test_bad_discrete_input_is_one_line(edit: dict[str, str], message: str) -> None:
    with pytest.raises(ModelError) as info:
        loads_model(latch(**edit), source="latch.toml")
    assert str(info.value) == f"latch.toml: {message}"


def test_values_given_at_call_time_are_checked(model: hybridlab.Model) -> None:
    run = hybridlab.simulate(model, t_end=1.5, initial={"armed": True, "count": 5},
                             backend="reference")
    assert run.final.state["count"] == 6.0
    with pytest.raises(ProblemError, match="state 'count': an int variable takes whole"):
        hybridlab.simulate(model, t_end=1.0, initial={"count": 0.5}, backend="reference")
    with pytest.raises(ProblemError, match="a discrete variable takes one value"):
        hybridlab.simulate(model, t_end=1.0, initial={"count": (0, 2)}, backend="reference")
    halving = loads_model(latch(**{'count = "count + 1"': 'count = "count/2 + 1"'}))
    with pytest.raises(SimulationError, match=r"^transition 'go' at t = 3 set 'count': an int"):
        hybridlab.simulate(halving, t_end=4.0, initial={"count": 1}, backend="reference")


def test_graph_check_takes_booleans_as_zero_or_one() -> None:
    # as a real, armed = 1/2 would let go -> back fire round at one instant forever
    as_states = latch(**{"discrete = { armed = false,": "discrete = {",
                         "states = { x = 0.0 }":
                         'states = { x = 0.0, armed = { initial = 0.0, flow = "0" } }',
                         "x >= 1 and armed": "x >= 1 and armed > 0.5",
                         '"not armed"': '"armed < 0.5"',
                         "armed = true": 'armed = "1"'})
    kinds = [f.kind for f in check_mode_graph(loads_model(as_states)).findings]
    assert kinds == ["zero-dwell-cycle"]
    report = check_mode_graph(loads_model(LATCH))
    assert report.findings == () and report.cycles[0].verdict == "impossible"


NETWORK = """
name = "counters"
[templates.counter]
states = { x = 0.0 }
discrete = { count = 0 }
modes.run = { flow = { x = "1" } }
initial = { mode = "run" }
[[templates.counter.transitions]]
name = "tick"
source = "run"
target = "run"
guard = "x >= 1"
reset = { x = "0", count = "count + 1" }
[instances.a]
template = "counter"
[instances.b]
template = "counter"
initial = { count = 10 }
"""


def test_templates_declare_discrete_variables_and_instances_start_them() -> None:
    text = NETWORK
    model = loads_model(text)
    assert model.discrete_names == ("a.count", "b.count")
    result = hybridlab.simulate(model, t_end=2.5, backend="reference")
    assert result.final.state["a.count"] == 2.0 and result.final.state["b.count"] == 12.0
    with pytest.raises(ModelError) as info:
        loads_model(text.replace("count = 10", "count = 1.5"), source="net.toml")
    assert str(info.value) == ("net.toml: instances.b.initial.count: an int variable takes "
                               "whole numbers (got 1.5) (instance 'b' of template 'counter') "
                               "(token '1.5')")
