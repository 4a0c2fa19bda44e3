"""Mass from a frequency response of position over force.

A free mass with viscous friction has ``T(s) = X/F = 1 / (s (m s + d))`` (eq. (4) of the
reference paper: ``(1/d) / (s (s m/d + 1))``). Above the break frequency
``omega_b = d / m`` it reduces to the double integrator ``T*(s) = 1 / (m s^2)``: the gain
falls by 40 dB per decade and its level gives ``m`` alone.

Locating the -40 dB/dec region: a straight line ``dB = a + k log10(f)`` is fitted in a
sliding window of ``window_decades`` around every point; the points whose local slope
``k`` lies within ``slope_tol`` of -40 dB/dec are candidates, and the region is the
longest run (in decades) of consecutive candidates. ``1/(m s^2)`` is fitted there with
its slope fixed: ``log10 m = -(dB + 40 log10 omega) / 20`` averaged over the region.

The viscous coefficient is poorly determined by such data: ``d`` only matters below
``omega_b`` where ``|T| ~ 1/(d omega)``, and at those low frequencies the real gain is
dominated by non-linear friction (pre-rolling makes it flat instead of -20 dB/dec).
:func:`fit_mass` therefore also fits eq. (4) and reports the relative uncertainty of
``d``, the condition number of the fit and the measured low-frequency slope.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from hybridlab.identify._report import axes, format_table
from hybridlab.identify.data import FrequencyData
from hybridlab.identify.errors import DataError

__all__ = ["SlopeRegion", "Eq4Fit", "MassFit", "local_slopes", "find_slope_region", "fit_mass"]

_MIN_POINTS = 5


@dataclass(frozen=True)
class SlopeRegion:
    """A frequency band where the gain falls at a given rate.

    Attributes
    ----------
    start, stop : int
        Index range ``[start, stop)`` of the data points in the band.
    f_low_hz, f_high_hz : float
        Its first and last frequency.
    slope : float
        Slope of a free line fitted over the band (dB/decade).
    slope_se : float
        Its standard error.

    Examples
    --------
    ``1 / (s (2 s + 60))`` breaks at 4.8 Hz; within 3 dB/dec of -40 from 12.6 Hz on:

    >>> f = np.logspace(0, 3, 61)
    >>> w = 2 * np.pi * f
    >>> region = find_slope_region(FrequencyData(f, -20 * np.log10(w * np.hypot(2 * w, 60))))
    >>> region.start, region.stop, round(region.f_low_hz, 1), round(region.decades, 2)
    (22, 61, 12.6, 1.9)
    >>> round(region.slope, 1), round(region.slope_se, 3)
    (-39.8, 0.027)
    """

    start: int
    stop: int
    f_low_hz: float
    f_high_hz: float
    slope: float
    slope_se: float

    @property
    def decades(self) -> float:
        """Width of the band in decades."""
        return float(np.log10(self.f_high_hz / self.f_low_hz))


@dataclass(frozen=True)
class Eq4Fit:
    """Fit of ``1 / (s (m s + d))`` and the diagnostics of why ``d`` is unreliable.

    Attributes
    ----------
    m, d : float
        Mass (kg) and viscous coefficient (N s/m).
    m_se, d_se : float
        Standard errors (from the Jacobian of the log-magnitude fit).
    condition_number : float
        Of the Jacobian with respect to ``log m`` and ``log d``: large values mean the data
        constrain ``d`` only in combination with ``m``.
    f_break_hz : float
        ``d / (2 pi m)``: below it the gain is ``1/(d omega)`` and only there ``d`` matters.
    n_below_break : int
        Data points below the break frequency.
    low_slope : float
        Measured slope of the lowest ``window_decades`` of data (eq. (4) predicts -20
        dB/dec; a flatter slope shows friction non-linearity).
    rms_db : float
        Residual root mean square of the fit (dB).

    Examples
    --------
    Noise-free data of ``m = 3.5`` kg, ``d = 25`` N s/m: eq. (4) recovers both, but only
    two points lie below the break frequency, the only ones where ``d`` matters:

    >>> f = np.logspace(0, 3, 61)
    >>> w = 2 * np.pi * f
    >>> eq4 = fit_mass(FrequencyData(f, -20 * np.log10(w * np.hypot(3.5 * w, 25.0)))).eq4
    >>> round(eq4.m, 3), round(eq4.d, 3), round(eq4.f_break_hz, 3), eq4.n_below_break
    (3.5, 25.0, 1.137, 2)
    """

    m: float
    d: float
    m_se: float
    d_se: float
    condition_number: float
    f_break_hz: float
    n_below_break: int
    low_slope: float
    rms_db: float

    @property
    def d_rel_se(self) -> float:
        """Relative standard error of ``d``."""
        return self.d_se / abs(self.d) if self.d else float("inf")

    def note(self) -> str:
        """One paragraph on the reliability of ``d``."""
        return (f"d = {self.d:.4g} N s/m has a relative standard error of "
                f"{100 * self.d_rel_se:.1f} % (condition number {self.condition_number:.3g}). "
                f"Only the {self.n_below_break} points below the break frequency "
                f"{self.f_break_hz:.3g} Hz depend on d, where the gain is 1/(d omega); the "
                f"measured low-frequency slope is {self.low_slope:.1f} dB/dec instead of -20, "
                f"so friction non-linearity (pre-rolling, Coulomb) dominates there and d from "
                f"the frequency response is unreliable: take d from steady-state runs.")


@dataclass(frozen=True)
class MassFit:
    """Result of :func:`fit_mass`.

    Attributes
    ----------
    m : float
        Mass from the -40 dB/dec region (kg).
    m_se : float
        Its standard error.
    region : SlopeRegion
        The band used.
    residuals : numpy.ndarray
        Data minus ``1/(m s^2)`` over the region (dB).
    phase_deg : float
        Mean measured phase over the region (a double integrator has -180); NaN without
        phase data.
    eq4 : Eq4Fit
        The fit of eq. (4) from the lowest frequency to the top of the region.
    data : FrequencyData
        The input.

    Examples
    --------
    >>> f = np.logspace(0, 3, 61)
    >>> w = 2 * np.pi * f
    >>> fit = fit_mass(FrequencyData(f, -20 * np.log10(w * np.hypot(3.5 * w, 25.0))))
    >>> round(fit.m, 3), round(fit.region.f_low_hz, 2), round(fit.region.f_high_hz)
    (3.526, 2.82, 1000)
    >>> print(fit.table().splitlines()[2])
    m (-40 dB/dec region)     3.5256      0.00788017   kg
    >>> sorted(fit.as_dict())
    ['eq4', 'method', 'parameters', 'phase_deg', 'region', 'residual_rms_db', 'uncertainties']
    """

    m: float
    m_se: float
    region: SlopeRegion
    residuals: np.ndarray
    phase_deg: float
    eq4: Eq4Fit
    data: FrequencyData

    @property
    def parameters(self) -> dict[str, float]:
        """The estimate by name: ``m``."""
        return {"m": self.m}

    @property
    def uncertainties(self) -> dict[str, float]:
        """Standard errors by name."""
        return {"m": self.m_se}

    def table(self) -> str:
        """A text table of the mass estimate, the region and the eq. (4) fit."""
        r, e = self.region, self.eq4
        rows: list[list[object]] = [
            ["m (-40 dB/dec region)", self.m, self.m_se, "kg"],
            ["region", f"{r.f_low_hz:.4g}-{r.f_high_hz:.4g}", "", "Hz"],
            ["region slope", r.slope, r.slope_se, "dB/dec"],
            ["region residual rms", float(np.sqrt(np.mean(self.residuals**2))), "", "dB"],
            ["m (eq. 4)", e.m, e.m_se, "kg"],
            ["d (eq. 4, unreliable)", e.d, e.d_se, "N s/m"],
            ["condition number (eq. 4)", e.condition_number, "", ""],
        ]
        return f"{format_table(['quantity', 'value', 'se', 'unit'], rows)}\n{e.note()}"

    def as_dict(self) -> dict[str, Any]:
        """A JSON-ready summary (``parameters`` maps ``m`` to its value)."""
        r = self.region
        return {"method": "mass", "parameters": self.parameters,
                "uncertainties": self.uncertainties,
                "region": {"f_low_hz": r.f_low_hz, "f_high_hz": r.f_high_hz,
                           "slope_db_per_decade": r.slope, "slope_se": r.slope_se,
                           "n": r.stop - r.start},
                "residual_rms_db": float(np.sqrt(np.mean(self.residuals**2))),
                "phase_deg": self.phase_deg,
                "eq4": {**vars(self.eq4), "d_rel_se": self.eq4.d_rel_se,
                        "note": self.eq4.note()}}

    def plot(self, ax: Any = None) -> Any:
        """Bode plot of the data, ``1/(m s^2)`` and eq. (4); returns the axes."""
        has_phase = self.data.phase_deg is not None
        ax = axes(ax, nrows=2 if has_phase else 1)
        mag = ax[0] if has_phase else ax
        f, w = self.data.frequency_hz, self.data.omega
        r = self.region
        mag.semilogx(f, self.data.magnitude_db, ".", ms=3, label="measured")
        mag.semilogx(f, -20 * np.log10(self.m * w**2), "--", lw=1,
                     label=f"1/(m s^2), m = {self.m:.4g} kg")
        mag.semilogx(f, _eq4_db(w, self.eq4.m, self.eq4.d), ":", lw=1,
                     label=f"eq. (4), m = {self.eq4.m:.3g}, d = {self.eq4.d:.3g}")
        mag.axvspan(r.f_low_hz, r.f_high_hz, alpha=0.15, label="-40 dB/dec region")
        mag.set(ylabel="|X/F| [dB]", title="frequency response")
        mag.legend(fontsize="small")
        if has_phase:
            ax[1].semilogx(f, self.data.phase_deg, ".", ms=3)
            ax[1].set(xlabel="frequency [Hz]", ylabel="phase [deg]")
        else:
            mag.set(xlabel="frequency [Hz]")
        return ax


def _eq4_db(omega: np.ndarray, m: float, d: float) -> np.ndarray:
    return -20 * np.log10(omega * np.hypot(m * omega, d))


def _line(x: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
    """Intercept, slope and slope standard error of ``y ~ a + k x``."""
    X = np.column_stack([np.ones_like(x), x])
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    res = y - X @ coef
    s2 = float(res @ res) / max(len(x) - 2, 1)
    sxx = float(np.sum((x - x.mean()) ** 2))
    return float(coef[0]), float(coef[1]), float(np.sqrt(s2 / sxx)) if sxx > 0 else np.inf


def local_slopes(frequency_hz: np.ndarray, magnitude_db: np.ndarray,
                 window_decades: float = 0.2) -> np.ndarray:
    """Slope (dB/decade) of a line fitted in a window of ``window_decades`` around each point.

    Windows holding fewer than three points give NaN.

    Examples
    --------
    >>> f = np.logspace(0, 2, 41)
    >>> local_slopes(f, -40 * np.log10(f)).round(6)[[0, 20, 40]]
    array([-40., -40., -40.])
    """
    x = np.log10(np.asarray(frequency_hz, dtype=float))
    y = np.asarray(magnitude_db, dtype=float)
    half = window_decades / 2 * (1 + 1e-9)  # a point exactly on the edge belongs in
    lo = np.searchsorted(x, x - half, side="left")
    hi = np.searchsorted(x, x + half, side="right")
    count = hi - lo
    out = np.full(len(x), np.nan)
    # wide windows: least squares from running sums, about each window's own first point
    # so the sums stay well conditioned; O(N) in all (a fit per window is O(N^2) for
    # dense data); narrow ones (few points, where sums cancel worst) fitted directly
    wide = np.flatnonzero(count >= _RUNNING_SUM_POINTS)
    if wide.size:
        out[wide] = _window_slopes(x, y, lo[wide], hi[wide])
    for i in np.flatnonzero((count >= 3) & (count < _RUNNING_SUM_POINTS)):
        out[i] = _line(x[lo[i]:hi[i]], y[lo[i]:hi[i]])[1]
    return out


_RUNNING_SUM_POINTS = 64


def _window_slopes(x: np.ndarray, y: np.ndarray, lo: np.ndarray, hi: np.ndarray
                   ) -> np.ndarray:
    """Least-squares slopes of ``y ~ a + k x`` over the windows ``[lo, hi)``, from prefix sums
    of ``x - x0`` and ``y - y0`` with ``(x0, y0)`` the first point of each window, built per
    block of windows sharing one origin."""
    out = np.empty(lo.size)
    block = 4096
    for start in range(0, lo.size, block):
        a, b = lo[start:start + block], hi[start:start + block]
        first, last = int(a.min()), int(b.max())
        x0, y0 = x[first], y[first]
        dx, dy = x[first:last] - x0, y[first:last] - y0
        sums = [np.concatenate([[0.0], np.cumsum(v)]) for v in (dx, dy, dx * dx, dx * dy)]
        sx, sy, sxx, sxy = (s[b - first] - s[a - first] for s in sums)
        n = (b - a).astype(float)
        out[start:start + block] = (n * sxy - sx * sy) / (n * sxx - sx * sx)
    return out


def find_slope_region(data: FrequencyData, *, target: float = -40.0, slope_tol: float = 3.0,
                      window_decades: float = 0.3, max_gap: int = 3) -> SlopeRegion:
    """The longest band (in decades) whose local slope is within ``slope_tol`` of ``target``.

    Parameters
    ----------
    data : FrequencyData
    target : float
        Slope sought (dB/decade).
    slope_tol : float
        Accepted deviation of the local slope (dB/decade).
    window_decades : float
        Width of the sliding window of :func:`local_slopes`.
    max_gap : int
        Runs of in-tolerance points separated by at most this many points (noise) are
        joined.

    Raises
    ------
    DataError
        If no band of at least five points has the slope.

    Examples
    --------
    >>> f = np.logspace(0, 3, 61)
    >>> w = 2 * np.pi * f
    >>> region = find_slope_region(FrequencyData(f, -20 * np.log10(w * np.hypot(2 * w, 60))))
    >>> round(region.f_low_hz), round(region.f_high_hz)
    (13, 1000)
    """
    if not slope_tol > 0:
        raise ValueError(f"slope_tol must be positive (got {slope_tol!r})")
    if not window_decades > 0:
        raise ValueError(f"window_decades must be positive (got {window_decades!r})")
    f, y = data.frequency_hz, data.magnitude_db
    ok = np.abs(local_slopes(f, y, window_decades) - target) <= slope_tol
    # noise makes single points fall out of tolerance: bridge gaps of up to max_gap points
    idx = np.flatnonzero(ok)
    best: tuple[float, int, int] | None = None
    if idx.size:
        breaks = np.flatnonzero(np.diff(idx) > max_gap + 1)
        for a, b in zip(np.r_[0, breaks + 1], np.r_[breaks, idx.size - 1], strict=True):
            i, j = int(idx[a]), int(idx[b]) + 1
            span = float(np.log10(f[j - 1] / f[i]))
            if j - i >= _MIN_POINTS and (best is None or span > best[0]):
                best = (span, i, j)
    if best is None:
        raise DataError(f"has no band of at least {_MIN_POINTS} points whose slope is within "
                        f"{slope_tol} dB/dec of {target} dB/dec (local slopes range "
                        f"{np.nanmin(local_slopes(f, y, window_decades)):.1f} to "
                        f"{np.nanmax(local_slopes(f, y, window_decades)):.1f})",
                        column="magnitude_db", source=data.source)
    _, a, b = best
    _, slope, slope_se = _line(np.log10(f[a:b]), y[a:b])
    return SlopeRegion(start=a, stop=b, f_low_hz=float(f[a]), f_high_hz=float(f[b - 1]),
                       slope=slope, slope_se=slope_se)


def _fit_eq4(data: FrequencyData, stop: int, m0: float, window_decades: float) -> Eq4Fit:
    w, y = data.omega[:stop], data.magnitude_db[:stop]
    # initial d from the lowest points as if they followed 1/(d omega)
    d0 = float(np.median(10 ** (-(y[:3] / 20)) / w[:3]))
    d0 = d0 if np.isfinite(d0) and d0 > 0 else m0 * w[0]

    def residual(theta: np.ndarray) -> np.ndarray:
        return _eq4_db(w, np.exp(theta[0]), np.exp(theta[1])) - y

    sol = least_squares(residual, np.log([m0, d0]), method="lm")
    m, d = np.exp(sol.x)
    J = sol.jac
    dof = max(len(y) - 2, 1)
    s2 = float(sol.fun @ sol.fun) / dof
    sv = np.linalg.svd(J, compute_uv=False)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else float("inf")
    try:
        cov = s2 * np.linalg.inv(J.T @ J)
        rel = np.sqrt(np.clip(np.diag(cov), 0, None))
    except np.linalg.LinAlgError:
        rel = np.array([np.inf, np.inf])
    f_break = d / (2 * np.pi * m)
    x = np.log10(data.frequency_hz)
    low = x <= x[0] + window_decades
    low_slope = _line(x[low], data.magnitude_db[low])[1] if low.sum() >= 3 else float("nan")
    return Eq4Fit(m=float(m), d=float(d), m_se=float(m * rel[0]), d_se=float(d * rel[1]),
                  condition_number=cond, f_break_hz=float(f_break),
                  n_below_break=int(np.sum(data.frequency_hz[:stop] < f_break)),
                  low_slope=float(low_slope), rms_db=float(np.sqrt(np.mean(sol.fun**2))))


def fit_mass(data: FrequencyData, *, slope_tol: float = 3.0,
             window_decades: float = 0.3) -> MassFit:
    """Identify the mass from the -40 dB/dec region of a position-over-force response.

    Parameters
    ----------
    data : FrequencyData
        Magnitude in dB of ``X/F`` (m/N).
    slope_tol, window_decades : float
        Region search settings; see :func:`find_slope_region`.

    Returns
    -------
    MassFit

    Raises
    ------
    DataError
        If no -40 dB/dec region is found.

    Examples
    --------
    Without a resonance above it the region starts near the break frequency, which biases
    ``m`` slightly upwards (here by 1 %); eq. (4) is exact for this noise-free plant:

    >>> f = np.logspace(0, 3, 61)
    >>> w = 2 * np.pi * f
    >>> fit = fit_mass(FrequencyData(f, -20 * np.log10(w * np.hypot(3.5 * w, 25.0))))
    >>> round(fit.m, 2), round(fit.eq4.m, 3), round(fit.eq4.d, 3)
    (3.53, 3.5, 25.0)
    """
    if not isinstance(data, FrequencyData):
        raise TypeError(f"data must be FrequencyData (got {type(data).__name__})")
    if len(data.frequency_hz) < 2 * _MIN_POINTS:
        raise DataError(f"needs at least {2 * _MIN_POINTS} points (got "
                        f"{len(data.frequency_hz)})", column="frequency_hz", source=data.source)
    region = find_slope_region(data, slope_tol=slope_tol, window_decades=window_decades)
    sl = slice(region.start, region.stop)
    w, y = data.omega[sl], data.magnitude_db[sl]
    log_m = -(y + 40 * np.log10(w)) / 20
    m = float(10 ** np.mean(log_m))
    m_se = float(m * np.log(10) * np.std(log_m, ddof=1) / np.sqrt(len(log_m)))
    residuals = y + 20 * np.log10(m * w**2)
    phase = (float(np.mean(data.phase_deg[sl])) if data.phase_deg is not None
             else float("nan"))
    eq4 = _fit_eq4(data, region.stop, m, window_decades)
    return MassFit(m=m, m_se=m_se, region=region, residuals=residuals, phase_deg=phase,
                   eq4=eq4, data=data)
