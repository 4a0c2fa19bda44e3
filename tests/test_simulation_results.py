"""Reading a run: repr, summary, plot, DataFrames, sampling at given times, the CSV grid."""

from __future__ import annotations

import csv
import tomllib
from pathlib import Path

import numpy as np
import pytest

import hybridlab
from hybridlab.cli import main
from hybridlab.simulation.result import FinalState, SimulationResult, Status
from hybridlab.simulation.tables import EventTable, SegmentTable

ROOT = Path(__file__).resolve().parents[1]
MODELS = sorted((ROOT / "models").glob("*.toml"))
THERMOSTAT = ROOT / "models" / "thermostat.toml"


@pytest.fixture(scope="module")
def ball_run(ball: hybridlab.Model) -> SimulationResult:
    return hybridlab.simulate(ball, 3.0, backend="reference")


@pytest.fixture(scope="module")
def thermostat_run() -> SimulationResult:
    return hybridlab.simulate(THERMOSTAT, 8.0, backend="reference")


def model_names(path: Path) -> tuple[tuple[str, ...], tuple[str, ...], tuple[str, ...]]:
    """States, modes and parameters of a model file: read from its tables when it has them
    (the large models load slowly), else from the loaded model (a composed model)."""
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    if isinstance(data.get("states"), dict) and isinstance(data.get("modes"), dict):
        return tuple(data["states"]), tuple(data["modes"]), tuple(data.get("parameters", ()))
    model = hybridlab.load_model(path)
    return tuple(model.states), tuple(model.modes), tuple(model.parameters)


def long_run(path: Path, k: int = 3000) -> SimulationResult:
    """A result of ``k`` jumps over the names of a model file, made without simulating."""
    names, modes, parameters = model_names(path)
    n, segments = len(names), k + 1
    cycle = np.arange(segments) % len(modes)
    table = SegmentTable.from_columns(
        mode=cycle, modes=modes, j=np.arange(segments),
        times=np.repeat(np.arange(segments + 1.0), 2)[1:-1], states=np.zeros((n, 2 * segments)),
        first=2 * np.arange(segments), count=np.full(segments, 2))
    events = EventTable.from_columns(
        names, t=np.arange(1.0, k + 1), j=np.arange(1, k + 1), transition=cycle[:k],
        labels=modes, source=cycle[:k], target=cycle[1:], modes=modes, kind=np.zeros(k, int),
        kinds=("jump",), grazing=np.zeros(k, bool), pre=np.zeros((k, n)), post=np.zeros((k, n)))
    final = FinalState(float(segments), k, modes[-1], dict.fromkeys(names, 0.0))
    return SimulationResult(Status.MAX_EVENTS, "stopped after 3000 events", events, table, final,
                            names, stats={"steps": 10**6, "backend": "reference"},
                            parameters=dict.fromkeys(parameters, 1.0))


@pytest.mark.parametrize("path", MODELS, ids=[p.stem for p in MODELS])
def test_repr_and_summary_stay_short_for_every_model(path: Path) -> None:
    result = long_run(path)
    text = repr(result)
    assert len(text) < 1000 and "\n" not in text
    assert text.startswith("<SimulationResult MAX_EVENTS: t 0.0 -> 3001.0, j=3000; 3001 segments, "
                           "3000 events (3000 jumps), 1000000 steps; states ")
    assert len(result.summary().splitlines()) <= 25


def test_repr_of_a_run(ball_run: SimulationResult) -> None:
    text = repr(ball_run)
    assert text.startswith("<SimulationResult COMPLETED: t 0.0 -> 3.0, j=1; 2 segments, 1 event "
                           "(1 jump), ")
    assert text.endswith("; states h, v; final mode 'fall'>")


def test_summary(thermostat_run: SimulationResult) -> None:
    lines = thermostat_run.summary().splitlines()
    assert lines[:6] == ["status: COMPLETED: reached t_end = 8.0", "reached: t 0.0 -> 8.0, j=3",
                         "events: 3 (3 jumps)", "  turn_off: 2 jumps", "  turn_on: 1 jump",
                         "final: mode cool, T=20.9836"]
    assert lines[6].startswith("run: reference backend, 4 segments, 3 events (3 jumps), ")


def test_summary_of_an_early_stop_says_what_to_do(ball: hybridlab.Model) -> None:
    result = hybridlab.simulate(ball, 3.0, max_events=1, backend="reference")
    lines = result.summary().splitlines()
    assert lines[0].startswith("status: MAX_EVENTS: ")
    assert lines[1] == "  " + Status.MAX_EVENTS.value


def test_plot_draws_one_line_per_state(ball_run: SimulationResult,
                                       thermostat_run: SimulationResult) -> None:
    pytest.importorskip("matplotlib")
    from matplotlib.figure import Figure

    fig = ball_run.plot()
    assert isinstance(fig, Figure)
    ax = fig.axes[0]
    assert [line.get_label() for line in ax.get_lines()] == ["h", "v"]
    h = ax.get_lines()[0].get_ydata()
    assert np.isnan(h).sum() == 1  # broken once, at the bounce
    assert len(ax.collections) == 1  # the events; one mode: no shading
    given = Figure().subplots()
    assert thermostat_run.plot("T", ax=given) is given
    assert len(given.get_lines()) == 1 and len(given.collections) == 3  # heat, cool, events
    with pytest.raises(ValueError, match="unknown state 'x'; the result has: h, v"):
        ball_run.plot(["h", "x"])


def test_to_pandas(ball_run: SimulationResult) -> None:
    pytest.importorskip("pandas")
    df = ball_run.to_pandas()
    assert list(df.columns) == ["t", "j", "mode", "h", "v"]
    assert len(df) == len(ball_run.t) and df["j"].tolist() == ball_run.j.tolist()
    grid = ball_run.to_pandas(0.5)
    assert grid["t"].tolist() == [0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0]
    assert grid["j"].tolist() == [0, 0, 0, 1, 1, 1, 1]
    np.testing.assert_array_equal(grid[["h", "v"]].to_numpy().T, ball_run.sample(0.5)[1])
    events = ball_run.events.to_pandas()
    assert len(events) == 1 and events.loc[0, "transition"] == "bounce"
    assert events.loc[0, "post_v"] == ball_run.events[0].post["v"]


def test_sample_at_given_times_takes_the_post_jump_value(ball_run: SimulationResult) -> None:
    bounce = ball_run.jumps[0]
    times = np.array([2.0, bounce.t, 0.5])
    t, x = ball_run.sample(times)
    np.testing.assert_array_equal(t, times)
    assert x[1, 1] == pytest.approx(bounce.post["v"], rel=1e-12)
    np.testing.assert_allclose(x, ball_run(times), rtol=1e-14)
    np.testing.assert_array_equal(ball_run.sample(t=times)[1], x)
    grid, y = ball_run.sample(1.0)  # a step, as before
    assert grid.tolist() == [0.0, 1.0, 2.0, 3.0] and y.shape == (2, 4)
    with pytest.raises(ValueError, match="outside the simulated hybrid time"):
        ball_run.sample([3.5])
    with pytest.raises(ValueError, match="dt must be a positive number"):
        ball_run.sample(0.0)


def test_cli_writes_a_uniform_grid(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "run.csv"
    assert main(["simulate", str(THERMOSTAT), "--t-end", "1", "--backend", "reference",
                 "--out", str(out), "--dt", "0.25"]) == 0
    with out.open(newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["t", "j", "mode", "T"]
    assert [float(r[0]) for r in rows[1:]] == [0.0, 0.25, 0.5, 0.75, 1.0]
    assert main(["simulate", str(THERMOSTAT), "--out", str(tmp_path / "run.json"),
                 "--dt", "0.25"]) == 2
    assert "--dt samples the --out CSV file" in capsys.readouterr().err
