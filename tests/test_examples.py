"""Every example script runs and its own checks pass (exit code 0).

Each example compares a simulation with a closed form and exits non-zero on a
mismatch, so running them here makes them part of the suite. They run as
subprocesses in a temporary working directory, with ``--plot`` pointing into
it, so the plotting path is exercised too. A new ``examples/*.py`` is picked
up automatically and must follow the same contract: a few seconds, an
optional ``--plot FILE.png``, exit status 0 when its checks hold.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES_DIR = Path(__file__).resolve().parents[1] / "examples"

#: Scripts with a command line of their own, run by a dedicated test below.
NOT_RUN_HERE = {
    "reproduce_paper.py": "CLI --out/--plots/--fast; run by test_reproduce_paper_fast",
}

#: Extra arguments for scripts whose full run is too long for the suite.
FAST_ARGS = {"sweep_fig14.py": ["--fast"], "compiled_backend.py": ["--quick"]}

EXAMPLES = sorted(p for p in EXAMPLES_DIR.glob("*.py") if p.name not in NOT_RUN_HERE)


def test_the_documented_examples_exist():
    assert {p.name for p in EXAMPLES} >= {"bouncing_ball.py", "thermostat.py", "sliding_mode.py",
                                          "sampled_control.py", "python_api.py", "demo.py"}


@pytest.mark.parametrize("script", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_runs_and_its_checks_pass(script, tmp_path):
    plot = tmp_path / f"{script.stem}.png"
    proc = subprocess.run(
        [sys.executable, str(script), "--plot", str(plot), *FAST_ARGS.get(script.name, [])],
        cwd=tmp_path, capture_output=True, text=True, timeout=120,
    )
    assert proc.returncode == 0, (
        f"{script.name} exited with {proc.returncode}\n"
        f"--- stdout\n{proc.stdout}\n--- stderr\n{proc.stderr}"
    )
    assert plot.stat().st_size > 0, f"{script.name} did not write {plot.name}"


def test_reproduce_paper_fast(tmp_path):
    """The paper reproduction (issue 3) in its fast mode, with every figure."""
    out = tmp_path / "paper.json"
    plots = tmp_path / "figures"
    proc = subprocess.run(
        [sys.executable, str(EXAMPLES_DIR / "reproduce_paper.py"), "--out", str(out),
         "--plots", str(plots), "--fast"],
        cwd=tmp_path, capture_output=True, text=True, timeout=900,
    )
    assert proc.returncode == 0, f"--- stdout\n{proc.stdout}\n--- stderr\n{proc.stderr}"
    import json

    data = json.loads(out.read_text())
    for key in ("period_s", "free_drop_nominal_crossings", "free_drop_identified_crossings",
                "payload_1kg_crossings", "payload_0_5kg_crossings", "step_overshoot_pct_1kg",
                "step_overshoot_pct_0_5kg", "settling_time_s_1kg", "settling_time_s_0_5kg",
                "tracking_error_max_mm", "tangential_velocity_at_crossings",
                "stop_return_final_error_mm", "stop_return_crossings"):
        assert key in data, key
    assert set(data["stop_return_crossings"]) == {"100", "250"}
    velocities = data["tangential_velocity_at_crossings"]
    assert velocities[0] > velocities[len(velocities) // 2] > velocities[-1]
    assert len(list(plots.glob("*.png"))) >= 8
