"""``hybridlab schema``: the JSON schema of model files."""

from __future__ import annotations

import argparse
import json
from typing import Any

from hybridlab.cli._args import emit
from hybridlab.cli._commands import HELP

__all__ = ["add_parser"]


def _run(args: argparse.Namespace) -> int:
    from hybridlab.model.loader import model_json_schema

    text = json.dumps(model_json_schema(), indent=2) + "\n"
    return emit(text, args.out, None)


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Add ``schema`` to the subparsers ``sub`` of the main command line; its parser.

    Examples
    --------
    >>> from hybridlab.cli._args import Parser
    >>> parser = Parser(prog="hybridlab")
    >>> _ = add_parser(parser.add_subparsers(dest="command", parser_class=Parser))
    >>> args = parser.parse_args(["schema", "--out", "model.schema.json"])
    >>> args.command, args.out
    ('schema', 'model.schema.json')
    """
    p: argparse.ArgumentParser = sub.add_parser("schema", help=HELP["schema"])
    p.add_argument("--out")
    p.set_defaults(run=_run)
    return p
