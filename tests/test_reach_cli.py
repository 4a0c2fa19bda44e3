"""``hybridlab reach``: exit codes 0 SAFE / 1 UNSAFE / 3 UNKNOWN / 2 user error, and the JSON."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from hybridlab.cli import main

ROOT = Path(__file__).resolve().parents[1]
BALL = str(ROOT / "models" / "bouncing_ball.toml")
DECAY = """
name = "decay"
parameters = { k = 1.0 }
states = { x = 1.0 }
[modes.run]
flow = { x = "-k*x" }
[initial]
mode = "run"
"""


@pytest.fixture
def decay(tmp_path: Path) -> str:
    path = tmp_path / "decay.toml"
    path.write_text(DECAY)
    return str(path)


def _run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(["reach", *argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_unsafe_exits_1_and_writes_the_counterexample(capsys, tmp_path):
    out_file = tmp_path / "verdict.json"
    code, out, err = _run(capsys, BALL, "--init", "h=5:10", "--t-end", "2",
                          "--safe", "h >= -1", "--safe", "v >= -13", "--out", str(out_file))
    assert code == 1 and err == ""
    assert out.startswith("verdict: UNSAFE: spec 'v >= -13' is violated at t=1.325178389 in "
                          "mode 'fall'")
    data = json.loads(out_file.read_text())
    assert data["verdict"] == "UNSAFE" and data["specs"] == ["h >= -1", "v >= -13"]
    cx = data["counterexample"]
    assert cx["spec"] == "v >= -13" and cx["mode"] == "fall" and cx["initial"]["h"] == 10.0
    assert cx["t"] == pytest.approx(13 / 9.81, abs=1e-12)
    assert data["margin"] == pytest.approx(13 - math.sqrt(2 * 9.81 * 10), abs=1e-7)
    assert data["time_s"] > 0
    assert {"bounds", "reachable_modes", "reason"} <= set(data)


def test_avoid_region_and_uncertain_parameter(capsys):
    code, out, _ = _run(capsys, BALL, "--init", "h=10", "--param", "e=0.5:0.9", "--t-end", "3",
                        "--avoid", "v=11:20", "--no-prove")
    assert code == 1 and "spec 'avoid v=11:20' is violated" in out


def test_no_prove_without_a_violation_is_unknown_exit_3(capsys):
    code, out, _ = _run(capsys, BALL, "--init", "h=5:10", "--t-end", "1", "--safe", "h >= -1",
                        "--no-prove", "--samples", "2")
    assert code == 3 and out.startswith("verdict: UNKNOWN: reachability was not attempted")


@pytest.mark.parametrize(("argv", "message"), [
    (["--init", "h=5:10", "--t-end", "1", "--safe", "w >= 0"],
     "hybridlab: error: spec 'w >= 0': unknown symbol (token 'w')"),
    (["--init", "h=10:5", "--t-end", "1", "--safe", "h >= 0"],
     "hybridlab: error: --init h: the interval 10:5 needs LO <= HI"),
    (["--init", "h=a:5", "--t-end", "1", "--safe", "h >= 0"],
     "hybridlab: error: --init h: 'a' is not a number"),
    (["--init", "hh=1:2", "--t-end", "1", "--safe", "h >= 0"],
     "hybridlab: error: initial: unknown state 'hh'; expected one of: h, v"),
    (["--init", "h", "--t-end", "1", "--safe", "h >= 0"],
     "hybridlab: error: --init expects NAME=LO:HI or NAME=VALUE (got 'h')"),
    (["--input", "e=0.5", "--t-end", "1", "--safe", "h >= 0"],
     "hybridlab: error: --input e: expects an interval LO:HI (got '0.5')"),
    (["--t-end", "1"], "hybridlab: error: give at least one --safe SPEC or --avoid REGION"),
    (["--t-end", "inf", "--safe", "h >= 0"], "hybridlab: error: --t-end: inf is not a finite "
                                             "number"),
    (["--t-end", "1", "--safe", "rise: h >= 0"],
     "hybridlab: error: spec 'rise: h >= 0': unknown mode; the model has: fall (token 'rise')"),
    (["--t-end", "1", "--safe", "h >= 0", "--out", "v.csv"],
     "hybridlab: error: --out must end in .json (got 'v.csv')"),
    (["--safe", "h >= 0"], "hybridlab: error: the following arguments are required: --t-end"),
    (["--t-end", "1", "--safe", "h >= 0", "--workers", "0"],
     "hybridlab: error: argument --workers: '0' is not positive"),
    (["--t-end", "1", "--safe", "h >= 0", "--split", "two"],
     "hybridlab: error: argument --split: 'two' is not an integer"),
])
def test_user_errors_exit_2_with_one_line(capsys, argv, message):
    code, out, err = _run(capsys, BALL, *argv)
    assert code == 2 and out == ""
    assert err == message + "\n"


def test_missing_model_file_is_a_user_error(capsys, tmp_path):
    code, _, err = _run(capsys, str(tmp_path / "none.toml"), "--t-end", "1", "--safe", "x >= 0")
    assert code == 2 and err.startswith("hybridlab: error: ") and err.count("\n") == 1


def test_safe_exits_0_with_bounds_and_modes_in_the_json(capsys, tmp_path, decay):
    out_file = tmp_path / "safe.json"
    code, out, _ = _run(capsys, decay, "--init", "x=1:2", "--t-end", "1", "--safe", "x >= 0.3",
                        "--samples", "2", "--out", str(out_file))
    assert code == 0 and out.startswith("verdict: SAFE: every spec holds")
    data = json.loads(out_file.read_text())
    assert data["verdict"] == "SAFE" and data["counterexample"] is None
    assert data["reachable_modes"] == ["run"] and data["reach_complete"] is True
    lo, hi = data["bounds"]["x"]
    assert lo <= math.exp(-1.0) and 2.0 <= hi < 2.01
    assert 0 <= data["margin"] <= math.exp(-1.0) - 0.3


def test_split_pieces_on_worker_processes_give_the_serial_verdict(capsys, tmp_path, decay):
    data = []
    for extra in ([], ["--workers", "2"]):
        out_file = tmp_path / f"split{len(extra)}.json"
        code, out, _ = _run(capsys, decay, "--init", "x=1:2", "--t-end", "1", "--safe",
                            "x >= 0.3", "--samples", "2", "--split", "2", *extra,
                            "--out", str(out_file))
        assert code == 0 and out.startswith("verdict: SAFE")
        data.append(json.loads(out_file.read_text()))
    assert data[0]["bounds"] == data[1]["bounds"] and data[0]["margin"] == data[1]["margin"]
    assert data[0]["bounds"]["x"][1] >= 2.0


def test_incomplete_reach_exits_3(capsys):
    code, out, _ = _run(capsys, BALL, "--init", "h=5:6", "--t-end", "3", "--safe", "h >= -1",
                        "--max-jumps", "0", "--samples", "2")
    assert code == 3 and out.startswith("verdict: UNKNOWN: the reach result is incomplete")


def test_a_command_without_a_time_budget_has_the_default_one(capsys, monkeypatch):
    # 50,000 steps of the thermostat take far longer than the (lowered) default budget
    import hybridlab.cli.reach as reach_command

    monkeypatch.setattr(reach_command, "DEFAULT_TIME_BUDGET", 0.2)
    thermostat = str(ROOT / "models" / "thermostat.toml")
    code, out, _ = _run(capsys, thermostat, "--init", "T=19:21", "--param", "a=0.09:0.11",
                        "--t-end", "500", "--step", "0.01", "--safe", "T <= 30",
                        "--samples", "2")
    assert code == 3 and "the time budget of 0.2 s ran out" in out
