"""Shared helpers of the benchmark scripts: timing, tables, JSON records.

Benchmarks measure speed as a *ratio* against a plain scipy implementation of
the same job, both timed in the same process on the same machine, so the
numbers are comparable across machines only as ratios. Nothing here is a
test: no timing is ever asserted.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import platform
import statistics
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

__all__ = [
    "ROOT",
    "Report",
    "Timing",
    "add_arguments",
    "format_table",
    "machine_info",
    "print_report",
    "repeat_count",
    "time_call",
    "time_calls",
    "write_json",
]

#: The repository root; model files are found relative to it.
ROOT = Path(__file__).resolve().parents[1]

#: Timed repetitions after the warm-up run, full and ``--quick``.
DEFAULT_REPEAT = 15
QUICK_REPEAT = 2

T = TypeVar("T")


@dataclass(frozen=True)
class Timing:
    """Wall-clock times of repeated calls, in seconds.

    Attributes
    ----------
    times : tuple of float
        Every timed call, in order (the warm-up run is not included). With
        blocks (see :func:`time_calls`), the warm calls: those right after a
        call of the same function.
    switched : tuple of float
        With blocks, the first call of each block: right after another
        implementation ran, so with its caches (and the garbage it left) cold.
    """

    times: tuple[float, ...]
    switched: tuple[float, ...] = ()

    @property
    def best(self) -> float:
        return min(self.times)

    @property
    def median(self) -> float:
        return statistics.median(self.times)

    @property
    def switched_median(self) -> float:
        return statistics.median(self.switched) if self.switched else math.nan

    def as_dict(self) -> dict[str, Any]:
        out = {"best_s": self.best, "median_s": self.median, "times_s": list(self.times)}
        if self.switched:
            out.update(switched_median_s=self.switched_median, switched_s=list(self.switched))
        return out


def time_calls(fns: Sequence[Callable[[], Any]], *, repeat: int, warmup: int = 1,
               block: int = 1) -> list[tuple[Timing, Any]]:
    """Time several calls against each other, interleaved.

    Each function gets ``warmup`` untimed calls, then round ``k`` of
    ``repeat`` calls every function once in turn, so a change of machine
    load during the measurement affects all of them alike and their ratio
    stays fair.

    With ``block > 1`` each round calls every function ``block`` times in a
    row: the first call of a block is recorded as *switched* (it runs right
    after another implementation, with cold caches), the others as warm
    (``Timing.times``). A call of a millisecond pays a large share for
    coming second; the warm median is its steady state, the switched one
    what a caller alternating between libraries sees.

    Returns
    -------
    list of (Timing, value)
        Per function, its timings and the value of its last call, so a
        benchmark can check the accuracy of exactly what it timed.
    """
    if repeat < 1 or block < 1:
        raise ValueError(f"repeat and block must be at least 1 (got {repeat!r}, {block!r})")
    values: list[Any] = [None] * len(fns)
    times: list[list[float]] = [[] for _ in fns]
    switched: list[list[float]] = [[] for _ in fns]
    for i, fn in enumerate(fns):
        for _ in range(warmup):
            values[i] = fn()
    for _ in range(repeat):
        for i, fn in enumerate(fns):
            for b in range(block):
                start = time.perf_counter()
                values[i] = fn()
                elapsed = time.perf_counter() - start
                (switched[i] if block > 1 and b == 0 else times[i]).append(elapsed)
    return [(Timing(tuple(t), tuple(s)), v)
            for t, s, v in zip(times, switched, values, strict=True)]


def time_call(fn: Callable[[], T], *, repeat: int, warmup: int = 1) -> tuple[Timing, T]:
    """Time ``fn()``: ``warmup`` untimed calls, then ``repeat`` timed ones."""
    return time_calls([fn], repeat=repeat, warmup=warmup)[0]


@dataclass
class Report:
    """What one benchmark module hands back: printable tables and raw records.

    Attributes
    ----------
    name : str
        Short identifier (the module name), the key in the JSON file.
    title : str
        One line saying what is compared.
    tables : list of (title, headers, rows)
        Tables to print; cells are already formatted strings.
    records : list of dict
        Raw numbers of every configuration, written by ``--json``.
    notes : list of str
        Lines printed under the tables (how to read them).
    """

    name: str
    title: str
    tables: list[tuple[str, Sequence[str], list[Sequence[str]]]] = field(default_factory=list)
    records: list[dict[str, Any]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        return {"title": self.title, "records": self.records, "notes": self.notes}


def format_table(headers: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """A plain-text table; the first column left-aligned, the others right-aligned.

    Examples
    --------
    >>> print(format_table(["method", "ms"], [["RK45", "1.5"], ["DOP853", "12.0"]]))
    method    ms
    ------  ----
    RK45     1.5
    DOP853  12.0
    """
    widths = [max(len(str(c)) for c in col) for col in zip(headers, *rows, strict=True)]

    def line(cells: Sequence[str]) -> str:
        parts = [str(c).ljust(w) if i == 0 else str(c).rjust(w)
                 for i, (c, w) in enumerate(zip(cells, widths, strict=True))]
        return "  ".join(parts).rstrip()

    return "\n".join([line(headers), line(["-" * w for w in widths]), *map(line, rows)])


def print_report(report: Report) -> None:
    """Print the title, every table and the notes of ``report``."""
    print(f"== {report.name}: {report.title}")
    for title, headers, rows in report.tables:
        print()
        print(title)
        print(format_table(headers, rows))
    if report.notes:
        print()
        for note in report.notes:
            print(note)
    print()


def machine_info() -> dict[str, Any]:
    """Where and when the numbers were measured."""
    import numpy
    import scipy

    import hybridlab

    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as fh:
            names = [ln.split(":", 1)[1].strip() for ln in fh if ln.startswith("model name")]
        if names:
            cpu = names[0]
    except OSError:
        pass
    return {
        "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "platform": platform.platform(),
        "cpu": cpu,
        "cpu_count": os.cpu_count(),
        "python": platform.python_version(),
        "numpy": numpy.__version__,
        "scipy": scipy.__version__,
        "hybridlab": hybridlab.__version__,
    }


def write_json(path: str | Path, reports: Sequence[Report]) -> None:
    """Write the machine description and the records of ``reports`` to ``path``."""
    payload = {"machine": machine_info(),
               "benchmarks": {r.name: r.as_dict() for r in reports}}
    Path(path).write_text(json.dumps(payload, indent=1) + "\n")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options every benchmark script accepts."""
    parser.add_argument("--quick", action="store_true",
                        help=f"{QUICK_REPEAT} timed repetitions instead of {DEFAULT_REPEAT}")
    parser.add_argument("--repeat", type=int, default=None,
                        help="timed repetitions per configuration (overrides --quick)")
    parser.add_argument("--json", metavar="FILE", default=None,
                        help="also write the raw numbers and the machine description to FILE")


def repeat_count(args: argparse.Namespace) -> int:
    """Timed repetitions requested on the command line."""
    if args.repeat is not None:
        if args.repeat < 1:
            raise SystemExit(f"--repeat must be at least 1 (got {args.repeat})")
        return args.repeat
    return QUICK_REPEAT if args.quick else DEFAULT_REPEAT


def run_main(run: Callable[[int], Report], description: str,
             argv: Sequence[str] | None = None) -> int:
    """The command line every single-benchmark script shares: ``[--quick] [--repeat N]
    [--json FILE]``; runs ``run(repeat)``, prints the report and optionally writes JSON."""
    parser = argparse.ArgumentParser(description=description)
    add_arguments(parser)
    args = parser.parse_args(argv)
    report = run(repeat_count(args))
    print_report(report)
    if args.json:
        write_json(args.json, [report])
    return 0
