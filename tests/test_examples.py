"""Every example script runs and its own checks pass (exit code 0).

Each example compares a simulation with a closed form and exits non-zero on a
mismatch, so running them here makes them part of the suite. Each runs as a
script (``__name__ == "__main__"``, its own ``sys.argv``) in a process of its
own, in a temporary working directory, with ``--plot`` pointing into it, so the
plotting path is exercised too. The process is forked from this one after the
libraries every example imports are loaded (on platforms without ``fork``: a
fresh interpreter), so the three seconds of imports are paid once, not once per
script. A new ``examples/*.py`` is picked up automatically and must follow the
same contract: a few seconds, an optional ``--plot FILE.png``, exit status 0
when its checks hold.
"""

from __future__ import annotations

import os
import runpy
import signal
import subprocess
import sys
import time
import traceback
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


def _preload() -> None:
    """Import what the examples import and load the compiled kernel, in this process."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot  # noqa: F401
    import scipy.integrate  # noqa: F401

    import hybridlab
    import hybridlab.verify  # noqa: F401

    hybridlab.simulate(str(EXAMPLES_DIR.parent / "models" / "bouncing_ball.toml"), t_end=0.1)


@pytest.fixture(scope="module")
def run_script():
    """``run(script, args, cwd, timeout) -> (exit code, stdout, stderr)``."""
    if not hasattr(os, "fork"):
        def run_fresh(script: Path, args: list[str], cwd: Path, timeout: float):
            proc = subprocess.run([sys.executable, str(script), *args], cwd=cwd,
                                  capture_output=True, text=True, timeout=timeout)
            return proc.returncode, proc.stdout, proc.stderr
        return run_fresh
    _preload()
    return _run_forked


def _run_forked(script: Path, args: list[str], cwd: Path, timeout: float):
    out, err = cwd / ".stdout", cwd / ".stderr"
    pid = os.fork()
    if pid == 0:  # the child: run the script, then leave without running pytest's exit code
        code = 1
        try:
            for fd, path in ((1, out), (2, err)):
                target = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
                os.dup2(target, fd)
                os.close(target)
            sys.stdout = open(1, "w", closefd=False)  # noqa: SIM115 - closed by _exit
            sys.stderr = open(2, "w", closefd=False)  # noqa: SIM115
            os.chdir(cwd)
            sys.argv = [str(script), *args]
            sys.path[0] = str(script.parent)
            try:
                runpy.run_path(str(script), run_name="__main__")
                code = 0
            except SystemExit as exc:
                code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
            except BaseException:  # noqa: BLE001 - reported like an uncaught exception
                traceback.print_exc()
            sys.stdout.flush()
            sys.stderr.flush()
        finally:
            os._exit(code)
    deadline = time.monotonic() + timeout
    while True:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            break
        if time.monotonic() > deadline:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            raise subprocess.TimeoutExpired(str(script), timeout)
        time.sleep(0.02)
    code = os.waitstatus_to_exitcode(status)
    return code, out.read_text(errors="replace"), err.read_text(errors="replace")


def test_the_documented_examples_exist():
    assert {p.name for p in EXAMPLES} >= {"bouncing_ball.py", "thermostat.py", "sliding_mode.py",
                                          "sampled_control.py", "python_api.py", "demo.py"}


@pytest.mark.parametrize("script", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_runs_and_its_checks_pass(script, tmp_path, run_script):
    plot = tmp_path / f"{script.stem}.png"
    code, out, err = run_script(script, ["--plot", str(plot), *FAST_ARGS.get(script.name, [])],
                                tmp_path, 120)
    assert code == 0, (
        f"{script.name} exited with {code}\n--- stdout\n{out}\n--- stderr\n{err}"
    )
    assert plot.stat().st_size > 0, f"{script.name} did not write {plot.name}"


def test_reproduce_paper_fast(tmp_path, run_script):
    """The paper reproduction in its fast mode, with every figure."""
    out = tmp_path / "paper.json"
    plots = tmp_path / "figures"
    code, stdout, stderr = run_script(EXAMPLES_DIR / "reproduce_paper.py",
                                      ["--out", str(out), "--plots", str(plots), "--fast"],
                                      tmp_path, 900)
    assert code == 0, f"--- stdout\n{stdout}\n--- stderr\n{stderr}"
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
