"""``hybridlab simulate MODEL``: one run, its status, events and final state (exit 3 if early)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from hybridlab.cli._args import (
    EXIT_INCOMPLETE,
    EXIT_INTERRUPTED,
    EXIT_OK,
    UsageError,
    assignments,
    require_finite,
)
from hybridlab.cli._commands import HELP
from hybridlab.simulation.options import METHODS

__all__ = ["add_parser"]


def _run(args: argparse.Namespace) -> int:
    from hybridlab._text import printable
    from hybridlab.model.loader import load_model
    from hybridlab.simulation.api import simulate
    from hybridlab.simulation.result import Status

    # check every argument before the (possibly long) simulation runs
    for option in ("t_end", "rtol", "atol", "max_step", "time_limit", "dt"):
        require_finite(getattr(args, option), "--" + option.replace("_", "-"), error=UsageError)
    params = assignments(args.set, "--set")
    initial = assignments(args.init, "--init", booleans=True)
    out = Path(args.out) if args.out else None
    if out is not None and out.suffix.lower() not in (".json", ".csv", ".npz"):
        raise UsageError(f"--out must end in .json, .csv or .npz (got {args.out!r})")
    if args.dt is not None and (out is None or out.suffix.lower() != ".csv"):
        raise UsageError("--dt samples the --out CSV file on a uniform grid: it needs "
                         "--out FILE.csv")
    if args.dt is not None and not args.dt > 0:
        raise UsageError(f"--dt must be a positive number (got {args.dt!r})")
    model = load_model(args.model)
    kwargs = {}
    if args.zeno:
        kwargs["zeno"] = args.zeno
    if args.backend:
        kwargs["backend"] = args.backend
    for option in ("max_steps", "time_limit"):
        if getattr(args, option) is not None:
            kwargs[option] = getattr(args, option)
    result = simulate(
        model, args.t_end, scenario=args.scenario, params=params, initial=initial,
        mode=args.mode, rtol=args.rtol, atol=args.atol, method=args.method,
        max_step=args.max_step, **kwargs,
    )
    if out is not None:
        try:
            result.save(out, dt=args.dt)
        except ValueError as exc:  # a grid too fine for the run's length
            raise UsageError(f"--dt: {exc}") from None
    jumps = len(result.jumps)
    print(f"status: {result.status.name}: {printable(result.message)}")
    print(f"events: {len(result.events)} ({jumps} jumps)")
    final = result.final
    state = ", ".join(f"{k}={v:.10g}" for k, v in final.state.items())
    print(f"final: t={final.t:.10g} j={final.j} mode={printable(final.mode)} {state}")
    if result.zeno_time is not None:
        print(f"zeno_time: {result.zeno_time:.12g}")
    if args.out:
        print(f"wrote {args.out}")
    if result.status is Status.INTERRUPTED:
        return EXIT_INTERRUPTED
    return EXIT_OK if result.status.ok else EXIT_INCOMPLETE


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Add ``simulate`` to the subparsers ``sub`` of the main command line; its parser.

    Examples
    --------
    >>> from hybridlab.cli._args import Parser
    >>> parser = Parser(prog="hybridlab")
    >>> _ = add_parser(parser.add_subparsers(dest="command", parser_class=Parser))
    >>> args = parser.parse_args(["simulate", "models/bouncing_ball.toml", "--t-end", "2",
    ...                           "--set", "e=0.5", "--backend", "reference"])
    >>> args.model, args.t_end, args.set, args.backend, args.zeno
    ('models/bouncing_ball.toml', 2.0, ['e=0.5'], 'reference', None)
    """
    p: argparse.ArgumentParser = sub.add_parser("simulate", help=HELP["simulate"])
    p.add_argument("model")
    p.add_argument("--scenario")
    p.add_argument("--t-end", type=float, dest="t_end")
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help="parameter override")
    p.add_argument("--init", action="append", metavar="NAME=VALUE",
                   help="initial state override")
    p.add_argument("--mode", help="initial mode")
    p.add_argument("--rtol", type=float)
    p.add_argument("--atol", type=float)
    p.add_argument("--method", choices=METHODS)
    p.add_argument("--max-step", type=float, dest="max_step")
    p.add_argument("--zeno", choices=("stop", "error"))
    p.add_argument("--max-steps", type=int, dest="max_steps",
                   help="integrator steps before stopping with STEP_LIMIT (default 10000000)")
    p.add_argument("--time-limit", type=float, dest="time_limit", metavar="SECONDS",
                   help="wall-clock seconds before stopping with TIME_LIMIT")
    p.add_argument("--backend", choices=("auto", "compiled", "reference"),
                   help="simulation backend (default: compiled when numba is installed)")
    p.add_argument("--out", help="write the result (.json, .csv or .npz)")
    p.add_argument("--dt", type=float, metavar="STEP",
                   help="with --out FILE.csv: write the states on a uniform grid of this step "
                        "(post-jump values at a jump instant) instead of the solver's points")
    p.set_defaults(run=_run)
    return p
