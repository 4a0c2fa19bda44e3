"""Mass from a frequency response: region search, recovery, eq. (4) diagnostics, errors."""

from __future__ import annotations

import argparse
import json

import numpy as np
import pytest

from hybridlab.cli.identify import add_parser as add_identify_parser
from hybridlab.identify import (
    DataError,
    FrequencyData,
    find_slope_region,
    fit_mass,
    read_frequency_csv,
    write_csv,
)
from hybridlab.identify.synthetic import frequency_response

M, D = 3.5, 257.0


@pytest.mark.parametrize("seed", range(6))
def test_recovers_mass_within_3_percent(seed: int) -> None:
    data = frequency_response(M, D, prerolling_stiffness=3000.0, noise_db=0.2, rng=seed)
    fit = fit_mass(data)
    assert abs(fit.m / M - 1) < 0.03
    # the region lies between the break (11.7 Hz) and the resonance (400 Hz)
    assert D / (2 * np.pi * M) < fit.region.f_low_hz < fit.region.f_high_hz < 400.0
    assert abs(fit.region.slope + 40) < 3
    assert fit.phase_deg == pytest.approx(-180, abs=15)


def test_d_is_reported_unreliable_under_friction_nonlinearity() -> None:
    clean = fit_mass(frequency_response(M, D, noise_db=0.2, rng=1))
    rough = fit_mass(frequency_response(M, D, prerolling_stiffness=3000.0, noise_db=0.2, rng=1))
    assert abs(clean.eq4.d / D - 1) < 0.05  # a linear plant gives d back
    assert abs(rough.eq4.d / D - 1) > 0.1  # pre-rolling spoils it ...
    assert rough.eq4.d_rel_se > clean.eq4.d_rel_se  # ... and the fit says so
    assert rough.eq4.low_slope > -10 and clean.eq4.low_slope < -18
    assert rough.eq4.n_below_break > 0 and rough.eq4.condition_number > 1
    assert "unreliable" in rough.eq4.note()


def test_region_of_a_pure_double_integrator_spans_everything() -> None:
    f = np.geomspace(1, 1000, 200)
    data = FrequencyData(f, -20 * np.log10(M * (2 * np.pi * f) ** 2))
    region = find_slope_region(data)
    assert (region.start, region.stop) == (0, 200)
    assert fit_mass(data).m == pytest.approx(M, rel=1e-9)


def test_no_region_is_an_error_naming_the_column() -> None:
    f = np.geomspace(1, 100, 50)
    with pytest.raises(DataError, match="magnitude_db.*-40"):
        fit_mass(FrequencyData(f, -20 * np.log10(f)))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"frequency_hz": [1.0, 2.0, 2.0], "magnitude_db": [0.0, 0.0, 0.0]}, "increasing"),
        ({"frequency_hz": [-1.0, 2.0], "magnitude_db": [0.0, 0.0]}, "positive"),
        ({"frequency_hz": [1.0, 2.0], "magnitude_db": [0.0, np.nan]}, "'magnitude_db'.*NaN"),
        ({"frequency_hz": [1.0, 2.0], "magnitude_db": [0.0, 1.0], "phase_deg": [0.0]},
         "different lengths"),
    ],
)
def test_bad_data(kwargs, match) -> None:
    with pytest.raises(DataError, match=match):
        FrequencyData(**kwargs)


def test_too_few_points() -> None:
    with pytest.raises(DataError, match="at least 10 points"):
        fit_mass(FrequencyData([1.0, 2.0, 3.0], [0.0, -12.0, -19.0]))


def test_csv_without_phase_and_cli(tmp_path, capsys) -> None:
    data = frequency_response(M, D, rng=2)
    path = tmp_path / "bode.csv"
    write_csv(path, {"frequency_hz": data.frequency_hz.tolist(),
                     "magnitude_db": data.magnitude_db.tolist()})
    assert read_frequency_csv(path).phase_deg is None
    parser = argparse.ArgumentParser()
    add_identify_parser(parser.add_subparsers(dest="command"))
    out = tmp_path / "m.json"
    args = parser.parse_args(["identify", "mass", str(path), "--out", str(out),
                              "--plot", str(tmp_path / "m.png")])
    assert args.run(args) == 0
    assert "-40 dB/dec region" in capsys.readouterr().out
    payload = json.loads(out.read_text())
    assert list(payload["parameters"]) == ["m"]
    assert abs(payload["parameters"]["m"] / M - 1) < 0.03
    (tmp_path / "bad.csv").write_text("frequency_hz,phase_deg\n1,0\n")
    args = parser.parse_args(["identify", "mass", str(tmp_path / "bad.csv")])
    with pytest.raises(ValueError, match="missing column.*magnitude_db"):
        args.run(args)


@pytest.mark.parametrize("n", [40, 500, 5000])
def test_local_slopes_equal_a_fit_per_window_with_work_linear_in_the_rows(n, monkeypatch):
    from hybridlab.identify import frequency

    rng = np.random.default_rng(n)
    f = np.sort(10 ** rng.uniform(0, 3, n))
    y = -40 * np.log10(f) + rng.normal(size=n)
    x, half = np.log10(f), 0.1 * (1 + 1e-9)
    lo, hi = np.searchsorted(x, x - half), np.searchsorted(x, x + half, side="right")
    check = rng.choice(n, size=min(n, 200), replace=False)
    expected = [frequency._line(x[lo[i]:hi[i]], y[lo[i]:hi[i]])[1] if hi[i] - lo[i] >= 3
                else np.nan for i in check]
    fits = []
    direct = frequency._line
    monkeypatch.setattr(frequency, "_line", lambda *a: fits.append(1) or direct(*a))
    got = frequency.local_slopes(f, y)
    np.testing.assert_allclose(got[check], expected, rtol=1e-8, atol=1e-8)
    # only windows of fewer than 64 points are fitted one by one: dense data costs O(n)
    count = hi - lo
    assert len(fits) == int(np.sum((count >= 3) & (count < 64)))
    if n == 5000:
        assert len(fits) < n / 20
