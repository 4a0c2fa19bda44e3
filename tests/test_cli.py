"""The ``hybridlab`` command line: check, simulate, graph, schema, and user errors."""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import hybridlab
from hybridlab.cli import main

ROOT = Path(__file__).resolve().parents[1]
BALL = ROOT / "models" / "bouncing_ball.toml"
THERMOSTAT = ROOT / "models" / "thermostat.toml"
G = 9.81


def ball_state(t: float, *, h0: float = 10.0, e: float = 0.8) -> tuple[float, float]:
    """Closed form of the ball between its first and second impact."""
    t1 = math.sqrt(2 * h0 / G)
    v1 = e * G * t1
    dt = t - t1
    return v1 * dt - G / 2 * dt**2, v1 - G * dt


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


# ----------------------------------------------------------------------------------------
# check


def test_check_prints_a_summary(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "check", str(BALL))
    assert (code, err) == (0, "")
    assert out == (
        "model 'bouncing_ball': OK\n"
        "  Ball dropped on a rigid floor\n"
        "  states: 2 continuous, 0 discrete\n"
        "    continuous: h, v\n"
        "  parameters (2): g, e\n"
        "  modes (1), initial 'fall':\n"
        "    fall: 1 outgoing, 1 invariant(s)\n"
        "  transitions (1):\n"
        "    bounce: fall -> fall when h <= 0 priority 1\n"
        "  scenarios: default (t_end 10), zeno (t_end 20), benchmark (t_end 50)\n"
    )


def test_check_thermostat(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "check", str(THERMOSTAT))
    assert code == 0
    assert out.splitlines()[0] == "model 'thermostat': OK"
    assert "    turn_off: heat -> cool when T >= T_high" in out.splitlines()
    assert "    turn_on: cool -> heat when T <= T_low" in out.splitlines()


def test_check_derives_the_mechanics(capsys: pytest.CaptureFixture[str],
                                     tmp_path: Path) -> None:
    """``check`` generates no numeric code but still derives the equations of motion."""
    model = tmp_path / "singular.toml"
    model.write_text('name = "singular"\nstates = { x = 0.0, u = 0.0 }\n'
                     'modes.move = {}\ninitial.mode = "move"\n[mechanics]\n'
                     'coordinates = ["x"]\nvelocities = ["u"]\nkinetic = "x**2/2"\n'
                     'potential = "0"\n')
    code, out, err = run(capsys, "check", str(model))
    assert (code, out) == (2, "")
    assert err == ("hybridlab: error: mechanics: the mass matrix d2T/du2 is singular; check "
                   "that the kinetic energy involves every velocity\n")


# ----------------------------------------------------------------------------------------
# simulate


def test_simulate_json(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out_file = tmp_path / "ball.json"
    code, out, err = run(capsys, "simulate", str(BALL), "--t-end", "3", "--out", str(out_file))
    assert (code, err) == (0, "")
    assert out.splitlines()[0] == "status: COMPLETED: reached t_end = 3.0"
    assert out.splitlines()[-1] == f"wrote {out_file}"
    data = json.loads(out_file.read_text())
    assert data["status"] == "COMPLETED"
    [event] = data["events"]
    assert {"t", "j", "transition", "source", "target", "pre", "post"} <= set(event)
    assert (event["j"], event["transition"], event["source"], event["target"]) == (
        1, "bounce", "fall", "fall")
    assert event["t"] == pytest.approx(math.sqrt(2 * 10.0 / G), rel=1e-8)
    assert set(event["pre"]) == set(event["post"]) == {"h", "v"}
    assert event["pre"]["v"] == pytest.approx(-math.sqrt(2 * G * 10.0), rel=1e-8)
    assert event["post"]["v"] == pytest.approx(-0.8 * event["pre"]["v"], rel=1e-12)
    assert event["pre"]["h"] == pytest.approx(0.0, abs=1e-8)
    final = data["final"]
    assert (final["t"], final["mode"]) == (3.0, "fall")
    h, v = ball_state(3.0)
    assert final["state"] == {"h": pytest.approx(h, rel=1e-6), "v": pytest.approx(v, rel=1e-6)}


def test_simulate_csv(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out_file = tmp_path / "ball.csv"
    code, _, _ = run(capsys, "simulate", str(BALL), "--t-end", "2", "--out", str(out_file))
    assert code == 0
    with out_file.open(newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["t", "j", "mode", "h", "v"]
    assert rows[1] == ["0.0", "0", "fall", "10.0", "0.0"]
    times = [float(r[0]) for r in rows[1:]]
    assert times == sorted(times)
    assert times[-1] == 2.0
    assert {r[1] for r in rows[1:]} == {"0", "1"}
    assert {r[2] for r in rows[1:]} == {"fall"}
    h, v = ball_state(2.0)
    assert float(rows[-1][3]) == pytest.approx(h, rel=1e-6)
    assert float(rows[-1][4]) == pytest.approx(v, rel=1e-6)


def test_simulate_npz(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out_file = tmp_path / "ball.npz"
    code, _, _ = run(capsys, "simulate", str(BALL), "--t-end", "2", "--out", str(out_file))
    assert code == 0
    with np.load(out_file) as data:
        assert list(data["state_names"]) == ["h", "v"]
        assert str(data["status"]) == "COMPLETED"
        t, y = data["t"], data["y"]
        assert y.shape == (2, t.size)
        assert t[0] == 0.0 and t[-1] == 2.0
        assert list(data["event_transition"]) == ["bounce"]
        assert data["event_t"][0] == pytest.approx(math.sqrt(2 * 10.0 / G), rel=1e-8)
        h, v = ball_state(2.0)
        np.testing.assert_allclose(y[:, -1], [h, v], rtol=1e-6)


def test_simulate_zeno_scenario_exits_3(capsys: pytest.CaptureFixture[str],
                                        tmp_path: Path) -> None:
    out_file = tmp_path / "zeno.json"
    code, out, err = run(capsys, "simulate", str(BALL), "--scenario", "zeno", "--out",
                         str(out_file))
    assert (code, err) == (3, "")
    assert out.startswith("status: ZENO: ")
    data = json.loads(out_file.read_text())
    assert data["status"] == "ZENO"
    # accumulation time of the e = 0.8 ball: t1 (1 + 2e/(1-e)) = 9 t1
    zeno_time = 9 * math.sqrt(2 * 10.0 / G)
    assert data["zeno_time"] == pytest.approx(zeno_time, rel=1e-6)
    assert data["final"]["t"] < 20.0
    [line] = [x for x in out.splitlines() if x.startswith("zeno_time: ")]
    assert float(line.removeprefix("zeno_time: ")) == pytest.approx(zeno_time, rel=1e-6)


def test_simulate_overrides(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out_file = tmp_path / "ball.json"
    code, _, err = run(capsys, "simulate", str(BALL), "--t-end", "1.8", "--set", "e=0.5",
                       "--init", "h=5", "--init", "v=0", "--mode", "fall", "--method", "RK45",
                       "--rtol", "1e-10", "--atol", "1e-12", "--out", str(out_file))
    assert (code, err) == (0, "")
    data = json.loads(out_file.read_text())
    event = data["events"][0]
    assert event["t"] == pytest.approx(math.sqrt(2 * 5.0 / G), rel=1e-7)
    assert event["post"]["v"] == pytest.approx(-0.5 * event["pre"]["v"], rel=1e-12)
    h, v = ball_state(1.8, h0=5.0, e=0.5)
    assert data["final"]["state"] == {"h": pytest.approx(h, rel=1e-6),
                                      "v": pytest.approx(v, rel=1e-6)}


def test_simulate_default_scenario_and_summary(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "simulate", str(THERMOSTAT), "--t-end", "5")
    assert code == 0
    lines = out.splitlines()
    assert lines[0] == "status: COMPLETED: reached t_end = 5.0"
    assert lines[1].startswith("events: ")
    assert lines[2].startswith("final: t=5 j=")


# ----------------------------------------------------------------------------------------
# graph and schema


def test_graph_prints_dot(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "graph", str(THERMOSTAT))
    assert (code, err) == (0, "")
    assert out == hybridlab.to_dot(hybridlab.load_model(THERMOSTAT))


def test_graph_writes_dot(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out_file = tmp_path / "ball.dot"
    code, out, _ = run(capsys, "graph", str(BALL), "--out", str(out_file))
    assert code == 0
    assert out == f"wrote {out_file}\n"
    assert out_file.read_text() == hybridlab.to_dot(hybridlab.load_model(BALL))


def test_schema_prints_json(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "schema")
    assert code == 0
    assert out == json.dumps(hybridlab.model_json_schema(), indent=2) + "\n"


def test_schema_writes_file(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out_file = tmp_path / "schema.json"
    code, _, _ = run(capsys, "schema", "--out", str(out_file))
    assert code == 0
    assert json.loads(out_file.read_text()) == hybridlab.model_json_schema()


# ----------------------------------------------------------------------------------------
# user errors: exactly one line on stderr, exit 2, no traceback


def bad_model(tmp_path: Path) -> Path:
    path = tmp_path / "bad.toml"
    path.write_text(BALL.read_text().replace('"-g"', '"-gg"'))
    return path


def user_error_cases(tmp_path: Path) -> list[tuple[list[str], str]]:
    missing = tmp_path / "missing.toml"
    bad = bad_model(tmp_path)
    ball = str(BALL)
    return [
        (["check", str(missing)],
         f"hybridlab: error: {missing}: cannot read file: No such file or directory"),
        (["check", str(bad)],
         f"hybridlab: error: {bad}: modes.fall.flow.v: unknown symbol (token 'gg')"),
        (["simulate", str(bad)],
         f"hybridlab: error: {bad}: modes.fall.flow.v: unknown symbol (token 'gg')"),
        (["graph", str(bad)],
         f"hybridlab: error: {bad}: modes.fall.flow.v: unknown symbol (token 'gg')"),
        (["simulate", ball, "--set", "q=1"],
         "hybridlab: error: params: unknown parameter 'q'; expected one of: g, e"),
        (["simulate", ball, "--set", "g=abc"],
         "hybridlab: error: --set g: 'abc' is not a number"),
        (["simulate", ball, "--set", "g"],
         "hybridlab: error: --set expects NAME=VALUE (got 'g')"),
        (["simulate", ball, "--init", "w=1"],
         "hybridlab: error: initial: unknown state 'w'; expected one of: h, v"),
        (["simulate", ball, "--init", "h=ten"],
         "hybridlab: error: --init h: 'ten' is not a number"),
        (["simulate", ball, "--t-end", "1", "--out", str(tmp_path / "ball.txt")],
         f"hybridlab: error: --out must end in .json, .csv or .npz "
         f"(got {str(tmp_path / 'ball.txt')!r})"),
        (["frobnicate"],
         "hybridlab: error: argument command: invalid choice: 'frobnicate' "
         "(choose from 'check', 'simulate', 'graph', 'identify', 'import', 'sweep', 'reach', "
         "'flatten', 'schema')"),
        ([], "hybridlab: error: the following arguments are required: command"),
        (["check"], "hybridlab: error: the following arguments are required: model"),
        (["simulate", ball, "--t-end", "soon"],
         "hybridlab: error: argument --t-end: invalid float value: 'soon'"),
        (["simulate", ball, "--method", "Euler"],
         "hybridlab: error: argument --method: invalid choice: 'Euler' (choose from 'RK45', "
         "'RK23', 'DOP853', 'Radau', 'BDF', 'LSODA')"),
        (["simulate", ball, "--scenario", "nope"],
         "hybridlab: error: scenario: unknown scenario 'nope'; the model has: default, zeno, "
         "benchmark"),
        (["simulate", ball, "--mode", "rise"],
         "hybridlab: error: mode: unknown mode 'rise'; expected one of: fall"),
        (["check", ball, "--frob"], "hybridlab: error: unrecognized arguments: --frob"),
    ]


CASE_IDS = ["missing-file", "bad-model-check", "bad-model-simulate", "bad-model-graph",
            "unknown-parameter", "non-number", "no-equals", "unknown-state", "non-number-init",
            "bad-suffix", "unknown-subcommand", "no-subcommand", "no-model", "bad-t-end",
            "bad-method", "unknown-scenario", "unknown-mode", "unknown-option"]


@pytest.mark.parametrize("index", range(len(CASE_IDS)), ids=CASE_IDS)
def test_user_errors_are_one_line(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                  index: int) -> None:
    argv, expected = user_error_cases(tmp_path)[index]
    code, out, err = run(capsys, *argv)
    assert code == 2
    assert out == ""
    assert err == expected + "\n"
    assert "Traceback" not in err


@pytest.mark.parametrize(
    "argv",
    [
        ["simulate", str(BALL), "--t-end", "-1"],
        ["simulate", str(BALL), "--rtol", "0"],
        ["simulate", str(BALL), "--set", "g=nan"],
        ["simulate", str(BALL), "--init", "h=inf"],
        ["simulate", str(BALL), "--t-end", "nan"],
        # a model file refuses t_end = inf; so must the command line (the thermostat would
        # otherwise run for a million events)
        ["simulate", str(BALL), "--t-end", "inf"],
    ],
    ids=["negative-t-end", "zero-rtol", "nan-parameter", "inf-initial", "nan-t-end",
         "inf-t-end"],
)
def test_bad_values_are_one_line_errors(capsys: pytest.CaptureFixture[str],
                                        argv: list[str]) -> None:
    code, out, err = run(capsys, *argv)
    assert (code, out) == (2, "")
    assert err.startswith("hybridlab: error: ")
    assert err.count("\n") == 1


def test_bad_suffix_writes_nothing(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    run(capsys, "simulate", str(BALL), "--t-end", "1", "--out", str(tmp_path / "ball.txt"))
    assert list(tmp_path.iterdir()) == []


def test_unwritable_output_is_a_user_error(capsys: pytest.CaptureFixture[str],
                                           tmp_path: Path) -> None:
    target = tmp_path / "no" / "such" / "dir" / "ball.dot"
    code, out, err = run(capsys, "graph", str(BALL), "--out", str(target))
    assert (code, out) == (2, "")
    assert err.startswith("hybridlab: error: ")
    assert err.count("\n") == 1


# ----------------------------------------------------------------------------------------
# the installed entry points


def test_console_script_runs() -> None:
    script = Path(sys.executable).with_name("hybridlab")
    done = subprocess.run([str(script), "check", str(BALL)], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[0] == "model 'bouncing_ball': OK"
    assert done.stderr == ""


def test_console_script_user_error(tmp_path: Path) -> None:
    script = Path(sys.executable).with_name("hybridlab")
    missing = tmp_path / "missing.toml"
    done = subprocess.run([str(script), "check", str(missing)], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 2
    assert done.stdout == ""
    assert done.stderr == (
        f"hybridlab: error: {missing}: cannot read file: No such file or directory\n")


def test_python_dash_m_runs() -> None:
    done = subprocess.run([sys.executable, "-m", "hybridlab", "graph", str(THERMOSTAT)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout == hybridlab.to_dot(hybridlab.load_model(THERMOSTAT))


def test_zeno_error_policy_exits_3_with_one_line(capsys, models_dir):
    from hybridlab.cli import main

    code = main(["simulate", str(models_dir / "bouncing_ball.toml"), "--scenario", "zeno",
                 "--zeno", "error"])
    err = capsys.readouterr().err
    assert code == 3
    assert err.count("\n") == 1 and err.startswith("hybridlab: error: Zeno behaviour")
