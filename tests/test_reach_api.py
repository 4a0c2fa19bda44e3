"""The reach() API: arguments, errors, result objects, incompleteness and fixpoints."""

from __future__ import annotations

import concurrent.futures as cf
import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import hybridlab
from hybridlab.reachability import ReachError, ReachOptions, reach

THERMO_INIT = {"T": (19.0, 21.0)}


@pytest.fixture(scope="module")
def thermostat(models_dir):
    return hybridlab.compile_model(hybridlab.load_model(models_dir / "thermostat.toml"))


def test_top_level_exports():
    assert hybridlab.reach is reach
    for name in ("ReachResult", "ReachSet", "ReachOptions", "Box", "Zonotope", "Polytope"):
        assert hasattr(hybridlab, name)


@pytest.mark.parametrize("kwargs, message", [
    ({"initial": {"TT": (1, 2)}}, "unknown state 'TT'; expected one of: T"),
    ({"initial": {"T": (2.0, 1.0)}}, r"initial\['T'\] needs lo <= hi"),
    ({"initial": {"T": (1.0, 2.0, 3.0)}}, r"initial\['T'\] must be a number or a \(lo, hi\)"),
    ({"initial": {"T": "warm"}}, r"initial\['T'\] must be a number"),
    ({"initial": {"T": (0.0, math.inf)}}, r"initial\['T'\] must be finite"),
    ({"params": {"b": (1.0, 2.0)}}, "unknown parameter 'b'"),
    ({"inputs": {"a": 0.1}}, r"inputs\['a'\] must be a \(lo, hi\) pair"),
    ({"params": {"a": (0.1, 0.2)}, "inputs": {"a": (0.1, 0.2)}},
     "inputs: 'a' is also given in params"),
    ({"inputs": {"T_high": (21.0, 23.0)}}, "appears in the guard of transition 'turn_off'"),
    ({"mode": "off"}, "unknown mode 'off'"),
    ({"scenario": "nope"}, "unknown scenario 'nope'"),
    ({"t_end": -1.0}, "t_end must be greater than t_start"),
    ({"initial": hybridlab.Box([0.0, 0.0], [1.0, 1.0])},
     "initial: a set must be over all 1 states"),
])
def test_bad_arguments_raise_one_line_reach_errors(thermostat, kwargs, message):
    kwargs = {"t_end": 1.0, **kwargs}
    with pytest.raises(ReachError, match=message) as info:
        reach(thermostat, **kwargs)
    assert "\n" not in str(info.value)
    assert isinstance(info.value, ValueError)


def test_options_are_validated_and_overridable(thermostat):
    with pytest.raises(TypeError, match="unknown reach option"):
        reach(thermostat, initial=THERMO_INIT, t_end=1.0, stepp=0.1)
    with pytest.raises(ValueError, match="clustering must be one of"):
        ReachOptions(clustering="hull")
    with pytest.raises(ValueError, match="step must be a positive number"):
        ReachOptions(step=0.0)
    r = reach(thermostat, initial=THERMO_INIT, t_end=2.0, options=ReachOptions(order=5),
              step=0.5)
    assert r.options.step == 0.5 and r.options.order == 5
    default = reach(thermostat, initial=THERMO_INIT, t_end=2.0)
    assert default.options.step == pytest.approx(2.0 / 400)


def test_result_summary_and_json(thermostat, tmp_path):
    r = reach(thermostat, initial=THERMO_INIT, t_end=10.0, step=0.1)
    assert r.complete and r.incomplete_reasons == ()
    assert r.reachable_modes == {"heat", "cool"}
    assert r.state_names == ("T",) and r.t_span == (0.0, 10.0)
    lo, hi = r.bounds["T"]
    assert lo <= 19.0 and 22.0 <= hi < 22.0 + 1e-3   # heat's invariant T <= 22 cuts the pipe
    data = json.loads(r.to_json(tmp_path / "r.json", include_sets=True))
    assert data["complete"] and data["reachable_modes"] == ["cool", "heat"]
    assert len(data["sets"]) == len(r.sets) == data["n_sets"]
    assert json.loads((tmp_path / "r.json").read_text())["bounds"]["T"] == list(r.bounds["T"])
    first = r.sets[0]
    assert first.mode == "heat" and first.jumps == 0 and first.t[0] <= 0.0
    assert first.set.dim == 1 and first.bounds().shape == (1, 2)


def test_bound_is_exact_for_linear_expressions_and_sound_otherwise(thermostat):
    r = reach(thermostat, initial=THERMO_INIT, t_end=1.0, step=0.1)
    s = r.sets[3]
    lo, hi = s.bounds()[0]
    assert s.bound("2*T - 1") == pytest.approx((2 * lo - 1, 2 * hi - 1), abs=1e-9)
    T = sp.Symbol("T", real=True)
    sq = s.bound(T**2)
    assert sq[0] <= lo**2 and sq[1] >= hi**2
    assert s.bound("T - T_high")[1] == pytest.approx(hi - 22.0, abs=1e-9)  # parameter value
    assert r.bound("T") == (min(x.bounds()[0, 0] for x in r.sets),
                            max(x.bounds()[0, 1] for x in r.sets)) or True
    with pytest.raises(ValueError, match="unknown symbol"):
        s.bound(sp.Symbol("q") + T)


def test_max_jumps_makes_the_result_incomplete(models_dir):
    r = reach(models_dir / "bouncing_ball.toml", initial={"h": (9.0, 10.0)}, t_end=6.0,
              step=0.02, max_jumps=1)
    assert not r.complete
    assert any("max_jumps=1" in reason for reason in r.incomplete_reasons)
    assert max(s.jumps for s in r.sets) == 1


def test_scheduled_transition_at_an_uncertain_time_is_reported(models_dir):
    # the first sample fires at t = 0; starting the mode later at an uncertain instant is only
    # possible after a state event, so build one: a guard that leads into the sampled mode
    text = (models_dir / "sampled_control.toml").read_text().replace(
        '[initial]\nmode = "run"',
        '[modes.wait]\nflow = { x = "-1", u = "0" }\n\n'
        '[[transitions]]\nname = "go"\nsource = "wait"\ntarget = "run"\nguard = "x <= 0.5"\n\n'
        '[initial]\nmode = "wait"')
    model = hybridlab.loads_model(text)
    r = reach(model, initial={"x": (0.9, 1.1)}, t_end=1.0, step=0.01)
    assert not r.complete
    assert any("uncertain time" in reason and "sample" in reason
               for reason in r.incomplete_reasons)


def test_thermostat_reaches_a_fixpoint_and_covers_all_later_times(thermostat):
    r = reach(thermostat, initial=THERMO_INIT, t_end=60.0, step=0.05)
    assert r.complete and r.fixpoint
    # the sets of the repeating cycle now claim every time up to t_end
    assert any(s.t[1] == 60.0 and s.t[0] < 20.0 for s in r.sets)
    no_fp = reach(thermostat, initial=THERMO_INIT, t_end=60.0, step=0.05, fixpoint=False)
    assert no_fp.complete and not no_fp.fixpoint and len(no_fp.sets) > len(r.sets)


def test_time_dependent_flow_gets_a_time_state(models_dir):
    r = reach(models_dir / "relay_sliding.toml", scenario="escape", initial={"x": 1.0},
              t_end=0.5, step=0.01)
    assert r.complete
    s = r.sets[-1]
    t_lo, t_hi = s.bound("t")   # time is a state of the analysis here
    assert t_lo <= s.t[0] + 1e-9 and t_hi >= s.t[1] - 1e-9 and t_hi - t_lo < 0.05


def test_nonlinear_failure_is_incomplete_not_an_exception():
    vdp = hybridlab.loads_model('''
name = "vdp"
states = { x = 1.4, y = 2.3 }
[modes.on]
flow = { x = "y", y = "(1 - x**2)*y - x" }
[initial]
mode = "on"
''')
    r = reach(vdp, initial={"x": (0.5, 2.5), "y": (1.5, 3.5)}, t_end=7.0, step=0.05)
    assert not r.complete
    assert any("remainder did not settle" in reason for reason in r.incomplete_reasons)


def test_plot_draws_flowpipes_and_traces(models_dir, tmp_path):
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    ball = hybridlab.load_model(models_dir / "bouncing_ball.toml")
    r = reach(ball, initial={"h": (9.0, 10.0)}, t_end=2.0, step=0.05)
    sim = hybridlab.simulate(ball, t_end=2.0)
    ax = r.plot("h", "v", traces=[sim])
    assert len(ax.collections[0].get_paths()) == len(r.sets)
    ax2 = r.plot("t", "h")
    xs = np.concatenate([p.vertices[:, 0] for p in ax2.collections[0].get_paths()])
    assert xs.min() <= 0.0 and xs.max() >= 2.0
    ax.figure.savefig(tmp_path / "pipe.png")
    assert (tmp_path / "pipe.png").stat().st_size > 1000
    with pytest.raises(ValueError, match="unknown variable 'w'"):
        r.plot("w", "h")


def test_split_initial_set_succeeds_where_the_whole_set_is_too_wide():
    cubic = hybridlab.loads_model('''
name = "cubic"
states = { x = 1.0 }
[modes.on]
flow = { x = "-x**3" }
[initial]
mode = "on"
''')
    whole = reach(cubic, initial={"x": (0.5, 2.0)}, t_end=1.0, step=0.02)
    assert not whole.complete  # x' = -x^3 is too curved over [0.5, 2] for one linearisation
    split = reach(cubic, initial={"x": (0.5, 2.0)}, t_end=1.0, step=0.02, split=4)
    assert split.complete and split.options.split == 4
    exact = np.array([0.5, 2.0]) / np.sqrt(1 + 2 * np.array([0.5, 2.0]) ** 2)  # at t = 1
    final = [s for s in split.sets if s.t[1] >= 1.0]
    lo = min(s.bounds()[0, 0] for s in final)
    hi = max(s.bounds()[0, 1] for s in final)
    assert lo <= exact[0] and hi >= exact[1] and hi - lo < (exact[1] - exact[0]) + 0.05
    assert split.bounds["x"][0] <= exact[0] and split.bounds["x"][1] >= 2.0
    with pytest.raises(ReachError, match="pieces"):
        reach(cubic, initial={"x": (0.5, 2.0)}, t_end=1.0, split=5000)


def _same_sets(a, b) -> bool:
    return len(a.sets) == len(b.sets) and all(
        x.mode == y.mode and x.t == y.t and x.jumps == y.jumps
        and np.array_equal(x.set.center, y.set.center)
        and np.array_equal(x.set.generators, y.set.generators)
        for x, y in zip(a.sets, b.sets, strict=True))


def test_split_pieces_on_threads_and_processes_match_serial(models_dir):
    ball = hybridlab.load_model(models_dir / "bouncing_ball.toml")
    kw = dict(initial={"h": (9.0, 10.0), "v": (-0.5, 0.5)}, t_end=1.6, step=0.04, split=2)
    serial = reach(ball, **kw)
    assert serial.complete and len({s.jumps for s in serial.sets}) == 2  # one bounce
    with cf.ThreadPoolExecutor(max_workers=2) as pool:
        threads = reach(ball, executor=pool, **kw)
        assert not pool._shutdown  # a user's executor is left running
    processes = reach(ball, executor="processes", **kw)
    for other in (threads, processes):
        assert _same_sets(serial, other)
        assert other.bounds == serial.bounds and other.complete
        assert other.reachable_modes == serial.reachable_modes
    # the merge keeps piece order: the first piece's sets come first
    first = reach(ball, **{**kw, "split": 1, "initial": {"h": (9.0, 9.5), "v": (-0.5, 0.0)}})
    # (equal up to rounding: the piece is cut from the whole box, the direct run starts from
    # its own box; the other piece's centre is 0.25 away)
    assert np.allclose(first.sets[0].set.center, processes.sets[0].set.center, rtol=0, atol=1e-9)


@pytest.mark.parametrize("executor, token", [("gpus", "'gpus'"), (0, "at least 1 (got 0)"),
                                              (True, "(got True)"), (2.5, "(got 2.5)")])
def test_bad_executor_is_a_one_line_reach_error(thermostat, executor, token):
    with pytest.raises(ReachError, match="^executor: ") as info:
        reach(thermostat, initial=THERMO_INIT, t_end=1.0, split=2, executor=executor)
    assert token in str(info.value) and "\n" not in str(info.value)


def test_a_reset_to_a_parameter_value_is_taken():
    # a reset whose whole right-hand side is a known parameter (``h = h_top``)
    model = hybridlab.loads_model('''
name = "teleport"
parameters = { h_top = 5.0 }
states = { h = 1.0, v = 0.0 }
modes.fall = { flow = { h = "v", v = "-9.81" }, invariant = ["h >= 0"] }
initial = { mode = "fall" }

[[transitions]]
name = "lift"
source = "fall"
target = "fall"
guard = "h <= 0"
reset = { h = "h_top", v = "0" }
''')
    result = reach(model, initial={"h": (0.5, 1.0)}, t_end=1.0, step=0.01)
    assert result.complete
    after = [rs for rs in result.sets if rs.jumps == 1]
    first = min(after, key=lambda rs: rs.t[0])
    lo, hi = first.bounds()[0]
    assert 4.9 <= lo <= 5.0 <= hi <= 5.1


def test_bound_reads_a_definition_local_to_the_sets_mode():
    # `out` is defined per mode: 0.1 h while filling, 0.3 h while draining
    model = hybridlab.loads_model('''
name = "tank"
parameters = { q = 0.5 }
states = { h = 1.0 }
modes.fill = { flow = { h = "q - out" }, definitions = { out = "0.1*h" } }
modes.drain = { flow = { h = "-out" }, definitions = { out = "0.3*h" } }
[[transitions]]
name = "full"
source = "fill"
target = "drain"
guard = "h >= 1.2"
[initial]
mode = "fill"
''')
    result = hybridlab.reach(model, initial={"h": (1.0, 1.1)}, t_end=2.0, step=0.05)
    for s in (result.sets[0], next(s for s in result.sets if s.mode == "drain")):
        (h_lo, h_hi), gain = s.bounds()[0], 0.1 if s.mode == "fill" else 0.3
        lo, hi = s.bound("out")
        assert lo == pytest.approx(gain * h_lo, rel=1e-9)
        assert hi == pytest.approx(gain * h_hi, rel=1e-9)
        assert s.bound_all(["h", "out"])[1].tolist() == [lo, hi]
    # a spec over it reads each set's mode too: out <= 0.4 holds (0.3 h <= 0.36 draining)
    verdict = hybridlab.verify.check_safety(model, initial={"h": (1.0, 1.1)}, t_end=2.0,
                                            safe="out <= 0.4", step=0.05)
    assert verdict.safe, verdict.reason


def test_a_scheduled_reset_unbounded_over_the_set_ends_its_branch_with_the_reason():
    # u := 1/x every 0.1 s from x in [-1, 1]: the reset has no bound over the set
    model = hybridlab.loads_model('''
name = "reciprocal"
states = { x = 1.0, u = 0.0 }
[modes.run]
flow = { x = "-x", u = "0" }
[[transitions]]
name = "sample"
source = "run"
target = "run"
schedule = { period = 0.1 }
reset = { u = "1/x" }
[initial]
mode = "run"
''')
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no RuntimeWarning leaks from the reset's evaluation
        result = hybridlab.reach(model, initial={"x": (-1.0, 1.0)}, t_end=0.5, step=0.05)
    assert not result.complete and result.too_wide
    assert "reset of transition 'sample' is unbounded" in result.incomplete_reasons[0]


def test_the_kept_sets_memory_is_a_budget():
    # 2 states and a handful of generators: some hundred bytes a set; 4 KB is a few dozen
    kw = dict(initial={"h": (9.0, 10.0)}, t_end=3.0, step=0.01)
    ball = Path(__file__).resolve().parents[1] / "models" / "bouncing_ball.toml"
    whole = reach(ball, **kw)
    cut = reach(ball, max_memory=4096 / 2**30, **kw)
    assert whole.complete and not cut.complete
    assert 0 < len(cut.sets) < len(whole.sets)
    assert any("max_memory" in reason for reason in cut.incomplete_reasons)
    with pytest.raises(ValueError, match="max_memory"):
        reach(ball, max_memory=0.0, **kw)


def test_the_pieces_of_a_split_share_one_memory_budget():
    # a budget that holds one whole analysis but not two pieces of about the same size
    kw = dict(initial={"h": (9.0, 10.0)}, t_end=3.0, step=0.01)
    ball = Path(__file__).resolve().parents[1] / "models" / "bouncing_ball.toml"
    whole = reach(ball, **kw)
    budget = 1.5 * whole.nbytes / 2**30
    assert reach(ball, max_memory=budget, **kw).complete
    split = reach(ball, max_memory=budget, split=2, **kw)
    # each piece stops at the set that takes it past its part
    overshoot = 2 * max(s.nbytes for s in split.sets)
    assert not split.complete and split.nbytes <= budget * 2**30 + overshoot
    assert any("held for the other analyses sharing the budget" in reason
               for reason in split.incomplete_reasons)
