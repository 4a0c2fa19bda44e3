"""Discrete variables constant in a mode (``hybridlab.reachability.constants``).

A gear box that shifts up once and back: in ``low`` the gain ``g`` is 1, in ``high`` it is 3,
each set by the transition into the mode; ``shifted`` is 0, then 1; ``level`` is recorded
from the state at the shift, and ``s`` is read by a switching function. Substituting the
constants makes ``high``'s flow affine.
"""

from __future__ import annotations

import numpy as np

import hybridlab
from hybridlab.reachability.constants import mode_constants, with_constants
from hybridlab.reachability.sets import Zonotope
from hybridlab.reachability.system import build_system

GEARS = """
name = "gears"
[states]
x = { initial = 1.0 }
[discrete]
g = { value = 1.0, type = "real" }
level = { value = 0.0, type = "real" }
s = { value = 1.0, type = "real" }
shifted = { value = 0.0, type = "real" }
[modes.low]
flow = { x = "-g*x + 0.05*sign(s)" }
[modes.high]
flow = { x = "-g*x + level" }
[[transitions]]
name = "up"
source = "low"
target = "high"
guard = ["x <= 0.5", "shifted <= 0.5"]
reset = { g = "3", level = "x/2", shifted = "1" }
[[transitions]]
name = "down"
source = "high"
target = "low"
guard = "x <= 0.2"
reset = { g = "g - 2" }
[initial]
mode = "low"
"""


def _system():
    compiled = hybridlab.compile_model(hybridlab.loads_model(GEARS))
    return compiled, build_system(compiled, compiled.parameter_vector(), {}, {})


def _named(system, found):
    return {mode: {system.znames[i]: v for i, v in values.items()}
            for mode, values in found.items()}


def test_the_constants_follow_the_resets_and_the_kept_values():
    compiled, system = _system()
    x0 = compiled.state_vector()
    point = Zonotope(x0, np.zeros((x0.size, 0)))
    # g: 1 initially, 3 after "up", 3 - 2 = 1 after "down"; shifted: 0, then 1 (both in
    # low: it varies there); level varies (x/2); s is read by the switching function
    # sign(s) and never substituted
    assert _named(system, mode_constants(system, "low", point)) == {
        "low": {"g": 1.0}, "high": {"g": 3.0, "shifted": 1.0}}
    # a gain not known at the start varies in low, and "down" computes it from high's 3
    wide = Zonotope(x0, np.diag([0.0, 0.5, 0.0, 0.0, 0.0]))
    assert _named(system, mode_constants(system, "low", wide)) == {
        "low": {}, "high": {"g": 3.0, "shifted": 1.0}}


def test_substituted_modes_become_affine_and_the_flowpipe_holds_every_run():
    compiled, system = _system()
    x0 = compiled.state_vector()
    known = with_constants(system, mode_constants(system, "low",
                                                  Zonotope(x0, np.zeros((x0.size, 0)))))
    assert not system.modes["high"].affine and known.modes["high"].affine
    assert known.modes["low"].switches.size == 1  # sign(s) is kept
    result = hybridlab.reach(compiled, initial={"x": (0.9, 1.0)}, t_end=3.0, step=0.01)
    assert result.complete and {"low", "high"} <= set(result.reachable_modes)
    times = np.linspace(0.0, 3.0, 301)
    for start in (0.9, 0.95, 1.0):
        run = hybridlab.simulate(compiled, initial={"x": start}, t_end=3.0, rtol=1e-10,
                                 atol=1e-12)
        assert [e.transition for e in run.jumps][:2] == ["up", "down"]
        states = np.array([run(t) for t in times])
        modes = [run.mode_at(t) for t in times]
        assert result.covers(times, states, modes, tol=1e-7).all(), start
