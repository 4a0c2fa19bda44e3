"""Start-up: wall-clock time of short command-line calls, each in a fresh process.

Each command runs ``--repeat`` times (after one warm-up run that fills the OS file
cache); the table shows the median and the minimum, and each command's ratio to
``python -c "import numpy"`` measured in the same run. ``import sympy`` is listed
because ``hybridlab check`` parses the model with sympy: it is that command's floor.

Usage::

    .venv/bin/python benchmarks/startup.py [--repeat N]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CLI = [sys.executable, "-m", "hybridlab"]
COMMANDS = {
    'python -c "pass"': [sys.executable, "-c", "pass"],
    'python -c "import numpy"': [sys.executable, "-c", "import numpy"],
    'python -c "import sympy"': [sys.executable, "-c", "import sympy"],
    'python -c "import hybridlab"': [sys.executable, "-c", "import hybridlab"],
    "hybridlab --help": [*CLI, "--help"],
    "hybridlab reach --help": [*CLI, "reach", "--help"],
    "hybridlab check models/bouncing_ball.toml": [*CLI, "check", "models/bouncing_ball.toml"],
    "hybridlab check models/trolley.toml": [*CLI, "check", "models/trolley.toml"],
}


def wall_times(command: list[str], repeat: int) -> list[float]:
    """Seconds per run of ``command`` (after one warm-up run)."""
    times = []
    for k in range(repeat + 1):
        start = time.perf_counter()
        subprocess.run(command, cwd=ROOT, check=True, stdout=subprocess.DEVNULL)
        if k:
            times.append(time.perf_counter() - start)
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args()
    rows = {name: wall_times(cmd, args.repeat) for name, cmd in COMMANDS.items()}
    numpy = statistics.median(rows['python -c "import numpy"'])
    print(f"{'command':44s} {'median s':>9s} {'min s':>7s} {'x numpy':>8s}")
    for name, times in rows.items():
        median = statistics.median(times)
        print(f"{name:44s} {median:9.3f} {min(times):7.3f} {median / numpy:8.1f}")


if __name__ == "__main__":
    main()
