"""Coulomb plus viscous friction from steady-state runs: ``F = c sign(v) + d v``.

At a constant velocity the driving force equals the friction force, so each run gives
one point ``(v, F)``. The line is fitted per direction (``F = c+ + d+ v`` for ``v > 0``,
``F = -c- + d- v`` for ``v < 0``) and for both directions together, by linear least
squares; the standard errors come from the covariance ``s^2 (X^T X)^-1`` with
``s^2 = RSS / (n - 2)``.

Exclusion rule (per direction, unless ``v_min`` is given): at low speed the force
departs from the line (Stribeck effect, stick-slip), so

1. fit the line to the faster half of the runs (``|v| >= median |v|``);
2. take ``sigma``, the residual standard deviation of that fit;
3. find the fastest run slower than the median whose residual exceeds ``k_sigma * sigma``;
   it and every slower run are excluded;
4. refit on the remaining runs.

The faster half must therefore lie in the linear region.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from hybridlab.identify._report import axes, format_table
from hybridlab.identify.data import FrictionData
from hybridlab.identify.errors import DataError

__all__ = ["LineFit", "FrictionFit", "fit_friction"]

_MIN_POINTS = 3  # two coefficients plus one degree of freedom for the variance


@dataclass(frozen=True)
class LineFit:
    """Friction of one direction: ``|F| = c + d |v|`` on the runs kept.

    Attributes
    ----------
    c, d : float
        Coulomb level (N, as a magnitude) and viscous slope (N s/m).
    c_se, d_se : float
        Their standard errors.
    n : int
        Runs used.
    n_excluded : int
        Runs excluded as low-velocity (non-linear) ones.
    v_min : float
        Speed threshold: runs with ``|v| <= v_min`` were excluded (0 when none were).
    rms : float
        Residual root mean square (N).

    Examples
    --------
    The two slowest runs per direction carry 8 N of extra (Stribeck) force and are
    excluded by the automatic rule:

    >>> v = np.array([0.01, 0.02, 0.05, 0.1, 0.2, 0.3])
    >>> force = 17.4 + 257.0 * v + np.where(v <= 0.02, 8.0, 0.0)
    >>> fit = fit_friction(FrictionData(np.r_[-v, v], np.r_[-force, force]))
    >>> line = fit.forward
    >>> round(line.c, 6), round(line.d, 6), line.n, line.n_excluded, line.v_min
    (17.4, 257.0, 4, 2, 0.02)
    """

    c: float
    d: float
    c_se: float
    d_se: float
    n: int
    n_excluded: int
    v_min: float
    rms: float


@dataclass(frozen=True)
class FrictionFit:
    """Result of :func:`fit_friction`.

    Attributes
    ----------
    c, d : float
        Coulomb (N) and viscous (N s/m) coefficients fitted on both directions together.
    c_se, d_se : float
        Standard errors of ``c`` and ``d``.
    forward, backward : LineFit
        The fits of positive and negative velocities.
    asymmetric : bool
        True when ``c`` or ``d`` differ between the directions by more than
        ``asymmetry_tol`` (relative) *and* by more than three combined standard errors.
    asymmetry_c, asymmetry_d : float
        ``(forward - backward) / overall`` for ``c`` and ``d``.
    used : numpy.ndarray
        Boolean mask of the runs used (the others fell under the exclusion rule).
    residuals : numpy.ndarray
        ``F - (c sign(v) + d v)`` for every run.
    data : FrictionData
        The input.

    Examples
    --------
    Runs with 20 N of Coulomb friction forwards but 15 N backwards:

    >>> v = np.array([-0.3, -0.2, -0.1, -0.05, 0.05, 0.1, 0.2, 0.3])
    >>> force = np.where(v > 0, 20.0, -15.0) + 250.0 * v
    >>> fit = fit_friction(FrictionData(v, force), v_min=0.0)
    >>> round(fit.c, 6), round(fit.d, 6), fit.asymmetric, round(fit.asymmetry_c, 3)
    (17.5, 250.0, True, 0.286)
    >>> fit.predict([-0.1, 0.1]).round(6).tolist()
    [-42.5, 42.5]
    >>> print(fit.table().splitlines()[-1])
    friction is ASYMMETRIC: c differs by +28.6 %, d by +0.0 % (forward - backward)
    """

    c: float
    d: float
    c_se: float
    d_se: float
    forward: LineFit
    backward: LineFit
    asymmetric: bool
    asymmetry_c: float
    asymmetry_d: float
    used: np.ndarray
    residuals: np.ndarray
    data: FrictionData

    @property
    def parameters(self) -> dict[str, float]:
        """The estimates by name: ``c`` and ``d``."""
        return {"c": self.c, "d": self.d}

    @property
    def uncertainties(self) -> dict[str, float]:
        """Standard errors by name."""
        return {"c": self.c_se, "d": self.d_se}

    def predict(self, velocity: float | np.ndarray) -> np.ndarray:
        """The fitted friction force ``c sign(v) + d v``."""
        v = np.asarray(velocity, dtype=float)
        return self.c * np.sign(v) + self.d * v

    def table(self) -> str:
        """A text table of the estimates per direction and overall."""
        rows = [[name, f.c, f.c_se, f.d, f.d_se, f.n, f.n_excluded, f.v_min, f.rms]
                for name, f in (("forward", self.forward), ("backward", self.backward))]
        rms = float(np.sqrt(np.mean(self.residuals[self.used] ** 2)))
        rows.append(["both", self.c, self.c_se, self.d, self.d_se, int(self.used.sum()),
                     int((~self.used).sum()), "", rms])
        text = format_table(["fit", "c [N]", "se(c)", "d [N s/m]", "se(d)", "n", "excluded",
                             "v_min [m/s]", "rms [N]"], rows)
        verdict = "ASYMMETRIC" if self.asymmetric else "symmetric"
        return (f"{text}\nfriction is {verdict}: c differs by {100 * self.asymmetry_c:+.1f} %, "
                f"d by {100 * self.asymmetry_d:+.1f} % (forward - backward)")

    def as_dict(self) -> dict[str, Any]:
        """A JSON-ready summary (``parameters`` maps ``c`` and ``d`` to their values)."""
        return {"method": "friction", "parameters": self.parameters,
                "uncertainties": self.uncertainties,
                "directions": {name: vars(f) for name, f in
                               (("forward", self.forward), ("backward", self.backward))},
                "asymmetric": self.asymmetric, "asymmetry_c": self.asymmetry_c,
                "asymmetry_d": self.asymmetry_d, "n_used": int(self.used.sum()),
                "residual_rms": float(np.sqrt(np.mean(self.residuals[self.used] ** 2)))}

    def plot(self, ax: Any = None) -> Any:
        """Plot the runs (excluded ones hollow) and the fitted lines; returns the axes."""
        ax = axes(ax)
        v, f = self.data.velocity, self.data.force
        ax.plot(v[self.used], f[self.used], "o", ms=4, label="runs used")
        if (~self.used).any():
            ax.plot(v[~self.used], f[~self.used], "o", ms=4, mfc="none",
                    label="excluded (low velocity)")
        for sign, line in ((1, self.forward), (-1, self.backward)):
            vv = np.linspace(0, np.max(np.abs(v)), 50) * sign
            ax.plot(vv, sign * line.c + line.d * vv, "-", lw=1)
        vv = np.linspace(-np.max(np.abs(v)), np.max(np.abs(v)), 201)
        ax.plot(vv, self.predict(vv), "k--", lw=0.8,
                label=f"c={self.c:.4g} N, d={self.d:.4g} N s/m")
        ax.set(xlabel="velocity [m/s]", ylabel="force [N]", title="steady-state friction")
        ax.legend(fontsize="small")
        return ax


def _lstsq(X: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Coefficients, their standard errors and the residuals of ``y ~ X``."""
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    res = y - X @ coef
    dof = max(len(y) - X.shape[1], 1)
    s2 = float(res @ res) / dof
    cov = s2 * np.linalg.pinv(X.T @ X)
    return coef, np.sqrt(np.clip(np.diag(cov), 0, None)), res


def _identifiable(speed: np.ndarray, name: str, stage: str) -> None:
    """Refuse a line fit through runs at fewer than two distinct speeds.

    ``c`` and ``d`` of ``c + d v`` are then not determined: least squares would report an
    arbitrary minimum-norm pair with standard errors near zero.
    """
    distinct = np.unique(speed)
    if distinct.size < 2 or np.ptp(speed) <= 1e-9 * max(float(np.max(np.abs(speed))), 1e-300):
        at = f"{float(distinct[0]):.6g} m/s" if distinct.size else "no speed"
        raise DataError(f"the {name} runs {stage} are all at one speed ({at}): Coulomb and "
                        "viscous friction cannot be told apart; runs at two or more different "
                        "speeds in each direction are needed", column="velocity")


def _direction(speed: np.ndarray, force: np.ndarray, v_min: float | None, k_sigma: float,
               name: str) -> tuple[LineFit, np.ndarray]:
    """Fit ``force = c + d speed`` (magnitudes) with the exclusion rule; returns the mask."""
    _identifiable(speed, name, "given")
    if len(speed) < _MIN_POINTS:
        raise DataError(f"needs at least {_MIN_POINTS} runs in the {name} direction "
                        f"(got {len(speed)})", column="velocity")
    if v_min is None:
        fast = speed >= np.median(speed)
        if fast.sum() < _MIN_POINTS:
            fast = np.argsort(speed)[-_MIN_POINTS:]
            fast = np.isin(np.arange(len(speed)), fast)
        _identifiable(speed[fast], name, "used for the exclusion rule (the faster half)")
        X = np.column_stack([np.ones(fast.sum()), speed[fast]])
        coef, _, res = _lstsq(X, force[fast])
        sigma = max(float(np.sqrt(res @ res / max(len(res) - 2, 1))),
                    1e-9 * max(float(np.max(np.abs(force))), 1.0))
        outside = (np.abs(force - coef[0] - coef[1] * speed) > k_sigma * sigma) & ~fast
        threshold = float(np.max(speed[outside])) if outside.any() else 0.0
        keep = speed > threshold
    else:
        threshold = float(v_min)
        keep = speed > threshold
    if keep.sum() < _MIN_POINTS:
        raise DataError(f"only {int(keep.sum())} runs of the {name} direction are faster than "
                        f"the exclusion threshold {threshold:.4g} m/s; at least {_MIN_POINTS} "
                        f"are needed", column="velocity")
    _identifiable(speed[keep], name, f"faster than the exclusion threshold {threshold:.4g} m/s")
    X = np.column_stack([np.ones(keep.sum()), speed[keep]])
    coef, se, res = _lstsq(X, force[keep])
    fit = LineFit(c=float(coef[0]), d=float(coef[1]), c_se=float(se[0]), d_se=float(se[1]),
                  n=int(keep.sum()), n_excluded=int((~keep).sum()), v_min=threshold,
                  rms=float(np.sqrt(np.mean(res**2))))
    return fit, keep


def fit_friction(data: FrictionData, *, v_min: float | None = None, k_sigma: float = 3.0,
                 asymmetry_tol: float = 0.05) -> FrictionFit:
    """Fit ``F = c sign(v) + d v`` to steady-state runs in both directions.

    Parameters
    ----------
    data : FrictionData
        Runs with positive and negative velocities (at least three each after exclusion).
    v_min : float, optional
        Exclude runs with ``|v| <= v_min``; by default the automatic rule of the module
        docstring decides per direction.
    k_sigma : float
        Residual threshold of the automatic rule, in standard deviations.
    asymmetry_tol : float
        Relative difference between directions above which (if also statistically
        significant) the friction is flagged as asymmetric.

    Returns
    -------
    FrictionFit

    Raises
    ------
    DataError
        If a direction is missing or has too few runs.

    Examples
    --------
    >>> v = np.array([-0.3, -0.2, -0.1, -0.05, 0.05, 0.1, 0.2, 0.3])
    >>> fit = fit_friction(FrictionData(v, 17.4 * np.sign(v) + 257.0 * v), v_min=0.0)
    >>> round(fit.c, 6), round(fit.d, 6), fit.asymmetric
    (17.4, 257.0, False)
    """
    if not isinstance(data, FrictionData):
        raise TypeError(f"data must be FrictionData (got {type(data).__name__})")
    if v_min is not None and not (np.isfinite(v_min) and v_min >= 0):
        raise ValueError(f"v_min must be a non-negative number (got {v_min!r})")
    if not k_sigma > 0:
        raise ValueError(f"k_sigma must be positive (got {k_sigma!r})")
    v, f = data.velocity, data.force
    fwd, bwd = np.flatnonzero(data.forward), np.flatnonzero(data.backward)
    if fwd.size == 0 or bwd.size == 0:
        missing = "negative" if bwd.size == 0 else "positive"
        raise DataError(f"has no runs with {missing} velocity; runs in both directions are "
                        f"needed", column="velocity", source=data.source)
    forward, keep_f = _direction(v[fwd], f[fwd], v_min, k_sigma, "forward (v > 0)")
    backward, keep_b = _direction(-v[bwd], -f[bwd], v_min, k_sigma, "backward (v < 0)")
    used = np.zeros(len(v), dtype=bool)
    used[fwd[keep_f]] = True
    used[bwd[keep_b]] = True
    X = np.column_stack([np.sign(v[used]), v[used]])
    coef, se, _ = _lstsq(X, f[used])
    c, d = float(coef[0]), float(coef[1])
    residuals = f - (c * np.sign(v) + d * v)

    def differs(a: float, b: float, sa: float, sb: float, ref: float) -> bool:
        gap = abs(a - b)
        return gap > asymmetry_tol * abs(ref) and gap > 3.0 * np.hypot(sa, sb)

    asym = (differs(forward.c, backward.c, forward.c_se, backward.c_se, c)
            or differs(forward.d, backward.d, forward.d_se, backward.d_se, d))
    return FrictionFit(
        c=c, d=d, c_se=float(se[0]), d_se=float(se[1]), forward=forward, backward=backward,
        asymmetric=bool(asym),
        asymmetry_c=(forward.c - backward.c) / c if c else float("nan"),
        asymmetry_d=(forward.d - backward.d) / d if d else float("nan"),
        used=used, residuals=residuals, data=data)
