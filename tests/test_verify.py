"""Safety specs, falsification, counterexamples, verdicts and assert_safe (issue 5, items 4-5)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from strategies import spec_texts

import hybridlab
from hybridlab.reachability.falsify import FalsifyOptions, falsify
from hybridlab.reachability.spec import Avoid, Spec, SpecError, as_specs, parse_spec
from hybridlab.simulation.problem import HybridProblem
from hybridlab.verify import SafetyAssertionError, VerdictStatus, assert_safe, check_safety

ROOT = Path(__file__).resolve().parents[1]
BALL = ROOT / "models" / "bouncing_ball.toml"

TWO_MODES = """
name = "two"
parameters = { a = 1.0 }
states = { x = 0.0, y = 0.0 }
[modes.up]
flow = { x = "k", y = "0" }
definitions = { k = "a" }
[modes.down]
flow = { x = "-1", y = "0" }
[[transitions]]
name = "flip"
source = "up"
target = "down"
guard = "x >= 2"
[initial]
mode = "up"
"""

OSCILLATOR = """
name = "oscillator"
states = { x = 1.0, v = 0.0 }
[modes.run]
flow = { x = "v", v = "-x" }
[initial]
mode = "run"
"""

DRIFT = """
name = "drift"
parameters = { u = 0.0 }
states = { x = 0.0, y = 0.0 }
[modes.run]
flow = { x = "u", y = "0" }
[initial]
mode = "run"
"""


@pytest.fixture(scope="module")
def two():
    return hybridlab.compile_model(hybridlab.loads_model(TWO_MODES))


@pytest.fixture(scope="module")
def ball():
    return hybridlab.compile_model(hybridlab.load_model(BALL))


# ----------------------------------------------------------------------------- specs
def test_spec_rows_are_normalised_to_nonnegative_margins(ball):
    spec = parse_spec("0 <= h <= 10 and v > -20", ball)
    assert spec.kind == "all" and spec.modes is None
    assert [str(r) for r in spec.rows["fall"]] == ["h", "10 - h", "v + 20"]
    # margins at (h, v) = (5, 0) and (11, -25)
    values = np.array([[5.0, 11.0], [5.0, -1.0], [20.0, -5.0]])
    assert spec.margin(values).tolist() == [5.0, -5.0]
    assert spec.violated(-5.0) and not spec.violated(0.0)


def test_mode_lists_definitions_and_parameters(two):
    up = parse_spec("up: x <= k + 1", two)  # a mode-local definition, substituted
    assert up.modes == ("up",) and set(up.rows) == {"up"}
    assert str(up.rows["up"][0]) == "a - x + 1"
    both = parse_spec(" up , down : x >= -a", two)
    assert both.modes == ("up", "down") and set(both.rows) == {"up", "down"}
    assert parse_spec("*: x >= 0", two).modes is None


@pytest.mark.parametrize(("text", "message"), [
    ("side: x >= 0", "spec 'side: x >= 0': unknown mode; the model has: up, down (token 'side')"),
    ("x >= z", "spec 'x >= z': unknown symbol (token 'z')"),
    ("x == 1", "spec 'x == 1': only inequalities (<, <=, >, >=) are allowed (token '==')"),
    ("x >= 0 or y >= 0", "spec 'x >= 0 or y >= 0': 'or' is not supported; use one transition "
                         "per alternative (token 'or')"),
    ("x", "spec 'x': an inequality such as 'x >= 0' is expected (token 'x')"),
    ("x >= t", "spec 'x >= t': time is not allowed in a safety spec; restrict the spec to modes "
               "instead (token 't')"),
    ("up:", "spec 'up:': empty expression"),
    ("down: x <= k", "spec 'down: x <= k': 'k' is defined in other modes but not in mode 'down' "
                     "(token 'k')"),
    ("__import__('os').system('x') >= 0",
     "spec \"__import__('os').system('x') >= 0\": only the built-in functions can be called "
     "(token \"__import__('os').system\")"),
])
def test_bad_specs_give_one_line_naming_the_spec_and_token(two, text, message):
    with pytest.raises(SpecError) as info:
        parse_spec(text, two)
    assert str(info.value) == message
    assert isinstance(info.value, ValueError)


def test_unrestricted_spec_on_a_mode_local_definition_says_how_to_restrict_it(two):
    with pytest.raises(SpecError, match=r"restrict the spec to the modes that define it"):
        parse_spec("x <= k", two)


@settings(max_examples=150, deadline=None)
@given(text=spec_texts())
def test_any_spec_text_gives_a_spec_or_a_one_line_spec_error(text):
    model = hybridlab.load_model(BALL)
    try:
        spec = parse_spec(text, model)
    except SpecError as exc:
        message = str(exc)
        assert message.startswith(f"spec {text!r}: ")
        assert "\n" not in message.replace(repr(text), "")
    else:
        assert isinstance(spec, Spec) and spec.rows and all(spec.rows.values())


def test_avoid_regions_from_boxes_and_polytopes(ball):
    box = Avoid(box={"h": (-1.0, 0.5), "v": (-3.0, 3.0)}).bind(ball)
    assert box.kind == "any" and box.strict and len(box.rows["fall"]) == 4
    # (h, v) = (0, 0) is inside, (1, 0) and (0, 4) are outside
    pts = {"inside": (0.0, 0.0), "above": (1.0, 0.0), "fast": (0.0, 4.0)}
    for name, (h, v) in pts.items():
        point = dict(zip(ball.symbolic.states, (h, v), strict=True))
        values = np.array([[float(r.subs(point))] for r in box.rows["fall"]])
        assert bool(box.violated(box.margin(values)[0])) == (name == "inside")
    poly = Avoid(polytope=([[1.0, 1.0]], [2.0]), modes=("fall",), name="h + v <= 2").bind(ball)
    assert poly.text == "h + v <= 2" and str(poly.rows["fall"][0]) == "1.0*h + 1.0*v - 2.0"
    with pytest.raises(SpecError, match="unknown state in box"):
        Avoid(box={"w": (0, 1)}).bind(ball)
    with pytest.raises(SpecError, match="exactly one of"):
        Avoid().bind(ball)
    with pytest.raises(SpecError, match=r"shape \(m, 2\)"):
        Avoid(polytope=([[1.0]], [2.0])).bind(ball)
    with pytest.raises(ValueError, match="at least one spec"):
        as_specs([], ball)


# ----------------------------------------------------------------------------- problem
def test_problem_arguments_are_checked_by_name(ball):
    with pytest.raises(ValueError, match="initial: unknown state 'w'"):
        HybridProblem.build(ball, initial={"w": (0, 1)}, t_end=1.0)
    with pytest.raises(ValueError, match=r"initial\['h'\] needs lo <= hi"):
        HybridProblem.build(ball, initial={"h": (2, 1)}, t_end=1.0)
    with pytest.raises(ValueError, match="params: unknown parameter 'G'"):
        HybridProblem.build(ball, initial={}, t_end=1.0, params={"G": 1.0})
    with pytest.raises(ValueError, match="inputs: 'e' is also given in params"):
        HybridProblem.build(ball, initial={}, t_end=1.0, params={"e": 0.5}, inputs={"e": (0, 1)})
    with pytest.raises(ValueError, match="t_end and t_start must be finite"):
        HybridProblem.build(ball, initial={}, t_end=math.inf)
    with pytest.raises(ValueError, match="scenario: unknown scenario 'fast'"):
        HybridProblem.build(ball, initial={}, t_end=1.0, scenario="fast")
    pb = HybridProblem.build(ball, initial={"h": 3.0}, t_end=1.0, scenario="benchmark")
    assert pb.dims == 0 and pb.x0.tolist() == [3.0, 0.0]
    assert pb.p0[ball.parameter_names.index("e")] == 0.95


# ----------------------------------------------------------------------------- falsification
def test_falsification_finds_the_exact_first_violation_instant_from_a_corner(ball):
    # from h0 = 10 (a corner of [5, 10]) the speed reaches 13 at t = 13/g, before the impact
    pb = HybridProblem.build(ball, initial={"h": (5.0, 10.0)}, t_end=2.0)
    found = falsify(pb, [parse_spec("v >= -13", ball)])
    cx = found.counterexample
    assert cx is not None and cx.spec == "v >= -13" and cx.mode == "fall"
    assert cx.initial == {"h": 10.0, "v": 0.0}
    assert cx.t == pytest.approx(13 / 9.81, abs=1e-12)
    assert cx.state["v"] == pytest.approx(-13.0, abs=1e-10)
    # the worst point of that run is the impact, sqrt(2 g h0)
    assert cx.t_worst == pytest.approx(math.sqrt(2 * 10 / 9.81), abs=1e-8)
    assert cx.margin == pytest.approx(13 - math.sqrt(2 * 9.81 * 10), abs=1e-7)


def test_a_violation_between_integrator_steps_is_found_in_dense_time():
    # x = cos t dips below -0.9999999 only for |t - pi| < 4.5e-4, far inside one DOP853 step
    osc = hybridlab.compile_model(hybridlab.loads_model(OSCILLATOR))
    # tight tolerances: near the dip the crossing time is 2000 times as sensitive as x
    tight = hybridlab.SimulationOptions(rtol=1e-12, atol=1e-14)
    pb = HybridProblem.build(osc, initial={}, t_end=4.0, options=tight)
    result = hybridlab.simulate(pb)
    assert np.abs(result.t - math.pi).min() > 0.01  # no stored point in the dip
    found = falsify(pb, [parse_spec("x >= -0.9999999", osc)])
    cx = found.counterexample
    assert cx is not None and found.runs == 1
    assert cx.t == pytest.approx(math.pi - math.acos(0.9999999), abs=1e-8)
    assert cx.t_worst == pytest.approx(math.pi, abs=1e-5)
    assert cx.margin == pytest.approx(-1e-7, rel=1e-3)


def test_counterexample_replays_bit_for_bit(ball):
    pb = HybridProblem.build(ball, initial={"h": (5.0, 10.0)}, t_end=3.0, params={"e": (0.5, 0.9)})
    # after the first bounce v = e*sqrt(2 g h0): above 11 needs e*sqrt(2 g h0) > 11
    cx = falsify(pb, [parse_spec("v <= 11", ball)]).counterexample
    assert cx is not None
    assert cx.parameters["e"] * math.sqrt(2 * 9.81 * cx.initial["h"]) > 11
    assert cx.t == pytest.approx(math.sqrt(2 * cx.initial["h"] / 9.81), abs=1e-9)  # the bounce
    first, again = cx.replay(), cx.replay()
    assert np.array_equal(first.t, again.t) and np.array_equal(first.y, again.y)
    assert [e.t for e in first.events] == [e.t for e in again.events]
    assert first.parameters["e"] == cx.parameters["e"]
    assert first(cx.t_worst)[1] == pytest.approx(11 - cx.margin, abs=1e-9)


_ENGINES = """
import sys
import hybridlab
from hybridlab.verify import check_safety
osc = hybridlab.loads_model(sys.argv[1])
for model, t_end, spec in (("models/bouncing_ball.toml", 2.0, "v >= -13"),
                           (osc, 200.0, "x >= -0.99999")):
    v = check_safety(model, initial={}, t_end=t_end, safe=spec, prove=False)
    cx = v.counterexample
    again = cx.replay()
    print(v.status.name, cx.options.backend,
          "hybridlab.simulation.compiled.backend" in sys.modules,
          again.stats["backend"] == cx.options.backend)
"""


def test_short_runs_are_falsified_on_the_reference_engine_and_long_ones_compiled():
    import subprocess
    import sys

    pytest.importorskip("numba")
    out = subprocess.run([sys.executable, "-c", _ENGINES, OSCILLATOR], capture_output=True,
                         text=True, check=True, cwd=ROOT).stdout.split("\n")
    # the ball's runs are a few steps: no kernel loaded; the oscillator's take thousands
    assert out[0] == "UNSAFE reference False True"
    assert out[1] == "UNSAFE compiled True True"


def test_uncertain_constant_inputs_are_sampled_and_reported():
    drift = hybridlab.compile_model(hybridlab.loads_model(DRIFT))
    pb = HybridProblem.build(drift, initial={"x": (0.0, 0.5)}, t_end=2.0, inputs={"u": (-1.0, 1.0)})
    cx = falsify(pb, [parse_spec("x <= 1.75", drift)]).counterexample
    assert cx is not None and cx.inputs == {"u": 1.0} and cx.parameters == {"u": 1.0}
    assert cx.t == pytest.approx(1.75 - cx.initial["x"], abs=1e-12)


def test_local_search_finds_a_small_unsafe_region_that_samples_miss():
    drift = hybridlab.compile_model(hybridlab.loads_model(DRIFT))
    spec = parse_spec("(x - 0.31)**2 + (y - 0.62)**2 >= 0.03**2", drift)
    pb = HybridProblem.build(drift, initial={"x": (0.0, 1.0), "y": (0.0, 1.0)}, t_end=0.5)
    options = FalsifyOptions(samples=4, local_evals=0)
    assert falsify(pb, [spec], options).counterexample is None
    found = falsify(pb, [spec], FalsifyOptions(samples=4, local_evals=60))
    cx = found.counterexample
    assert cx is not None and found.runs <= 1 + 4 + 4 + 60
    assert math.hypot(cx.initial["x"] - 0.31, cx.initial["y"] - 0.62) < 0.03


def test_no_violation_reports_the_lowest_simulated_margin(ball):
    pb = HybridProblem.build(ball, initial={"h": (5.0, 10.0)}, t_end=2.0)
    found = falsify(pb, [parse_spec("h <= 10.5", ball)], FalsifyOptions(local_evals=5))
    assert found.counterexample is None
    assert found.margins["h <= 10.5"] == pytest.approx(0.5, abs=1e-12)
    assert found.runs == 1 + 2 + FalsifyOptions().samples + 5


# ----------------------------------------------------------------------------- verdicts
def test_unsafe_verdict_and_assert_safe_message(ball):
    verdict = check_safety(ball, initial={"h": (5.0, 10.0)}, t_end=2.0, safe=["v >= -13"])
    assert verdict.status is VerdictStatus.UNSAFE and verdict.margin < 0
    assert verdict.reach is None  # reachability is not needed once a violation is found
    data = verdict.as_dict()
    assert data["verdict"] == "UNSAFE" and data["counterexample"]["t"] == verdict.counterexample.t
    with pytest.raises(AssertionError) as info:
        assert_safe(ball, initial={"h": (5.0, 10.0)}, t_end=2.0, safe=["h >= -1", "v >= -13"])
    message = str(info.value)
    assert message.splitlines()[0] == (
        f"UNSAFE: spec 'v >= -13' violated at t={13 / 9.81:.10g} in mode 'fall'")
    assert "state: h=1.38634, v=-13" in message
    assert isinstance(info.value, SafetyAssertionError)
    assert info.value.verdict.counterexample.initial["h"] == 10.0


def test_unknown_without_reachability_is_an_assertion_unless_allowed(ball):
    kwargs = dict(initial={"h": (5.0, 10.0)}, t_end=1.0, safe="h >= -1", prove=False,
                  falsify_options=FalsifyOptions(samples=2, local_evals=0))
    with pytest.raises(SafetyAssertionError, match=r"^UNKNOWN: reachability was not attempted"):
        assert_safe(ball, **kwargs)
    verdict = assert_safe(ball, allow_unknown=True, **kwargs)
    assert verdict.status is VerdictStatus.UNKNOWN and verdict.margin is None
    assert verdict.falsification.runs == 1 + 2 + 2


DECAY = """
name = "decay"
parameters = { k = 1.0 }
states = { x = 1.0 }
[modes.run]
flow = { x = "-k*x" }
[initial]
mode = "run"
"""


def test_safe_with_a_proven_margin_on_a_closed_form():
    # x = x0 exp(-t) with x0 in [1, 2]: x >= exp(-1) = 0.368 and x <= 2 on [0, 1]
    verdict = check_safety(hybridlab.loads_model(DECAY), initial={"x": (1.0, 2.0)}, t_end=1.0,
                           safe=["x >= 0.3", "x <= 2.05"],
                           falsify_options=FalsifyOptions(samples=4, local_evals=5))
    assert verdict.status is VerdictStatus.SAFE, verdict.reason
    assert verdict.reach.complete and 0 <= verdict.margin <= 0.05
    lows = {b.spec: b.lower for b in verdict.spec_bounds}
    assert 0.0 <= lows["x >= 0.3"] <= math.exp(-1.0) - 0.3
    assert verdict.as_dict()["verdict"] == "SAFE"


def test_a_misspelt_option_fails_before_any_work(ball):
    with pytest.raises(TypeError, match="unknown reach option.*rtoll"):
        check_safety(ball, initial={}, t_end=1.0, safe="h <= 20", prove=False, rtoll=1e-9)


def test_a_quick_proof_needs_no_simulation(monkeypatch):
    from hybridlab.reachability import verdict as verdicts

    monkeypatch.setattr(verdicts, "_QUICK_PROOF_S", 120.0)  # a loaded machine is slow
    verdict = check_safety(hybridlab.loads_model(DECAY), initial={"x": (1.0, 2.0)}, t_end=1.0,
                           safe=["x >= 0.3", "x <= 2.05"])
    assert verdict.status is VerdictStatus.SAFE, verdict.reason
    assert verdict.falsification is None and "falsification" not in verdict.as_dict()
    # an unproved spec: the quick attempt stops at its first unproved set, the flowpipes are
    # computed again at the default step after the falsification
    unproved = check_safety(hybridlab.loads_model(DECAY), initial={"x": (1.0, 2.0)},
                            t_end=1.0, safe=[f"x >= {math.exp(-1.0) - 1e-9!r}"], step=0.1,
                            falsify_options=FalsifyOptions(samples=2, local_evals=0))
    assert unproved.status is VerdictStatus.UNKNOWN and unproved.reach.complete
    assert unproved.falsification.runs == 1 + 2 + 2


def test_reach_stops_at_the_first_set_that_does_not_prove_a_spec():
    decay = hybridlab.compile_model(hybridlab.loads_model(DECAY))
    specs = as_specs(["x >= 0.5"], decay)  # x = x0 exp(-t) falls below 0.5 at t = ln 2
    result = hybridlab.reach(decay, initial={"x": (1.0, 2.0)}, t_end=1.0, step=0.01,
                             stop_unproved=specs)
    assert not result.complete
    assert result.incomplete_reasons[0].startswith(
        "stopped at the first set that does not prove spec 'x >= 0.5' (t in [0.68")
    # the flowpipe's bound crosses 0.5 a step before t = ln 2, and the analysis ends there
    assert len(result.sets) == 69 and result.sets[-1].t[1] < math.log(2.0)
    # the set at the end of that step already holds states below 0.5: not only between steps
    assert result.stopped_unproved and not result.unproved_between_steps
    # a margin of 1e-4 at t = 1: the sets at the step instants prove it, the set over the
    # last step (rounded, with its between-step remainder) does not
    thin = hybridlab.reach(decay, initial={"x": (1.0, 2.0)}, t_end=1.0, step=0.01,
                           stop_unproved=as_specs([f"x >= {math.exp(-1.0) - 1e-4!r}"], decay))
    assert thin.stopped_unproved and thin.unproved_between_steps
    full = hybridlab.reach(decay, initial={"x": (1.0, 2.0)}, t_end=1.0, step=0.01)
    assert full.complete and len(full.sets) == 100


def test_unknown_when_the_reach_is_cut_by_max_jumps(ball):
    verdict = check_safety(ball, initial={"h": (5.0, 6.0)}, t_end=3.0, safe=["h >= -1"],
                           max_jumps=0, falsify_options=FalsifyOptions(samples=2, local_evals=0))
    assert verdict.status is VerdictStatus.UNKNOWN
    assert verdict.reason.startswith("the reach result is incomplete (")
    assert "falsification found no violation in 5 simulation(s)" in verdict.reason
    assert not verdict.reach.complete


def test_unknown_when_the_bound_is_too_coarse_names_spec_mode_and_time():
    # a spec that holds with a margin of 1e-9 cannot be proved by a coarse flowpipe
    verdict = check_safety(hybridlab.loads_model(DECAY), initial={"x": (1.0, 2.0)}, t_end=1.0,
                           safe=[f"x >= {math.exp(-1.0) - 1e-9!r}"], step=0.1,
                           falsify_options=FalsifyOptions(samples=2, local_evals=0))
    assert verdict.status is VerdictStatus.UNKNOWN
    assert verdict.margin < 0 and verdict.where.mode == "run"
    assert "while no simulation violated it: the overlap may be spurious" in verdict.reason
    assert verdict.where.t[1] == pytest.approx(1.0)


def test_an_unproved_spec_is_refined_by_halving_the_default_step():
    # the flowpipe's lower bound near t = 1 is exp(-1) - 0.18 r: the default step
    # (1/400) misses a margin of 1e-4 by 3.6e-4, the step halved three times proves it
    decay = hybridlab.loads_model(DECAY)
    spec = f"x >= {math.exp(-1.0) - 1e-4!r}"
    quiet = FalsifyOptions(samples=2, local_evals=0)
    verdict = check_safety(decay, initial={"x": (1.0, 2.0)}, t_end=1.0, safe=spec,
                           falsify_options=quiet)
    assert verdict.status is VerdictStatus.SAFE, verdict.reason
    assert verdict.reason.endswith("(refined: step=0.0003125)")
    assert verdict.reach.options.step == 1 / 400 / 8 and 0 < verdict.margin < 1e-4
    # the default step failed only between step instants: refined before any simulation
    assert verdict.falsification is None
    chosen = check_safety(decay, initial={"x": (1.0, 2.0)}, t_end=1.0, safe=spec,
                          falsify_options=quiet, step=1 / 400, split=1)
    assert chosen.status is VerdictStatus.UNKNOWN and "refined" not in chosen.reason
    # a chosen step is kept; the initial set, left to the verdict, is bisected instead: the
    # dense-time bloat grows with the set's width, even for this affine flow
    pieces = check_safety(decay, initial={"x": (1.0, 2.0)}, t_end=1.0, safe=spec,
                          falsify_options=quiet, step=1 / 400)
    assert pieces.status is VerdictStatus.SAFE and "split='auto'" in pieces.reason
    assert pieces.reach.options.step == 1 / 400 and pieces.reach.pieces > 1
    assert not pieces.reach.nonlinear


def test_a_verdict_prepares_its_system_once_for_all_its_analyses(monkeypatch):
    # the refinements of the test above are four analyses; the system (and the derivatives
    # its modes take) is built for the first and shared by the others
    import hybridlab.reachability.api as api

    prepared, analyses = [], []
    monkeypatch.setattr(api, "prepare_reach",
                        lambda problem, real=api.prepare_reach: prepared.append(real(problem))
                        or prepared[-1])
    monkeypatch.setattr(api, "reach_prepared", lambda prep, real=api.reach_prepared, **kw:
                        analyses.append(prep) or real(prep, **kw))
    decay = hybridlab.loads_model(DECAY)
    verdict = check_safety(decay, initial={"x": (1.0, 2.0)}, t_end=1.0,
                           safe=f"x >= {math.exp(-1.0) - 1e-4!r}",
                           falsify_options=FalsifyOptions(samples=2, local_evals=0))
    assert verdict.status is VerdictStatus.SAFE
    assert len(prepared) == 1 and len(analyses) >= 4
    assert all(prep is prepared[0] for prep in analyses)


def test_a_verdict_keeps_at_most_max_memory_of_sets_over_all_its_analyses():
    # the refinement above ends at 3,200 sets; while it runs, the coarser attempts it
    # started from are held, so a budget of 1.05 times its own sets does not suffice
    decay = hybridlab.loads_model(DECAY)
    kw = dict(initial={"x": (1.0, 2.0)}, t_end=1.0, safe=f"x >= {math.exp(-1.0) - 1e-4!r}",
              falsify_options=FalsifyOptions(samples=2, local_evals=0))
    proved = check_safety(decay, **kw)
    assert proved.status is VerdictStatus.SAFE and len(proved.reach.sets) == 3200
    short = check_safety(decay, max_memory=1.05 * proved.reach.nbytes / 2**30, **kw)
    assert short.status is VerdictStatus.UNKNOWN
    assert "held for the other analyses sharing the budget" in short.reason


def test_executor_runs_split_pieces_and_a_bad_one_fails_before_any_work():
    kw = dict(initial={"h": (5.0, 6.0)}, t_end=0.5, safe="h >= -1", split=2,
              falsify_options=FalsifyOptions(samples=0, local_evals=0))
    serial = check_safety(BALL, **kw)
    threads = assert_safe(BALL, executor="threads", **kw)
    assert serial.status is threads.status is VerdictStatus.SAFE
    assert threads.reach.bounds == serial.reach.bounds
    with pytest.raises(ValueError, match="^executor: .*got 'cluster'") as info:
        check_safety(BALL, executor="cluster", **kw)
    assert isinstance(info.value, hybridlab.errors.HybridlabError) and "\n" not in str(info.value)


def test_a_set_too_wide_for_the_linearisation_is_split_until_proved(models_dir):
    from hybridlab.io import load_spaceex

    vdp = load_spaceex(models_dir / "spaceex" / "vanderpol.xml",
                       models_dir / "spaceex" / "vanderpol.cfg")
    kw = {k: v for k, v in vdp.reach_kwargs().items() if k != "step"}
    kw["initial"] = {"x": (1.1, 1.7), "y": (2.3, 2.5)}  # twice the ARCH box
    whole = hybridlab.reach(vdp.model, **{**kw, "t_end": 4.0})
    assert not whole.complete and whole.too_wide  # one set: the remainder blows up
    # the step and the flowpipe are the caller's here, so only the split can prove it
    verdict = check_safety(vdp.model, safe=vdp.safe_specs(), **{**kw, "t_end": 4.0},
                           step=0.01, flowpipe="zonotope",
                           falsify_options=FalsifyOptions(samples=0, local_evals=0))
    assert verdict.status is VerdictStatus.SAFE
    # bisected where it failed: two halves suffice where equal pieces took 2 x 2
    assert "split='auto'; 2 pieces" in verdict.reason and verdict.reach.pieces == 2
    # an explicit split is the caller's: no other is tried
    kept = check_safety(vdp.model, safe=vdp.safe_specs(), **{**kw, "t_end": 4.0}, split=1,
                        step=0.01, flowpipe="zonotope",
                        falsify_options=FalsifyOptions(samples=0, local_evals=0))
    assert kept.status is VerdictStatus.UNKNOWN and "split=" not in kept.reason
