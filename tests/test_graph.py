"""The mode graph (networkx) and its DOT export."""

from __future__ import annotations

from pathlib import Path

import networkx as nx
import pytest
from strategies import MODEL_FILES

import hybridlab
from hybridlab import loads_model, mode_graph, to_dot

ROOT = Path(__file__).resolve().parents[1]

TWO_ROOMS = """\
name = "two rooms"

[parameters]
k = 0.5

[states]
x = 1.0
c = 0.0

[modes.left]
flow = { x = "-k*x", c = "1" }
invariant = "x >= -1"

[modes.right]
flow = { x = "k", c = "1" }

[modes.idle]
flow = { x = "0", c = "0" }

[[transitions]]
name = "go"
source = "left"
target = "right"
guard = ["x <= 0.5", "c >= 1"]
reset = { c = "0" }
priority = 2

[[transitions]]
name = "jump"
source = "left"
target = "right"
guard = "x <= 0.1"

[[transitions]]
name = "back"
source = "right"
target = "left"
guard = "x >= 2"
reset = { x = "1", c = "0" }

[[transitions]]
name = "tick"
source = "right"
target = "right"
schedule = { period = 0.25, phase = 0.5 }

[initial]
mode = "left"
"""


@pytest.fixture(scope="module")
def rooms() -> hybridlab.Model:
    return loads_model(TWO_ROOMS)


def test_graph_is_a_multidigraph(rooms: hybridlab.Model) -> None:
    graph = mode_graph(rooms)
    assert isinstance(graph, nx.MultiDiGraph)
    assert isinstance(graph, nx.DiGraph)
    assert graph.graph["name"] == "two rooms"


def test_one_node_per_mode_with_attributes(rooms: hybridlab.Model) -> None:
    graph = mode_graph(rooms)
    assert list(graph.nodes) == ["left", "right", "idle"]
    assert dict(graph.nodes(data=True)) == {
        "left": {"flow": {"x": "-k*x", "c": "1"}, "invariant": ["x >= -1"], "initial": True},
        "right": {"flow": {"x": "k", "c": "1"}, "invariant": [], "initial": False},
        "idle": {"flow": {"x": "0", "c": "0"}, "invariant": [], "initial": False},
    }
    assert graph.degree("idle") == 0


def test_one_edge_per_transition_keyed_by_name(rooms: hybridlab.Model) -> None:
    graph = mode_graph(rooms)
    assert sorted(graph.edges(keys=True)) == [
        ("left", "right", "go"), ("left", "right", "jump"), ("right", "left", "back"),
        ("right", "right", "tick")]
    assert graph.number_of_edges("left", "right") == 2  # parallel edges kept apart


def test_edge_attributes(rooms: hybridlab.Model) -> None:
    graph = mode_graph(rooms)
    assert graph.edges["left", "right", "go"] == {
        "name": "go", "guard": "x <= 0.5 and c >= 1", "reset": {"c": "0"}, "priority": 2,
        "schedule": ""}
    assert graph.edges["left", "right", "jump"] == {
        "name": "jump", "guard": "x <= 0.1", "reset": {}, "priority": None, "schedule": ""}
    assert graph.edges["right", "left", "back"] == {
        "name": "back", "guard": "x >= 2", "reset": {"x": "1", "c": "0"}, "priority": None,
        "schedule": ""}
    tick = graph.edges["right", "right", "tick"]
    assert (tick["guard"], tick["reset"], tick["priority"]) == ("", {}, None)
    assert tick["schedule"] == "every 0.25 from 0.5"


def test_thermostat_graph() -> None:
    graph = mode_graph(hybridlab.load_model(ROOT / "models" / "thermostat.toml"))
    assert sorted(graph.edges(keys=True)) == [("cool", "heat", "turn_on"),
                                              ("heat", "cool", "turn_off")]
    assert graph.edges["heat", "cool", "turn_off"] == {
        "name": "turn_off", "guard": "T >= T_high", "reset": {}, "priority": None,
        "schedule": ""}


def test_bouncing_ball_graph() -> None:
    graph = mode_graph(hybridlab.load_model(ROOT / "models" / "bouncing_ball.toml"))
    assert list(graph.edges(keys=True, data=True)) == [
        ("fall", "fall", "bounce", {"name": "bounce", "guard": "h <= 0",
                                    "reset": {"v": "-e*v"}, "priority": 1, "schedule": ""})]


@pytest.mark.parametrize("path", MODEL_FILES, ids=[p.name for p in MODEL_FILES])
def test_bundled_models_graph_and_dot(path: Path) -> None:
    model = hybridlab.load_model(path)
    graph = mode_graph(model)
    assert list(graph.nodes) == list(model.modes)
    # a transition declared with several sources is one edge per source mode
    assert graph.number_of_edges() == len(model.symbolic.transitions)
    assert {key for _, _, key in graph.edges(keys=True)} == {tr.name for tr in model.transitions}
    assert [n for n, initial in graph.nodes(data="initial") if initial] == [model.initial.mode]
    dot = to_dot(model)
    for mode in model.modes:
        assert f'  "{mode}" [shape=' in dot
    for tr in model.transitions:
        assert f'[label="{tr.name}' in dot


def test_dot_of_two_rooms_exactly(rooms: hybridlab.Model) -> None:
    assert to_dot(rooms) == (
        'digraph "two rooms" {\n'
        "  rankdir=LR;\n"
        '  "left" [shape=doublecircle, label="left\\nx\' = -k*x\\nc\' = 1"];\n'
        '  "right" [shape=ellipse, label="right\\nx\' = k\\nc\' = 1"];\n'
        '  "idle" [shape=ellipse, label="idle\\nx\' = 0\\nc\' = 0"];\n'
        '  "left" -> "right" [label="go [x <= 0.5 and c >= 1] c := 0"];\n'
        '  "left" -> "right" [label="jump [x <= 0.1]"];\n'
        '  "right" -> "left" [label="back [x >= 2] x := 1 c := 0"];\n'
        '  "right" -> "right" [label="tick (every 0.25 from 0.5)"];\n'
        "}\n"
    )


def test_dot_quotes_awkward_names() -> None:
    text = TWO_ROOMS.replace('"left"', '"le\\"ft\\\\"').replace("[modes.left]",
                                                                '[modes."le\\"ft\\\\"]')
    text = text.replace('name = "two rooms"', 'name = "two \\"rooms\\""')
    dot = to_dot(loads_model(text))
    assert dot.startswith('digraph "two \\"rooms\\"" {\n')
    node = '  "le\\"ft\\\\" [shape=doublecircle, label="le\\"ft\\\\\\nx\' = -k*x\\nc\' = 1"];'
    assert node in dot
    assert '  "le\\"ft\\\\" -> "right" [label="go [x <= 0.5 and c >= 1] c := 0"];' in dot


def test_source_lists_give_one_edge_per_source() -> None:
    text = TWO_ROOMS.replace('name = "back"\nsource = "right"',
                             'name = "back"\nsource = ["right", "idle"]')
    graph = mode_graph(loads_model(text))
    assert sorted(e for e in graph.edges(keys=True) if e[2] == "back") == [
        ("idle", "left", "back"), ("right", "left", "back")]
