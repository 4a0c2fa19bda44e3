"""The ARCH-COMP gearbox (``models/spaceex/gearbox.xml``): collisions with the two flanks of
a gear tooth and the meshing, checked against runs solved in closed form."""

from __future__ import annotations

import math

import numpy as np
import pytest

_THETA = 0.628318530717959
_MS, _MG2, _ZETA = 3.2, 18.1, 0.9
_ACCEL = np.array([70.0 / _MS, -0.08 * 1.0 / 0.7])  # Fs / ms, -Rs Tf / Jg2


def _collision(vx: float, vy: float, sign: float) -> tuple[float, float, float]:
    """``(vx, vy, impulse)`` after hitting the upper (``sign = 1``) or lower flank, by the
    impact law with restitution, from the physical parameters (not the model file)."""
    s, c = math.sin(_THETA), math.cos(_THETA)
    den = _MS * c**2 + _MG2 * s**2
    new_vx = ((_MS * c**2 - _MG2 * _ZETA * s**2) * vx
              - sign * (_ZETA + 1) * _MG2 * s * c * vy) / den
    new_vy = (-sign * (_ZETA + 1) * _MS * s * c * vx
              + (_MG2 * s**2 - _MS * _ZETA * c**2) * vy) / den
    impulse = (_ZETA + 1) * _MS * _MG2 * (s * vx + sign * c * vy) / den
    return new_vx, new_vy, impulse


def _first_root(g0: float, g1: float, g2: float) -> float:
    """The first ``tau > 0`` with ``g0 + g1 tau + g2 tau^2 / 2 = 0`` (``inf``: none)."""
    roots = np.roots([0.5 * g2, g1, g0]) if g2 != 0.0 else np.array([-g0 / g1])
    real = [r.real for r in np.atleast_1d(roots) if abs(r.imag) < 1e-15 and r.real > 1e-12]
    return min(real, default=math.inf)


def _run(px: float, py: float, t_end: float = 0.21):
    """The exact run from rest at ``(px, py)``: pieces ``(mode, t0, t1, state at t0)``."""
    tan = math.tan(_THETA)
    x = np.array([0.0, 0.0, px, py, 0.0])  # vx, vy, px, py, I
    t, pieces = 0.0, []
    while t < t_end:
        vx, vy, px, py, _ = x
        ax, ay = _ACCEL
        # the flanks py + tan px = 0 (upper) and py - tan px = 0 (lower), and px = -0.003
        hits = {
            "upper": _first_root(py + tan * px, vy + tan * vx, ay + tan * ax),
            "lower": _first_root(py - tan * px, vy - tan * vx, ay - tan * ax),
            "mesh": _first_root(px + 0.003, vx, ax),
        }
        what, tau = min(hits.items(), key=lambda kv: kv[1])
        t1 = min(t + tau, t_end)
        pieces.append(("free", t, t1, x.copy()))
        if t1 >= t_end:
            break
        x[:2] = x[:2] + _ACCEL * tau
        x[2:4] = x[2:4] + np.array([vx, vy]) * tau + 0.5 * _ACCEL * tau**2
        if what == "mesh":
            x[4] += _MS * (x[0] + x[1])
            x[:2] = 0.0
            pieces.append(("meshed", t1, t_end, x.copy()))
            break
        x[0], x[1], impulse = _collision(x[0], x[1], 1.0 if what == "upper" else -1.0)
        x[4] += impulse
        t = t1
    return pieces


def _states(piece, times: np.ndarray) -> np.ndarray:
    mode, t0, _, x = piece
    tau = times - t0
    if mode == "meshed":
        return np.column_stack([np.tile(x, (tau.size, 1)), times])
    vel = x[:2] + np.outer(tau, _ACCEL)
    pos = x[2:4] + np.outer(tau, x[:2]) + 0.5 * np.outer(tau**2, _ACCEL)
    return np.column_stack([vel, pos, np.full(tau.size, x[4]), times])


@pytest.mark.parametrize("cfg, px, py", [
    ("gearbox_grbx01.cfg", (-0.0168, -0.0166), (0.0029, 0.0031)),
])
def test_gearbox_runs_lie_in_the_flowpipes_through_every_collision_and_the_meshing(
        spaceex_proof, cfg, px, py):
    """GRBX01-MES01 is proved with default options (meshed before t = 0.2, impulse below
    20), and exact runs from the corners and random points of the initial box (closed-form
    parabolas between collisions, each collision at the exact root of the flank's
    quadratic) lie in the flowpipes of their modes, before and after every collision; the
    same samples moved 1 mm along ``px`` are not all covered."""
    verdict = spaceex_proof("gearbox.xml", cfg)
    result = verdict.reach
    assert result.complete and list(result.state_names[:5]) == ["vx", "vy", "px", "py", "I"]
    rng = np.random.default_rng(5)
    corners = [(a, b) for a in px for b in py]
    starts = corners + [(rng.uniform(*px), rng.uniform(*py)) for _ in range(6)]
    collisions, highest, outside = 0, 0.0, 0
    for x0, y0 in starts:
        pieces = _run(x0, y0)
        collisions += sum(1 for p in pieces if p[0] == "free") - 1
        assert pieces[-1][0] == "meshed" and pieces[-1][1] < 0.2
        for piece in pieces:
            mode, t0, t1, _ = piece
            times = np.linspace(t0, t1, 15)
            states = _states(piece, times)
            inside = result.covers(times, states, mode, tol=1e-9)
            assert inside.all(), (x0, y0, mode, times[~inside][0])
            shifted = states + np.r_[0.0, 0.0, 1e-3, 0.0, 0.0, 0.0]
            outside += int((~result.covers(times, shifted, mode, tol=1e-9)).sum())
            highest = max(highest, float(states[:, 4].max()))
    assert collisions >= 2 * len(starts)  # every run bounced off the flanks before meshing
    assert 15.0 < highest < 20.0 and outside > 0
