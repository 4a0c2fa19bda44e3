"""Run every benchmark and print its tables (``make bench``).

Usage::

    .venv/bin/python benchmarks/run_all.py [--quick] [--repeat N] [--json FILE] [--only NAME]

A benchmark is a module in this folder with a ``run(repeat: int) -> Report``
function; add its name to :data:`BENCHMARKS` to include it.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import time
from collections.abc import Sequence

from common import Report, add_arguments, machine_info, print_report, repeat_count, write_json

#: Benchmark modules, run in this order. ``ball_peers`` comes last: it may import jax, and
#: a process pool forked after JAX has started its threads can deadlock.
BENCHMARKS = ("bouncing_ball", "trolley_free_drop", "trolley_stop_and_return", "kernel_floor",
              "ball_peers")


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Run the hybridlab benchmarks.")
    add_arguments(parser)
    parser.add_argument("--only", action="append", choices=BENCHMARKS, metavar="NAME",
                        help="run only this benchmark (repeatable; one of "
                             f"{', '.join(BENCHMARKS)})")
    args = parser.parse_args(argv)
    repeat = repeat_count(args)
    info = machine_info()
    print(f"hybridlab {info['hybridlab']} benchmarks, {info['date']}")
    print(f"{info['cpu']}, {info['cpu_count']} cores, {info['platform']}")
    print(f"Python {info['python']}, numpy {info['numpy']}, scipy {info['scipy']}; "
          f"{repeat} timed runs per configuration")
    print()
    reports: list[Report] = []
    for name in args.only or BENCHMARKS:
        start = time.perf_counter()
        report = importlib.import_module(name).run(repeat)
        print_report(report)
        print(f"({name}: {time.perf_counter() - start:.1f} s)")
        print()
        reports.append(report)
    if args.json:
        write_json(args.json, reports)
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
