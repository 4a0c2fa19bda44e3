"""Static mode-graph checks: `check_mode_graph`, the feasibility decisions and `graph --check`."""

from __future__ import annotations

from pathlib import Path

import pytest
import sympy as sp
from strategies import MODEL_FILES

import hybridlab
from hybridlab import loads_model
from hybridlab.cli import main
from hybridlab.graph import Feasibility, Severity, check_mode_graph, decide
from hybridlab.model.names import match_modes

ROOT = Path(__file__).resolve().parents[1]
x, y = sp.symbols("x y", real=True)


def model(modes: str, transitions: str, *, states: str = "x = 0.0", extra: str = "",
          initial: str = "a") -> hybridlab.Model:
    return loads_model(f'name = "m"\n[parameters]\nk = 1.0\n[states]\n{states}\n{modes}\n'
                       f'{transitions}\n[initial]\nmode = "{initial}"\n{extra}')


def kinds(report: hybridlab.graph.GraphReport) -> list[tuple[str, str, str]]:
    return [(f.severity.value, f.kind, f.subject) for f in report.findings]


TWO_MODES = '[modes.a]\nflow = { x = "1" }\ninvariant = "x <= 1"\n[modes.b]\nflow = { x = "-1" }\n'


# ----------------------------------------------------------------- feasibility decisions
def test_lp_margin_is_the_half_gap_between_contradicting_rows() -> None:
    decision = decide([x - 2, 1 - x])  # x >= 2 and x <= 1: best compromise x = 1.5
    assert decision.verdict is Feasibility.IMPOSSIBLE and decision.method == "lp"
    assert decision.margin == pytest.approx(-0.5, abs=1e-9)


def test_touching_rows_are_possible() -> None:
    decision = decide([x - 1, 1 - x, y])
    assert decision.verdict is Feasibility.POSSIBLE
    assert decision.margin == pytest.approx(0, abs=1e-9)


def test_constant_rows_decide_without_states() -> None:
    assert decide([sp.Float(-0.25)]).verdict is Feasibility.IMPOSSIBLE
    assert decide([sp.Float(0.0), x]).verdict is Feasibility.POSSIBLE


def test_nonlinear_rows_are_decided_by_intervals_on_a_bounded_box() -> None:
    # x - x^2 <= 1/4 everywhere: infeasible, provable once the invariant bounds x
    assert decide([x - x**2 - 0.3, x, 1 - x]).verdict is Feasibility.IMPOSSIBLE
    assert decide([x - x**2 - 0.2, x, 1 - x]).verdict is Feasibility.POSSIBLE
    # unbounded: the interval enclosure of x - x^2 is the whole line on every box
    assert decide([x - x**2 - 0.3]).verdict is Feasibility.UNDECIDED


def test_nonlinear_touching_point_is_found_by_local_search() -> None:
    # |x + 0.29 sin(y) - 0.25| == 0.02 only on a curve: proved by a point, not by a box
    edge = sp.Abs(x + 0.29 * sp.sin(y) - 0.25) - 0.02
    assert decide([edge, -edge]).verdict is Feasibility.POSSIBLE


# ----------------------------------------------------------------- transitions
def test_guard_contradicting_the_invariant_never_fires() -> None:
    report = check_mode_graph(model(TWO_MODES, '[[transitions]]\nname = "go"\nsource = "a"\n'
                                    'target = "b"\nguard = "x >= 2"'))
    [tr] = report.transitions
    assert (tr.guard, tr.method) == (Feasibility.IMPOSSIBLE, "lp")
    assert kinds(report) == [("error", "never-fires", "go"), ("warning", "dead-mode", "b"),
                             ("info", "sink-mode", "b")]
    assert str(report.findings[0]) == (
        "error: [never-fires] transition 'go' (a -> b) never fires: its guard contradicts the "
        "invariant of 'a' [lp]")
    assert "only through transitions that never fire" in report.findings[1].message
    assert not report.ok


def test_guard_that_touches_the_invariant_fires() -> None:
    report = check_mode_graph(model(TWO_MODES, '[[transitions]]\nname = "go"\nsource = "a"\n'
                                    'target = "b"\nguard = "x >= 1"'))
    assert report.transitions[0].guard is Feasibility.POSSIBLE
    assert report.ok and report.dead_modes == () and report.sink_modes == ("b",)


def test_scenario_parameters_can_enable_a_guard() -> None:
    text = ('[[transitions]]\nname = "go"\nsource = "a"\ntarget = "b"\nguard = "x >= 1 + k"')
    scenario = '[scenarios.low]\nt_end = 1.0\nparameters = { k = -0.5 }\n'
    report = check_mode_graph(model(TWO_MODES, text, extra=scenario))
    assert report.parameter_sets == ("model values", "low")
    assert report.transitions[0].guard is Feasibility.POSSIBLE
    assert report.reachable == {"model values": ("a",), "low": ("a", "b")}
    only_defaults = check_mode_graph(model(TWO_MODES, text, extra=scenario), scenarios=[])
    assert only_defaults.transitions[0].guard is Feasibility.IMPOSSIBLE
    with pytest.raises(hybridlab.ModelError, match="unknown scenario.*'nope'"):
        check_mode_graph(model(TWO_MODES, text, extra=scenario), scenarios=["nope"])


def test_reset_outside_the_target_invariant_is_an_error() -> None:
    modes = TWO_MODES + 'invariant = "x >= 0"\n'
    report = check_mode_graph(model(modes, '[[transitions]]\nname = "go"\nsource = "a"\n'
                                    'target = "b"\nguard = "x >= 1"\nreset = { x = "x - 5" }'))
    [tr] = report.transitions
    assert (tr.guard, tr.reset) == (Feasibility.POSSIBLE, Feasibility.IMPOSSIBLE)
    assert kinds(report)[0] == ("error", "reset-violates-invariant", "go")
    # the transition cannot be taken, so the target is dead as well
    assert report.dead_modes == ("b",)
    fine = check_mode_graph(model(modes, '[[transitions]]\nname = "go"\nsource = "a"\n'
                                  'target = "b"\nguard = "x >= 1"\nreset = { x = "x - 1" }'))
    assert fine.transitions[0].reset is Feasibility.POSSIBLE and fine.ok


def test_unreachable_mode_is_dead_and_sinks_are_informational() -> None:
    modes = TWO_MODES + '[modes.c]\nflow = { x = "0" }\n'
    report = check_mode_graph(model(modes, '[[transitions]]\nname = "go"\nsource = "a"\n'
                                    'target = "b"\nguard = "x >= 0"'))
    assert report.dead_modes == ("c",)
    assert report.sink_modes == ("b", "c")
    assert ("warning", "dead-mode", "c") in kinds(report)
    assert report.count(Severity.INFO) == 2


def test_empty_invariant_is_an_error() -> None:
    modes = '[modes.a]\nflow = { x = "1" }\ninvariant = ["x >= 1", "x <= 0"]\n'
    report = check_mode_graph(model(modes, ""))
    assert kinds(report)[0] == ("error", "empty-invariant", "a")


def test_nonlinear_guard_decided_by_intervals() -> None:
    modes = ('[modes.a]\nflow = { x = "1", y = "0" }\ninvariant = "x >= 2"\n'
             '[modes.b]\nflow = { x = "0", y = "0" }\n')
    report = check_mode_graph(model(modes, '[[transitions]]\nname = "in_disc"\nsource = "a"\n'
                                    'target = "b"\nguard = "x**2 + y**2 <= 1"',
                                    states="x = 3.0\ny = 0.0"))
    [tr] = report.transitions
    assert (tr.guard, tr.method) == (Feasibility.IMPOSSIBLE, "lp+interval")
    assert kinds(report)[0] == ("error", "never-fires", "in_disc")


def test_nonlinear_guard_left_undecided_is_only_informational() -> None:
    report = check_mode_graph(model(TWO_MODES.replace('invariant = "x <= 1"\n', ""),
                                    '[[transitions]]\nname = "bump"\nsource = "a"\n'
                                    'target = "b"\nguard = "x - x**2 >= 0.3"'))
    assert report.transitions[0].guard is Feasibility.UNDECIDED
    assert kinds(report)[0] == ("info", "undecided", "bump")
    assert "nonlinear" in report.findings[0].message
    # an undecided guard keeps its edge: "b" counts as reachable
    assert report.ok and report.dead_modes == ()


# ----------------------------------------------------------------- zero-dwell cycles
PING_PONG = '''
[[transitions]]
name = "ping"
source = "a"
target = "b"
guard = "x >= 0"
{reset}
[[transitions]]
name = "pong"
source = "b"
target = "a"
guard = "x >= 0"
'''


def test_zero_dwell_cycle_possible() -> None:
    report = check_mode_graph(model(TWO_MODES, PING_PONG.format(reset="")))
    [cycle] = report.cycles
    assert (cycle.transitions, cycle.modes, cycle.verdict) == (
        ("ping", "pong"), ("a", "b"), Feasibility.POSSIBLE)
    assert cycle.parameter_set == "model values"
    assert kinds(report) == [("warning", "zero-dwell-cycle", "ping -> pong")]


def test_zero_dwell_cycle_made_impossible_by_a_reset() -> None:
    report = check_mode_graph(model(TWO_MODES, PING_PONG.format(reset='reset = { x = "-1" }')))
    [cycle] = report.cycles
    assert cycle.verdict is Feasibility.IMPOSSIBLE
    assert report.ok and report.findings == ()


def test_latched_flag_lets_a_cycle_round_once_but_not_twice() -> None:
    # "pong" needs f <= 0.5 and sets f = 1; nothing clears it. One round (ping, pong, and ping
    # enabled again) is possible, two rounds are not: the default (rounds=2) says impossible
    text = PING_PONG.format(reset="") + 'reset = { f = "1" }\n'
    text = text.replace('target = "a"\nguard = "x >= 0"',
                        'target = "a"\nguard = ["x >= 0", "f <= 0.5"]')
    states = 'x = 0.0\nf = { initial = 0.0, flow = "0" }'
    one = check_mode_graph(model(TWO_MODES, text, states=states), rounds=1)
    two = check_mode_graph(model(TWO_MODES, text, states=states))
    assert one.cycles[0].verdict is Feasibility.POSSIBLE
    assert two.cycles[0].verdict is Feasibility.IMPOSSIBLE


SENSOR = '''
[[transitions]]
name = "on"
source = "a"
target = "*"
guard = ["s <= 0.5", "x >= 0"]
reset = {{ s = "1" }}
[[transitions]]
name = "off"
source = "a"
target = "*"
guard = ["s >= 0.5", "x <= {off}"]
reset = {{ s = "0" }}
'''


def test_two_self_loops_without_hysteresis_form_a_zero_dwell_cycle() -> None:
    modes = '[modes.a]\nflow = { x = "1", s = "0" }\n'
    report = check_mode_graph(model(modes, SENSOR.format(off="0"), states="x = 0.0\ns = 0.0"))
    assert [(c.transitions, c.verdict) for c in report.cycles] == [
        (("on", "off"), Feasibility.POSSIBLE)]
    hysteresis = check_mode_graph(model(modes, SENSOR.format(off="-0.1"),
                                        states="x = 0.0\ns = 0.0"))
    assert [c.verdict for c in hysteresis.cycles] == [Feasibility.IMPOSSIBLE]


def test_single_self_loop_and_scheduled_transitions_are_not_cycles() -> None:
    ball = check_mode_graph(hybridlab.load_model(ROOT / "models" / "bouncing_ball.toml"))
    assert ball.cycles == () and ball.ok
    scheduled = PING_PONG.format(reset="schedule = { period = 0.1 }")
    report = check_mode_graph(model(TWO_MODES, scheduled))
    assert report.cycles == ()


def test_cycle_length_bound() -> None:
    modes = "".join(f'[modes.m{i}]\nflow = {{ x = "0" }}\n' for i in range(4))
    transitions = "".join(f'[[transitions]]\nname = "t{i}"\nsource = "m{i}"\n'
                          f'target = "m{(i + 1) % 4}"\nguard = "x >= 0"\n' for i in range(4))
    assert len(check_mode_graph(model(modes, transitions, initial="m0")).cycles) == 1
    short = check_mode_graph(model(modes, transitions, initial="m0"), max_cycle_length=3)
    assert short.cycles == ()


# ----------------------------------------------------------------- the bundled models
@pytest.fixture(scope="module")
def trolley_report() -> hybridlab.graph.GraphReport:
    return check_mode_graph(hybridlab.load_model(ROOT / "models" / "trolley.toml"))


def test_trolley_every_mode_reachable_in_some_scenario(
        trolley_report: hybridlab.graph.GraphReport) -> None:
    report = trolley_report
    assert report.dead_modes == () and report.sink_modes == ()
    assert report.count(Severity.ERROR) == 0
    modes = list(report.reachable["jerk_limited"])
    assert report.reachable["model values"] == tuple(match_modes("hold", modes))  # nothing starts
    assert set(modes) == {m for name in ("hold", *(f"p4_{i}" for i in range(1, 8)))
                          for m in match_modes(name, modes)}
    assert len(modes) == 8
    starts = [t for t in report.transitions if t.name.startswith("start_")]
    assert all(t.guard is Feasibility.POSSIBLE for t in starts)


def test_trolley_sensor_edges_are_zero_dwell_candidates(
        trolley_report: hybridlab.graph.GraphReport) -> None:
    # without hysteresis, on/off of one sensor can alternate at the window edge
    # (the simulator confirms it: a tip resting on the edge ends in a ZENO cascade)
    warnings = [f for f in trolley_report.findings if f.severity is Severity.WARNING]
    assert [f.subject for f in warnings] == ["s1_off -> s1_on", "s2_off -> s2_on"]
    assert all("in 17 places" in f.message for f in warnings)
    disabled = [f for f in trolley_report.findings if f.kind == "schedule-disabled"]
    assert [f.subject for f in disabled] == ["sample"]
    # the manoeuvre loops back to "hold", but "started" is latched: never twice at one instant
    long = [c for c in trolley_report.cycles if "arrive" in c.transitions]
    assert long and all(c.verdict is Feasibility.IMPOSSIBLE for c in long)


# the trolleys (trolley_linear.toml imports trolley.toml's sensors and logic) have the
# zero-dwell sensor edges checked above
@pytest.mark.parametrize("path", [p for p in MODEL_FILES if not p.stem.startswith("trolley")],
                         ids=lambda p: p.stem)
def test_small_bundled_models_are_clean(path: Path) -> None:
    report = check_mode_graph(hybridlab.load_model(path))
    assert report.ok and report.dead_modes == ()
    assert all(t.guard is Feasibility.POSSIBLE for t in report.transitions)
    assert all(c.verdict is Feasibility.IMPOSSIBLE for c in report.cycles)


def test_thermostat_hysteresis_rules_out_a_zero_dwell_cycle() -> None:
    report = check_mode_graph(hybridlab.load_model(ROOT / "models" / "thermostat.toml"))
    [cycle] = report.cycles
    assert cycle.verdict is Feasibility.IMPOSSIBLE and cycle.method == "lp"
    assert {t.name: t.guard for t in report.transitions} == {
        "turn_off": Feasibility.POSSIBLE, "turn_on": Feasibility.POSSIBLE}


# ----------------------------------------------------------------- command line
def test_cli_check_exit_codes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["graph", str(ROOT / "models" / "thermostat.toml"), "--check"]) == 0
    out = capsys.readouterr().out
    assert out == ("thermostat: 0 errors, 0 warnings, 0 infos; 2 transition edges, 1 cycle, "
                   "2 parameter sets checked\n")
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "bad"\n[states]\nx = 0.0\n' + TWO_MODES +
                   '[[transitions]]\nname = "go"\nsource = "a"\ntarget = "b"\nguard = "x >= 2"\n'
                   '[initial]\nmode = "a"\n')
    assert main(["graph", str(bad), "--check"]) == 4
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("error: [never-fires] transition 'go'")
    assert lines[-1].startswith("bad: 1 error, 1 warning, 1 info;")
    assert main(["graph", str(bad)]) == 0  # without --check: DOT, as before
    assert capsys.readouterr().out.startswith('digraph "bad" {')
    assert main(["graph", str(bad), "--check", "--scenario", "nope"]) == 2
    assert "unknown scenario" in capsys.readouterr().err
    assert main(["graph", str(bad), "--check", "--max-cycle-length", "0"]) == 2
