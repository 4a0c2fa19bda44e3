"""Steps proven quiet by interval bounds (``compiled/bounds.py``): sound enclosures, same events.

* every interval function of ``interval_ops`` encloses the point function on its intervals;
* the generated box ops enclose the point ops of every bundled model at points of the box;
* ``state_box`` encloses the dense output the sampler evaluates;
* a run with ``prove_quiet_steps`` has bit for bit the events, final state and status of a
  run that samples every step, and it does skip steps.
"""

from __future__ import annotations

import ctypes
import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

import hybridlab

numba = pytest.importorskip("numba")

from hybridlab.simulation.compiled import interval_ops as iv  # noqa: E402
from hybridlab.simulation.compiled.backend import prepare  # noqa: E402
from hybridlab.simulation.compiled.bounds import state_box  # noqa: E402
from hybridlab.simulation.compiled.integrate import DOP853 as DOP853_CODE  # noqa: E402
from hybridlab.simulation.compiled.integrate import RK45 as RK45_CODE  # noqa: E402
from hybridlab.simulation.compiled.integrate import dense_eval  # noqa: E402
from hybridlab.simulation.compiled.opcodes import (  # noqa: E402
    OP_GUARD,
    OP_GUARD_BOX,
    OP_INV_BOX,
    OP_SWITCH,
    OP_SWITCH_BOX,
)

_floats = st.floats(-50.0, 50.0, allow_nan=False)


def _interval(draw_pair):
    a, b = draw_pair
    return (a, b) if a <= b else (b, a)


_intervals = st.tuples(_floats, _floats).map(_interval)

_UNARY = [(iv.i_sin, math.sin, None), (iv.i_cos, math.cos, None),
          (iv.i_exp, math.exp, (-50.0, 30.0)), (iv.i_log, math.log, (1e-3, 50.0)),
          (iv.i_sqrt, math.sqrt, (0.0, 50.0)), (iv.i_abs, abs, None),
          (iv.i_atan, math.atan, None), (iv.i_tanh, math.tanh, None),
          (iv.i_sinh, math.sinh, (-20.0, 20.0)), (iv.i_cosh, math.cosh, (-20.0, 20.0)),
          (iv.i_asin, math.asin, (-1.0, 1.0)), (iv.i_acos, math.acos, (-1.0, 1.0)),
          (iv.i_tan, math.tan, (-1.5, 1.5)),
          (iv.i_heaviside, lambda v: 0.0 if v < 0 else (1.0 if v > 0 else 0.5), None),
          (iv.i_sign, lambda v: 0.0 if v == 0 else math.copysign(1.0, v), None),
          (iv.i_neg, lambda v: -v, None)]
_BINARY = [(iv.i_add, lambda a, b: a + b), (iv.i_sub, lambda a, b: a - b),
           (iv.i_mul, lambda a, b: a * b), (iv.i_div, lambda a, b: a / b),
           (iv.i_min, min), (iv.i_max, max)]


def _points(lo, hi, k=9):
    return [lo, hi, *np.linspace(lo, hi, k)[1:-1]]


@settings(max_examples=150, deadline=None)
@given(box=_intervals, which=st.integers(0, len(_UNARY) - 1))
def test_unary_interval_functions_enclose_the_point_function(box, which):
    fn, point, domain = _UNARY[which]
    lo, hi = box
    if domain is not None:
        lo, hi = np.clip([lo, hi], *domain)
    out_lo, out_hi = fn(lo, hi)
    assert out_lo <= out_hi
    for v in _points(lo, hi, 101):
        assert out_lo <= point(v) <= out_hi


@settings(max_examples=150, deadline=None)
@given(a=_intervals, b=_intervals, which=st.integers(0, len(_BINARY) - 1))
@example(a=(0.0, 0.0), b=(0.0, 0.0), which=3)  # found by a random run: 0 / 0
def test_binary_interval_functions_enclose_the_point_function(a, b, which):
    fn, point = _BINARY[which]
    out_lo, out_hi = fn(*a, *b)
    if fn is iv.i_div and b[0] <= 0.0 <= b[1]:
        if a == (0.0, 0.0):  # 0 / b is 0 wherever it is defined
            assert out_lo <= 0.0 <= out_hi and out_hi - out_lo <= 1e-299
        else:
            assert (out_lo, out_hi) == (-math.inf, math.inf)
        return
    with np.errstate(over="ignore"):  # a product or quotient may overflow to inf: enclosed too
        for u in _points(*a):
            for v in _points(*b):
                assert out_lo <= point(u, v) <= out_hi


@settings(max_examples=100, deadline=None)
@given(a=st.tuples(st.floats(-3.0, 3.0), st.floats(-3.0, 3.0)).map(_interval),
       k=st.integers(-4, 5))
def test_integer_powers_enclose_the_point_power(a, k):
    lo, hi = iv.i_powi(*a, k)
    with np.errstate(over="ignore", divide="ignore"):
        for v in _points(*a, 41):
            if v == 0.0 and k < 0:
                continue
            assert lo <= np.float64(v) ** k <= hi


def test_operands_partly_outside_a_domain_keep_the_defined_part():
    entire = (-math.inf, math.inf)
    lo, hi = iv.i_log(-1.0, 2.0)
    assert lo == -math.inf and math.log(2.0) < hi < math.log(2.0) + 1e-14
    assert iv.i_sqrt(-1e-300, 1.0)[0] == 0.0
    lo, hi = iv.i_asin(-1.5, 0.0)
    assert lo <= -0.5 * math.pi and 0.0 <= hi < 1e-299
    assert iv.i_div(1.0, 2.0, -1.0, 1.0) == entire
    assert iv.i_entire() == entire
    assert max(map(abs, iv.i_mul(0.0, 0.0, -math.inf, math.inf))) < 1e-299  # 0 times anything


def test_empty_operands_give_empty_and_box_functions_bound_it_by_the_whole_line():
    for pair in (iv.i_sqrt(-2.0, -1.0), iv.i_log(-2.0, 0.0), iv.i_acos(1.5, 2.0),
                 iv.i_add(math.nan, 1.0, 0.0, 1.0), iv.i_exp(*iv.i_empty())):
        assert all(math.isnan(v) for v in pair)
    assert iv.i_bound(*iv.i_sqrt(-2.0, -1.0)) == (-math.inf, math.inf)


def test_half_infinite_intervals_stay_half_infinite():
    assert iv.i_add(1.0, math.inf, 2.0, 3.0)[0] > 2.9
    assert iv.i_powi(2.0, math.inf, 2)[0] > 3.9
    assert iv.i_exp(-math.inf, 0.0)[0] == 0.0
    assert iv.i_recip(1.0, math.inf)[0] == 0.0


def test_sin_and_cos_reach_their_extrema_inside_an_interval():
    assert iv.i_sin(1.0, 2.0)[1] >= 1.0  # pi/2 inside
    assert iv.i_sin(1.0, 1.5)[1] < 1.0
    assert iv.i_cos(3.0, 3.2)[0] <= -1.0  # pi inside
    assert iv.i_cos(-0.1, 0.1)[1] >= 1.0


# ---------------------------------------------------------------- generated box ops

_MODELS = ["bouncing_ball", "thermostat", "relay_sliding",
           "friction_oscillator", "trolley"]
_PTR = ctypes.POINTER(ctypes.c_double)


def _call(model, op, group, t, x, p, sigma, f, out):
    model.ctypes(op, group, t, *(a.ctypes.data_as(_PTR) for a in (x, p, sigma, f, out)))


def _groups(compiled, source):
    """Every box op of the model: ``(box op, point op, group, outputs, mode)``; invariants
    have no point op of their own (they are rows of the modes' conditions)."""
    for tr in compiled.transitions:
        if tr.guard is not None:
            yield OP_GUARD_BOX, OP_GUARD, source.guard_group[tr.index], tr.guard.size, None
    for mi, mode in enumerate(compiled.modes.values()):
        if mode.invariants.size:
            yield OP_INV_BOX, None, source.invariant_group[mi], mode.invariants.size, mode
        if mode.switches:
            yield OP_SWITCH_BOX, OP_SWITCH, source.switch_group[mi], len(mode.switches), mode


@pytest.mark.parametrize("name", _MODELS)
def test_box_ops_enclose_the_point_ops_of_every_bundled_model(models_dir, name):
    compiled = hybridlab.compile_model(hybridlab.load_model(models_dir / f"{name}.toml"))
    prep = prepare(compiled)
    model, box_model = prep.module.model, prep.module.box
    p = compiled.parameter_vector()
    x0 = compiled.state_vector()
    n = x0.size
    rng = np.random.default_rng(7)
    checked = 0
    for box_op, op, group, k, mode in _groups(compiled, prep.source):
        sigma = rng.choice([-1.0, 1.0], size=max(k, 1))
        for _ in range(20):
            center = x0 + rng.normal(scale=1.0, size=n)
            half = np.abs(rng.normal(scale=0.1, size=n)) * rng.integers(0, 2, size=n)
            box = np.concatenate([center - half, center + half])
            t_box = np.sort(rng.uniform(0.0, 5.0, size=2))
            bounds = np.empty(2 * k)
            _call(box_model, box_op, group, 0.0, box, p, sigma, t_box, bounds)
            for _ in range(10):
                x = center + half * rng.uniform(-1.0, 1.0, size=n)
                t = rng.uniform(*t_box)
                if op is None:  # invariants: the point values from the reference's functions
                    value = np.asarray(mode.invariants.values(t, x, p, np.empty(0)), dtype=float)
                else:
                    value = np.empty(k)
                    _call(model, op, group, t, x, p, sigma, np.zeros(n), value)
                finite = np.isfinite(value)
                assert np.all(bounds[:k][finite] <= value[finite])
                assert np.all(value[finite] <= bounds[k:][finite])
                checked += 1
    assert checked > 0


# ---------------------------------------------------------------- the state box


@settings(max_examples=100, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), rk45=st.booleans(), scale=st.floats(1e-6, 1e3))
def test_state_box_encloses_the_dense_output(seed, rk45, scale):
    rng = np.random.default_rng(seed)
    method = RK45_CODE if rk45 else DOP853_CODE
    nco = 4 if rk45 else 7
    n = 3
    coef = rng.normal(scale=scale, size=(nco, n)) * rng.uniform(0, 1, size=(nco, 1)) ** 3
    y_old = rng.normal(scale=scale, size=n)
    # as the integrator makes a step: h is the difference of the two (rounded) ends, so every
    # time of the step has its abscissa (t - t_old) / h in [0, 1]
    t_old = 10.0
    t_new = t_old + float(rng.uniform(1e-4, 1.0))
    h = t_new - t_old
    act = np.array([0, 2])  # state 1 keeps its value
    coef[:, 1] = 0.0
    box = np.empty(2 * n)
    state_box(method, coef, h, y_old, act, box)
    out = np.empty(n)
    for t in np.linspace(t_old, t_new, 33):
        dense_eval(method, coef, t_old, h, y_old, act, t, out)
        assert np.all(box[:n] <= out) and np.all(out <= box[n:])
    assert box[1] == box[n + 1] == y_old[1]


# ---------------------------------------------------------------- same events, fewer samples

_RUNS = [("bouncing_ball", "benchmark", {}), ("bouncing_ball", "zeno", {}),
         ("thermostat", None, {}), ("sampled_control", None, {}),
         ("relay_sliding", "escape", {}), ("friction_oscillator", None, {}),
         ("trolley", "default", {}), ("trolley", "free_drop_nominal", {"t_end": 10.0}),
         ("trolley", "jerk_limited", {})]


def _record(result):
    return ([(e.t, e.j, e.transition, e.kind, e.grazing, tuple(e.pre.values()),
              tuple(e.post.values())) for e in result.events],
            result.status, result.final)


@pytest.mark.parametrize("method", ["DOP853", "RK45"])
@pytest.mark.parametrize(("name", "scenario", "extra"), _RUNS)
def test_quiet_steps_change_no_event(models_dir, name, scenario, extra, method):
    compiled = hybridlab.compile_model(hybridlab.load_model(models_dir / f"{name}.toml"))
    kw = {"backend": "compiled", "method": method, **extra}
    if scenario:
        kw["scenario"] = scenario
    sampled = hybridlab.simulate(compiled, prove_quiet_steps=False, **kw)
    proven = hybridlab.simulate(compiled, **kw)
    assert _record(proven) == _record(sampled)
    assert proven.stats["steps"] == sampled.stats["steps"]
    assert sampled.stats["quiet_steps"] == 0
    if name in ("bouncing_ball", "trolley"):
        assert 0 < proven.stats["quiet_steps"] < proven.stats["steps"]


def test_a_guard_through_tan_is_proven_quiet_away_from_its_crossing(tmp_path):
    # tan is enclosed like the other functions: steps far from the crossing are skipped
    path = tmp_path / "m.toml"
    path.write_text('name = "m"\n[states]\nx = { initial = 0.0 }\n'
                    '[modes.a]\nflow = { x = "1" }\n[modes.b]\nflow = { x = "1" }\n'
                    '[[transitions]]\nname = "go"\nsource = "a"\ntarget = "b"\n'
                    'guard = "tan(x/4) >= 0.9"\n'
                    '[initial]\nmode = "a"\n')
    compiled = hybridlab.compile_model(hybridlab.load_model(path))
    result = hybridlab.simulate(compiled, t_end=5.0, backend="compiled")
    assert result.stats["quiet_steps"] > 0
    assert result.events[0].t == pytest.approx(4.0 * math.atan(0.9), abs=1e-9)


def _random_model(seed: int) -> str:
    """A two-mode forced oscillator with nonlinear guards, a bounce and Coulomb friction."""
    rng = np.random.default_rng(seed)
    a, b, c, d, e, f, g = (float(v) for v in rng.uniform(0.2, 1.5, size=7))
    return f"""name = "fuzz{seed}"
[parameters]
w = {{ value = {1.0 + a:.6f} }}
damp = {{ value = {0.05 * b:.6f} }}
force = {{ value = {1.5 * c:.6f} }}
mu = {{ value = {0.3 * d:.6f} }}
level = {{ value = {0.3 * e:.6f} }}
window = {{ value = {0.2 * f:.6f} }}
wall = {{ value = {1.0 + g:.6f} }}
[states]
x = {{ initial = {float(rng.uniform(-1, 1)):.6f} }}
y = {{ initial = {float(rng.uniform(-1, 1)):.6f} }}
z = {{ initial = 0.0 }}
[modes.free]
flow = {{ x = "y", y = "-w**2*x - damp*y + force*sin(1.3*t)", z = "1" }}
[modes.rough]
flow = {{ x = "y", y = "-w**2*x - mu*sign(y) + force*cos(0.7*t)", z = "1" }}
invariant = ["z <= 40"]
[[transitions]]
name = "catch"
source = "free"
target = "rough"
guard = ["sin(x)*exp(-0.1*z) + 0.3*y*abs(y) >= level", "z >= 1"]
reset = {{ z = "0" }}
[[transitions]]
name = "release"
source = "rough"
target = "free"
guard = ["abs(x - 0.2) <= window", "cos(y) >= 0.9", "z >= 2"]
reset = {{ z = "0" }}
[[transitions]]
name = "bounce"
source = "*"
target = "*"
guard = ["x >= wall", "y >= 0"]
reset = {{ y = "-0.8*y" }}
[initial]
mode = "free"
"""


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_quiet_steps_change_no_event_on_random_models(tmp_path, seed):
    path = tmp_path / f"fuzz{seed}.toml"
    path.write_text(_random_model(seed))
    compiled = hybridlab.compile_model(hybridlab.load_model(path))
    kw = {"t_end": 60.0, "backend": "compiled", "rtol": 1e-7, "atol": 1e-9}
    sampled = hybridlab.simulate(compiled, prove_quiet_steps=False, **kw)
    proven = hybridlab.simulate(compiled, **kw)
    assert proven.stats["backend"] == "compiled"
    assert len(sampled.events) > 5
    assert _record(proven) == _record(sampled)
    assert 0 < proven.stats["quiet_steps"] < proven.stats["steps"]
