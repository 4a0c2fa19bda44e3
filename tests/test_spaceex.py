"""SpaceEx import: structure, semantics against closed forms, one-line errors, and networks
written as components that simulate like the flat import."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import hybridlab
from hybridlab.cli import main
from hybridlab.io import (
    ConstraintSet,
    SpaceExError,
    load_spaceex,
    loads_spaceex,
    loads_spaceex_components,
)

ROOT = Path(__file__).resolve().parents[1]
SPACEEX = ROOT / "models" / "spaceex"

PARAM = '<param name="{}" type="real" local="false" d1="1" d2="1" dynamics="{}"/>'


def ball_xml(flow: str = "x' == v &amp; v' == -g", guard: str = "x &lt;= 0 &amp; v &lt; 0",
             assignment: str = "v' == -c*v", invariant: str = "x &gt;= 0") -> str:
    params = "".join(PARAM.format(n, d) for n, d in
                     (("x", "any"), ("v", "any"), ("g", "const"), ("c", "const")))
    return f"""<?xml version="1.0" encoding="iso-8859-1"?>
<sspaceex xmlns="http://www-verimag.imag.fr/xml-namespaces/sspaceex" version="0.2">
<component id="ball">{params}<param name="hop" type="label" local="false"/>
<location id="1" name="always"><invariant>{invariant}</invariant><flow>{flow}</flow></location>
<transition source="1" target="1"><label>hop</label><guard>{guard}</guard>
<assignment>{assignment}</assignment></transition></component></sspaceex>"""


BALL_CFG = 'initially = "x == 10 & v == 0 & g == 9.81 & c == 0.8"\ntime-horizon = 5'


def load_text(xml: str, cfg: str | None = BALL_CFG):
    return loads_spaceex(xml, cfg, source="ball.xml", cfg_source="ball.cfg")


def error_of(xml: str, cfg: str | None = BALL_CFG) -> str:
    with pytest.raises(SpaceExError) as info:
        load_text(xml, cfg)
    text = str(info.value)
    assert "\n" not in text
    return text


# ------------------------------------------------------------------ structure and semantics

def test_bouncing_ball_file_imports_with_its_cfg():
    p = load_spaceex(SPACEEX / "bouncing_ball.xml", SPACEEX / "bouncing_ball.cfg")
    m = p.model
    assert m.state_names == ("x", "v")
    assert {k: v.value for k, v in m.parameters.items()} == {"c": 0.75, "g": 1.0}
    assert m.modes["always"].flow == {"x": "v", "v": "-g"}
    [tr] = m.transitions
    assert (tr.name, tr.guard, tr.reset) == ("hop", ["x <= 0", "v < 0"], {"v": "-c*v"})
    assert p.initial == {"x": (10.0, 10.2), "v": (0.0, 0.0)}
    assert p.initial_modes == ("always",)
    assert p.t_end == 20.0 and p.options.time_step == 0.05 and p.options.max_jumps == 10
    [forbidden] = p.forbidden
    assert forbidden.relations == ("x >= 10.25",) and forbidden.modes is None
    assert forbidden.contains(np.array([10.3, 0.0])) and not forbidden.contains([10.2, 0.0])


def test_converted_ball_bounces_at_the_closed_form_times():
    p = load_text(ball_xml())
    r = hybridlab.simulate(p.model, 5.0)
    g, e, h0 = 9.81, 0.8, 10.0
    t1 = math.sqrt(2 * h0 / g)
    v1 = g * t1
    expected = [t1, t1 + 2 * e * v1 / g]
    assert [ev.t for ev in r.jumps] == pytest.approx(expected, rel=1e-9)
    assert r(expected[0])[1] == pytest.approx(e * v1, rel=1e-9)  # post-impact velocity


def test_model_round_trips_through_toml():
    model = load_text(ball_xml()).model
    again = hybridlab.loads_model(hybridlab.dumps_model(model))
    assert again.model_dump() == model.model_dump()


TIMED = """<sspaceex version="0.2">
<component id="timer">
  {t}<param name="tick" type="label" local="false"/>
  <location id="1" name="wait"><invariant>t &lt;= 1</invariant><flow>t' == 1</flow></location>
  <transition source="1" target="1"><label>tick</label><guard>t &gt;= 1</guard>
    <assignment>t := 0</assignment></transition>
</component>
<component id="counter">
  {n}<param name="tick" type="label" local="false"/>
  <location id="1" name="even"><flow>n' == 0</flow></location>
  <location id="2" name="odd"><flow>n' == 0</flow></location>
  <transition source="1" target="2"><label>tick</label><assignment>n' == n + 1</assignment>
  </transition>
  <transition source="2" target="1"><label>tick</label><assignment>n' == n + 1</assignment>
  </transition>
</component>
<component id="sys">
  {t}{n}<param name="tick" type="label" local="false"/>
  <bind component="timer" as="clk"><map key="t">t</map><map key="tick">tick</map></bind>
  <bind component="counter" as="cnt"><map key="n">n</map><map key="tick">tick</map></bind>
</component></sspaceex>""".format(t=PARAM.format("t", "any"), n=PARAM.format("n", "any"))


def test_label_synchronised_product_of_a_timer_and_a_counter():
    p = loads_spaceex(TIMED, 'system = sys\ninitially = "t == 0 & n == 0 & loc(cnt) == even"',
                      source="timed.xml")
    m = p.model
    assert p.renamed == {"t": "t_"}  # t is hybridlab's time symbol
    assert m.state_names == ("t_", "n")
    assert set(m.modes) == {"even", "odd"} and m.initial.mode == "even"
    # one synchronised transition per counter edge, guard from the timer, both resets
    assert sorted((tr.source, tr.target) for tr in m.transitions) == [("even", "odd"),
                                                                       ("odd", "even")]
    for tr in m.transitions:
        assert tr.guard == ["t_ >= 1"] and tr.reset == {"t_": "0", "n": "n + 1"}
    r = hybridlab.simulate(m, 3.5)
    assert [ev.t for ev in r.jumps] == pytest.approx([1.0, 2.0, 3.0], rel=1e-9)
    assert r.final.mode == "odd"
    assert r.final.state["n"] == pytest.approx(3.0)
    assert r.final.state["t_"] == pytest.approx(0.5, rel=1e-9)


def test_unsynchronised_transitions_interleave():
    xml = TIMED.replace('<map key="tick">tick</map></bind>\n  <bind component="counter"',
                        '</bind>\n  <bind component="counter"')
    p = loads_spaceex(xml, 'system = sys\ninitially = "t == 0 & n == 0 & loc(cnt) == even"')
    kinds = sorted((tr.source, tr.target, tr.guard == ["0 <= 0"]) for tr in p.model.transitions)
    # the timer's local tick self-loops in both modes; the counter moves on its own (no guard)
    assert kinds == [("even", "even", False), ("even", "odd", True), ("odd", "even", True),
                     ("odd", "odd", False)]


def test_polytope_initial_set_uncertain_constant_and_input():
    xml = ball_xml(flow="x' == v + u &amp; v' == -g").replace(
        '</location>', '</location>').replace(
        '<param name="hop"', PARAM.format("u", "any") + '<param name="hop"').replace(
        "<invariant>x &gt;= 0</invariant>", "<invariant>x &gt;= 0 &amp; u &gt;= -0.5 &amp; "
        "u &lt;= 0.25</invariant>")
    cfg = 'initially = "x + v <= 12 & x >= 10 & v >= 0 & g == 9.81 & c >= 0.7 & c <= 0.8"'
    p = load_text(xml, cfg)
    assert isinstance(p.initial, ConstraintSet)
    assert p.initial.relations == ("x + v <= 12", "x >= 10", "v >= 0")
    assert p.params == {"g": 9.81, "c": (0.7, 0.8)}
    assert p.inputs == {"u": (-0.5, 0.25)}
    assert p.model.parameters["u"].value == pytest.approx(-0.125)
    x0 = np.array([p.model.states["x"].initial, p.model.states["v"].initial])
    assert p.initial.contains(x0)
    assert p.model.modes["always"].invariant == ["x >= 0"]  # the input bounds moved out


def test_forbidden_union_with_locations():
    p = loads_spaceex(TIMED, 'system = sys\ninitially = "t == 0 & n == 0"\n'
                             'forbidden = "n >= 5 & loc(cnt) == odd | t >= 2"')
    assert p.initial_modes == ("even", "odd")  # the counter's location is left open
    first, second = p.forbidden
    assert first.modes == frozenset({"odd"}) and first.relations == ("n >= 5",)
    assert second.modes is None and second.A.tolist() == [[-1.0, 0.0]]


def test_network_with_local_variable_and_nested_names():
    xml = """<sspaceex><component id="osc">
      <param name="x" type="real" local="false" d1="1" d2="1" dynamics="any"/>
      <param name="y" type="real" local="true" d1="1" d2="1" dynamics="any"/>
      <param name="w" type="real" local="false" d1="1" d2="1" dynamics="const"/>
      <location id="1" name="run"><flow>x' == y &amp; y' == -w^2*x</flow></location>
    </component><component id="net">
      <param name="x" type="real" local="false" d1="1" d2="1" dynamics="any"/>
      <bind component="osc" as="o"><map key="x">x</map><map key="w">2</map></bind>
    </component></sspaceex>"""
    p = loads_spaceex(xml, 'initially = "x == 1 & o.y == 0"\ntime-horizon = 1')
    assert p.model.state_names == ("x", "o_y") and p.renamed == {"o.y": "o_y"}
    assert p.model.modes["run"].flow == {"x": "o_y", "o_y": "-w**2*x"}
    r = hybridlab.simulate(p.model, 1.0)
    assert r.final.state["x"] == pytest.approx(math.cos(2.0), abs=1e-6)


def test_every_bundled_spaceex_model_imports_and_simulates():
    cfgs = sorted(SPACEEX.glob("*.cfg"))
    assert len(cfgs) >= 3
    for cfg in cfgs:  # name.cfg or name_variant.cfg for name.xml
        [xml] = [x for x in SPACEEX.glob("*.xml") if cfg.stem.startswith(x.stem)]
        p = load_spaceex(xml, cfg)
        # the reference engine: no model compile per file (the import is what is tested)
        r = hybridlab.simulate(p.model, min(p.t_end or 1.0, 1.0), backend="reference")
        assert r.status.ok, (xml.name, r.message)
        assert p.forbidden, xml.name  # every benchmark states its property


def test_cli_prints_toml_that_loads(capsys, tmp_path):
    code = main(["import", "spaceex", str(SPACEEX / "bouncing_ball.xml"),
                 "--cfg", str(SPACEEX / "bouncing_ball.cfg")])
    out = capsys.readouterr().out
    assert code == 0 and out.startswith("# imported from")
    assert "# forbidden: x >= 10.25" in out
    assert hybridlab.loads_model(out).state_names == ("x", "v")
    target = tmp_path / "ball.toml"
    assert main(["import", "spaceex", str(SPACEEX / "bouncing_ball.xml"), "-o",
                 str(target)]) == 0
    assert hybridlab.load_model(target).name == "bouncing_ball"


def test_cli_user_error_is_one_line_with_exit_2(capsys, tmp_path):
    bad = tmp_path / "bad.xml"
    bad.write_text(ball_xml(flow="x' == vv &amp; v' == -g"))
    assert main(["import", "spaceex", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "unknown variable (token 'vv')" in err


# ------------------------------------------------------------------ errors

LOC = "component[@id='ball']/location[@name='always']"


@pytest.mark.parametrize(("kwargs", "expected"), [
    ({"flow": "x' == vv &amp; v' == -g"}, f"ball.xml: {LOC}/flow: unknown variable (token 'vv')"),
    ({"flow": "x' &lt;= v &amp; v' == -g"},
     f"ball.xml: {LOC}/flow: a flow must be a conjunction of x' == expr (differential "
     "inclusions are not supported) (token \"x' <= v\")"),
    ({"flow": "x' == v &amp; v' == -g; import os"},
     f"ball.xml: {LOC}/flow: unexpected character (token '; import os')"),
    ({"guard": "__import__('os').system('ls') &gt;= 0"},
     "ball.xml: component[@id='ball']/transition[1]/guard: unexpected character "
     "(token \".system('ls') >= 0\")"),
    ({"guard": "__import__(x) &gt;= 0"},
     "ball.xml: component[@id='ball']/transition[1]/guard: unknown function "
     "(token '__import__')"),
    ({"guard": "x.__class__ &gt;= 0"},
     "ball.xml: component[@id='ball']/transition[1]/guard: unknown variable "
     "(token 'x.__class__')"),
    ({"guard": "[x] &gt;= 0"},
     "ball.xml: component[@id='ball']/transition[1]/guard: unexpected character (token "
     "'[x] >= 0')"),
    ({"guard": "x &lt;= 0 | v &lt; 0"},
     "ball.xml: component[@id='ball']/transition[1]/guard: disjunction '|' is not supported "
     "here (token '|')"),
    ({"assignment": "v' &gt;= -c*v"},
     "ball.xml: component[@id='ball']/transition[1]/assignment: an assignment must be x' == "
     "expr or x := expr for a variable x (non-deterministic resets are not supported) "
     "(token \"v' >= -c*v\")"),
    ({"invariant": "x &gt;= 0 &amp; sgn(x) &lt; 2"},
     f"ball.xml: {LOC}/invariant: unknown function (token 'sgn')"),
    ({"invariant": "x &gt;= 1/0"}, f"ball.xml: {LOC}/invariant: division by zero (token '1/0')"),
])
def test_bad_expressions_give_one_line_errors(kwargs, expected):
    assert error_of(ball_xml(**kwargs)) == expected


def test_dtd_entity_bomb_is_refused():
    levels = "".join(f'<!ENTITY lol{i} "{f"&lol{i - 1};" * 10}">' for i in range(1, 10))
    bomb = ('<?xml version="1.0"?><!DOCTYPE lolz [<!ENTITY lol0 "lol">' + levels
            + ']><sspaceex><component id="a">&lol9;</component></sspaceex>')
    assert error_of(bomb) == ("ball.xml: sspaceex: DTDs and entity declarations are not allowed "
                              "in SpaceEx files (token '<!DOCTYPE')")


def test_external_entity_is_refused():
    xxe = ('<?xml version="1.0"?><!DOCTYPE a [<!ENTITY e SYSTEM "file:///etc/passwd">]>'
           '<sspaceex>&e;</sspaceex>')
    assert "DTDs and entity declarations are not allowed" in error_of(xxe)


@pytest.mark.parametrize(("xml", "cfg", "expected"), [
    ("<sspaceex><component id='a'>", BALL_CFG,
     "ball.xml: sspaceex: invalid XML: no element found (at line 1, column 29)"),
    ("<model/>", BALL_CFG, "ball.xml: model: the root element must be <sspaceex> "
                           "(token 'model')"),
    (ball_xml(), 'initially = "x == 10 & v == 0 & g == 9.81"',
     "ball.cfg: initially: constant has no value (map it to a number in a <bind> or give "
     "'c == value' in the initially set) (token 'c')"),
    (ball_xml(), 'initially = "x >= 10 & x <= 11 & v >= x & g == 9.81 & c == 0.8"',
     "ball.cfg: initially: the initial set is unbounded in this variable (constrain it) "
     "(token 'v')"),
    (ball_xml(), 'initially = "x == 10 & v == 0 & g == 9.81 & c == 0.8 & loc(ball) == up"',
     "ball.cfg: initially: automaton 'ball' has no location of this name (token 'up')"),
    (ball_xml(), 'initially = "x == 10 & v == 0 & g == 9.81 & c == 0.8 & loc(b) == always"',
     "ball.cfg: initially: loc(...) names no single automaton of the system (token 'loc(b)')"),
    (ball_xml(), 'initially = "x*x <= 10 & v == 0 & g == 9.81 & c == 0.8"',
     "ball.cfg: initially: the initial set must be given by linear constraints "
     "(token 'x*x <= 10')"),
    (ball_xml(), 'initially = "x == 10 & x == 11 & v == 0 & g == 9.81 & c == 0.8"',
     "ball.cfg: initially: the initial set is empty"),
    (ball_xml(), BALL_CFG + '\nforbidden = "x >= "',
     "ball.cfg: forbidden: missing operand of a comparison"),
    (ball_xml(), BALL_CFG.replace("time-horizon = 5", "time-horizon = -1"),
     "ball.cfg: time-horizon: must be a positive finite number (token '-1')"),
    (ball_xml(), 'initially "x == 1"', "ball.cfg: initially: line 1: expected '=' after the "
                                       "key (token '\"x == 1\"')"),
    (ball_xml(), BALL_CFG + "\nsystem = net", "ball.xml: system: no component with this id "
                                              "(token 'net')"),
])
def test_file_and_cfg_errors(xml, cfg, expected):
    assert error_of(xml, cfg) == expected


def test_missing_file_error():
    with pytest.raises(SpaceExError, match=r"^nope.xml: cannot read file"):
        load_spaceex("nope.xml")


JUNK = st.lists(st.sampled_from(list("xvgc'()+-*/^&|=<>:;.,!01 e_[]\"\\") +
                                ["loc", "sin", "__import__", "os", "lambda", "==", "<=", ":=",
                                 "true", "1e400", "\n"]),
                max_size=25).map("".join)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(guard=JUNK, assignment=JUNK)
def test_random_expression_text_gives_a_model_or_a_one_line_error(guard, assignment):
    from xml.sax.saxutils import escape

    xml = ball_xml(guard=escape(guard), assignment=escape(assignment))
    try:
        p = load_text(xml)
    except SpaceExError as exc:
        text = str(exc)
        assert "\n" not in text and text.startswith("ball.xml: component[@id='ball']/")
    else:
        assert isinstance(p.model, hybridlab.Model)


# ------------------------------------------------------------------ names that try to escape
@pytest.mark.parametrize("name", [
    "a\n[[transitions]]\nname = \"evil\"\nsource = \"a\"\ntarget = \"a\"\nguard = \"x >= 0\"",
    "a\r\n# x", 'a"b', "a\\nb", "a\u2028b", "x = 1", "*)",
])
def test_an_imported_name_means_exactly_what_the_xml_means(tmp_path, name):
    # the location name goes into the written file's header comment and into its keys
    escaped = (name.replace("&", "&amp;").replace("<", "&lt;").replace('"', "&quot;")
               .replace("\n", "&#10;").replace("\r", "&#13;"))
    xml = ball_xml().replace('name="always"', f'name="{escaped}"').replace("iso-8859-1", "utf-8")
    problem = load_text(xml)
    (tmp_path / "ball.xml").write_text(xml, encoding="utf-8")
    (tmp_path / "ball.cfg").write_text(BALL_CFG)
    target = tmp_path / "imported.toml"
    assert main(["import", "spaceex", str(tmp_path / "ball.xml"), "--cfg",
                 str(tmp_path / "ball.cfg"), "-o", str(target)]) == 0
    written = hybridlab.load_model(target)
    assert written == problem.model  # the file holds the model, and nothing else
    a = hybridlab.simulate(problem.model, 3.0, backend="reference")
    b = hybridlab.simulate(written, 3.0, backend="reference")
    assert [e.t for e in a.events] == [e.t for e in b.events] and len(a.events) == 1
    lines = target.read_text(encoding="utf-8").splitlines()
    comments = [k for k, ln in enumerate(lines) if ln.startswith("#")]
    assert comments == list(range(len(comments)))  # the header only: nothing escaped it


def test_a_cfg_key_given_twice_is_an_error():
    cfg = BALL_CFG + "\ntime-horizon = 50"
    assert "line 3: the key is given twice" in error_of(ball_xml(), cfg)


# ------------------------------------------------------------------ networks as components

def written(tmp_path: Path, name: str) -> tuple[Path, Path]:
    """``import spaceex NAME -o`` and ``flatten`` of what it wrote."""
    out, flat = tmp_path / f"{name}.toml", tmp_path / f"{name}_flat.toml"
    assert main(["import", "spaceex", str(SPACEEX / f"{name}.xml"), "--cfg",
                 str(SPACEEX / f"{name}.cfg"), "-o", str(out)]) == 0
    assert main(["flatten", str(out), "-o", str(flat)]) == 0
    return out, flat


def same_events(imported: hybridlab.io.SpaceExComponents, model: hybridlab.Model,
                t_end: float) -> int:
    """Simulate the flat import and ``model``: the same jumps at the same times."""
    a = hybridlab.simulate(imported.problem.model, t_end, backend="reference")
    b = hybridlab.simulate(model, t_end, backend="reference")
    assert a.status.ok and b.status.ok
    modes = imported.modes or {m: m for m in imported.problem.model.modes}
    assert [(modes[e.source], modes[e.target]) for e in a.jumps] == \
        [(e.source, e.target) for e in b.jumps]
    assert np.allclose([e.t for e in a.jumps], [e.t for e in b.jumps], rtol=0, atol=1e-10)
    names = imported.names or {s: s for s in imported.problem.model.state_names}
    for flat, qualified in names.items():
        if flat in a.final.state:
            assert a.final.state[flat] == pytest.approx(b.final.state[qualified], abs=1e-10)
    return len(a.jumps)


def test_two_rooms_network_is_written_as_components(tmp_path):
    out, flat = written(tmp_path, "two_rooms")
    text = out.read_text()
    doc = tomllib.loads(text)
    assert list(doc["templates"]) == ["room", "heater"]
    assert doc["instances"]["room2"] == {
        "template": "room", "parameters": {"a": 0.07}, "initial": {"T": 17.0},
        "labels": {"start": "start2", "stop": "stop2"}, "connect": {"T_other": "room1.T"}}
    assert "# renamed: T1 -> room1.T" in text and "# forbidden: room1.T <= 12" in text
    imported = hybridlab.io.spaceex_components(SPACEEX / "two_rooms.xml",
                                               SPACEEX / "two_rooms.cfg")
    model = hybridlab.load_model(out)
    assert hybridlab.load_model(flat) == model
    assert model.initial.mode == "room1.off|room2.off|heater.idle"
    assert same_events(imported, model, 40.0) >= 4
    # the same network as hybridlab's own two_rooms.toml: the same runs
    own = hybridlab.load_model(ROOT / "models" / "two_rooms.toml")
    a = hybridlab.simulate(own, 40.0, backend="reference")
    b = hybridlab.simulate(model, 40.0, backend="reference")
    assert [(e.source, e.target) for e in a.jumps] == [(e.source, e.target) for e in b.jumps]
    assert np.allclose([e.t for e in a.jumps], [e.t for e in b.jumps], rtol=0, atol=1e-10)


def test_room_heating_is_one_automaton_and_stays_flat(tmp_path):
    out, flat = written(tmp_path, "room_heating")
    imported = hybridlab.io.spaceex_components(SPACEEX / "room_heating.xml",
                                               SPACEEX / "room_heating.cfg")
    assert imported.document is None
    assert "\n# one automaton: written as a flat model\n" in out.read_text()
    model = hybridlab.load_model(flat)
    assert hybridlab.load_model(out) == imported.problem.model == model
    assert same_events(imported, model, 3.0) >= 2


CFG = 'initially = "t == 0 & n == 0 & loc(cnt) == odd"\nforbidden = "n >= 5 & loc(cnt) == odd"'


def test_labels_synchronise_and_loc_sets_the_initial_and_forbidden_modes():
    imported = loads_spaceex_components(TIMED, CFG, source="timed.xml")
    doc = imported.document
    assert doc is not None
    assert doc["instances"] == {"clk": {"template": "timer"}, "cnt": {"template": "counter"}}
    assert doc["templates"]["counter"]["initial"] == {"mode": "odd"}  # the cfg's loc(cnt)
    assert doc["templates"]["counter"]["transitions"][0] == {
        "name": "tick", "source": "even", "target": "odd", "reset": {"n": "n + 1"},
        "label": "tick"}  # no guard of its own: the timer's decides
    assert "# forbidden: cnt.n >= 5 in modes clk.wait|cnt.odd" in imported.text()
    model = imported.model()
    assert model.initial.mode == "clk.wait|cnt.odd"
    assert same_events(imported, model, 3.5) == 3
    # a label that only one automaton declares interleaves: no label in the file
    alone = TIMED.replace('<map key="tick">tick</map></bind>\n  <bind component="counter"',
                          '</bind>\n  <bind component="counter"')
    imported = loads_spaceex_components(alone, CFG)
    assert imported.document is not None
    assert all("label" not in tr for tpl in imported.document["templates"].values()
               for tr in tpl["transitions"])
    model = imported.model()  # built only when its modes have the flat import's transitions
    assert [tr.name for tr in model.transitions] == ["clk.tick", "cnt.tick", "cnt.tick_2"]


COUNTER_TICKS = ('<transition source="1" target="2"><label>tick</label>',
                 '<transition source="2" target="1"><label>tick</label>')
TIMER_TICK = '<transition source="1" target="1"><label>tick</label>'
CANNOT = {
    # the counter, not the timer, resets the timer's clock
    "'cnt' assigns 't_', whose flow another component gives (a component resets only its own "
    "states)":
        TIMED.replace("\n    <assignment>t := 0</assignment>", "")
             .replace("n' == n + 1</assignment>", "n' == n + 1 &amp; t := 0</assignment>")
             .replace('<component id="counter">', '<component id="counter">' + PARAM.format(
                 "t", "any"))
             .replace('<map key="n">n</map>', '<map key="n">n</map><map key="t">t</map>'),
    # the counter declares tick but has no transition with it: the timer's never fires
    "label 'tick' is declared by 'cnt', which has no transition with it (it blocks the "
    "others')":
        TIMED.replace(COUNTER_TICKS[0], '<transition source="1" target="2">')
             .replace(COUNTER_TICKS[1], '<transition source="2" target="1">'),
    # a plain transition between two ticks of one location: the product tries the three in
    # the order of the XML, components would try the ticks first
    "'clk' in location 'wait' would try simultaneous transitions in another order":
        TIMED.replace(TIMER_TICK, TIMER_TICK + '<guard>t &gt;= 1</guard></transition>'
                      '<transition source="1" target="1"><guard>t &gt;= 1</guard></transition>'
                      + TIMER_TICK),
}


@pytest.mark.parametrize("note", list(CANNOT))
def test_what_components_cannot_say_keeps_the_product(note):
    imported = loads_spaceex_components(CANNOT[note], CFG, source="timed.xml")
    assert imported.document is None and imported.note == "written as the product: " + note
    text = imported.text()
    assert f"\n# {imported.note}\n" in text
    assert hybridlab.loads_model(text) == imported.problem.model


def test_flat_option_writes_todays_product(capsys):
    assert main(["import", "spaceex", str(SPACEEX / "two_rooms.xml"), "--cfg",
                 str(SPACEEX / "two_rooms.cfg"), "--flat"]) == 0
    text = capsys.readouterr().out
    problem = load_spaceex(SPACEEX / "two_rooms.xml", SPACEEX / "two_rooms.cfg")
    assert hybridlab.loads_model(text) == problem.model
    assert "templates" not in tomllib.loads(text)


def test_a_constant_of_one_value_keeps_one_template_an_uncertain_one_is_shared():
    ball = ball_xml().replace('name="hop" type="label" local="false"',
                              'name="hop" type="label" local="true"')
    for local in ("x", "v"):
        ball = ball.replace(f'name="{local}" type="real" local="false"',
                            f'name="{local}" type="real" local="true"')
    xml = ball.replace("</sspaceex>", f"""<component id="pair">{PARAM.format("g", "const")}
      <bind component="ball" as="b1"><map key="g">g</map><map key="c">0.8</map></bind>
      <bind component="ball" as="b2"><map key="g">g</map><map key="c">0.9</map></bind>
      </component></sspaceex>""")
    init = 'initially = "b1.x == 10 & b1.v == 0 & b2.x == 5 & b2.v == 0 & {}"'
    one = loads_spaceex_components(xml, init.format("g == 9.81")).document
    assert one is not None and list(one["templates"]) == ["ball"]
    assert one["instances"]["b2"] == {"template": "ball", "parameters": {"c": 0.9},
                                      "initial": {"x": 5.0}}
    uncertain = loads_spaceex_components(xml, init.format("g >= 9.8 & g <= 9.82"))
    assert uncertain.document is not None and list(uncertain.document["templates"]) == [
        "ball", "ball_"]
    assert uncertain.document["instances"]["b2"]["connect"] == {"g": "b1.g"}
    assert "# uncertain constant: b1.g in [9.8, 9.82]" in uncertain.text()
    assert uncertain.model().parameter_names == ("b1.g", "b1.c", "b2.c")
