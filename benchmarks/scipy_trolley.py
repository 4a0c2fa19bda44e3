"""The trolley of ``models/trolley.toml`` written as a plain ``solve_ivp`` program.

This is the baseline the trolley benchmarks time hybridlab against: what a
competent engineer writes for the same jobs *without* hybridlab, at the same
``method``/``rtol``/``atol``. Only the parameter values are read from the model
file (so both sides simulate the same numbers); everything else is written by
hand here:

* **Equations of motion, derived by hand** (no sympy): with ``M_t = M_block + m_p``,
  ``ml = m_p l_c`` and the generalised forces ``Q_x = F_in - F_f - d v``,
  ``Q_phi = -T_f - b_b omega``, Lagrange's equations of the model's energies are ::

      [ M_t          ml cos(phi) ] [ v'     ]   [ Q_x + ml omega^2 sin(phi)   ]
      [ ml cos(phi)  J           ] [ omega' ] = [ Q_phi - ml g sin(phi)       ]

  solved in closed form (Cramer's rule). Five states: ``x, v, phi, omega`` and the
  velocity-loop integrator ``z`` (``z' = e_v``); hybridlab carries 18 (the
  reference-segment, sensor and bookkeeping states too).
* **Coulomb friction as stick/slip modes**, the textbook way: while a surface slips,
  its friction is ``c sign`` with the sign frozen for the segment, and a terminal
  event on ``v = 0`` (``omega = 0``) stops the solver. There the required static
  force (the friction that would keep the velocity at zero) is computed; inside
  the friction band the surface sticks (velocity held at exactly 0), outside it the
  sign flips. While stuck, a terminal event on ``band - |required force|`` finds
  the breakaway. Both frictions can stick at once; which ones stick is decided by
  dropping those whose required force leaves the band until none does. This is
  Filippov's solution for friction laws affine in the sign, so it should, and does,
  agree with hybridlab's sliding mode (``check`` in ``trolley_check.py``).
* **Sensors as non-terminal events**: the rod tip entering or leaving each
  sensor's window (``x + r sin(phi) = p -+ w``) does not change the dynamics, so the
  four boundaries are ordinary ``solve_ivp`` events, located without a restart.
  Each root toggles the sensor output. Like any ``solve_ivp`` event, a boundary
  crossed twice inside one solver step is not seen.
* **The stop-and-return as a reference schedule**: the reference is piecewise
  quadratic in time; every segment end is known in advance (or computed at the
  stop) and is an integration boundary, so ``solve_ivp`` is restarted there. The
  sensor-1 detection during the approach is a terminal event; at it the cart
  position is recorded and the brake, return and hold segments are planned.

Unsupported model options (the sampled controller, sensor latency, profiles 2 and
4) raise ``ValueError``: the benchmark jobs do not use them.

``simulate_trolley`` is the general loop; ``free_drop``, ``stop_and_return`` and
``fig14_point`` are the three benchmark jobs.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace

import numpy as np
from common import ROOT
from scipy.integrate import solve_ivp

__all__ = ["MODEL", "Trolley", "TrolleyRun", "fig14_point", "free_drop", "rhs_values",
           "simulate_trolley", "stop_and_return"]

MODEL = ROOT / "models" / "trolley.toml"

#: Names of the event-log entries, as hybridlab spells them.
SLIP_V, SLIP_W = "sign(v)", "sign(omega)"
SENSOR_EDGES = ("s1_on", "s1_off", "s2_on", "s2_off")
#: A stuck surface breaks away once its required force exceeds the band by this
#: fraction. Without it the settled cart chatters: after the last slip the PI loop
#: leaves it stuck with the force on the band edge, a position error of 1e-17 m
#: winds the integrator across the edge, and stick and slip alternate every first
#: step (1e-4 s) for ever. Shifts a breakaway by about 1e-10 s.
BREAKAWAY_MARGIN = 1e-9


@dataclass(frozen=True)
class Trolley:
    """The numbers of one trolley job (parameters, initial state, horizon).

    Read from the model file with :meth:`from_model`, so the scipy program and
    hybridlab simulate the same values; the derived quantities are written here
    by hand.
    """

    g: float
    m_C: float
    c: float
    d: float
    m_r: float
    L_r: float
    m_l: float
    l_l: float
    r: float
    a_b: float
    b_b: float
    P_x: float
    P_v: float
    I_v: float
    K_u: float
    ff: float
    controller: float
    p_1: float
    d_s: float
    det: float
    profile: float
    t_go: float
    v_max: float
    a_max: float
    x0: float
    v0: float
    phi0: float
    omega0: float
    z0: float
    x_s0: float
    t_end: float

    @classmethod
    def from_model(cls, scenario: str, params: Mapping[str, float] | None = None,
                   initial: Mapping[str, float] | None = None,
                   t_end: float | None = None) -> Trolley:
        """The job of ``scenario`` in ``models/trolley.toml``, with overrides.

        Raises ``ValueError`` for model options this plain implementation does
        not cover (sampled controller, latency, profiles other than 0 and 1).
        """
        model = _model()
        sc = model.scenarios[scenario]
        p = {name: q.value for name, q in model.parameters.items()} | sc.parameters
        p |= dict(params or {})
        x = ({name: s.initial for name, s in model.states.items()}
             | {name: float(d.value) for name, d in model.discrete.items()} | sc.initial)
        x |= dict(initial or {})
        for name in ("sampled", "latency"):
            if p[name] != 0.0:
                raise ValueError(f"{name} must be 0 for the plain scipy trolley (got {p[name]!r})")
        if p["profile"] not in (0.0, 1.0):
            raise ValueError(f"profile must be 0 or 1 for the plain scipy trolley "
                             f"(got {p['profile']!r})")
        for name in ("z_d", "u_h", "tau", "v_s", "a_s", "pending", "started", "S_1", "S_2"):
            if x[name] != 0.0:
                raise ValueError(f"initial {name} must be 0 for the plain scipy trolley "
                                 f"(got {x[name]!r})")
        fields = {f: p[f] for f in cls.__dataclass_fields__ if f in p}
        return cls(**fields, x0=x["x"], v0=x["v"], phi0=x["phi"], omega0=x["omega"],
                   z0=x["z"], x_s0=x["x_s"], t_end=sc.t_end if t_end is None else t_end)

    # hand-derived constants of the equations of motion
    @property
    def m_p(self) -> float:
        return self.m_r + self.m_l

    @property
    def ml(self) -> float:
        """``m_p l_c`` (the pendulum's static moment)."""
        return self.m_r * self.L_r / 2 + self.m_l * self.l_l

    @property
    def J(self) -> float:
        """Pendulum inertia about the pivot."""
        return self.m_r * self.L_r**2 / 3 + self.m_l * self.l_l**2

    @property
    def M_t(self) -> float:
        """Translational inertia of cart plus pendulum, ``M_block + m_p``."""
        m_block = self.m_C - self.m_p * (1 - self.ml**2 / (self.m_p * self.J))
        return m_block + self.m_p

    @property
    def w(self) -> float:
        """Half-width of a sensor's window for the rod tip."""
        return self.r * math.sin(self.det)


@dataclass(frozen=True)
class TrolleyRun:
    """What the scipy program produced.

    Attributes
    ----------
    events : tuple of (float, str)
        Every event in time order, named as in hybridlab's log: sensor edges
        (``s1_on`` ...), manoeuvre transitions (``detect``, ``stop``, ``turn`` ...),
        friction events ``"slide_start sign(v)"``, ``"slide_end sign(omega)"``,
        ``"crossing sign(v)"`` and so on.
    t : float
        Final time.
    state : tuple of float
        ``(x, v, phi, omega, z)`` at ``t``.
    x_e : float or None
        Cart position recorded at the sensor event (stop-and-return only).
    steps : int
        Accepted ``solve_ivp`` steps over all restarts.
    restarts : int
        ``solve_ivp`` calls.
    """

    events: tuple[tuple[float, str], ...]
    t: float
    state: tuple[float, ...]
    x_e: float | None
    steps: int
    restarts: int

    def times(self, name: str) -> np.ndarray:
        """Times of the events called ``name``."""
        return np.array([t for t, n in self.events if n == name])


@functools.lru_cache(maxsize=1)
def _model():  # noqa: ANN202 - hybridlab.Model, imported lazily
    import hybridlab

    return hybridlab.load_model(MODEL)


# ----- dynamics ---------------------------------------------------------------------------
@dataclass(frozen=True)
class _Segment:
    """A piece of the reference: ``x_ref = x0 + v0 (t - t0) + a0 (t - t0)^2 / 2``."""

    name: str
    t0: float
    x0: float
    v0: float
    a0: float
    t1: float  # end of the segment (inf: open)
    v_p: float = 0.0  # peak speed of the return move


    def at(self, t: float) -> tuple[float, float]:
        tau = t - self.t0
        return self.x0 + self.v0 * tau + 0.5 * self.a0 * tau * tau, self.v0 + self.a0 * tau


@dataclass(frozen=True)
class _Friction:
    """The friction mode: which surfaces stick, and the frozen signs of the others."""

    stuck_v: bool
    stuck_w: bool
    s_v: float
    s_w: float


def _make_rhs(tr: Trolley, seg: _Segment, fr: _Friction) -> Callable[[float, np.ndarray], list]:
    """``y' = f(t, y)`` for ``y = (x, v, phi, omega, z)`` in one friction mode."""
    M_t, ml, J, mgl = tr.M_t, tr.ml, tr.J, tr.ml * tr.g
    c, d, a_b, b_b = tr.c, tr.d, tr.a_b, tr.b_b
    P_x, P_v, I_v, K, ff = tr.P_x, tr.P_v, tr.I_v, tr.controller * tr.K_u, tr.ff
    t0, x0, v0, a0 = seg.t0, seg.x0, seg.v0, seg.a0
    f_v, f_w = c * fr.s_v, a_b * fr.s_w
    sin, cos = math.sin, math.cos

    if fr.stuck_v and fr.stuck_w:
        def rhs(t: float, y: np.ndarray) -> list:
            tau = t - t0
            e_v = ff * (v0 + a0 * tau) + P_x * (x0 + v0 * tau + 0.5 * a0 * tau * tau - y[0])
            return [0.0, 0.0, 0.0, 0.0, e_v]
    elif fr.stuck_v:
        def rhs(t: float, y: np.ndarray) -> list:
            tau = t - t0
            e_v = ff * (v0 + a0 * tau) + P_x * (x0 + v0 * tau + 0.5 * a0 * tau * tau - y[0])
            om = y[3]
            alpha = (-f_w - b_b * om - mgl * sin(y[2])) / J
            return [0.0, 0.0, om, alpha, e_v]
    elif fr.stuck_w:
        def rhs(t: float, y: np.ndarray) -> list:
            tau = t - t0
            x, v = y[0], y[1]
            e_v = ff * (v0 + a0 * tau) + P_x * (x0 + v0 * tau + 0.5 * a0 * tau * tau - x) - v
            F_in = K * (P_v * e_v + I_v * y[4])
            return [v, (F_in - f_v - d * v) / M_t, 0.0, 0.0, e_v]
    else:
        def rhs(t: float, y: np.ndarray) -> list:
            tau = t - t0
            x, v, phi, om, z = y
            e_v = ff * (v0 + a0 * tau) + P_x * (x0 + v0 * tau + 0.5 * a0 * tau * tau - x) - v
            F_in = K * (P_v * e_v + I_v * z)
            s, co = sin(phi), cos(phi)
            q1 = F_in - f_v - d * v + ml * om * om * s
            q2 = -f_w - b_b * om - mgl * s
            m12 = ml * co
            det = M_t * J - m12 * m12
            return [v, (J * q1 - m12 * q2) / det, om, (M_t * q2 - m12 * q1) / det, e_v]
    return rhs


def rhs_values(tr: Trolley, t: float, y: np.ndarray, x_ref: float, v_ref: float,
               s_v: float, s_w: float) -> np.ndarray:
    """The slipping right-hand side at one point, for checks against hybridlab's flow."""
    seg = _Segment("check", t, x_ref, v_ref, 0.0, math.inf)
    return np.array(_make_rhs(tr, seg, _Friction(False, False, s_v, s_w))(t, y))


def _required(tr: Trolley, seg: _Segment, fr: _Friction, t: float,
              y: np.ndarray) -> tuple[float, float]:
    """Friction force / torque that keeps the stuck surfaces stuck (nan for slipping ones)."""
    x, v, phi, om, z = y
    x_ref, v_ref = seg.at(t)
    e_v = tr.ff * v_ref + tr.P_x * (x_ref - x) - v
    F_in = tr.controller * tr.K_u * (tr.P_v * e_v + tr.I_v * z)
    s, co = math.sin(phi), math.cos(phi)
    mgl = tr.ml * tr.g
    if fr.stuck_v and fr.stuck_w:
        return F_in, -mgl * s
    if fr.stuck_v:  # v' = 0: the pendulum row gives omega', the cart row the force
        alpha = (-tr.a_b * fr.s_w - tr.b_b * om - mgl * s) / tr.J
        return F_in + tr.ml * om * om * s - tr.ml * co * alpha, math.nan
    if fr.stuck_w:  # omega' = 0: the cart row gives v', the pendulum row the torque
        a = (F_in - tr.c * fr.s_v - tr.d * v) / tr.M_t
        return math.nan, -mgl * s - tr.ml * co * a
    return math.nan, math.nan


def _resolve(tr: Trolley, seg: _Segment, fr: _Friction, t: float, y: np.ndarray) -> _Friction:
    """Release every stuck surface whose required force leaves its band, until none does."""
    while fr.stuck_v or fr.stuck_w:
        F, T = _required(tr, seg, fr, t, y)
        drop_v = fr.stuck_v and abs(F) > tr.c * (1 + BREAKAWAY_MARGIN)
        drop_w = fr.stuck_w and abs(T) > tr.a_b * (1 + BREAKAWAY_MARGIN)
        if not (drop_v or drop_w):
            break
        fr = _Friction(fr.stuck_v and not drop_v, fr.stuck_w and not drop_w,
                       math.copysign(1.0, F) if drop_v else fr.s_v,
                       math.copysign(1.0, T) if drop_w else fr.s_w)
    return fr


# ----- events -----------------------------------------------------------------------------
def _event(fn: Callable, *, terminal: bool, direction: float) -> Callable:
    fn.terminal = terminal  # type: ignore[attr-defined]
    fn.direction = direction  # type: ignore[attr-defined]
    return fn


def _friction_events(tr: Trolley, seg: _Segment, fr: _Friction,
                     t_start: float) -> list[tuple[str, Callable]]:
    """Terminal events: a slipping velocity reaching 0, a stuck surface breaking away.

    Each returns its value *before* the crossing at the restart instant itself
    (the bouncing-ball loop's guard), so an event just handled cannot be found
    again at ``t_start``: after a stick/slip decision taken exactly on the band
    edge, the velocity or band margin starts at a rounding error from zero and
    ``solve_ivp`` would otherwise report it at ``t_start`` forever.
    """
    def slip(k: int, sign: float) -> Callable:
        return _event(lambda t, y: sign if t == t_start else y[k], terminal=True,
                      direction=-sign)

    def stick(k: int, band: float) -> Callable:
        band *= 1 + BREAKAWAY_MARGIN
        return _event(lambda t, y: 1.0 if t == t_start
                      else band - abs(_required(tr, seg, fr, t, y)[k]),
                      terminal=True, direction=-1)

    return [("break_v", stick(0, tr.c)) if fr.stuck_v else ("zero_v", slip(1, fr.s_v)),
            ("break_w", stick(1, tr.a_b)) if fr.stuck_w else ("zero_w", slip(3, fr.s_w))]


def _sensor_events(tr: Trolley, approach: bool, t_start: float,
                   just_fired: int | None) -> list[tuple[str, Callable]]:
    """The four window boundaries of the two sensors, as events on the rod tip.

    During the approach the left boundary of sensor 1 is terminal (the
    detection). A boundary that fired terminally at the restart instant returns
    +1 there, so ``solve_ivp`` cannot report it a second time at ``t_start``
    (the same guard as the bouncing-ball loop).
    """
    r, w = tr.r, tr.w
    bounds = (tr.p_1 - w, tr.p_1 + w, tr.p_1 + tr.d_s - w, tr.p_1 + tr.d_s + w)
    out = []
    for k, b in enumerate(bounds):
        if k == just_fired:
            def fn(t: float, y: np.ndarray, b: float = b) -> float:
                return 1.0 if t == t_start else y[0] + r * math.sin(y[2]) - b
        else:
            def fn(t: float, y: np.ndarray, b: float = b) -> float:
                return y[0] + r * math.sin(y[2]) - b
        detect = approach and k == 0
        out.append((f"sensor{k}", _event(fn, terminal=detect, direction=1 if detect else 0)))
    return out


# ----- the restart loop -------------------------------------------------------------------
def _advance(tr: Trolley, seg: _Segment, t: float, y: np.ndarray,
             x_e: float | None) -> tuple[list[str], _Segment]:
    """The reference segment after ``seg`` (which ends at ``t``), and the transitions' names."""
    a, v_max = tr.a_max, tr.v_max
    x_ref, v_ref = seg.at(t)
    if seg.name == "hold":  # t_go: start the manoeuvre from where the cart is
        return ["start_stop_return"], _Segment("approach_acc", t, float(y[0]), 0.0, a,
                                               t + v_max / a)
    if seg.name == "approach_acc":
        return ["cruise"], _Segment("approach_cruise", t, x_ref, v_max, 0.0, math.inf)
    if x_e is None:
        raise RuntimeError(f"segment {seg.name!r} ended before the sensor event")
    if seg.name == "brake":  # plan the return: triangle or trapezoid
        v_p = min(v_max, math.sqrt(a * (x_ref - x_e)))
        return ["turn"], _Segment("ret_acc", t, x_ref, 0.0, -a, t + v_p / a, v_p)
    if seg.name == "ret_acc":
        v_p = seg.v_p
        cruise = (x_ref - x_e - v_p**2 / (2 * a)) / v_p
        if cruise > 0:
            return ["ret_cruise"], _Segment("ret_cruise", t, x_ref, -v_p, 0.0, t + cruise, v_p)
        return ["ret_cruise", "ret_dec"], _Segment("ret_dec", t, x_ref, -v_p, a, t + v_p / a, v_p)
    if seg.name == "ret_cruise":
        return ["ret_dec"], _Segment("ret_dec", t, x_ref, -seg.v_p, a, t + seg.v_p / a, seg.v_p)
    if seg.name == "ret_dec":
        return ["arrive"], _Segment("hold", t, x_e, 0.0, 0.0, math.inf)
    raise RuntimeError(f"segment {seg.name!r} has no successor")


def simulate_trolley(tr: Trolley, *, method: str = "DOP853", rtol: float = 1e-8,
                     atol: float = 1e-10, max_step: float = math.inf,
                     max_restarts: int = 100_000) -> TrolleyRun:
    """Simulate ``tr`` from 0 to ``tr.t_end`` with a ``solve_ivp`` restart loop.

    Raises ``RuntimeError`` if ``solve_ivp`` fails or after ``max_restarts``
    restarts (stick/slip chattering).
    """
    t = 0.0
    y = np.array([tr.x0, tr.v0, tr.phi0, tr.omega0, tr.z0], dtype=float)
    events: list[tuple[float, str]] = []
    # hold the set point; with profile 1 the stop-and-return starts at t_go
    seg = _Segment("hold", 0.0, tr.x_s0, 0.0, 0.0,
                   max(tr.t_go, 0.0) if tr.profile == 1.0 else math.inf)
    tip = y[0] + tr.r * math.sin(y[2])
    sensor_on = [abs(tip - tr.p_1) <= tr.w, abs(tip - tr.p_1 - tr.d_s) <= tr.w]
    for i, on in enumerate(sensor_on):
        if on:
            events.append((t, f"s{i + 1}_on"))
    if tr.profile == 1.0 and tip >= tr.p_1 - tr.w:
        raise ValueError(f"the rod tip starts at or past sensor 1 (tip {tip!r}, p_1 {tr.p_1!r})")
    fr = _resolve(tr, seg, _Friction(y[1] == 0.0, y[3] == 0.0, 1.0, 1.0), t, y)
    just_fired: int | None = None
    x_e: float | None = None
    steps = restarts = 0
    while True:
        if seg.t1 <= t:  # the reference segment is over: the next one starts here
            names, seg = _advance(tr, seg, t, y, x_e)
            events += [(t, n) for n in names]
            fr = _resolve(tr, seg, fr, t, y)
            continue
        if t >= tr.t_end:
            break
        approach = seg.name in ("approach_acc", "approach_cruise")
        fric = _friction_events(tr, seg, fr, t)
        sens = _sensor_events(tr, approach, t, just_fired)
        just_fired = None
        sol = solve_ivp(_make_rhs(tr, seg, fr), (t, min(seg.t1, tr.t_end)), y, method=method,
                        rtol=rtol, atol=atol, max_step=max_step,
                        events=[fn for _, fn in fric + sens])
        if sol.status == -1:
            raise RuntimeError(f"solve_ivp failed at t = {sol.t[-1]!r}: {sol.message}")
        if restarts >= max_restarts:
            raise RuntimeError(f"more than {max_restarts} restarts by t = {t!r}: chattering")
        steps += sol.t.size - 1
        restarts += 1
        # sensor edges: every root of a window boundary toggles its sensor
        roots = sorted((float(te), k) for k in range(4) for te in sol.t_events[len(fric) + k])
        for te, k in roots:
            i = k // 2
            sensor_on[i] = not sensor_on[i]
            events.append((te, f"s{i + 1}_{'on' if sensor_on[i] else 'off'}"))
        if sol.status == 0:  # reached the end of the segment (or t_end)
            t, y = float(sol.t[-1]), sol.y[:, -1].copy()
            continue
        hit = next(i for i, (_, fn) in enumerate(fric + sens)
                   if fn.terminal and sol.t_events[i].size)
        t = float(sol.t_events[hit][-1])
        y = sol.y_events[hit][-1].copy()
        if hit >= len(fric):  # sensor 1 sees the screw: record x, brake from the reference
            x_e = float(y[0])
            x_ref, v_ref = seg.at(t)
            events += [(t, "detect"), (t, "stop")]
            seg = _Segment("brake", t, x_ref, v_ref, -tr.a_max, t + v_ref / tr.a_max)
            just_fired = 0
            fr = _resolve(tr, seg, fr, t, y)
            continue
        kind = fric[hit][0]
        if kind == "zero_v":
            y[1] = 0.0
            fr = _resolve(tr, seg, replace(fr, stuck_v=True), t, y)
            events.append((t, f"{'slide_start' if fr.stuck_v else 'crossing'} {SLIP_V}"))
        elif kind == "zero_w":
            y[3] = 0.0
            fr = _resolve(tr, seg, replace(fr, stuck_w=True), t, y)
            events.append((t, f"{'slide_start' if fr.stuck_w else 'crossing'} {SLIP_W}"))
        else:
            F, T = _required(tr, seg, fr, t, y)
            if kind == "break_v":
                fr = replace(fr, stuck_v=False, s_v=math.copysign(1.0, F))
                events.append((t, f"slide_end {SLIP_V}"))
            else:
                fr = replace(fr, stuck_w=False, s_w=math.copysign(1.0, T))
                events.append((t, f"slide_end {SLIP_W}"))
            fr = _resolve(tr, seg, fr, t, y)
    events.sort(key=lambda e: e[0])  # stable: same-instant events keep their order
    return TrolleyRun(tuple(events), t, tuple(float(v) for v in y), x_e, steps, restarts)


# ----- the benchmark jobs -----------------------------------------------------------------
def free_drop(*, t_end: float | None = None, method: str = "DOP853", rtol: float = 1e-8,
              atol: float = 1e-10, max_step: float = math.inf) -> TrolleyRun:
    """Scenario ``free_drop``: the pendulum dropped from 90 deg, the cart held."""
    return simulate_trolley(Trolley.from_model("free_drop", t_end=t_end), method=method,
                            rtol=rtol, atol=atol, max_step=max_step)


def stop_and_return(*, p_1: float | None = None, a_max: float | None = None,
                    t_end: float | None = None, method: str = "DOP853", rtol: float = 1e-8,
                    atol: float = 1e-10, max_step: float = math.inf) -> TrolleyRun:
    """Scenario ``default``: the event-based stop-and-return (Fig. 13)."""
    params = {k: v for k, v in (("p_1", p_1), ("a_max", a_max)) if v is not None}
    return simulate_trolley(Trolley.from_model("default", params, t_end=t_end), method=method,
                            rtol=rtol, atol=atol, max_step=max_step)


def residual_edges(run: TrolleyRun) -> int:
    """Sensor-1 edges after the arrival (the count of Fig. 14); -1 if it never arrived."""
    arrive = run.times("arrive")
    if arrive.size == 0:
        return -1
    return sum(1 for t, n in run.events if n in ("s1_on", "s1_off") and t > arrive[0])


def fig14_point(p_1: float, a_max: float, hold: float, rtol: float = 1e-8, atol: float = 1e-10,
                method: str = "DOP853") -> int:
    """One point of the Fig. 14 sweep: residual sensor-1 edges after a stop-and-return.

    The manoeuvre with sensor 1 at ``p_1`` and acceleration ``a_max``, simulated
    to ``12 + hold`` seconds like ``examples/reproduce_paper.py``; returns the
    number of sensor-1 edges after the arrival (-1 if the cart never arrived).
    """
    run = stop_and_return(p_1=p_1, a_max=a_max, t_end=12.0 + hold, method=method, rtol=rtol,
                          atol=atol)
    return residual_edges(run)
