"""Runs end in bounded time: non-finite values, step and wall-clock budgets, Ctrl-C.

A flow that is NaN at the start used to hang both backends (the integrator's first step
never finished); ``max_step`` below the double spacing and ``t_end = 1e300`` ran without
bound; the compiled kernel ignored Ctrl-C. Every such run now ends with a status that
names what happened, and ``final`` is the last good state.
"""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import hybridlab
from hybridlab import Status

BACKENDS = ["reference", "auto"]


def one_state(flow: str, x0: float = 1.0, extra: str = "") -> hybridlab.Model:
    return hybridlab.loads_model(f"""
name = "one"
states = {{ x = {x0} }}
[modes.a]
flow = {{ x = "{flow}" }}
{extra}
[initial]
mode = "a"
""", source="<test>")


OSCILLATOR = hybridlab.loads_model("""
name = "osc"
states = { x = 1.0, v = 0.0 }
[modes.a]
flow = { x = "v", v = "-x" }
[initial]
mode = "a"
""", source="<test>")


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize(("flow", "named"), [
    ("sqrt(x - 2)", "sqrt(x - 2)"), ("asin(2*x)", "asin(2*x)"), ("log(x - 5)", "log(x - 5)"),
    ("x/(x - 1)", "x/(x - 1)"),
])
def test_a_flow_undefined_at_the_start_fails_at_once_naming_it(flow, named, backend):
    result = hybridlab.simulate(one_state(flow), t_end=1.0, backend=backend)  # (it hung before)
    assert result.status is Status.SOLVER_FAILED
    assert f"the flow of x, {named}, is" in result.message and "t = 0.0" in result.message
    assert result.final.t == 0.0 and result.final.state == {"x": 1.0}


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_guard_undefined_at_the_start_fails_naming_it(backend):
    model = one_state("-x", extra="""
[[transitions]]
name = "go"
source = "a"
target = "a"
guard = "sqrt(x - 3) >= 1"
""")
    result = hybridlab.simulate(model, t_end=1.0, backend=backend)
    assert result.status is Status.SOLVER_FAILED
    assert "the guard of 'go' (sqrt(x - 3) >= 1) is nan at t = 0.0" in result.message


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_flow_that_leaves_its_domain_fails_with_the_last_good_state(backend):
    # x' = -1 from x = 1: sqrt(x) is undefined past t = 1; the run fails there, not at 0
    result = hybridlab.simulate(one_state("-1 + 1e-9*sqrt(x)"), t_end=2.0, backend=backend)
    assert result.status is Status.SOLVER_FAILED
    assert 0.9 < result.final.t <= 1.0 + 1e-6
    assert 0.0 <= result.final.state["x"] == pytest.approx(1.0 - result.final.t, abs=1e-6)


@pytest.mark.parametrize("backend", BACKENDS)
def test_the_step_budget_bounds_a_run_to_a_huge_horizon(backend):
    result = hybridlab.simulate(OSCILLATOR, t_end=1e300, max_steps=2000, backend=backend)
    assert result.status is Status.STEP_LIMIT
    assert result.stats["steps"] == 2000 and "max_steps = 2000" in result.message
    t = result.final.t
    assert t > 100  # the last good state, not the initial one
    assert result.final.state["x"] == pytest.approx(math.cos(t), abs=1e-5)
    assert result(np.array([t]))[0, 0] == pytest.approx(math.cos(t), abs=1e-5)


@pytest.mark.parametrize("backend", BACKENDS)
def test_the_wall_clock_limit_stops_a_run(backend):
    result = hybridlab.simulate(OSCILLATOR, t_end=1e300, time_limit=0.3, backend=backend)
    assert result.status is Status.TIME_LIMIT and "time_limit = 0.3 s" in result.message
    # the run keeps the oscillator's state; its phase error grows with the time reached (a
    # compiled run reaches t = 1.4e5 in 0.3 s on a fast machine, 9.5e-5 off)
    assert result.final.state["x"] == pytest.approx(math.cos(result.final.t),
                                                    abs=1e-4 + 2e-9 * result.final.t)


def test_a_step_too_small_for_the_horizon_is_refused_before_running():
    with pytest.raises(ValueError, match=r"max_step = 1e-300 needs more than max_steps"):
        hybridlab.simulate(OSCILLATOR, t_end=1.0, max_step=1e-300)
    with pytest.raises(ValueError, match="time_limit must be a positive number"):
        hybridlab.simulate(OSCILLATOR, t_end=1.0, time_limit=0.0)


_INTERRUPTED = textwrap.dedent("""
    import signal, sys, time
    # a child of a background job inherits SIGINT ignored: take it back, as a terminal would
    signal.signal(signal.SIGINT, signal.default_int_handler)
    import hybridlab
    model = hybridlab.loads_model('''
    name = "osc"
    states = { x = 1.0, v = 0.0 }
    [modes.a]
    flow = { x = "v", v = "-x" }
    [initial]
    mode = "a"
    ''')
    backend = sys.argv[1]
    hybridlab.simulate(model, t_end=1.0, backend=backend)  # compile or load the kernel
    print("running", flush=True)
    start = time.perf_counter()
    r = hybridlab.simulate(model, t_end=1e300, time_limit=60, backend=backend)
    print(r.status.name, r.final.t > 0, round(time.perf_counter() - start, 1), flush=True)
""")


@pytest.mark.parametrize("backend", BACKENDS)
def test_ctrl_c_stops_the_run_and_returns_the_partial_result(backend):
    proc = subprocess.Popen([sys.executable, "-c", _INTERRUPTED, backend],
                            stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None
        assert proc.stdout.readline().strip() == "running"
        time.sleep(1.0)
        os.kill(proc.pid, signal.SIGINT)
        out, _ = proc.communicate(timeout=300)
    finally:
        proc.kill()
    status, moved, _ = out.split()
    # not TIME_LIMIT: the run stopped at Ctrl-C, long before its 60 s limit
    assert (status, moved) == ("INTERRUPTED", "True")
