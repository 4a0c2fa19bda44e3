"""The compiled (numba) backend against the reference engine, hand-off, fallback, disk cache."""

from __future__ import annotations

import io
import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

import hybridlab
from hybridlab.errors import SimulationError

pytest.importorskip("numba")

# (model, scenario, t_end): every bundled model and scenario; the trolley on short horizons
# (its stop-and-return up to the return to hold, and the first second of the free drop, both
# with Filippov sliding of the cart friction, stick/slip and the two frictions at once)
CASES = [
    ("bouncing_ball", "default", None),
    ("bouncing_ball", "zeno", None),
    ("bouncing_ball", "benchmark", None),
    ("thermostat", "default", None),
    ("sampled_control", "default", None),
    ("relay_sliding", "default", None),
    ("relay_sliding", "escape", 4.0),
    ("friction_oscillator", "default", None),
    ("trolley", "step", 0.05),
    ("trolley", "default", 2.1),
    ("trolley", "free_drop", 1.0),
]


@pytest.fixture(scope="module")
def compiled_models(models_dir):
    names = {name for name, _, _ in CASES}
    return {name: hybridlab.compile_model(hybridlab.load_model(models_dir / f"{name}.toml"))
            for name in names}


def _pair(model, **kw):
    fast = hybridlab.simulate(model, backend="compiled", **kw)
    ref = hybridlab.simulate(model, backend="reference", **kw)
    return fast, ref


@pytest.mark.parametrize(("name", "scenario", "t_end"), CASES)
def test_event_sequences_and_times_agree_with_the_reference(compiled_models, name, scenario,
                                                            t_end):
    fast, ref = _pair(compiled_models[name], scenario=scenario, t_end=t_end)
    # the whole run on the kernel: no fallback, no hand-off to the reference engine
    assert fast.stats["backend"] == "compiled"
    assert "fallback" not in fast.stats and "handoff" not in fast.stats
    assert fast.status == ref.status
    assert [(e.transition, e.kind, e.source, e.target, e.j) for e in fast.events] == \
        [(e.transition, e.kind, e.source, e.target, e.j) for e in ref.events]
    for a, b in zip(fast.events, ref.events, strict=True):
        assert abs(a.t - b.t) <= 1e-9
        for key in a.post:
            assert a.post[key] == pytest.approx(b.post[key], rel=1e-6, abs=1e-7)
    assert fast.final.mode == ref.final.mode and fast.final.j == ref.final.j
    assert fast.final.t == pytest.approx(ref.final.t, abs=1e-9)
    for key, value in ref.final.state.items():
        assert fast.final.state[key] == pytest.approx(value, rel=1e-6, abs=1e-7)
    if ref.zeno_time is not None:
        assert fast.zeno_time == pytest.approx(ref.zeno_time, rel=1e-9)
    # dense output between the events agrees too
    # (inside the horizon: at a Zeno end the two runs stop a rounding error apart)
    t = np.linspace(ref.segments[0].t_start, 0.999 * min(ref.final.t, fast.final.t), 37)
    np.testing.assert_allclose(fast(t), ref(t), rtol=1e-6, atol=1e-7)


def test_a_step_refined_past_the_samplers_buffers_gives_the_reference_events():
    # one sampling interval per step and 8 refinement levels over a guard that dips below
    # zero six times a second: a step refined R times has 3 + 2 R samples, so more than 3
    # refinements per step on average put some step past the 8 samples the kernel's sampler
    # starts with; it doubles its buffers and scans that step again
    wiggle = hybridlab.model_from_dict({
        "name": "wiggle", "states": {"x": 0.0, "y": 0.0},
        "modes": {"m": {"flow": {"x": "1", "y": "0"}}}, "initial": {"mode": "m"},
        "transitions": [{"name": "dip", "source": "m", "target": "m",
                         "guard": "sin(40*x) + 0.999 <= 0", "reset": {"y": "y + 1"}}]})
    runs = {backend: hybridlab.simulate(wiggle, t_end=1.0, backend=backend, samples_per_step=1,
                                        max_refine=8, max_step=1.0)
            for backend in ("reference", "compiled")}
    times = {backend: [event.t for event in run.jumps] for backend, run in runs.items()}
    assert len(times["compiled"]) == 3
    assert times["compiled"] == pytest.approx(times["reference"], abs=1e-9)
    assert runs["compiled"].stats["refinements"] > 3 * runs["compiled"].stats["steps"]


def test_sliding_runs_compiled_with_the_reference_slide_events(compiled_models):
    relay = hybridlab.simulate(compiled_models["relay_sliding"], backend="compiled")
    assert relay.stats["backend"] == "compiled" and "fallback" not in relay.stats
    # x' = -sign(x) from x = 1: reaches x = 0 at t = 1 and slides there
    assert [(e.kind, e.transition) for e in relay.events] == [("slide_start", "sign(x)")]
    assert relay.events[0].t == pytest.approx(1.0, abs=1e-9)
    assert relay(np.array([3.0]))[0] == pytest.approx(0.0, abs=1e-12)
    stiff = hybridlab.simulate(compiled_models["thermostat"], t_end=5.0, method="Radau")
    assert stiff.stats["backend"] == "reference" and "Radau" in stiff.stats["fallback"]


def test_friction_oscillator_sticks_where_the_closed_form_says(compiled_models):
    # d = 0: each half swing (pi/2 s) loses 2c/k = 0.25 of amplitude: x = 1 -> -0.75 -> 0.5 ->
    # -0.25 -> 0, where |k x| = 0 <= c and the mass sticks for good (a sliding motion on v = 0)
    fast = hybridlab.simulate(compiled_models["friction_oscillator"], backend="compiled",
                              rtol=1e-11, atol=1e-13)
    assert fast.stats["backend"] == "compiled"
    half = np.pi / 2  # half period of sqrt(k/m) = 2
    turns = [e for e in fast.events if e.kind in ("crossing", "slide_start")]
    np.testing.assert_allclose([e.t for e in turns], half * np.arange(1, len(turns) + 1),
                               atol=1e-9)
    assert turns[-1].kind == "slide_start"
    assert [e.pre["x"] for e in turns] == pytest.approx([-0.75, 0.5, -0.25, 0.0][:len(turns)],
                                                        abs=1e-9)


_SLIDE_THEN_BLOCK = """
name = "slide_then_block"
states = { x = 1.0, y = 0.0 }
[modes.a]
flow = { x = "-sign(x)", y = "1" }
invariant = "y <= 2"
[initial]
mode = "a"
"""

_NOT_AFFINE = """
name = "not_affine"
states = { x = 1.0 }
[modes.a]
flow = { x = "-sign(x)*exp(sign(x))" }
[initial]
mode = "a"
"""


def test_rare_cases_hand_the_run_to_the_reference_midway():
    model = hybridlab.model.loads_model(_SLIDE_THEN_BLOCK)
    fast, ref = _pair(model, t_end=5.0)
    # the slide at t = 1 is the kernel's; the invariant violation at t = 2 the reference's
    assert fast.stats["backend"] == "compiled" and "fallback" not in fast.stats
    assert "(handle)" in fast.stats["handoff"]
    assert fast.status == ref.status == hybridlab.Status.INVARIANT_VIOLATED
    assert fast.message == ref.message
    assert [e.kind for e in fast.events] == [e.kind for e in ref.events] == ["slide_start"]
    assert fast.events[0].t == pytest.approx(1.0, abs=1e-12)
    assert fast.final.t == pytest.approx(2.0, abs=1e-12)
    np.testing.assert_allclose(fast(np.array([0.5, 1.5])), ref(np.array([0.5, 1.5])), atol=1e-12)


_PING_PONG = """
name = "ping_pong"
states = { x = 0.0, y = 1.0 }
[modes.a]
flow = { x = "1", y = "-sign(y)" }
[modes.b]
flow = { x = "1", y = "-sign(y)" }
[[transitions]]
name = "ab"
source = "a"
target = "b"
guard = "x >= 2"
[[transitions]]
name = "ba"
source = "b"
target = "a"
guard = "x >= 2"
[initial]
mode = "a"
"""

_OUTSIDE = """
name = "outside"
states = { x = 2.0 }
[modes.a]
flow = { x = "1" }
invariant = "x <= 1"
[initial]
mode = "a"
"""


@pytest.mark.parametrize(("text", "entry"), [(_PING_PONG, "(handle)"), (_OUTSIDE, "(flow)")])
def test_hand_off_reports_like_the_reference(text, entry):
    # a zero-dwell cycle at t = 2 after a slide at t = 1 (handed over at the event), and a mode
    # entered outside its invariant (handed over at the start of the flow segment)
    model = hybridlab.model.loads_model(text)
    fast, ref = _pair(model, t_end=5.0, max_event_iterations=20)
    assert fast.stats["backend"] == "compiled" and entry in fast.stats["handoff"]
    assert fast.status == ref.status and fast.status is not hybridlab.Status.COMPLETED
    assert fast.message == ref.message
    assert [(e.transition, e.kind, e.j) for e in fast.events] == \
        [(e.transition, e.kind, e.j) for e in ref.events]
    np.testing.assert_allclose([e.t for e in fast.events], [e.t for e in ref.events], atol=1e-12)
    assert (fast.final.mode, fast.final.j) == (ref.final.mode, ref.final.j)
    assert fast.final.t == pytest.approx(ref.final.t, abs=1e-12)


def test_non_affine_sliding_raises_like_the_reference():
    model = hybridlab.model.loads_model(_NOT_AFFINE)
    for backend in ("reference", "compiled"):
        with pytest.raises(SimulationError, match="affine"):
            hybridlab.simulate(model, t_end=3.0, backend=backend)


def test_ball_closed_form_on_both_methods(compiled_models):
    g, e, h0 = 9.81, 0.8, 10.0
    t1 = np.sqrt(2 * h0 / g)
    exact = t1 + np.cumsum([0.0] + [2 * t1 * e**k for k in range(1, 6)])
    for method in ("DOP853", "RK45"):
        result = hybridlab.simulate(compiled_models["bouncing_ball"], t_end=exact[-1] + 0.1,
                                    method=method, rtol=1e-10, atol=1e-12, backend="compiled")
        times = np.array([ev.t for ev in result.jumps])
        np.testing.assert_allclose(times, exact, rtol=0, atol=1e-9)
        assert result.stats["backend"] == "compiled"


def test_max_events_stops_like_the_reference(compiled_models):
    fast, ref = _pair(compiled_models["thermostat"], t_end=60.0, max_events=5)
    assert fast.status == ref.status == hybridlab.Status.MAX_EVENTS
    assert fast.message.split(" by t")[0] == ref.message.split(" by t")[0] == "5 events logged"
    assert fast.events[-1].t == pytest.approx(ref.events[-1].t, abs=1e-9)
    assert fast.final.j == ref.final.j and fast.final.mode == ref.final.mode
    for result in (fast, ref):  # the run ends after its last event: in its target and post
        last = result.events[-1]
        assert (result.final.t, result.final.j, result.final.mode) == (last.t, last.j,
                                                                        last.target)
        assert result.final.state == last.post
        np.testing.assert_array_equal(result(result.final.t), list(last.post.values()))


def test_zeno_error_policy_raises_on_the_compiled_backend(compiled_models):
    with pytest.raises(hybridlab.ZenoError):
        hybridlab.simulate(compiled_models["bouncing_ball"], scenario="zeno", zeno="error",
                           backend="compiled")


def test_without_numba_auto_is_the_reference_and_compiled_is_an_error(compiled_models,
                                                                     monkeypatch):
    import hybridlab.simulation.compiled as comp

    monkeypatch.setattr(comp.importlib.util, "find_spec",
                        lambda name, *a: None if name == "numba" else object())
    result = hybridlab.simulate(compiled_models["bouncing_ball"], t_end=3.0)
    assert result.stats.get("backend", "reference") == "reference"
    with pytest.raises(SimulationError, match="needs numba"):
        hybridlab.simulate(compiled_models["bouncing_ball"], t_end=3.0, backend="compiled")
    with pytest.raises(ValueError, match="backend must be one of"):
        hybridlab.simulate(compiled_models["bouncing_ball"], t_end=3.0, backend="fast")


_DECAY = textwrap.dedent("""
    name = "cache_probe"
    states = { x = 1.0 }
    parameters = { k = { value = 0.731 } }
    [modes.on]
    flow = { x = "-k*x" }
    [[transitions]]
    name = "reset"
    source = "on"
    target = "on"
    guard = "x <= 0.25"
    reset = { x = "1" }
    [initial]
    mode = "on"
""")


def test_second_process_loads_the_compiled_model_from_the_disk_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("HYBRIDLAB_CACHE_DIR", str(tmp_path))
    model = hybridlab.model.loads_model(_DECAY + f"# {tmp_path.name}\n")
    first = hybridlab.simulate(model, t_end=5.0, backend="compiled")
    assert first.stats["backend"] == "compiled"
    assert first.stats["compiled_cache_hit"] is False
    assert any(p.suffix == ".py" for p in tmp_path.iterdir())
    # exact switching times: x = exp(-k t) reaches 1/4 every ln(4)/k
    period = np.log(4.0) / 0.731
    np.testing.assert_allclose([e.t for e in first.jumps], period * np.arange(1, 3), atol=1e-9)
    script = ("import hybridlab, sys; m = hybridlab.model.loads_model(sys.stdin.read()); "
              "r = hybridlab.simulate(m, t_end=5.0, backend='compiled'); "
              "print(r.stats['backend'], r.stats['compiled_cache_hit'])")
    out = subprocess.run([sys.executable, "-c", script], input=_DECAY + f"# {tmp_path.name}\n",
                         capture_output=True, text=True, check=True,
                         env={**os.environ, "HYBRIDLAB_CACHE_DIR": str(tmp_path)})
    assert out.stdout.split() == ["compiled", "True"]


def test_kernel_cache_is_checked_where_numba_keeps_it(tmp_path):
    """With ``$NUMBA_CACHE_DIR`` set numba caches the kernel there, not in the source tree:
    the digest of the kernel's sources (which drops a stale kernel) must be kept there too."""
    script = ("from hybridlab.simulation.compiled import backend; "
              "print(backend._kernel_cache_path())")
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         check=True, env={**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)})
    cache = Path(out.stdout.strip())
    assert cache.parent == tmp_path
    assert (cache / "kernel-sources.sha256").is_file()


def test_a_compile_is_announced_on_a_terminal_only(monkeypatch: pytest.MonkeyPatch,
                                                    tmp_path: Path) -> None:
    monkeypatch.setenv("HYBRIDLAB_CACHE_DIR", str(tmp_path))
    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    def fresh(tag: str) -> hybridlab.Model:  # a model no cache has seen
        rate = 1.0 + (time.time_ns() % 10**12) * 1e-12 + ord(tag) * 1e-3  # new generated code
        return hybridlab.loads_model(f'name = "fresh{tag}"\nstates = {{ x = 1.0 }}\n'
                                     f'[modes.a]\nflow = {{ x = "-{rate!r}*x" }}\n'
                                     '[initial]\nmode = "a"\n')

    terminal = Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    hybridlab.simulate(fresh("a"), 0.1, backend="compiled")
    assert "hybridlab: compiling model 'fresha' (" in terminal.getvalue()
    piped = io.StringIO()
    monkeypatch.setattr(sys, "stderr", piped)
    hybridlab.simulate(fresh("b"), 0.1, backend="compiled")
    assert piped.getvalue() == ""


def test_the_kernel_lets_other_threads_run(compiled_models):
    # a compiled run in a thread releases the GIL while the kernel works: this thread's
    # Python loop goes on meanwhile (with the GIL held it would stand still until the end)
    import threading

    ball = compiled_models["bouncing_ball"]
    long_run = {"t_end": 20.0, "max_step": 2e-5, "backend": "compiled"}
    expected = hybridlab.simulate(ball, **long_run)
    results = []
    worker = threading.Thread(target=lambda: results.append(hybridlab.simulate(ball, **long_run)))
    spins = 0
    worker.start()
    while worker.is_alive():
        spins += 1
    worker.join()
    assert results[0].stats["steps"] == expected.stats["steps"] > 500_000
    assert list(results[0].events.t) == list(expected.events.t)
    # held, the GIL would let this loop run only while the other thread prepares its run
    # (some 20,000 turns, one switch interval of 5 ms); free, for the second of the run
    assert spins > 100_000
