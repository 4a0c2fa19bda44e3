"""Model parameters from summary quantities: :func:`fit_targets`.

Each :class:`~hybridlab.identify.targets.Target` is one number a simulated experiment
should reproduce (an event count, a period, a value at events, a step overshoot or
settling time) with its uncertainty. :func:`fit_targets` simulates every experiment once
per parameter point, computes the statistics with the continuous surrogates of
:mod:`hybridlab.identify.summary`, and minimises the weighted residuals
``(simulated - target) / sigma`` with :func:`scipy.optimize.least_squares`.

Counts stay convergent because the residual uses the *continuous count* (crossings plus
the fraction of the way to the next one), compared with ``N + 1/2`` for a measured ``N``
(a measured N means the continuous count lies in ``(N, N + 1]``) with the quantisation
``1/sqrt(12)`` added to the tolerance: the residual is continuous and piecewise smooth in
the parameters, so finite differences give a usable gradient even where the integer
count changes.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from hybridlab.errors import HybridlabError, ModelError
from hybridlab.identify._optimise import BudgetSpent, ParameterSpace, minimise_residuals
from hybridlab.identify._report import axes, format_table
from hybridlab.identify.targets import MAX_SAMPLES, Target, _Observers, target_statistic
from hybridlab.model.schema import Model
from hybridlab.simulation.api import simulate
from hybridlab.simulation.observe import Observer
from hybridlab.simulation.problem import HybridProblem, as_compiled
from hybridlab.symbolic.compile import CompiledModel

__all__ = ["TargetFit", "fit_targets"]

_METHODS = ("least_squares", "nelder-mead")
#: Residual (in sigmas) of a quantity the simulation does not produce.
MISSING_PENALTY = 30.0


@dataclass(frozen=True)
class TargetFit:
    """Result of :func:`fit_targets`.

    Attributes
    ----------
    parameters, uncertainties, initial : dict of str to float
        Estimates, their standard errors (from the Jacobian of the weighted residuals,
        ``cov = (J^T J)^-1``, tolerances read as standard uncertainties; NaN where the
        Jacobian is rank deficient or the method has none) and the start values.
    targets : tuple of Target
    simulated, simulated_initial : tuple of float
        The statistics at the estimate and at the start (counts as integers).
    continuous : tuple of float
        The continuous statistics at the estimate (what the residuals use).
    residuals, residuals_initial : numpy.ndarray
        ``(continuous - reference) / sigma`` per target at the estimate and at the start
        (a quantity the simulation does not produce counts as ``MISSING_PENALTY``).
    cost : float
        Half the sum of squared residuals.
    singular_values : numpy.ndarray
        Of the weighted Jacobian with respect to the relative (log) parameter changes:
        a small one means a combination of parameters the targets barely determine.
    weakest : dict of str to float
        That combination: the right singular vector of the smallest singular value
        (components on relative changes of the parameters).
    correlation : numpy.ndarray
        Correlation matrix of the estimates (NaN when not available).
    n_evaluations : int
        Parameter points simulated (each runs every experiment once).
    success : bool
    message : str

    Examples
    --------
    The bouncing ball's restitution ``e`` from its first apex (6.4 m means ``e = 0.8``),
    from 0.79 and with a budget of four parameter points:

    >>> from hybridlab.identify.targets import Target
    >>> apex = Target("value", 6.4, 0.01, transition="bounce", at="h + v**2/(2*g)",
    ...               index=0, t_end=1.6)
    >>> result = fit_targets("models/bouncing_ball.toml", [apex], fit=["e"],
    ...                      initial_guess={"e": 0.79}, max_evaluations=4,
    ...                      simulation_options={"backend": "reference"})
    >>> round(result.parameters["e"], 3), result.n_evaluations, result.message
    (0.8, 4, 'stopped after max_evaluations = 4 parameter points')
    >>> round(result.simulated_initial[0], 3), round(result.simulated[0], 2)
    (6.241, 6.4)
    >>> round(float(result.residuals_initial[0]), 1), bool(abs(result.residuals[0]) < 1)
    (-15.9, True)
    """

    parameters: dict[str, float]
    uncertainties: dict[str, float]
    initial: dict[str, float]
    targets: tuple[Target, ...]
    simulated: tuple[float, ...]
    simulated_initial: tuple[float, ...]
    continuous: tuple[float, ...]
    residuals: np.ndarray
    residuals_initial: np.ndarray
    cost: float
    singular_values: np.ndarray
    weakest: dict[str, float]
    correlation: np.ndarray
    n_evaluations: int
    success: bool
    message: str
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def condition(self) -> float:
        """Largest over smallest singular value (inf when rank deficient)."""
        s = self.singular_values
        return float(s[0] / s[-1]) if len(s) and s[-1] > 0 else math.inf

    def identifiability(self) -> str:
        """One line: singular values, condition number and the weakest combination."""
        if not len(self.singular_values):
            return "identifiability: no Jacobian (derivative-free method)"
        combo = " ".join(f"{v:+.2f} d{n}/{n}" for n, v in self.weakest.items())
        sv = ", ".join(f"{s:.3g}" for s in self.singular_values)
        return (f"identifiability: singular values {sv} (condition {self.condition:.3g}); "
                f"weakest direction {combo}")

    def table(self) -> str:
        """Text tables of the estimates and of the targets, and the diagnostic."""
        est = format_table(["parameter", "estimate", "se", "initial"],
                           [[n, v, self.uncertainties[n], self.initial[n]]
                            for n, v in self.parameters.items()])
        rows = [[t.label, t.value, t.tolerance, s0, s, float(r)] for t, s0, s, r in
                zip(self.targets, self.simulated_initial, self.simulated, self.residuals,
                    strict=True)]
        tgt = format_table(["target", "value", "tol", "at start", "at estimate",
                            "residual/sigma"], rows)
        names = list(self.parameters)
        lines = [est, "", tgt, "", self.identifiability()]
        if len(names) > 1 and np.all(np.isfinite(self.correlation)):
            pairs = [f"{names[i]}/{names[j]} {self.correlation[i, j]:+.3f}"
                     for i in range(len(names)) for j in range(i + 1, len(names))]
            lines.append("correlations: " + ", ".join(pairs))
        lines.append(f"{self.n_evaluations} parameter points simulated; {self.message}")
        return "\n".join(lines)

    def as_dict(self) -> dict[str, Any]:
        """A JSON-ready summary (``parameters`` maps each fitted name to its value)."""
        return {"method": "targets", "parameters": dict(self.parameters),
                "uncertainties": dict(self.uncertainties), "initial": dict(self.initial),
                "targets": [{**t.as_dict(), "label": t.label, "simulated": s,
                             "simulated_initial": s0, "continuous": c, "residual": float(r)}
                            for t, s, s0, c, r in zip(self.targets, self.simulated,
                                                      self.simulated_initial, self.continuous,
                                                      self.residuals, strict=True)],
                "cost": self.cost, "singular_values": self.singular_values.tolist(),
                "condition": self.condition, "weakest": dict(self.weakest),
                "correlation": self.correlation.tolist(), "n_evaluations": self.n_evaluations,
                "success": self.success, "message": self.message}

    def plot(self, ax: Any = None) -> Any:
        """Residuals in units of sigma per target, at the start and at the estimate."""
        ax = axes(ax)
        k = np.arange(len(self.targets))
        ax.barh(k + 0.2, self.residuals_initial, height=0.4, label="at start", color="0.7")
        ax.barh(k - 0.2, self.residuals, height=0.4, label="at the estimate")
        ax.axvspan(-1, 1, color="g", alpha=0.1)
        ax.set_yticks(k, [t.label for t in self.targets], fontsize="small")
        ax.invert_yaxis()
        ax.set(xlabel="(simulated - target) / sigma", title="targets")
        ax.legend(fontsize="small")
        return ax


def _check_fit(fit: Sequence[str] | str, compiled: CompiledModel) -> list[str]:
    if isinstance(fit, str):
        fit = [n.strip() for n in fit.split(",") if n.strip()]
    fit = list(fit)
    if not fit:
        raise ValueError("fit must name at least one parameter")
    for name in fit:
        if name not in compiled.parameter_names:
            raise ValueError(f"fit: the model has no parameter {name!r}")
    if len(set(fit)) != len(fit):
        raise ValueError(f"fit names a parameter twice (got {fit!r})")
    return fit


def _check_targets(targets: Sequence[Target], compiled: CompiledModel) -> tuple[Target, ...]:
    targets = tuple(targets)
    if not targets or not all(isinstance(t, Target) for t in targets):
        raise ValueError("targets must be a non-empty sequence of Target")
    spec = compiled.model
    transitions = {t.name for t in spec.transitions}
    for i, t in enumerate(targets):
        if t.scenario is not None and t.scenario not in spec.scenarios:
            raise ValueError(f"targets[{i}].scenario: unknown scenario {t.scenario!r}; the "
                             f"model has: {', '.join(spec.scenarios) or 'none'}")
        if t.transition is not None and t.transition not in transitions:
            raise ValueError(f"targets[{i}].transition: the model has no transition "
                             f"{t.transition!r}")
        if t.t_end is None and (t.scenario is None or spec.scenarios[t.scenario].t_end is None):
            raise ValueError(f"targets[{i}].t_end is required when no scenario gives it")
        horizon = t.t_end if t.t_end is not None else spec.scenarios[str(t.scenario)].t_end
        if t.dt is not None and horizon / t.dt > MAX_SAMPLES:
            raise ValueError(f"targets[{i}].dt: {horizon:g} s at dt = {t.dt:g} s needs "
                             f"{horizon / t.dt:.3g} samples; at most {MAX_SAMPLES} (raise dt)")
        for key in ("observable", "at"):
            text = getattr(t, key)
            if isinstance(text, str) and text not in compiled.state_names:
                try:  # an unknown name or bad text fails here, not after the first simulation
                    Observer(compiled, [text])
                except ModelError as exc:
                    raise ValueError(f"targets[{i}].{key}: {exc.message} (token "
                                     f"{exc.token!r})") from None
    return targets


def fit_targets(
    model: Model | CompiledModel | str | Path | HybridProblem,
    targets: Sequence[Target],
    *,
    fit: Sequence[str] | str,
    params: Mapping[str, float] | None = None,
    initial_guess: Mapping[str, float] | None = None,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    method: str = "least_squares",
    max_evaluations: int = 40,
    diff_step: float = 1e-3,
    xtol: float = 1e-4,
    simulation_options: Mapping[str, object] | None = None,
) -> TargetFit:
    """Estimate model parameters so that simulated summary quantities match targets.

    Parameters
    ----------
    model : Model, CompiledModel, str, pathlib.Path or HybridProblem
        A problem (with point values) supplies ``params`` and the integrator
        settings; each target keeps its own scenario, initial values and horizon.
    targets : sequence of Target
        The quantities to match; targets of the same experiment share a simulation.
    fit : sequence of str, or str "a,b"
        Parameters to estimate.
    params : mapping, optional
        Fixed parameter overrides applied to every experiment (before each target's own
        ``params``); the fitted parameters override both.
    initial_guess : mapping, optional
        Start values (default: the model's values).
    bounds : mapping of str to (float, float), optional
        Per-parameter bounds; by default each parameter keeps the sign of its start value
        and is optimised in ``log`` (relative) coordinates.
    method : {"least_squares", "nelder-mead"}
    max_evaluations : int
        Most parameter points to simulate (each runs every experiment once).
    diff_step : float
        Relative finite-difference step.
    xtol : float
        Relative step size at which to stop.
    simulation_options : mapping, optional
        Extra keyword arguments of :func:`hybridlab.simulate` (e.g. ``rtol``).

    Returns
    -------
    TargetFit

    Raises
    ------
    ValueError
        Unknown parameter, scenario, transition or method; bad bounds or budget.

    Examples
    --------
    The restitution coefficient of a bouncing ball from the height of its first bounce
    (``e^2 h0 = 0.64 * 10`` m, so 6.4 m means ``e = 0.8``), starting from 0.6:

    >>> import hybridlab
    >>> apex = Target("value", 6.4, 0.01, transition="bounce", at="h + v**2/(2*g)",
    ...               index=0, t_end=3.0)
    >>> result = fit_targets("models/bouncing_ball.toml", [apex], fit=["e"],
    ...                      initial_guess={"e": 0.6})
    >>> round(result.parameters["e"], 4), f"{result.uncertainties['e']:.2g}"
    (0.8, '0.00062')

    The standard error is ``tolerance / (d apex / d e) = 0.01 / (2 e h0)``.
    """
    if isinstance(model, HybridProblem):  # its parameters and integrator settings
        base = model.arguments("fit_targets")
        params = {**base["params"], **(params or {})}
        simulation_options = {"options": base["options"], **(simulation_options or {})}
    compiled = as_compiled(model)
    fit = _check_fit(fit, compiled)
    targets = _check_targets(targets, compiled)
    if method not in _METHODS:
        raise ValueError(f"method must be one of {', '.join(_METHODS)} (got {method!r})")
    if not (isinstance(max_evaluations, int) and max_evaluations >= len(fit) + 2):
        raise ValueError(f"max_evaluations must be an integer >= {len(fit) + 2} "
                         f"(got {max_evaluations!r})")
    base = dict(zip(compiled.parameter_names, compiled.parameter_vector(params), strict=True))
    unknown = sorted(set(initial_guess or {}) - set(fit))
    if unknown:
        raise ValueError(f"initial_guess: {unknown[0]!r} is not a fitted parameter")
    start = {n: float((initial_guess or {}).get(n, base[n])) for n in fit}
    space = ParameterSpace.around(fit, start, bounds)
    lo, hi = space.bounds()

    experiments: dict[tuple[Any, ...], list[int]] = {}
    for i, t in enumerate(targets):
        experiments.setdefault(t.experiment(), []).append(i)
    observers = _Observers(compiled)
    # (their values are checked by simulate)
    options: dict[str, Any] = dict(simulation_options or {})
    sigma = np.array([t.sigma for t in targets])
    reference = np.array([t.reference for t in targets])
    cache: dict[tuple[float, ...], tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
    count = [0]
    limit = [max_evaluations]

    def run(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        key = tuple(np.round(theta, 12))
        if key in cache:
            return cache[key]
        if count[0] >= limit[0]:
            raise BudgetSpent
        count[0] += 1
        values = dict(zip(fit, space.values(theta).tolist(), strict=True))
        cont = np.full(len(targets), np.nan)
        shown = np.full(len(targets), np.nan)
        for members in experiments.values():
            t0 = targets[members[0]]
            try:
                result = simulate(compiled, t0.t_end, scenario=t0.scenario,
                                  params={**(params or {}), **t0.params, **values},
                                  initial=t0.initial, **options)
            except (HybridlabError, ValueError, ArithmeticError):
                continue
            for i in members:
                with contextlib.suppress(HybridlabError, ValueError, ArithmeticError):
                    cont[i], shown[i] = target_statistic(targets[i], result, observers)
        res = np.where(np.isfinite(cont), (cont - reference) / sigma, MISSING_PENALTY)
        cache[key] = (res, cont, shown)
        return cache[key]

    theta0 = space.theta0()
    limit[0] = max_evaluations - (len(fit) if method == "least_squares" else 0)
    success, message, jac, x_opt = minimise_residuals(
        lambda th: run(th)[0], theta0, lo, hi, method=method, max_evaluations=max_evaluations,
        xtol=xtol, diff_step=diff_step, ftol=1e-8,
        budget_text=f"stopped after max_evaluations = {max_evaluations} parameter points")
    best = np.array(min(cache, key=lambda k: float(cache[k][0] @ cache[k][0])))
    residual, cont, shown = cache[tuple(np.round(best, 12))]
    limit[0] = max_evaluations

    n = len(fit)
    se = np.full(n, np.nan)
    singular = np.empty(0)
    weakest: dict[str, float] = {}
    corr = np.full((n, n), np.nan)
    if method == "least_squares":
        try:
            if jac is None or not np.allclose(x_opt, best):
                jac = np.empty((len(residual), n))
                for i in range(n):
                    h = diff_step * max(abs(best[i]), 1.0)
                    probe = best.copy()
                    probe[i] += h
                    jac[:, i] = (run(probe)[0] - residual) / h
            se, singular, weakest, corr = _statistics(np.asarray(jac), fit)
            se = se * space.derivative(best)
        except BudgetSpent:
            message += "; no evaluations left for the uncertainties"
    first = cache.get(tuple(np.round(theta0, 12)))
    nan = np.full(len(targets), np.nan)
    initial_residual, initial_shown = (first[0], first[2]) if first else (nan, nan)
    return TargetFit(
        parameters=dict(zip(fit, space.values(best).tolist(), strict=True)),
        uncertainties={k: float(e) for k, e in zip(fit, se, strict=True)},
        initial=start, targets=targets, simulated=tuple(map(float, shown)),
        simulated_initial=tuple(map(float, initial_shown)), continuous=tuple(map(float, cont)),
        residuals=residual, residuals_initial=initial_residual,
        cost=0.5 * float(residual @ residual), singular_values=singular,
        weakest=weakest, correlation=corr, n_evaluations=count[0], success=success,
        message=message)


def _statistics(jac: np.ndarray, names: list[str]) -> tuple[np.ndarray, np.ndarray,
                                                             dict[str, float], np.ndarray]:
    """Standard errors, singular values, weakest direction and correlations in theta."""
    n = len(names)
    _, s, vt = np.linalg.svd(jac)  # vt is n x n even with fewer residuals than parameters
    s = np.concatenate([s, np.zeros(n - len(s))])
    weakest = vt[-1] * (np.sign(vt[-1][np.argmax(np.abs(vt[-1]))]) or 1.0)
    rank = int(np.sum(s > s[0] * 1e-8)) if len(s) and s[0] > 0 else 0
    if rank < n:
        return (np.full(n, np.nan), s, dict(zip(names, weakest.tolist(), strict=True)),
                np.full((n, n), np.nan))
    cov = (vt.T / s**2) @ vt
    se = np.sqrt(np.clip(np.diag(cov), 0, None))
    corr = cov / np.outer(se, se)
    return se, s, dict(zip(names, weakest.tolist(), strict=True)), corr
