"""``hybridlab import``: convert a model from another format to TOML.

``add_parser(subparsers)`` adds::

    import spaceex MODEL.xml [--cfg FILE.cfg] [--system ID] [--flat] [-o model.toml]

It prints the imported model as TOML (headed by comments giving the initial set, the
forbidden set and the horizon from the ``.cfg``) or writes it to ``-o``: a network of
several automata as components (templates, instances, connections, labels), or with
``--flat`` as their product. User errors
are raised as hybridlab errors (``ValueError``) for the caller to print in one line.
"""

from __future__ import annotations

import argparse
from typing import Any

from hybridlab.cli._args import emit
from hybridlab.cli._commands import HELP

__all__ = ["add_parser"]


def _run_spaceex(args: argparse.Namespace) -> int:
    from hybridlab.io import load_spaceex, problem_header, spaceex_components
    from hybridlab.model.loader import dumps_model

    if args.flat:
        problem = load_spaceex(args.model, args.cfg, system=args.system)
        text = problem_header(problem) + "\n" + dumps_model(problem.model)
    else:
        text = spaceex_components(args.model, args.cfg, system=args.system).text()
    return emit(text, args.out)


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Add ``import spaceex`` to the subparsers ``sub`` of the main command line; its parser.

    Examples
    --------
    >>> from hybridlab.cli._args import Parser
    >>> parser = Parser(prog="hybridlab")
    >>> _ = add_parser(parser.add_subparsers(dest="command", parser_class=Parser))
    >>> args = parser.parse_args(["import", "spaceex", "models/spaceex/bouncing_ball.xml",
    ...                           "--cfg", "models/spaceex/bouncing_ball.cfg", "-o", "ball.toml"])
    >>> args.format, args.model, args.cfg, args.system, args.flat, args.out
    ('spaceex', 'models/spaceex/bouncing_ball.xml', 'models/spaceex/bouncing_ball.cfg', None,
     False, 'ball.toml')
    """
    imp: argparse.ArgumentParser = sub.add_parser("import", help=HELP["import"])
    formats = imp.add_subparsers(dest="format", required=True,
                                 parser_class=type(imp))
    sx = formats.add_parser("spaceex", help="a SpaceEx XML model (and its .cfg)")
    sx.add_argument("model", help="the SpaceEx model file (.xml)")
    sx.add_argument("--cfg", help="the SpaceEx configuration file (.cfg)")
    sx.add_argument("--system", help="the component to import (default: the .cfg's "
                                     "'system', else the component nobody binds)")
    sx.add_argument("--flat", action="store_true",
                    help="write the product of the network's automata, not its components")
    sx.add_argument("-o", "--out", help="write the TOML model to this file")
    sx.set_defaults(run=_run_spaceex)
    return imp
