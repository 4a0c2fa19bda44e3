"""Peak memory of a 10,000-run ensemble that keeps only observables.

A cheap model (the thermostat, 60 min, two observables and one event count
per run) is swept over 10,000 initial temperatures and heat-loss rates with
:func:`hybridlab.sweep` on the default executor (a process pool over every
core). Peak resident set sizes come from ``resource.getrusage``: this process
(``RUSAGE_SELF``) and the largest worker process (``RUSAGE_CHILDREN``, which
reports the largest child, not a sum); the bound printed is the parent plus
every worker at that largest child's peak.

Run ``python benchmarks/sweep_memory.py [--runs N] [--workers N]``.
"""

from __future__ import annotations

import argparse
import resource
import sys
import time

import numpy as np
from common import ROOT

import hybridlab

MODEL = ROOT / "models" / "thermostat.toml"


def _mib(kib: int) -> float:
    return kib / 1024.0  # ru_maxrss is in KiB on Linux


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10_000)
    parser.add_argument("--workers", type=int, default=None)
    args = parser.parse_args(argv)
    side = int(np.ceil(np.sqrt(args.runs)))
    temps = np.linspace(15.0, 25.0, side)
    rates = np.linspace(0.05, 0.2, side)
    before = _mib(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
    started = time.perf_counter()
    table = hybridlab.sweep(MODEL, grid={"T": temps, "a": rates}, t_end=60.0,
                            observe={"T_end": "T", "T_max": ("max", "T")},
                            events=["turn_on"], executor=args.workers)
    elapsed = time.perf_counter() - started
    parent = _mib(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
    child = _mib(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)
    workers = int(table.executor.partition("(")[2].rstrip(")") or 1)
    total = parent + workers * child
    print(f"{len(table)} runs ({len(table.failed)} not completed) in {elapsed:.1f} s "
          f"on {table.executor}, {len(table) / elapsed:.0f} runs/s")
    print(f"peak RSS: parent {parent:.0f} MiB (before the sweep {before:.0f} MiB), "
          f"largest worker {child:.0f} MiB")
    print(f"upper bound on the sweep's memory: {parent:.0f} + {workers} x {child:.0f} = "
          f"{total:.0f} MiB ({'under' if total < 1024 else 'OVER'} 1 GiB)")
    return 0 if total < 1024 else 1


if __name__ == "__main__":
    sys.exit(main())
