"""The ``hybridlab`` command line: one module per command.

Exit codes: 0 success; 2 user error (bad model, file or argument: one line on
stderr, no traceback); 3 a simulation that ended before ``t_end`` (its status
says why); 4 ``graph --check`` reported a warning or an error; 1 an internal
error.

Every command module holds ``add_parser(subparsers)``, which defines its
arguments, and the function that runs it; it imports numpy, scipy, sympy and
the engines inside that function. Only the module of the command being run is
imported: the others are listed by name and help line
(:mod:`hybridlab.cli._commands`), so ``hybridlab --help`` and a command's
``--help`` load none of the numerical libraries.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Sequence

from hybridlab._lazy import lazy_exports
from hybridlab.cli._args import (
    EXIT_BUG,
    EXIT_INCOMPLETE,
    EXIT_INTERNAL,
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_USAGE,
    Parser,
    UsageError,
)
from hybridlab.cli._commands import COMMANDS, command_of
from hybridlab.errors import HybridlabError, ModelError, SimulationError

__all__ = ["EXIT_BUG", "EXIT_INTERRUPTED", "main"]

# the command modules load on first access too (hybridlab.cli.check)
__getattr__, __dir__ = lazy_exports(__name__, __file__)


def _parser(argv: Sequence[str]) -> Parser:
    """The parser of ``argv``: every command listed, only the one ``argv`` runs defined.

    Examples
    --------
    >>> parser = _parser(["check", "models/thermostat.toml"])
    >>> parser.parse_args(["check", "models/thermostat.toml"]).run.__module__
    'hybridlab.cli.check'
    >>> parser.parse_args(["simulate", "models/thermostat.toml"])  # listed, options not loaded
    Traceback (most recent call last):
    ...
    hybridlab.cli._args.UsageError: unrecognized arguments: models/thermostat.toml
    """
    running = command_of(argv)
    parser = Parser(prog="hybridlab", description="Model, simulate and verify hybrid automata.")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    for command in COMMANDS:
        if command is running:
            importlib.import_module(command.module).add_parser(sub)
        else:  # named in the listing only; its options load when it runs
            sub.add_parser(command.name, help=command.help)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code.

    Examples
    --------
    >>> main(["check", "models/bouncing_ball.toml"])  # doctest: +ELLIPSIS
    model 'bouncing_ball': OK
    ...
    0
    """
    try:
        if argv is None:
            argv = sys.argv[1:]
        args = _parser(argv).parse_args(argv)
        return int(args.run(args))
    except SystemExit as exc:  # argparse's own exits: --help, --version
        code = exc.code
        if code is None:
            return EXIT_OK
        if isinstance(code, int):
            return code
        print(code, file=sys.stderr)
        return EXIT_INTERNAL
    except SimulationError as exc:  # the run could not go on (e.g. --zeno error): not a user error
        text = " ".join(str(exc).split())
        print(f"hybridlab: error: {text}", file=sys.stderr)
        return EXIT_INCOMPLETE
    except (UsageError, ModelError, ValueError, TypeError, OSError, HybridlabError) as exc:
        text = " ".join(str(exc).split())
        print(f"hybridlab: error: {text}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("hybridlab: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as exc:  # noqa: BLE001 - one line and a report, never a traceback
        report = _write_report(argv)
        where = f"the full report is in {report}" if report else "no report could be written"
        print(f"hybridlab: internal error ({type(exc).__name__}); please report it: {where}",
              file=sys.stderr)
        return EXIT_BUG


def _write_report(argv: Sequence[str] | None) -> str | None:
    """Write the traceback of the exception being handled to a new file; its path."""
    import os  # only an internal error needs these
    import tempfile
    import traceback

    try:
        fd, path = tempfile.mkstemp(prefix="hybridlab-report-", suffix=".txt")
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(f"hybridlab {sys.argv[1:] if argv is None else list(argv)!r}\n\n")
            fh.write(traceback.format_exc())
    except OSError:
        return None
    return path
