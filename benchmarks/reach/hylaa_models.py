"""Hylaa versions of the reach benchmarks; run with the Python of a separate Hylaa venv.

    python3 -m venv /tmp/hylaa-venv
    /tmp/hylaa-venv/bin/pip install hylaa swiglpk==5.0.10
    /tmp/hylaa-venv/bin/python benchmarks/reach/hylaa_models.py bouncing_ball

Prints one JSON line ``{"verdict": "SAFE" | "UNSAFE" | "UNKNOWN", "time_s": ...}``.
This file imports only Hylaa and numpy/scipy, never hybridlab: Hylaa is a benchmark
peer, not a dependency. Hylaa handles affine dynamics only (the Van der Pol benchmark
is not written here). Hylaa's default semantics is discrete time: sets are checked at
the time steps, not between them.
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np

G, C = 1.0, 0.75  # the SpaceEx ball constants (bouncing_ball.xml)


def _ball(forbidden_row: list[float], forbidden_rhs: float, step: float, t_end: float):
    from hylaa import lputil
    from hylaa.core import Core
    from hylaa.hybrid_automaton import HybridAutomaton
    from hylaa.settings import HylaaSettings, PlotSettings
    from hylaa.stateset import StateSet

    # states (x, v, a) with a == 1 carrying the affine term: x' = v, v' = -g*a
    ha = HybridAutomaton("bouncing_ball")
    mode = ha.new_mode("always")
    mode.set_dynamics(np.array([[0, 1, 0], [0, 0, -G], [0, 0, 0]], float))
    mode.set_invariant(np.array([[-1.0, 0, 0]]), np.array([0.0]))  # x >= 0
    bounce = ha.new_transition(mode, mode, "hop")
    bounce.set_guard(np.array([[1.0, 0, 0], [0, 1.0, 0]]), np.array([0.0, 0.0]))  # x<=0, v<=0
    bounce.set_reset(np.array([[1.0, 0, 0], [0, -C, 0], [0, 0, 1.0]]))
    error = ha.new_mode("_error")
    bad = ha.new_transition(mode, error, "forbidden")
    bad.set_guard(np.array([forbidden_row]), np.array([forbidden_rhs]))

    init = lputil.from_box([(10.0, 10.2), (0.0, 0.0), (1.0, 1.0)], mode)
    settings = HylaaSettings(step, t_end)
    settings.plot.plot_mode = PlotSettings.PLOT_NONE
    settings.stdout = HylaaSettings.STDOUT_NONE
    return Core(ha, settings).run([StateSet(init, mode)])


BENCHMARKS = {
    # forbidden x >= 10.25  ->  -x <= -10.25
    "bouncing_ball": lambda: _ball([-1.0, 0, 0], -10.25, 0.05, 20.0),
    # forbidden v <= -4.5
    "bouncing_ball_fast": lambda: _ball([0, 1.0, 0], -4.5, 0.05, 20.0),
}


def main(argv: list[str]) -> int:
    if len(argv) != 1 or argv[0] not in BENCHMARKS:
        print(f"usage: hylaa_models.py {{{','.join(BENCHMARKS)}}}", file=sys.stderr)
        return 2
    import hylaa.core  # noqa: F401 - the import is not timed

    start = time.perf_counter()
    result = BENCHMARKS[argv[0]]()
    elapsed = time.perf_counter() - start
    if result.has_concrete_error:
        verdict = "UNSAFE"
    elif result.has_aggregated_error:
        verdict = "UNKNOWN"
    else:
        verdict = "SAFE"
    print(json.dumps({"verdict": verdict, "time_s": elapsed}))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
