"""``hybridlab flatten MODEL -o OUT``: a model built from components as one flat file."""

from __future__ import annotations

import argparse
from typing import Any

from hybridlab.cli._args import emit
from hybridlab.cli._commands import HELP

__all__ = ["add_parser"]


def _run(args: argparse.Namespace) -> int:
    from hybridlab.model.loader import dumps_model, load_model

    model = load_model(args.model)
    text = dumps_model(model)
    return emit(text, args.out, f": {len(model.states)} states, {len(model.modes)} modes, "
                                f"{len(model.transitions)} transitions")


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Add ``flatten`` to the subparsers ``sub`` of the main command line; its parser.

    Examples
    --------
    >>> from hybridlab.cli._args import Parser
    >>> parser = Parser(prog="hybridlab")
    >>> _ = add_parser(parser.add_subparsers(dest="command", parser_class=Parser))
    >>> args = parser.parse_args(["flatten", "models/two_rooms.toml", "-o", "flat.toml"])
    >>> args.command, args.model, args.out
    ('flatten', 'models/two_rooms.toml', 'flat.toml')
    """
    p: argparse.ArgumentParser = sub.add_parser("flatten", help=HELP["flatten"])
    p.add_argument("model")
    p.add_argument("-o", "--out", help="the file to write (default: print the model)")
    p.set_defaults(run=_run)
    return p
