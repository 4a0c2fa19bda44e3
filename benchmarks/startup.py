"""Start-up: wall-clock time of short command-line calls, each in a fresh process.

hybridlab's bytecode is compiled first (as pip does for an installed package; an
editable checkout run with ``PYTHONDONTWRITEBYTECODE`` would otherwise recompile
every module it imports in every process). Then, after one warm-up round that
fills the OS file cache, each round runs every command once, in turn, so a
change in the machine's load hits all commands alike; ``--repeat`` rounds.

The table shows per command the median and the minimum wall-clock time, the
median CPU time (user + system) and the median's ratio to
``python -c "import numpy"`` measured in the same rounds. The ``import``
lines are the floors: ``hybridlab check`` reads the model with sympy and
pydantic, so ``import sympy, pydantic`` is the least it can take.

Usage::

    .venv/bin/python benchmarks/startup.py [--repeat N]
"""

from __future__ import annotations

import argparse
import compileall
import datetime
import os
import platform
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: the console script next to this interpreter, else ``python -m hybridlab``
_SCRIPT = Path(sys.executable).with_name("hybridlab")
CLI = [str(_SCRIPT)] if _SCRIPT.exists() else [sys.executable, "-m", "hybridlab"]
PY = [sys.executable, "-c"]
BASELINE = 'python -c "import numpy"'
COMMANDS: dict[str, list[str]] = {
    'python -c "pass"': [*PY, "pass"],
    BASELINE: [*PY, "import numpy"],
    'python -c "import sympy, pydantic"': [*PY, "import sympy, pydantic"],
    'python -c "import hybridlab"': [*PY, "import hybridlab"],
    "hybridlab --help": [*CLI, "--help"],
    "hybridlab simulate --help": [*CLI, "simulate", "--help"],
    "hybridlab reach --help": [*CLI, "reach", "--help"],
    "hybridlab check models/thermostat.toml": [*CLI, "check", "models/thermostat.toml"],
    "hybridlab check models/friction_oscillator.toml": [*CLI, "check",
                                                         "models/friction_oscillator.toml"],
    "hybridlab check models/two_rooms.toml": [*CLI, "check", "models/two_rooms.toml"],
    "hybridlab check models/trolley.toml": [*CLI, "check", "models/trolley.toml"],
}


def run_once(command: list[str]) -> tuple[float, float]:
    """Wall-clock and CPU (user + system) seconds of one run of ``command``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(command, cwd=ROOT, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def measure(commands: dict[str, list[str]], repeat: int) -> dict[str, list[tuple[float, float]]]:
    """``repeat`` rounds (after a warm-up round) of every command in turn."""
    runs: dict[str, list[tuple[float, float]]] = {name: [] for name in commands}
    for k in range(repeat + 1):
        for name, command in commands.items():
            timing = run_once(command)
            if k:
                runs[name].append(timing)
    return runs


def table(runs: dict[str, list[tuple[float, float]]]) -> str:
    """The results as a table with each median's ratio to the baseline's."""
    baseline = statistics.median(wall for wall, _ in runs[BASELINE])
    width = max(map(len, runs))
    lines = [f"{'command':{width}s} {'median s':>9s} {'min s':>7s} {'cpu s':>7s} {'x numpy':>8s}"]
    for name, timings in runs.items():
        walls = [wall for wall, _ in timings]
        median = statistics.median(walls)
        cpu = statistics.median(cpu for _, cpu in timings)
        lines.append(f"{name:{width}s} {median:9.3f} {min(walls):7.3f} {cpu:7.3f} "
                     f"{median / baseline:8.1f}")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="timed rounds (default 5)")
    args = parser.parse_args()
    compileall.compile_dir(ROOT / "hybridlab", quiet=1)
    load = os.getloadavg()[0]
    runs = measure(COMMANDS, args.repeat)
    print(f"{datetime.date.today()}, {platform.python_implementation()} "
          f"{platform.python_version()}, {os.cpu_count()} cores, load average "
          f"{load:.2f} before / {os.getloadavg()[0]:.2f} after; median of {args.repeat} rounds")
    print(table(runs))


if __name__ == "__main__":
    main()
