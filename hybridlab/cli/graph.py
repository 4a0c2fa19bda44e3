"""``hybridlab graph MODEL``: the mode graph in Graphviz DOT, or its check (exit 4 on findings)."""

from __future__ import annotations

import argparse
from typing import Any

from hybridlab.cli._args import EXIT_FINDINGS, EXIT_OK, UsageError, emit
from hybridlab.cli._commands import HELP

__all__ = ["add_parser"]


def _run(args: argparse.Namespace) -> int:
    from hybridlab.model.loader import load_model

    if args.max_cycle_length < 1:
        raise UsageError(f"--max-cycle-length must be at least 1 (got {args.max_cycle_length})")
    model = load_model(args.model)
    if args.check:  # the checks' LP solver (scipy) loads only here
        from hybridlab.graph import check_mode_graph

        report = check_mode_graph(model, scenarios=args.scenario,
                                  max_cycle_length=args.max_cycle_length)
        print(report)
        return EXIT_OK if report.ok else EXIT_FINDINGS
    from hybridlab.graph import to_dot

    text = to_dot(model)
    return emit(text, args.out)


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Add ``graph`` to the subparsers ``sub`` of the main command line; its parser.

    Examples
    --------
    >>> from hybridlab.cli._args import Parser
    >>> parser = Parser(prog="hybridlab")
    >>> _ = add_parser(parser.add_subparsers(dest="command", parser_class=Parser))
    >>> args = parser.parse_args(["graph", "models/thermostat.toml", "--check"])
    >>> args.model, args.check, args.scenario, args.max_cycle_length
    ('models/thermostat.toml', True, None, 8)
    """
    p: argparse.ArgumentParser = sub.add_parser("graph", help=HELP["graph"])
    p.add_argument("model")
    p.add_argument("--out", help="write the DOT text to this file")
    p.add_argument("--check", action="store_true",
                   help="report dead modes, guards that never hold, zero-dwell cycles; "
                        "exit 4 on a warning or an error")
    p.add_argument("--scenario", action="append", metavar="NAME",
                   help="with --check: check only this scenario's parameters (repeatable)")
    p.add_argument("--max-cycle-length", type=int, default=8, dest="max_cycle_length",
                   help="with --check: longest cycle examined (default 8)")
    p.set_defaults(run=_run)
    return p
