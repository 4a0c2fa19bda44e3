"""Friction from steady-state runs: recovery, exclusion rule, asymmetry, bad data, CLI."""

from __future__ import annotations

import argparse
import json

import numpy as np
import pytest

from hybridlab.cli.identify import add_parser as add_identify_parser
from hybridlab.identify import DataError, FrictionData, fit_friction, read_friction_csv, write_csv
from hybridlab.identify.synthetic import friction_runs

C, D = 17.41, 257.0


@pytest.mark.parametrize("seed", range(5))
def test_recovers_c_and_d_within_2_percent(seed: int) -> None:
    fit = fit_friction(friction_runs(C, D, noise=0.3, rng=seed))
    assert abs(fit.c / C - 1) < 0.02
    assert abs(fit.d / D - 1) < 0.02
    # the truth lies within a few standard errors
    assert abs(fit.c - C) < 4 * fit.c_se
    assert abs(fit.d - D) < 4 * fit.d_se
    assert not fit.asymmetric


def test_exclusion_rule_drops_the_stribeck_region() -> None:
    data = friction_runs(C, D, stribeck_force=30.0, stribeck_velocity=0.01, noise=0.2, rng=3)
    fit = fit_friction(data)
    slow = np.abs(data.velocity) < 0.01
    assert not fit.used[slow].any()  # the hump (up to +12.6 N at rest) is excluded
    assert fit.used[np.abs(data.velocity) > 0.05].all()
    naive = fit_friction(data, v_min=0.0)
    assert abs(naive.c / C - 1) > 0.05  # without exclusion the hump biases c
    assert fit.forward.v_min > 0 and fit.backward.v_min > 0


def test_explicit_threshold() -> None:
    data = friction_runs(C, D, rng=1)
    fit = fit_friction(data, v_min=0.05)
    assert fit.used.sum() == np.sum(np.abs(data.velocity) > 0.05)
    assert fit.forward.v_min == 0.05


def test_asymmetry_is_flagged_and_directions_recovered() -> None:
    fit = fit_friction(friction_runs(C, D, c_backward=14.0, d_backward=240.0, rng=2))
    assert fit.asymmetric
    assert abs(fit.forward.c / C - 1) < 0.02 and abs(fit.backward.c / 14.0 - 1) < 0.02
    assert abs(fit.backward.d / 240.0 - 1) < 0.02
    assert fit.asymmetry_c > 0.1
    assert "ASYMMETRIC" in fit.table()


def test_noise_free_fit_is_exact_and_standard_errors_vanish() -> None:
    v = np.array([-0.3, -0.2, -0.1, -0.05, 0.05, 0.1, 0.2, 0.3])
    fit = fit_friction(FrictionData(v, C * np.sign(v) + D * v), v_min=0.0)
    assert fit.c == pytest.approx(C, rel=1e-12) and fit.d == pytest.approx(D, rel=1e-12)
    assert fit.c_se < 1e-9 and np.max(np.abs(fit.residuals)) < 1e-9


@pytest.mark.parametrize(
    ("velocity", "force", "match"),
    [
        ([0.1, 0.2, np.nan, 0.3], [1.0, 2.0, 3.0, 4.0], "column 'velocity'.*NaN.*row 3"),
        ([0.1, 0.2, -0.3], [1.0, 2.0, np.inf], "column 'force'"),
        ([0.1, 0.2, 0.3, 0.4], [20.0, 40.0, 60.0, 80.0], "no runs with negative velocity"),
        ([-0.1, -0.2, -0.3], [-20.0, -40.0, -60.0], "no runs with positive velocity"),
        ([0.1, 0.2, -0.1, -0.2], [40.0, 60.0, -40.0, -60.0], "at least 3 runs"),
        ([0.1, 0.2], [1.0], "different lengths"),
    ],
)
def test_bad_data_names_the_problem(velocity, force, match) -> None:
    with pytest.raises(DataError, match=match) as info:
        fit_friction(FrictionData(velocity, force))
    assert isinstance(info.value, ValueError)


def test_threshold_leaving_too_few_runs() -> None:
    with pytest.raises(DataError, match="exclusion threshold"):
        fit_friction(friction_runs(C, D, rng=0), v_min=0.29)


def test_csv_missing_column_and_bad_cell(tmp_path) -> None:
    path = tmp_path / "runs.csv"
    path.write_text("speed,force\n0.1,40\n")
    with pytest.raises(DataError, match="runs.csv: column 'velocity': missing column"):
        read_friction_csv(path)
    path.write_text("velocity,force\n0.1,forty\n")
    with pytest.raises(DataError, match="column 'force': is not a number at data row 1"):
        read_friction_csv(path)
    with pytest.raises(DataError, match="cannot read"):
        read_friction_csv(tmp_path / "missing.csv")


def test_cli_prints_a_table_and_writes_json(tmp_path, capsys) -> None:
    data = friction_runs(C, D, rng=4)
    csv_path, out, png = tmp_path / "runs.csv", tmp_path / "fit.json", tmp_path / "fit.png"
    write_csv(csv_path, {"velocity": data.velocity.tolist(), "force": data.force.tolist(),
                         "note": ["x"] * len(data.velocity)})
    parser = argparse.ArgumentParser()
    add_identify_parser(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["identify", "friction", str(csv_path), "--out", str(out),
                              "--plot", str(png)])
    assert args.run(args) == 0
    text = capsys.readouterr().out
    assert "forward" in text and "backward" in text and "symmetric" in text
    payload = json.loads(out.read_text())
    assert set(payload["parameters"]) == {"c", "d"}
    assert abs(payload["parameters"]["c"] / C - 1) < 0.02
    assert png.stat().st_size > 1000
