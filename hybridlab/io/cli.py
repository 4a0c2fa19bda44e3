"""The ``import`` subcommand, ready to be attached to the main command line.

``add_import_parser(subparsers)`` adds::

    import spaceex MODEL.xml [--cfg FILE.cfg] [--system ID] [-o model.toml]

It prints the imported model as TOML (headed by comments giving the initial set, the
forbidden set and the horizon from the ``.cfg``) or writes it to ``-o``. User errors
are raised as hybridlab errors (``ValueError``) for the caller to print in one line.
"""

from __future__ import annotations

import argparse

from hybridlab._files import replace_text
from hybridlab._text import printable
from hybridlab.io.spaceex import ConstraintSet, SpaceExProblem, load_spaceex
from hybridlab.model.loader import dumps_model

__all__ = ["add_import_parser", "problem_header"]


def problem_header(problem: SpaceExProblem) -> str:
    """TOML comment lines describing what the model file cannot hold (initial set, ...).

    Examples
    --------
    >>> p = load_spaceex("models/spaceex/bouncing_ball.xml",
    ...                  "models/spaceex/bouncing_ball.cfg")
    >>> print(problem_header(p))
    # imported from models/spaceex/bouncing_ball.xml, models/spaceex/bouncing_ball.cfg
    # initial set: x in [10, 10.2], v in [0, 0]; modes: always
    # forbidden: x >= 10.25
    # time horizon 20, sampling time 0.05, max jumps 10
    """
    lines = [f"# imported from {', '.join(problem.source)}"]
    if isinstance(problem.initial, ConstraintSet):
        init = " and ".join(problem.initial.relations)
    else:
        init = ", ".join(f"{k} in [{lo:g}, {hi:g}]" for k, (lo, hi) in problem.initial.items())
    lines.append(f"# initial set: {init}; modes: {', '.join(problem.initial_modes)}")
    for name, value in problem.params.items():
        if isinstance(value, tuple):
            lines.append(f"# uncertain constant: {name} in [{value[0]:g}, {value[1]:g}]")
    for name, (lo, hi) in problem.inputs.items():
        lines.append(f"# input (varies in time): {name} in [{lo:g}, {hi:g}]")
    for f in problem.forbidden:
        where = f" in modes {', '.join(sorted(f.modes))}" if f.modes is not None else ""
        lines.append(f"# forbidden: {' and '.join(f.relations) or 'everything'}{where}")
    opts = problem.options
    parts = []
    if problem.t_end is not None:
        parts.append(f"time horizon {problem.t_end:g}")
    if opts.time_step is not None:
        parts.append(f"sampling time {opts.time_step:g}")
    if opts.max_jumps is not None:
        parts.append(f"max jumps {opts.max_jumps}")
    if parts:
        lines.append("# " + ", ".join(parts))
    for old, new in problem.renamed.items():
        lines.append(f"# renamed: {old} -> {new}")
    # names and relations come from the XML: none may end a comment line early
    return "\n".join("# " + printable(line[2:]) for line in lines)


def _run_spaceex(args: argparse.Namespace) -> int:
    problem = load_spaceex(args.model, args.cfg, system=args.system)
    text = problem_header(problem) + "\n" + dumps_model(problem.model)
    if args.out:
        replace_text(args.out, text)
        print(f"wrote {args.out}")
    else:
        print(text, end="")
    return 0


def add_import_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Attach ``import spaceex`` to the subparsers ``sub`` of the main command line."""
    imp = sub.add_parser("import", help="convert a model from another format to TOML")
    formats = imp.add_subparsers(dest="format", required=True,
                                 parser_class=type(imp))
    sx = formats.add_parser("spaceex", help="a SpaceEx XML model (and its .cfg)")
    sx.add_argument("model", help="the SpaceEx model file (.xml)")
    sx.add_argument("--cfg", help="the SpaceEx configuration file (.cfg)")
    sx.add_argument("--system", help="the component to import (default: the .cfg's "
                                     "'system', else the component nobody binds)")
    sx.add_argument("-o", "--out", help="write the TOML model to this file")
    sx.set_defaults(run=_run_spaceex)
