"""Discontinuous flows: choosing the sign of each switch, and Filippov sliding.

At a point on a switching surface ``s_k = 0`` the flows on both sides decide
what happens (Filippov): if both push the state across, it crosses; if both
push towards the surface, the state *slides* on it with the equivalent
dynamics, obtained by solving ``ds_k/dt = 0`` for the sign value
``sigma_k in [-1, 1]`` (for flows affine in ``sigma`` this is exactly
Filippov's convex combination). Several surfaces may slide at once; the set
is found by an active-set iteration. Sliding ends when an equivalent value
reaches +-1, which the simulator watches as an event.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np

from hybridlab.errors import SimulationError
from hybridlab.simulation.rules import EQUAL_SLOPES, EQUIVALENT_SIGN_SLACK
from hybridlab.symbolic.compile import CompiledMode

__all__ = ["equivalent_sigma", "equivalent_sigma_batch", "resolve_switches"]


def _sdot(mode: CompiledMode, t: float, x: np.ndarray, p: np.ndarray,
          sigma: np.ndarray) -> np.ndarray:
    f = mode.flow(t, x, p, sigma)
    return mode.switch_fields.derivative(t, x, p, sigma, f)


def _dsigma(mode: CompiledMode):
    if mode.flow_dsigma is None:
        raise SimulationError(f"mode {mode.name!r} has no discontinuity to slide on")
    return mode.flow_dsigma


def _require_affine(mode: CompiledMode, sliding: Sequence[int]) -> None:
    if not mode.affine_in_sigma:
        names = ", ".join(mode.switches[k].text for k in sliding)
        raise SimulationError(
            f"mode {mode.name!r}: sliding on {names} needs a flow that is affine in the sign "
            "of each switching function (e.g. c*sign(v)); rewrite the discontinuity or use modes")


def equivalent_sigma(mode: CompiledMode, t: float, x: np.ndarray, p: np.ndarray,
                     sigma: np.ndarray, sliding: Sequence[int]) -> np.ndarray:
    """Equivalent sign values of the ``sliding`` switches at one point.

    Solves ``ds_S/dt = 0`` (linear in ``sigma_S`` for flows affine in sigma).

    Examples
    --------
    The relay ``x' = -k sign(x) + w0 sin(omega t)`` slides on ``x = 0`` with
    ``sigma = w0 sin(omega t) / k``:

    >>> import hybridlab
    >>> compiled = hybridlab.compile_model(hybridlab.load_model("models/relay_sliding.toml"))
    >>> relay, p = compiled.modes["relay"], compiled.parameter_vector({"w0": 0.5})
    >>> equivalent_sigma(relay, np.pi / 2, np.array([0.0]), p, np.array([1.0]), [0]).tolist()
    [0.5]
    """
    sliding = list(sliding)
    base = sigma.copy()
    base[sliding] = 0.0
    f0 = mode.flow(t, x, p, base)
    b = mode.switch_fields.derivative(t, x, p, base, f0)[sliding]
    grad = mode.switch_fields.gradient(t, x, p, base)[sliding]
    a = grad @ _dsigma(mode)(t, x, p, base)[:, sliding]
    try:
        return np.linalg.solve(a, -b)
    except np.linalg.LinAlgError:
        names = ", ".join(mode.switches[k].text for k in sliding)
        raise SimulationError(
            f"mode {mode.name!r}: sliding on {names} at t={t!r} is not uniquely defined "
            "(the equivalent-dynamics matrix is singular)") from None


def equivalent_sigma_batch(mode: CompiledMode, t: np.ndarray, x: np.ndarray, p: np.ndarray,
                           sigma: np.ndarray, sliding: Sequence[int]) -> np.ndarray:
    """:func:`equivalent_sigma` at ``k`` points; returns shape ``(len(sliding), k)``.

    Examples
    --------
    >>> import hybridlab
    >>> compiled = hybridlab.compile_model(hybridlab.load_model("models/relay_sliding.toml"))
    >>> relay, p = compiled.modes["relay"], compiled.parameter_vector({"w0": 0.5})
    >>> t = np.array([0.0, np.pi / 6, np.pi / 2])
    >>> sigma = equivalent_sigma_batch(relay, t, np.zeros((1, 3)), p, np.array([1.0]), [0])
    >>> sigma.round(12).tolist()
    [[0.0, 0.25, 0.5]]
    """
    sliding = list(sliding)
    base = sigma.copy()
    base[sliding] = 0.0
    f0 = mode.flow.batch(t, x, p, base)
    b = mode.switch_fields.batch_derivative(t, x, p, base, f0)[sliding]
    grad = mode.switch_fields.gradient_batch(t, x, p, base)[sliding]
    dsig = _dsigma(mode).batch(t, x, p, base)[:, sliding]
    a = np.einsum("snk,nrk->ksr", grad, dsig)
    try:
        return np.linalg.solve(a, -b.T[..., None])[..., 0].T
    except np.linalg.LinAlgError:
        return np.full((len(sliding), np.size(t)), np.inf)


def resolve_switches(mode: CompiledMode, t: float, x: np.ndarray, p: np.ndarray,
                     sigma: np.ndarray, at_surface: Iterable[int],
                     forced: dict[int, float] | None = None) -> tuple[np.ndarray, tuple[int, ...]]:
    """Decide the sign of every switch at a point where ``at_surface`` switches vanish.

    Parameters
    ----------
    mode : CompiledMode
    t, x, p : time, state, parameters
    sigma : numpy.ndarray
        Current signs (+-1); entries of ``at_surface`` are re-decided.
    at_surface : iterable of int
        Switches with ``s_k = 0`` at this point.
    forced : dict, optional
        Switches whose sign is fixed (a sliding motion that just ended).

    Returns
    -------
    sigma : numpy.ndarray
        New signs; sliding entries hold their equivalent value.
    sliding : tuple of int
        The switches that slide.

    Examples
    --------
    On ``x = 0`` the relay ``x' = -k sign(x) + w0 sin(omega t)`` (``k = 1``) slides while
    the disturbance is within its authority, and is pushed across when it is not:

    >>> import hybridlab
    >>> compiled = hybridlab.compile_model(hybridlab.load_model("models/relay_sliding.toml"))
    >>> relay, x = compiled.modes["relay"], np.array([0.0])
    >>> weak, strong = (compiled.parameter_vector({"w0": w0}) for w0 in (0.5, 2.0))
    >>> resolve_switches(relay, np.pi / 2, x, weak, np.array([1.0]), [0])
    (array([0.5]), (0,))
    >>> resolve_switches(relay, np.pi / 2, x, strong, np.array([-1.0]), [0])
    (array([1.]), ())
    """
    sigma = sigma.copy()
    previous = sigma.copy()
    forced = forced or {}
    for k, value in forced.items():
        sigma[k] = value
    sliding = [k for k in sorted(set(at_surface)) if k not in forced]

    def sides(k: int) -> tuple[float, float]:
        plus, minus = sigma.copy(), sigma.copy()
        plus[k], minus[k] = 1.0, -1.0
        return _sdot(mode, t, x, p, plus)[k], _sdot(mode, t, x, p, minus)[k]

    def leave(k: int, d_plus: float, d_minus: float) -> None:
        sliding.remove(k)
        if d_plus > 0 and d_minus > 0:
            sigma[k] = 1.0
        elif d_plus < 0 and d_minus < 0:
            sigma[k] = -1.0
        else:  # repelling or tangential: keep going the way the state came
            sigma[k] = 1.0 if previous[k] >= 0 else -1.0

    # a surface whose flow does not depend on its sign (abs, min, max) is crossed, not slid on
    for k in list(sliding):
        d_plus, d_minus = sides(k)
        if abs(d_plus - d_minus) <= EQUAL_SLOPES * (abs(d_plus) + abs(d_minus)):
            leave(k, d_plus, d_minus)
    # active set: all candidates slide jointly; drop those whose equivalent sign leaves
    # [-1, 1] or that do not attract, and solve again
    for _ in range(2 * len(sliding) + 2):
        if not sliding:
            break
        _require_affine(mode, sliding)
        sigma[sliding] = 0.0
        eq = equivalent_sigma(mode, t, x, p, sigma, sliding)
        sigma[sliding] = eq
        outside = [k for k, value in zip(sliding, eq, strict=True) if
                   abs(value) > 1 + EQUIVALENT_SIGN_SLACK]
        if outside:
            for k in outside:
                sigma[k] = float(np.sign(sigma[k]))
                sliding.remove(k)
            continue
        repelling = [(k, *sides(k)) for k in sliding]
        repelling = [(k, dp, dm) for k, dp, dm in repelling if not (dp <= 0 <= dm and dm > dp)]
        if not repelling:
            break
        for k, d_plus, d_minus in repelling:
            leave(k, d_plus, d_minus)
    return sigma, tuple(sliding)
