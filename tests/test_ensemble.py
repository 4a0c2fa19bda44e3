"""Ensembles: grid expansion, name resolution, errors, agreement with single runs,
failing runs, executors, CSV output and the ``hybridlab sweep`` CLI."""

from __future__ import annotations

import concurrent.futures as cf
import csv
import math
import signal
import threading
from pathlib import Path

import numpy as np
import pytest

import hybridlab
from hybridlab.cli import main
from hybridlab.ensemble import Count, SweepError, SweepResult, simulate_many, sweep

ROOT = Path(__file__).resolve().parents[1]
BALL = ROOT / "models" / "bouncing_ball.toml"
THERMOSTAT = ROOT / "models" / "thermostat.toml"
G = 9.81


def impacts(h0: float, e: float, t_end: float) -> list[float]:
    """Closed-form impact times of a ball dropped from rest at h0."""
    t = math.sqrt(2 * h0 / G)
    v = G * t
    out = []
    while t <= t_end and len(out) < 1000:  # the grids below stay clear of Zeno
        out.append(t)
        v *= e
        t += 2 * v / G
    return out


def top_height(result) -> float:
    """A module-level function observable (picklable, so it runs in worker processes)."""
    return float(np.max(result.y[0]))


@pytest.fixture(scope="module")
def ball() -> hybridlab.Model:
    return hybridlab.load_model(BALL)


@pytest.fixture(scope="module")
def ball_grid(ball) -> SweepResult:
    # accumulation times t_1 (1 + e) / (1 - e) > 4 s: no Zeno run
    return sweep(ball, grid={"e": [0.7, 0.8, 0.9], "h": [5.0, 10.0]}, t_end=4.0,
                 observe={"v_end": "v", "top": ("max", "h"), "h1": ("at", "h", 1.0)},
                 events=["bounce", Count("bounce", after="bounce", name="later")],
                 executor="serial")


# ----- grid expansion and name resolution ----------------------------------------------------
def test_grid_is_a_full_factorial_last_name_fastest(ball_grid):
    assert len(ball_grid) == 6
    assert ball_grid.inputs == ("e", "h")
    assert ball_grid["e"].tolist() == [0.7, 0.7, 0.8, 0.8, 0.9, 0.9]
    assert ball_grid["h"].tolist() == [5.0, 10.0] * 3
    assert ball_grid["run"].tolist() == list(range(6))
    assert ball_grid.columns == ("run", "e", "h", "status", "t_final", "jumps", "count:bounce",
                                 "later", "v_end", "top", "h1", "error")


def test_counts_and_observables_match_the_closed_form(ball_grid):
    for row in range(len(ball_grid)):
        e, h0 = ball_grid["e"][row], ball_grid["h"][row]
        expected = len(impacts(h0, e, 4.0))
        assert ball_grid["count:bounce"][row] == expected
        assert ball_grid["later"][row] == expected - 1  # strictly after the first bounce
        assert ball_grid["top"][row] == pytest.approx(h0)
        if math.sqrt(2 * h0 / G) > 1.0:  # before the first impact: free fall
            assert ball_grid["h1"][row] == pytest.approx(h0 - G / 2, abs=1e-9)
    assert ball_grid.ok and set(ball_grid["error"]) == {""}


def test_rows_equal_individual_simulate_calls(ball, ball_grid):
    for row in (0, 3, 5):
        params = {"e": float(ball_grid["e"][row])}
        result = hybridlab.simulate(ball, 4.0, params=params,
                                    initial={"h": float(ball_grid["h"][row])})
        assert ball_grid["jumps"][row] == len(result.jumps)
        assert ball_grid["t_final"][row] == result.final.t
        assert ball_grid["v_end"][row] == pytest.approx(result.final.state["v"], abs=1e-12)
        assert ball_grid["status"][row] == result.status.name


def test_a_state_name_sets_the_initial_state_and_a_parameter_the_parameter(ball):
    table = sweep(ball, grid={"v": [0.0, 5.0]}, params={"g": 1.0}, initial={"h": 1.0},
                  t_end=0.5, observe={"h_end": "h"}, executor="serial")
    # h(t) = 1 + v0 t - t^2/2 with g = 1
    assert table["h_end"].tolist() == pytest.approx([1 - 0.125, 1 + 2.5 - 0.125])


def test_samples_forms_are_equivalent(ball):
    kwargs = {"t_end": 1.0, "observe": {"h_end": "h"}, "executor": "serial"}
    dicts = sweep(ball, samples=[{"h": 3.0, "g": 2.0}, {"h": 4.0, "g": 1.0}], **kwargs)
    pair = sweep(ball, samples=(["h", "g"], [[3.0, 2.0], [4.0, 1.0]]), **kwargs)
    structured = np.array([(3.0, 2.0), (4.0, 1.0)], dtype=[("h", float), ("g", float)])
    struct = sweep(ball, samples=structured, **kwargs)
    expected = [3.0 - 1.0, 4.0 - 0.5]
    for table in (dicts, pair, struct):
        assert table["h_end"].tolist() == pytest.approx(expected)
    crossed = sweep(ball, samples=[{"h": 3.0}, {"h": 4.0}], grid={"g": [1.0, 2.0]}, **kwargs)
    assert crossed["h_end"].tolist() == pytest.approx([2.5, 2.0, 3.5, 3.0])


def test_simulate_many_records_what_each_run_set():
    table = simulate_many(THERMOSTAT, [{"initial": {"T": 20.0}},
                                       {"initial": {"T": 21.0}, "params": {"a": 0.2},
                                        "t_end": 2.0}],
                          observe={"T_end": "T"}, events=["turn_off"], executor="serial")
    assert table.columns == ("run", "a", "T", "t_end", "status", "t_final", "jumps",
                             "count:turn_off", "T_end", "error")
    assert table["T"].tolist() == [20.0, 21.0]
    # heat from 21 towards 40 at rate 0.2 until T_high = 22, then cool towards 10 (T_low = 18
    # is not reached before t = 2)
    t_switch = math.log((40 - 21) / (40 - 22)) / 0.2
    assert table["count:turn_off"].tolist()[1] == 1
    expected = 10 + (22 - 10) * math.exp(-0.2 * (2.0 - t_switch))
    assert table["T_end"][1] == pytest.approx(expected, rel=1e-7)
    assert np.isnan(table["a"][0]) and table["a"][1] == 0.2
    assert table["t_final"].tolist() == [60.0, 2.0]


# ----- errors --------------------------------------------------------------------------------
@pytest.mark.parametrize(("kwargs", "message"), [
    ({"grid": {"ee": [1.0]}}, "'ee' is neither a parameter nor a state"),
    ({"grid": {"e": []}}, "grid 'e': expected a non-empty"),
    ({"grid": {"e": [0.5, "x"]}}, "grid 'e': 'x' is not a number"),
    ({"grid": {"e": [math.inf]}}, "not a finite number"),
    ({"grid": {"e": [0.5]}, "params": {"e": 0.4}}, "'e' is swept and also given"),
    ({"events": ["bonce"]}, "unknown transition 'bonce'"),
    ({"events": [Count("bounce", after="nope")]}, "unknown transition 'nope'"),
    ({"observe": {"x": "hh + 1"}}, "hh"),
    ({"observe": {"x": ("mean", "h")}}, "unknown reduction 'mean'"),
    ({"observe": {"status": "h"}}, "column 'status' appears twice"),
    ({"keep": "everything"}, "keep must be one of"),
    ({"rtol": -1.0}, "rtol must be a positive number"),
    ({"colour": "red"}, "unknown simulate option 'colour'"),
    ({"scenario": "nope"}, "unknown scenario 'nope'"),
    ({"chunksize": 0}, "chunksize must be a positive integer"),
    ({"executor": "gpu"}, "executor: expected an Executor"),
])
def test_setup_errors_are_one_line_and_raised_before_any_run(ball, kwargs, message):
    kwargs = {"grid": {"h": [1.0]}, "t_end": 1.0, **kwargs}
    with pytest.raises(ValueError, match=message) as info:
        sweep(ball, **kwargs)
    assert "\n" not in str(info.value)


def test_t_end_is_required_without_a_scenario():
    model = hybridlab.model_from_dict({
        "name": "decay", "parameters": {"k": 1.0}, "states": {"x": 1.0},
        "modes": {"m": {"flow": {"x": "-k*x"}}}, "initial": {"mode": "m"}})
    with pytest.raises(SweepError, match="t_end is required"):
        sweep(model, grid={"k": [1.0]})
    table = sweep(model, grid={"k": [1.0, 2.0]}, t_end=1.0, observe={"x": "x"},
                  executor="serial")
    assert table["x"].tolist() == pytest.approx([math.exp(-1), math.exp(-2)], rel=1e-7)


def test_a_failing_run_is_recorded_not_raised(ball):
    # zeno="error" makes the runs that reach the accumulation point raise ZenoError
    table = sweep(ball, grid={"e": [0.5, 0.8]}, t_end=5.0, zeno="error", observe=["h"],
                  executor="serial")
    assert table["status"].tolist() == ["ERROR", "COMPLETED"]
    assert table["error"][0].startswith("ZenoError")
    assert np.isnan(table["t_final"][0]) and np.isnan(table["h"][0])
    assert table.failed == (0,) and not table.ok


# ----- executors -----------------------------------------------------------------------------
def _small(ball, executor, **kwargs) -> SweepResult:
    return sweep(ball, grid={"e": [0.6, 0.75, 0.9], "h": [1.0, 3.0]}, t_end=3.0,
                 observe={"v_end": "v", "top": top_height}, events=["bounce"],
                 executor=executor, **kwargs)


def test_thread_and_process_executors_match_serial(ball):
    serial = _small(ball, "serial")
    assert serial.executor == "serial"
    threads = _small(ball, "threads", chunksize=1)
    with cf.ProcessPoolExecutor(max_workers=2) as pool:
        processes = _small(ball, pool, chunksize=2)
    for other in (threads, processes):
        assert other.columns == serial.columns
        assert other.rows == serial.rows  # identical numbers, in run order


def test_results_are_kept_on_request_and_reattached(ball):
    table = sweep(ball, grid={"e": [0.5, 0.8]}, t_end=3.0, keep="results", executor=2)
    assert table.executor == "processes(2)"
    assert len(table.results) == 2
    for k, result in enumerate(table.results):
        assert len(result.jumps) == table["jumps"][k]
        assert result.observe("h", [0.0])[0] == pytest.approx(10.0)  # compiled re-attached
    assert _small(ball, "serial").results is None


def test_an_unpicklable_function_observable_is_refused_for_processes(ball):
    with pytest.raises(SweepError, match="cannot be pickled"):
        sweep(ball, grid={"e": [0.5, 0.8]}, t_end=1.0, observe={"f": lambda r: 1.0},
              executor="processes")
    table = sweep(ball, grid={"e": [0.5, 0.8]}, t_end=1.0, observe={"f": lambda r: 1.0},
                  executor="threads")
    assert table["f"].tolist() == [1.0, 1.0]


def test_progress_bar_on_request(ball, capsys):
    sweep(ball, grid={"e": [0.5, 0.8]}, t_end=1.0, executor="serial", progress=True)
    assert "2/2 runs" in capsys.readouterr().err
    sweep(ball, grid={"e": [0.5, 0.8]}, t_end=1.0, executor="serial")
    assert capsys.readouterr().err == ""  # not a terminal: quiet


# ----- output --------------------------------------------------------------------------------
def test_csv_round_trip_and_arrays(ball_grid, tmp_path):
    path = tmp_path / "table.csv"
    ball_grid.to_csv(path)
    with path.open() as fh:
        rows = list(csv.reader(fh))
    assert tuple(rows[0]) == ball_grid.columns
    assert len(rows) == 7
    k = ball_grid.columns.index("v_end")
    assert [float(r[k]) for r in rows[1:]] == ball_grid["v_end"].tolist()
    assert ball_grid.to_numpy(["e", "count:bounce"]).shape == (6, 2)
    assert ball_grid.as_dict()["status"] == ["COMPLETED"] * 6
    pivot = ball_grid.pivot("e", "h", "count:bounce")
    assert pivot.index.tolist() == [0.7, 0.8, 0.9] and pivot.columns.tolist() == [5.0, 10.0]
    assert pivot.values[2, 1] == len(impacts(10.0, 0.9, 4.0))
    with pytest.raises(KeyError, match="no column 'nope'"):
        ball_grid.column("nope")


# ----- the CLI -------------------------------------------------------------------------------
def test_cli_sweep_writes_the_table_and_exits_0(tmp_path, capsys):
    out = tmp_path / "t.csv"
    code = main(["sweep", str(BALL), "--grid", "e=0.7:0.9:3", "--grid", "h=5,10",
                 "--t-end", "4", "--observe", "top=max:h", "--observe", "v_end=v",
                 "--count", "bounce", "--count", "later=bounce@bounce", "--workers", "1",
                 "--out", str(out)])
    assert code == 0, capsys.readouterr()
    with out.open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 6
    assert [int(r["count:bounce"]) for r in rows] == [len(impacts(float(r["h"]),
                                                                  float(r["e"]), 4.0))
                                                      for r in rows]
    assert all(int(r["later"]) == int(r["count:bounce"]) - 1 for r in rows)
    assert "6 runs, 6 completed" in capsys.readouterr().out


def test_cli_sweep_exits_3_when_a_run_ends_early(tmp_path, capsys):
    out = tmp_path / "t.csv"
    code = main(["sweep", str(BALL), "--grid", "e=0.5,0.8", "--t-end", "5",
                 "--workers", "1", "--out", str(out)])
    assert code == 3
    assert "run 0: ZENO" in capsys.readouterr().out
    assert out.exists()


@pytest.mark.parametrize("args", [
    ["--grid", "ee=0:1:3"],
    ["--grid", "e=0:1"],
    ["--grid", "e=0:1:x"],
    ["--grid", "e=0.5", "--observe", "x=hh"],
    ["--grid", "e=0.5", "--count", "bonce"],
    ["--grid", "e=0.5", "--value", "e=1"],
    ["--grid", "e=0.5", "--workers", "0"],
    [],
])
def test_cli_sweep_user_errors_exit_2_with_one_line(tmp_path, capsys, args):
    code = main(["sweep", str(BALL), "--t-end", "1", *args, "--out", str(tmp_path / "t.csv")])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith("hybridlab: error:") and err.count("\n") == 1
    assert not (tmp_path / "t.csv").exists()


def test_cli_sweep_rejects_a_non_csv_output(tmp_path, capsys):
    assert main(["sweep", str(BALL), "--grid", "e=0.5", "--out", str(tmp_path / "t.json")]) == 2
    assert "--out must end in .csv" in capsys.readouterr().err


def test_ctrl_c_during_a_sweep_keeps_every_finished_run():
    calls = []

    def stop_on_the_third_run(result):
        calls.append(result.final.t)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return result.final.t

    table = hybridlab.sweep("models/bouncing_ball.toml", grid={"e": [0.1, 0.2, 0.3, 0.4, 0.5]},
                            t_end=1.0, observe={"t": stop_on_the_third_run}, executor="serial",
                            chunksize=1)
    assert table.interrupted
    assert list(table["status"]) == ["COMPLETED"] * 2 + ["INTERRUPTED"] * 3
    assert table["t"].tolist()[:2] == [1.0, 1.0]
    assert "interrupted (Ctrl-C)" in table.column("error")[4]


def test_ctrl_c_stops_a_threads_sweep_after_the_runs_in_progress():
    # Ctrl-C reaches the main thread only; the chunks running in the pool's threads
    # (200 runs each) must stop after their current run, and their finished runs count
    main_thread = threading.main_thread().ident
    calls = []

    def interrupt_on_the_fifth_run(result):
        calls.append(result.final.t)
        if len(calls) == 5:
            signal.pthread_kill(main_thread, signal.SIGINT)
        return result.final.t

    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        table = hybridlab.sweep(BALL, grid={"e": np.linspace(0.5, 0.9, 400).tolist()},
                                t_end=1.0, observe={"t": interrupt_on_the_fifth_run},
                                executor="threads", chunksize=200, backend="reference")
    finally:
        signal.signal(signal.SIGINT, previous)
    done = int((table["status"] == "COMPLETED").sum())
    assert table.interrupted
    assert 5 <= done == len(calls) < 100
    assert int((table["status"] == "INTERRUPTED").sum()) == 400 - done


def test_a_per_run_time_limit_bounds_each_run_of_a_sweep(tmp_path):
    model = tmp_path / "osc.toml"
    model.write_text('name = "osc"\nparameters = { w = 1.0 }\nstates = { x = 1.0, v = 0.0 }\n'
                     '[modes.a]\nflow = { x = "v", v = "-w*x" }\n[initial]\nmode = "a"\n')
    table = hybridlab.sweep(model, grid={"w": [1.0, 4.0]}, t_end=1e300, time_limit=0.2,
                            executor="serial")
    assert list(table["status"]) == ["TIME_LIMIT", "TIME_LIMIT"]
    assert not table.interrupted


def _die_once_at_e_03(result):
    """Kill the worker process the first time the run with e = 0.3 finishes (a marker file
    in $HYBRIDLAB_TEST_MARKER says it happened)."""
    import os
    from pathlib import Path

    marker = Path(os.environ["HYBRIDLAB_TEST_MARKER"])
    if result.parameters["e"] == 0.3 and not marker.exists():
        marker.write_text("died")
        os._exit(1)
    return result.final.t


def _die_always_at_e_03(result):
    import os

    if result.parameters["e"] == 0.3:
        os._exit(1)
    return result.final.t


def test_runs_lost_with_a_dead_worker_are_run_again(tmp_path, monkeypatch):
    monkeypatch.setenv("HYBRIDLAB_TEST_MARKER", str(tmp_path / "marker"))
    grid = {"e": [0.1, 0.2, 0.3, 0.4, 0.5, 0.6]}
    table = hybridlab.sweep("models/bouncing_ball.toml", grid=grid, t_end=1.0,
                            observe={"t": _die_once_at_e_03}, executor=2, chunksize=1)
    assert (tmp_path / "marker").exists()  # a worker did die
    assert list(table["status"]) == ["COMPLETED"] * 6
    always = hybridlab.sweep("models/bouncing_ball.toml", grid=grid, t_end=1.0,
                             observe={"t": _die_always_at_e_03}, executor=2, chunksize=1)
    status = list(always["status"])
    assert status[2] == "ERROR" and "worker process died" in always.column("error")[2]
    assert status.count("COMPLETED") == 5
