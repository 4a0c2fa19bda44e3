"""``hybridlab sweep``: many runs over a grid, one CSV row per run.

``add_parser(subparsers)`` adds::

    sweep MODEL --grid NAME=LO:HI:N [--grid NAME=V1,V2,...] [--value NAME=V ...]
          [--scenario S] [--t-end T] [--observe NAME=[REDUCTION:]EXPR ...]
          [--count [COLUMN=]TR[,TR...][@AFTER] ...] [--workers N] --out FILE.csv

The command returns 0 when every run completed and 3 when some run ended
early (its status, or ``ERROR``, is in the table); user errors are raised as
``ValueError`` (:class:`SweepError`) for the caller to print as one line
(exit code 2).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING, Any

from hybridlab.cli._args import (
    EXIT_INCOMPLETE,
    EXIT_INTERRUPTED,
    EXIT_OK,
    finite_number,
    split_assignment,
)
from hybridlab.cli._commands import HELP
from hybridlab.ensemble.errors import SweepError
from hybridlab.simulation.options import METHODS

if TYPE_CHECKING:
    from hybridlab.ensemble.observables import Count, Observable

__all__ = ["add_parser", "parse_count", "parse_grid", "parse_observe"]


def _split(item: str, option: str) -> tuple[str, str]:
    name, value = split_assignment(item, option, require_value=True, error=SweepError)
    return name, value.strip()


def _float(text: str, where: str) -> float:
    return finite_number(text, where, error=SweepError)


def parse_grid(items: list[str] | None) -> dict[str, list[float]]:
    """``NAME=LO:HI:N`` (N evenly spaced values, ends included) or ``NAME=V1,V2,...``.

    Examples
    --------
    >>> parse_grid(["a=0:1:3", "b=5,7"])
    {'a': [0.0, 0.5, 1.0], 'b': [5.0, 7.0]}
    >>> parse_grid(["a=0:1"])
    Traceback (most recent call last):
    ...
    hybridlab.ensemble.errors.SweepError: --grid a: expected LO:HI:N or V1,V2,... (got '0:1')
    """
    import numpy as np

    from hybridlab.ensemble.spec import check_run_count

    grid: dict[str, list[float]] = {}
    for item in items or ():
        name, spec = _split(item, "--grid")
        if name in grid:
            raise SweepError(f"--grid {name}: given twice")
        if ":" in spec:
            parts = spec.split(":")
            if len(parts) != 3:
                raise SweepError(f"--grid {name}: expected LO:HI:N or V1,V2,... (got {spec!r})")
            lo, hi = (_float(p, f"--grid {name}") for p in parts[:2])
            try:
                n = int(parts[2])
            except ValueError:
                n = 0
            if n < 1:
                raise SweepError(f"--grid {name}: N must be a positive integer "
                                 f"(got {parts[2]!r})")
            check_run_count(n, f"--grid {name}")
            grid[name] = [float(v) for v in np.linspace(lo, hi, n)]
        else:
            grid[name] = [_float(p, f"--grid {name}") for p in spec.split(",")]
    return grid


def parse_observe(items: list[str] | None) -> dict[str, Observable]:
    """``NAME=EXPR`` (final value), ``NAME=min:EXPR``, ``NAME=max:EXPR``, ``NAME=at@T:EXPR``.

    Examples
    --------
    >>> obs = parse_observe(["peak=max:abs(v)", "h_end=h", "h2=at@2.5:h"])
    >>> [(o.reduction, o.expression, o.time) for o in obs.values()]
    [('max', 'abs(v)', None), ('final', 'h', None), ('at', 'h', 2.5)]
    """
    from hybridlab.ensemble.observables import Observable

    out: dict[str, Observable] = {}
    for item in items or ():
        name, spec = _split(item, "--observe")
        reduction, sep, expr = spec.partition(":")
        if not sep:
            out[name] = Observable(name, spec)
        elif reduction.startswith("at@"):
            out[name] = Observable(name, expr.strip(), "at",
                                   _float(reduction[3:], f"--observe {name}"))
        else:
            out[name] = Observable(name, expr.strip(), reduction.strip())
    return out


def parse_count(item: str) -> Count:
    """``TR``, ``TR1,TR2``, ``TR1,TR2@AFTER``, optionally ``COLUMN=`` in front.

    Examples
    --------
    >>> parse_count("residual=s1_on,s1_off@arrive")
    Count(transitions=('s1_on', 's1_off'), after='arrive', name='residual')
    >>> parse_count("bounce").column
    'count:bounce'
    """
    from hybridlab.ensemble.observables import Count

    name, sep, spec = item.partition("=")
    if not sep:
        name, spec = "", item
    spec, _, after = spec.partition("@")
    transitions = tuple(t.strip() for t in spec.split(",") if t.strip())
    if not transitions:
        raise SweepError(f"--count expects [COLUMN=]TR[,TR...][@AFTER] (got {item!r})")
    return Count(transitions, after=after.strip() or None, name=name.strip() or None)


def _run(args: argparse.Namespace) -> int:
    from hybridlab.ensemble.api import sweep
    from hybridlab.model.loader import load_model

    out = Path(args.out)
    if out.suffix.lower() != ".csv":
        raise SweepError(f"--out must end in .csv (got {args.out!r})")
    if args.t_end is not None:
        _float(str(args.t_end), "--t-end")
    grid = parse_grid(args.grid)
    if not grid:
        raise SweepError("give at least one --grid NAME=LO:HI:N")
    fixed: dict[str, float] = {}
    for item in args.value or ():
        name, value = _split(item, "--value")
        fixed[name] = _float(value, f"--value {name}")
    if args.time_limit is not None:
        _float(str(args.time_limit), "--time-limit")
    options: dict[str, Any] = {k: getattr(args, k) for k in ("method", "rtol", "atol", "max_step",
                                                             "max_steps", "time_limit")
                               if getattr(args, k) is not None}
    if args.backend:
        options["backend"] = args.backend
    if args.workers is not None and args.workers < 1:
        raise SweepError(f"--workers must be at least 1 (got {args.workers})")
    model = load_model(args.model)
    params = {n: v for n, v in fixed.items() if n in model.parameters}
    initial = {n: v for n, v in fixed.items() if n not in model.parameters}
    table = sweep(model, grid=grid, params=params, initial=initial, scenario=args.scenario,
                  t_end=args.t_end, observe=parse_observe(args.observe),
                  events=[parse_count(c) for c in args.count or ()], executor=args.workers,
                  progress=args.progress, **options)
    table.to_csv(out)
    failed = table.failed
    print(f"{len(table)} runs, {len(table) - len(failed)} completed, {len(failed)} not "
          f"({table.elapsed:.3g} s, {table.executor})")
    status, error = table.column("status"), table.column("error")
    for k in failed[:5]:
        print(f"  run {k}: {status[k]}{': ' + error[k] if error[k] else ''}")
    if len(failed) > 5:
        print(f"  ... and {len(failed) - 5} more (see the status column)")
    print(f"wrote {args.out}")
    if table.interrupted:
        print("interrupted (Ctrl-C): the runs that had not finished have status INTERRUPTED")
        return EXIT_INTERRUPTED
    return EXIT_OK if not failed else EXIT_INCOMPLETE


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``sweep`` to an argparse ``subparsers`` object.

    Examples
    --------
    >>> parser = argparse.ArgumentParser(prog="hybridlab")
    >>> _ = add_parser(parser.add_subparsers(dest="command"))
    >>> args = parser.parse_args(["sweep", "ball.toml", "--grid", "e=0.5:0.9:5",
    ...                           "--out", "table.csv"])
    >>> args.run.__name__, args.grid
    ('_run', ['e=0.5:0.9:5'])
    """
    p: argparse.ArgumentParser = subparsers.add_parser(
        "sweep", help=HELP["sweep"],
        description="Simulate a model over a full-factorial grid of parameters and initial "
                    "states, in parallel, and write one CSV row per run (docs/sweeps.md).")
    p.add_argument("model")
    p.add_argument("--grid", action="append", metavar="NAME=LO:HI:N",
                   help="a swept parameter or state: N values from LO to HI, or V1,V2,...")
    p.add_argument("--value", action="append", metavar="NAME=V",
                   help="a fixed parameter or initial state for every run")
    p.add_argument("--scenario")
    p.add_argument("--t-end", type=float, dest="t_end")
    p.add_argument("--observe", action="append", metavar="NAME=[REDUCTION:]EXPR",
                   help="a column: EXPR at the end, or min:EXPR, max:EXPR, at@T:EXPR")
    p.add_argument("--count", action="append", metavar="[COLUMN=]TR[,TR...][@AFTER]",
                   help="a column counting jumps of transitions (only after AFTER first fired)")
    p.add_argument("--workers", type=int,
                   help="parallel worker processes (1: serial; default: every core)")
    p.add_argument("--method", choices=METHODS)
    p.add_argument("--rtol", type=float)
    p.add_argument("--atol", type=float)
    p.add_argument("--max-step", type=float, dest="max_step")
    p.add_argument("--max-steps", type=int, dest="max_steps",
                   help="integrator steps per run before it stops with STEP_LIMIT")
    p.add_argument("--time-limit", type=float, dest="time_limit", metavar="SECONDS",
                   help="wall-clock seconds per run before it stops with TIME_LIMIT")
    p.add_argument("--backend", help="simulation backend, passed to simulate")
    p.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="progress bar on stderr (default: when stderr is a terminal, not in CI)")
    p.add_argument("--out", required=True, metavar="FILE.csv", help="the table")
    p.set_defaults(run=_run)
    return p
