"""Hylaa versions of the reach benchmarks; run with the Python of a separate Hylaa venv.

    python3 -m venv /tmp/hylaa-venv
    /tmp/hylaa-venv/bin/pip install hylaa swiglpk==5.0.10
    /tmp/hylaa-venv/bin/python benchmarks/reach/hylaa_models.py bouncing_ball

Prints one JSON line ``{"verdict": "SAFE" | "UNSAFE" | "UNKNOWN", "time_s": ...}``.
This file imports only Hylaa and numpy/scipy, never hybridlab: Hylaa is a benchmark
peer, not a dependency. Hylaa handles affine dynamics only (the Van der Pol benchmark
is not written here). Hylaa's default semantics is discrete time: sets are checked at
the time steps, not between them. Constants and affine terms are extra states (``one == 1``,
an uncertain constant as a state with zero flow); each disjunct of a SpaceEx forbidden set
is a transition to an error mode. The building's 48x48 matrix is read from
``models/spaceex/building.xml`` (its flows are sums of ``coefficient*variable`` terms).
"""

from __future__ import annotations

import json
import math
import re
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

G, C = 1.0, 0.75  # the SpaceEx ball constants (bouncing_ball.xml)
SPACEEX = Path(__file__).resolve().parents[2] / "models" / "spaceex"


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


def _hylaa():
    from hylaa import lputil
    from hylaa.core import Core
    from hylaa.hybrid_automaton import HybridAutomaton
    from hylaa.settings import HylaaSettings, PlotSettings
    from hylaa.stateset import StateSet

    return lputil, Core, HybridAutomaton, HylaaSettings, PlotSettings, StateSet


def _settings(step: float, t_end: float):
    _, _, _, HylaaSettings, PlotSettings, _ = _hylaa()
    settings = HylaaSettings(step, t_end)
    settings.plot.plot_mode = PlotSettings.PLOT_NONE
    settings.stdout = HylaaSettings.STDOUT_NONE
    return settings


def _error_transitions(ha, mode, n: int, disjuncts) -> None:
    """One transition to the error mode per disjunct, a list of (row dict, rhs): row . x <= rhs."""
    error = ha.modes.get("_error") or ha.new_mode("_error")
    for k, rows in enumerate(disjuncts):
        g = np.zeros((len(rows), n))
        rhs = np.zeros(len(rows))
        for i, (row, r) in enumerate(rows):
            for j, c in row.items():
                g[i, j] = c
            rhs[i] = r
        ha.new_transition(mode, error, f"forbidden_{mode.name}_{k}").set_guard(g, rhs)


# spacecraft (spacecraft.xml): states x, y, vx, vy, t, tabort, one
_SC_APPROACH = [[-0.057599765881773, 0.000200959896519766, -2.89995083970656, 0.00877200894463775],
                [-0.000174031357370456, -0.0665123984901026, -0.00875351105536225,
                 -2.90300269286856]]
_SC_RENDEZVOUS = [[-0.575999943070835, 0.000262486079431672, -19.2299795908647,
                   0.00876275931760007],
                  [-0.000262486080737868, -0.575999940191886, -0.00876276068239993,
                   -19.2299765959399]]
_SC_ABORT = [[0.0000575894721132, 0.0, 0.0, 0.00876276], [0.0, 0.0, -0.00876276, 0.0]]


def _spacecraft(t_lo: float, t_hi: float, step: float = 0.2, t_end: float = 300.0):
    lputil, Core, HybridAutomaton, _, _, StateSet = _hylaa()
    n = 7
    X, Y, VX, VY, T, TA, ONE = range(n)

    def dyn(rows):
        a = np.zeros((n, n))
        a[X, VX] = a[Y, VY] = 1.0
        a[VX, :4] = rows[0]
        a[VY, :4] = rows[1]
        a[T, ONE] = 1.0
        return a

    ha = HybridAutomaton("spacecraft")
    approach = ha.new_mode("approaching")
    approach.set_dynamics(dyn(_SC_APPROACH))
    approach.set_invariant([[1.0, 0, 0, 0, 0, 0, 0], [0, 0, 0, 0, 1.0, -1.0, 0]], [-100.0, 0.0])
    rendezvous = ha.new_mode("rendezvous")
    rendezvous.set_dynamics(dyn(_SC_RENDEZVOUS))
    octagon = [[-1.0, 0], [1.0, 0], [0, -1.0], [0, 1.0], [-1.0, -1.0], [1.0, 1.0], [1.0, -1.0],
               [-1.0, 1.0]]
    inv = np.zeros((9, n))
    inv[:8, :2] = octagon
    inv[8, T], inv[8, TA] = 1.0, -1.0
    rendezvous.set_invariant(inv, [100.0] * 4 + [141.1] * 4 + [0.0])
    abort = ha.new_mode("aborting")
    abort.set_dynamics(dyn(_SC_ABORT))
    ha.new_transition(approach, rendezvous, "approach").set_guard([[-1.0, 0, 0, 0, 0, 0, 0]],
                                                                  [100.0])
    for src in (approach, rendezvous):
        ha.new_transition(src, abort, "abort").set_guard([[0, 0, 0, 0, -1.0, 1.0, 0]], [0.0])
    t30 = math.tan(math.pi / 6)
    # forbidden (spacecraft_sra0*.cfg), each disjunct as rows r . x <= rhs
    _error_transitions(ha, rendezvous, n, [
        [({VX: -1.0}, -3.0)], [({VX: 1.0}, -3.0)], [({VY: -1.0}, -3.0)], [({VY: 1.0}, -3.0)],
        [({VX: -1.0, VY: -1.0}, -4.2)], [({VX: -1.0, VY: 1.0}, -4.2)],
        [({VX: 1.0, VY: -1.0}, -4.2)], [({VX: 1.0, VY: 1.0}, -4.2)],
        [({X: -t30, Y: 1.0}, 0.0)], [({X: -t30, Y: -1.0}, 0.0)]])
    _error_transitions(ha, abort, n, [[({X: -1.0}, 0.1), ({X: 1.0}, 0.1), ({Y: -1.0}, 0.1),
                                       ({Y: 1.0}, 0.1)]])
    init = lputil.from_box([(-925.0, -875.0), (-425.0, -375.0), (0.0, 0.0), (0.0, 0.0),
                            (0.0, 0.0), (t_lo, t_hi), (1.0, 1.0)], approach)
    return Core(ha, _settings(step, t_end)).run([StateSet(init, approach)])


def _affine_flows(xml: str, n: int, input_name: str) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """``{location: (A, b)}`` read off a SpaceEx file's flows ``xi' == sum coef*xj + coef*u``
    over the states ``x1 .. xn`` and one input (flows of other variables, such as a clock,
    are left out; a location split over parallel components is summed)."""
    ns = "{http://www-verimag.imag.fr/xml-namespaces/sspaceex}"
    root = ET.parse(SPACEEX / xml).getroot()
    term = re.compile(rf"([+-]?)\s*(?:([0-9.eE+-]+)\*)?(x\d+|{input_name})\b")
    flows: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for location in root.iter(f"{ns}location"):
        a, b = flows.setdefault(location.get("name"), (np.zeros((n, n)), np.zeros(n)))
        for eq in location.find(f"{ns}flow").text.split("&"):
            lhs, rhs = eq.split("==")
            name = lhs.strip().rstrip("'")
            if not re.fullmatch(r"x\d+", name):
                continue
            i = int(name[1:]) - 1
            for sign, coef, var in term.findall(rhs):
                c = (float(coef) if coef else 1.0) * (-1.0 if sign == "-" else 1.0)
                if var == input_name:
                    b[i] += c
                else:
                    a[i, int(var[1:]) - 1] += c
    return flows


def _building(step: float = 0.002, t_end: float = 20.0):
    lputil, Core, HybridAutomaton, _, _, StateSet = _hylaa()
    a, b = _affine_flows("building.xml", 48, "u1")["model"]
    n = 48
    ha = HybridAutomaton("building")
    mode = ha.new_mode("model")
    mode.set_dynamics(a)
    mode.set_inputs(b.reshape(n, 1), [[1.0], [-1.0]], [1.0, -0.8])  # u1 in [0.8, 1]
    _error_transitions(ha, mode, n, [[({24: -1.0}, -0.0051)]])  # x25 >= 0.0051
    box = [(0.0002, 0.00025)] * 10 + [(0.0, 0.0)] * 14 + [(-0.0001, 0.0001)] + [(0.0, 0.0)] * 23
    init = lputil.from_box(box, mode)
    return Core(ha, _settings(step, t_end)).run([StateSet(init, mode)])


def _room_heating(step: float = 0.05, t_end: float = 1800.0):
    """room_heating.xml: states x1, x2, one; a = 0.5, b = 0.4 / 0.3, c = 6 / 7, u = 11."""
    lputil, Core, HybridAutomaton, _, _, StateSet = _hylaa()
    a_, b1, b2, c1, c2, u = 0.5, 0.4, 0.3, 6.0, 7.0, 11.0
    on, off, get, dif = 20.0, 21.0, 18.0, 1.0
    ha = HybridAutomaton("room_heating")
    modes = {}
    for name, h1, h2, inv in (("heat1_on", 1, 0, ([[1.0, 0, 0]], [off])),
                              ("heat1_off", 0, 0, ([[-1.0, 0, 0]], [-on])),
                              ("heat2_on", 0, 1, ([[0, 1.0, 0]], [off])),
                              ("heat2_off", 0, 0, ([[0, -1.0, 0]], [-on]))):
        m = ha.new_mode(name)
        m.set_dynamics([[-(a_ + b1), a_, c1 * h1 + b1 * u],
                        [a_, -(a_ + b2), c2 * h2 + b2 * u],
                        [0, 0, 0]])
        m.set_invariant(*inv)
        modes[name] = m
    m = modes
    ha.new_transition(m["heat1_on"], m["heat1_off"], "off1").set_guard([[-1.0, 0, 0]], [-off])
    ha.new_transition(m["heat1_off"], m["heat1_on"], "on1").set_guard([[1.0, 0, 0]], [on])
    ha.new_transition(m["heat2_on"], m["heat2_off"], "off2").set_guard([[0, -1.0, 0]], [-off])
    ha.new_transition(m["heat2_off"], m["heat2_on"], "on2").set_guard([[0, 1.0, 0]], [on])
    for src in ("heat1_on", "heat1_off"):  # x2 <= get & x1 - x2 >= dif
        ha.new_transition(m[src], m["heat2_on"], "move12").set_guard(
            [[0, 1.0, 0], [-1.0, 1.0, 0]], [get, -dif])
    for src in ("heat2_on", "heat2_off"):
        ha.new_transition(m[src], m["heat1_on"], "move21").set_guard(
            [[1.0, 0, 0], [1.0, -1.0, 0]], [get, -dif])
    for mode in m.values():  # forbidden x_i <= 17 | x_i >= 22
        _error_transitions(ha, mode, 3, [[({0: 1.0}, 17.0)], [({0: -1.0}, -22.0)],
                                         [({1: 1.0}, 17.0)], [({1: -1.0}, -22.0)]])
    init = lputil.from_box([(20.4, 20.6), (19.9, 20.1), (1.0, 1.0)], m["heat1_on"])
    return Core(ha, _settings(step, t_end)).run([StateSet(init, m["heat1_on"])])


def _stiff2d(step: float = 0.001, t_end: float = 5.0):
    """stiff2d.xml: x' = -x + 1000 y + 1, y' = -2000 y; states x, y, one."""
    lputil, Core, HybridAutomaton, _, _, StateSet = _hylaa()
    ha = HybridAutomaton("stiff2d")
    mode = ha.new_mode("run")
    mode.set_dynamics([[-1.0, 1000.0, 1.0], [0, -2000.0, 0], [0, 0, 0]])
    _error_transitions(ha, mode, 3, [[({0: -1.0}, -1.8)]])  # x >= 1.8
    init = lputil.from_box([(0.9, 1.1), (0.9, 1.1), (1.0, 1.0)], mode)
    return Core(ha, _settings(step, t_end)).run([StateSet(init, mode)])


_CRANE = [[0.0, 1.0, 0.0, 0.0, 0.0, 0.0],
          [-0.417533, -3.1931759963, 39.24, 0.0, -14.825331, 11.123344],
          [0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
          [0.0417533, 0.31931759963, -4.905, 0.0, 1.4825331, -1.1123344],
          [0.0638407957, -0.32473339016573, 0.0, 0.0, -3.7332068901, -0.7007592976],
          [0.0853437452, -0.72366802635628, 0.0, 0.0, -5.9714023436, -2.2736115136]]


def _crane(x_min: float, step: float = 0.01, t_end: float = 15.0):
    """crane.xml: states x, v, y, w, yri, wri (linear, no constant term); forbidden x <= x_min."""
    lputil, Core, HybridAutomaton, _, _, StateSet = _hylaa()
    ha = HybridAutomaton("crane")
    mode = ha.new_mode("move")
    mode.set_dynamics(_CRANE)
    _error_transitions(ha, mode, 6, [[({0: 1.0}, x_min)]])
    init = lputil.from_box([(0.0, 5.0), (0.0, 0.0), (-0.2, 0.2), (-0.1, 0.1), (0.0, 0.0),
                            (0.0, 0.0)], mode)
    return Core(ha, _settings(step, t_end)).run([StateSet(init, mode)])


def _platoon(bound: float, step: float = 0.02, t_end: float = 20.0):
    """platoon.xml: states x1..x9, t, one; u in [-9, 1] on x2; switching every 5 s."""
    lputil, Core, HybridAutomaton, _, _, StateSet = _hylaa()
    n, T, ONE = 11, 9, 10
    ha = HybridAutomaton("platoon")
    modes = []
    for name, (rows, coupling) in _affine_flows("platoon.xml", 9, "u").items():
        a = np.zeros((n, n))
        a[:9, :9] = rows
        a[T, ONE] = 1.0
        mode = ha.new_mode(name)
        mode.set_dynamics(a)
        b = np.zeros((n, 1))
        b[:9, 0] = coupling
        mode.set_inputs(b, [[1.0], [-1.0]], [1.0, 9.0])  # u in [-9, 1]
        clock = np.zeros((1, n))
        clock[0, T] = 1.0
        mode.set_invariant(clock, [5.0])
        modes.append(mode)
    reset = np.identity(n)
    reset[T, T] = 0.0
    for src, dst in ((0, 1), (1, 0)):
        guard = np.zeros((1, n))
        guard[0, T] = -1.0
        tr = ha.new_transition(modes[src], modes[dst], f"switch{src}")
        tr.set_guard(guard, [-5.0])  # t >= 5
        tr.set_reset(reset)
    for mode in modes:  # forbidden x1, x4 or x7 <= -bound
        _error_transitions(ha, mode, n, [[({i: 1.0}, -bound)] for i in (0, 3, 6)])
    init = lputil.from_box([(0.0, 0.0)] * 10 + [(1.0, 1.0)], modes[0])
    return Core(ha, _settings(step, t_end)).run([StateSet(init, modes[0])])


def _gearbox(px: tuple[float, float], py: tuple[float, float], step: float = 0.2 / 182,
             t_end: float = 0.21):
    """gearbox.xml from its physical parameters: states vx, vy, px, py, I, t, one; modes free
    and meshed; Hylaa's own gearbox example's deaggregation on."""
    lputil, Core, HybridAutomaton, _, _, StateSet = _hylaa()
    n = 7
    VX, VY, PX, PY, IMP, T, ONE = range(n)
    ms, mg2, zeta, theta = 3.2, 18.1, 0.9, 0.628318530717959
    sin, cos, tan = math.sin(theta), math.cos(theta), math.tan(theta)
    ha = HybridAutomaton("gearbox")
    free = ha.new_mode("free")
    a = np.zeros((n, n))
    a[VX, ONE], a[VY, ONE] = 70.0 / ms, -0.08 * 1.0 / 0.7  # Fs / ms, -Rs Tf / Jg2
    a[PX, VX] = a[PY, VY] = a[T, ONE] = 1.0
    free.set_dynamics(a)
    inv = np.zeros((3, n))
    inv[0, PX] = 1.0  # px <= -0.003
    inv[1, PY], inv[1, PX] = 1.0, tan  # py <= -tan px
    inv[2, PY], inv[2, PX] = -1.0, tan  # py >= tan px
    free.set_invariant(inv, [-0.003, 0.0, 0.0])
    meshed = ha.new_mode("meshed")
    still = np.zeros((n, n))
    still[T, ONE] = 1.0
    meshed.set_dynamics(still)
    den = ms * cos**2 + mg2 * sin**2
    for name, sign in (("upper_flank", 1.0), ("lower_flank", -1.0)):
        guard = np.zeros((2, n))
        guard[0, PY], guard[0, PX] = -sign, -tan  # upper: py >= -tan px; lower: py <= tan px
        guard[1, VX], guard[1, VY] = -sin, -sign * cos  # moving into the flank
        reset = np.identity(n)
        reset[VX, VX] = (ms * cos**2 - mg2 * zeta * sin**2) / den
        reset[VX, VY] = -sign * (zeta + 1) * mg2 * sin * cos / den
        reset[VY, VX] = -sign * (zeta + 1) * ms * sin * cos / den
        reset[VY, VY] = (mg2 * sin**2 - ms * zeta * cos**2) / den
        reset[IMP, VX] = (zeta + 1) * ms * mg2 * sin / den
        reset[IMP, VY] = sign * (zeta + 1) * ms * mg2 * cos / den
        tr = ha.new_transition(free, free, name)
        tr.set_guard(guard, [0.0, 0.0])
        tr.set_reset(reset)
    mesh = np.identity(n)
    mesh[VX, VX] = mesh[VY, VY] = 0.0
    mesh[IMP, VX] = mesh[IMP, VY] = ms
    tr = ha.new_transition(free, meshed, "mesh")
    tr.set_guard([[0, 0, -1.0, 0, 0, 0, 0]], [0.003])  # px >= -0.003
    tr.set_reset(mesh)
    # forbidden: free at t >= 0.2, or I >= 20
    _error_transitions(ha, free, n, [[({T: -1.0}, -0.2)], [({IMP: -1.0}, -20.0)]])
    _error_transitions(ha, meshed, n, [[({IMP: -1.0}, -20.0)]])
    init = lputil.from_box([(0.0, 0.0), (0.0, 0.0), px, py, (0.0, 0.0), (0.0, 0.0),
                            (1.0, 1.0)], free)
    settings = _settings(step, t_end)
    settings.aggstrat.deaggregate = True
    return Core(ha, settings).run([StateSet(init, free)])


BENCHMARKS = {
    "crane": lambda: _crane(-1.8),
    "crane_unsafe": lambda: _crane(-1.5),
    # forbidden x >= 10.25  ->  -x <= -10.25
    "bouncing_ball": lambda: _ball([-1.0, 0, 0], -10.25, 0.05, 20.0),
    # forbidden v <= -4.5
    "bouncing_ball_fast": lambda: _ball([0, 1.0, 0], -4.5, 0.05, 20.0),
    "spacecraft_sra01": lambda: _spacecraft(120.0, 120.0),
    "spacecraft_sra02": lambda: _spacecraft(120.0, 125.0),
    "spacecraft_sra03": lambda: _spacecraft(120.0, 145.0),
    "spacecraft_sra04": lambda: _spacecraft(240.0, 240.0),
    "building_bldf01": _building,
    "room_heating": _room_heating,
    "stiff2d": _stiff2d,
    "platoon_plad01_bnd42": lambda: _platoon(42.0),
    "platoon_plad01_bnd30": lambda: _platoon(30.0),
    "gearbox_grbx01": lambda: _gearbox((-0.0168, -0.0166), (0.0029, 0.0031)),
    "gearbox_grbx02": lambda: _gearbox((-0.01675, -0.01665), (0.00285, 0.00315)),
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
